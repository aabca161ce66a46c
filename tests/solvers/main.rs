//! The multiplier systems' solvers: Newton's kept and grouped Jacobians, the sparse and banded
//! LU backends and their agreement with the dense one. With debug assertions (`cargo test
//! --test solvers`) the pattern checks inside the solvers run as well.
//!
//! One test binary for the suite (a module a file): the generic code the files share is
//! compiled and linked once.

mod backends;
mod banded;
mod newton;
mod sparse;
