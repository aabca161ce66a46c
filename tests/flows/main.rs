//! The flows and the stepper in code: convergence orders, residuals, symmetry, drift, errors,
//! the ports and the examples' command lines.
//!
//! One test binary for the suite (a module a file): the generic code the files share is
//! compiled and linked once.

#[path = "../common/mod.rs"]
mod common;

mod adaptive;
mod adaptive_dense;
mod brackets;
mod chain;
mod check_model;
mod coefficients;
mod convergence;
mod damped_pendulum;
mod derivatives;
mod discrete_gradient;
mod dissipation;
mod driven;
mod embedding;
mod errors;
mod examples_cli;
mod extrapolation;
mod four_bar;
mod fused;
mod geometry;
mod hostile;
mod implicit;
mod implicit_inputs;
mod long_runs;
mod petrov_galerkin;
mod petrov_galerkin_inputs;
mod ports;
mod projected_midpoint;
mod reversible;
mod rigid;
mod rigid_planar;
mod rigid_projection;
mod small_path;
mod step_doubling;
mod stepper;
