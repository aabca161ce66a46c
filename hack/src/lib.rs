//! No code: this crate's dependencies fix one feature set for the crates that every build of the
//! workspace shares, so that the wheel, the command with and without MPI, and the tests reuse one
//! compiled copy of nalgebra, faer and the library (see Cargo.toml).
