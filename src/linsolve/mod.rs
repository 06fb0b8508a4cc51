//! The contact pressure solve: a linear complementarity problem (LCP) with a
//! symmetric positive definite matrix, solved by block principal pivoting
//! with a primal active-set fallback; its linear solves go to a redundant
//! direct solver (envelope Cholesky) on every rank, or to a PETSc KSP over
//! the simulation's communicator when the system is too large for it.
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
//! penetration. It is also the optimality condition of the strictly convex
//! QP `min ½xᵀAx + rᵀx` subject to `x ≥ 0`.
//!
//! # Why block principal pivoting, and the fallback
//!
//! An SPD matrix is a P-matrix, so the LCP has exactly one solution and it
//! is the complementary basic solution `x_F = -A_FF⁻¹ r_F`, `x_G = 0` of one
//! particular *free set* `F`. Block principal pivoting (Júdice & Pires 1994;
//! Kim & Park's NNLS variant) guesses `F`, solves, and moves *every*
//! infeasible index (`xᵢ < 0` in `F`, `wᵢ < 0` outside) to the other side at
//! once. Unlike a one-index-at-a-time active-set loop ("solve, drop the most
//! tensile row, solve again"), whose iteration count grows with the number of
//! contact changes, it typically finishes in 2-5 linear solves whatever the
//! size (measured: 3 solves for 1000 contact-like unknowns, 5 for a
//! 1000-unknown obstacle problem), and every iterate is an exact solve. The
//! start is `F = {i : rᵢ < 0}`.
//!
//! Block exchanges can cycle (`tests.rs` has a 5-unknown example with a
//! period-3 cycle), and they stall on the nearly singular matrices that
//! several contact particles per grid cell give (`Tᵀ M⁻¹ T` has rank about
//! the number of node columns; the regularisation alone sets the
//! conditioning). When the number of infeasibilities has not improved for
//! `patience` exchanges (default 3), the driver switches to its fallback:
//!
//! * [`Fallback::PrimalActiveSet`] (default): a primal active-set method on
//!   the QP (Lawson–Hanson style: subspace minimiser, step back to keep
//!   `x ≥ 0`, drop what reaches zero; add descent directions `wᵢ < 0`, one
//!   per coupled group, or the single most negative one when a group
//!   addition made no progress). The objective decreases strictly, so it
//!   terminates; its solves involve only the positive pressures.
//! * [`Fallback::Murty`]: Murty's single principal pivot with the
//!   least-index rule (finite for any P-matrix), returning to block
//!   exchanges when the count improves.
//!
//! Measured on contact-like strips with 4 particles per cell and
//! regularisation 1e-4 (`tests/linsolve_bench.rs`, `linsolve_common`):
//! Murty's rule did not finish within 3000 solves for 400 or 1000 unknowns;
//! the primal fallback takes 53 solves for 200 unknowns, 185 for 1000
//! (118 positive pressures). With regularisation 1e-2 (2 per cell) block
//! exchanges alone finish in 3. The caller's regularisation therefore
//! decides the cost: keep it as large as accuracy allows.
//!
//! Sign tests are relative (`wᵢ < -τ max|r|`, `xᵢ < -τ max|r| / Aᵢᵢ`,
//! `τ = feas_tol`), and the returned pressures are clamped to `x ≥ 0`
//! exactly. All decisions are made from replicated data.
//!
//! # Linear solves
//!
//! * **Direct** (`|F| ≤ dense_max` and an estimated factorisation cost of
//!   at most `direct_work_max` multiply-adds): `A_FF` is reordered by
//!   reverse Cuthill–McKee (`ordering.rs`, so the caller's numbering of the
//!   particles does not matter) and factored by an envelope Cholesky
//!   (`cholesky.rs`), redundantly on every rank, no communication: bitwise
//!   the same answer on any number of ranks. Contact sets along an indenter
//!   surface are quasi one-dimensional, so the envelope is a narrow band:
//!   8000 unknowns factor in 2.5 ms. A non-positive pivot is
//!   `Status::Unstable` ("contact matrix is not positive definite").
//! * **PETSc** (otherwise): `A_FF` as a PETSc AIJ matrix over the
//!   communicator (contiguous, nearly equal chunks of rows per rank, each
//!   assembled from the replicated CSR with exact preallocation), **CG with
//!   Jacobi** by default (Jacobi does not depend on the partition, so the
//!   answer on 1, 2 or 4 ranks agrees to the solver tolerance: measured
//!   identical iteration counts and ≤ 1e-10 relative differences), the
//!   previous iterate as the initial guess (14-37 % fewer KSP iterations on
//!   multi-pivot LCPs of 1000 unknowns), and the solution gathered to every
//!   rank. The KSP has the options prefix
//!   `LcpOptions::prefix` (default `gimlet_contact_`) and reads the options
//!   database at every solve, so a host can pass
//!   `-gimlet_contact_ksp_type gmres -gimlet_contact_pc_type bjacobi` or
//!   `-gimlet_contact_ksp_monitor`. (An option that sets a type and is later
//!   removed leaves that type in place, as with any PETSc object.) A KSP that
//!   does not converge is `Status::Petsc` with PETSc's reason, e.g.
//!   `KSP_DIVERGED_ITS after 10000 iterations, residual norm …`. Setting
//!   `dense_max = 0` sends every solve to PETSc.
//!
//! Where the direct path stops paying (`tests/linsolve_bench.rs`, 1 rank,
//! one solve over all `n` unknowns, times per LCP call; the machine is
//! shared, so single figures vary by up to 2× between runs, the ratios
//! less):
//!
//! | matrix | n | direct | PETSc CG+Jacobi | KSP its |
//! |---|---|---|---|---|
//! | strip, 2 per cell, reg 1e-2 | 64 | 11 µs | 76 µs | 46 |
//! | | 1000 | 0.18 ms | 1.0 ms | 77 |
//! | | 8000 | 2.5 ms | 14 ms | 77 |
//! | strip, 4 per cell, reg 1e-4 | 1000 | 0.32 ms | 1.6 ms | 141 |
//! | 2D block of particles (~34 nnz/row) | 2000 | 14 ms (1.4e7 madds) | 25 ms | 259 |
//! | | 4000 | 69 ms (6.1e7 madds) | 49 ms | 256 |
//!
//! PETSc has a floor of about 35 µs per solve on one rank, and on two ranks
//! of this 2-core machine (shared with other jobs) each CG iteration pays
//! the latency of two reductions: on the strips PETSc was 3-100× slower than
//! the redundant direct solve there, and the 2D block crossed over at 4000
//! unknowns as on one rank. CG's answer is also only as good as
//! `cond(A_FF) · rtol`: on the near-singular strip (4 per cell, reg 1e-4)
//! it differed from the direct one by 1e-8 to 3e-7 relative, where the
//! direct path is exact to rounding and bitwise rank-invariant. Hence the
//! defaults `dense_max = 8000` and `direct_work_max = 3e7` multiply-adds
//! (the crossover of the 2D worst case); PETSc serves the rare large, wide
//! systems and hosts that ask for it.
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

mod bounded;
mod cholesky;
mod ordering;
mod petsc;
mod pivot;
#[cfg(test)]
mod tests;

pub use cholesky::{NotPositiveDefinite, ProfileCholesky, PIVOT_REL_TOL};
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
        t.sort_by_key(|e| (e.0, e.1));
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
        for (i, d) in diag.iter_mut().enumerate() {
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
                    *d = v;
                }
                prev = Some(j);
            }
            if d.is_nan() || *d <= 0.0 {
                return Err(Error::arg(format!(
                    "contact matrix: diagonal entry ({i}, {i}) is {d} (missing or not positive); an SPD matrix has a positive diagonal"
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
    /// may be solved by the direct path (envelope Cholesky, redundantly on
    /// every rank); larger ones go to PETSc. Default [`DEFAULT_DENSE_MAX`].
    pub dense_max: usize,
    /// ... and only if the envelope factorisation costs at most this many
    /// multiply-adds (after the reverse Cuthill–McKee ordering); above it
    /// PETSc is used. Default [`DEFAULT_DIRECT_WORK_MAX`].
    pub direct_work_max: f64,
    /// Cap on the active-set iterations (= linear solves) of one LCP
    /// (default 200), raised to `pivots_per_unknown` times the number of
    /// unknowns for larger systems. Hitting it is `Status::Unstable`.
    pub max_pivots: usize,
    /// Iterations allowed per unknown (default 4): the cap is
    /// `max(max_pivots, pivots_per_unknown · n)`. A large contact set (the
    /// 6-level multiscale indentation: 169 unknowns) can need more than a
    /// fixed 200 single pivots once the block exchanges stop improving;
    /// 0 makes `max_pivots` the cap whatever the size.
    pub pivots_per_unknown: usize,
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

/// Default [`LcpOptions::dense_max`]: the direct path was 4-6× faster than
/// PETSc up to this size on contact-like strips (module doc, table).
pub const DEFAULT_DENSE_MAX: usize = 8000;

/// Default [`LcpOptions::direct_work_max`] (multiply-adds): the measured
/// crossover of a 2D block of contact particles, the worst case for the
/// envelope (about 30 ms of factorisation on this machine).
pub const DEFAULT_DIRECT_WORK_MAX: f64 = 3e7;

impl Default for LcpOptions {
    fn default() -> Self {
        LcpOptions {
            prefix: "gimlet_contact_".to_string(),
            rtol: 1e-12,
            max_it: 10_000,
            dense_max: DEFAULT_DENSE_MAX,
            direct_work_max: DEFAULT_DIRECT_WORK_MAX,
            max_pivots: 200,
            pivots_per_unknown: 4,
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
        if self.direct_work_max.is_nan() || self.direct_work_max < 0.0 {
            return Err(Error::arg(format!(
                "LcpOptions.direct_work_max = {}: must be a number >= 0 (infinity allowed)",
                self.direct_work_max
            )));
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
    /// Linear solves done by the direct path (envelope Cholesky).
    pub direct_solves: usize,
    /// Linear solves done by PETSc.
    pub petsc_solves: usize,
    /// KSP iterations, summed over the PETSc solves.
    pub ksp_iterations: usize,
    /// KSP iterations of the longest PETSc solve.
    pub ksp_iterations_max: usize,
    /// Unknowns of the largest linear system solved.
    pub largest_system: usize,
    /// Stored entries of the largest envelope Cholesky factor (direct path).
    pub largest_envelope: usize,
    /// Multiply-adds (estimate) of the largest direct factorisation.
    pub largest_direct_work: f64,
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
    bws: bounded::Workspace,
    diag: Vec<f64>,
    direct: Direct,
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
            bws: bounded::Workspace::default(),
            diag: Vec::new(),
            direct: Direct::default(),
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
        let out = self.solve_inner(Some(comm), a, r, None, x);
        if out.is_err() {
            x.clear();
            x.resize(a.n, 0.0);
        }
        out
    }

    /// Solves the bounded problem `lo ≤ x ≤ hi`, `w = A x + r` with `wᵢ ≥ 0`
    /// where `xᵢ = loᵢ`, `wᵢ ≤ 0` where `xᵢ = hiᵢ` and `wᵢ = 0` in between
    /// (the friction tractions under Coulomb's bounds; see `bounded.rs`),
    /// by the same linear solves as [`solve_lcp`](Self::solve_lcp).
    /// `x` in: a start (projected onto the box); out: the solution, on every
    /// rank. `lo ≤ 0 ≤ hi` is required (infinite bounds allowed); the
    /// residual `w` is then in [`box_residual`](Self::box_residual).
    /// Collective over `comm` when given (None: serial, every solve direct).
    /// Errors as for `solve_lcp`; after one `x` holds zeros.
    pub fn solve_box(
        &mut self,
        comm: Option<&Comm>,
        a: &SymCsr,
        r: &[f64],
        lo: &[f64],
        hi: &[f64],
        x: &mut Vec<f64>,
    ) -> Result<LcpReport> {
        let out = if lo.len() != a.n || hi.len() != a.n {
            Err(Error::arg(format!(
                "friction bounds: lo has {} and hi {} entries, the matrix has n = {} rows",
                lo.len(),
                hi.len(),
                a.n
            )))
        } else if let Some(i) = (0..a.n).find(|&i| !(lo[i] <= 0.0 && hi[i] >= 0.0)) {
            Err(Error::arg(format!(
                "friction bounds: lo[{i}] = {} and hi[{i}] = {} must satisfy lo <= 0 <= hi",
                lo[i], hi[i]
            )))
        } else {
            self.solve_inner(comm, a, r, Some((lo, hi)), x)
        };
        if out.is_err() {
            x.clear();
            x.resize(a.n, 0.0);
        }
        out
    }

    /// The residual `w = A x + r` of the last successful
    /// [`solve_box`](Self::solve_box).
    pub fn box_residual(&self) -> &[f64] {
        &self.bws.w
    }

    /// [`solve_lcp`](Self::solve_lcp) on one process, without MPI: every
    /// linear solve is direct, whatever `dense_max` says. For tests and
    /// single-process tools.
    pub fn solve_lcp_serial(
        &mut self,
        a: &SymCsr,
        r: &[f64],
        x: &mut Vec<f64>,
    ) -> Result<LcpReport> {
        let out = self.solve_inner(None, a, r, None, x);
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
        bounds: Option<(&[f64], &[f64])>,
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
            bws,
            diag,
            direct,
            ksp,
        } = self;
        let params = PivotParams {
            max_pivots: opts
                .max_pivots
                .max(opts.pivots_per_unknown.saturating_mul(a.n)),
            feas_tol: opts.feas_tol,
            patience: opts.patience,
            fallback: opts.fallback,
        };
        let mut petsc_types: Option<(String, String)> = None;
        let mut solver = |sys: SubSystem<'_>| -> Result<SolveStats> {
            let m = sys.free.len();
            // Every input of this decision is replicated: all ranks agree.
            let direct_ok = match comm {
                None => true,
                Some(_) if m > opts.dense_max => false,
                Some(_) => direct.prepare(&sys) <= opts.direct_work_max,
            };
            if direct_ok {
                if comm.is_none() {
                    direct.prepare(&sys);
                }
                return direct.solve(sys);
            }
            let comm = comm.expect("the PETSc path has a communicator");
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
        };
        let mut report = match bounds {
            None => pivot::solve_lcp(a, r, diag, params, ws, x, &mut solver)?,
            Some((lo, hi)) => bounded::solve_box(a, r, lo, hi, diag, params, bws, x, &mut solver)?,
        };
        report.petsc_types = petsc_types;
        Ok(report)
    }
}

/// Scratch of the direct path.
#[derive(Clone, Debug, Default)]
pub(crate) struct Direct {
    rcm: ordering::Rcm,
    chol: ProfileCholesky,
    first: Vec<usize>,
    b: Vec<f64>,
}

impl Direct {
    /// Orders `A_FF` (reverse Cuthill–McKee) and computes its envelope;
    /// returns the multiply-adds the factorisation will take (an upper
    /// bound, `Σ_i len_i² / 2` over the envelope rows).
    pub(crate) fn prepare(&mut self, sys: &SubSystem<'_>) -> f64 {
        let a = sys.a;
        self.rcm.order(a, sys.free, sys.pos);
        let (perm, inv) = (&self.rcm.perm, &self.rcm.inv);
        self.first.clear();
        for (new, &k) in perm.iter().enumerate() {
            let g = sys.free[k as usize] as usize;
            let mut f = new;
            for &j in &a.cols[a.row_ptr[g]..a.row_ptr[g + 1]] {
                let p = sys.pos[j as usize];
                if p != NOT_FREE {
                    f = f.min(inv[p as usize] as usize);
                }
            }
            self.first.push(f);
        }
        ProfileCholesky::flops_estimate(&self.first)
    }

    /// Factors and solves (after [`prepare`](Self::prepare) on the same
    /// system). Redundant on every rank, no communication, bitwise the same
    /// everywhere.
    pub(crate) fn solve(&mut self, sys: SubSystem<'_>) -> Result<SolveStats> {
        let m = sys.free.len();
        let a = sys.a;
        let (perm, inv) = (&self.rcm.perm, &self.rcm.inv);
        self.chol.reset(&self.first);
        for (new, &k) in perm.iter().enumerate() {
            let g = sys.free[k as usize] as usize;
            for e in a.row_ptr[g]..a.row_ptr[g + 1] {
                let p = sys.pos[a.cols[e] as usize];
                if p != NOT_FREE {
                    let nj = inv[p as usize] as usize;
                    if nj <= new {
                        self.chol.set(new, nj, a.vals[e]);
                    }
                }
            }
        }
        if let Err(e) = self.chol.factor() {
            return Err(Error::new(
                Status::Unstable,
                format!(
                    "contact matrix is not positive definite: Cholesky pivot {:.3e} at unknown {} (diagonal {:.3e}) of a {m}-unknown active set",
                    e.pivot,
                    sys.free[perm[e.row] as usize],
                    e.diagonal
                ),
            ));
        }
        self.b.clear();
        self.b.extend(perm.iter().map(|&k| sys.rhs[k as usize]));
        self.chol.solve(&mut self.b);
        for (new, &k) in perm.iter().enumerate() {
            sys.x[k as usize] = self.b[new];
        }
        Ok(SolveStats {
            backend: Backend::Direct,
            iterations: 0,
            envelope: self.chol.envelope(),
            work: ProfileCholesky::flops_estimate(&self.first),
        })
    }
}

/// The direct path: `A_FF` in reverse Cuthill–McKee order, envelope
/// Cholesky, two triangular solves.
#[cfg(test)]
pub(crate) fn direct_solve(sys: SubSystem<'_>, d: &mut Direct) -> Result<SolveStats> {
    d.prepare(&sys);
    d.solve(sys)
}
