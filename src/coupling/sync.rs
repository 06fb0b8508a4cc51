//! The synchronisation of two levels ([`Coupler::sync`]): level changes,
//! the old copies dropped, fresh copies made on both levels with their
//! time-level correction.

use super::copies::{deliver_copies, deliver_copy_pair, Arrivals, CopyBatch};
use super::layout::{cell_at, in_any, stencil_at, surely_in, surely_out, PairLayout};
use super::ring_field::{FieldExchange, FieldMaterials};
use super::{copy_depth, Coupler};
use crate::comm::Comm;
use crate::error::{Error, Result, Status};
use crate::geom::IBox;
use crate::kernel::grid::mf;
use crate::kernel::{speed_of, Grid};
use crate::level::{Departure, Level};
use crate::material::MatParams;
use crate::particles::{f64_field, CopyKind, PackedParticle, Particles};
use crate::records::Routed;

impl Coupler {
    /// Synchronises level `l` with level `l + 1` (collective): owned
    /// particles that crossed the fine region's boundary change level, the
    /// old copies are deleted, and fresh copies are made: coarse-owned
    /// particles in the fine ghost ring onto the fine level, fine-owned
    /// particles within [`copy_depth`] coarse cells inside the fine region onto
    /// the coarse level (first, since the ring copies' stress field needs
    /// them). Ring copies take the coarse level's nodal stress field, and
    /// copies' velocities are moved to their new level's time level (see
    /// the module notes). Copies are recreated rather than matched, so no
    /// search between levels is needed; arrivals are ordered by global id.
    ///
    /// A particle that left the fine level's region across the domain
    /// boundary goes to [`Coupler::outflow`] (it left the domain); one that
    /// lies in no patch of level `l` but inside the domain waits for the
    /// next coarser level. Errors are agreed across ranks at the end, after
    /// every exchange (no rank returns early while another waits in one).
    ///
    /// Cost: a pass over each level's particles (a flag and a position
    /// test per particle; patches that cannot hold a particle to move or
    /// copy are skipped whole, and positions well inside or well outside
    /// the fine boxes skip the cell computation), the copies themselves
    /// (those for this rank's patches appended one field at a time in
    /// their final order, those for other ranks written one field at a
    /// time into one message per rank), and the nodal field only where
    /// ring copies read it (nodes within a cell of the fine ghost ring)
    /// rather than over the whole coarse level. Buffers and layout masks
    /// are kept between synchronisations. The result is bitwise the same
    /// as making every copy by packing it and summing the field over the
    /// whole level: the same particles, values and order, and the same
    /// additions in the same order at every node read.
    pub fn sync(&mut self, levels: &mut [Level], l: usize, comm: &Comm) -> Result<()> {
        use crate::particles::{COPY_FROM_COARSER, COPY_FROM_FINER, OWNED};
        let nr = comm.size() as usize;
        let f = l + 1;
        if self.dt.is_empty() {
            // Outside a step: the copies made here are not those of a
            // step's end (see `Coupler::copies_dt_cfl1`).
            self.final_syncs = 0;
        }
        let (lo, hi) = levels.split_at_mut(f);
        let (coarse, fine) = (&mut lo[l], &mut hi[0]);
        let SyncScratch {
            to_coarse,
            to_fine,
            gone,
            pairs,
            cand,
            cand_b,
            sorted,
            mods,
            mods_b,
            arrivals,
            field,
            accel,
        } = &mut self.scratch;
        for b in [&mut *to_coarse, &mut *to_fine] {
            b.resize_with(nr, Vec::new);
            b.iter_mut().for_each(Vec::clear);
        }
        let mut transfers = 0u64;
        // Errors are noted and agreed at the end, after every exchange: no
        // rank returns early while another waits in one.
        let mut err: Option<Error> = None;
        // Owned particles that left the fine level during its steps: to the
        // coarse level (their records are packed particles already); one
        // outside the domain left it; one in no patch of this level but
        // inside the domain waits for the next coarser level.
        for rec in std::mem::take(&mut self.pending[f]) {
            let p = PackedParticle::new(&rec);
            let (x, y) = (p.x(), p.y());
            let c = coarse.cell_of(x, y);
            if let Some(q) = coarse.find_patch(c) {
                Routed::write(&mut to_coarse[coarse.owner[q] as usize], q, &rec);
                transfers += 1;
            } else if !coarse.domain.contains_cell(c[0], c[1]) {
                let id = p.id();
                self.outflow.push(Departure { id, x, y });
            } else if l > 0 {
                self.pending[l].push(rec);
            } else {
                note(
                    &mut err,
                    Err::<(), _>(Error::new(
                        Status::Internal,
                        format!(
                            "particle {} at ({x}, {y}) left level {f} and lies in no patch of level {l}",
                            p.id()
                        ),
                    )),
                );
            }
        }
        // Fine level: drop copies from the coarse level; hand owned
        // particles outside the fine region to the coarse level. A
        // particle lies in its patch's cells, so a patch inside the fine
        // region has none to hand over.
        if pairs.len() <= l {
            pairs.resize_with(l + 1, PairLayout::default);
        }
        let pair = &mut pairs[l];
        pair.update(coarse, fine);
        let (fo, fh) = (fine.origin, fine.h);
        // The largest half-lengths of the particles the two levels hold
        // (owned ones, with those that change level on both sides, and
        // copies: an over-estimate at most), for the depth of the copies'
        // layer.
        let (mut lp_c, mut lp_f) = (0.0f64, 0.0f64);
        for (_, p) in to_coarse.iter().flat_map(|b| Routed::all(b)) {
            lp_c = lp_c.max(p.lpx()).max(p.lpy());
        }
        for p in &mut fine.local {
            let parts = &p.parts;
            lp_f = lp_f.max(max_half_length(parts));
            let inside = fine.owned.iter().any(|b| b.contains_box(&p.cells));
            gone.clear();
            for i in 0..parts.len() {
                let c = parts.copy[i];
                let drop = if c == COPY_FROM_COARSER {
                    true
                } else if c == OWNED && !inside {
                    let (x, y) = (parts.x[i], parts.y[i]);
                    let moved = !surely_in(&pair.owned_in, x, y)
                        && !in_any(&fine.owned, cell_at(fo, fh, x, y))
                        && coarse.pack_for(parts, i, to_coarse);
                    if moved {
                        lp_c = lp_c.max(parts.lpx[i]).max(parts.lpy[i]);
                    }
                    transfers += moved as u64;
                    moved
                } else {
                    false
                };
                if drop {
                    gone.push(i);
                }
            }
            p.parts.remove_sorted(gone);
        }
        // Coarse level: drop copies from the fine level; hand owned
        // particles inside the fine region to the fine level (only a patch
        // whose cells reach the fine region can hold one).
        for p in &mut coarse.local {
            let parts = &p.parts;
            lp_c = lp_c.max(max_half_length(parts));
            let reach = p.cells.refine().grow(1);
            let near = fine.owned.iter().any(|b| b.overlaps(&reach));
            gone.clear();
            for i in 0..parts.len() {
                let c = parts.copy[i];
                let drop = if c == COPY_FROM_FINER {
                    true
                } else if c == OWNED && near {
                    let (x, y) = (parts.x[i], parts.y[i]);
                    let moved = !surely_out(&pair.owned_around, x, y)
                        && in_any(&fine.owned, cell_at(fo, fh, x, y))
                        && fine.pack_for(parts, i, to_fine);
                    if moved {
                        lp_f = lp_f.max(parts.lpx[i]).max(parts.lpy[i]);
                    }
                    transfers += moved as u64;
                    moved
                } else {
                    false
                };
                if drop {
                    gone.push(i);
                }
            }
            p.parts.remove_sorted(gone);
        }
        // Level changes are rare: one agreement for both levels (with the
        // half-lengths), and the deliveries only when some rank has a
        // particle to move.
        let moving = to_coarse
            .iter()
            .chain(to_fine.iter())
            .any(|b| !b.is_empty());
        let mut agreed = [f64::from(u8::from(moving)), lp_c, lp_f];
        comm.max_f64(&mut agreed)?;
        let (mappings, smoothing) = self.reach.unwrap_or((2, 0));
        pair.set_depth(
            copy_depth(mappings, smoothing, agreed[1], agreed[2], coarse.h),
            fine,
        );
        if agreed[0] > 0.0 {
            note(&mut err, coarse.deliver(comm, to_coarse));
            note(&mut err, fine.deliver(comm, to_fine));
        }
        for b in to_coarse.iter_mut().chain(to_fine.iter_mut()) {
            b.clear();
        }
        // Time levels: with the schemes' staggering, a level's particle
        // velocity lags (USL, MUSL) its stress by half of that level's step,
        // so a copy's velocity is moved by half a fine step (the difference
        // of the two half steps) along the owner's last acceleration, read
        // from the owner's grid (`lag` gives the sign). Without it the
        // copies carry the other level's phase, an O(dt) error at the
        // boundary that drained about 2 % of the energy per period of the
        // vibrating plate at cfl 0.5; with it, 0.1 %.
        let shift = match (self.dt.get(l), self.dt.get(f)) {
            (Some(&dc), Some(&df)) if dc > 0.0 && df > 0.0 => 0.5 * df * self.lag,
            _ => 0.0,
        };
        // Fresh copies of the fine particles on the coarse level first
        // (delivered at once when the ring copies are smoothed with the
        // coarse nodal field, which needs them; see below).
        cand.clear();
        // A fine particle's coarse cell from its fine cell when the fine
        // cells halve the coarse ones exactly (the same origin, `fh` half of
        // `h`: `(x - o) / fh` is then exactly twice `(x - o) / h`, and the
        // floor of twice a number, halved, is the floor of the number);
        // otherwise by its own division.
        let halves = fo == coarse.origin && fh * 2.0 == coarse.h;
        // The last coarse patch found (consecutive particles mostly share
        // one; patches are disjoint, so a patch that holds the cell is the
        // one `find_patch` finds).
        let mut last: Option<(IBox, usize)> = None;
        for (pi, p) in fine.local.iter().enumerate() {
            if pair.deep.iter().any(|b| b.contains_box(&p.cells)) {
                continue;
            }
            let parts = &p.parts;
            for i in 0..parts.len() {
                if parts.copy[i] != OWNED {
                    continue;
                }
                let (x, y) = (parts.x[i], parts.y[i]);
                if surely_in(&pair.deep_in, x, y) {
                    continue;
                }
                let fc = cell_at(fo, fh, x, y);
                if in_any(&pair.deep, fc) {
                    continue;
                }
                let cc = if halves {
                    [fc[0] >> 1, fc[1] >> 1]
                } else {
                    cell_at(coarse.origin, coarse.h, x, y)
                };
                let q = match last {
                    Some((b, q)) if b.contains_cell(cc[0], cc[1]) => q,
                    _ => {
                        let Some(q) = coarse.find_patch(cc) else {
                            continue;
                        };
                        last = Some((coarse.patches[q], q));
                        q
                    }
                };
                cand.push(Candidate {
                    q: q as u32,
                    id: parts.id[i],
                    pi: pi as u32,
                    i: i as u32,
                });
            }
        }
        sort_candidates(cand, sorted);
        if shift != 0.0 {
            accelerations(&fine.local, cand, accel);
        }
        // Copies of fine particles change their velocity only: the other
        // fields are copied from their originals.
        mods.clear();
        mods.extend(cand.iter().flat_map(|c| {
            let p = &fine.local[c.pi as usize];
            let (parts, i) = (&p.parts, c.i as usize);
            let mut v = [parts.vx[i], parts.vy[i]];
            if shift != 0.0 {
                let (x, y) = (parts.x[i], parts.y[i]);
                let acc = &accel[c.pi as usize];
                if let Some(a) = p.grid.as_ref().and_then(|g| acceleration(g, acc, x, y)) {
                    v[0] -= shift * a[0];
                    v[1] -= shift * a[1];
                }
            }
            v
        }));
        if self.final_sync {
            // The stable step of the copies the step leaves on the coarse
            // level (their velocities are their own; the rest is their
            // originals').
            self.copies_dt[l][0] = copies_dt_cfl1(
                coarse.h,
                &self.mats,
                fine,
                cand,
                mods,
                N_VELOCITY,
                |p, i, _| [p.fxx[i], p.fxy[i], p.fyx[i], p.fyy[i]],
            );
        }
        let batch_a = CopyBatch {
            cand,
            mods,
            width: N_VELOCITY,
            kind: CopyKind::FromFiner,
        };
        // Fresh ring copies of the coarse particles. Where the fine ring's
        // velocities are prescribed (USL and MUSL, in a step) they keep
        // their owners' values; otherwise (USF, and a synchronisation
        // outside a step, before which the scheme may change) they take
        // the coarse level's nodal stress and deformation gradient at
        // their positions (see the module notes), whose sums need the
        // coarse level's fresh copies: those are delivered first. Ring
        // copies with their owners' values need nothing from them, so both
        // batches then go in one exchange after both are made (the rank
        // that makes most ring copies is not waited for twice).
        let smooth = self.dt.is_empty() || self.lag < 0.0;
        if smooth {
            let r = deliver_copies(coarse, fine, comm, batch_a, to_coarse, arrivals);
            note(&mut err, r);
        }
        let materials = self.dt.is_empty() || !self.one_material;
        if let Some(b) = note(
            &mut err,
            field.build(
                pair,
                coarse,
                fine,
                comm,
                cand_b,
                FieldMaterials {
                    check: materials,
                    owned_only: &self.owned_only,
                    sum: smooth,
                },
            ),
        ) {
            coarse.stats.bytes_sent += b;
        }
        sort_candidates(cand_b, sorted);
        if shift != 0.0 {
            accelerations(&coarse.local, cand_b, accel);
        }
        mods_b.clear();
        mods_b.extend(cand_b.iter().flat_map(|c| {
            let p = &coarse.local[c.pi as usize];
            let (parts, i) = (&p.parts, c.i as usize);
            let (x, y) = (parts.x[i], parts.y[i]);
            let mut m = own_mods(parts, i);
            if shift != 0.0 {
                let acc = &accel[c.pi as usize];
                if let Some(a) = p.grid.as_ref().and_then(|g| acceleration(g, acc, x, y)) {
                    m[0] = parts.vx[i] + shift * a[0];
                    m[1] = parts.vy[i] + shift * a[1];
                }
            }
            if !smooth {
                return m;
            }
            let own = [m[6], m[7], m[8], m[9], m[2], m[3], m[4], m[5], m[10]];
            let lin = self
                .owned_only
                .get(parts.material[i] as usize)
                .copied()
                .unwrap_or(false);
            let (stress, grad) = pair.smooth(p.k, x, y, parts.material[i], own, materials, lin);
            if let Some(s) = stress {
                m[6..10].copy_from_slice(&s);
            }
            if let Some(g) = grad {
                m[2..6].copy_from_slice(&g[..4]);
                m[10] = g[4];
            }
            m
        }));
        if self.final_sync {
            // The same for the ring copies on the fine level (velocity and
            // deformation gradient as the copies hold them).
            self.copies_dt[f][1] = copies_dt_cfl1(
                fine.h,
                &self.mats,
                coarse,
                cand_b,
                mods_b,
                N_MODS,
                |_, _, m| [m[M_FXX], m[M_FXX + 1], m[M_FXX + 2], m[M_FXX + 3]],
            );
        }
        let batch_b = CopyBatch {
            cand: cand_b,
            mods: mods_b,
            width: N_MODS,
            kind: CopyKind::FromCoarser,
        };
        let r = if smooth {
            deliver_copies(fine, coarse, comm, batch_b, to_fine, arrivals)
        } else {
            deliver_copy_pair(
                coarse, fine, comm, batch_a, batch_b, to_coarse, to_fine, arrivals,
            )
        };
        note(&mut err, r);
        let bad = comm.any(err.is_some())?;
        if let Some(e) = err {
            return Err(e);
        }
        if bad {
            return Err(Error::elsewhere(
                Status::Internal,
                format!("the synchronisation of levels {l} and {f} failed on another rank; see that rank's message"),
            ));
        }
        self.transfers += transfers;
        Ok(())
    }
}

/// `h / max (c + |v|)` over a batch of copies of `src`'s particles
/// (infinite for none), each with its original's material, the first two of
/// its `width` values in `mods` as its velocity and `f(original's fields,
/// its index, the values)` as its deformation gradient: what
/// [`crate::kernel::stable_dt_cfl1`] gives for the copies once made.
fn copies_dt_cfl1(
    h: f64,
    mats: &[MatParams],
    src: &Level,
    cand: &[Candidate],
    mods: &[f64],
    width: usize,
    f: impl Fn(&Particles, usize, &[f64]) -> [f64; 4],
) -> f64 {
    let top = cand
        .iter()
        .zip(mods.chunks_exact(width))
        .map(|(c, m)| {
            let (parts, i) = (&src.local[c.pi as usize].parts, c.i as usize);
            speed_of(
                &mats[parts.material[i] as usize],
                f(parts, i, m),
                [m[0], m[1]],
            )
        })
        .fold(0.0f64, f64::max);
    h / top
}

/// The largest half-length (`lpx`, `lpy`) of the particles (0 without
/// any), in independent lanes.
pub(super) fn max_half_length(p: &Particles) -> f64 {
    let mut top = [0.0f64; 4];
    for v in [&p.lpx[..], &p.lpy[..]] {
        let mut it = v.chunks_exact(4);
        for c in &mut it {
            for (t, &x) in top.iter_mut().zip(c) {
                *t = t.max(x);
            }
        }
        for &x in it.remainder() {
            top[0] = top[0].max(x);
        }
    }
    top.iter().fold(0.0, |a, &b| a.max(b))
}

/// Keeps the first error of `r` in `err`; the value on success.
pub(super) fn note<T>(err: &mut Option<Error>, r: Result<T>) -> Option<T> {
    match r {
        Ok(v) => Some(v),
        Err(e) => {
            err.get_or_insert(e);
            None
        }
    }
}

/// Sorts copies by `(q, id)`: a least-significant-digit radix sort by
/// bytes (stable; as many passes as the largest id and patch index have
/// bytes), with `tmp` as scratch.
pub(super) fn sort_candidates(cand: &mut Vec<Candidate>, tmp: &mut Vec<Candidate>) {
    let bytes = |m: u64| (64 - m.leading_zeros()).div_ceil(8) as usize;
    let max_id = cand.iter().map(|c| c.id).max().unwrap_or(0);
    let max_q = cand.iter().map(|c| c.q).max().unwrap_or(0);
    let digits = (0..bytes(max_id))
        .map(|b| (false, 8 * b))
        .chain((0..bytes(max_q as u64)).map(|b| (true, 8 * b)));
    for (of_q, shift) in digits {
        let digit = |c: &Candidate| {
            let v = if of_q { c.q as u64 } else { c.id };
            ((v >> shift) & 0xff) as usize
        };
        let mut count = [0usize; 256];
        for c in cand.iter() {
            count[digit(c)] += 1;
        }
        let mut at = 0;
        for n in count.iter_mut() {
            let k = *n;
            *n = at;
            at += k;
        }
        // Every slot is written below.
        tmp.resize(
            cand.len(),
            Candidate {
                q: 0,
                id: 0,
                pi: 0,
                i: 0,
            },
        );
        for c in cand.iter() {
            let d = digit(c);
            tmp[count[d]] = *c;
            count[d] += 1;
        }
        std::mem::swap(cand, tmp);
    }
}

/// The nodal accelerations (see [`node_accelerations`]) of the grids of
/// the local patches `local` that copies `cand` are made from, into
/// `accel` (indexed by local patch; others left empty).
pub(super) fn accelerations(
    local: &[crate::level::LocalPatch],
    cand: &[Candidate],
    accel: &mut Vec<Vec<[f64; 2]>>,
) {
    accel.resize_with(local.len(), Vec::new);
    accel.iter_mut().for_each(Vec::clear);
    for c in cand {
        let (p, a) = (&local[c.pi as usize], &mut accel[c.pi as usize]);
        if let (true, Some(g)) = (a.is_empty(), p.grid.as_ref()) {
            node_accelerations(g, a);
        }
    }
}

/// The f64 fields (indices into [`Particles::F64_NAMES`]) a copy may
/// change: `vx, vy` (its time level), `fxx, fxy, fyx, fyy`, `sxx, syy,
/// sxy, szz` and `fzz` (the nodal field, for ring copies); its copy flag is
/// set too.
pub(super) const MODS: [usize; N_MODS] = [
    f64_field("vx"),
    f64_field("vy"),
    f64_field("fxx"),
    f64_field("fxy"),
    f64_field("fyx"),
    f64_field("fyy"),
    f64_field("sxx"),
    f64_field("syy"),
    f64_field("sxy"),
    f64_field("szz"),
    f64_field("fzz"),
];

/// The number of fields a copy may change ([`MODS`]).
pub(super) const N_MODS: usize = 11;

/// Where `fxx, fxy, fyx, fyy` start among [`MODS`].
const M_FXX: usize = 2;

/// The number of leading fields of [`MODS`] a copy of a finer level's
/// particle changes: its velocity (`vx, vy`, its time level).
pub(super) const N_VELOCITY: usize = 2;

/// The f64 field index of the copy flag.
pub(super) const F_COPY: usize = f64_field("copy");

/// The values of particle `i` in the fields [`MODS`].
#[inline]
pub(super) fn own_mods(parts: &Particles, i: usize) -> [f64; N_MODS] {
    [
        parts.vx[i],
        parts.vy[i],
        parts.fxx[i],
        parts.fxy[i],
        parts.fyx[i],
        parts.fyy[i],
        parts.sxx[i],
        parts.syy[i],
        parts.sxy[i],
        parts.szz[i],
        parts.fzz[i],
    ]
}

/// A copy to make: particle `i` (global id `id`) of local patch `pi`,
/// going to patch `q` of the other level. Copies are sent and appended in
/// the order of `(q, id)`, the order in which [`Level::deliver`] appends
/// arrivals, so that each message's copies arrive in the order they are
/// merged in (see [`deliver_copies`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct Candidate {
    pub(super) q: u32,
    pub(super) id: u64,
    pub(super) pi: u32,
    pub(super) i: u32,
}

/// Scratch of [`Coupler::sync`] kept between synchronisations, so that a
/// synchronisation allocates nothing once warm (apart from what the
/// deliveries receive). It holds no state: a clone is empty.
#[derive(Default)]
pub(super) struct SyncScratch {
    /// Messages to the coarse level, one buffer per rank: the records of
    /// the particles moving to it (see [`Level::deliver`]), then the
    /// copies' columns (see [`deliver_copies`]).
    pub(super) to_coarse: Vec<Vec<u8>>,
    /// Messages to the fine level, one buffer per rank, as `to_coarse`.
    pub(super) to_fine: Vec<Vec<u8>>,
    /// Slots of a patch's particles to remove.
    pub(super) gone: Vec<usize>,
    /// Layout masks and nodal sums of each pair of levels (indexed by the
    /// coarse level).
    pub(super) pairs: Vec<PairLayout>,
    /// The copies to make.
    pub(super) cand: Vec<Candidate>,
    /// The ring copies to make, when they go in one exchange with the
    /// copies of `cand` (see [`deliver_copy_pair`]).
    pub(super) cand_b: Vec<Candidate>,
    /// Scratch of [`sort_candidates`].
    pub(super) sorted: Vec<Candidate>,
    /// The values of the copies that differ from their originals' (the
    /// leading fields of [`MODS`]), one set per copy, one after the other.
    pub(super) mods: Vec<f64>,
    /// The values of the copies of `cand_b`, as `mods`.
    pub(super) mods_b: Vec<f64>,
    /// Copies that arrive from other ranks and the merged order of a
    /// patch's arrivals (see [`deliver_copies`]).
    pub(super) arrivals: Arrivals,
    /// Buffers of the nodal field's exchange.
    pub(super) field: FieldExchange,
    /// Nodal accelerations of the local patches' grids that copies are
    /// made from (see [`accelerations`]), indexed by local patch.
    pub(super) accel: Vec<Vec<[f64; 2]>>,
}

impl Clone for SyncScratch {
    fn clone(&self) -> Self {
        SyncScratch::default()
    }
}

impl std::fmt::Debug for SyncScratch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("SyncScratch")
    }
}

/// The nodal accelerations of the last step on grid `g`: force over mass
/// at every node with mass (after boundary conditions: the kernel zeroes
/// constrained force components), zero at nodes without (never read).
pub(super) fn node_accelerations(g: &Grid, out: &mut Vec<[f64; 2]>) {
    out.clear();
    out.extend(g.mass.iter().zip(g.mom_force.iter()).map(|(&m, f)| {
        if m > 0.0 {
            [f.0[mf::FX] / m, f.0[mf::FY] / m]
        } else {
            [0.0, 0.0]
        }
    }));
}

/// The acceleration of the last step at `(x, y)`: the nodal accelerations
/// `acc` of grid `g` (see [`node_accelerations`]) interpolated bilinearly
/// over the stencil nodes with mass, their weights normalised; `None` when
/// no stencil node has mass.
pub(super) fn acceleration(g: &Grid, acc: &[[f64; 2]], x: f64, y: f64) -> Option<[f64; 2]> {
    let (k, w) = stencil_at(g.lo, g.n, g.origin, g.h, x, y)?;
    let mut a = [0.0; 2];
    let mut ws = 0.0;
    for n in 0..4 {
        if w[n] > 0.0 && g.mass[k[n]] > 0.0 {
            a[0] += w[n] * acc[k[n]][0];
            a[1] += w[n] * acc[k[n]][1];
            ws += w[n];
        }
    }
    (ws > 0.0).then(|| [a[0] / ws, a[1] / ws])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_changed_fields_are_the_values_a_copy_keeps_of_its_own() {
        let n = Particles::F64_NAMES;
        assert_eq!(n[F_COPY], "copy");
        let m: Vec<&str> = MODS.iter().map(|&k| n[k]).collect();
        assert_eq!(
            m,
            ["vx", "vy", "fxx", "fxy", "fyx", "fyy", "sxx", "syy", "sxy", "szz", "fzz"]
        );
        assert_eq!(m[M_FXX..M_FXX + 4], ["fxx", "fxy", "fyx", "fyy"]);
        let mut p = Particles::new();
        p.push(
            &crate::particles::NewParticle {
                id: 1,
                x: 0.5,
                y: 0.5,
                lpx: 0.1,
                lpy: 0.1,
                vx: 0.0,
                vy: 0.0,
                mass: 1.0,
                material: 0,
            },
            1.0,
        );
        for (k, v) in p.f64_fields_mut().into_iter().enumerate() {
            v[0] = 10.0 + k as f64;
        }
        let fields = p.f64_fields();
        let own = own_mods(&p, 0);
        for (j, &k) in MODS.iter().enumerate() {
            assert_eq!(own[j], fields[k][0], "{}", n[k]);
        }
    }

    #[test]
    fn candidates_sort_by_patch_then_id() {
        let mut s = 0x9e37_79b9_7f4a_7c15u64;
        for (n, id_bits, q_max) in [
            (0, 8, 3),
            (1, 8, 3),
            (500, 12, 7),
            (3000, 40, 300),
            (64, 64, 1),
        ] {
            let mut cand: Vec<Candidate> = (0..n)
                .map(|k| {
                    s ^= s << 13;
                    s ^= s >> 7;
                    s ^= s << 17;
                    Candidate {
                        q: (s % q_max) as u32,
                        id: if id_bits == 64 {
                            s
                        } else {
                            s >> (64 - id_bits)
                        },
                        pi: k,
                        i: k,
                    }
                })
                .collect();
            let mut want = cand.clone();
            want.sort_by_key(|c| (c.q, c.id, c.pi));
            sort_candidates(&mut cand, &mut Vec::new());
            let key = |v: &[Candidate]| v.iter().map(|c| (c.q, c.id, c.pi)).collect::<Vec<_>>();
            assert_eq!(key(&cand), key(&want));
        }
    }
}
