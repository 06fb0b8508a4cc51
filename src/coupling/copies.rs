//! Copy delivery: the copies one level makes of the other's particles,
//! appended to their patches here or sent column-wise to other ranks.

use super::sync::{Candidate, F_COPY, MODS};
use crate::comm::Comm;
use crate::error::{Error, Result, Status};
use crate::level::Level;
use crate::particles::{CopyKind, Particles};
use crate::records::CopyColumns;
use crate::storage::FieldVec;

/// Scratch of [`deliver_copies`].
#[derive(Default)]
pub(super) struct Arrivals {
    /// Per rank: the indices into the copies of those going to its
    /// patches (in the copies' order), for the other ranks.
    pub(super) to: Vec<Vec<u32>>,
    /// One message's copies as runs of consecutive particles of one source
    /// patch: (source patch, first particle, length).
    pub(super) send_runs: Vec<[u32; 3]>,
    /// Copies from other ranks, sorted by (patch, id, offset).
    pub(super) remote: Vec<RemoteCopy>,
    /// One patch's arrivals in order: an index into the copies, or
    /// [`REMOTE`] plus an index into `remote`.
    pub(super) order: Vec<u32>,
    /// One patch's local arrivals: (slot among the arrivals, index into
    /// the copies, source patch, particle).
    pub(super) local: Vec<[u32; 4]>,
    /// One patch's remote arrivals as runs of consecutive slots read from
    /// consecutive copies of one message: (first slot, offset of its
    /// first f64 field in the received bytes, the message's column length
    /// in bytes, length).
    pub(super) rest: Vec<[usize; 4]>,
    /// One patch's local arrivals as runs of consecutive slots copied
    /// from consecutive particles of one source patch: (first slot,
    /// source patch, first particle, length).
    pub(super) runs: Vec<[u32; 4]>,
    /// The outgoing messages concatenated (see [`Comm::alltoallv_into`]).
    pub(super) sbuf: Vec<u8>,
    /// The incoming messages, and bytes left over from larger exchanges.
    pub(super) rbuf: Vec<u8>,
    /// The incoming bytes per rank.
    pub(super) counts: Vec<usize>,
    /// Per rank, where the message of the batch being merged lies in
    /// `rbuf`: (first byte, length; 0 for none).
    pub(super) segs: Vec<(usize, usize)>,
    /// The same for the second batch of [`deliver_copy_pair`].
    pub(super) segs_b: Vec<(usize, usize)>,
}

/// A copy received from another rank (see [`deliver_copies`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct RemoteCopy {
    /// Its patch.
    pub(super) q: u32,
    /// Its global id.
    pub(super) id: u64,
    /// Offset of its f64 field 0 in the received bytes; field `k` is
    /// `k * stride` further.
    pub(super) at: usize,
    /// Bytes per column of its message (8 times the message's copies).
    pub(super) stride: usize,
    /// Its material.
    pub(super) material: u32,
}

/// Marks an entry of [`Arrivals::order`] as a copy from another rank.
pub(super) const REMOTE: u32 = 1 << 31;

/// Copies to make on the other level (see [`deliver_copies`]).
#[derive(Clone, Copy)]
pub(super) struct CopyBatch<'a> {
    /// The copies, sorted by `(q, id)`.
    pub(super) cand: &'a [Candidate],
    /// Their values that differ from their originals': the first
    /// `width` fields of [`MODS`], one set per copy, one after the other.
    pub(super) mods: &'a [f64],
    /// The number of fields of [`MODS`] in a set of `mods`.
    pub(super) width: usize,
    /// Their kind (the copy flag they get).
    pub(super) kind: CopyKind,
}

/// Delivers copies onto the patches of `dst` (collective): the batch's
/// `cand` (sorted by `(q, id)`) are particles of `src`'s local patches, to
/// be copied onto patch `q` of `dst` with the values `mods` (the first
/// `width` fields of [`MODS`], one set per copy) and the copy flag of the
/// batch's kind. Copies for other ranks' patches are written into `send`,
/// one message per rank ([`CopyColumns`]: the value in `mods` for those
/// fields, the batch's flag for the copy flag, the particle's own value
/// otherwise), the copies in `(q, id)` order; a rank with no copy gets an
/// empty message, and the exchange reuses `arr`'s buffers. Copies for this
/// rank's patches are appended directly; both are written one field at a
/// time, merged by `(patch, id)` (for equal ones, by sender and then
/// position): the particles and order that [`Level::deliver`] of all the
/// copies packed as records gives (every patch's arrivals sorted by global
/// id), without packing the local ones (and without its agreement on
/// whether anything moves: every rank exchanges). A message whose length
/// is not that of its header's copies is an [`Status::Internal`] error.
pub(super) fn deliver_copies(
    dst: &mut Level,
    src: &Level,
    comm: &Comm,
    batch: CopyBatch,
    send: &mut [Vec<u8>],
    arr: &mut Arrivals,
) -> Result<()> {
    let me = comm.rank();
    pack_copies(dst, src, me, batch, send, arr, false);
    // Copies exist at nearly every synchronisation: exchange without first
    // agreeing whether any rank has one (an empty exchange appends nothing).
    dst.stats.bytes_sent += send.iter().map(|b| b.len() as u64).sum::<u64>();
    let n_recv = comm.alltoallv_into(&[&*send], &mut arr.sbuf, &mut arr.rbuf, &mut arr.counts)?;
    arr.segs.clear();
    let mut at = 0usize;
    for &len in &arr.counts {
        arr.segs.push((at, len));
        at += len;
    }
    debug_assert_eq!(at, n_recv);
    merge_copies(dst, src, me, batch, false, arr)
}

/// Delivers two batches of copies in one exchange (collective): `a`, of
/// `fine`'s particles onto `coarse`, and `b`, of `coarse`'s particles onto
/// `fine`, as two calls of [`deliver_copies`] would, when neither batch's
/// values depend on the other's copies. Every rank sends each other rank
/// both messages (an empty one is its count alone), so the receiver finds
/// where the first ends; `a` is merged first.
#[allow(clippy::too_many_arguments)]
pub(super) fn deliver_copy_pair(
    coarse: &mut Level,
    fine: &mut Level,
    comm: &Comm,
    a: CopyBatch,
    b: CopyBatch,
    send_a: &mut [Vec<u8>],
    send_b: &mut [Vec<u8>],
    arr: &mut Arrivals,
) -> Result<()> {
    let me = comm.rank();
    pack_copies(coarse, fine, me, a, send_a, arr, true);
    pack_copies(fine, coarse, me, b, send_b, arr, true);
    coarse.stats.bytes_sent += send_a.iter().map(|m| m.len() as u64).sum::<u64>();
    fine.stats.bytes_sent += send_b.iter().map(|m| m.len() as u64).sum::<u64>();
    comm.alltoallv_into(
        &[&*send_a, &*send_b],
        &mut arr.sbuf,
        &mut arr.rbuf,
        &mut arr.counts,
    )?;
    arr.segs.clear();
    arr.segs_b.clear();
    let mut at = 0usize;
    for (r, &len) in arr.counts.iter().enumerate() {
        let la = if len == 0 {
            0
        } else {
            arr.rbuf
                .get(at..at + len)
                .and_then(CopyColumns::first_len)
                .ok_or_else(|| {
                    Error::new(
                        Status::Internal,
                        format!("rank {r} sent {len} bytes of two copy batches: the first batch's count does not fit"),
                    )
                })?
        };
        arr.segs.push((at, la));
        arr.segs_b.push((at + la, len - la));
        at += len;
    }
    merge_copies(coarse, fine, me, a, false, arr)?;
    merge_copies(fine, coarse, me, b, true, arr)
}

/// Writes the messages of `batch`'s copies for other ranks' patches of
/// `dst` into `send` (see [`deliver_copies`]); with `always`, a rank with
/// none gets a message of no copy (its count alone) instead of no bytes.
fn pack_copies(
    dst: &Level,
    src: &Level,
    me: i32,
    batch: CopyBatch,
    send: &mut [Vec<u8>],
    arr: &mut Arrivals,
    always: bool,
) {
    let (cand, mods, width) = (batch.cand, batch.mods, batch.width);
    let flag = batch.kind.flag();
    let (srcf, slot) = source_fields(src, width);
    arr.to.resize_with(send.len(), Vec::new);
    arr.to.iter_mut().for_each(Vec::clear);
    for (n, c) in cand.iter().enumerate().take(mods.len() / width.max(1)) {
        let r = dst.owner[c.q as usize];
        if r != me {
            arr.to[r as usize].push(n as u32);
        }
    }
    // Each message column by column, each column in one sequential pass.
    for (r, (buf, to)) in send.iter_mut().zip(&arr.to).enumerate() {
        buf.clear();
        if to.is_empty() {
            if always && r != me as usize {
                CopyColumns::write(buf, 0);
            }
            continue;
        }
        let n = to.len();
        arr.send_runs.clear();
        for &ci in to {
            let c = &cand[ci as usize];
            match arr.send_runs.last_mut() {
                Some(r) if r[0] == c.pi && r[1] + r[2] == c.i => r[2] += 1,
                _ => arr.send_runs.push([c.pi, c.i, 1]),
            }
        }
        let mut msg = CopyColumns::write(buf, n);
        msg.patches(to.iter().map(|&ci| cand[ci as usize].q));
        msg.ids(to.iter().map(|&ci| cand[ci as usize].id));
        msg.materials(to.iter().map(|&ci| {
            let c = &cand[ci as usize];
            src.local[c.pi as usize].parts.material[c.i as usize]
        }));
        for (k, &j) in slot.iter().enumerate() {
            if j != usize::MAX {
                msg.column(k, 0, to.iter().map(|&ci| mods[ci as usize * width + j]));
            } else if k == F_COPY {
                msg.column(k, 0, std::iter::repeat(flag));
            } else {
                let mut at = 0;
                for &[pi, i, len] in &arr.send_runs {
                    let (i, len) = (i as usize, len as usize);
                    msg.column(k, at, srcf[pi as usize][k][i..i + len].iter().copied());
                    at += len;
                }
            }
        }
    }
}

/// `src`'s f64 fields per local patch, and for each f64 field its index
/// among a batch's `width` values per copy (`usize::MAX` for a field the
/// copies take from their originals).
#[allow(clippy::type_complexity)]
fn source_fields(
    src: &Level,
    width: usize,
) -> (
    Vec<[&FieldVec<f64>; Particles::N_F64]>,
    [usize; Particles::N_F64],
) {
    let srcf = src.local.iter().map(|p| p.parts.f64_fields()).collect();
    let mut slot = [usize::MAX; Particles::N_F64];
    for (j, &k) in MODS.iter().enumerate().take(width) {
        slot[k] = j;
    }
    (srcf, slot)
}

/// Merges `batch`'s copies into `dst`'s patches: the local ones from
/// `src`, the remote ones from the messages at `arr.segs` (or, with
/// `second`, `arr.segs_b`) of `arr.rbuf` (see [`deliver_copies`]).
fn merge_copies(
    dst: &mut Level,
    src: &Level,
    me: i32,
    batch: CopyBatch,
    second: bool,
    arr: &mut Arrivals,
) -> Result<()> {
    let (cand, mods, width) = (batch.cand, batch.mods, batch.width);
    let flag = batch.kind.flag();
    let (srcf, slot) = source_fields(src, width);
    let recv = &arr.rbuf;
    let segs = if second { &arr.segs_b } else { &arr.segs };
    arr.remote.clear();
    for (r, &(start, len)) in segs.iter().enumerate() {
        if len == 0 {
            continue;
        }
        let Some(msg) = recv.get(start..start + len).and_then(CopyColumns::read) else {
            return Err(Error::new(
                Status::Internal,
                format!("rank {r} sent {len} bytes of copies: not a count and that many copies"),
            ));
        };
        arr.remote.extend(
            msg.patches()
                .zip(msg.ids())
                .zip(msg.materials())
                .enumerate()
                .map(|(p, ((q, id), material))| RemoteCopy {
                    q,
                    id,
                    at: start + msg.value_at(p),
                    stride: msg.stride(),
                    material,
                }),
        );
    }
    arr.remote.sort_unstable_by_key(|r| (r.q, r.id, r.at));
    let rem = &arr.remote;
    // Local copies (cand[ci..], skipping other ranks' patches) and remote
    // copies (rem[ri..]), both in (patch, id) order.
    let (mut ci, mut ri) = (0, 0);
    loop {
        while ci < cand.len() && dst.owner[cand[ci].q as usize] != me {
            ci += 1;
        }
        let q = match (cand.get(ci), rem.get(ri)) {
            (None, None) => break,
            (Some(c), None) => c.q,
            (None, Some(r)) => r.q,
            (Some(c), Some(r)) => c.q.min(r.q),
        };
        arr.order.clear();
        loop {
            while ci < cand.len() && dst.owner[cand[ci].q as usize] != me {
                ci += 1;
            }
            let c = cand.get(ci).filter(|c| c.q == q);
            let r = rem.get(ri).filter(|r| r.q == q);
            match (c, r) {
                (None, None) => break,
                (Some(c), Some(r)) if r.id < c.id => {
                    arr.order.push(REMOTE | ri as u32);
                    ri += 1;
                }
                (Some(_), _) => {
                    arr.order.push(ci as u32);
                    ci += 1;
                }
                (None, Some(_)) => {
                    arr.order.push(REMOTE | ri as u32);
                    ri += 1;
                }
            }
        }
        let Some(p) = dst.local_mut(q as usize) else {
            return Err(Error::new(
                Status::Internal,
                format!("a particle was sent to patch {q}, which this rank does not own"),
            ));
        };
        let parts = &mut p.parts;
        let order = &arr.order;
        parts.id.extend(order.iter().map(|&o| {
            if o & REMOTE != 0 {
                rem[(o & !REMOTE) as usize].id
            } else {
                cand[o as usize].id
            }
        }));
        parts.material.extend(order.iter().map(|&o| {
            if o & REMOTE != 0 {
                rem[(o & !REMOTE) as usize].material
            } else {
                let c = &cand[o as usize];
                src.local[c.pi as usize].parts.material[c.i as usize]
            }
        }));
        // The f64 fields, each written in place over its new slots: the
        // local copies and the remote ones apart (no branch per value),
        // both as runs where they are consecutive.
        arr.local.clear();
        arr.rest.clear();
        for (pos, &o) in order.iter().enumerate() {
            if o & REMOTE != 0 {
                let r = &rem[(o & !REMOTE) as usize];
                match arr.rest.last_mut() {
                    Some(s)
                        if s[0] + s[3] == pos && s[2] == r.stride && s[1] + 8 * s[3] == r.at =>
                    {
                        s[3] += 1
                    }
                    _ => arr.rest.push([pos, r.at, r.stride, 1]),
                }
            } else {
                let c = &cand[o as usize];
                arr.local.push([pos as u32, o, c.pi, c.i]);
            }
        }
        arr.runs.clear();
        for &[pos, _, pi, i] in &arr.local {
            match arr.runs.last_mut() {
                Some(r) if r[1] == pi && r[0] + r[3] == pos && r[2] + r[3] == i => r[3] += 1,
                _ => arr.runs.push([pos, pi, i, 1]),
            }
        }
        let n = order.len();
        for (k, v) in parts.f64_fields_mut().into_iter().enumerate() {
            let j = slot[k];
            let base = v.len();
            v.resize(base + n, 0.0);
            let d = &mut v[base..];
            if j != usize::MAX {
                for &[pos, o, _, _] in &arr.local {
                    d[pos as usize] = mods[o as usize * width + j];
                }
            } else if k == F_COPY {
                for &[pos, ..] in &arr.local {
                    d[pos as usize] = flag;
                }
            } else {
                for &[pos, pi, i, len] in &arr.runs {
                    let (pos, i, len) = (pos as usize, i as usize, len as usize);
                    d[pos..pos + len].copy_from_slice(&srcf[pi as usize][k][i..i + len]);
                }
            }
            for &[pos, at, stride, len] in &arr.rest {
                let col = CopyColumns::values(recv, at + k * stride, len);
                for (x, v) in d[pos..pos + len].iter_mut().zip(col) {
                    *x = v;
                }
            }
        }
    }
    Ok(())
}
