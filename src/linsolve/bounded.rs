//! The box-constrained problem of the friction solve: find `lo ≤ x ≤ hi`
//! with `w = A x + r` and, for every `i`,
//!
//! ```text
//!     xᵢ = loᵢ ⇒ wᵢ ≥ 0,   xᵢ = hiᵢ ⇒ wᵢ ≤ 0,   loᵢ < xᵢ < hiᵢ ⇒ wᵢ = 0
//! ```
//!
//! (a bounded LCP; `A` symmetric positive definite). It is the optimality
//! condition of the strictly convex QP `min ½xᵀAx + rᵀx, lo ≤ x ≤ hi`, which
//! has exactly one solution. For the tangential contact tractions `x`, the
//! bounds are `∓μ P` (Coulomb's cone at the current pressures `P`) and `w`
//! is the end-of-step slip: zero where a particle sticks, opposite to the
//! traction where it slips at the bound. `loᵢ = hiᵢ` fixes `xᵢ` (a particle
//! without pressure carries no friction); infinite bounds are allowed
//! (`μ = ∞`: stick wherever there is pressure).
//!
//! The method mirrors [`super::pivot`]: **block principal pivoting** for
//! bounded LCPs (Júdice & Pires 1994): a state assigns every unknown to
//! `F` (free), `L` (held at `lo`) or `U` (held at `hi`); `x_F` solves
//! `A_FF x_F = −r_F − A_FB x_B`; every infeasible unknown (`x_F` outside its
//! bounds, `w_L < 0`, `w_U > 0`) moves at once. When the count of
//! infeasibilities stops improving for `patience` exchanges, a **primal
//! active-set** method takes over from the projection of the iterate onto
//! the box: subspace minimisation with a step back to the first bound hit,
//! then the release of the most violating bound; the objective decreases
//! strictly, so it terminates. The linear solves go through the same
//! [`SubSolver`] as the LCP's (direct, or PETSc for large systems).
//!
//! Sign tests are relative to `max|r|` as in [`super::pivot`]; the
//! returned `x` lies within its bounds exactly.

use super::pivot::{record, residual, PivotParams, SubSolver, SubSystem};
use super::{LcpReport, SymCsr, NOT_FREE};
use crate::error::{Error, Result, Status};

/// Where an unknown is held.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Side {
    Free,
    Lo,
    Hi,
}

/// Scratch space, reused between calls.
#[derive(Default, Debug)]
pub(crate) struct Workspace {
    side: Vec<Side>,
    free: Vec<u32>,
    pos: Vec<u32>,
    rhs: Vec<f64>,
    xf: Vec<f64>,
    /// `w = A x + r` of the last iterate.
    pub(crate) w: Vec<f64>,
}

struct Problem<'a> {
    a: &'a SymCsr,
    r: &'a [f64],
    lo: &'a [f64],
    hi: &'a [f64],
    diag: &'a [f64],
    params: PivotParams,
    rmax: f64,
    tol_w: f64,
}

impl Problem<'_> {
    fn tol_x(&self, i: usize) -> f64 {
        self.tol_w / self.diag[i]
    }

    /// Whether `i` can never move (`loᵢ = hiᵢ`).
    fn fixed(&self, i: usize) -> bool {
        self.lo[i] >= self.hi[i]
    }

    /// Solves `A_FF z = −r_F − A_FB x_B` for the free set of `ws.side`
    /// (guess: `x`); `z` is left in `ws.xf`, aligned with `ws.free`.
    fn solve_free<S: SubSolver>(
        &self,
        ws: &mut Workspace,
        x: &[f64],
        solver: &mut S,
        report: &mut LcpReport,
    ) -> Result<()> {
        ws.free.clear();
        for (i, s) in ws.side.iter().enumerate() {
            if *s == Side::Free {
                ws.pos[i] = ws.free.len() as u32;
                ws.free.push(i as u32);
            } else {
                ws.pos[i] = NOT_FREE;
            }
        }
        let m = ws.free.len();
        ws.rhs.clear();
        ws.xf.clear();
        let a = self.a;
        for &i in &ws.free {
            let i = i as usize;
            let mut b = -self.r[i];
            for k in a.row_ptr[i]..a.row_ptr[i + 1] {
                let j = a.cols[k] as usize;
                if ws.pos[j] == NOT_FREE && x[j] != 0.0 {
                    b -= a.vals[k] * x[j];
                }
            }
            ws.rhs.push(b);
            ws.xf.push(x[i]);
        }
        report.pivots += 1;
        if m == 0 {
            return Ok(());
        }
        let stats = solver.solve(SubSystem {
            a,
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
                    "friction solve: the linear solve of iteration {} returned a non-finite traction at unknown {} ({m} unknowns)",
                    report.pivots, ws.free[k]
                ),
            ));
        }
        Ok(())
    }

    /// The infeasible unknowns of the current iterate (and the largest
    /// violation relative to `max|r|`).
    fn violations(&self, ws: &Workspace, x: &[f64], out: &mut Vec<(usize, Side)>) -> f64 {
        out.clear();
        let mut worst = 0.0f64;
        for i in 0..self.a.n {
            if self.fixed(i) {
                continue;
            }
            match ws.side[i] {
                Side::Free => {
                    let t = self.tol_x(i);
                    if x[i] < self.lo[i] - t {
                        out.push((i, Side::Lo));
                        worst = worst.max((self.lo[i] - x[i]) * self.diag[i] / self.rmax);
                    } else if x[i] > self.hi[i] + t {
                        out.push((i, Side::Hi));
                        worst = worst.max((x[i] - self.hi[i]) * self.diag[i] / self.rmax);
                    }
                }
                Side::Lo if ws.w[i] < -self.tol_w => {
                    out.push((i, Side::Free));
                    worst = worst.max(-ws.w[i] / self.rmax);
                }
                Side::Hi if ws.w[i] > self.tol_w => {
                    out.push((i, Side::Free));
                    worst = worst.max(ws.w[i] / self.rmax);
                }
                _ => {}
            }
        }
        worst
    }

    fn cap_error(&self, infeasible: usize, worst: f64) -> Error {
        Error::new(
            Status::Unstable,
            format!(
                "friction solve not done within max_pivots = {} iterations: {infeasible} of {} tractions still infeasible (largest violation {worst:.3e} relative to max|r| = {:.3e}, tolerance {:.1e})",
                self.params.max_pivots, self.a.n, self.rmax, self.params.feas_tol
            ),
        )
    }
}

/// Holds `x` at the bound of `side` (or leaves it for `Free`).
fn hold(i: usize, side: Side, lo: &[f64], hi: &[f64], x: &mut [f64]) {
    match side {
        Side::Lo => x[i] = lo[i],
        Side::Hi => x[i] = hi[i],
        Side::Free => {}
    }
}

/// Solves the bounded LCP (module doc). `x` in: a start (any length; it is
/// projected onto the box, missing entries are 0); out: the solution,
/// within its bounds. `diag` holds `Aᵢᵢ`; `a`, `r`, `lo ≤ hi` are assumed
/// validated (`lo ≤ 0 ≤ hi`, so `x = 0` is feasible).
#[allow(clippy::too_many_arguments)]
pub(crate) fn solve_box<S: SubSolver>(
    a: &SymCsr,
    r: &[f64],
    lo: &[f64],
    hi: &[f64],
    diag: &[f64],
    params: PivotParams,
    ws: &mut Workspace,
    x: &mut Vec<f64>,
    solver: &mut S,
) -> Result<LcpReport> {
    let n = a.n;
    let mut report = LcpReport::default();
    x.resize(n, 0.0);
    for i in 0..n {
        x[i] = x[i].clamp(lo[i], hi[i]);
    }
    ws.w.clear();
    ws.w.resize(n, 0.0);
    let rmax = r.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if rmax == 0.0 {
        x.fill(0.0);
        return Ok(report);
    }
    let pb = Problem {
        a,
        r,
        lo,
        hi,
        diag,
        params,
        rmax,
        tol_w: params.feas_tol * rmax,
    };
    ws.side.clear();
    // The start's sides: at a bound where it lies on one, except that a
    // zero start of a two-sided box (`lo < 0 < hi`) is interior.
    ws.side.extend((0..n).map(|i| {
        if pb.fixed(i) || x[i] <= lo[i] && (x[i] != 0.0 || hi[i] > 0.0 && lo[i] == 0.0) {
            Side::Lo
        } else if x[i] >= hi[i] && (x[i] != 0.0 || lo[i] < 0.0 && hi[i] == 0.0) {
            Side::Hi
        } else {
            Side::Free
        }
    }));
    ws.pos.clear();
    ws.pos.resize(n, NOT_FREE);
    let mut moves: Vec<(usize, Side)> = Vec::new();

    // Phase 1: block exchanges.
    let mut best = usize::MAX;
    let mut budget = params.patience;
    let solved = loop {
        pb.solve_free(ws, x, solver, &mut report)?;
        for (&i, &v) in ws.free.iter().zip(&ws.xf) {
            x[i as usize] = v;
        }
        residual(a, x, r, &mut ws.w);
        let worst = pb.violations(ws, x, &mut moves);
        let nv = moves.len();
        if nv == 0 {
            break true;
        }
        if report.pivots >= params.max_pivots {
            return Err(pb.cap_error(nv, worst));
        }
        if nv < best {
            best = nv;
            budget = params.patience;
        } else if budget > 0 {
            budget -= 1;
        } else {
            break false;
        }
        report.block_exchanges += 1;
        for &(i, s) in &moves {
            ws.side[i] = s;
            hold(i, s, lo, hi, x);
        }
    };

    if !solved {
        // Phase 2: primal active set from the projection onto the box.
        for i in 0..n {
            x[i] = x[i].clamp(lo[i], hi[i]);
            ws.side[i] = if pb.fixed(i) || x[i] == lo[i] && x[i] != 0.0 {
                Side::Lo
            } else if x[i] == hi[i] && x[i] != 0.0 {
                Side::Hi
            } else {
                Side::Free
            };
        }
        loop {
            // Inner: minimise over the free set, stepping back to bounds.
            while ws.side.contains(&Side::Free) {
                if report.pivots >= params.max_pivots {
                    residual(a, x, r, &mut ws.w);
                    let worst = pb.violations(ws, x, &mut moves);
                    return Err(pb.cap_error(moves.len(), worst));
                }
                pb.solve_free(ws, x, solver, &mut report)?;
                report.fallback_solves += 1;
                let mut alpha = 1.0f64;
                for (&i, &z) in ws.free.iter().zip(&ws.xf) {
                    let i = i as usize;
                    let t = pb.tol_x(i);
                    if z < lo[i] - t {
                        alpha = alpha.min((x[i] - lo[i]) / (x[i] - z));
                    } else if z > hi[i] + t {
                        alpha = alpha.min((hi[i] - x[i]) / (z - x[i]));
                    }
                }
                if alpha >= 1.0 {
                    for (&i, &z) in ws.free.iter().zip(&ws.xf) {
                        let i = i as usize;
                        x[i] = z.clamp(lo[i], hi[i]);
                    }
                    break;
                }
                for (&i, &z) in ws.free.iter().zip(&ws.xf) {
                    let i = i as usize;
                    let v = x[i] + alpha * (z - x[i]);
                    let t = pb.tol_x(i);
                    if v <= lo[i] + t && z < x[i] {
                        x[i] = lo[i];
                        ws.side[i] = Side::Lo;
                    } else if v >= hi[i] - t && z > x[i] {
                        x[i] = hi[i];
                        ws.side[i] = Side::Hi;
                    } else {
                        x[i] = v;
                    }
                }
            }
            residual(a, x, r, &mut ws.w);
            // Outer: release the bound that is violated most.
            pb.violations(ws, x, &mut moves);
            let Some(&(i, _)) = moves
                .iter()
                .max_by(|p, q| ws.w[p.0].abs().total_cmp(&ws.w[q.0].abs()))
            else {
                break;
            };
            if report.pivots >= params.max_pivots {
                let worst = pb.violations(ws, x, &mut moves);
                return Err(pb.cap_error(moves.len(), worst));
            }
            report.single_pivots += 1;
            ws.side[i] = Side::Free;
        }
    }
    for i in 0..n {
        x[i] = x[i].clamp(lo[i], hi[i]);
    }
    residual(a, x, r, &mut ws.w);
    report.active = (0..n).filter(|&i| ws.side[i] != Side::Free).count();
    let mut m = 0.0f64;
    for i in 0..n {
        // Natural residual of the box problem: |x − clamp(x − w/Aᵢᵢ)| Aᵢᵢ.
        let p = (x[i] - ws.w[i] / diag[i]).clamp(lo[i], hi[i]);
        m = m.max(((x[i] - p) * diag[i]).abs());
    }
    report.complementarity = m / rmax;
    Ok(report)
}
