//! # Gimlet
//!
//! 2D material point simulation with the generalized interpolation material
//! point method (GIMP) on nested multi-level grids, run in parallel over MPI,
//! with a rigid-indenter contact algorithm. The method follows Ma et al.,
//! CMES 8(2) 2005; the weights follow Bardenhagen & Kober, CMES 5(6) 2004.
//!
//! Layers, from the bottom (each knows only the ones below it):
//! `storage`, `geom`, `shape`, `material`, `particles`, `kernel` (no MPI, no
//! FFI), then
//! `comm`, `linsolve`, `io` (MPI), then `ffi` (the C ABI). `docs/ARCHITECTURE.md`
//! has the full table, the path of one step and where each concept lives;
//! `docs/method.md` the method.

#![deny(missing_docs)]

pub mod amr;
pub mod balance;
pub mod comm;
pub mod contact;
pub mod diag;
pub mod error;
pub mod ffi;
pub mod fnv;
pub mod geom;
pub mod indentation;
pub mod io;
pub mod kernel;
pub mod level;
pub mod limits;
pub mod linsolve;
pub mod ln;
pub mod material;
pub mod particles;
pub mod scenes;
pub mod shape;
pub mod sim;
pub mod solver;
pub mod storage;
