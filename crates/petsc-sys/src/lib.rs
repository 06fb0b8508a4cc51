//! Raw bindings to the system PETSc, generated at build time by bindgen
//! against the headers found through pkg-config (`petsc`). On Debian this is
//! `libpetsc-real-dev`: PETSc 3.18 with real `f64` scalars and 32-bit
//! `PetscInt`.
//!
//! Only what Gimlet uses is bound (see the allowlists in `build.rs`): PETSc
//! initialisation and error handlers, `Mat` (AIJ), `Vec`, `VecScatter`, `KSP`
//! and `PC`, the enums they take, and the type-name strings such as [`MATAIJ`],
//! [`KSPCG`] and [`PCJACOBI`] (NUL-terminated byte strings: pass
//! `KSPCG.as_ptr().cast()`).
//!
//! MPI types are not generated here: `MPI_Comm` is [`mpi_sys::MPI_Comm`], the
//! same type the rest of Gimlet uses, so a communicator from `mpi-sys` goes
//! straight into [`MatCreate`] or [`KSPCreate`].
//!
//! C enums (`InsertMode`, `NormType`, `MatOption`, `KSPConvergedReason`, …)
//! are `#[repr(transparent)]` newtypes with associated constants, e.g.
//! `InsertMode::INSERT_VALUES`, so any value PETSc hands back is sound.
//!
//! Everything here is `unsafe` FFI; every function returns a
//! [`PetscErrorCode`] that is `0` on success.

#![deny(missing_docs)]

mod bindings {
    //! The bindgen output (no doc comments: PETSc documents its API in man
    //! pages, not in header comments).
    #![allow(
        missing_docs,
        non_upper_case_globals,
        non_camel_case_types,
        non_snake_case,
        dead_code,
        clippy::all
    )]
    include!(concat!(env!("OUT_DIR"), "/bindings.rs"));
}

pub use bindings::*;
pub use mpi_sys::MPI_Comm;

/// `PETSC_DEFAULT` as a `PetscReal`, for the real-valued arguments of calls
/// such as [`KSPSetTolerances`] (C code writes `(PetscReal)PETSC_DEFAULT`;
/// the generated [`PETSC_DEFAULT`] is an `i32`).
pub const PETSC_DEFAULT_REAL: PetscReal = PETSC_DEFAULT as PetscReal;
