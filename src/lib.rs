//! # Gimlet
//!
//! 2D material point simulation with the generalized interpolation material
//! point method (GIMP) on nested multi-level grids, run in parallel over MPI,
//! with a rigid-indenter contact algorithm. The method follows Ma et al.,
//! CMES 8(2) 2005; the weights follow Bardenhagen & Kober, CMES 5(6) 2004.
//!
//! Layers, from the bottom (each knows only the ones below it):
//! `storage`, `geom`, `mode`, `shape`, `material`, `particles`, `kernel` (no
//! MPI, no FFI), then
//! `comm`, `linsolve`, `io` (MPI), then `ffi` (the C ABI).

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
pub mod mode;
pub mod particles;
pub mod scenes;
pub mod shape;
pub mod sim;
pub mod solver;
pub mod storage;
