//! # Gimlet
//!
//! 2D material point simulation with the generalized interpolation material
//! point method (GIMP) on nested multi-level grids, run in parallel over MPI,
//! with a rigid-indenter contact algorithm. The method follows Ma et al.,
//! CMES 8(2) 2005; the weights follow Bardenhagen & Kober, CMES 5(6) 2004.
//!
//! ## Layers
//!
//! From the bottom: small utilities; the numerical layers (`geom`,
//! `mode`, `shape`, `material`, `particles`, `kernel`: one patch, one step, no
//! MPI, no C); the message layouts (`records`); MPI (`comm`) and the
//! contact solve over PETSc (`linsolve`); contact; one level of patches
//! over ranks (`level`); the coupling of levels (`coupling`); the
//! simulation (`sim`); files (`io`); the C ABI (`ffi`). Each module may
//! import only the modules its row below names (and itself), and use C
//! types (`std::os::raw`, `std::ffi`, `extern "C"`) and system bindings
//! only as its row says: C types appear where a C library is called, the
//! host's (`ffi`), MPI's (`comm`), PETSc's (`linsolve`) and HDF5's (`io`).
//! The test `tests/layers.rs` reads this table and every `crate::`,
//! `super::` and outside-crate path of every file under `src/` (code, not
//! comments), and fails on an import the table does not allow; it also
//! checks that the table names every module and has no cycle. Change the
//! table here, and only here, to change the rule.
//!
//! <!-- layers:begin -->
//! | module | may import | C types and system bindings |
//! |---|---|---|
//! | `error` | | |
//! | `fnv` | | |
//! | `ln` | | |
//! | `storage` | | |
//! | `balance` | | |
//! | `limits` | `error` | |
//! | `geom` | `error`, `limits` | |
//! | `mode` | | |
//! | `shape` | `error`, `limits`, `mode` | |
//! | `material` | `error`, `limits`, `ln`, `mode` | |
//! | `particles` | `error`, `storage` | |
//! | `kernel` | `error`, `limits`, `ln`, `storage`, `geom`, `mode`, `shape`, `material`, `particles` | `libc::clock_gettime`, `libc::timespec`, `libc::CLOCK_THREAD_CPUTIME_ID` (the thread CPU clock of the phase timing) |
//! | `records` | `error`, `particles` | |
//! | `diag` | `error`, `limits`, `storage`, `geom`, `mode`, `shape`, `material`, `particles`, `kernel` | |
//! | `indentation` | `error`, `limits`, `geom` | |
//! | `comm` | `error`, `limits` | `mpi_sys`, `std::os::raw`, `std::ffi` |
//! | `linsolve` | `error`, `limits`, `fnv`, `comm` | `mpi_sys`, `petsc_sys`, `std::os::raw`, `std::ffi`, `extern "C"` |
//! | `contact` | `error`, `limits`, `ln`, `storage`, `geom`, `mode`, `shape`, `material`, `particles`, `kernel`, `comm`, `linsolve` | |
//! | `level` | `error`, `limits`, `storage`, `balance`, `geom`, `mode`, `shape`, `material`, `particles`, `kernel`, `records`, `comm`, `contact` | |
//! | `coupling` | `error`, `limits`, `storage`, `geom`, `mode`, `shape`, `material`, `particles`, `kernel`, `records`, `comm`, `contact`, `level` | |
//! | `sim` | `error`, `limits`, `storage`, `balance`, `geom`, `mode`, `shape`, `material`, `particles`, `kernel`, `records`, `diag`, `comm`, `contact`, `level`, `coupling` | |
//! | `io` | `error`, `limits`, `fnv`, `storage`, `geom`, `mode`, `shape`, `material`, `particles`, `kernel`, `records`, `comm`, `contact`, `level`, `sim` | `hdf5_sys`, `mpi_sys`, `std::os::raw`, `std::ffi`, `extern "C"` |
//! | `ffi` | `error`, `limits`, `fnv`, `ln`, `storage`, `balance`, `geom`, `mode`, `shape`, `material`, `particles`, `kernel`, `records`, `diag`, `indentation`, `comm`, `linsolve`, `contact`, `level`, `coupling`, `sim`, `io` | `libc`, `mpi_sys`, `std::os::raw`, `std::ffi`, `extern "C"` |
//! <!-- layers:end -->
//!
//! `docs/ARCHITECTURE.md` draws the same layers with the path of one step
//! and where each concept lives; `docs/method.md` states the method.

#![deny(missing_docs)]

pub mod balance;
pub mod comm;
pub mod contact;
pub mod coupling;
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
pub mod records;
pub mod shape;
pub mod sim;
pub mod storage;
