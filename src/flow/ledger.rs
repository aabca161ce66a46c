//! The time and the energy ledger of a step: the extra coordinates of the extended system,
//! threaded through the sub-flows of a splitting.
//!
//! A non-autonomous, open system `x' = f(x) + B(x) u(t)` is split as an autonomous one on the
//! extended state `(x, τ, S, D)` with `τ' = 1` (time), `S' = yᵀu` (energy supplied through the
//! ports, `y = Bᵀ∇H`) and `D' = ∇Hᵀ R ∇H` (energy dissipated). Each sub-flow advances the
//! coordinates it owns:
//!
//! - the exact flow of an input, `x ← x + B(x) ∫_τ^{τ+h} u`, advances `τ` by `h` and adds the
//!   energy it supplied, `H(x_after) − H(x_before)` (exactly `∫ yᵀu` along the sub-flow);
//! - the exact flow of a damping adds the energy it removed to `D`;
//! - every other sub-flow leaves them as they are.
//!
//! Because these are exact flows of the parts of one autonomous vector field, any composition
//! (Strang, Yoshida, …) integrates `τ`, `S` and `D` to the same order as `x`, and a sub-flow
//! of a time-dependent part sees the time of its own sub-step (Hairer, Lubich & Wanner,
//! *Geometric Numerical Integration*, §IV.1 and §II.5). One part of a splitting carries time;
//! a flow whose part carries it advances `τ` by exactly its `h`.

/// The extended coordinates of a step: time, supplied and dissipated energy (see the module
/// documentation). [`Flow::step_at`](super::Flow::step_at) threads one through a splitting.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Ledger<T> {
    /// The time `τ` at the start of the sub-flow about to run.
    pub t: T,
    /// Energy supplied through the input ports so far, `∫ yᵀu dt`.
    pub supplied: T,
    /// Energy dissipated so far, `∫ ∇Hᵀ R ∇H dt`, as accounted by the dissipative sub-flows
    /// that report it.
    pub dissipated: T,
}

impl<T: num_traits::Zero> Ledger<T> {
    /// A ledger at time `t` with no energy supplied or dissipated.
    pub fn at(t: T) -> Self {
        Self {
            t,
            supplied: T::zero(),
            dissipated: T::zero(),
        }
    }
}
