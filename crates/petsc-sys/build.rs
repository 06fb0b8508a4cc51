//! Generates raw PETSc bindings with bindgen against the PETSc found through
//! pkg-config (`petsc`; Debian's `libpetsc-real-dev` installs PETSc 3.18 with
//! real double scalars and 32-bit `PetscInt`).
//!
//! Only what Gimlet uses is allowlisted. MPI types are blocklisted and taken
//! from `mpi-sys`, so `MPI_Comm` in these bindings is `mpi_sys::MPI_Comm`.

use std::env;
use std::path::PathBuf;
use std::process::Command;

/// Functions Gimlet calls (anchored regex alternatives).
const FUNCTIONS: &[&str] = &[
    // initialisation and error handling
    "PetscInitialize",
    "PetscInitializeNoArguments",
    "PetscInitialized",
    "PetscFinalize",
    "PetscFinalized",
    "PetscOptionsSetValue",
    "PetscPushErrorHandler",
    "PetscPopErrorHandler",
    "PetscIgnoreErrorHandler",
    "PetscReturnErrorHandler",
    "PetscErrorMessage",
    "PetscOptionsInsertString",
    "PetscOptionsClearValue",
    "PetscOptionsHasName",
    // Mat
    "MatCreate",
    "MatSetSizes",
    "MatSetType",
    "MatSetFromOptions",
    "MatMPIAIJSetPreallocation",
    "MatSeqAIJSetPreallocation",
    "MatSetValues",
    "MatAssemblyBegin",
    "MatAssemblyEnd",
    "MatGetOwnershipRange",
    "MatGetSize",
    "MatMult",
    "MatDestroy",
    "MatZeroEntries",
    "MatSetOption",
    "MatSeqAIJSetPreallocationCSR",
    "MatMPIAIJSetPreallocationCSR",
    "MatCreateVecs",
    // Vec
    "VecCreate",
    "VecCreateMPI",
    "VecSetSizes",
    "VecSetFromOptions",
    "VecSetValues",
    "VecAssemblyBegin",
    "VecAssemblyEnd",
    "VecGetArray",
    "VecRestoreArray",
    "VecGetArrayRead",
    "VecRestoreArrayRead",
    "VecDestroy",
    "VecSet",
    "VecSum",
    "VecNorm",
    "VecAXPY",
    "VecGetOwnershipRange",
    "VecGetSize",
    "VecGetLocalSize",
    "VecDuplicate",
    "VecScatterCreateToAll",
    "VecScatterBegin",
    "VecScatterEnd",
    "VecScatterDestroy",
    // KSP / PC
    "KSPCreate",
    "KSPSetOperators",
    "KSPSetType",
    "KSPGetPC",
    "PCSetType",
    "KSPSetTolerances",
    "KSPSetFromOptions",
    "KSPSolve",
    "KSPGetConvergedReason",
    "KSPGetIterationNumber",
    "KSPGetResidualNorm",
    "KSPDestroy",
    "KSPReset",
    "KSPGetType",
    "PCGetType",
    "KSPSetOptionsPrefix",
    "KSPSetInitialGuessNonzero",
];

/// Types named directly (the ones reachable from the functions come anyway).
const TYPES: &[&str] = &[
    "PetscErrorCode",
    "PetscInt",
    "PetscScalar",
    "PetscReal",
    "PetscBool",
    "PetscErrorType",
    "Mat",
    "Vec",
    "KSP",
    "PC",
    "VecScatter",
    "MatType",
    "KSPType",
    "PCType",
    "InsertMode",
    "ScatterMode",
    "MatAssemblyType",
    "NormType",
    "MatOption",
    "KSPConvergedReason",
];

/// C enums exposed as `#[repr(transparent)]` newtypes with associated
/// constants: values returned by PETSc that this version does not know can
/// never be undefined behaviour, unlike a Rust `enum`.
const NEWTYPE_ENUMS: &[&str] = &[
    "PetscBool",
    "PetscErrorType",
    "InsertMode",
    "ScatterMode",
    "MatAssemblyType",
    "NormType",
    "MatOption",
    "KSPConvergedReason",
];

/// Variables and object-like macros: `PETSC_COMM_WORLD` is a real variable;
/// the others are `#define`s (integers, or string literals for the type
/// names, which bindgen turns into NUL-terminated byte-string constants).
const VARS: &[&str] = &[
    "PETSC_COMM_WORLD",
    "PETSC_DECIDE",
    "PETSC_DETERMINE",
    "PETSC_DEFAULT",
    "MATAIJ",
    "MATSEQAIJ",
    "MATMPIAIJ",
    "KSPCG",
    "KSPGMRES",
    "KSPPREONLY",
    "PCNONE",
    "PCJACOBI",
    "PCBJACOBI",
    "PCLU",
    "KSPConvergedReasons",
];

fn alternatives(names: &[&str]) -> String {
    format!("^({})$", names.join("|"))
}

/// Include directories of the MPI that PETSc was built with: PETSc's
/// `petsc.pc` does not list them, but `petscsys.h` includes `<mpi.h>`.
fn mpi_include_dirs() -> Vec<PathBuf> {
    for name in ["ompi-c", "mpi-c", "mpich", "mpi"] {
        if let Ok(lib) = pkg_config::Config::new()
            .cargo_metadata(false)
            .env_metadata(false)
            .probe(name)
        {
            if !lib.include_paths.is_empty() {
                return lib.include_paths;
            }
        }
    }
    // Open MPI's compiler wrapper can say it directly.
    if let Ok(out) = Command::new("mpicc").arg("--showme:incdirs").output() {
        if out.status.success() {
            let dirs: Vec<PathBuf> = String::from_utf8_lossy(&out.stdout)
                .split_whitespace()
                .map(PathBuf::from)
                .collect();
            if !dirs.is_empty() {
                return dirs;
            }
        }
    }
    Vec::new()
}

fn main() {
    println!("cargo:rerun-if-changed=wrapper.h");
    println!("cargo:rerun-if-changed=build.rs");

    let petsc = pkg_config::Config::new()
        .atleast_version("3.18")
        .probe("petsc")
        .unwrap_or_else(|e| {
            panic!(
                "PETSc not found through pkg-config `petsc` ({e}); \
                 install libpetsc-real-dev (scripts/setup.sh does) or set PKG_CONFIG_PATH"
            )
        });
    if let Some(dir) = petsc.include_paths.first() {
        // Exposed to dependents as DEP_PETSC_INCLUDE.
        println!("cargo:include={}", dir.display());
    }

    let mut builder = bindgen::Builder::default()
        .header("wrapper.h")
        // Match the workspace's `rust-version` (plain `extern "C"` blocks).
        .rust_target(bindgen::RustTarget::stable(80, 0).expect("a Rust target bindgen knows"))
        .parse_callbacks(Box::new(bindgen::CargoCallbacks::new()))
        .allowlist_function(alternatives(FUNCTIONS))
        .allowlist_type(alternatives(TYPES))
        .allowlist_var(alternatives(VARS))
        .blocklist_type("^(MPI_.*|ompi_.*)$")
        .raw_line("use mpi_sys::MPI_Comm;")
        .default_macro_constant_type(bindgen::MacroTypeVariation::Signed)
        .generate_comments(false)
        .layout_tests(true);
    for e in NEWTYPE_ENUMS {
        builder = builder.newtype_enum(format!("^{e}$"));
    }
    for dir in petsc.include_paths.iter().chain(mpi_include_dirs().iter()) {
        builder = builder.clang_arg(format!("-I{}", dir.display()));
    }

    let bindings = builder
        .generate()
        .expect("bindgen failed on the PETSc headers (is libclang-dev installed?)");
    let out = PathBuf::from(env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    bindings
        .write_to_file(out.join("bindings.rs"))
        .expect("cannot write the PETSc bindings into OUT_DIR");
}
