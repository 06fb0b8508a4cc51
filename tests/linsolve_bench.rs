//! Where the direct path stops paying: times of one contact LCP call whose
//! answer needs exactly one linear solve over all `n` unknowns
//! (`r = -A x*` with `x* > 0`, so `F = {all}` from the start and is final),
//! through the direct path (`dense_max = ∞`, `direct_work_max = ∞`) and
//! through PETSc (`dense_max = 0`), side by side in one run, for
//! n = 8 … 8000, on contact-like strips (one row of particles, 2 or 4 per
//! cell; also numbered in a random order) and on a square block of contact
//! particles (2D coupling, the worst case for the envelope); plus the
//! effect of the warm start on the KSP iterations of multi-pivot LCPs.
//!
//! Ignored by default (it measures, it does not check). Run on 1 and 2
//! ranks:
//!
//! ```text
//! cargo test --release --test linsolve_bench -- --ignored --nocapture
//! mpiexec -n 2 target/release/deps/linsolve_bench-<hash> --ignored --nocapture
//! ```

mod linsolve_common;

use gimlet::comm::Comm;
use gimlet::linsolve::{LcpOptions, Linsolve, SymCsr};
use linsolve_common::*;
use mpi_sys as mpi;
use std::ptr;
use std::time::Instant;

/// Seconds per call of `f` (the minimum over batches, each batch at least
/// ~20 ms, at most 10 batches or 1.5 s; rank 0's clock after a barrier, the
/// batch length agreed by a max-reduction so all ranks run the same calls).
fn time_per_call(comm: &Comm, mut f: impl FnMut()) -> f64 {
    f(); // warm-up (also creates the KSP)
    let mut reps = 1usize;
    let mut best = f64::INFINITY;
    let start = Instant::now();
    for _ in 0..10 {
        comm.barrier().unwrap();
        let t = Instant::now();
        for _ in 0..reps {
            f();
        }
        let mut dt = [t.elapsed().as_secs_f64()];
        comm.max_f64(&mut dt).unwrap();
        best = best.min(dt[0] / reps as f64);
        if dt[0] < 0.02 {
            reps *= 2;
        }
        let mut el = [start.elapsed().as_secs_f64()];
        comm.max_f64(&mut el).unwrap();
        if el[0] > 1.5 {
            break;
        }
    }
    best
}

/// `r = -A x*` for `x*_i = 1 + ½ sin(0.7 i)` (all positive).
fn one_solve_rhs(a: &SymCsr) -> Vec<f64> {
    let xs: Vec<f64> = (0..a.n)
        .map(|i| 1.0 + 0.5 * (0.7 * i as f64).sin())
        .collect();
    let mut ax = vec![0.0; a.n];
    matvec(a, &xs, &mut ax);
    ax.iter().map(|v| -v).collect()
}

#[test]
#[ignore = "benchmark: prints the direct/PETSc crossover; run with --ignored --nocapture"]
fn direct_versus_petsc_crossover() {
    unsafe { mpi::MPI_Init(ptr::null_mut(), ptr::null_mut()) };
    let world = Comm::world().unwrap();
    let root = world.rank() == 0;
    let sizes = [8, 16, 32, 64, 128, 256, 512, 1000, 2000, 4000, 8000];
    for (family, ppc, reg, scramble, square) in [
        ("strip ppc=2 reg=1e-2", 2, 1e-2, false, false),
        ("strip ppc=4 reg=1e-4", 4, 1e-4, false, false),
        (
            "strip ppc=2 reg=1e-2, scrambled numbering",
            2,
            1e-2,
            true,
            false,
        ),
        (
            "square patch ppc=2 reg=1e-2 (2D coupling)",
            2,
            1e-2,
            false,
            true,
        ),
    ] {
        if root {
            eprintln!(
                "\n[{} ranks] {family}: one LCP call = one solve over all n unknowns",
                world.size()
            );
            eprintln!(
                "{:>6} {:>8} {:>12} {:>12} {:>8} {:>8} {:>12} {:>10} {:>10} {:>10}",
                "n",
                "nnz/row",
                "direct[us]",
                "PETSc [us]",
                "ratio",
                "KSP its",
                "validate[us]",
                "rel diff",
                "envelope",
                "work"
            );
        }
        for &n in &sizes {
            let rows = if square {
                (n as f64).sqrt().round() as usize
            } else {
                1
            };
            let a = contact_patch(n, rows, ppc, reg, 5);
            let a = if scramble { scrambled(&a, 13) } else { a };
            let r = one_solve_rhs(&a);
            let mut direct = Linsolve::new(LcpOptions {
                dense_max: usize::MAX,
                direct_work_max: f64::INFINITY,
                ..LcpOptions::default()
            });
            let mut petsc = Linsolve::new(LcpOptions {
                dense_max: 0,
                ..LcpOptions::default()
            });
            let mut x = Vec::new();
            let rep = petsc.solve_lcp(&world, &a, &r, &mut x).unwrap();
            assert_eq!(rep.pivots, 1, "{rep:?}");
            let mut xd = Vec::new();
            let repd = direct.solve_lcp(&world, &a, &r, &mut xd).unwrap();
            let diff = rel_diff(&x, &xd);
            let td = time_per_call(&world, || {
                direct.solve_lcp(&world, &a, &r, &mut xd).unwrap();
            });
            let tp = time_per_call(&world, || {
                petsc.solve_lcp(&world, &a, &r, &mut x).unwrap();
            });
            // The validation and the residual alone: r ≥ 0 needs no solve.
            let rpos: Vec<f64> = r.iter().map(|v| v.abs()).collect();
            let tv = time_per_call(&world, || {
                direct.solve_lcp(&world, &a, &rpos, &mut xd).unwrap();
            });
            if root {
                eprintln!(
                    "{:>6} {:>8.1} {:>12.1} {:>12.1} {:>8.2} {:>8} {:>12.1} {:>10.1e} {:>10} {:>10.2e}",
                    n,
                    nnz_per_row(&a),
                    td * 1e6,
                    tp * 1e6,
                    tp / td,
                    rep.ksp_iterations,
                    tv * 1e6,
                    diff,
                    repd.largest_envelope,
                    repd.largest_direct_work
                );
            }
        }
    }

    // Warm start: KSP iterations of LCPs needing several pivots.
    if root {
        eprintln!(
            "\n[{} ranks] warm start (previous iterate as the KSP's initial guess)",
            world.size()
        );
        eprintln!(
            "{:>28} {:>6} {:>7} {:>14} {:>14} {:>10} {:>10}",
            "problem", "n", "pivots", "KSP its cold", "KSP its warm", "cold [us]", "warm [us]"
        );
    }
    let problems: Vec<(String, SymCsr, Vec<f64>)> = vec![
        {
            let (a, r) = obstacle(1000, 0.05);
            ("obstacle eps=0.05".into(), a, r)
        },
        {
            let a = contact_strip(1000, 2, 1e-2, 9);
            let r = indenter_rhs(&a);
            ("strip ppc=2 reg=1e-2".into(), a, r)
        },
        {
            let a = contact_strip(1000, 4, 1e-4, 9);
            let r = indenter_rhs(&a);
            ("strip ppc=4 reg=1e-4".into(), a, r)
        },
        {
            let (a, r) = random_banded(1000, 6, 0.2, 9);
            ("random banded w=6".into(), a, r)
        },
    ];
    for (name, a, r) in &problems {
        let mut out = Vec::new();
        for warm in [false, true] {
            let mut ls = Linsolve::new(LcpOptions {
                dense_max: 0,
                warm_start: warm,
                ..LcpOptions::default()
            });
            let mut x = Vec::new();
            let rep = ls.solve_lcp(&world, a, r, &mut x).unwrap();
            let t = time_per_call(&world, || {
                ls.solve_lcp(&world, a, r, &mut x).unwrap();
            });
            out.push((rep, t));
        }
        if root {
            eprintln!(
                "{:>28} {:>6} {:>7} {:>14} {:>14} {:>10.0} {:>10.0}",
                name,
                a.n,
                out[0].0.pivots,
                format!(
                    "{} (max {})",
                    out[0].0.ksp_iterations, out[0].0.ksp_iterations_max
                ),
                format!(
                    "{} (max {})",
                    out[1].0.ksp_iterations, out[1].0.ksp_iterations_max
                ),
                out[0].1 * 1e6,
                out[1].1 * 1e6
            );
        }
    }
    drop(world);
    unsafe { mpi::MPI_Finalize() };
}
