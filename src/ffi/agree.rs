//! Collective agreement: every collective C entry point validates its
//! arguments locally, then agrees with the other ranks before any further
//! collective work, in the spirit of PETSc's `PetscValidLogicalCollective*`.
//!
//! # The mechanism
//!
//! A call's arguments that must be the same on every rank are described by
//! an [`Args`] fingerprint: for each argument its name and a 64-bit value
//! (the bits of a number, or an FNV-1a hash of a string or an array), plus a
//! hash of the call's name. Arrays that are per-rank by design (particle
//! arrays, field values) are not fingerprinted.
//!
//! [`agree`] then makes **one** `MPI_Allreduce` (`MPI_MIN` over a fixed-size
//! array of `u64`) of
//!
//! ```text
//! [ key, name, a_1 .. a_N, !key, !name, !a_1 .. !a_N ]
//! ```
//!
//! where `key` is `u64::MAX` on a rank whose local validation passed and
//! `(severity << 32) | rank` on a rank that rejected the call. The minimum of
//! `v` and of `!v` give the minimum and the maximum of every entry over the
//! ranks, so after the one reduction every rank knows, identically:
//!
//! - whether any rank rejected the call, and which one wins: the **most
//!   severe** status (see [`severity`]), ties to the **lowest rank**; that
//!   rank's status and message then travel to every rank by a broadcast
//!   (only on failure), and every rank returns them, the message prefixed
//!   with "rejected on rank r: " when some ranks had accepted the call;
//! - otherwise, whether any argument differs between ranks (its minimum and
//!   maximum differ): every rank returns `InvalidArgument` naming the call
//!   (through the boundary's prefix) and the first differing argument, with
//!   two of the values passed when they are numbers. A differing call name
//!   means the ranks are in different calls: that is reported too (so ranks
//!   that make different collective calls at the same point get an error,
//!   not a hang, as long as both calls start with this agreement).
//!
//! The array has the same size for every call, so the reduction matches
//! even when the ranks are in different calls.
//!
//! After the agreement, the call's collective work runs; [`outcome`] then
//! makes its result the same on every rank the same way (one more
//! reduction; the winner's message is prefixed "failed on rank r: " when
//! some ranks had succeeded). For a step, for example, `PARTICLES_LEFT` on
//! one rank and `UNSTABLE` on another become `UNSTABLE` everywhere.
//!
//! # Using it
//!
//! A new collective entry point is one call of [`collective`]:
//!
//! ```ignore
//! collective("gimlet_set_foo", sim, args!(a, b),
//!     |s| check_foo(s, a, b),          // local validation only (no MPI)
//!     |s, ok| s.set_foo(ok))           // collective work, after agreement
//! ```
//!
//! Everything the first closure returns as an error is agreed before the
//! second closure runs; the second closure's result is agreed afterwards.
//! Inside longer collective code, [`agree`] can be used directly.

use super::GimletSim;
use crate::comm::{mpi_usable, Comm};
use crate::error::{Error, Result, Status};
use crate::sim::Simulation;
use std::ffi::CStr;
use std::os::raw::{c_char, c_int};
use std::panic::{catch_unwind, AssertUnwindSafe};

/// Most arguments a fingerprint holds; more are folded into the last slot.
pub(crate) const MAX_ARGS: usize = 14;

/// Entries of the reduced array: key, name, arguments, and their complements.
const SLOTS: usize = 1 + 1 + MAX_ARGS;

/// How an argument's 64-bit value is shown in a mismatch message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// The bits of an `f64`.
    Real,
    /// A signed integer.
    Int,
    /// A hash (strings, arrays): the values are not shown.
    Hash,
}

/// The fingerprint of a collective call's arguments: names, kinds and 64-bit
/// values (see the module documentation).
#[derive(Clone, Debug)]
pub struct Args {
    n: usize,
    names: [&'static str; MAX_ARGS],
    kinds: [Kind; MAX_ARGS],
    vals: [u64; MAX_ARGS],
}

impl Default for Args {
    fn default() -> Self {
        Self::new()
    }
}

pub use crate::fnv::{fnv1a, FNV_OFFSET};

/// A value that can be fingerprinted.
pub trait Fingerprint {
    /// Its kind and 64-bit value.
    fn fingerprint(&self) -> (Kind, u64);
}

impl Fingerprint for f64 {
    fn fingerprint(&self) -> (Kind, u64) {
        (Kind::Real, self.to_bits())
    }
}
impl Fingerprint for i32 {
    fn fingerprint(&self) -> (Kind, u64) {
        (Kind::Int, i64::from(*self) as u64)
    }
}
impl Fingerprint for i64 {
    fn fingerprint(&self) -> (Kind, u64) {
        (Kind::Int, *self as u64)
    }
}
impl Fingerprint for [f64] {
    fn fingerprint(&self) -> (Kind, u64) {
        let mut h = fnv1a(FNV_OFFSET, &(self.len() as u64).to_le_bytes());
        for v in self {
            h = fnv1a(h, &v.to_bits().to_le_bytes());
        }
        (Kind::Hash, h)
    }
}
impl Fingerprint for str {
    fn fingerprint(&self) -> (Kind, u64) {
        (Kind::Hash, fnv1a(FNV_OFFSET, self.as_bytes()))
    }
}

/// A C string argument (NULL allowed) for a fingerprint: its bytes are
/// hashed; NULL hashes differently from every string.
#[derive(Clone, Copy, Debug)]
pub struct Text(pub *const c_char);

impl Fingerprint for Text {
    fn fingerprint(&self) -> (Kind, u64) {
        if self.0.is_null() {
            return (Kind::Hash, 0x6e75_6c6c_6e75_6c6c);
        }
        // SAFETY: the C ABI documents every string argument as NULL or
        // NUL-terminated.
        let bytes = unsafe { CStr::from_ptr(self.0) }.to_bytes();
        (Kind::Hash, fnv1a(FNV_OFFSET ^ 0x5a, bytes))
    }
}

impl Args {
    /// No arguments (the call name alone is still agreed).
    pub fn new() -> Args {
        Args {
            n: 0,
            names: [""; MAX_ARGS],
            kinds: [Kind::Hash; MAX_ARGS],
            vals: [0; MAX_ARGS],
        }
    }

    /// Adds argument `name` with value `v`.
    pub fn with<T: Fingerprint + ?Sized>(mut self, name: &'static str, v: &T) -> Args {
        let (kind, val) = v.fingerprint();
        if self.n < MAX_ARGS {
            self.names[self.n] = name;
            self.kinds[self.n] = kind;
            self.vals[self.n] = val;
            self.n += 1;
        } else {
            // Folded into the last slot, which then names both.
            let k = MAX_ARGS - 1;
            self.kinds[k] = Kind::Hash;
            self.vals[k] = fnv1a(self.vals[k], &val.to_le_bytes());
        }
        self
    }
}

/// `args!(a, b, c)`: the fingerprint of the named local variables (each a
/// number, `Text` or a slice), named as in the source.
#[macro_export]
#[doc(hidden)]
macro_rules! gimlet_args {
    ($($a:ident),* $(,)?) => {
        $crate::ffi::agree::Args::new()$(.with(stringify!($a), &$a))*
    };
}
pub use crate::gimlet_args as args;

/// The severity order of statuses when ranks fail differently (most severe
/// first): `Internal`, `Mpi`, `Io`, `Petsc`, `Unstable`, `ParticlesLeft`,
/// `InvalidState`, `InvalidArgument`, `NullPointer`, `BufferTooSmall`. A
/// state that went wrong (non-finite values) outranks particles that left;
/// a broken library or communicator outranks both.
pub fn severity(s: Status) -> u64 {
    match s {
        Status::Internal => 0,
        Status::Mpi => 1,
        Status::Io => 2,
        Status::Petsc => 3,
        Status::Unstable => 4,
        Status::ParticlesLeft => 5,
        Status::InvalidState => 6,
        Status::InvalidArgument => 7,
        Status::NullPointer => 8,
        Status::BufferTooSmall => 9,
        Status::Ok => 10,
    }
}

fn status_of_severity(k: u64) -> Status {
    use Status::*;
    [
        Internal,
        Mpi,
        Io,
        Petsc,
        Unstable,
        ParticlesLeft,
        InvalidState,
        InvalidArgument,
        NullPointer,
        BufferTooSmall,
    ]
    .into_iter()
    .find(|s| severity(*s) == k)
    .unwrap_or(Internal)
}

/// The phase of a call an agreement belongs to (part of the name hash, so
/// that ranks in different phases never agree by accident).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    /// Before the collective work: arguments and local validation.
    Arguments,
    /// After it: the outcome.
    Outcome,
}

fn show(kind: Kind, v: u64) -> String {
    match kind {
        Kind::Real => format!("{}", f64::from_bits(v)),
        Kind::Int => format!("{}", v as i64),
        Kind::Hash => String::new(),
    }
}

/// The reduction and its reading (see the module documentation). `call` is
/// the entry point's name.
fn reduce<T>(comm: &Comm, call: &str, phase: Phase, args: &Args, local: Result<T>) -> Result<T> {
    let name = fnv1a(FNV_OFFSET, format!("{call}#{}", phase as u8).as_bytes());
    let rank = comm.rank() as u64;
    // An echo of another rank's failure (`Error::elsewhere`) ranks below
    // every failure of a rank's own, whatever its status: the failing
    // rank's status and message win.
    let key = match &local {
        Ok(_) => u64::MAX,
        Err(e) => ((e.elsewhere as u64) << 63) | (severity(e.status) << 32) | rank,
    };
    let mut v = [0u64; 2 * SLOTS];
    v[0] = key;
    v[1] = name;
    v[2..2 + MAX_ARGS].copy_from_slice(&args.vals);
    for k in 0..SLOTS {
        v[SLOTS + k] = !v[k];
    }
    comm.min_u64(&mut v)?;
    let (min, max) = (|k: usize| v[k], |k: usize| !v[SLOTS + k]);
    // Ranks in different calls (or phases): nothing else can be compared.
    if min(1) != max(1) {
        return Err(Error::arg(
            "the ranks made different calls at this point; every rank must make the same collective calls in the same order",
        ));
    }
    // The first argument that differs between ranks, if any.
    let differing = (0..args.n).find(|&k| min(2 + k) != max(2 + k)).map(|k| {
        let (name, kind) = (args.names[k], args.kinds[k]);
        let values = if kind == Kind::Hash {
            String::new()
        } else {
            let (lo, hi) = (min(2 + k), max(2 + k));
            format!(" (for example {} and {})", show(kind, lo), show(kind, hi))
        };
        (name, values)
    });
    if min(0) != u64::MAX {
        // Some rank failed: the winner's status and message go to everyone.
        let winner = (min(0) & 0xffff_ffff) as i32;
        // Every rank failed on its own (no success, no echo).
        let all_failed = max(0) >> 63 == 0;
        let mut msg = match &local {
            Err(e) if comm.rank() == winner => e.msg.clone().into_bytes(),
            _ => Vec::new(),
        };
        comm.bcast_bytes(winner, &mut msg)?;
        let mut msg = String::from_utf8_lossy(&msg).into_owned();
        let status = status_of_severity((min(0) >> 32) & 0x7fff_ffff);
        let verb = match phase {
            Phase::Arguments => "rejected",
            Phase::Outcome => "failed",
        };
        if !(all_failed || comm.size() == 1) {
            msg = format!("{verb} on rank {winner}: {msg}");
        }
        if let Some((name, values)) = differing {
            msg.push_str(&format!(
                "; the ranks also passed different values of {name}{values}"
            ));
        }
        return Err(Error::new(status, msg));
    }
    if let Some((name, values)) = differing {
        return Err(Error::arg(format!(
            "the ranks passed different values of {name}{values}; a collective call needs the same {name} on every rank"
        )));
    }
    local
}

/// Agrees on the arguments and the local validation of collective call
/// `call` before any collective work (see the module documentation): on
/// every rank, the same `Ok(local value)` or the same error. One
/// `MPI_Allreduce`, plus a broadcast when a rank rejected the call.
pub fn agree<T>(comm: &Comm, call: &str, args: &Args, local: Result<T>) -> Result<T> {
    reduce(comm, call, Phase::Arguments, args, local)
}

/// Makes the result of the collective work of `call` the same on every
/// rank (the most severe failure, ties to the lowest rank, with its
/// message). One `MPI_Allreduce`, plus a broadcast on failure.
pub fn outcome<T>(comm: &Comm, call: &str, local: Result<T>) -> Result<T> {
    reduce(comm, call, Phase::Outcome, &Args::new(), local)
}

/// Runs `f`, turning a panic into an `Internal` error (the panic hook of
/// the boundary records its message).
fn caught<T>(f: impl FnOnce() -> Result<T>) -> Result<T> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(_) => Err(super::panic_error()),
    }
}

/// The collective calls that leave the snapshot of transactional steps in
/// place (see `Simulation::step`): the steps themselves and the calls that
/// only read the state. Every other collective call may change the state
/// outside stepping, so it invalidates the snapshot (a call missing from
/// this list costs a fresh snapshot at the next step, never a wrong undo).
const KEEPS_SNAPSHOT: &[&str] = &[
    "gimlet_step",
    "gimlet_advance_to",
    "gimlet_stable_dt",
    "gimlet_diagnostics",
    "gimlet_particle_count",
    "gimlet_patch_crossings",
    "gimlet_write_output",
    "gimlet_write_checkpoint",
    "gimlet_csv_append",
    "gimlet_csv_open",
    "gimlet_output_open",
    "gimlet_check_xdmf",
];

/// The C entry point of a collective call on a handle: `check` validates the
/// arguments on this rank (no MPI), [`agree`] makes every rank accept or
/// reject the call the same way (also when the ranks passed different
/// `args`), then `run` does the collective work and [`outcome`] makes its
/// result the same everywhere. Returns the status; on failure the message
/// (prefixed with `name`) is the thread's last error on every rank.
///
/// A NULL handle is rejected at once (there is no communicator to agree
/// on: a handle NULL on some ranks only leaves the others waiting). A
/// handle made unusable by an internal error still takes part in the
/// agreement, so every rank rejects the call. A panic in `run` poisons the
/// handle and skips the outcome agreement (the ranks may be in different
/// places of the collective work).
pub(crate) fn collective<T>(
    name: &str,
    sim: *mut GimletSim,
    args: Args,
    check: impl FnOnce(&Simulation) -> Result<T>,
    run: impl FnOnce(&mut Simulation, T) -> Result<()>,
) -> c_int {
    collective_handle(
        name,
        sim,
        args,
        |h| check(&h.sim),
        |h, v| run(&mut h.sim, v),
    )
}

/// As [`collective`], with `check` and `run` given the whole handle: the
/// simulation and what the handle keeps beside it (its outputs).
pub(crate) fn collective_handle<T>(
    name: &str,
    sim: *mut GimletSim,
    args: Args,
    check: impl FnOnce(&GimletSim) -> Result<T>,
    run: impl FnOnce(&mut GimletSim, T) -> Result<()>,
) -> c_int {
    if sim.is_null() {
        super::set_last_error(&format!(
            "{name}: sim is NULL; pass a handle from gimlet_create"
        ));
        return super::GIMLET_ERR_NULL_POINTER;
    }
    // SAFETY: non-null handles come from gimlet_create and live until
    // gimlet_destroy; the caller must not use one from two threads at once.
    let h = unsafe { &mut *sim };
    if !mpi_usable() {
        super::set_last_error(&format!(
            "{name}: MPI is finalized (or not initialized): collective calls need MPI; destroy the handle before MPI_Finalize"
        ));
        return super::GIMLET_ERR_INVALID_STATE;
    }
    let mut panicked = false;
    let rc = super::guard(name, || {
        let local = if h.poisoned {
            Err(Error::new(
                Status::Internal,
                "the handle is unusable after an earlier internal error; destroy it",
            ))
        } else {
            caught(|| check(h))
        };
        let v = agree(h.sim.comm(), name, &args, local)?;
        if !KEEPS_SNAPSHOT.contains(&name) {
            h.sim.invalidate_snapshot();
        }
        match catch_unwind(AssertUnwindSafe(|| run(h, v))) {
            Ok(r) => outcome(h.sim.comm(), name, r),
            Err(_) => {
                panicked = true;
                Err(super::panic_error())
            }
        }
    });
    if rc == super::GIMLET_ERR_INTERNAL || panicked {
        h.poisoned = true;
    }
    rc
}

/// Creates a handle collectively over the caller's communicator: `comm` is
/// the duplicate made by [`Comm::dup`] (which checks the caller's handle
/// without any MPI call that could abort; without a communicator there is
/// nothing to agree on, so its failure returns at once). Then `check` runs
/// on each rank (no MPI) and every rank agrees on it and on `args`; then
/// `build` makes the simulation on the duplicate and the outcome is agreed
/// (on a second duplicate, since `build` takes the first). `*out` is
/// written only on success, on every rank.
pub(crate) fn create_on<P>(
    comm: Result<Comm>,
    name: &str,
    args: Args,
    out: *mut *mut GimletSim,
    check: impl FnOnce() -> Result<P>,
    build: impl FnOnce(Comm, P) -> Result<Simulation>,
) -> Result<()> {
    let comm = comm?;
    let local = if out.is_null() {
        Err(Error::new(Status::NullPointer, "out is NULL"))
    } else {
        caught(check)
    };
    let p = agree(&comm, name, &args, local)?;
    let witness = Comm::dup(comm.raw())?;
    let built = caught(|| build(comm, p));
    let sim = outcome(&witness, name, built)?;
    let b = Box::new(GimletSim {
        sim,
        outputs: Default::default(),
        poisoned: false,
    });
    // SAFETY: out was checked non-null on every rank (agreed above).
    unsafe { *out = Box::into_raw(b) };
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn args_name_their_values() {
        let dt = 0.5f64;
        let level = 3i32;
        let a = args!(dt, level);
        assert_eq!(a.n, 2);
        assert_eq!(a.names[..2], ["dt", "level"]);
        assert_eq!(a.vals[0], 0.5f64.to_bits());
        assert_eq!(a.vals[1], 3);
        assert_eq!(show(a.kinds[0], a.vals[0]), "0.5");
        // Strings and arrays are hashed; NULL differs from "".
        let empty = c"";
        assert_ne!(
            Text(std::ptr::null()).fingerprint(),
            Text(empty.as_ptr()).fingerprint()
        );
        assert_ne!([1.0, 2.0][..].fingerprint(), [2.0, 1.0][..].fingerprint());
    }

    #[test]
    fn severities_round_trip() {
        for s in [
            Status::Internal,
            Status::Mpi,
            Status::Io,
            Status::Petsc,
            Status::Unstable,
            Status::ParticlesLeft,
            Status::InvalidState,
            Status::InvalidArgument,
            Status::NullPointer,
            Status::BufferTooSmall,
        ] {
            assert_eq!(status_of_severity(severity(s)), s);
        }
        assert!(severity(Status::Unstable) < severity(Status::ParticlesLeft));
    }
}
