//! The MPI layer: an owned duplicate of the caller's communicator and the few
//! collectives the library needs (reductions, prefix sums, all-to-all exchange
//! of byte buffers). Everything above this module speaks to MPI through it.
//!
//! The duplicate has `MPI_ERRORS_RETURN` set, so an MPI failure becomes an
//! `Error` with status `Mpi` instead of aborting the host.

use crate::error::{Error, Result, Status};
use mpi_sys as ffi;
use std::os::raw::{c_int, c_void};

/// The MPI communicator type, as `mpi.h` spells it.
pub type RawComm = ffi::MPI_Comm;

/// True when `MPI_Init` has been called and `MPI_Finalize` has not.
pub fn mpi_usable() -> bool {
    let mut init: c_int = 0;
    let mut fin: c_int = 0;
    // SAFETY: both calls are allowed before MPI_Init and after MPI_Finalize.
    unsafe {
        ffi::MPI_Initialized(&mut init);
        ffi::MPI_Finalized(&mut fin);
    }
    init != 0 && fin == 0
}

fn check(rc: c_int, what: &str) -> Result<()> {
    if rc == 0 {
        return Ok(());
    }
    let mut buf = vec![0 as std::os::raw::c_char; 512];
    let mut len: c_int = 0;
    // SAFETY: the buffer is MPI_MAX_ERROR_STRING-sized (Open MPI: 256).
    unsafe { ffi::MPI_Error_string(rc, buf.as_mut_ptr(), &mut len) };
    let text: String = buf[..len.clamp(0, 511) as usize]
        .iter()
        .map(|&c| c as u8 as char)
        .collect();
    Err(Error::new(
        Status::Mpi,
        format!("{what} failed with MPI error {rc}: {text}"),
    ))
}

/// An owned duplicate of a caller's communicator, freed on drop.
#[derive(Debug)]
pub struct Comm {
    raw: RawComm,
    rank: i32,
    size: i32,
}

// SAFETY: the communicator handle is only used from the thread that owns the
// simulation; MPI handles are plain values.
unsafe impl Send for Comm {}

/// How many consecutive empty slots of Open MPI's Fortran-handle table
/// [`check_handle`] scans past the last live communicator before it
/// concludes that a handle is not in the table. Open MPI gives a new
/// communicator the lowest free slot, so live communicators sit at the
/// bottom of the table; a gap this long needs thousands of communicators
/// freed below a live one.
const F2C_SCAN_GAP: i32 = 4096;

/// True when the MPI library is Open MPI (whose `MPI_Comm` is a pointer and
/// whose `MPI_Comm_f2c` returns a NULL pointer for an invalid handle).
fn is_open_mpi() -> bool {
    static OPEN_MPI: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *OPEN_MPI.get_or_init(|| {
        let mut buf = vec![0 as std::os::raw::c_char; 8192];
        let mut len: c_int = 0;
        // SAFETY: MPI_Get_library_version may be called at any time; the
        // buffer is larger than MPI_MAX_LIBRARY_VERSION_STRING (Open MPI: 256).
        unsafe { ffi::MPI_Get_library_version(buf.as_mut_ptr(), &mut len) };
        let text: String = buf[..len.clamp(0, 8191) as usize]
            .iter()
            .map(|&c| c as u8 as char)
            .collect();
        text.contains("Open MPI")
    })
}

/// True when `comm` is a live communicator of Open MPI's Fortran-handle
/// table (every communicator Open MPI creates gets a slot; freeing it clears
/// the slot). `MPI_Comm_f2c` never invokes an error handler (MPI-3.1
/// section 17.2.4) and dereferences nothing but the table.
fn in_f2c_table(comm: RawComm) -> bool {
    let mut gap = 0;
    let mut i: ffi::RSMPI_Fint = 0;
    while gap <= F2C_SCAN_GAP {
        // SAFETY: MPI is initialized (checked by the caller); f2c only reads
        // Open MPI's table and returns NULL past its end.
        let c = unsafe { ffi::RSMPI_Comm_f2c(i) };
        if c == comm {
            return true;
        }
        if c.0.is_null() {
            gap += 1;
        } else {
            gap = 0;
        }
        i += 1;
    }
    false
}

/// Checks, without any MPI call that could invoke an error handler (Open
/// MPI's default, `MPI_ERRORS_ARE_FATAL`, aborts the process), that `comm`
/// is a live intra-communicator: MPI is initialized and not finalized, the
/// handle is not a NULL pointer (what Open MPI's `MPI_Comm_f2c` returns for
/// an invalid Fortran handle), not `MPI_COMM_NULL` (what `MPI_Comm_free`
/// leaves in the caller's variable), and, with Open MPI, in the table of live
/// communicators (a copy of a freed handle is not); then that it is not an
/// inter-communicator. `name` names the argument in messages.
///
/// What cannot be detected: a handle that is valid on some ranks and not on
/// others (the valid ranks wait in `MPI_Comm_dup` for the others); different
/// communicators on different ranks; a freed handle whose memory Open MPI
/// has since given to a new communicator (it is then that communicator).
pub fn check_handle(comm: RawComm, name: &str) -> Result<()> {
    if !mpi_usable() {
        return Err(Error::state(
            "MPI is not initialized (or already finalized): call MPI_Init before creating a simulation; the library never initializes MPI itself",
        ));
    }
    if comm.0.is_null() {
        return Err(Error::arg(format!(
            "{name} is not a communicator handle (a NULL pointer, which is what MPI_Comm_f2c returns for an invalid Fortran handle); pass a valid communicator"
        )));
    }
    // SAFETY: reading an extern static handle.
    if comm == unsafe { ffi::RSMPI_COMM_NULL } {
        return Err(Error::arg(format!(
            "{name} is MPI_COMM_NULL (for example a communicator already freed); pass a valid communicator"
        )));
    }
    if is_open_mpi() && !in_f2c_table(comm) {
        return Err(Error::arg(format!(
            "{name} is not a live communicator of this process (it was freed, or is not a communicator handle); pass a valid communicator"
        )));
    }
    let mut inter: c_int = 0;
    // SAFETY: comm is a live communicator (checked above).
    check(
        unsafe { ffi::MPI_Comm_test_inter(comm, &mut inter) },
        "MPI_Comm_test_inter",
    )?;
    if inter != 0 {
        return Err(Error::arg(format!(
            "{name} is an inter-communicator; pass an intra-communicator (for example MPI_COMM_WORLD or one made by MPI_Comm_split)"
        )));
    }
    Ok(())
}

impl Comm {
    /// Duplicates `comm` (the caller keeps theirs) after [`check_handle`].
    /// The duplication runs with `MPI_ERRORS_RETURN` set on `comm` for its
    /// duration (the caller's error handler is restored afterwards), so a
    /// failure is an error status, not an abort; the duplicate keeps
    /// `MPI_ERRORS_RETURN`. Collective over `comm`.
    pub fn dup(comm: RawComm) -> Result<Comm> {
        check_handle(comm, "comm")?;
        let mut raw = unsafe { ffi::RSMPI_COMM_NULL };
        let mut old = std::mem::MaybeUninit::<ffi::MPI_Errhandler>::uninit();
        // SAFETY: comm is a live communicator (checked above); the error
        // handler returned is a new reference, freed below.
        let have_old = unsafe { ffi::MPI_Comm_get_errhandler(comm, old.as_mut_ptr()) } == 0;
        if have_old {
            unsafe { ffi::MPI_Comm_set_errhandler(comm, ffi::RSMPI_ERRORS_RETURN) };
        }
        // SAFETY: as above.
        let rc = unsafe { ffi::MPI_Comm_dup(comm, &mut raw) };
        if have_old {
            // SAFETY: old was filled by MPI_Comm_get_errhandler.
            unsafe {
                let mut old = old.assume_init();
                ffi::MPI_Comm_set_errhandler(comm, old);
                ffi::MPI_Errhandler_free(&mut old);
            }
        }
        check(rc, "MPI_Comm_dup")?;
        // From here on `c` frees the duplicate on every error path.
        let mut c = Comm {
            raw,
            rank: 0,
            size: 0,
        };
        // SAFETY: raw is our own valid duplicate.
        check(
            unsafe { ffi::MPI_Comm_set_errhandler(raw, ffi::RSMPI_ERRORS_RETURN) },
            "MPI_Comm_set_errhandler",
        )?;
        check(
            unsafe { ffi::MPI_Comm_rank(raw, &mut c.rank) },
            "MPI_Comm_rank",
        )?;
        check(
            unsafe { ffi::MPI_Comm_size(raw, &mut c.size) },
            "MPI_Comm_size",
        )?;
        Ok(c)
    }

    /// Duplicates the communicator given by its Fortran handle: a negative
    /// handle is rejected at once; others are converted with
    /// `MPI_Comm_f2c` (which maps an invalid handle to an invalid C handle
    /// without invoking an error handler) and checked by [`Comm::dup`].
    pub fn from_fortran(fcomm: ffi::RSMPI_Fint) -> Result<Comm> {
        if !mpi_usable() {
            return Self::dup(unsafe { ffi::RSMPI_COMM_NULL });
        }
        if fcomm < 0 {
            return Err(Error::arg(format!(
                "fcomm = {fcomm} is not a Fortran communicator handle (handles are >= 0); pass MPI_COMM_WORLD or another valid communicator"
            )));
        }
        // SAFETY: MPI is initialized; f2c maps invalid handles to an invalid
        // C handle (NULL in Open MPI) without invoking an error handler.
        let c = unsafe { ffi::RSMPI_Comm_f2c(fcomm) };
        if c.0.is_null() {
            return Err(Error::arg(format!(
                "fcomm = {fcomm} is not a live Fortran communicator handle (never created, or freed); pass MPI_COMM_WORLD or another valid communicator"
            )));
        }
        Self::dup(c)
    }

    /// `MPI_COMM_WORLD` duplicated (for tests and drivers).
    pub fn world() -> Result<Comm> {
        Self::dup(unsafe { ffi::RSMPI_COMM_WORLD })
    }

    /// This process's rank.
    pub fn rank(&self) -> i32 {
        self.rank
    }

    /// Number of ranks.
    pub fn size(&self) -> i32 {
        self.size
    }

    /// The raw handle (owned by `self`; do not free it).
    pub fn raw(&self) -> RawComm {
        self.raw
    }

    fn allreduce(
        &self,
        v: &mut [u8],
        n: usize,
        ty: ffi::MPI_Datatype,
        op: ffi::MPI_Op,
    ) -> Result<()> {
        // mpi-sys does not export MPI_IN_PLACE: reduce from a copy.
        let send = v.to_vec();
        let rc = unsafe {
            ffi::MPI_Allreduce(
                send.as_ptr() as *const c_void,
                v.as_mut_ptr() as *mut c_void,
                n as c_int,
                ty,
                op,
                self.raw,
            )
        };
        check(rc, "MPI_Allreduce")
    }

    /// In-place sum of `v` over all ranks.
    pub fn sum_f64(&self, v: &mut [f64]) -> Result<()> {
        let n = v.len();
        let bytes = as_bytes_mut(v);
        self.allreduce(bytes, n, unsafe { ffi::RSMPI_DOUBLE }, unsafe {
            ffi::RSMPI_SUM
        })
    }

    /// In-place max of `v` over all ranks.
    pub fn max_f64(&self, v: &mut [f64]) -> Result<()> {
        let n = v.len();
        self.allreduce(as_bytes_mut(v), n, unsafe { ffi::RSMPI_DOUBLE }, unsafe {
            ffi::RSMPI_MAX
        })
    }

    /// In-place min of `v` over all ranks.
    pub fn min_f64(&self, v: &mut [f64]) -> Result<()> {
        let n = v.len();
        self.allreduce(as_bytes_mut(v), n, unsafe { ffi::RSMPI_DOUBLE }, unsafe {
            ffi::RSMPI_MIN
        })
    }

    /// In-place sum of `v` over all ranks.
    pub fn sum_u64(&self, v: &mut [u64]) -> Result<()> {
        let n = v.len();
        self.allreduce(as_bytes_mut(v), n, unsafe { ffi::RSMPI_UINT64_T }, unsafe {
            ffi::RSMPI_SUM
        })
    }

    /// In-place max of `v` over all ranks.
    pub fn max_u64(&self, v: &mut [u64]) -> Result<()> {
        let n = v.len();
        self.allreduce(as_bytes_mut(v), n, unsafe { ffi::RSMPI_UINT64_T }, unsafe {
            ffi::RSMPI_MAX
        })
    }

    /// In-place min of `v` over all ranks.
    pub fn min_u64(&self, v: &mut [u64]) -> Result<()> {
        let n = v.len();
        self.allreduce(as_bytes_mut(v), n, unsafe { ffi::RSMPI_UINT64_T }, unsafe {
            ffi::RSMPI_MIN
        })
    }

    /// Rank `root`'s `bytes` on every rank (collective; the other ranks'
    /// `bytes` are replaced). Two broadcasts: the length, then the bytes.
    pub fn bcast_bytes(&self, root: i32, bytes: &mut Vec<u8>) -> Result<()> {
        let mut len = bytes.len() as u64;
        // SAFETY: one u64 on every rank.
        let rc = unsafe {
            ffi::MPI_Bcast(
                &mut len as *mut u64 as *mut c_void,
                1,
                ffi::RSMPI_UINT64_T,
                root,
                self.raw,
            )
        };
        check(rc, "MPI_Bcast")?;
        if self.rank != root {
            bytes.clear();
            bytes.try_reserve_exact(len as usize).map_err(|_| {
                Error::new(
                    Status::Mpi,
                    format!("cannot allocate {len} bytes for a broadcast"),
                )
            })?;
            bytes.resize(len as usize, 0);
        }
        if len == 0 {
            return Ok(());
        }
        let n = c_int::try_from(len).map_err(|_| {
            Error::new(
                Status::Mpi,
                format!("a broadcast of {len} bytes is too long"),
            )
        })?;
        // SAFETY: every rank's buffer holds `len` bytes.
        let rc = unsafe {
            ffi::MPI_Bcast(
                bytes.as_mut_ptr() as *mut c_void,
                n,
                ffi::RSMPI_UINT8_T,
                root,
                self.raw,
            )
        };
        check(rc, "MPI_Bcast")
    }

    /// True on every rank when `flag` is true on any rank.
    pub fn any(&self, flag: bool) -> Result<bool> {
        let mut v = [flag as u64];
        self.max_u64(&mut v)?;
        Ok(v[0] != 0)
    }

    /// Exclusive prefix sum of `v` over ranks (0 on rank 0).
    pub fn exscan_u64(&self, v: u64) -> Result<u64> {
        let mut out: u64 = 0;
        let rc = unsafe {
            ffi::MPI_Exscan(
                &v as *const u64 as *const c_void,
                &mut out as *mut u64 as *mut c_void,
                1,
                ffi::RSMPI_UINT64_T,
                ffi::RSMPI_SUM,
                self.raw,
            )
        };
        check(rc, "MPI_Exscan")?;
        Ok(if self.rank == 0 { 0 } else { out })
    }

    /// Every rank's `v`, in rank order.
    pub fn allgather_u64(&self, v: u64) -> Result<Vec<u64>> {
        let mut out = vec![0u64; self.size as usize];
        let rc = unsafe {
            ffi::MPI_Allgather(
                &v as *const u64 as *const c_void,
                1,
                ffi::RSMPI_UINT64_T,
                out.as_mut_ptr() as *mut c_void,
                1,
                ffi::RSMPI_UINT64_T,
                self.raw,
            )
        };
        check(rc, "MPI_Allgather")?;
        Ok(out)
    }

    /// Every rank's bytes `mine`, concatenated in rank order (collective).
    pub fn allgatherv_bytes(&self, mine: &[u8]) -> Result<Vec<u8>> {
        let counts: Vec<c_int> = self
            .allgather_u64(mine.len() as u64)?
            .iter()
            .map(|&c| c as c_int)
            .collect();
        let mut displ = vec![0 as c_int; counts.len()];
        for i in 1..counts.len() {
            displ[i] = displ[i - 1] + counts[i - 1];
        }
        let total: usize = counts.iter().map(|&c| c as usize).sum();
        // Real allocations on both sides (see `alltoallv_into`).
        let mut sbuf: Vec<u8> = Vec::with_capacity(mine.len() + 1);
        sbuf.extend_from_slice(mine);
        let mut rbuf: Vec<u8> = Vec::with_capacity(total + 1);
        rbuf.resize(total, 0);
        let rc = unsafe {
            ffi::MPI_Allgatherv(
                sbuf.as_ptr() as *const c_void,
                mine.len() as c_int,
                ffi::RSMPI_UINT8_T,
                rbuf.as_mut_ptr() as *mut c_void,
                counts.as_ptr(),
                displ.as_ptr(),
                ffi::RSMPI_UINT8_T,
                self.raw,
            )
        };
        check(rc, "MPI_Allgatherv")?;
        Ok(rbuf)
    }

    /// Sends `send[r]` to rank `r` for every `r` and returns what each rank
    /// sent to this one, concatenated in rank order, with the per-rank counts.
    pub fn alltoallv_bytes(&self, send: &[Vec<u8>]) -> Result<(Vec<u8>, Vec<usize>)> {
        let (mut sbuf, mut rbuf, mut counts) = (Vec::new(), Vec::new(), Vec::new());
        let total = self.alltoallv_into(&[send], &mut sbuf, &mut rbuf, &mut counts)?;
        rbuf.truncate(total);
        Ok((rbuf, counts))
    }

    /// [`Comm::alltoallv_bytes`] into buffers the caller keeps between
    /// calls: what each rank sent to this one is `rbuf[..n]`, concatenated
    /// in rank order, with `n` returned and the per-rank counts in
    /// `counts`. `sbuf` is scratch for the concatenated outgoing bytes.
    /// Once the buffers are as large as the exchanges, a call allocates
    /// nothing and does not clear `rbuf` (bytes past `n` are left over from
    /// earlier calls). The bytes for rank `r` are `parts[0][r]`, then
    /// `parts[1][r]` and so on: several sets of messages go in one
    /// exchange.
    pub fn alltoallv_into(
        &self,
        parts: &[&[Vec<u8>]],
        sbuf: &mut Vec<u8>,
        rbuf: &mut Vec<u8>,
        counts: &mut Vec<usize>,
    ) -> Result<usize> {
        let p = self.size as usize;
        assert!(
            parts.iter().all(|s| s.len() == p),
            "alltoallv_into needs one buffer per rank in each part"
        );
        let scounts: Vec<c_int> = (0..p)
            .map(|r| parts.iter().map(|s| s[r].len()).sum::<usize>() as c_int)
            .collect();
        let mut rcounts = vec![0 as c_int; p];
        let rc = unsafe {
            ffi::MPI_Alltoall(
                scounts.as_ptr() as *const c_void,
                1,
                ffi::RSMPI_INT32_T,
                rcounts.as_mut_ptr() as *mut c_void,
                1,
                ffi::RSMPI_INT32_T,
                self.raw,
            )
        };
        check(rc, "MPI_Alltoall")?;
        let displs = |c: &[c_int]| -> Vec<c_int> {
            let mut d = vec![0 as c_int; c.len()];
            for i in 1..c.len() {
                d[i] = d[i - 1] + c[i - 1];
            }
            d
        };
        let sdispl = displs(&scounts);
        let rdispl = displs(&rcounts);
        // Both buffers hold at least one byte: with two empty Vecs the
        // pointers would coincide, which Open MPI rejects as aliasing.
        sbuf.clear();
        sbuf.reserve(scounts.iter().map(|&c| c as usize).sum::<usize>() + 1);
        for r in 0..p {
            for s in parts {
                sbuf.extend_from_slice(&s[r]);
            }
        }
        sbuf.push(0);
        let total: usize = rcounts.iter().map(|&c| c as usize).sum();
        if rbuf.len() <= total {
            rbuf.try_reserve_exact(total + 1 - rbuf.len())
                .map_err(|_| {
                    Error::new(
                        Status::Mpi,
                        format!("cannot allocate {total} bytes to receive an exchange"),
                    )
                })?;
            rbuf.resize(total + 1, 0u8);
        }
        let rc = unsafe {
            ffi::MPI_Alltoallv(
                sbuf.as_ptr() as *const c_void,
                scounts.as_ptr(),
                sdispl.as_ptr(),
                ffi::RSMPI_UINT8_T,
                rbuf.as_mut_ptr() as *mut c_void,
                rcounts.as_ptr(),
                rdispl.as_ptr(),
                ffi::RSMPI_UINT8_T,
                self.raw,
            )
        };
        check(rc, "MPI_Alltoallv")?;
        counts.clear();
        counts.extend(rcounts.iter().map(|&c| c as usize));
        Ok(total)
    }

    /// Point-to-point exchange with known peers (not collective): sends
    /// `sends[k].1` to rank `sends[k].0` and receives `recvs[k].1` bytes
    /// from rank `recvs[k].0`, returning the received buffers in the order
    /// of `recvs`. Both sides must agree on the sizes and use the same `tag`.
    pub fn exchange_with(
        &self,
        sends: &[(i32, &[u8])],
        recvs: &[(i32, usize)],
        tag: i32,
    ) -> Result<Vec<Vec<u8>>> {
        let mut bufs: Vec<Vec<u8>> = recvs.iter().map(|&(_, n)| vec![0u8; n]).collect();
        let mut reqs = Vec::with_capacity(sends.len() + recvs.len());
        for (b, &(r, n)) in bufs.iter_mut().zip(recvs) {
            let mut req = unsafe { ffi::RSMPI_REQUEST_NULL };
            // SAFETY: the buffer outlives the request (waited on below).
            let rc = unsafe {
                ffi::MPI_Irecv(
                    b.as_mut_ptr() as *mut c_void,
                    n as c_int,
                    ffi::RSMPI_UINT8_T,
                    r,
                    tag,
                    self.raw,
                    &mut req,
                )
            };
            check(rc, "MPI_Irecv")?;
            reqs.push(req);
        }
        for &(r, b) in sends {
            let mut req = unsafe { ffi::RSMPI_REQUEST_NULL };
            // SAFETY: the buffer outlives the request (waited on below).
            let rc = unsafe {
                ffi::MPI_Isend(
                    b.as_ptr() as *const c_void,
                    b.len() as c_int,
                    ffi::RSMPI_UINT8_T,
                    r,
                    tag,
                    self.raw,
                    &mut req,
                )
            };
            check(rc, "MPI_Isend")?;
            reqs.push(req);
        }
        // SAFETY: every request was started above.
        let rc = unsafe {
            ffi::MPI_Waitall(
                reqs.len() as c_int,
                reqs.as_mut_ptr(),
                ffi::RSMPI_STATUSES_IGNORE,
            )
        };
        check(rc, "MPI_Waitall")?;
        Ok(bufs)
    }

    /// Blocks until every rank arrives.
    pub fn barrier(&self) -> Result<()> {
        check(unsafe { ffi::MPI_Barrier(self.raw) }, "MPI_Barrier")
    }
}

impl Drop for Comm {
    fn drop(&mut self) {
        if mpi_usable() {
            // SAFETY: raw is our own duplicate, freed exactly once.
            unsafe { ffi::MPI_Comm_free(&mut self.raw) };
        }
    }
}

fn as_bytes_mut<T: Copy>(v: &mut [T]) -> &mut [u8] {
    // SAFETY: T is a plain-old-data number type (f64/u64) here.
    unsafe { std::slice::from_raw_parts_mut(v.as_mut_ptr() as *mut u8, std::mem::size_of_val(v)) }
}
