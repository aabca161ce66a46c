//! Models from `H(x)` and `g(x)` alone, with derivatives by forward-mode dual numbers.
//!
//! One test binary for the suite (a module a file): the generic code the files share is
//! compiled and linked once.

#[path = "../common/ad_models.rs"]
mod ad_models;

mod andrews;
mod autodiff;
