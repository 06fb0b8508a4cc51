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

impl Comm {
    /// Duplicates `comm` (the caller keeps theirs). Fails with a clear status
    /// when MPI is not initialized or `comm` is `MPI_COMM_NULL`.
    pub fn dup(comm: RawComm) -> Result<Comm> {
        if !mpi_usable() {
            return Err(Error::state(
                "MPI is not initialized (or already finalized): call MPI_Init before creating a simulation; the library never initializes MPI itself",
            ));
        }
        // SAFETY: reading an extern static handle.
        if comm == unsafe { ffi::RSMPI_COMM_NULL } {
            return Err(Error::arg(
                "comm is MPI_COMM_NULL; pass a valid communicator",
            ));
        }
        let mut raw = unsafe { ffi::RSMPI_COMM_NULL };
        // SAFETY: comm is a communicator handle from the caller; MPI checks it.
        check(unsafe { ffi::MPI_Comm_dup(comm, &mut raw) }, "MPI_Comm_dup")?;
        unsafe { ffi::MPI_Comm_set_errhandler(raw, ffi::RSMPI_ERRORS_RETURN) };
        let mut rank = 0;
        let mut size = 0;
        unsafe {
            ffi::MPI_Comm_rank(raw, &mut rank);
            ffi::MPI_Comm_size(raw, &mut size);
        }
        Ok(Comm { raw, rank, size })
    }

    /// Duplicates the communicator given by its Fortran handle.
    pub fn from_fortran(fcomm: ffi::RSMPI_Fint) -> Result<Comm> {
        if !mpi_usable() {
            return Self::dup(unsafe { ffi::RSMPI_COMM_NULL });
        }
        // SAFETY: MPI is initialized; f2c maps invalid handles to MPI_COMM_NULL.
        let c = unsafe { ffi::RSMPI_Comm_f2c(fcomm) };
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
        // Real allocations on both sides (see `alltoallv_bytes`).
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
        let p = self.size as usize;
        assert_eq!(send.len(), p, "alltoallv_bytes needs one buffer per rank");
        let scounts: Vec<c_int> = send.iter().map(|b| b.len() as c_int).collect();
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
        // Both buffers get a real allocation: with two empty Vecs the
        // pointers would coincide, which Open MPI rejects as aliasing.
        let mut sbuf: Vec<u8> = Vec::with_capacity(send.iter().map(|b| b.len()).sum::<usize>() + 1);
        for b in send {
            sbuf.extend_from_slice(b);
        }
        let total: usize = rcounts.iter().map(|&c| c as usize).sum();
        let mut rbuf = Vec::with_capacity(total + 1);
        rbuf.resize(total, 0u8);
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
        Ok((rbuf, rcounts.iter().map(|&c| c as usize).collect()))
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
