//! Block principal pivoting for the LCP `x ≥ 0, w = A x + r ≥ 0, xᵢwᵢ = 0`
//! with a symmetric positive definite (hence P-) matrix `A`.
//!
//! The state is the free set `F` (the unknowns allowed to be non-zero; the
//! complement `G` is held at zero). For a given `F` the *complementary basic
//! solution* is `x_F = -A_FF⁻¹ r_F`, `x_G = 0`, `w = A x + r` (so `w_F = 0`).
//! It solves the LCP exactly when it is feasible: `x_F ≥ 0` and `w_G ≥ 0`.
//! The infeasible set is `V = {i ∈ F : xᵢ < 0} ∪ {i ∈ G : wᵢ < 0}`.
//!
//! * **Block exchange** (Júdice & Pires 1994; Kim & Park's NNLS variant):
//!   move every index of `V` to the other set at once. This usually ends in
//!   a handful of iterations even for thousands of unknowns, but it can
//!   cycle.
//! * **Murty's single principal pivot** with the least-index rule: move only
//!   `min V`. For a P-matrix this terminates finitely from any start
//!   (Murty 1974), but may take many iterations.
//!
//! The driver keeps the number of infeasibilities `|V|` of the best iterate so
//! far; a block exchange is taken when `|V|` improves on it, and at most
//! `patience` more times without improvement; after that it takes single
//! least-index pivots until `|V|` improves again (then block exchanges resume,
//! with a fresh patience). `best` only decreases and the block exchanges
//! without improvement are bounded, so the iteration ends in a pure Murty
//! phase if not before: finite termination for any P-matrix.
//!
//! Sign tests are relative, so that rounding does not flip a decision:
//! `wᵢ < -τ·max|r|` and `xᵢ < -τ·max|r|/Aᵢᵢ` (`x` has the units of `r/A`),
//! with `τ = feas_tol`. All decisions are taken from data every rank holds
//! identically, so every rank takes the same branch.
//!
//! This module knows nothing of MPI or PETSc: the linear solves are done by
//! a callback ([`SubSolver`]) that the caller chooses per solve.

use super::{LcpReport, SymCsr, NOT_FREE};
use crate::error::{Error, Result, Status};

/// Which solver did a linear solve.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Backend {
    /// Redundant dense Cholesky on every rank.
    Dense,
    /// PETSc KSP over the communicator.
    Petsc,
}

/// What one linear solve reports back.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SolveStats {
    /// Who solved it.
    pub backend: Backend,
    /// Krylov iterations (0 for the dense path).
    pub iterations: usize,
}

/// One linear solve `A_FF x_F = rhs` handed to the [`SubSolver`].
pub(crate) struct SubSystem<'a> {
    /// The matrix (all of it; only the rows and columns in `free` are used).
    pub a: &'a SymCsr,
    /// The free set, ascending.
    pub free: &'a [u32],
    /// `pos[i]` is the position of `i` in `free`, or [`NOT_FREE`].
    pub pos: &'a [u32],
    /// Right-hand side, `rhs[k]` for unknown `free[k]`.
    pub rhs: &'a [f64],
    /// In: an initial guess (the previous iterate restricted to `free`, zero
    /// for the indices just freed). Out: the solution.
    pub x: &'a mut [f64],
}

/// Solves one `A_FF x_F = rhs`; chosen by the caller (dense or PETSc).
pub(crate) trait SubSolver {
    /// Solves `sys` in place (`sys.x` in: guess, out: solution).
    fn solve(&mut self, sys: SubSystem<'_>) -> Result<SolveStats>;
}

impl<F: FnMut(SubSystem<'_>) -> Result<SolveStats>> SubSolver for F {
    fn solve(&mut self, sys: SubSystem<'_>) -> Result<SolveStats> {
        self(sys)
    }
}

/// The pivoting parameters (a subset of `LcpOptions`).
#[derive(Clone, Copy, Debug)]
pub(crate) struct PivotParams {
    /// Cap on the number of iterations (= linear solves).
    pub max_pivots: usize,
    /// Relative tolerance `τ` of the sign tests.
    pub feas_tol: f64,
    /// Block exchanges allowed without improvement before the single-pivot
    /// fallback (`usize::MAX`: never fall back; may cycle).
    pub patience: usize,
}

/// Scratch space of the driver, reused between calls (grows, never shrinks).
#[derive(Default, Debug)]
pub(crate) struct Workspace {
    in_free: Vec<bool>,
    free: Vec<u32>,
    pos: Vec<u32>,
    rhs: Vec<f64>,
    xf: Vec<f64>,
    infeasible: Vec<u32>,
    /// `w = A x + r` of the last iterate (the gaps).
    pub(crate) w: Vec<f64>,
}

/// `w = A x + r`.
fn residual(a: &SymCsr, x: &[f64], r: &[f64], w: &mut [f64]) {
    for i in 0..a.n {
        let (lo, hi) = (a.row_ptr[i], a.row_ptr[i + 1]);
        let mut s = r[i];
        for (&j, &v) in a.cols[lo..hi].iter().zip(&a.vals[lo..hi]) {
            s += v * x[j as usize];
        }
        w[i] = s;
    }
}

/// Solves the LCP with block principal pivoting (see the module doc).
/// `diag` holds `Aᵢᵢ` (checked positive by the caller), `x` is resized to `n`
/// and receives the solution; `ws.w` the gaps. `a` and `r` are assumed
/// validated.
pub(crate) fn solve_lcp<S: SubSolver>(
    a: &SymCsr,
    r: &[f64],
    diag: &[f64],
    params: PivotParams,
    ws: &mut Workspace,
    x: &mut Vec<f64>,
    solver: &mut S,
) -> Result<LcpReport> {
    let n = a.n;
    let mut report = LcpReport::default();
    x.clear();
    x.resize(n, 0.0);
    ws.w.clear();
    ws.w.extend_from_slice(r);
    if !r.iter().any(|&v| v < 0.0) {
        // x = 0 is the solution: w = r ≥ 0 and x·w = 0. No solve at all.
        return Ok(report);
    }
    let rmax = r.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let tol_w = params.feas_tol * rmax;

    ws.in_free.clear();
    ws.in_free.extend(r.iter().map(|&v| v < 0.0));
    ws.pos.clear();
    ws.pos.resize(n, NOT_FREE);

    let mut best = usize::MAX;
    let mut budget = params.patience;
    loop {
        // The free set, ascending, and the positions of its members.
        ws.free.clear();
        for (i, &f) in ws.in_free.iter().enumerate() {
            if f {
                ws.pos[i] = ws.free.len() as u32;
                ws.free.push(i as u32);
            } else {
                ws.pos[i] = NOT_FREE;
            }
        }
        let m = ws.free.len();
        ws.rhs.clear();
        ws.xf.clear();
        for &i in &ws.free {
            ws.rhs.push(-r[i as usize]);
            // Previous iterate: its value if it stayed free, 0 if just freed.
            ws.xf.push(x[i as usize]);
        }
        if m > 0 {
            let stats = solver.solve(SubSystem {
                a,
                free: &ws.free,
                pos: &ws.pos,
                rhs: &ws.rhs,
                x: &mut ws.xf,
            })?;
            match stats.backend {
                Backend::Dense => report.dense_solves += 1,
                Backend::Petsc => {
                    report.petsc_solves += 1;
                    report.ksp_iterations += stats.iterations;
                    report.ksp_iterations_max = report.ksp_iterations_max.max(stats.iterations);
                }
            }
            report.largest_system = report.largest_system.max(m);
        }
        report.pivots += 1;
        for (&i, &v) in ws.free.iter().zip(&ws.xf) {
            if !v.is_finite() {
                return Err(Error::new(
                    Status::Unstable,
                    format!(
                        "contact LCP: the linear solve of active-set iteration {} returned a non-finite pressure at unknown {i} ({m} unknowns)",
                        report.pivots
                    ),
                ));
            }
            x[i as usize] = v;
        }
        residual(a, x, r, &mut ws.w);

        // The infeasible set and the largest violation (relative to the
        // tolerance scale, for the error message).
        ws.infeasible.clear();
        let mut worst = 0.0f64;
        for i in 0..n {
            if ws.in_free[i] {
                let tol_x = tol_w / diag[i];
                if x[i] < -tol_x {
                    ws.infeasible.push(i as u32);
                    worst = worst.max(-x[i] * diag[i] / rmax);
                }
            } else if ws.w[i] < -tol_w {
                ws.infeasible.push(i as u32);
                worst = worst.max(-ws.w[i] / rmax);
            }
        }
        let nv = ws.infeasible.len();
        if nv == 0 {
            break;
        }
        if report.pivots >= params.max_pivots {
            return Err(Error::new(
                Status::Unstable,
                format!(
                    "contact LCP not solved within max_pivots = {} active-set iterations: {nv} of {n} unknowns still infeasible (largest violation {worst:.3e} relative to max|r| = {rmax:.3e}, tolerance {:.1e})",
                    params.max_pivots, params.feas_tol
                ),
            ));
        }
        let block = if nv < best {
            best = nv;
            budget = params.patience;
            true
        } else if budget > 0 {
            budget -= 1;
            true
        } else {
            false
        };
        if block {
            report.block_exchanges += 1;
            for &i in &ws.infeasible {
                flip(i as usize, &mut ws.in_free, x);
            }
        } else {
            report.single_pivots += 1;
            // `infeasible` is ascending: its first entry is the least index.
            flip(ws.infeasible[0] as usize, &mut ws.in_free, x);
        }
    }

    // Feasible within the tolerance: clamp the (tiny) negative pressures to
    // zero so that x ≥ 0 holds exactly, and recompute the gaps.
    let mut clamped = false;
    for v in x.iter_mut() {
        if *v < 0.0 {
            *v = 0.0;
            clamped = true;
        }
    }
    if clamped {
        residual(a, x, r, &mut ws.w);
    }
    report.active = x.iter().filter(|&&v| v > 0.0).count();
    report.complementarity = complementarity(x, &ws.w, diag, rmax);
    Ok(report)
}

/// Moves `i` to the other set; a leaving unknown is set to zero.
#[inline]
fn flip(i: usize, in_free: &mut [bool], x: &mut [f64]) {
    in_free[i] = !in_free[i];
    if !in_free[i] {
        x[i] = 0.0;
    }
}

/// The natural residual `max_i |min(Aᵢᵢ xᵢ, wᵢ)| / max|r|`: zero exactly
/// when `x ≥ 0`, `w ≥ 0` and `xᵢwᵢ = 0` for all `i`.
pub(crate) fn complementarity(x: &[f64], w: &[f64], diag: &[f64], rmax: f64) -> f64 {
    if rmax == 0.0 {
        return 0.0;
    }
    let mut m = 0.0f64;
    for i in 0..x.len() {
        m = m.max((diag[i] * x[i]).min(w[i]).abs());
    }
    m / rmax
}
