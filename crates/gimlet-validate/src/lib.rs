//! Gimlet's validation tools, kept out of the shipped library: the
//! single-patch reference solver ([`solver`]: the library's one step on
//! one patch, without MPI), the validation scenes measured against closed
//! forms ([`scenes`]), and three commands:
//!
//! - `gimlet-validate`: the validation problems and the work-precision
//!   study (`cargo run --release -p gimlet-validate --bin gimlet-validate`);
//! - `gimlet-bench`: the kernel-only reference line of `make bench`;
//! - `gimlet-io-check`: the MPI check of the library's `io` layer
//!   (`make io-check`: under `mpiexec -n 1` and `-n 2`).
//!
//! The integration tests under `tests/` that need the reference solver or
//! the scenes live here too.

#![deny(missing_docs)]

pub mod scenes;
pub mod solver;
