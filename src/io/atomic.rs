//! Atomic replacement of a file by a collective writer.
//!
//! [`write_atomic`] lets the writer produce the file under a temporary name in
//! the same directory (`.gimlet.tmp-<unique>`); only when every rank succeeded
//! does rank 0 flush it to disk and rename it over `path` (POSIX `rename` is
//! atomic within one file system). On any failure the temporary is removed and
//! the previous file at `path`, if any, is untouched.

use super::agree;
use crate::comm::Comm;
use crate::error::{Error, Result, Status};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{SystemTime, UNIX_EPOCH};

static COUNTER: AtomicU64 = AtomicU64::new(0);

/// A temporary name beside `path`, the same on every rank (rank 0 chooses
/// it from its process id, the clock and a counter).
pub fn temp_path(comm: &Comm, path: &Path) -> Result<PathBuf> {
    let nanos = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_nanos() as u64)
        .unwrap_or(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let mine = (u64::from(std::process::id()) << 32) ^ nanos ^ n.rotate_left(48);
    let from_root = comm.allgather_u64(mine)?[0];
    if path.file_name().is_none() {
        return Err(Error::arg(format!(
            "path '{}' has no file name",
            path.display()
        )));
    }
    // A short name whatever the length of the final one, so that MPI-IO
    // (which has limits on file names, see `h5`) only ever creates files
    // with short names; the rename to `path` is plain POSIX.
    Ok(path.with_file_name(format!(".gimlet.tmp-{from_root:016x}")))
}

/// Runs the collective `write(tmp)` to produce the file under a temporary
/// name, then moves it to `path` atomically. Collective over `comm`; `write`
/// is called on every rank (it decides which ranks write bytes). When `write`
/// fails on any rank, or the rename fails, every rank returns an error, the
/// temporary is removed and an existing file at `path` is left as it was.
pub fn write_atomic<F>(comm: &Comm, path: &Path, write: F) -> Result<()>
where
    F: FnOnce(&Path) -> Result<()>,
{
    let tmp = temp_path(comm, path)?;
    let written = agree(comm, write(&tmp));
    if written.is_err() {
        if comm.rank() == 0 && tmp.exists() {
            let _ = std::fs::remove_file(&tmp);
        }
        comm.barrier()?;
        return written;
    }
    let committed = if comm.rank() == 0 {
        commit(&tmp, path).inspect_err(|_| {
            let _ = std::fs::remove_file(&tmp);
        })
    } else {
        Ok(())
    };
    agree(comm, committed)
}

/// Flushes `tmp` to disk, renames it to `path` and flushes the directory.
fn commit(tmp: &Path, path: &Path) -> Result<()> {
    let io = |what: &str, e: std::io::Error| {
        Error::new(
            Status::Io,
            format!("{what} '{}' failed: {e}", path.display()),
        )
    };
    std::fs::File::open(tmp)
        .and_then(|f| f.sync_all())
        .map_err(|e| io("flushing the new", e))?;
    std::fs::rename(tmp, path).map_err(|e| io("renaming the temporary file to", e))?;
    // Best effort: make the rename itself durable (not every file system
    // supports syncing a directory).
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        if let Ok(d) = std::fs::File::open(dir) {
            let _ = d.sync_all();
        }
    }
    Ok(())
}
