//! The contact LCP solve in a host that **initialised PETSc itself** (before
//! any Gimlet call) and finalises it itself. Run by ctest under
//! `mpiexec -n 1, 2` (`linsolve_host_petsc_npN`); plain `cargo test` runs it
//! as a 1-rank singleton. One `#[test]` (PETSc can be initialised once per
//! process).
//!
//! Checked: Gimlet uses the host's PETSc without initialising it again
//! (`gimlet_started_petsc()` stays false); a PETSc error inside Gimlet goes
//! to Gimlet's own error handler, not to the host's, and after the call the
//! host's handler is on top again (a host-side error reaches it); after
//! Gimlet's solvers are dropped PETSc is still initialised and not
//! finalised, the host's own PETSc objects still work, and the host's
//! `PetscFinalize` and `MPI_Finalize` both return 0. A solve that needs
//! PETSc after the host finalised it fails with `InvalidState` (PETSc cannot
//! be initialised twice), while the direct path keeps working.

mod linsolve_common;

use gimlet::comm::Comm;
use gimlet::error::Status;
use gimlet::linsolve::{gimlet_started_petsc, LcpOptions, Linsolve};
use linsolve_common::*;
use mpi_sys as mpi;
use petsc_sys as ps;
use std::os::raw::{c_char, c_int, c_void};
use std::ptr;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Calls of the host's error handler.
static HOST_HANDLER_CALLS: AtomicUsize = AtomicUsize::new(0);

/// The host's PETSc error handler: counts, stays silent, returns the code.
unsafe extern "C" fn host_handler(
    _comm: mpi::MPI_Comm,
    _line: c_int,
    _func: *const c_char,
    _file: *const c_char,
    code: ps::PetscErrorCode,
    _p: ps::PetscErrorType,
    _mess: *const c_char,
    _ctx: *mut c_void,
) -> ps::PetscErrorCode {
    HOST_HANDLER_CALLS.fetch_add(1, Ordering::SeqCst);
    code
}

fn flag(f: unsafe extern "C" fn(*mut ps::PetscBool) -> ps::PetscErrorCode) -> bool {
    let mut b = ps::PetscBool::PETSC_FALSE;
    unsafe { f(&mut b) };
    b == ps::PetscBool::PETSC_TRUE
}

/// A host-side PETSc error: a Vec with local size above its global size.
fn host_triggers_an_error() -> ps::PetscErrorCode {
    unsafe {
        let mut v: ps::Vec = ptr::null_mut();
        assert_eq!(ps::VecCreate(ps::PETSC_COMM_WORLD, &mut v), 0);
        let code = ps::VecSetSizes(v, 11, 10);
        assert_eq!(ps::VecDestroy(&mut v), 0);
        code
    }
}

#[test]
fn contact_lcp_in_a_host_that_owns_petsc() {
    unsafe {
        assert_eq!(mpi::MPI_Init(ptr::null_mut(), ptr::null_mut()), 0);
        // The host initialises PETSc (on MPI_COMM_WORLD) and installs its
        // own error handler.
        assert_eq!(ps::PetscInitializeNoArguments(), 0);
        assert_eq!(
            ps::PetscPushErrorHandler(Some(host_handler), ptr::null_mut()),
            0
        );
    }
    let world = Comm::world().expect("world");
    let (a, r) = obstacle(200, 0.05);
    let mut xd = Vec::new();
    Linsolve::new(LcpOptions {
        dense_max: usize::MAX,
        direct_work_max: f64::INFINITY,
        ..LcpOptions::default()
    })
    .solve_lcp(&world, &a, &r, &mut xd)
    .expect("direct");

    let mut ls = Linsolve::new(LcpOptions {
        dense_max: 0,
        ..LcpOptions::default()
    });
    let mut x = Vec::new();
    let rep = ls.solve_lcp(&world, &a, &r, &mut x).expect("PETSc path");
    assert!(rep.petsc_solves >= 1);
    assert!(rel_diff(&x, &xd) <= 1e-10, "{}", rel_diff(&x, &xd));
    assert!(!gimlet_started_petsc(), "the host's PETSc is used as it is");

    // A PETSc error inside Gimlet: reported to the caller, not to the
    // host's handler.
    let name = c"-gimlet_contact_ksp_type";
    unsafe {
        assert_eq!(
            ps::PetscOptionsSetValue(ptr::null_mut(), name.as_ptr(), c"bogus".as_ptr()),
            0
        );
    }
    let e = ls
        .solve_lcp(&world, &a, &r, &mut x)
        .expect_err("unknown type");
    assert_eq!(e.status, Status::Petsc);
    assert!(e.msg.contains("bogus"), "{}", e.msg);
    assert_eq!(
        HOST_HANDLER_CALLS.load(Ordering::SeqCst),
        0,
        "Gimlet's errors must not reach the host's handler"
    );
    unsafe {
        assert_eq!(
            ps::PetscOptionsClearValue(ptr::null_mut(), name.as_ptr()),
            0
        )
    };
    ls.solve_lcp(&world, &a, &r, &mut x).expect("works again");
    assert!(rel_diff(&x, &xd) <= 1e-10);

    // The host's handler is on top again.
    assert_ne!(host_triggers_an_error(), 0);
    assert!(
        HOST_HANDLER_CALLS.load(Ordering::SeqCst) >= 1,
        "the host's handler must be restored after Gimlet's calls"
    );

    // Gimlet's solvers are gone; PETSc is the host's, still usable.
    drop(ls);
    drop(world);
    assert!(flag(ps::PetscInitialized));
    assert!(
        !flag(ps::PetscFinalized),
        "Gimlet never finalises the host's PETSc"
    );
    unsafe {
        let mut v: ps::Vec = ptr::null_mut();
        assert_eq!(
            ps::VecCreateMPI(ps::PETSC_COMM_WORLD, ps::PETSC_DECIDE, 10, &mut v),
            0
        );
        assert_eq!(ps::VecSet(v, 2.0), 0);
        let mut s = 0.0;
        assert_eq!(ps::VecSum(v, &mut s), 0);
        assert_eq!(s, 20.0);
        assert_eq!(ps::VecDestroy(&mut v), 0);
        assert_eq!(ps::PetscPopErrorHandler(), 0);
        assert_eq!(ps::PetscFinalize(), 0, "the host's PetscFinalize");
        assert!(flag(ps::PetscFinalized));
    }
    // PETSc cannot come back: the PETSc path says so (the same on every
    // rank), the direct path still works.
    let world = Comm::world().expect("world");
    let mut late = Linsolve::new(LcpOptions {
        dense_max: 0,
        ..LcpOptions::default()
    });
    let e = late
        .solve_lcp(&world, &a, &r, &mut x)
        .expect_err("PETSc was finalized");
    assert_eq!(e.status, Status::InvalidState, "{}", e.msg);
    assert!(e.msg.contains("finalized"), "{}", e.msg);
    late.set_options(LcpOptions {
        dense_max: usize::MAX,
        direct_work_max: f64::INFINITY,
        ..LcpOptions::default()
    });
    late.solve_lcp(&world, &a, &r, &mut x).expect("direct path");
    assert_eq!(x, xd);
    drop(late);
    drop(world);
    unsafe { assert_eq!(mpi::MPI_Finalize(), 0, "the host's MPI_Finalize") };
}
