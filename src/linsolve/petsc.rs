//! PETSc for the contact solve: the lifecycle (initialise only when the host
//! has not, on the simulation's ranks only; finalise only what Gimlet
//! started, at `MPI_Finalize`), error mapping, and the distributed KSP solve
//! of one `A_FF x_F = b_F`.
//!
//! See the `linsolve` module documentation for the contract with hosts.

use super::pivot::{Backend, SolveStats, SubSystem};
use super::LcpOptions;
use crate::comm::{Comm, RawComm};
use crate::error::{Error, Result, Status};
use mpi_sys as mpi;
use petsc_sys as ps;
use std::ffi::{CStr, CString};
use std::os::raw::{c_char, c_int, c_void};
use std::ptr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

// ------------------------------------------------------------------ errors

/// The `Error` for a failed PETSc call: the call's name, PETSc's generic text
/// for the code and the specific message of the error (from
/// `PetscErrorMessage`), and the code.
fn petsc_error(call: &str, code: ps::PetscErrorCode) -> Error {
    let mut text: *const c_char = ptr::null();
    let mut specific: *mut c_char = ptr::null_mut();
    // SAFETY: PetscErrorMessage only reads static tables and the last error's
    // message buffer; both outputs are valid pointers.
    let rc = unsafe { ps::PetscErrorMessage(code, &mut text, &mut specific) };
    let cstr = |p: *const c_char| {
        if p.is_null() {
            String::new()
        } else {
            // SAFETY: PETSc returns NUL-terminated strings it owns.
            unsafe { CStr::from_ptr(p) }
                .to_string_lossy()
                .trim()
                .to_string()
        }
    };
    let (text, specific) = if rc == 0 {
        (cstr(text), cstr(specific))
    } else {
        (String::new(), String::new())
    };
    let what = match (text.is_empty(), specific.is_empty()) {
        (true, true) => "no message".to_string(),
        (false, true) => text,
        (true, false) => specific,
        (false, false) => format!("{text}: {specific}"),
    };
    Error::new(
        Status::Petsc,
        format!("{call} failed: {what} (PETSc error {code})"),
    )
}

/// `Ok` when `code` is 0, else the mapped error naming `call`.
fn check(code: ps::PetscErrorCode, call: &str) -> Result<()> {
    if code == 0 {
        Ok(())
    } else {
        Err(petsc_error(call, code))
    }
}

fn check_mpi(code: c_int, call: &str) -> Result<()> {
    if code == 0 {
        Ok(())
    } else {
        Err(Error::new(
            Status::Mpi,
            format!("{call} failed with MPI error {code} in the contact solve"),
        ))
    }
}

/// While alive, PETSc errors return their code silently
/// (`PetscReturnErrorHandler` on top of the handler stack): nothing is
/// printed and nothing aborts. Dropping it pops exactly that handler, so the
/// host's handlers below are untouched.
struct QuietErrors(());

impl QuietErrors {
    fn push() -> Result<QuietErrors> {
        // SAFETY: PETSc is initialised (callers check first).
        check(
            unsafe {
                ps::PetscPushErrorHandler(Some(ps::PetscReturnErrorHandler), ptr::null_mut())
            },
            "PetscPushErrorHandler",
        )?;
        Ok(QuietErrors(()))
    }
}

impl Drop for QuietErrors {
    fn drop(&mut self) {
        // SAFETY: pops the handler pushed in `push`.
        unsafe { ps::PetscPopErrorHandler() };
    }
}

// --------------------------------------------------------------- lifecycle

/// What Gimlet did to PETSc in this process.
struct Started {
    /// `PETSC_COMM_WORLD` of the PETSc Gimlet initialised (a communicator
    /// Gimlet created; freed after `PetscFinalize`).
    world: Option<RawComm>,
}

// SAFETY: the communicator handle is a plain value, only used under the lock.
unsafe impl Send for Started {}

static STARTED: Mutex<Started> = Mutex::new(Started { world: None });
static GIMLET_STARTED_PETSC: AtomicBool = AtomicBool::new(false);

/// True when Gimlet initialised PETSc in this process (it will then finalise
/// it at the start of `MPI_Finalize`). False when the host did, or when
/// PETSc was never needed.
pub fn gimlet_started_petsc() -> bool {
    GIMLET_STARTED_PETSC.load(Ordering::SeqCst)
}

/// PETSc's own view: initialised and not finalised.
pub(crate) fn petsc_usable() -> bool {
    let mut init = ps::PetscBool::PETSC_FALSE;
    let mut fin = ps::PetscBool::PETSC_FALSE;
    // SAFETY: both only read flags; allowed before init and after finalize.
    unsafe {
        ps::PetscInitialized(&mut init);
        ps::PetscFinalized(&mut fin);
    }
    init == ps::PetscBool::PETSC_TRUE && fin == ps::PetscBool::PETSC_FALSE
}

/// Copy callback of the `MPI_COMM_SELF` attribute: a duplicate of
/// `MPI_COMM_SELF` does not inherit it.
unsafe extern "C" fn no_copy(
    _comm: mpi::MPI_Comm,
    _keyval: c_int,
    _extra: *mut c_void,
    _value_in: *mut c_void,
    _value_out: *mut c_void,
    flag: *mut c_int,
) -> c_int {
    *flag = 0;
    0
}

/// Delete callback of the `MPI_COMM_SELF` attribute: MPI runs it at the
/// start of `MPI_Finalize`, while MPI is still fully usable. Finalises the
/// PETSc Gimlet started (unless someone already did) and frees its world
/// communicator. Never panics (it runs inside MPI).
unsafe extern "C" fn finalize_petsc(
    _comm: mpi::MPI_Comm,
    _keyval: c_int,
    _value: *mut c_void,
    _extra: *mut c_void,
) -> c_int {
    let mut init = ps::PetscBool::PETSC_FALSE;
    let mut fin = ps::PetscBool::PETSC_FALSE;
    ps::PetscInitialized(&mut init);
    ps::PetscFinalized(&mut fin);
    if init == ps::PetscBool::PETSC_TRUE && fin == ps::PetscBool::PETSC_FALSE {
        ps::PetscFinalize();
    }
    if let Ok(mut s) = STARTED.lock() {
        if let Some(mut c) = s.world.take() {
            mpi::MPI_Comm_free(&mut c);
        }
    }
    0
}

/// Makes PETSc usable on every rank of `comm`. Collective over `comm`.
///
/// * Ranks where PETSc is already initialised (by the host, or by Gimlet for
///   another simulation) use it as it is.
/// * Ranks where it is not initialise it together, over a communicator of
///   just those ranks (`MPI_Comm_split` of `comm`): that communicator becomes
///   `PETSC_COMM_WORLD`, `-no_signal_handler` is put in the options database
///   first (PETSc reads it in `PetscInitialize` and then installs no signal
///   handler), and an attribute on `MPI_COMM_SELF` finalises PETSc at the
///   start of `MPI_Finalize`.
/// * If PETSc was finalised already on any rank, it fails everywhere with
///   `InvalidState` (PETSc cannot be initialised twice).
pub(crate) fn ensure_petsc(comm: &Comm) -> Result<()> {
    let mut init = ps::PetscBool::PETSC_FALSE;
    let mut fin = ps::PetscBool::PETSC_FALSE;
    // SAFETY: flag reads, allowed at any time.
    unsafe {
        ps::PetscInitialized(&mut init);
        ps::PetscFinalized(&mut fin);
    }
    // 0: usable, 1: needs initialisation, 2: finalised already.
    let state: u64 = if fin == ps::PetscBool::PETSC_TRUE {
        2
    } else if init == ps::PetscBool::PETSC_TRUE {
        0
    } else {
        1
    };
    let mut worst = [state];
    comm.max_u64(&mut worst)?;
    match worst[0] {
        0 => return Ok(()),
        2 => {
            return Err(Error::state(
                "PETSc was finalized (by the host) before the contact solve needed it; PETSc cannot be initialized again in this process: finalize PETSc only after destroying the simulation",
            ))
        }
        _ => {}
    }
    // Some ranks need PETSc: they initialise it together.
    let need = state == 1;
    let mut sub = unsafe { mpi::RSMPI_COMM_NULL };
    // SAFETY: collective over comm; sub is an output handle.
    check_mpi(
        unsafe {
            mpi::MPI_Comm_split(
                comm.raw(),
                if need { 0 } else { mpi::RSMPI_UNDEFINED },
                comm.rank(),
                &mut sub,
            )
        },
        "MPI_Comm_split",
    )?;
    let local = if need { initialize_on(sub) } else { Ok(()) };
    agree(comm, local, "PETSc initialisation")
}

/// Initialises PETSc with `PETSC_COMM_WORLD = world` (collective over
/// `world`) and arranges its finalisation at `MPI_Finalize`. Takes ownership
/// of `world`.
fn initialize_on(mut world: RawComm) -> Result<()> {
    // SAFETY: PETSc is neither initialised nor finalised here (checked by the
    // caller); setting options and PETSC_COMM_WORLD before PetscInitialize
    // is the documented way. `world` is a valid communicator of the ranks
    // that call this together.
    unsafe {
        let name = c"-no_signal_handler";
        let value = c"true";
        let rc = ps::PetscOptionsSetValue(ptr::null_mut(), name.as_ptr(), value.as_ptr());
        if rc != 0 {
            mpi::MPI_Comm_free(&mut world);
            return Err(Error::new(
                Status::Petsc,
                format!("PetscOptionsSetValue(-no_signal_handler) failed before PetscInitialize (PETSc error {rc})"),
            ));
        }
        ps::PETSC_COMM_WORLD = world;
        let rc = ps::PetscInitializeNoArguments();
        if rc != 0 {
            return Err(Error::new(
                Status::Petsc,
                format!("PetscInitializeNoArguments failed (PETSc error {rc})"),
            ));
        }
        GIMLET_STARTED_PETSC.store(true, Ordering::SeqCst);
        if let Ok(mut s) = STARTED.lock() {
            s.world = Some(world);
        }
        let mut keyval: c_int = 0;
        check_mpi(
            mpi::MPI_Comm_create_keyval(
                Some(no_copy),
                Some(finalize_petsc),
                &mut keyval,
                ptr::null_mut(),
            ),
            "MPI_Comm_create_keyval",
        )?;
        check_mpi(
            mpi::MPI_Comm_set_attr(mpi::RSMPI_COMM_SELF, keyval, ptr::null_mut()),
            "MPI_Comm_set_attr(MPI_COMM_SELF)",
        )?;
    }
    Ok(())
}

/// Makes an outcome collective: every rank returns an error when any rank
/// failed (its own error where it failed, a pointer to the other rank
/// elsewhere). One `MPI_Allreduce` over `comm`.
fn agree(comm: &Comm, local: Result<()>, what: &str) -> Result<()> {
    let failed = comm.any(local.is_err())?;
    match local {
        Err(e) => Err(e),
        Ok(()) if failed => Err(Error::elsewhere(
            Status::Petsc,
            format!("{what} failed on another rank of the simulation's communicator"),
        )),
        Ok(()) => Ok(()),
    }
}

// ----------------------------------------------------------- owned objects

/// A `Mat` destroyed on drop.
struct OwnedMat(ps::Mat);
impl Drop for OwnedMat {
    fn drop(&mut self) {
        // SAFETY: created by MatCreate, destroyed once.
        unsafe { ps::MatDestroy(&mut self.0) };
    }
}

/// A `Vec` destroyed on drop.
struct OwnedVec(ps::Vec);
impl Drop for OwnedVec {
    fn drop(&mut self) {
        // SAFETY: created by MatCreateVecs, destroyed once.
        unsafe { ps::VecDestroy(&mut self.0) };
    }
}

/// A C string of PETSc's (a type name) as a Rust string.
fn type_name(p: *const c_char) -> String {
    if p.is_null() {
        String::new()
    } else {
        // SAFETY: PETSc's type names are static NUL-terminated strings.
        unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
    }
}

/// The name of a `KSPConvergedReason` as the enum spells it (from PETSc's
/// own table, e.g. `KSP_DIVERGED_ITS`).
fn reason_name(reason: ps::KSPConvergedReason) -> String {
    let v = reason.0;
    if (-11..=9).contains(&v) {
        // SAFETY: KSPConvergedReasons points into a table shifted so that
        // every value of the enum (-11..=9 in PETSc 3.18) is a valid index.
        let p = unsafe { *ps::KSPConvergedReasons.offset(v as isize) };
        let s = type_name(p);
        if !s.is_empty() {
            // PETSc's table omits the enum's `KSP_` prefix.
            return if s.starts_with("KSP_") {
                s
            } else {
                format!("KSP_{s}")
            };
        }
    }
    format!("KSPConvergedReason {v}")
}

// ------------------------------------------------------------- the solver

/// The PETSc side of a `Linsolve`: its own duplicate of the simulation's
/// communicator and one KSP on it, kept between solves (so PETSc's inner
/// communicator and the KSP's set-up are not rebuilt every time), plus
/// scratch arrays.
pub(crate) struct KspSolver {
    comm: RawComm,
    ksp: ps::KSP,
    rank: usize,
    size: usize,
    /// (local rows, global rows) of the operator the KSP last saw.
    sizes: Option<(usize, usize)>,
    ia: Vec<ps::PetscInt>,
    ja: Vec<ps::PetscInt>,
    va: Vec<f64>,
    xloc: Vec<f64>,
    counts: Vec<c_int>,
    displs: Vec<c_int>,
    /// KSP and PC type names of the last solve.
    pub(crate) types: (String, String),
}

impl KspSolver {
    /// Initialises PETSc if needed, duplicates `comm` and creates the KSP
    /// (CG + Jacobi, options prefix `prefix`). Collective over `comm`.
    pub(crate) fn new(comm: &Comm, prefix: &CStr) -> Result<KspSolver> {
        ensure_petsc(comm)?;
        let mut dup = unsafe { mpi::RSMPI_COMM_NULL };
        // SAFETY: collective over comm.
        check_mpi(
            unsafe { mpi::MPI_Comm_dup(comm.raw(), &mut dup) },
            "MPI_Comm_dup",
        )?;
        let mut ksp: ps::KSP = ptr::null_mut();
        let made = (|| -> Result<()> {
            let _quiet = QuietErrors::push()?;
            // SAFETY: PETSc is usable; dup is a valid communicator.
            unsafe {
                check(ps::KSPCreate(dup, &mut ksp), "KSPCreate")?;
                check(
                    ps::KSPSetOptionsPrefix(ksp, prefix.as_ptr()),
                    "KSPSetOptionsPrefix",
                )?;
                check(ps::KSPSetType(ksp, ps::KSPCG.as_ptr().cast()), "KSPSetType")?;
                let mut pc: ps::PC = ptr::null_mut();
                check(ps::KSPGetPC(ksp, &mut pc), "KSPGetPC")?;
                check(ps::PCSetType(pc, ps::PCJACOBI.as_ptr().cast()), "PCSetType")?;
            }
            Ok(())
        })();
        let made = agree(comm, made, "creating the contact KSP");
        if let Err(e) = made {
            // SAFETY: destroy what was created (KSPDestroy accepts NULL).
            unsafe {
                if !ksp.is_null() {
                    let _quiet = QuietErrors::push();
                    ps::KSPDestroy(&mut ksp);
                }
                mpi::MPI_Comm_free(&mut dup);
            }
            return Err(e);
        }
        Ok(KspSolver {
            comm: dup,
            ksp,
            rank: comm.rank() as usize,
            size: comm.size() as usize,
            sizes: None,
            ia: Vec::new(),
            ja: Vec::new(),
            va: Vec::new(),
            xloc: Vec::new(),
            counts: Vec::new(),
            displs: Vec::new(),
            types: (String::new(), String::new()),
        })
    }

    /// True when `comm` has the same group as the communicator this solver
    /// was created for (`MPI_Comm_compare` is a local call).
    pub(crate) fn serves(&self, comm: &Comm) -> Result<bool> {
        let mut result: c_int = 0;
        // SAFETY: both are valid communicators.
        check_mpi(
            unsafe { mpi::MPI_Comm_compare(self.comm, comm.raw(), &mut result) },
            "MPI_Comm_compare",
        )?;
        Ok(unsafe { result == mpi::RSMPI_IDENT || result == mpi::RSMPI_CONGRUENT })
    }

    /// First row of rank `rank`'s chunk of `m` rows (contiguous, nearly equal
    /// chunks: sizes differ by at most one).
    fn row_start(&self, rank: usize, m: usize) -> usize {
        ((rank as u64 * m as u64) / self.size as u64) as usize
    }

    /// Solves `sys` with the KSP: the submatrix `A_FF` is assembled as an AIJ
    /// matrix with each rank's contiguous chunk of rows (exact preallocation
    /// from the replicated CSR, no communication), CG + Jacobi unless the
    /// options database says otherwise, and the solution is gathered to
    /// every rank. Collective over the communicator.
    pub(crate) fn solve(&mut self, opts: &LcpOptions, sys: SubSystem<'_>) -> Result<SolveStats> {
        if !petsc_usable() {
            return Err(Error::state(
                "PETSc was finalized (by the host) while a simulation still needed it for the contact solve: finalize PETSc only after destroying the simulation",
            ));
        }
        let m = sys.free.len();
        let lo = self.row_start(self.rank, m);
        let hi = self.row_start(self.rank + 1, m);
        let nloc = hi - lo;

        // This rank's rows of A_FF, in F numbering. `free` ascends, so the
        // mapped column indices of a row ascend too.
        self.ia.clear();
        self.ja.clear();
        self.va.clear();
        self.ia.push(0);
        let a = sys.a;
        for &i in &sys.free[lo..hi] {
            let i = i as usize;
            let (s, e) = (a.row_ptr[i], a.row_ptr[i + 1]);
            for (&j, &v) in a.cols[s..e].iter().zip(&a.vals[s..e]) {
                let p = sys.pos[j as usize];
                if p != super::NOT_FREE {
                    self.ja.push(p as ps::PetscInt);
                    self.va.push(v);
                }
            }
            self.ia.push(self.ja.len() as ps::PetscInt);
        }

        let mut stats = SolveStats {
            backend: Backend::Petsc,
            iterations: 0,
            envelope: 0,
            work: 0.0,
        };
        self.xloc.clear();
        self.xloc.resize(nloc, 0.0);
        let local = self.solve_local(opts, &sys, lo, hi, m, &mut stats);
        let comm = self.comm;
        let failed = {
            let mut v = [local.is_err() as u64];
            // SAFETY: a one-element allreduce on our communicator.
            let send = v;
            check_mpi(
                unsafe {
                    mpi::MPI_Allreduce(
                        send.as_ptr().cast(),
                        v.as_mut_ptr().cast(),
                        1,
                        mpi::RSMPI_UINT64_T,
                        mpi::RSMPI_MAX,
                        comm,
                    )
                },
                "MPI_Allreduce",
            )?;
            v[0] != 0
        };
        local?;
        if failed {
            return Err(Error::elsewhere(
                Status::Petsc,
                "the contact KSP solve failed on another rank of the simulation's communicator",
            ));
        }

        // Every rank gets the whole solution.
        self.counts.clear();
        self.displs.clear();
        for q in 0..self.size {
            let (a0, a1) = (self.row_start(q, m), self.row_start(q + 1, m));
            self.displs.push(a0 as c_int);
            self.counts.push((a1 - a0) as c_int);
        }
        // SAFETY: xloc has counts[rank] entries, sys.x has m = Σ counts.
        check_mpi(
            unsafe {
                mpi::MPI_Allgatherv(
                    self.xloc.as_ptr().cast(),
                    nloc as c_int,
                    mpi::RSMPI_DOUBLE,
                    sys.x.as_mut_ptr().cast(),
                    self.counts.as_ptr(),
                    self.displs.as_ptr(),
                    mpi::RSMPI_DOUBLE,
                    comm,
                )
            },
            "MPI_Allgatherv",
        )?;
        Ok(stats)
    }

    /// The PETSc part of [`solve`](Self::solve), under the quiet error
    /// handler; every object it creates is destroyed before it returns.
    fn solve_local(
        &mut self,
        opts: &LcpOptions,
        sys: &SubSystem<'_>,
        lo: usize,
        hi: usize,
        m: usize,
        stats: &mut SolveStats,
    ) -> Result<()> {
        let nloc = hi - lo;
        let _quiet = QuietErrors::push()?;
        let (ml, mg) = (nloc as ps::PetscInt, m as ps::PetscInt);
        // SAFETY: every handle below is created here, checked, and owned by a
        // guard that destroys it; the arrays outlive the calls that read them.
        unsafe {
            let mut mat = OwnedMat(ptr::null_mut());
            check(ps::MatCreate(self.comm, &mut mat.0), "MatCreate")?;
            check(ps::MatSetSizes(mat.0, ml, ml, mg, mg), "MatSetSizes")?;
            check(
                ps::MatSetType(mat.0, ps::MATAIJ.as_ptr().cast()),
                "MatSetType",
            )?;
            // Exactly the entries given (each call is a no-op on the other
            // matrix type); both assemble the matrix.
            check(
                ps::MatSeqAIJSetPreallocationCSR(
                    mat.0,
                    self.ia.as_ptr(),
                    self.ja.as_ptr(),
                    self.va.as_ptr(),
                ),
                "MatSeqAIJSetPreallocationCSR",
            )?;
            check(
                ps::MatMPIAIJSetPreallocationCSR(
                    mat.0,
                    self.ia.as_ptr(),
                    self.ja.as_ptr(),
                    self.va.as_ptr(),
                ),
                "MatMPIAIJSetPreallocationCSR",
            )?;
            check(
                ps::MatSetOption(
                    mat.0,
                    ps::MatOption::MAT_SYMMETRIC,
                    ps::PetscBool::PETSC_TRUE,
                ),
                "MatSetOption(MAT_SYMMETRIC)",
            )?;
            check(
                ps::MatSetOption(mat.0, ps::MatOption::MAT_SPD, ps::PetscBool::PETSC_TRUE),
                "MatSetOption(MAT_SPD)",
            )?;

            let mut xv = OwnedVec(ptr::null_mut());
            let mut bv = OwnedVec(ptr::null_mut());
            check(
                ps::MatCreateVecs(mat.0, &mut xv.0, &mut bv.0),
                "MatCreateVecs",
            )?;
            // Decided from the replicated guess: the same on every rank.
            let warm = opts.warm_start && sys.x.iter().any(|&v| v != 0.0);
            for (v, src) in [(bv.0, &sys.rhs[lo..hi]), (xv.0, &sys.x[lo..hi])] {
                let mut p: *mut f64 = ptr::null_mut();
                check(ps::VecGetArray(v, &mut p), "VecGetArray")?;
                let dst = std::slice::from_raw_parts_mut(p, nloc);
                if v == xv.0 && !warm {
                    dst.fill(0.0);
                } else {
                    dst.copy_from_slice(src);
                }
                check(ps::VecRestoreArray(v, &mut p), "VecRestoreArray")?;
            }

            if self.sizes != Some((nloc, m)) {
                // The KSP keeps work vectors of the old sizes: drop them.
                check(ps::KSPReset(self.ksp), "KSPReset")?;
                self.sizes = Some((nloc, m));
            }
            check(
                ps::KSPSetOperators(self.ksp, mat.0, mat.0),
                "KSPSetOperators",
            )?;
            check(
                ps::KSPSetTolerances(
                    self.ksp,
                    opts.rtol,
                    1e-300,
                    ps::PETSC_DEFAULT_REAL,
                    opts.max_it as ps::PetscInt,
                ),
                "KSPSetTolerances",
            )?;
            // The guess is the same on every rank count (replicated data),
            // so it does not break rank invariance.
            check(
                ps::KSPSetInitialGuessNonzero(
                    self.ksp,
                    if warm {
                        ps::PetscBool::PETSC_TRUE
                    } else {
                        ps::PetscBool::PETSC_FALSE
                    },
                ),
                "KSPSetInitialGuessNonzero",
            )?;
            check(ps::KSPSetFromOptions(self.ksp), "KSPSetFromOptions")?;
            let mut kt: ps::KSPType = ptr::null();
            check(ps::KSPGetType(self.ksp, &mut kt), "KSPGetType")?;
            let mut pc: ps::PC = ptr::null_mut();
            check(ps::KSPGetPC(self.ksp, &mut pc), "KSPGetPC")?;
            let mut pt: ps::PCType = ptr::null();
            check(ps::PCGetType(pc, &mut pt), "PCGetType")?;
            let (kt, pt) = (type_name(kt), type_name(pt));
            if self.types.0 != kt || self.types.1 != pt {
                self.types = (kt, pt);
            }

            check(ps::KSPSolve(self.ksp, bv.0, xv.0), "KSPSolve")?;
            let mut reason = ps::KSPConvergedReason::KSP_CONVERGED_ITERATING;
            check(
                ps::KSPGetConvergedReason(self.ksp, &mut reason),
                "KSPGetConvergedReason",
            )?;
            let mut its: ps::PetscInt = 0;
            check(
                ps::KSPGetIterationNumber(self.ksp, &mut its),
                "KSPGetIterationNumber",
            )?;
            stats.iterations = its.max(0) as usize;
            if reason.0 < 0 {
                let mut rnorm = 0.0;
                check(
                    ps::KSPGetResidualNorm(self.ksp, &mut rnorm),
                    "KSPGetResidualNorm",
                )?;
                return Err(Error::new(
                    Status::Petsc,
                    format!(
                        "KSPSolve of the contact system ({m} unknowns, {} {}) did not converge: {} after {its} iterations, residual norm {rnorm:.3e} (rtol {:.1e}, max_it {})",
                        self.types.0,
                        self.types.1,
                        reason_name(reason),
                        opts.rtol,
                        opts.max_it
                    ),
                ));
            }
            let mut p: *const f64 = ptr::null();
            check(ps::VecGetArrayRead(xv.0, &mut p), "VecGetArrayRead")?;
            self.xloc
                .copy_from_slice(std::slice::from_raw_parts(p, nloc));
            check(ps::VecRestoreArrayRead(xv.0, &mut p), "VecRestoreArrayRead")?;
        }
        Ok(())
    }
}

impl Drop for KspSolver {
    /// Destroys the KSP and frees the communicator duplicate (both
    /// collective over the communicator). After `MPI_Finalize`, or once
    /// PETSc has been finalised, nothing can be destroyed any more: both
    /// handles are then forgotten (freeing the communicator would run
    /// PETSc's attribute callbacks after `PetscFinalize`).
    fn drop(&mut self) {
        if !crate::comm::mpi_usable() || !petsc_usable() {
            return;
        }
        if let Ok(_quiet) = QuietErrors::push() {
            // SAFETY: our KSP, destroyed once.
            unsafe { ps::KSPDestroy(&mut self.ksp) };
        }
        // SAFETY: our duplicate, freed once.
        unsafe { mpi::MPI_Comm_free(&mut self.comm) };
    }
}

/// `prefix` as a C string, or an error naming the option.
pub(crate) fn prefix_cstring(prefix: &str) -> Result<CString> {
    if prefix.is_empty()
        || prefix.starts_with('-')
        || !prefix
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || b == b'_')
    {
        return Err(Error::arg(format!(
            "LcpOptions.prefix = {prefix:?}: a PETSc options prefix must be a non-empty string of ASCII letters, digits and '_' that does not start with '-'"
        )));
    }
    CString::new(prefix).map_err(|_| Error::arg("LcpOptions.prefix contains a NUL byte"))
}

/// Adds `text` (`-name value` pairs, as on a command line) to PETSc's
/// options database, initialising PETSc first when needed (see
/// [`ensure_petsc`]); the contact KSP reads them at its next
/// `KSPSetFromOptions`. Collective over `comm`.
pub fn insert_options(comm: &Comm, text: &str) -> Result<()> {
    let c = std::ffi::CString::new(text)
        .map_err(|_| Error::arg("options must not contain a NUL byte"))?;
    ensure_petsc(comm)?;
    let r = (|| -> Result<()> {
        let _quiet = QuietErrors::push()?;
        // SAFETY: PETSc is initialised; `c` is a NUL-terminated string.
        unsafe {
            check(
                ps::PetscOptionsInsertString(ptr::null_mut(), c.as_ptr()),
                "PetscOptionsInsertString",
            )
        }
    })();
    agree(comm, r, "inserting PETSc options")
}
