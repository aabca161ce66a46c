//! The tools that measure lieflow, as a workspace crate of their own so that the library —
//! even with its `scene` feature — pulls no peer solver, no double-double scalar and no thread
//! pool.
//!
//! - [`precision`]: work–precision sets. Every scheme of a plan at every step size (and the
//!   peers at every tolerance) against a reference: closed form, Kahan–Li 8 in double-double
//!   arithmetic, or Richardson-extrapolated double-precision runs; fitted slopes; CSV rows.
//! - [`peers`]: Hairer's DOP853 on the index-1 ODE and Radau5 on the index-3 DAE of the same
//!   scene, as a user would otherwise solve it.
//! - [`stress`]: the hard-case suite — public test problems, stiff damping and springs, extreme
//!   lengths and mass ratios, nearly singular multiplier systems, redundant constraints, very
//!   long runs, hostile input — each judged by bounds from theory.
//! - [`sweep`]: parameter sweeps of a scene, members in parallel on a rayon pool, rows
//!   identical for any number of threads.
//!
//! The `lieflow` command (`lieflow precision`, `lieflow stress`, `lieflow sweep`) is a thin
//! shell over these.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod peers;
pub mod precision;
pub mod stress;
pub mod sweep;
