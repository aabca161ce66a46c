//! How a scene's order-2 step is raised to the order it asks for: a symmetric composition
//! (negative sub-steps) or an extrapolation (every sub-step forward, for damped scenes).

use super::density::DistanceDensity;
use crate::error::SetupError;
use crate::flow::{
    AdaptiveExtrapolation, AdaptiveOptions, CompositionTable, Flow, FlowExt, ManifoldProjection,
    ProjectionOptions, ReversibleSteps, StepDoubling, Tolerances,
};
use crate::scene::schema::Method;
use crate::system::Model;
use crate::vector::Vector;

/// The raise of a scene's symmetric order-2 step (see `choose_scheme`).
#[derive(Debug, Clone, PartialEq)]
pub enum Raise {
    /// The step itself: order 2.
    Base,
    /// A symmetric composition with the table's coefficients (negative sub-steps above
    /// order 2, so refused on dissipative flows).
    Compose(&'static CompositionTable),
    /// Aitken–Neville extrapolation to this order on the harmonic sequence, every sub-step
    /// forward ([`Extrapolated`](crate::flow::Extrapolated)), re-projected onto the manifold
    /// when constrained ([`Reprojected`](crate::flow::Reprojected)).
    Extrapolate(u32),
    /// Order- and step-size-controlled extrapolation to a tolerance
    /// ([`AdaptiveExtrapolation`](crate::flow::AdaptiveExtrapolation)), every sub-step forward,
    /// projected onto the manifold after every accepted step when constrained.
    Adaptive(Control),
    /// The step (composed by the table, when any) of fixed order, its steps chosen to a
    /// tolerance by step doubling ([`StepDoubling`](crate::flow::StepDoubling)).
    Doubling(Control, Option<&'static CompositionTable>),
    /// The symmetric step (composed by the table, when any) with reversible steps along a
    /// density ([`ReversibleSteps`](crate::flow::ReversibleSteps)).
    Reversible(Control, DistanceDensity, Option<&'static CompositionTable>),
}

/// A scene's tolerance and step limits ([`Raise::Adaptive`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Control {
    /// The relative tolerance.
    pub rtol: f64,
    /// The absolute tolerance.
    pub atol: f64,
    /// The smallest step.
    pub h_min: f64,
    /// The largest step.
    pub h_max: f64,
    /// The highest order.
    pub max_order: u32,
    /// The state's scales for the absolute tolerance (empty: 1 for every component): 1 for a
    /// position, the slot's mass for a momentum, so that `atol` holds positions and
    /// velocities alike.
    pub scales: Vec<f64>,
    /// The damping's shortest relaxation time, when the splitting's impulses act on damped
    /// momenta: the sub-steps resolve it; under step doubling, any damping's: the first step
    /// resolves it ([`AdaptiveOptions::resolve`]).
    pub resolve: Option<f64>,
    /// The times the inputs' signals jump or kink: no step crosses them
    /// ([`AdaptiveOptions::breakpoints`]).
    pub breakpoints: Vec<f64>,
    /// Keep each accepted step's polynomial ([`AdaptiveOptions::dense_output`]).
    pub dense: bool,
}

impl Control {
    /// The library's options in the scalar `T`.
    fn options<T: crate::real::Real>(&self) -> Result<AdaptiveOptions<T>, SetupError> {
        let tolerances = if self.scales.is_empty() {
            Tolerances::new(T::lit(self.rtol), T::lit(self.atol))?
        } else {
            let atol = self.scales.iter().map(|&s| T::lit(self.atol * s)).collect();
            Tolerances::per_component(vec![T::lit(self.rtol)], atol)?
        };
        let mut o = AdaptiveOptions::new(tolerances);
        o.h_min = T::lit(self.h_min);
        o.h_max = Some(T::lit(self.h_max));
        o.max_order = self.max_order;
        o.resolve = self.resolve.map(T::lit);
        o.breakpoints = self.breakpoints.iter().map(|&t| T::lit(t)).collect();
        o.dense_output = self.dense;
        Ok(o)
    }
}

impl Raise {
    /// The composition table, when composed.
    pub fn table(&self) -> Option<&'static CompositionTable> {
        match self {
            Raise::Compose(t) => Some(t),
            Raise::Doubling(_, t) | Raise::Reversible(_, _, t) => *t,
            _ => None,
        }
    }

    /// Whether the steps are chosen by a controller (a tolerance was given).
    pub fn is_controlled(&self) -> bool {
        matches!(
            self,
            Raise::Adaptive(_) | Raise::Doubling(..) | Raise::Reversible(..)
        )
    }

    /// Why a scene with `scheme` (damped or not) at `order` gets this raise — what `lieflow
    /// check` tells a user.
    pub fn reason(&self, scheme: Method, dissipative: bool, order: u32) -> &'static str {
        match (scheme, self) {
            (Method::Auto, Raise::Extrapolate(o)) if *o > 8 && !dissipative => {
                "an order above 8 asked: extrapolation (the compositions stop at order 8)"
            }
            (Method::Auto, Raise::Extrapolate(_)) => {
                "damping is declared and an order above 2 asked: extrapolation, every sub-step forward (a composition's negative sub-steps would run the damping backwards)"
            }
            (Method::Auto, Raise::Compose(_)) => {
                "no damping and an order above 2 asked: a symmetric composition (its negative sub-steps are harmless without dissipation)"
            }
            (Method::Auto, Raise::Base) if dissipative && order == 2 => {
                "order 2: the symmetric step of the exact sub-flows, the damping flow among them"
            }
            (Method::Auto, Raise::Base) => {
                "order 2: the symmetric step of the exact sub-flows itself"
            }
            (_, Raise::Adaptive(_)) => {
                "a tolerance asked: the splitting extrapolated with the order and the step chosen to meet it, every sub-step forward"
            }
            (_, Raise::Doubling(..)) => {
                "a tolerance asked of a scheme of fixed order: its steps chosen by step doubling (the error per unit step), each step a step of the scheme, so what it keeps it keeps"
            }
            (_, Raise::Reversible(..)) => {
                "`controller = \"reversible\"` on a conservative scene: steps along the density that retrace themselves backwards (no drift on long runs); the tolerance sets the step scale once"
            }
            (Method::Extrapolation, _) => {
                "`scheme = \"extrapolation\"`: Strang extrapolated, every sub-step forward"
            }
            (Method::PetrovGalerkin, _) => {
                "`scheme = \"petrov-galerkin\"`: an exact discrete energy balance at the order asked"
            }
            (Method::DiscreteGradient, _) => {
                "`scheme = \"discrete-gradient\"`: energy conserved or decreasing by construction, order 2"
            }
            _ => "named by `integrator.scheme`",
        }
    }

    /// The scheme's description with the raise: `"{base} composed by …"`, `"{base},
    /// extrapolated …"`.
    pub fn describe(&self, base: &str) -> String {
        match self {
            Raise::Base => base.to_owned(),
            Raise::Compose(t) => format!("{base} composed by {} ({} stages)", t.name, t.stages),
            Raise::Adaptive(c) => format!(
                "{base}, extrapolated adaptively (orders 4 to {}, rtol {:e}, atol {:e}{}; any constraints projected after every accepted step{})",
                c.max_order,
                c.rtol,
                c.atol,
                c.resolve.map_or_else(String::new, |r| format!(
                    "; sub-steps within the damping's relaxation time {r:.3e}, so the steps follow it: scheme = \"petrov-galerkin\" with the tolerance takes steps set by the motion"
                )),
                if c.dense {
                    "; reports from each step's polynomial (dense output, its error held to the tolerance too)"
                } else {
                    ""
                }
            ),
            Raise::Doubling(c, t) => format!(
                "{}, steps by step doubling with a PI controller (rtol {:e}, atol {:e}, per unit step{})",
                t.map_or(Raise::Base, Raise::Compose).describe(base),
                c.rtol,
                c.atol,
                c.resolve.map_or_else(String::new, |r| format!(
                    "; the first step within the damping's relaxation time {r:.3e}"
                ))
            ),
            Raise::Reversible(c, _, t) => format!(
                "{}, reversible steps along the density (Hairer–Söderlind; ε set at rtol {:e}, atol {:e})",
                t.map_or(Raise::Base, Raise::Compose).describe(base),
                c.rtol,
                c.atol
            ),
            Raise::Extrapolate(order) => {
                let rows = order / 2;
                format!(
                    "{base}, extrapolated to order {order} (Aitken–Neville on 1..{rows} sub-steps, {} per step, all forward), re-projected",
                    rows * (rows + 1) / 2
                )
            }
        }
    }
}

/// Where a constrained step is re-projected after an extrapolation: the system, the initial
/// state and the projection options.
pub(crate) type Onto<'a, Sys, V> = Option<(Sys, &'a V, ProjectionOptions<<V as Vector>::Real>)>;

/// `flow` raised by `raise`, boxed. `backward` lets a composition run a dissipative sub-flow
/// backwards (reference runs only); `onto` re-projects an extrapolated constrained step.
///
/// # Errors
/// [`SetupError::Scheme`] when the flow cannot be extrapolated (not symmetric), and the
/// projection's setup errors.
pub(crate) fn raised<V, F, Sys>(
    flow: F,
    raise: Raise,
    backward: bool,
    onto: Onto<'_, Sys, V>,
) -> Result<Box<dyn Flow<V>>, SetupError>
where
    V: Vector + 'static,
    F: Flow<V> + 'static,
    Sys: Model<V> + 'static,
{
    Ok(match (raise, backward) {
        (Raise::Base, _) => Box::new(flow),
        (Raise::Compose(t), false) => Box::new(flow.composed(t)),
        (Raise::Compose(t), true) => Box::new(flow.composed(t).allow_backward_dissipation()),
        (Raise::Extrapolate(order), _) => {
            let e = flow.extrapolated(order)?;
            match onto {
                Some((system, x0, options)) => Box::new(e.reprojected(system, x0, options)?),
                None => Box::new(e),
            }
        }
        (Raise::Doubling(c, t), _) => {
            let step =
                raised::<V, F, Sys>(flow, t.map_or(Raise::Base, Raise::Compose), backward, None)?;
            Box::new(StepDoubling::try_new(step, (), c.options()?)?)
        }
        (Raise::Reversible(c, density, t), _) => {
            let step =
                raised::<V, F, Sys>(flow, t.map_or(Raise::Base, Raise::Compose), backward, None)?;
            Box::new(ReversibleSteps::try_new(step, density, c.options()?)?)
        }
        (Raise::Adaptive(c), _) => {
            let options = c.options()?;
            match onto {
                Some((system, x0, p)) => {
                    let finish = ManifoldProjection::try_new(system, x0, p)?;
                    Box::new(AdaptiveExtrapolation::try_new(flow, finish, options)?)
                }
                None => Box::new(AdaptiveExtrapolation::try_new(flow, (), options)?),
            }
        }
    })
}
