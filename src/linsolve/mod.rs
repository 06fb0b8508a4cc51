//! The contact pressure solve: a linear complementarity problem (LCP) with a
//! symmetric positive definite matrix, solved by block principal pivoting;
//! its linear solves go to a redundant dense Cholesky when small and to a
//! PETSc KSP over the simulation's communicator when large.
//!
//! # What is solved
//!
//! The contact step of Ma et al. 2005 (eq. 11) has one unknown normal
//! pressure per contact particle, coupled through the grid nodes the
//! particles share, and admits compressive pressures only. With the matrix
//! `A` (symmetric positive definite: the caller's Gauss least-constraint form
//! `Tᵀ M⁻¹ T` plus a small diagonal regularisation) and the vector `r`
//! (`rᵢ < 0`: particle `i` would penetrate the indenter without contact) the
//! problem is the LCP
//!
//! ```text
//!     find x ≥ 0 such that w = A x + r ≥ 0 and xᵢ wᵢ = 0 for every i
//! ```
//!
//! (`x`: pressures, `w`: scaled end-of-step gaps). A pressure is either zero
//! with a non-negative gap (no contact) or positive with a zero gap (the
//! particle ends exactly on the surface): no tensile pressure, no
//! penetration.
//!
//! # Why block principal pivoting
//!
//! An SPD matrix is a P-matrix, so the LCP has exactly one solution and it
//! is the complementary basic solution `x_F = -A_FF⁻¹ r_F`, `x_G = 0` of one
//! particular *free set* `F`. Block principal pivoting (Júdice & Pires 1994;
//! Kim & Park's NNLS variant) guesses `F`, solves, and moves *every*
//! infeasible index (`xᵢ < 0` in `F`, `wᵢ < 0` outside) to the other side at
//! once. Unlike a one-index-at-a-time active-set loop ("solve, drop the most
//! tensile row, solve again"), whose iteration count grows with the number of
//! contact changes, it typically finishes in a few linear solves whatever
//! the size, and every iterate is an exact solve. Block exchanges can cycle;
//! when the number of infeasibilities has not improved for `patience`
//! exchanges, the driver falls back to Murty's single principal pivot with
//! the least-index rule, which terminates for any P-matrix, and returns to
//! block exchanges when the count improves (see `pivot.rs`). The start is
//! `F = {i : rᵢ < 0}`. Sign tests are relative (`wᵢ < -τ max|r|`,
//! `xᵢ < -τ max|r| / Aᵢᵢ`, `τ = feas_tol`), and the returned pressures are
//! clamped to `x ≥ 0` exactly.
//!
//! # Linear solves
//!
//! * `|F| ≤ dense_max`: dense Cholesky (`dense.rs`), redundantly on every
//!   rank, no communication: bitwise the same on any number of ranks. A
//!   non-positive pivot is `Status::Unstable` ("contact matrix is not
//!   positive definite").
//! * `|F| > dense_max`: `A_FF` as a PETSc AIJ matrix over the communicator
//!   (contiguous, nearly equal chunks of rows per rank, each assembled from
//!   the replicated CSR with exact preallocation), **CG with Jacobi** by
//!   default (Jacobi does not depend on the partition, so the answer on 1, 2
//!   or 4 ranks agrees to the solver tolerance), the previous iterate as the
//!   initial guess, and the solution gathered to every rank. The KSP has the
//!   options prefix `LcpOptions::prefix` (default `gimlet_contact_`) and
//!   reads the options database at every solve, so a host can pass
//!   `-gimlet_contact_ksp_type gmres -gimlet_contact_pc_type bjacobi` or
//!   `-gimlet_contact_ksp_monitor`. (An option that sets a type and is later
//!   removed leaves that type in place, as with any PETSc object.) A KSP that
//!   does not converge is `Status::Petsc` with PETSc's reason, e.g.
//!   `KSP_DIVERGED_ITS after 10000 iterations, residual norm …`.
//!
//! # Collective calls
//!
//! `Linsolve::solve_lcp` is collective over the communicator it is given:
//! every rank passes the same matrix and right-hand side and gets the same
//! `x` and gaps back. All branch decisions are taken from replicated data,
//! so every rank takes the same path; a problem with no `rᵢ < 0` (including
//! `n = 0`) returns `x = 0` on every rank without any communication and
//! without PETSc. Input errors are found from replicated data too, so they
//! are the same on every rank. A PETSc failure on any rank is reported on
//! every rank (one extra `MPI_Allreduce` per PETSc solve). Dropping a
//! `Linsolve` that has used PETSc is collective over that communicator (it
//! destroys its KSP and frees its communicator duplicate); one that never
//! used PETSc does no communication when dropped.
//!
//! # The PETSc lifecycle contract
//!
//! * Gimlet initialises PETSc **only if the host has not**, lazily, at the
//!   first linear solve that needs PETSc. It initialises it on the
//!   simulation's ranks only (`PETSC_COMM_WORLD` becomes a communicator of
//!   those ranks that Gimlet creates; `MPI_COMM_WORLD` is not involved), and
//!   puts `-no_signal_handler` in the options database first, so PETSc
//!   installs no signal handler (a host can still ask for PETSc's handlers
//!   with `PETSC_OPTIONS=-no_signal_handler false`).
//! * Gimlet **never finalises a PETSc it did not start**. One it started is
//!   finalised at the start of `MPI_Finalize` (a delete callback of an
//!   attribute on `MPI_COMM_SELF`, which the MPI standard runs first thing in
//!   `MPI_Finalize`). A host that initialised PETSc itself finalises it
//!   itself, after destroying the simulations that use it.
//! * PETSc's error handler stack: around its calls Gimlet pushes
//!   `PetscReturnErrorHandler` (nothing printed, nothing aborts) and pops it
//!   afterwards; every code is checked and becomes `Status::Petsc` with the
//!   call's name and PETSc's message. The PETSc objects of a solve are
//!   created and destroyed in pairs, on error paths too; each `Linsolve`
//!   keeps one KSP on its own duplicate of the communicator between solves.
//! * Several `Linsolve`s (several simulations, on different communicators)
//!   coexist; on ranks where another simulation already initialised PETSc,
//!   the others reuse it, and the ranks that have not initialise it
//!   together.
//! * Not thread-safe: a `Linsolve` is used by one thread at a time (PETSc's
//!   error handler stack and options database are process-global).

mod dense;
mod petsc;
mod pivot;
#[cfg(test)]
mod tests;

pub use dense::{cholesky_factor, cholesky_solve, NotPositiveDefinite, PIVOT_REL_TOL};
pub use petsc::{gimlet_started_petsc, insert_options};
pub use pivot::Fallback;

use crate::comm::Comm;
use crate::error::{Error, Result, Status};
use pivot::{Backend, PivotParams, SolveStats, SubSystem};

/// Marks an unknown that is not in the free set (position map).
pub(crate) const NOT_FREE: u32 = u32::MAX;

/// A symmetric sparse matrix, every rank holding the same complete copy:
/// rows `0..n` in CSR form, column indices ascending within a row, both
/// triangles stored, the diagonal stored and positive.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SymCsr {
    /// Number of rows and columns.
    pub n: usize,
    /// `row_ptr[i]..row_ptr[i + 1]` are row `i`'s entries (`n + 1` values).
    pub row_ptr: Vec<usize>,
    /// Column index of each entry.
    pub cols: Vec<u32>,
    /// Value of each entry.
    pub vals: Vec<f64>,
}

impl SymCsr {
    /// Builds the CSR form from `(row, col, value)` triplets; duplicates are
    /// summed. Both triangles must be given. (For tests and small callers;
    /// the contact assembly writes CSR directly.)
    pub fn from_triplets(n: usize, triplets: &[(usize, usize, f64)]) -> SymCsr {
        let mut t: Vec<(usize, usize, f64)> = triplets.to_vec();
        t.sort_by(|a, b| (a.0, a.1).cmp(&(b.0, b.1)));
        let mut row_ptr = vec![0usize; n + 1];
        let mut cols: Vec<u32> = Vec::with_capacity(t.len());
        let mut vals: Vec<f64> = Vec::with_capacity(t.len());
        let mut last: Option<(usize, usize)> = None;
        for &(i, j, v) in &t {
            if last == Some((i, j)) {
                *vals.last_mut().expect("an entry") += v;
            } else {
                cols.push(j as u32);
                vals.push(v);
                row_ptr[i + 1] += 1;
                last = Some((i, j));
            }
        }
        for i in 0..n {
            row_ptr[i + 1] += row_ptr[i];
        }
        SymCsr {
            n,
            row_ptr,
            cols,
            vals,
        }
    }

    /// Checks the structure and the values, and writes the diagonal into
    /// `diag`. Errors (`InvalidArgument`) name the first violation found.
    /// Symmetry is checked entry by entry to a relative `1e-12` of
    /// `sqrt(Aᵢᵢ Aⱼⱼ)`. Cost `O(nnz log(nnz per row))`.
    pub fn validate(&self, diag: &mut Vec<f64>) -> Result<()> {
        let n = self.n;
        if n > i32::MAX as usize {
            return Err(Error::arg(format!(
                "contact matrix: n = {n} unknowns exceeds PETSc's 32-bit index range ({})",
                i32::MAX
            )));
        }
        if self.row_ptr.len() != n + 1 {
            return Err(Error::arg(format!(
                "contact matrix: row_ptr has {} entries, expected n + 1 = {}",
                self.row_ptr.len(),
                n + 1
            )));
        }
        let nnz = self.cols.len();
        if self.vals.len() != nnz || self.row_ptr[0] != 0 || self.row_ptr[n] != nnz {
            return Err(Error::arg(format!(
                "contact matrix: row_ptr[0] = {}, row_ptr[n] = {}, {} column indices and {} values; expected 0, and all three equal",
                self.row_ptr[0],
                self.row_ptr[n],
                nnz,
                self.vals.len()
            )));
        }
        diag.clear();
        diag.resize(n, 0.0);
        for i in 0..n {
            let (lo, hi) = (self.row_ptr[i], self.row_ptr[i + 1]);
            if lo > hi || hi > nnz {
                return Err(Error::arg(format!(
                    "contact matrix: row_ptr is not non-decreasing at row {i} ({lo} then {hi})"
                )));
            }
            let mut prev: Option<u32> = None;
            for k in lo..hi {
                let (j, v) = (self.cols[k], self.vals[k]);
                if j as usize >= n {
                    return Err(Error::arg(format!(
                        "contact matrix: column index {j} in row {i} is out of range 0..{n}"
                    )));
                }
                if prev.is_some_and(|p| p >= j) {
                    return Err(Error::arg(format!(
                        "contact matrix: column indices of row {i} are not strictly ascending ({} then {j})",
                        prev.unwrap_or(0)
                    )));
                }
                if !v.is_finite() {
                    return Err(Error::arg(format!(
                        "contact matrix: entry ({i}, {j}) is {v}, not a finite number"
                    )));
                }
                if j as usize == i {
                    diag[i] = v;
                }
                prev = Some(j);
            }
            if !(diag[i] > 0.0) {
                return Err(Error::arg(format!(
                    "contact matrix: diagonal entry ({i}, {i}) is {} (missing or not positive); an SPD matrix has a positive diagonal",
                    diag[i]
                )));
            }
        }
        for i in 0..n {
            for k in self.row_ptr[i]..self.row_ptr[i + 1] {
                let j = self.cols[k] as usize;
                if j <= i {
                    continue;
                }
                let row_j = &self.cols[self.row_ptr[j]..self.row_ptr[j + 1]];
                let t = match row_j.binary_search(&(i as u32)) {
                    Ok(p) => self.vals[self.row_ptr[j] + p],
                    Err(_) => {
                        return Err(Error::arg(format!(
                            "contact matrix is not symmetric: entry ({i}, {j}) is stored but ({j}, {i}) is not (store both triangles)"
                        )))
                    }
                };
                let v = self.vals[k];
                if (v - t).abs() > 1e-12 * (diag[i] * diag[j]).sqrt() {
                    return Err(Error::arg(format!(
                        "contact matrix is not symmetric: entry ({i}, {j}) = {v:e} but ({j}, {i}) = {t:e}"
                    )));
                }
            }
        }
        Ok(())
    }
}

/// Options of the contact LCP solve.
#[derive(Clone, Debug, PartialEq)]
pub struct LcpOptions {
    /// PETSc options prefix of the KSP (default `gimlet_contact_`; options
    /// are then `-gimlet_contact_ksp_type`, `-gimlet_contact_pc_type`, …).
    pub prefix: String,
    /// KSP relative tolerance (default `1e-12`; PETSc's default norm for
    /// CG: the preconditioned residual relative to that of the right-hand
    /// side).
    pub rtol: f64,
    /// KSP iteration cap (default 10000).
    pub max_it: usize,
    /// Linear systems with at most this many unknowns (the current free set)
    /// are solved by dense Cholesky on every rank; larger ones by PETSc.
    /// Default [`DEFAULT_DENSE_MAX`] (see its measurement).
    pub dense_max: usize,
    /// Cap on the active-set iterations (= linear solves) of one LCP
    /// (default 200). Hitting it is `Status::Unstable`.
    pub max_pivots: usize,
    /// Relative tolerance `τ` of the sign tests (default `1e-10`): an
    /// unknown is infeasible when `xᵢ < -τ max|r| / Aᵢᵢ` (in the free set) or
    /// `wᵢ < -τ max|r|` (outside it). Must exceed the linear solver's error.
    pub feas_tol: f64,
    /// Block exchanges allowed without reducing the number of
    /// infeasibilities before single least-index pivots take over (default
    /// 3). `usize::MAX` disables the fallback (block exchanges alone may
    /// cycle; for tests).
    pub patience: usize,
    /// What follows the block exchanges when they stop reducing the number
    /// of infeasibilities (default [`Fallback::PrimalActiveSet`]).
    pub fallback: Fallback,
    /// Start each KSP solve from the previous iterate restricted to the new
    /// free set (default true; see `DEFAULT_DENSE_MAX`'s measurements).
    pub warm_start: bool,
}

/// Default [`LcpOptions::dense_max`]. Measured on this project's machine
/// (`tests/linsolve_bench.rs`, contact-like matrices with 15-25 nonzeros
/// per row): see the module README section for the table. Below it the
/// redundant dense Cholesky is faster than a PETSc KSP on 1 rank, and it
/// never communicates.
pub const DEFAULT_DENSE_MAX: usize = 48;

impl Default for LcpOptions {
    fn default() -> Self {
        LcpOptions {
            prefix: "gimlet_contact_".to_string(),
            rtol: 1e-12,
            max_it: 10_000,
            dense_max: DEFAULT_DENSE_MAX,
            max_pivots: 200,
            feas_tol: 1e-10,
            patience: 3,
            fallback: Fallback::PrimalActiveSet,
            warm_start: true,
        }
    }
}

impl LcpOptions {
    /// Checks every field; the error names the field and its bound.
    pub fn validate(&self) -> Result<()> {
        petsc::prefix_cstring(&self.prefix)?;
        if !(self.rtol > 0.0 && self.rtol < 1.0) {
            return Err(Error::arg(format!(
                "LcpOptions.rtol = {}: must be in (0, 1)",
                self.rtol
            )));
        }
        if self.max_it == 0 || self.max_it > i32::MAX as usize {
            return Err(Error::arg(format!(
                "LcpOptions.max_it = {}: must be in 1..={}",
                self.max_it,
                i32::MAX
            )));
        }
        if self.max_pivots == 0 {
            return Err(Error::arg("LcpOptions.max_pivots = 0: must be at least 1"));
        }
        if !(self.feas_tol >= 0.0 && self.feas_tol < 1.0) {
            return Err(Error::arg(format!(
                "LcpOptions.feas_tol = {}: must be in [0, 1)",
                self.feas_tol
            )));
        }
        Ok(())
    }
}

/// What one LCP solve did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LcpReport {
    /// Active-set iterations (= linear solves; 0 when `x = 0` was the answer
    /// at once).
    pub pivots: usize,
    /// Iterations that exchanged every infeasible index.
    pub block_exchanges: usize,
    /// Iterations that moved one index (Murty's least-index pivot, or the
    /// primal fallback's single-index safeguard).
    pub single_pivots: usize,
    /// Linear solves done in the primal active-set fallback (included in
    /// `pivots`).
    pub fallback_solves: usize,
    /// Linear solves done by the dense Cholesky.
    pub dense_solves: usize,
    /// Linear solves done by PETSc.
    pub petsc_solves: usize,
    /// KSP iterations, summed over the PETSc solves.
    pub ksp_iterations: usize,
    /// KSP iterations of the longest PETSc solve.
    pub ksp_iterations_max: usize,
    /// Unknowns of the largest linear system solved.
    pub largest_system: usize,
    /// Unknowns with a positive pressure at the solution.
    pub active: usize,
    /// `max_i |min(Aᵢᵢ xᵢ, wᵢ)| / max|r|` at the returned solution: zero
    /// exactly for an exact LCP solution.
    pub complementarity: f64,
    /// KSP and PC types of the last PETSc solve (None if PETSc was not used).
    pub petsc_types: Option<(String, String)>,
}

/// The contact LCP solver of one simulation: options, scratch space and,
/// once PETSc has been needed, a KSP on a duplicate of the communicator.
pub struct Linsolve {
    opts: LcpOptions,
    ws: pivot::Workspace,
    diag: Vec<f64>,
    dense: Vec<f64>,
    inv_diag: Vec<f64>,
    ksp: Option<petsc::KspSolver>,
}

impl std::fmt::Debug for Linsolve {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Linsolve")
            .field("opts", &self.opts)
            .field("petsc", &self.ksp.is_some())
            .finish()
    }
}

impl Linsolve {
    /// A solver with the given options (checked at each solve). No MPI or
    /// PETSc call.
    pub fn new(opts: LcpOptions) -> Linsolve {
        Linsolve {
            opts,
            ws: pivot::Workspace::default(),
            diag: Vec::new(),
            dense: Vec::new(),
            inv_diag: Vec::new(),
            ksp: None,
        }
    }

    /// The options.
    pub fn options(&self) -> &LcpOptions {
        &self.opts
    }

    /// Replaces the options (used from the next solve on; a new prefix takes
    /// effect only for a KSP not created yet).
    pub fn set_options(&mut self, opts: LcpOptions) {
        self.opts = opts;
    }

    /// The gaps `w = A x + r` of the last successful solve (on every rank).
    pub fn gaps(&self) -> &[f64] {
        &self.ws.w
    }

    /// Solves the LCP `x ≥ 0, w = A x + r ≥ 0, xᵢwᵢ = 0`. Collective over
    /// `comm`: every rank passes identical `a` and `r`; on return every rank
    /// holds the identical complete `x` (and [`gaps`](Self::gaps)).
    ///
    /// Errors: `InvalidArgument` for bad options, a malformed or
    /// non-symmetric matrix or a non-finite `r`; `Unstable` when the matrix
    /// is found not positive definite or the pivot cap is hit; `Petsc` for a
    /// PETSc failure or a KSP that does not converge; `InvalidState` when the
    /// host finalised PETSc before the simulation was done with it. After an
    /// error `x` holds zeros and the object is usable again.
    pub fn solve_lcp(
        &mut self,
        comm: &Comm,
        a: &SymCsr,
        r: &[f64],
        x: &mut Vec<f64>,
    ) -> Result<LcpReport> {
        let out = self.solve_inner(Some(comm), a, r, x);
        if out.is_err() {
            x.clear();
            x.resize(a.n, 0.0);
        }
        out
    }

    /// [`solve_lcp`](Self::solve_lcp) on one process, without MPI: every
    /// linear solve is dense, whatever `dense_max` says. For tests and
    /// single-process tools.
    pub fn solve_lcp_serial(
        &mut self,
        a: &SymCsr,
        r: &[f64],
        x: &mut Vec<f64>,
    ) -> Result<LcpReport> {
        let out = self.solve_inner(None, a, r, x);
        if out.is_err() {
            x.clear();
            x.resize(a.n, 0.0);
        }
        out
    }

    fn solve_inner(
        &mut self,
        comm: Option<&Comm>,
        a: &SymCsr,
        r: &[f64],
        x: &mut Vec<f64>,
    ) -> Result<LcpReport> {
        self.opts.validate()?;
        a.validate(&mut self.diag)?;
        if r.len() != a.n {
            return Err(Error::arg(format!(
                "contact right-hand side r has {} entries, the matrix has n = {} rows",
                r.len(),
                a.n
            )));
        }
        if let Some(i) = r.iter().position(|v| !v.is_finite()) {
            return Err(Error::arg(format!(
                "contact right-hand side r[{i}] = {}, not a finite number",
                r[i]
            )));
        }
        let Linsolve {
            opts,
            ws,
            diag,
            dense,
            inv_diag,
            ksp,
        } = self;
        let params = PivotParams {
            max_pivots: opts.max_pivots,
            feas_tol: opts.feas_tol,
            patience: opts.patience,
            fallback: opts.fallback,
        };
        let mut petsc_types: Option<(String, String)> = None;
        let mut solver = |sys: SubSystem<'_>| -> Result<SolveStats> {
            let m = sys.free.len();
            match comm {
                Some(comm) if m > opts.dense_max => {
                    if let Some(k) = ksp.as_ref() {
                        if !k.serves(comm)? {
                            return Err(Error::arg(
                                "solve_lcp: comm is not the communicator (or a duplicate of it) this solver first used PETSc on",
                            ));
                        }
                    } else {
                        let prefix = petsc::prefix_cstring(&opts.prefix)?;
                        *ksp = Some(petsc::KspSolver::new(comm, &prefix)?);
                    }
                    let k = ksp.as_mut().expect("created above");
                    let stats = k.solve(opts, sys)?;
                    if petsc_types.as_ref() != Some(&k.types) {
                        petsc_types = Some(k.types.clone());
                    }
                    Ok(stats)
                }
                _ => dense_solve(sys, dense, inv_diag),
            }
        };
        let mut report = pivot::solve_lcp(a, r, diag, params, ws, x, &mut solver)?;
        report.petsc_types = petsc_types;
        Ok(report)
    }
}

/// The dense path: gathers `A_FF` (lower triangle) and solves by Cholesky.
fn dense_solve(sys: SubSystem<'_>, buf: &mut Vec<f64>, inv: &mut Vec<f64>) -> Result<SolveStats> {
    let m = sys.free.len();
    buf.clear();
    buf.resize(m * m, 0.0);
    inv.clear();
    inv.resize(m, 0.0);
    let a = sys.a;
    for (k, &i) in sys.free.iter().enumerate() {
        let i = i as usize;
        let row = &mut buf[k * m..(k + 1) * m];
        for e in a.row_ptr[i]..a.row_ptr[i + 1] {
            let j = a.cols[e] as usize;
            if j > i {
                break;
            }
            let p = sys.pos[j];
            if p != NOT_FREE {
                row[p as usize] = a.vals[e];
            }
        }
    }
    if let Err(e) = cholesky_factor(buf, m, inv) {
        return Err(Error::new(
            Status::Unstable,
            format!(
                "contact matrix is not positive definite: Cholesky pivot {:.3e} at unknown {} (diagonal {:.3e}) of a {m}-unknown active set",
                e.pivot, sys.free[e.row], e.diagonal
            ),
        ));
    }
    sys.x.copy_from_slice(sys.rhs);
    cholesky_solve(buf, m, inv, sys.x);
    Ok(SolveStats {
        backend: Backend::Dense,
        iterations: 0,
    })
}
