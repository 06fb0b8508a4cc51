//! The C ABI. Conventions, for every `gimlet_*` function:
//!
//! - it returns an `int` status, `GIMLET_OK` (0) on success;
//! - on failure, `gimlet_last_error` gives one sentence (thread-local) that
//!   names the bad argument and the bound it broke;
//! - outputs are written only on success (the one exception: a call that
//!   fails with `GIMLET_ERR_BUFFER_TOO_SMALL` reports the needed count);
//! - panics are caught and become `GIMLET_ERR_INTERNAL`; nothing aborts the
//!   host and nothing is printed;
//! - arrays are caller-owned with explicit lengths (`int64_t`, so that a
//!   negative length is caught, and Fortran can pass `integer(c_int64_t)`);
//! - calls on a handle are collective over its communicator unless their
//!   documentation says "local";
//! - every collective call validates its arguments on each rank, then agrees
//!   across ranks before any other collective work (see [`agree`]): a call
//!   rejected on any rank is rejected on every rank with the same status and
//!   message, and arguments that differ between ranks are an error on every
//!   rank, never a hang or a silent divergence. Its outcome is agreed the
//!   same way.
//!
//! Adding a collective entry point is one call of [`agree::collective`],
//! with the arguments that must agree, a local check and the collective work:
//!
//! ```ignore
//! collective("gimlet_set_foo", sim, args!(a, b), |s| check_foo(s, a, b), |s, ok| s.set_foo(ok))
//! ```
//!
//! (`args!` names local variables: numbers, `agree::Text(ptr)` for C
//! strings, slices for arrays that must be equal on every rank; per-rank
//! arrays are left out.) The exception is `gimlet_destroy`, which has no
//! argument to agree on: it must be called on every rank.
//!
//! Safety, for every `unsafe extern "C"` function here: each pointer is NULL
//! or valid for the number of elements its documentation gives, and a handle
//! is used by one thread at a time.
#![allow(clippy::missing_safety_doc)]

use crate::error::{Error, Result, Status};
use crate::sim::Simulation;
use std::cell::RefCell;
use std::os::raw::{c_char, c_int};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::Once;

pub mod agree;
pub mod contact;
pub mod friction;
pub mod handle;
pub mod indentation;
pub mod indentation_axisym;
pub mod io;
pub mod layout;
pub mod particles;
pub mod query;
pub mod run;

/// The communicator type of `mpi.h` (a transparent newtype in mpi-sys, so
/// the ABI matches).
/// cbindgen:no-export
#[allow(non_camel_case_types)]
pub type MPI_Comm = mpi_sys::MPI_Comm;

/// The Fortran communicator handle type of `mpi.h`.
/// cbindgen:no-export
#[allow(non_camel_case_types)]
pub type MPI_Fint = mpi_sys::RSMPI_Fint;

/// Success.
pub const GIMLET_OK: c_int = 0;
/// A required pointer (handle, buffer, output) was NULL.
pub const GIMLET_ERR_NULL_POINTER: c_int = 1;
/// An argument was outside its documented bounds.
pub const GIMLET_ERR_INVALID_ARGUMENT: c_int = 2;
/// The call is not allowed now (hierarchy frozen, MPI not initialized, ...).
pub const GIMLET_ERR_INVALID_STATE: c_int = 3;
/// An MPI call failed.
pub const GIMLET_ERR_MPI: c_int = 4;
/// A PETSc call failed.
pub const GIMLET_ERR_PETSC: c_int = 5;
/// A file could not be written or read, or was rejected.
pub const GIMLET_ERR_IO: c_int = 6;
/// A caller buffer was too small; the needed count was reported.
pub const GIMLET_ERR_BUFFER_TOO_SMALL: c_int = 7;
/// The solution became unstable or the time step exceeded the stable bound.
pub const GIMLET_ERR_UNSTABLE: c_int = 8;
/// Particles left the domain during a step.
pub const GIMLET_ERR_PARTICLES_LEFT: c_int = 9;
/// An internal error (a caught panic); the handle then refuses every call
/// except `gimlet_destroy`.
pub const GIMLET_ERR_INTERNAL: c_int = 10;

/// The C status code of an error status.
pub(crate) fn status_code(s: Status) -> c_int {
    match s {
        Status::Ok => GIMLET_OK,
        Status::NullPointer => GIMLET_ERR_NULL_POINTER,
        Status::InvalidArgument => GIMLET_ERR_INVALID_ARGUMENT,
        Status::InvalidState => GIMLET_ERR_INVALID_STATE,
        Status::Mpi => GIMLET_ERR_MPI,
        Status::Petsc => GIMLET_ERR_PETSC,
        Status::Io => GIMLET_ERR_IO,
        Status::BufferTooSmall => GIMLET_ERR_BUFFER_TOO_SMALL,
        Status::Unstable => GIMLET_ERR_UNSTABLE,
        Status::ParticlesLeft => GIMLET_ERR_PARTICLES_LEFT,
        Status::Internal => GIMLET_ERR_INTERNAL,
    }
}

/// The opaque simulation handle.
pub struct GimletSim {
    pub(crate) sim: Simulation,
    /// Output settings (HDF5/XDMF series and CSV series): the handle's,
    /// not part of the simulated state, so a checkpoint read keeps them.
    pub(crate) outputs: crate::io::Outputs,
    pub(crate) poisoned: bool,
}

thread_local! {
    static LAST_ERROR: RefCell<String> = const { RefCell::new(String::new()) };
    static IN_FFI: RefCell<bool> = const { RefCell::new(false) };
    static PANIC_MSG: RefCell<String> = const { RefCell::new(String::new()) };
}

static HOOK: Once = Once::new();

/// Installs (once) a panic hook that stays silent for panics raised inside a
/// `gimlet_*` call and records their message; other panics go to the
/// previous hook.
fn install_hook() {
    HOOK.call_once(|| {
        let prev = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if IN_FFI.with(|f| *f.borrow()) {
                let msg = if let Some(s) = info.payload().downcast_ref::<&str>() {
                    s.to_string()
                } else if let Some(s) = info.payload().downcast_ref::<String>() {
                    s.clone()
                } else {
                    "unknown panic".to_string()
                };
                let loc = info
                    .location()
                    .map(|l| format!(" at {}:{}", l.file(), l.line()))
                    .unwrap_or_default();
                PANIC_MSG.with(|m| *m.borrow_mut() = format!("{msg}{loc}"));
            } else {
                prev(info);
            }
        }));
    });
}

pub(crate) fn set_last_error(msg: &str) {
    LAST_ERROR.with(|e| {
        let mut e = e.borrow_mut();
        e.clear();
        e.push_str(msg);
    });
}

/// The `Internal` error of the panic last caught on this thread.
pub(crate) fn panic_error() -> Error {
    let m = PANIC_MSG.with(|m| m.borrow().clone());
    Error::new(
        Status::Internal,
        format!("internal error (caught panic: {m})"),
    )
}

/// Runs `f` at the boundary: catches panics, records errors, returns a status.
pub(crate) fn guard(name: &str, f: impl FnOnce() -> Result<()>) -> c_int {
    install_hook();
    IN_FFI.with(|v| *v.borrow_mut() = true);
    let r = catch_unwind(AssertUnwindSafe(f));
    IN_FFI.with(|v| *v.borrow_mut() = false);
    let err = match r {
        Ok(Ok(())) => return GIMLET_OK,
        Ok(Err(e)) => e,
        Err(_) => panic_error(),
    };
    set_last_error(&format!("{name}: {}", err.msg));
    status_code(err.status)
}

/// Runs `f` on the simulation behind `sim` (checked for NULL and poison); a
/// caught panic poisons the handle.
pub(crate) fn with_sim(
    name: &str,
    sim: *mut GimletSim,
    f: impl FnOnce(&mut Simulation) -> Result<()>,
) -> c_int {
    if sim.is_null() {
        set_last_error(&format!(
            "{name}: sim is NULL; pass a handle from gimlet_create"
        ));
        return GIMLET_ERR_NULL_POINTER;
    }
    // SAFETY: non-null handles come from gimlet_create and live until
    // gimlet_destroy; the caller must not use one from two threads at once.
    let h = unsafe { &mut *sim };
    if h.poisoned {
        set_last_error(&format!(
            "{name}: the handle is unusable after an earlier internal error; destroy it"
        ));
        return GIMLET_ERR_INTERNAL;
    }
    let rc = guard(name, || f(&mut h.sim));
    if rc == GIMLET_ERR_INTERNAL {
        h.poisoned = true;
    }
    rc
}

/// A NULL check for an output or input pointer.
pub(crate) fn nonnull<T>(p: *const T, name: &str) -> Result<()> {
    if p.is_null() {
        return Err(Error::new(Status::NullPointer, format!("{name} is NULL")));
    }
    Ok(())
}

/// Checks a caller length (`n >= 0`, at most `max`).
pub(crate) fn check_len(n: i64, name: &str, max: i64) -> Result<usize> {
    if n < 0 || n > max {
        return Err(Error::arg(format!(
            "{name} = {n} must be between 0 and {max}"
        )));
    }
    Ok(n as usize)
}

/// A caller array of `n` elements as a slice (NULL allowed only when n = 0).
///
/// # Safety
/// `p` must point to `n` readable elements when non-null.
pub(crate) unsafe fn slice<'a, T>(p: *const T, n: usize, name: &str) -> Result<&'a [T]> {
    if n == 0 {
        return Ok(&[]);
    }
    nonnull(p, name)?;
    Ok(std::slice::from_raw_parts(p, n))
}

/// Writes `out` (records of `group` elements each) into a caller buffer with
/// room for `capacity` records, reporting the number of records in `count`
/// (also when the buffer is too small). A NULL buffer only asks for the count.
///
/// # Safety
/// `buf` must have room for `capacity` elements when non-null; `count` must
/// be valid.
pub(crate) unsafe fn fill_buffer<T: Copy>(
    out: &[T],
    group: usize,
    buf: *mut T,
    capacity: i64,
    count: *mut i64,
    name: &str,
) -> Result<()> {
    nonnull(count, "count")?;
    let records = (out.len() / group) as i64;
    if buf.is_null() {
        *count = records;
        return Ok(());
    }
    if capacity < 0 {
        return Err(Error::arg(format!("capacity = {capacity} must be >= 0")));
    }
    if capacity < records {
        *count = records;
        return Err(Error::new(
            Status::BufferTooSmall,
            format!("{name} has capacity {capacity} but {records} entries are needed (reported in count)"),
        ));
    }
    std::ptr::copy_nonoverlapping(out.as_ptr(), buf, out.len());
    *count = records;
    Ok(())
}

/// Copies the last error message of this thread into `buf` (NUL-terminated,
/// truncated to `len` bytes including the NUL) and stores the length needed
/// (including the NUL) in `needed` when it is not NULL. `buf` may be NULL
/// with `len` 0 to ask for the length only. Returns `GIMLET_OK`, or
/// `GIMLET_ERR_NULL_POINTER` when `buf` is NULL with `len > 0`. Local.
#[no_mangle]
pub unsafe extern "C" fn gimlet_last_error(
    buf: *mut c_char,
    len: usize,
    needed: *mut usize,
) -> c_int {
    LAST_ERROR.with(|e| {
        let e = e.borrow();
        let bytes = e.as_bytes();
        if !needed.is_null() {
            *needed = bytes.len() + 1;
        }
        if len == 0 {
            return GIMLET_OK;
        }
        if buf.is_null() {
            return GIMLET_ERR_NULL_POINTER;
        }
        let n = bytes.len().min(len - 1);
        std::ptr::copy_nonoverlapping(bytes.as_ptr() as *const c_char, buf, n);
        *buf.add(n) = 0;
        GIMLET_OK
    })
}

/// The library version (the same numbers as the `GIMLET_VERSION_*` macros
/// of the header the caller compiled against, when both match). Local; any
/// output pointer may be NULL.
#[no_mangle]
pub unsafe extern "C" fn gimlet_version(
    major: *mut c_int,
    minor: *mut c_int,
    patch: *mut c_int,
) -> c_int {
    let v = |s: &str| s.parse::<c_int>().unwrap_or(-1);
    if !major.is_null() {
        *major = v(env!("CARGO_PKG_VERSION_MAJOR"));
    }
    if !minor.is_null() {
        *minor = v(env!("CARGO_PKG_VERSION_MINOR"));
    }
    if !patch.is_null() {
        *patch = v(env!("CARGO_PKG_VERSION_PATCH"));
    }
    GIMLET_OK
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The calling thread's last error message (checks the reported size).
    pub(crate) fn message() -> String {
        let mut buf = vec![0 as c_char; 512];
        let mut needed = 0usize;
        // SAFETY: buffer of the given length.
        let rc = unsafe { gimlet_last_error(buf.as_mut_ptr(), buf.len(), &mut needed) };
        assert_eq!(rc, GIMLET_OK);
        let bytes: Vec<u8> = buf
            .iter()
            .take_while(|&&c| c != 0)
            .map(|&c| c as u8)
            .collect();
        assert_eq!(needed, bytes.len() + 1);
        String::from_utf8(bytes).unwrap()
    }

    #[test]
    fn panics_become_a_status_and_a_message() {
        let rc = guard("gimlet_test", || panic!("boom {}", 42));
        assert_eq!(rc, GIMLET_ERR_INTERNAL);
        let m = message();
        assert!(m.starts_with("gimlet_test: internal error"), "{m}");
        assert!(m.contains("boom 42"), "{m}");
    }

    #[test]
    fn errors_map_to_their_status() {
        let rc = guard("gimlet_test", || Err(Error::arg("n = -1 must be >= 0")));
        assert_eq!(rc, GIMLET_ERR_INVALID_ARGUMENT);
        assert_eq!(message(), "gimlet_test: n = -1 must be >= 0");
        assert_eq!(guard("gimlet_test", || Ok(())), GIMLET_OK);
    }

    #[test]
    fn fill_buffer_reports_counts() {
        let data = [1i64, 2, 3, 4, 5, 6, 7, 8];
        let mut count = -1i64;
        let mut buf = [0i64; 8];
        // SAFETY: buffers sized as passed.
        unsafe {
            fill_buffer(&data, 4, std::ptr::null_mut(), 0, &mut count, "cells").unwrap();
            assert_eq!(count, 2);
            let e = fill_buffer(&data, 4, buf.as_mut_ptr(), 1, &mut count, "cells").unwrap_err();
            assert_eq!(e.status, Status::BufferTooSmall);
            assert_eq!(count, 2);
            assert_eq!(buf, [0; 8]);
            fill_buffer(&data, 4, buf.as_mut_ptr(), 2, &mut count, "cells").unwrap();
            assert_eq!(buf, data);
        }
    }
}
