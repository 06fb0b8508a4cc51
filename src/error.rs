//! The library's error type: a status code and one sentence that names the bad
//! argument and the bound it broke. The C ABI turns it into a status code and a
//! thread-local message (see `ffi`).

use std::fmt;

/// Status codes returned by every C entry point (`0` is success).
#[repr(i32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    /// Success.
    Ok = 0,
    /// A required pointer (handle, buffer, output) was NULL.
    NullPointer = 1,
    /// An argument was out of its documented bounds.
    InvalidArgument = 2,
    /// The call is not allowed in the handle's current state (for example the
    /// hierarchy is frozen, or MPI is not initialized).
    InvalidState = 3,
    /// An MPI call failed.
    Mpi = 4,
    /// A PETSc call failed.
    Petsc = 5,
    /// An HDF5 or file-system operation failed, or a file was rejected.
    Io = 6,
    /// A caller buffer was too small; the needed size was reported.
    BufferTooSmall = 7,
    /// The solution became unstable (non-finite values, or a time step above
    /// the stable bound).
    Unstable = 8,
    /// Particles left the domain during a step (see the documented policy).
    ParticlesLeft = 9,
    /// A Rust panic was caught at the boundary; the handle may be inconsistent.
    Internal = 10,
}

/// An error with its status and a one-sentence message.
#[derive(Clone, Debug, PartialEq)]
pub struct Error {
    /// The status code the C ABI returns.
    pub status: Status,
    /// One sentence naming the argument and the bound it broke.
    pub msg: String,
    /// The failure happened on another rank: this rank only learned of it
    /// in a reduction and its message says so. When the ranks agree on the
    /// outcome of a call, an error of the failing rank itself wins over such
    /// an echo of the same status, so every rank reports the failing rank's
    /// message (the one naming the particle, patch or argument).
    pub elsewhere: bool,
}

impl Error {
    /// An error with the given status and message.
    pub fn new(status: Status, msg: impl Into<String>) -> Self {
        Error {
            status,
            msg: msg.into(),
            elsewhere: false,
        }
    }
    /// An echo of a failure on another rank (see [`Error::elsewhere`]).
    pub fn elsewhere(status: Status, msg: impl Into<String>) -> Self {
        Error {
            elsewhere: true,
            ..Self::new(status, msg)
        }
    }
    /// `InvalidArgument` with a message.
    pub fn arg(msg: impl Into<String>) -> Self {
        Self::new(Status::InvalidArgument, msg)
    }
    /// `InvalidState` with a message.
    pub fn state(msg: impl Into<String>) -> Self {
        Self::new(Status::InvalidState, msg)
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.msg)
    }
}

impl std::error::Error for Error {}

/// Result alias used throughout the crate.
pub type Result<T> = std::result::Result<T, Error>;
