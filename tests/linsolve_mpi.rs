//! The contact LCP solve over MPI, with **Gimlet initialising PETSc** (the
//! host initialises only MPI). Run by ctest under `mpiexec -n 1, 2, 4`
//! (`linsolve_mpi_npN`); plain `cargo test` runs it as a 1-rank singleton.
//!
//! MPI and PETSc can be initialised once per process and the test harness
//! runs tests as threads of one process, so this file holds exactly one
//! `#[test]`, in phases:
//!
//! 1. **Sub-communicators**: world is split in two halves (even/odd ranks);
//!    the even half solves on its own communicator first, while the odd
//!    ranks wait at a world barrier without touching PETSc. Were PETSc's
//!    initialisation collective over `MPI_COMM_WORLD`, the even ranks would
//!    hang in it (ctest's timeout fails the test). Then the odd half
//!    initialises PETSc for itself, with a second `Linsolve` on another
//!    communicator. `PETSC_COMM_WORLD` spans the half, and no signal
//!    handler was installed (`-no_signal_handler`).
//! 2. **PETSc path = direct path**: LCPs of a few hundred unknowns, forced
//!    through PETSc (`dense_max = 0`), agree with the redundant direct path to
//!    1e-10 relative, and every rank holds the identical solution.
//! 3. **Options through the prefix**: `-gimlet_contact_ksp_type gmres`
//!    changes the KSP type of the `gimlet_contact_` solver and not of a
//!    solver with another prefix; an unknown type is a `Status::Petsc` error
//!    with PETSc's message, nothing is printed, and the next solve works.
//! 4. **KSP failure**: `max_it = 1` with `rtol = 1e-14` is `Status::Petsc`
//!    naming `KSP_DIVERGED_ITS`; the next solve on the same object works.
//! 5. **Teardown**: the solvers are dropped, `MPI_Finalize` finalises the
//!    PETSc Gimlet started (through the `MPI_COMM_SELF` attribute) and
//!    returns 0; ctest fails the test on any `PETSC ERROR` or warning output.

mod linsolve_common;

use gimlet::comm::Comm;
use gimlet::error::Status;
use gimlet::linsolve::{gimlet_started_petsc, LcpOptions, LcpReport, Linsolve, SymCsr};
use linsolve_common::*;
use mpi_sys as mpi;
use petsc_sys as ps;
use std::ptr;

/// The signals PETSc's default handler takes over.
const SIGNALS: [libc::c_int; 6] = [
    libc::SIGSEGV,
    libc::SIGFPE,
    libc::SIGBUS,
    libc::SIGILL,
    libc::SIGTERM,
    libc::SIGUSR1,
];

fn signal_handlers() -> Vec<usize> {
    SIGNALS
        .iter()
        .map(|&s| {
            // SAFETY: queries the current action only.
            let mut old: libc::sigaction = unsafe { std::mem::zeroed() };
            assert_eq!(unsafe { libc::sigaction(s, ptr::null(), &mut old) }, 0);
            old.sa_sigaction
        })
        .collect()
}

fn petsc_initialized() -> bool {
    let mut f = ps::PetscBool::PETSC_FALSE;
    unsafe { ps::PetscInitialized(&mut f) };
    f == ps::PetscBool::PETSC_TRUE
}

fn petsc_finalized() -> bool {
    let mut f = ps::PetscBool::PETSC_FALSE;
    unsafe { ps::PetscFinalized(&mut f) };
    f == ps::PetscBool::PETSC_TRUE
}

fn set_option(name: &str, value: Option<&str>) {
    let n = std::ffi::CString::new(name).unwrap();
    let v = value.map(|v| std::ffi::CString::new(v).unwrap());
    let rc = unsafe {
        ps::PetscOptionsSetValue(
            ptr::null_mut(),
            n.as_ptr(),
            v.as_ref().map_or(ptr::null(), |v| v.as_ptr()),
        )
    };
    assert_eq!(rc, 0, "PetscOptionsSetValue({name})");
}

fn clear_option(name: &str) {
    let n = std::ffi::CString::new(name).unwrap();
    assert_eq!(
        unsafe { ps::PetscOptionsClearValue(ptr::null_mut(), n.as_ptr()) },
        0
    );
}

/// Every rank holds the same vector: entrywise min and max over ranks agree.
fn assert_replicated(comm: &Comm, x: &[f64], what: &str) {
    let mut lo = x.to_vec();
    let mut hi = x.to_vec();
    comm.min_f64(&mut lo).unwrap();
    comm.max_f64(&mut hi).unwrap();
    for i in 0..x.len() {
        assert_eq!(
            lo[i].to_bits(),
            hi[i].to_bits(),
            "{what}: x[{i}] differs between ranks"
        );
    }
}

fn direct_only() -> LcpOptions {
    LcpOptions {
        dense_max: usize::MAX,
        direct_work_max: f64::INFINITY,
        ..LcpOptions::default()
    }
}

fn petsc_only() -> LcpOptions {
    LcpOptions {
        dense_max: 0,
        ..LcpOptions::default()
    }
}

/// Solves with `ls` (PETSc path expected) and compares with the direct path.
fn agree_with_direct(
    comm: &Comm,
    ls: &mut Linsolve,
    a: &SymCsr,
    r: &[f64],
    what: &str,
) -> LcpReport {
    let mut xd = Vec::new();
    let rd = Linsolve::new(direct_only())
        .solve_lcp(comm, a, r, &mut xd)
        .unwrap_or_else(|e| panic!("{what}, direct: {e}"));
    assert_eq!(
        (rd.petsc_solves, rd.direct_solves),
        (0, rd.pivots),
        "{what}: {rd:?}"
    );
    let mut xp = Vec::new();
    let rp = ls
        .solve_lcp(comm, a, r, &mut xp)
        .unwrap_or_else(|e| panic!("{what}, PETSc: {e}"));
    assert!(
        rp.petsc_solves >= 1 && rp.direct_solves == 0,
        "{what}: {rp:?}"
    );
    let d = rel_diff(&xp, &xd);
    assert!(
        d <= 1e-10,
        "{what}: PETSc and direct solutions differ by {d:e} (relative)"
    );
    assert!(rp.complementarity <= 1e-9, "{what}: {rp:?}");
    assert_eq!(rp.active, rd.active, "{what}: same contact set");
    assert_replicated(comm, &xp, what);
    if comm.rank() == 0 {
        eprintln!(
            "[{} ranks] {what}: n = {}, {:.1} nnz/row, active {}, pivots {} (direct {}), KSP its total {} max {}, rel. diff {d:.1e}",
            comm.size(),
            a.n,
            nnz_per_row(a),
            rp.active,
            rp.pivots,
            rd.pivots,
            rp.ksp_iterations,
            rp.ksp_iterations_max
        );
    }
    rp
}

#[test]
fn contact_lcp_over_mpi_with_gimlet_initialising_petsc() {
    // SAFETY: the host's MPI_Init, once per process.
    assert_eq!(
        unsafe { mpi::MPI_Init(ptr::null_mut(), ptr::null_mut()) },
        0
    );
    let world = Comm::world().expect("world");
    let (rank, size) = (world.rank(), world.size());
    let handlers_before = signal_handlers();
    assert!(!petsc_initialized() && !gimlet_started_petsc());

    // ---- 1. Two halves, each initialising PETSc on its own.
    let mut raw_half = unsafe { mpi::RSMPI_COMM_NULL };
    assert_eq!(
        unsafe { mpi::MPI_Comm_split(world.raw(), rank % 2, rank, &mut raw_half) },
        0
    );
    let half = Comm::dup(raw_half).expect("half");
    unsafe { mpi::MPI_Comm_free(&mut raw_half) };
    let (a, r) = obstacle(120, 0.05);
    let mut half_solver = Linsolve::new(petsc_only());
    let mut xh = Vec::new();
    if rank % 2 == 0 {
        let rep = half_solver
            .solve_lcp(&half, &a, &r, &mut xh)
            .expect("even half");
        assert!(rep.petsc_solves >= 1);
        assert!(petsc_initialized() && gimlet_started_petsc());
        let mut s = 0;
        unsafe { mpi::MPI_Comm_size(ps::PETSC_COMM_WORLD, &mut s) };
        assert_eq!(s, half.size(), "PETSC_COMM_WORLD spans the even half only");
    }
    world
        .barrier()
        .expect("barrier: the even half did not wait for the odd one");
    if rank % 2 == 1 {
        assert!(
            !petsc_initialized(),
            "the odd half has not initialised PETSc yet"
        );
        half_solver
            .solve_lcp(&half, &a, &r, &mut xh)
            .expect("odd half");
        let mut s = 0;
        unsafe { mpi::MPI_Comm_size(ps::PETSC_COMM_WORLD, &mut s) };
        assert_eq!(s, half.size(), "PETSC_COMM_WORLD spans the odd half only");
    }
    assert!(petsc_initialized() && gimlet_started_petsc());
    assert_eq!(
        signal_handlers(),
        handlers_before,
        "PETSc installed signal handlers despite -no_signal_handler"
    );
    // Both halves found the same answer (it does not depend on the ranks).
    let mut xd = Vec::new();
    Linsolve::new(direct_only())
        .solve_lcp(&world, &a, &r, &mut xd)
        .unwrap();
    assert!(rel_diff(&xh, &xd) <= 1e-10);

    // ---- 2. PETSc path against the direct path, on the world communicator
    // (PETSc is initialised everywhere now: no new initialisation).
    let mut ls = Linsolve::new(petsc_only());
    let (a, r) = obstacle(300, 0.05);
    let rep = agree_with_direct(&world, &mut ls, &a, &r, "obstacle n=300");
    assert_eq!(
        rep.petsc_types,
        Some(("cg".to_string(), "jacobi".to_string())),
        "CG + Jacobi by default"
    );
    let a = contact_strip(320, 2, 0.05, 7);
    let r = indenter_rhs(&a);
    agree_with_direct(&world, &mut ls, &a, &r, "contact strip n=320 ppc=2");
    let a = contact_strip(400, 4, 0.05, 11);
    let r = indenter_rhs(&a);
    agree_with_direct(&world, &mut ls, &a, &r, "contact strip n=400 ppc=4");
    let (a, r) = random_banded(250, 4, 0.5, 3);
    agree_with_direct(&world, &mut ls, &a, &r, "random banded n=250");
    // Near-singular (4 particles per cell, regularisation 1e-4): the block
    // exchanges stall and the primal active-set fallback takes over; the
    // PETSc path follows the same pivot sequence.
    let a = contact_strip(200, 4, 1e-4, 9);
    let r = indenter_rhs(&a);
    let rep = agree_with_direct(
        &world,
        &mut ls,
        &a,
        &r,
        "contact strip n=200 ppc=4 reg=1e-4",
    );
    assert!(rep.fallback_solves > 0, "{rep:?}");
    // Mixed: small active sets direct, large ones PETSc.
    let mut mixed = Linsolve::new(LcpOptions {
        dense_max: 100,
        ..LcpOptions::default()
    });
    let (a, r) = obstacle(300, 0.05);
    let mut xm = Vec::new();
    mixed.solve_lcp(&world, &a, &r, &mut xm).unwrap();
    let mut xd = Vec::new();
    Linsolve::new(direct_only())
        .solve_lcp(&world, &a, &r, &mut xd)
        .unwrap();
    assert!(rel_diff(&xm, &xd) <= 1e-10);

    // ---- 3. Options through the prefix.
    let mut other = Linsolve::new(LcpOptions {
        prefix: "other_".into(),
        dense_max: 0,
        ..LcpOptions::default()
    });
    set_option("-gimlet_contact_ksp_type", Some("gmres"));
    let rep = agree_with_direct(
        &world,
        &mut ls,
        &a,
        &r,
        "obstacle n=300, -gimlet_contact_ksp_type gmres",
    );
    assert_eq!(
        rep.petsc_types.as_ref().map(|t| t.0.as_str()),
        Some("gmres")
    );
    let rep = agree_with_direct(&world, &mut other, &a, &r, "obstacle n=300, prefix other_");
    assert_eq!(
        rep.petsc_types.as_ref().map(|t| t.0.as_str()),
        Some("cg"),
        "an option of another prefix does not apply"
    );
    set_option("-gimlet_contact_ksp_type", Some("cg"));
    set_option("-gimlet_contact_pc_type", Some("bjacobi"));
    let rep = agree_with_direct(&world, &mut ls, &a, &r, "obstacle n=300, bjacobi");
    assert_eq!(
        rep.petsc_types,
        Some(("cg".to_string(), "bjacobi".to_string()))
    );
    set_option("-gimlet_contact_pc_type", Some("jacobi"));
    set_option("-gimlet_contact_ksp_type", Some("no_such_krylov_method"));
    let mut x = Vec::new();
    let e = ls
        .solve_lcp(&world, &a, &r, &mut x)
        .expect_err("an unknown KSP type must fail");
    assert_eq!(e.status, Status::Petsc, "{}", e.msg);
    assert!(
        e.msg.contains("KSPSetFromOptions failed") && e.msg.contains("no_such_krylov_method"),
        "{}",
        e.msg
    );
    assert!(e.msg.contains("PETSc error"), "{}", e.msg);
    assert_eq!(x, vec![0.0; a.n]);
    clear_option("-gimlet_contact_ksp_type");
    clear_option("-gimlet_contact_pc_type");
    let rep = agree_with_direct(
        &world,
        &mut ls,
        &a,
        &r,
        "obstacle n=300 after the failed solve",
    );
    assert_eq!(
        rep.petsc_types.as_ref().map(|t| t.1.as_str()),
        Some("jacobi")
    );

    // ---- 4. A KSP that does not converge, then a normal solve again.
    ls.set_options(LcpOptions {
        max_it: 1,
        rtol: 1e-14,
        ..petsc_only()
    });
    let e = ls
        .solve_lcp(&world, &a, &r, &mut x)
        .expect_err("one CG iteration cannot reach 1e-14");
    assert_eq!(e.status, Status::Petsc);
    assert!(e.msg.contains("KSP_DIVERGED_ITS"), "{}", e.msg);
    assert!(e.msg.contains("after 1 iterations"), "{}", e.msg);
    ls.set_options(petsc_only());
    agree_with_direct(
        &world,
        &mut ls,
        &a,
        &r,
        "obstacle n=300 after KSP_DIVERGED_ITS",
    );

    // Empty and trivial problems: no PETSc, no communication needed.
    let rep = ls
        .solve_lcp(&world, &SymCsr::from_triplets(0, &[]), &[], &mut x)
        .unwrap();
    assert_eq!((rep.pivots, rep.petsc_solves), (0, 0));
    let rpos: Vec<f64> = r.iter().map(|v| v.abs()).collect();
    let rep = ls.solve_lcp(&world, &a, &rpos, &mut x).unwrap();
    assert_eq!((rep.pivots, rep.petsc_solves), (0, 0));
    assert!(x.iter().all(|&v| v == 0.0));

    // ---- 5. Teardown: drops (collective), then MPI_Finalize finalises the
    // PETSc Gimlet started.
    drop(ls);
    drop(other);
    drop(mixed);
    drop(half_solver);
    drop(half);
    drop(world);
    assert!(
        !petsc_finalized(),
        "nothing finalises PETSc before MPI_Finalize"
    );
    assert_eq!(unsafe { mpi::MPI_Finalize() }, 0, "MPI_Finalize");
    assert!(
        petsc_finalized(),
        "the MPI_COMM_SELF attribute finalised PETSc during MPI_Finalize"
    );
    if rank == 0 {
        eprintln!(
            "[{size} ranks] MPI_Finalize returned 0 and PETSc was finalised by Gimlet's callback"
        );
    }
}
