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
//!   cycle, and it stalls on nearly singular matrices.
//!
//! The driver keeps the number of infeasibilities `|V|` of the best iterate
//! so far; a block exchange is taken when `|V|` improves on it, and at most
//! `patience` more times without improvement. Then the fallback:
//!
//! * [`Fallback::Murty`]: single principal pivots with the least-index rule
//!   (move only `min V`) until `|V|` improves again, then block exchanges
//!   with a fresh patience. `best` only decreases and the block exchanges
//!   without improvement are bounded, so the iteration ends in a pure Murty
//!   phase if not before, which terminates for any P-matrix (Murty 1974) —
//!   but it may take very many iterations.
//! * [`Fallback::PrimalActiveSet`]: a primal active-set method on the
//!   equivalent QP `min ½xᵀAx + rᵀx, x ≥ 0` (see [`primal_active_set`]),
//!   monotone in the objective, hence finite.
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
    /// Redundant envelope Cholesky on every rank.
    Direct,
    /// PETSc KSP over the communicator.
    Petsc,
}

/// What one linear solve reports back.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SolveStats {
    /// Who solved it.
    pub backend: Backend,
    /// Krylov iterations (0 for the direct path).
    pub iterations: usize,
    /// Stored entries of the Cholesky factor (0 for PETSc).
    pub envelope: usize,
    /// Multiply-adds (estimate) of the factorisation (0 for PETSc).
    pub work: f64,
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

/// Solves one `A_FF x_F = rhs`; chosen by the caller (direct or PETSc).
pub(crate) trait SubSolver {
    /// Solves `sys` in place (`sys.x` in: guess, out: solution).
    fn solve(&mut self, sys: SubSystem<'_>) -> Result<SolveStats>;
}

impl<F: FnMut(SubSystem<'_>) -> Result<SolveStats>> SubSolver for F {
    fn solve(&mut self, sys: SubSystem<'_>) -> Result<SolveStats> {
        self(sys)
    }
}

/// What follows the block exchanges when they stop making progress.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fallback {
    /// A primal active-set method on the equivalent QP
    /// `min ½xᵀAx + rᵀx, x ≥ 0` (Lawson–Hanson style, with block additions
    /// and a single-index safeguard): the objective decreases strictly, so
    /// no set repeats and it terminates; its solves are restricted to the
    /// (small) set of positive pressures.
    PrimalActiveSet,
    /// Murty's single principal pivot with the least-index rule (finite
    /// for P-matrices, but one index per solve).
    Murty,
}

/// The pivoting parameters (a subset of `LcpOptions`).
#[derive(Clone, Copy, Debug)]
pub(crate) struct PivotParams {
    /// Cap on the number of iterations (= linear solves).
    pub max_pivots: usize,
    /// Relative tolerance `τ` of the sign tests.
    pub feas_tol: f64,
    /// Block exchanges allowed without improvement before the fallback
    /// (`usize::MAX`: never fall back; may cycle).
    pub patience: usize,
    /// The fallback.
    pub fallback: Fallback,
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
    before: Vec<u32>,
    /// `w = A x + r` of the last iterate (the gaps).
    pub(crate) w: Vec<f64>,
}

/// `w = A x + r`.
pub(crate) fn residual(a: &SymCsr, x: &[f64], r: &[f64], w: &mut [f64]) {
    for i in 0..a.n {
        let (lo, hi) = (a.row_ptr[i], a.row_ptr[i + 1]);
        let mut s = r[i];
        for (&j, &v) in a.cols[lo..hi].iter().zip(&a.vals[lo..hi]) {
            s += v * x[j as usize];
        }
        w[i] = s;
    }
}

/// Counts one linear solve of `m` unknowns in `report`.
pub(crate) fn record(report: &mut LcpReport, stats: &SolveStats, m: usize) {
    match stats.backend {
        Backend::Direct => {
            report.direct_solves += 1;
            report.largest_envelope = report.largest_envelope.max(stats.envelope);
            report.largest_direct_work = report.largest_direct_work.max(stats.work);
        }
        Backend::Petsc => {
            report.petsc_solves += 1;
            report.ksp_iterations += stats.iterations;
            report.ksp_iterations_max = report.ksp_iterations_max.max(stats.iterations);
        }
    }
    report.largest_system = report.largest_system.max(m);
}

/// The fixed data of one LCP solve.
struct Problem<'a> {
    a: &'a SymCsr,
    r: &'a [f64],
    diag: &'a [f64],
    params: PivotParams,
    /// `max|r|`, the scale of the sign tests.
    rmax: f64,
    /// `τ max|r|`: the tolerance on `w`; on `xᵢ` it is `tol_w / Aᵢᵢ`.
    tol_w: f64,
}

impl Problem<'_> {
    fn tol_x(&self, i: usize) -> f64 {
        self.tol_w / self.diag[i]
    }

    /// Solves `A_FF z = -r_F` for the free set marked in `ws.in_free`
    /// (guess: `x` on it); `z` is left in `ws.xf`, aligned with `ws.free`.
    fn solve_free<S: SubSolver>(
        &self,
        ws: &mut Workspace,
        x: &[f64],
        solver: &mut S,
        report: &mut LcpReport,
    ) -> Result<()> {
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
            ws.rhs.push(-self.r[i as usize]);
            ws.xf.push(x[i as usize]);
        }
        report.pivots += 1;
        if m == 0 {
            return Ok(());
        }
        let stats = solver.solve(SubSystem {
            a: self.a,
            free: &ws.free,
            pos: &ws.pos,
            rhs: &ws.rhs,
            x: &mut ws.xf,
        })?;
        record(report, &stats, m);
        if let Some(k) = ws.xf.iter().position(|v| !v.is_finite()) {
            return Err(Error::new(
                Status::Unstable,
                format!(
                    "contact LCP: the linear solve of active-set iteration {} returned a non-finite pressure at unknown {} ({m} unknowns)",
                    report.pivots, ws.free[k]
                ),
            ));
        }
        Ok(())
    }

    /// The error for hitting the iteration cap.
    fn cap_error(&self, infeasible: usize, worst: f64) -> Error {
        Error::new(
            Status::Unstable,
            format!(
                "contact LCP not solved within max_pivots = {} active-set iterations: {infeasible} of {} unknowns still infeasible (largest violation {worst:.3e} relative to max|r| = {:.3e}, tolerance {:.1e})",
                self.params.max_pivots, self.a.n, self.rmax, self.params.feas_tol
            ),
        )
    }
}

/// Solves the LCP (see the module doc): block principal pivoting, then the
/// chosen fallback if the block exchanges stop making progress. `diag`
/// holds `Aᵢᵢ` (checked positive by the caller), `x` is resized to `n` and
/// receives the solution; `ws.w` the gaps. `a` and `r` are assumed
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
    let pb = Problem {
        a,
        r,
        diag,
        params,
        rmax,
        tol_w: params.feas_tol * rmax,
    };
    ws.in_free.clear();
    ws.in_free.extend(r.iter().map(|&v| v < 0.0));
    ws.pos.clear();
    ws.pos.resize(n, NOT_FREE);

    if !block_pivoting(&pb, ws, x, solver, &mut report)? {
        primal_active_set(&pb, ws, x, solver, &mut report)?;
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

/// Phase 1: block exchanges (with Murty's least-index pivot as fallback if
/// so chosen). Returns `true` when solved, `false` when the primal
/// active-set fallback must take over.
fn block_pivoting<S: SubSolver>(
    pb: &Problem<'_>,
    ws: &mut Workspace,
    x: &mut [f64],
    solver: &mut S,
    report: &mut LcpReport,
) -> Result<bool> {
    let mut best = usize::MAX;
    let mut budget = pb.params.patience;
    loop {
        pb.solve_free(ws, x, solver, report)?;
        for (&i, &v) in ws.free.iter().zip(&ws.xf) {
            x[i as usize] = v;
        }
        residual(pb.a, x, pb.r, &mut ws.w);

        // The infeasible set and the largest violation (relative to max|r|,
        // for the error message).
        ws.infeasible.clear();
        let mut worst = 0.0f64;
        for (i, &xi) in x.iter().enumerate() {
            if ws.in_free[i] {
                if xi < -pb.tol_x(i) {
                    ws.infeasible.push(i as u32);
                    worst = worst.max(-xi * pb.diag[i] / pb.rmax);
                }
            } else if ws.w[i] < -pb.tol_w {
                ws.infeasible.push(i as u32);
                worst = worst.max(-ws.w[i] / pb.rmax);
            }
        }
        let nv = ws.infeasible.len();
        if nv == 0 {
            return Ok(true);
        }
        if report.pivots >= pb.params.max_pivots {
            return Err(pb.cap_error(nv, worst));
        }
        let block = if nv < best {
            best = nv;
            budget = pb.params.patience;
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
        } else if pb.params.fallback == Fallback::Murty {
            report.single_pivots += 1;
            // `infeasible` is ascending: its first entry is the least index.
            flip(ws.infeasible[0] as usize, &mut ws.in_free, x);
        } else {
            return Ok(false);
        }
    }
}

/// `f(x) = ½xᵀAx + rᵀx = ½ xᵀ(w + r)` for `w = A x + r`.
fn objective(x: &[f64], w: &[f64], r: &[f64]) -> f64 {
    0.5 * x
        .iter()
        .zip(w.iter().zip(r))
        .map(|(&xi, (&wi, &ri))| xi * (wi + ri))
        .sum::<f64>()
}

/// Phase 2: a primal active-set method on `min f(x) = ½xᵀAx + rᵀx, x ≥ 0`
/// (the LCP's equivalent strictly convex QP), from a feasible start: the
/// positive part of phase 1's last iterate if its objective is below
/// `f(0) = 0`, else `x = 0`. `P` (held in `ws.in_free`) is the support of
/// `x`.
///
/// * Inner loop: `z` minimises `f` on the subspace of `P`; if `z_P ≥ 0`,
///   `x = z`; else step from `x` toward `z` as far as `x ≥ 0` allows, drop
///   the indices that reached zero, and repeat. `f` decreases along the way
///   (convexity), and the loop ends (`P` shrinks).
/// * Outer loop: with `w = A x + r`, the indices `i ∉ P` with `wᵢ < 0`
///   (descent directions) are added to `P`, all at once; if that made no
///   progress (the inner loop dropped them all again), only the most
///   negative one is added next, which by Lawson–Hanson's argument does
///   (its subspace minimiser is positive there). `f` strictly decreases
///   from one outer iteration to the next, so no set repeats: finite.
fn primal_active_set<S: SubSolver>(
    pb: &Problem<'_>,
    ws: &mut Workspace,
    x: &mut [f64],
    solver: &mut S,
    report: &mut LcpReport,
) -> Result<()> {
    let n = pb.a.n;
    // Start: the positive part of the current iterate, or zero.
    for v in x.iter_mut() {
        *v = v.max(0.0);
    }
    residual(pb.a, x, pb.r, &mut ws.w);
    if objective(x, &ws.w, pb.r) >= 0.0 {
        x.fill(0.0);
        ws.w.copy_from_slice(pb.r);
    }
    for (f, &xi) in ws.in_free.iter_mut().zip(x.iter()) {
        *f = xi > 0.0;
    }
    // After a block addition: check that it made progress (P changed).
    let mut check_block = false;
    let mut next_single = false;
    loop {
        // Inner loop: x becomes the minimiser of f on the span of P (x ≥ 0).
        while ws.in_free.iter().any(|&f| f) {
            if report.pivots >= pb.params.max_pivots {
                residual(pb.a, x, pb.r, &mut ws.w);
                let (count, worst) = outside_violations(pb, ws);
                return Err(pb.cap_error(count, worst));
            }
            pb.solve_free(ws, x, solver, report)?;
            report.fallback_solves += 1;
            // Largest step keeping x ≥ 0 toward z.
            let mut alpha = 1.0f64;
            for (&i, &z) in ws.free.iter().zip(&ws.xf) {
                let i = i as usize;
                if z < -pb.tol_x(i) {
                    alpha = alpha.min(x[i] / (x[i] - z));
                }
            }
            if alpha >= 1.0 {
                for (&i, &z) in ws.free.iter().zip(&ws.xf) {
                    x[i as usize] = z.max(0.0);
                }
                break;
            }
            for (&i, &z) in ws.free.iter().zip(&ws.xf) {
                let i = i as usize;
                let blocking = z < -pb.tol_x(i) && x[i] / (x[i] - z) <= alpha;
                let v = x[i] + alpha * (z - x[i]);
                if blocking || v <= pb.tol_x(i) {
                    x[i] = 0.0;
                    ws.in_free[i] = false;
                } else {
                    x[i] = v;
                }
            }
        }
        residual(pb.a, x, pb.r, &mut ws.w);
        if check_block {
            // The inner loop dropped every index the block added: no
            // progress; add only the most negative gap next.
            next_single = ws.in_free.iter().filter(|&&f| f).count() == ws.before.len()
                && ws.before.iter().all(|&i| ws.in_free[i as usize]);
            check_block = false;
        }

        // Outer: descent directions outside P.
        let mut most: Option<usize> = None;
        ws.infeasible.clear();
        for i in 0..n {
            if !ws.in_free[i] && ws.w[i] < -pb.tol_w {
                ws.infeasible.push(i as u32);
                if most.map_or(true, |m| ws.w[i] < ws.w[m]) {
                    most = Some(i);
                }
            }
        }
        let Some(most) = most else {
            return Ok(());
        };
        if report.pivots >= pb.params.max_pivots {
            let (count, worst) = outside_violations(pb, ws);
            return Err(pb.cap_error(count, worst));
        }
        ws.before.clear();
        ws.before
            .extend((0..n as u32).filter(|&i| ws.in_free[i as usize]));
        if next_single {
            ws.in_free[most] = true;
            report.single_pivots += 1;
            next_single = false;
        } else {
            // Of each group of coupled candidates, only the one with the
            // most negative gap: neighbours share grid nodes, and adding a
            // whole group at once mostly adds indices that the inner loop
            // then drops one solve at a time.
            for &i in &ws.infeasible {
                let i = i as usize;
                let (lo, hi) = (pb.a.row_ptr[i], pb.a.row_ptr[i + 1]);
                let local_min = pb.a.cols[lo..hi].iter().all(|&j| {
                    let j = j as usize;
                    j == i || ws.in_free[j] || ws.w[j] >= -pb.tol_w || (ws.w[i], i) < (ws.w[j], j)
                });
                if local_min {
                    ws.pos[i] = 0; // mark; applied below
                } else {
                    ws.pos[i] = NOT_FREE;
                }
            }
            for &i in &ws.infeasible {
                if ws.pos[i as usize] == 0 {
                    ws.in_free[i as usize] = true;
                }
            }
            report.block_exchanges += 1;
            check_block = true;
        }
    }
}

/// Count and largest relative size of the gaps `wᵢ < -tol` outside the free
/// set (for the cap error of phase 2).
fn outside_violations(pb: &Problem<'_>, ws: &Workspace) -> (usize, f64) {
    let mut count = 0;
    let mut worst = 0.0f64;
    for i in 0..pb.a.n {
        if !ws.in_free[i] && ws.w[i] < -pb.tol_w {
            count += 1;
            worst = worst.max(-ws.w[i] / pb.rmax);
        }
    }
    (count, worst)
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
