//! Ports: inputs that act on a model from outside and the outputs collocated with them.
//!
//! An open port-Hamiltonian system (van der Schaft & Jeltsema, *Port-Hamiltonian Systems
//! Theory*, 2014, §2.2) with constraints:
//!
//! ```text
//! x' = M(x) (∇H(x) + G(x)ᵀ λ) + B(x) u(t),   g(x) = 0,   y = B(x)ᵀ ∇H(x),
//! ```
//!
//! so that `dH/dt = −∇Hᵀ R ∇H + yᵀu`: what the ports supply, `∫ yᵀu dt`, is the only source of
//! energy. The input's sub-flow `x' = B(x) u(t)` is solved exactly when `B` does not change
//! along its own columns (`(∂B/∂x) B = 0`: a constant `B`, or forces and torques `B(q)` acting
//! on the momenta of a mechanical model): `x ← x + B(x) ∫ u dt`. [`InputFlow`] is that
//! sub-flow; it joins a splitting like any closed-form flow (`kick.then(input).strang(drift)`),
//! carries the time (see [`Ledger`](crate::flow::Ledger)) so that every sub-step sees its own
//! time and a composition keeps its order, and accounts for the energy it supplies exactly.
//!
//! Inputs are [`Signal`]s: closed forms of time (constant, step, ramp, sine, piecewise-linear
//! table, integrated exactly), a closure of time (integrated by Gauss–Legendre quadrature), or a
//! value [`Held`] between steps and set by the embedder (zero-order hold). `B` is an
//! [`InputMap`]: [`InputMatrix`] (constant), [`ComponentInputs`] (each input drives one
//! component), or [`FnInputMap`] (closures, for a state-dependent `B(q)`).
//!
//! The constraint must not see the input directly (`G B = 0`, true for a force on a mechanical
//! model with position constraints), so the hidden constraint `φ = G M ∇H` is unchanged.

mod flow;
mod map;
mod signal;

pub use flow::{InputFlow, SuppliedEnergy, Supplying};
pub use map::{ComponentInputs, FnInputMap, InputMap, InputMatrix};
pub use signal::{Held, Signal};
