//! The frames of an animation, kept from a run's samples at the display rate.

use lieflow::scene::Sample;
use lieflow::scene::sketch::Sketch;

/// How many frames a page keeps: at most `max_frames`, and at most `max_bytes` of position
/// data (`12` bytes a slot a frame, base64 adds a third in the page). The frames are spread
/// evenly over the run's time; each is the first step at or after its time.
///
/// The default keeps 1000 frames and 12 MB of positions, so a page stays under 20 MB: a
/// 1000-body chain over any number of steps keeps 1000 frames (12 MB, a 17 MB page).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameBudget {
    /// The most frames.
    pub max_frames: usize,
    /// The most bytes of positions.
    pub max_bytes: usize,
}

impl Default for FrameBudget {
    fn default() -> Self {
        Self {
            max_frames: 1000,
            max_bytes: 12_000_000,
        }
    }
}

/// Why a run cannot be animated.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum RecorderError {
    /// A built-in model has no scene of bodies to draw.
    NoBodies,
    /// A traced body the scene does not have (its name).
    UnknownBody(String),
    /// A budget that keeps fewer than two frames.
    Budget(String),
}

impl std::fmt::Display for RecorderError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::NoBodies => write!(
                f,
                "a built-in model has no bodies to draw: animate a scene of bodies"
            ),
            Self::UnknownBody(name) => write!(
                f,
                "no body named '{name}' to trace (a body's name, or '<generator>.<i>')"
            ),
            Self::Budget(why) => write!(f, "{why}"),
        }
    }
}

impl std::error::Error for RecorderError {}

/// Keeps the frames of a run (see the crate docs): call [`observe`](Self::observe) with every
/// sample of the run and [`finish`](Self::finish) with the last.
#[derive(Debug, Clone)]
pub struct Recorder {
    pub(crate) sketch: Sketch,
    /// Slots in the state (`q` holds `slots × dim` positions).
    pub(crate) slots: usize,
    pub(crate) traces: Vec<usize>,
    pub(crate) output_names: Vec<String>,
    t0: f64,
    span: f64,
    planned: usize,
    next: usize,
    pub(crate) times: Vec<f64>,
    pub(crate) steps: Vec<usize>,
    pub(crate) positions: Vec<f32>,
    pub(crate) outputs: Vec<f32>,
    pub(crate) energy: Vec<f64>,
    /// The latest sample seen, when it was not kept.
    latest: Option<Latest>,
}

/// A copy of the latest sample (its buffers reused from sample to sample).
#[derive(Debug, Clone, Default)]
struct Latest {
    step: usize,
    t: f64,
    energy: Option<f64>,
    x: Vec<f64>,
    outputs: Vec<f64>,
}

impl Recorder {
    /// A recorder of a run of the scene `sketch` from `t0` to `t_end` whose states have
    /// `state_len` entries and whose samples carry `output_names`; `traces` names the bodies
    /// whose paths are drawn (empty: the last body of each generator, or every body of a scene
    /// of at most four).
    ///
    /// # Errors
    /// [`RecorderError::NoBodies`] without a sketch (a built-in model),
    /// [`RecorderError::UnknownBody`] for a traced name the scene does not have,
    /// [`RecorderError::Budget`] for a budget of fewer than two frames.
    pub fn new(
        sketch: Option<&Sketch>,
        state_len: usize,
        output_names: Vec<String>,
        (t0, t_end): (f64, f64),
        traces: &[String],
        budget: FrameBudget,
    ) -> Result<Self, RecorderError> {
        let sketch = sketch.ok_or(RecorderError::NoBodies)?;
        let slots = state_len / 2 / sketch.dim.max(1);
        let by_bytes = budget.max_bytes / (12 * slots.max(1));
        let planned = budget.max_frames.min(by_bytes);
        if planned < 2 {
            return Err(RecorderError::Budget(format!(
                "a budget of {} frames and {} bytes keeps fewer than two frames of {slots} bodies ({} bytes a frame)",
                budget.max_frames,
                budget.max_bytes,
                12 * slots
            )));
        }
        let traces = if traces.is_empty() {
            default_traces(sketch)
        } else {
            traces
                .iter()
                .map(|name| {
                    sketch
                        .bodies
                        .iter()
                        .position(|b| &b.name == name)
                        .ok_or_else(|| RecorderError::UnknownBody(name.clone()))
                })
                .collect::<Result<_, _>>()?
        };
        Ok(Self {
            sketch: sketch.clone(),
            slots,
            traces,
            output_names,
            t0,
            span: (t_end - t0).max(0.0),
            planned,
            next: 0,
            times: Vec::new(),
            steps: Vec::new(),
            positions: Vec::new(),
            outputs: Vec::new(),
            energy: Vec::new(),
            latest: None,
        })
    }

    /// Keeps sample `s` if it is the first at or after the next frame's time; otherwise holds
    /// it as the run's latest, which [`finish`](Self::finish) keeps.
    pub fn observe(&mut self, s: &Sample<'_>) {
        let due = self.t0 + self.span * self.next as f64 / (self.planned - 1) as f64;
        if self.next < self.planned && s.t >= due - 1e-12 * self.span.max(f64::MIN_POSITIVE) {
            self.keep(s);
            while self.next < self.planned
                && self.t0 + self.span * self.next as f64 / (self.planned - 1) as f64 <= s.t
            {
                self.next += 1;
            }
            self.latest = None;
        } else {
            let mut l = self.latest.take().unwrap_or_default();
            l.step = s.step;
            l.t = s.t;
            l.energy = s.energy;
            l.x.clear();
            l.x.extend_from_slice(s.x);
            l.outputs.clear();
            l.outputs.extend_from_slice(s.outputs);
            self.latest = Some(l);
        }
    }

    /// Ends the frames with the run's last sample, if it was not kept (a run that stopped early
    /// ends its animation where it stopped).
    pub fn finish(&mut self) {
        if let Some(l) = self.latest.take() {
            self.keep(&Sample {
                step: l.step,
                t: l.t,
                x: &l.x,
                energy: l.energy,
                dissipated: None,
                supplied: None,
                g: None,
                phi: None,
                outputs: &l.outputs,
                multipliers: &[],
            });
        }
    }

    /// The frames kept so far.
    pub fn frames(&self) -> usize {
        self.times.len()
    }

    fn keep(&mut self, s: &Sample<'_>) {
        let d = self.sketch.dim;
        for slot in 0..self.slots {
            for k in 0..3 {
                let v = if k < d { s.x[slot * d + k] } else { 0.0 };
                self.positions.push(v as f32);
            }
        }
        self.outputs.extend(
            (0..self.output_names.len()).map(|j| s.outputs.get(j).map_or(f32::NAN, |&v| v as f32)),
        );
        if let Some(e) = s.energy {
            self.energy.push(e);
        }
        self.times.push(s.t);
        self.steps.push(s.step);
    }
}

/// The bodies traced by default: every body of a scene of at most four, otherwise the last
/// body of each generator (a chain's tip), at most eight.
fn default_traces(sketch: &Sketch) -> Vec<usize> {
    if sketch.bodies.len() <= 4 {
        return (0..sketch.bodies.len()).collect();
    }
    let mut tips: Vec<usize> = Vec::new();
    for (i, b) in sketch.bodies.iter().enumerate() {
        let group = b.name.rsplit_once('.').map(|(g, _)| g);
        let next = sketch
            .bodies
            .get(i + 1)
            .map(|n| n.name.rsplit_once('.').map(|(g, _)| g));
        if group.is_some() && next != Some(group) {
            tips.push(i);
        }
    }
    tips.truncate(8);
    tips
}
