//! `--animate FILE.html`: the animation page of a run (`lieflow_view`), for `run` and for a
//! member of a `sweep`.

use crate::number::num;
use lieflow::scene::{Compiled, RunSummary, Sample};
use lieflow_view::{FrameBudget, PageInfo, Recorder, write_page};
use std::path::PathBuf;

/// The flags of an animation page.
#[derive(Debug, Clone, clap::Args)]
pub(crate) struct AnimateArgs {
    /// Write an animation of the run as one self-contained HTML page (three.js inlined; opens
    /// offline in a browser): play, pause, scrub, speed, an orbit camera, the outputs plotted
    /// and the events marked (the file must end in `.html`; it is checked writable before the
    /// run).
    #[arg(long, value_name = "FILE.html")]
    pub(crate) animate: Option<PathBuf>,
    /// A body whose path the animation draws (repeatable; default: each chain's last body, or
    /// every body of a scene of at most four).
    #[arg(long, value_name = "BODY", requires = "animate")]
    pub(crate) trace: Vec<String>,
    /// The most frames the animation keeps, spread evenly over the run (default 1000; fewer
    /// for large scenes, so that the positions stay within 12 MB and the page under 20 MB).
    #[arg(long, value_name = "N", requires = "animate")]
    pub(crate) frames: Option<usize>,
}

impl AnimateArgs {
    /// Checks the target before a run: an `.html` name in a writable place.
    pub(crate) fn check(&self) -> Result<(), String> {
        let Some(path) = &self.animate else {
            return Ok(());
        };
        let html = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("html") || e.eq_ignore_ascii_case("htm"));
        if !html {
            return Err(format!(
                "--animate {}: the animation is an HTML page; give a file name ending in .html",
                path.display()
            ));
        }
        if self.frames.is_some_and(|f| f < 2) {
            return Err("--frames must be at least 2".to_owned());
        }
        std::fs::File::create(path)
            .map(drop)
            .map_err(|e| format!("--animate: cannot write {}: {e}", path.display()))
    }

    /// The recorder of a run of `compiled`, when an animation is asked for.
    pub(crate) fn recorder(&self, compiled: &Compiled) -> Result<Option<Animation>, String> {
        let Some(path) = &self.animate else {
            return Ok(None);
        };
        let mut budget = FrameBudget::default();
        if let Some(f) = self.frames {
            budget.max_frames = f;
        }
        let sim = compiled.simulation.as_ref();
        let recorder = Recorder::new(
            compiled.sketch.as_ref(),
            sim.state().len(),
            sim.output_names(),
            (sim.time(), compiled.plan.t_end),
            &self.trace,
            budget,
        )
        .map_err(|e| format!("--animate: {e}"))?;
        let a = &compiled.assembly;
        Ok(Some(Animation {
            path: path.clone(),
            recorder,
            title: a.name.clone(),
            subtitle: format!("{}, order {}, dt = {}", a.scheme, a.order, num(sim.dt(), 6)),
        }))
    }
}

/// Runs `compiled` to its plan's end with an animation (`args.animate` set) and writes the
/// page; returns what a summary says of it. For a sweep's member, whose rows the sweep wrote.
pub(crate) fn run_animated(
    mut compiled: Compiled,
    args: &AnimateArgs,
) -> Result<serde_json::Value, String> {
    let mut animation = args
        .recorder(&compiled)?
        .ok_or_else(|| "no --animate file".to_owned())?;
    let summary = lieflow::scene::run(compiled.simulation.as_mut(), &compiled.plan, &mut |s| {
        animation.observe(s);
    });
    animation.write(&summary)
}

/// An animation being recorded.
pub(crate) struct Animation {
    path: PathBuf,
    recorder: Recorder,
    title: String,
    subtitle: String,
}

impl Animation {
    /// Sees a sample of the run.
    pub(crate) fn observe(&mut self, s: &Sample<'_>) {
        self.recorder.observe(s);
    }

    /// Writes the page, its last frame the run's last sample, with the summary's events;
    /// returns what the summary says of it.
    pub(crate) fn write(mut self, summary: &RunSummary) -> Result<serde_json::Value, String> {
        self.recorder.finish();
        let info = PageInfo {
            title: self.title,
            subtitle: format!(
                "{}; {} steps to t = {}",
                self.subtitle,
                summary.steps,
                num(summary.t, 8)
            ),
            events: summary
                .events
                .iter()
                .map(|e| (e.name.clone(), e.t))
                .collect(),
        };
        let bytes = write_page(&self.path, &self.recorder, &info)
            .map_err(|e| format!("writing {}: {e}", self.path.display()))?;
        println!(
            "  animation: {} ({} frames, {:.1} MB)",
            self.path.display(),
            self.recorder.frames(),
            bytes as f64 / 1e6
        );
        Ok(serde_json::json!({
            "path": self.path.display().to_string(),
            "frames": self.recorder.frames(),
            "bytes": bytes,
        }))
    }
}
