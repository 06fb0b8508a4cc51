//! Output a user can open and restart files that continue exactly.
//!
//! - [`h5`]: a small safe wrapper over parallel HDF5 (collective files,
//!   distributed 1D/2D datasets, groups, attributes).
//! - [`format`]: the `gimlet_format` / `gimlet_format_version` tag on every
//!   file and its validation on open.
//! - [`atomic`]: replace a file only when the new one was written completely.
//! - [`xdmf`]: XDMF 3 descriptions of particle snapshots, and their check
//!   against the HDF5 files.
//! - [`csv`]: time-series CSV with round-trip numbers.
//! - [`snapshot`]: one output time of a simulation (particles and grid
//!   layout) in one HDF5 file.
//! - [`series`]: the output settings a handle carries: the HDF5 + XDMF
//!   output series and the CSV time series.
//! - [`checkpoint`]: checkpoint and restart that continue exactly.
//!
//! Every function taking a [`Comm`](crate::comm::Comm) is collective over it.

pub mod atomic;
pub mod checkpoint;
mod checkpoint_contact;
pub mod csv;
pub mod format;
pub mod h5;
pub mod series;
pub mod snapshot;
pub mod xdmf;

pub use series::Outputs;

use crate::comm::Comm;
use crate::error::{Error, Result, Status};

/// Makes a collective step's outcome the same on every rank: when any rank
/// failed, every rank returns the error of the lowest failing rank (status and
/// message), so callers on all ranks see the same explanation.
pub fn agree<T>(comm: &Comm, local: Result<T>) -> Result<T> {
    if !comm.any(local.is_err())? {
        return local;
    }
    let mine = match &local {
        Err(e) => {
            let mut b = (e.status as i32).to_le_bytes().to_vec();
            b.extend_from_slice(e.msg.as_bytes());
            b
        }
        Ok(_) => Vec::new(),
    };
    let send = vec![mine; comm.size() as usize];
    let (bytes, counts) = comm.alltoallv_bytes(&send)?;
    let mut start = 0;
    for c in counts {
        if c >= 4 {
            let b = &bytes[start..start + c];
            let code = i32::from_le_bytes([b[0], b[1], b[2], b[3]]);
            let msg = String::from_utf8_lossy(&b[4..]).into_owned();
            return Err(Error::new(status_from(code), msg));
        }
        start += c;
    }
    Err(Error::elsewhere(
        Status::Io,
        "a collective I/O step failed on another rank",
    ))
}

fn status_from(code: i32) -> Status {
    use Status::*;
    [
        Ok,
        NullPointer,
        InvalidArgument,
        InvalidState,
        Mpi,
        Petsc,
        Io,
        BufferTooSmall,
        Unstable,
        ParticlesLeft,
        Internal,
    ]
    .into_iter()
    .find(|s| *s as i32 == code)
    .unwrap_or(Io)
}
