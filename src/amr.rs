//! Nested levels (the paper's section 3.2): the recursive subcycled
//! advance (level `l + 1` takes two steps of half the size per step of
//! level `l`, fig. 8) and the synchronisation that couples two levels by
//! moving and copying particles, never splitting or merging them.
//!
//! Every particle is owned by exactly one level: the finest level whose
//! boxes hold it. A level also holds copies for coupling, flagged in
//! [`Particles::copy`]: a refined level holds copies of the coarser level's
//! particles in its ghost ring (`geom::RING` cells around its boxes); a
//! coarser level holds copies of the finer level's particles in a layer
//! inside the refined region as deep as one coarse step reaches (see
//! [`copy_depth`]; deeper, it holds nothing and does no work). Copies are
//! advanced with their level and thrown away at the next synchronisation,
//! where fresh ones are made from the owners. Because copies are recreated
//! rather than updated in place, no search for the matching particle on the
//! other level is needed (the paper's main cost): synchronisation is one
//! pass over the particles of the two levels plus one exchange; global ids
//! identify particles across levels and ranks, and arrivals are ordered by
//! id so that results do not depend on the number of ranks.
//!
//! Two details of the copies decide the accuracy of the coupling. Measured
//! on the vibrating plate (unit square, rollers, fundamental mode, 32
//! coarse cells, fine box `[0.25, 0.75]²`): the RMS displacement error over
//! `[0.375, 0.625]²`, largest of 8 samples in a period, as a multiple of
//! the uniform-coarse error, at cfl 0.5 / 0.25 / 0.125.
//!
//! **Ring copies take the coarse level's stress field, not its particles'
//! values.** On the coarse grid the velocity gradient is constant over most
//! of a coarse cell, so the fine-sized particles the coarse level owns around
//! a refined region carry a stress (and deformation gradient) that is a
//! staircase, one value per coarse cell, off by `h_c |∇σ| / 2` at the cell
//! edges. Copied as they are into the fine ghost ring, the steps put forces
//! of order `h_c |∇σ|` on the fine nodes at coarse-cell edges, the fine
//! region's boundary among them, and every synchronisation re-creates them
//! unrelaxed: an error injected per synchronisation, which pure FLIP keeps
//! in the velocities of the particles next to the boundary (2.1x / 3.2x /
//! 4.4x, growing as the step shrinks). A fresh ring copy therefore takes
//! its stress and deformation gradient from the coarse level's nodal field
//! at its position: the mass-weighted nodal average (bilinear weights) of
//! all the coarse level's particles, owned ones and copies of the finer
//! level's, interpolated bilinearly; continuous and second-order accurate.
//! Where a stencil node has no mass or holds several materials the copy
//! keeps its own values (no smoothing across material interfaces), and a
//! field equal to the particle's values to round-off leaves them untouched
//! (uniform states stay bitwise uniform).
//!
//! **Copies are put on their new level's time level.** The schemes stagger
//! velocity and stress: with USL and MUSL a level's particle velocity lags
//! its stress by half of that level's step (with USF it leads), so a coarse
//! particle's velocity is half a fine step further behind than the fine
//! level's, and a fine particle's half a fine step ahead of the coarse
//! level's. Copied unchanged, the copies carry the other level's phase into
//! the boundary at every synchronisation, an O(dt) error that drains energy
//! (-2 % per period at cfl 0.5 with the smoothed stress alone: 3.3x /
//! 1.5x / 1.25x). A copy's velocity is therefore moved by half a fine step
//! along its owner's last acceleration (nodal force over nodal mass of the
//! owner's grid, interpolated bilinearly): forward for ring copies, back
//! for copies on the coarser level. With both: 0.78x / 0.91x / 1.08x (the
//! fine region beats the coarse error at the default cfl), energy drift
//! +0.09 % per period at cfl 0.5 (uniform grids: 1e-6; before: -1.3 %). The correction needs the
//! step sizes, so it applies to synchronisations inside
//! [`Coupler::advance`]; the one a simulation makes before its first step
//! (or after particles are inserted or set) copies states as they are.

use crate::comm::Comm;
use crate::contact::Contact;
use crate::error::{Error, Result, Status};
use crate::geom::IBox;
use crate::kernel::grid::mf;
use crate::kernel::{Grid, Ramp, Scheme, StepParams, Transfer};
use crate::level::{Departure, Level, GHOST};
use crate::material::MatParams;
use crate::particles::Particles;
use crate::storage::FieldVec;

/// Depth, in coarse cells, of the layer inside a refined region in which
/// the coarse level keeps copies of the fine particles: the reach of one
/// coarse step, so that the coarse-owned particles outside the region see
/// the nodal data a coarse step over every particle would give. Deeper
/// inside, the coarse level holds no particles and does no work.
///
/// A step of `mappings` mappings (USL 1; MUSL and USF 2: a P2G whose nodal
/// values the next G2P reads, then another) and `smoothing` grid-particle-
/// grid passes (XPIC of order `smoothing + 1`) reads, for a coarse-owned
/// particle `P`, nodes within `h + lp_P` of it; those nodes' values come
/// from particles within `h + lp` of them, whose updated values come from
/// nodes within `h + lp`, and so on: `k = 2 (mappings + smoothing)` hops,
/// the first `P`'s, the others through copies. A fine particle deeper than
/// `k h + lp_coarse + (k - 1) lp_fine` inside the region (`lp_coarse` at
/// least the largest half-length of a coarse-owned particle, `lp_fine` of
/// a fine one; GIMP supports are open, MPM's are narrower) cannot reach `P`,
/// so the depth is that, rounded up. Checked on the 3-level pressure
/// indentation (fine particles of `h / 8`, coarse ones of `h / 4`; state
/// hash after 300 steps): MUSL and USF (depth 5, uGIMP/FLIP and cpGIMP/APIC)
/// and USL (depth 3) give the same bits as layers one and three cells
/// deeper and as the fixed 6 cells used before, and different ones one cell
/// shallower. Counting an XPIC pass as two hops over-estimates (XPIC(3)
/// with MUSL: depth 10, where 8 already gives the bits of deeper layers and
/// 7 does not; the fixed 6 did not). A simulation asks for two mappings
/// whatever its scheme (see [`Coupler::set_transfer`]).
pub fn copy_depth(mappings: u32, smoothing: u32, lp_coarse: f64, lp_fine: f64, h: f64) -> i64 {
    let k = 2.0 * f64::from(mappings + smoothing);
    let d = k + (lp_coarse.max(0.0) + (k - 1.0) * lp_fine.max(0.0)) / h;
    // Half-lengths are at most half a cell of their level: `d` is small;
    // anything else (not finite) copies the whole region.
    if d.is_finite() {
        d.ceil().max(1.0) as i64
    } else {
        i64::MAX / 4
    }
}

/// State of the coupling between levels.
#[derive(Clone, Debug, Default)]
pub struct Coupler {
    /// Owned particles that left a refined level's computational region
    /// during its steps, packed, to be handed to the next coarser level at
    /// the next synchronisation (indexed by level).
    pub pending: Vec<Vec<Vec<u8>>>,
    /// Particles this rank moved between levels (owner changes).
    pub transfers: u64,
    /// Owned particles that left a refined level across the domain
    /// boundary, found by the last synchronisation: they left the domain
    /// (the caller records them as lost, as for the coarsest level).
    pub outflow: Vec<Departure>,
    /// Step size of each level's last step, while [`Coupler::advance`]
    /// runs (empty otherwise: a synchronisation outside a step, after
    /// particles were inserted or set, makes copies without the time
    /// correction).
    dt: Vec<f64>,
    /// `+1` when the scheme's particle velocity lags its stress by half a
    /// step (USL, MUSL), `-1` when it leads (USF).
    lag: f64,
    /// Whether the material table has one material, while
    /// [`Coupler::advance`] runs (the nodal field then needs no material
    /// check).
    one_material: bool,
    /// Mappings and smoothing passes of a step of the scheme (see
    /// [`copy_depth`]), set by [`Coupler::set_transfer`]; two mappings and no
    /// smoothing until then.
    reach: Option<(u32, u32)>,
    /// Buffers and layout masks of [`Coupler::sync`], kept between
    /// synchronisations (no state: a clone starts empty).
    scratch: SyncScratch,
}

impl Coupler {
    /// Tells the coupling the transfer of the steps its copies serve (the
    /// depth of the copies' layer follows from it, see [`copy_depth`]).
    /// The layer is made for two mappings whatever the scheme: USL needs
    /// one, but a caller may switch to MUSL or USF between the
    /// synchronisation that makes the copies and the step they serve (a
    /// switch to more XPIC passes makes the simulation synchronise again,
    /// see [`Coupler::smoothing`]).
    pub fn set_transfer(&mut self, transfer: Transfer, xpic_order: u32) {
        self.reach = Some((2, Self::smoothing(transfer, xpic_order)));
    }

    /// The grid-particle-grid smoothing passes of a step with `transfer`
    /// (XPIC of order `m`: `m - 1`).
    pub fn smoothing(transfer: Transfer, xpic_order: u32) -> u32 {
        match transfer {
            Transfer::Xpic => xpic_order.saturating_sub(1),
            Transfer::Flip | Transfer::Apic => 0,
        }
    }

    /// Advances level `l` by one step of `prm.dt / 2^l` starting at time
    /// `t`, then (recursively) the finer levels by two half steps each, and
    /// synchronises each pair when they meet (the paper's fig. 8).
    ///
    /// A level's step leaves out of its last pass the copies whose updated
    /// state nothing reads before the next synchronisation replaces them
    /// (see [`Level::step`]): the copies of the finer level's particles,
    /// which live one step of their level (made by the synchronisation
    /// with the finer level after the step before, thrown away by the one
    /// after this step), and on the finest level, in the second of its two
    /// steps, the ring copies (the synchronisation with the coarser level
    /// that follows replaces them; a level with a finer one keeps them
    /// updated: that synchronisation's nodal field reads them). Owned
    /// particles, the grids and the copies the next step reads are the same
    /// bits as with the full pass.
    #[allow(clippy::too_many_arguments)]
    pub fn advance(
        &mut self,
        levels: &mut [Level],
        comm: &Comm,
        l: usize,
        t: f64,
        mats: &[MatParams],
        base: &StepParams,
        ramp: &Ramp,
        lost: &mut Vec<Departure>,
        contact: &mut Contact,
        thickness: f64,
    ) -> Result<()> {
        self.advance_level(
            levels, comm, l, t, false, mats, base, ramp, lost, contact, thickness,
        )
    }

    /// [`Coupler::advance`] of level `l`, whose step is the second of the
    /// two of its coarser level's step when `second`.
    #[allow(clippy::too_many_arguments)]
    fn advance_level(
        &mut self,
        levels: &mut [Level],
        comm: &Comm,
        l: usize,
        t: f64,
        second: bool,
        mats: &[MatParams],
        base: &StepParams,
        ramp: &Ramp,
        lost: &mut Vec<Departure>,
        contact: &mut Contact,
        thickness: f64,
    ) -> Result<()> {
        use crate::particles::{COPY_FROM_COARSER, COPY_FROM_FINER};
        let mut prm = *base;
        prm.dt = base.dt / (1u64 << l) as f64;
        prm.load_factor = ramp.factor(t);
        if l == 0 {
            self.set_transfer(base.transfer, base.xpic_order);
            self.dt = vec![0.0; levels.len()];
            self.one_material = mats.len() == 1;
            self.lag = match base.scheme {
                Scheme::Usf => -1.0,
                Scheme::Usl | Scheme::Musl => 1.0,
            };
        }
        let ctx = contact.level_step(l, t + prm.dt, thickness);
        // On one level nothing reads the grids between two steps (the
        // coupling of levels reads the last step's nodal forces): the last
        // pass may prepare the next step's first mapping.
        let next = (levels.len() == 1).then(|| ramp.factor(t + prm.dt));
        let finest = l + 1 == levels.len();
        let skip = if !finest {
            Some(COPY_FROM_FINER)
        } else if second && l > 0 {
            Some(COPY_FROM_COARSER)
        } else {
            None
        };
        let departures = match levels[l].step(comm, mats, &prm, ctx, next, skip) {
            Ok(d) => d,
            Err(e) => {
                self.dt.clear();
                return Err(e);
            }
        };
        self.dt[l] = prm.dt;
        if l == 0 {
            lost.extend(departures.into_iter().map(|d| d.0));
        } else {
            self.pending[l].extend(departures.into_iter().map(|d| d.1));
        }
        if l + 1 < levels.len() {
            self.advance_level(
                levels,
                comm,
                l + 1,
                t,
                false,
                mats,
                base,
                ramp,
                lost,
                contact,
                thickness,
            )?;
            self.advance_level(
                levels,
                comm,
                l + 1,
                t + 0.5 * prm.dt,
                true,
                mats,
                base,
                ramp,
                lost,
                contact,
                thickness,
            )?;
            let t0 = std::time::Instant::now();
            let r = self.sync(levels, l, comm);
            lost.append(&mut self.outflow);
            levels[l].stats.coupling += t0.elapsed().as_secs_f64();
            if r.is_err() || l == 0 {
                self.dt.clear();
            }
            r?;
        }
        if l == 0 {
            self.dt.clear();
        }
        Ok(())
    }

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
    /// copy are skipped whole, and positions well inside a box skip the
    /// cell computation), the copies themselves (those for this rank's
    /// patches appended one field at a time in their final order, those
    /// for other ranks written one field at a time into one message per
    /// rank), and the nodal field only where ring copies read it (nodes
    /// within a cell of the fine ghost ring) rather than over the whole
    /// coarse level. Buffers and layout masks are kept between
    /// synchronisations. The result is bitwise the same as making every
    /// copy by packing it and summing the field over the whole level: the
    /// same particles, values and order, and the same additions in the same
    /// order at every node read.
    pub fn sync(&mut self, levels: &mut [Level], l: usize, comm: &Comm) -> Result<()> {
        use crate::particles::{COPY_FROM_COARSER, COPY_FROM_FINER, OWNED};
        let nr = comm.size() as usize;
        let f = l + 1;
        let (lo, hi) = levels.split_at_mut(f);
        let (coarse, fine) = (&mut lo[l], &mut hi[0]);
        let SyncScratch {
            to_coarse,
            to_fine,
            gone,
            pairs,
            cand,
            sorted,
            mods,
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
            let (x, y) = (rec_f64(&rec, W_X), rec_f64(&rec, W_Y));
            let c = coarse.cell_of(x, y);
            if let Some(q) = coarse.find_patch(c) {
                let buf = &mut to_coarse[coarse.owner[q] as usize];
                buf.extend_from_slice(&(q as u64).to_le_bytes());
                buf.extend_from_slice(&rec);
                transfers += 1;
            } else if !coarse.domain.contains_cell(c[0], c[1]) {
                let id = rec_u64(&rec, 0);
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
                            rec_u64(&rec, 0)
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
        for rec in to_coarse
            .iter()
            .flat_map(|b| b.chunks_exact(8 + Particles::PACKED_BYTES))
        {
            lp_c = lp_c
                .max(rec_f64(&rec[8..], W_LPX))
                .max(rec_f64(&rec[8..], W_LPY));
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
                    let cell = cell_at(fo, fh, parts.x[i], parts.y[i]);
                    let moved = in_any(&fine.owned, cell) && fine.pack_for(parts, i, to_fine);
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
        // Fresh copies of the fine particles on the coarse level first: the
        // coarse nodal field the ring copies are smoothed with needs them.
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
        mods.clear();
        mods.extend(cand.iter().map(|c| {
            let p = &fine.local[c.pi as usize];
            let (parts, i) = (&p.parts, c.i as usize);
            let mut m = own_mods(parts, i);
            if shift != 0.0 {
                let (x, y) = (parts.x[i], parts.y[i]);
                let acc = &accel[c.pi as usize];
                if let Some(a) = p.grid.as_ref().and_then(|g| acceleration(g, acc, x, y)) {
                    m[0] = parts.vx[i] - shift * a[0];
                    m[1] = parts.vy[i] - shift * a[1];
                }
            }
            m
        }));
        let r = deliver_copies(
            coarse,
            fine,
            comm,
            cand,
            mods,
            COPY_FROM_FINER,
            to_coarse,
            arrivals,
        );
        note(&mut err, r);
        // Fresh ring copies of the coarse particles, with the coarse level's
        // nodal stress and deformation gradient at their positions.
        let materials = self.dt.is_empty() || !self.one_material;
        if let Some(b) = note(
            &mut err,
            field.build(pair, coarse, fine, comm, cand, materials),
        ) {
            coarse.stats.bytes_sent += b;
        }
        sort_candidates(cand, sorted);
        if shift != 0.0 {
            accelerations(&coarse.local, cand, accel);
        }
        mods.clear();
        mods.extend(cand.iter().map(|c| {
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
            let own = [m[6], m[7], m[8], m[9], m[2], m[3], m[4], m[5]];
            let (stress, grad) = pair.smooth(p.k, x, y, parts.material[i], own, materials);
            if let Some(s) = stress {
                m[6..10].copy_from_slice(&s);
            }
            if let Some(g) = grad {
                m[2..6].copy_from_slice(&g);
            }
            m
        }));
        let r = deliver_copies(
            fine,
            coarse,
            comm,
            cand,
            mods,
            COPY_FROM_COARSER,
            to_fine,
            arrivals,
        );
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

/// The largest half-length (`lpx`, `lpy`) of the particles (0 without
/// any), in independent lanes.
fn max_half_length(p: &Particles) -> f64 {
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
fn note<T>(err: &mut Option<Error>, r: Result<T>) -> Option<T> {
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
fn sort_candidates(cand: &mut Vec<Candidate>, tmp: &mut Vec<Candidate>) {
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
fn accelerations(
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

/// Scratch of [`deliver_copies`].
#[derive(Default)]
struct Arrivals {
    /// Per rank: the indices into the copies of those going to its
    /// patches (in the copies' order), for the other ranks.
    to: Vec<Vec<u32>>,
    /// One message's copies as runs of consecutive particles of one source
    /// patch: (source patch, first particle, length).
    send_runs: Vec<[u32; 3]>,
    /// Copies from other ranks, sorted by (patch, id, offset).
    remote: Vec<RemoteCopy>,
    /// One patch's arrivals in order: an index into the copies, or
    /// [`REMOTE`] plus an index into `remote`.
    order: Vec<u32>,
    /// One patch's local arrivals: (slot among the arrivals, index into
    /// the copies, source patch, particle).
    local: Vec<[u32; 4]>,
    /// One patch's remote arrivals as runs of consecutive slots read from
    /// consecutive copies of one message: (first slot, offset of its
    /// first f64 field in the received bytes, the message's column length
    /// in bytes, length).
    rest: Vec<[usize; 4]>,
    /// One patch's local arrivals as runs of consecutive slots copied
    /// from consecutive particles of one source patch: (first slot,
    /// source patch, first particle, length).
    runs: Vec<[u32; 4]>,
}

/// A copy received from another rank (see [`deliver_copies`]).
#[derive(Clone, Copy, Debug)]
struct RemoteCopy {
    /// Its patch.
    q: u32,
    /// Its global id.
    id: u64,
    /// Offset of its f64 field 0 in the received bytes; field `k` is
    /// `k * stride` further.
    at: usize,
    /// Bytes per column of its message (8 times the message's copies).
    stride: usize,
    /// Its material.
    material: u32,
}

/// Marks an entry of [`Arrivals::order`] as a copy from another rank.
const REMOTE: u32 = 1 << 31;

/// Bytes per copy in a message of [`deliver_copies`]: its patch (u32), id
/// (u64), material (u32) and [`Particles::N_F64`] f64 fields.
const COPY_BYTES: usize = 4 + 8 + 4 + 8 * Particles::N_F64;

/// The little-endian u32 in the 4 bytes `w`.
#[inline]
fn le_u32(w: &[u8]) -> u32 {
    u32::from_le_bytes(w.try_into().expect("4 bytes"))
}

/// The little-endian u64 in the 8 bytes `w`.
#[inline]
fn le_u64(w: &[u8]) -> u64 {
    u64::from_le_bytes(w.try_into().expect("8 bytes"))
}

/// Delivers copies onto the patches of `dst` (collective): `cand` (sorted
/// by `(q, id)`) are particles of `src`'s local patches, to be copied onto
/// patch `q` of `dst` with the values `mods` (one set per copy, see
/// [`MODS`]) and the copy flag `flag`. Copies for other ranks' patches are
/// written into `send`, one message per rank, column-wise: the number of
/// copies `n` (u64), then the `n` patches (u32), the `n` ids (u64), the
/// `n` materials (u32) and, for each f64 field `k` of
/// [`Particles::F64_NAMES`] in turn, its `n` values (the value in `mods`
/// for the fields [`MODS`], `flag` for the copy flag, the particle's own
/// value otherwise), all little-endian, the copies in `(q, id)` order; a
/// rank with no copy gets an empty message. Copies for this rank's patches
/// are appended directly; both are written one field at a time, merged by
/// `(patch, id)` (for equal ones, by sender and then position): the
/// particles and order that [`Level::deliver`] of all the copies packed
/// as records gives (every patch's arrivals sorted by global id), without
/// packing the local ones (and without its agreement on whether anything
/// moves: every rank exchanges). A message whose length is not that of
/// its header's copies is an [`Status::Internal`] error.
#[allow(clippy::too_many_arguments)]
fn deliver_copies(
    dst: &mut Level,
    src: &Level,
    comm: &Comm,
    cand: &[Candidate],
    mods: &[[f64; 10]],
    flag: f64,
    send: &mut [Vec<u8>],
    arr: &mut Arrivals,
) -> Result<()> {
    let me = comm.rank();
    let srcf: Vec<[&FieldVec<f64>; Particles::N_F64]> =
        src.local.iter().map(|p| p.parts.f64_fields()).collect();
    let mut slot = [usize::MAX; Particles::N_F64];
    for (j, &k) in MODS.iter().enumerate() {
        slot[k] = j;
    }
    arr.to.resize_with(send.len(), Vec::new);
    arr.to.iter_mut().for_each(Vec::clear);
    for (n, c) in cand.iter().enumerate().take(mods.len()) {
        let r = dst.owner[c.q as usize];
        if r != me {
            arr.to[r as usize].push(n as u32);
        }
    }
    // Each message column by column, each column in one sequential pass.
    for (buf, to) in send.iter_mut().zip(&arr.to) {
        buf.clear();
        if to.is_empty() {
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
        buf.resize(8 + n * COPY_BYTES, 0);
        let (head, body) = buf.split_at_mut(8);
        head.copy_from_slice(&(n as u64).to_le_bytes());
        let (qs, body) = body.split_at_mut(4 * n);
        let (ids, body) = body.split_at_mut(8 * n);
        let (mats, cols) = body.split_at_mut(4 * n);
        for (w, &ci) in qs.chunks_exact_mut(4).zip(to) {
            w.copy_from_slice(&cand[ci as usize].q.to_le_bytes());
        }
        for (w, &ci) in ids.chunks_exact_mut(8).zip(to) {
            w.copy_from_slice(&cand[ci as usize].id.to_le_bytes());
        }
        for (w, &ci) in mats.chunks_exact_mut(4).zip(to) {
            let c = &cand[ci as usize];
            let m = src.local[c.pi as usize].parts.material[c.i as usize];
            w.copy_from_slice(&m.to_le_bytes());
        }
        for (k, col) in cols.chunks_exact_mut(8 * n).enumerate() {
            let words = col.chunks_exact_mut(8).zip(to);
            let j = slot[k];
            if j != usize::MAX {
                for (w, &ci) in words {
                    w.copy_from_slice(&mods[ci as usize][j].to_le_bytes());
                }
            } else if k == F_COPY {
                for (w, _) in words {
                    w.copy_from_slice(&flag.to_le_bytes());
                }
            } else {
                let mut at = 0;
                for &[pi, i, len] in &arr.send_runs {
                    let (i, len) = (i as usize, len as usize);
                    let from = &srcf[pi as usize][k][i..i + len];
                    for (w, v) in col[at..at + 8 * len].chunks_exact_mut(8).zip(from) {
                        w.copy_from_slice(&v.to_le_bytes());
                    }
                    at += 8 * len;
                }
            }
        }
    }
    // Copies exist at nearly every synchronisation: exchange without first
    // agreeing whether any rank has one (an empty exchange appends nothing).
    dst.stats.bytes_sent += send.iter().map(|b| b.len() as u64).sum::<u64>();
    let (recv, counts) = comm.alltoallv_bytes(send)?;
    arr.remote.clear();
    let mut seg = 0usize;
    for (r, &len) in counts.iter().enumerate() {
        let start = seg;
        seg = seg.saturating_add(len);
        if len == 0 {
            continue;
        }
        let msg = recv.get(start..seg);
        let n = msg
            .and_then(|m| m.get(..8))
            .and_then(|h| usize::try_from(le_u64(h)).ok())
            .filter(|&n| n.checked_mul(COPY_BYTES).and_then(|b| b.checked_add(8)) == Some(len));
        let (Some(msg), Some(n)) = (msg, n) else {
            return Err(Error::new(
                Status::Internal,
                format!("rank {r} sent {len} bytes of copies: not a count and that many copies"),
            ));
        };
        let (qs, body) = msg[8..].split_at(4 * n);
        let (ids, body) = body.split_at(8 * n);
        let mats = &body[..4 * n];
        let at = start + 8 + 16 * n;
        arr.remote.extend(
            qs.chunks_exact(4)
                .zip(ids.chunks_exact(8))
                .zip(mats.chunks_exact(4))
                .enumerate()
                .map(|(p, ((q, id), m))| RemoteCopy {
                    q: le_u32(q),
                    id: le_u64(id),
                    at: at + 8 * p,
                    stride: 8 * n,
                    material: le_u32(m),
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
                    d[pos as usize] = mods[o as usize][j];
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
                let col = &recv[at + k * stride..at + k * stride + 8 * len];
                for (x, w) in d[pos..pos + len].iter_mut().zip(col.chunks_exact(8)) {
                    *x = f64::from_bits(le_u64(w));
                }
            }
        }
    }
    Ok(())
}

/// Number of nodal sums of the coarse nodal field: mass, mass times the
/// four stress components, the four deformation-gradient components, the
/// material index and its square.
const NF: usize = 11;

/// MPI tag of the exchange of the nodal field's partial sums.
const TAG_RING_FIELD: i32 = 23;

/// Word positions in a packed particle (see [`Particles::pack`]): the id,
/// the material, then f64 field `k` of [`Particles::F64_NAMES`] at `2 + k`.
const W_X: usize = 2;
/// Word of `y` in a packed particle.
const W_Y: usize = 3;
/// Word of `lpx` in a packed particle.
const W_LPX: usize = 12;
/// Word of `lpy` in a packed particle.
const W_LPY: usize = 13;
/// The f64 fields (indices into [`Particles::F64_NAMES`]) a copy may
/// change: `vx, vy` (its time level), `fxx, fxy, fyx, fyy` and `sxx, syy,
/// sxy, szz` (the nodal field, for ring copies); its copy flag is set too.
const MODS: [usize; 10] = [4, 5, 12, 13, 14, 15, 16, 17, 18, 19];

/// The f64 field index of the copy flag.
const F_COPY: usize = Particles::N_F64 - 1;

/// The values of particle `i` in the fields [`MODS`].
#[inline]
fn own_mods(parts: &Particles, i: usize) -> [f64; 10] {
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
    ]
}

/// Word `w` of a packed particle, as an integer.
fn rec_u64(rec: &[u8], w: usize) -> u64 {
    u64::from_le_bytes(rec[8 * w..8 * w + 8].try_into().expect("8 bytes"))
}

/// Word `w` of a packed particle, as an f64.
fn rec_f64(rec: &[u8], w: usize) -> f64 {
    f64::from_bits(rec_u64(rec, w))
}

/// `v.floor() as i64` (saturating, NaN to 0) without a call to `floor`.
#[inline]
fn floor_i64(v: f64) -> i64 {
    let t = v as i64;
    if (t as f64) > v {
        t.saturating_sub(1)
    } else {
        t
    }
}

/// The cell of a level with origin `o` and cell size `h` holding a point:
/// the same as [`Level::cell_of`].
#[inline]
fn cell_at(o: [f64; 2], h: f64, x: f64, y: f64) -> [i64; 2] {
    [floor_i64((x - o[0]) / h), floor_i64((y - o[1]) / h)]
}

/// The cells of a box as a rectangle of positions shrunk by a margin far
/// above the rounding of `(x - o) / h` and of the rectangle's corners: a
/// point strictly inside it lies in a cell of the box (a test without
/// division; points near the edges, or NaN, take the exact test).
#[derive(Clone, Copy, Debug)]
struct Inside {
    lo: [f64; 2],
    hi: [f64; 2],
}

impl Inside {
    fn of(b: &IBox, o: [f64; 2], h: f64) -> Inside {
        let axis = |a: usize| {
            let (lo, hi) = (o[a] + b.lo[a] as f64 * h, o[a] + b.hi[a] as f64 * h);
            let m = 1e-6 * h + 1e-12 * (o[a].abs() + lo.abs() + hi.abs());
            (lo + m, hi - m)
        };
        let (x, y) = (axis(0), axis(1));
        Inside {
            lo: [x.0, y.0],
            hi: [x.1, y.1],
        }
    }

    #[inline]
    fn holds(&self, x: f64, y: f64) -> bool {
        x > self.lo[0] && x < self.hi[0] && y > self.lo[1] && y < self.hi[1]
    }
}

/// Whether one of `boxes` surely holds `(x, y)` (see [`Inside`]).
#[inline]
fn surely_in(boxes: &[Inside], x: f64, y: f64) -> bool {
    boxes.iter().any(|b| b.holds(x, y))
}

/// Whether one of `boxes` contains cell `c`.
#[inline]
fn in_any(boxes: &[IBox], c: [i64; 2]) -> bool {
    boxes.iter().any(|b| b.contains_cell(c[0], c[1]))
}

/// A copy to make: particle `i` (global id `id`) of local patch `pi`,
/// going to patch `q` of the other level. Copies are sent and appended in
/// the order of `(q, id)`, the order in which [`Level::deliver`] appends
/// arrivals, so that each message's copies arrive in the order they are
/// merged in (see [`deliver_copies`]).
#[derive(Clone, Copy, Debug)]
struct Candidate {
    q: u32,
    id: u64,
    pi: u32,
    i: u32,
}

/// Scratch of [`Coupler::sync`] kept between synchronisations, so that a
/// synchronisation allocates nothing once warm (apart from what the
/// deliveries receive). It holds no state: a clone is empty.
#[derive(Default)]
struct SyncScratch {
    /// Messages to the coarse level, one buffer per rank: the records of
    /// the particles moving to it (see [`Level::deliver`]), then the
    /// copies' columns (see [`deliver_copies`]).
    to_coarse: Vec<Vec<u8>>,
    /// Messages to the fine level, one buffer per rank, as `to_coarse`.
    to_fine: Vec<Vec<u8>>,
    /// Slots of a patch's particles to remove.
    gone: Vec<usize>,
    /// Layout masks and nodal sums of each pair of levels (indexed by the
    /// coarse level).
    pairs: Vec<PairLayout>,
    /// The copies to make.
    cand: Vec<Candidate>,
    /// Scratch of [`sort_candidates`].
    sorted: Vec<Candidate>,
    /// The values of the copies that differ from their originals' (see
    /// [`MODS`]), one set per copy.
    mods: Vec<[f64; 10]>,
    /// Copies that arrive from other ranks and the merged order of a
    /// patch's arrivals (see [`deliver_copies`]).
    arrivals: Arrivals,
    /// Buffers of the nodal field's exchange.
    field: FieldExchange,
    /// Nodal accelerations of the local patches' grids that copies are
    /// made from (see [`accelerations`]), indexed by local patch.
    accel: Vec<Vec<[f64; 2]>>,
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

/// The layout of a pair of levels: coarse patches, fine boxes, fine owned
/// boxes, fine domain.
type LayoutKey = (Vec<IBox>, Vec<IBox>, Vec<IBox>, IBox);

/// What a pair of levels' layout decides for the coupling, computed once
/// per layout: the fine level's deep boxes and, per coarse patch, which
/// cells and nodes the ring copies' nodal field involves.
#[derive(Default)]
struct PairLayout {
    /// The layout these were computed for: coarse patches, fine boxes,
    /// fine owned boxes, fine domain.
    key: Option<LayoutKey>,
    /// The depth of the copies' layer, in coarse cells, `deep` was made
    /// for (0: none yet).
    depth: i64,
    /// The fine cells deep inside the fine region (no copies on the coarse
    /// level), see [`deep_boxes`].
    deep: Vec<IBox>,
    /// `deep` as positions (see [`Inside`]).
    deep_in: Vec<Inside>,
    /// The fine level's own boxes as positions (see [`Inside`]).
    owned_in: Vec<Inside>,
    /// Per coarse patch (built when this rank first holds it).
    patches: Vec<Option<PatchRing>>,
    /// Per coarse patch: the nodal field at its `read` nodes, `NF` values
    /// per node of its grid (node-major): the summed mass, then (where it
    /// is positive) the eight mass-weighted averages (stress, deformation
    /// gradient) and the material index's mean and variance (zero without
    /// the material sums).
    fin: Vec<Vec<f64>>,
    /// Origin of the coarse level.
    origin: [f64; 2],
    /// Cell size of the coarse level.
    h: f64,
}

/// The nodal field's footprint on one coarse patch's grid (the grid the
/// patch has while it holds particles: its cells grown by [`GHOST`]).
///
/// A cell is a *ring* cell when a coarse particle in it can be copied into
/// the fine ghost ring: one of the fine cells it covers lies in the fine
/// level's boxes and not in its own region. When the fine cells halve the
/// coarse ones exactly (the same origin, half the cell size: always, for
/// the levels of a simulation) a coarse particle's fine cell is one of the
/// two per axis its coarse cell covers, and this footprint is exact;
/// otherwise (a particle's fine cell from its own division) the fine cells
/// within one fine cell of the cell count too, a margin over rounding. A
/// node is *needed* when it is a corner
/// of a ring cell; a cell *contributes* when one of its corners is needed.
/// Ring copies read the field at the corners of their cell, which are
/// needed nodes; the particles that contribute to a needed node are those
/// of contributing cells, so the sums there are the whole level's, in the
/// same order.
struct PatchRing {
    /// Cells whose four corners are on the grid: the patch's cells grown by
    /// [`GHOST`]; the grid's first node is `ext.lo`.
    ext: IBox,
    /// Grid nodes per axis.
    nn: [usize; 2],
    /// Per cell of `ext` (row-major): whether it contributes.
    contrib: Vec<bool>,
    /// Per cell of `ext`: whether it is a ring cell.
    ring: Vec<bool>,
    /// Per grid node: whether it is needed (by this or another patch).
    need: Vec<bool>,
    /// Per grid node: whether it is a corner of a ring cell of `ext`.
    read: Vec<bool>,
    /// Grid nodes the partial sums write or send: needed nodes and the
    /// corners of contributing cells.
    touch: Vec<u32>,
    /// Grid nodes that are corners of ring cells of `ext`.
    read_list: Vec<u32>,
    /// Per cell of `ext`: whether it or one of its eight neighbours
    /// contributes (the quick test of [`FieldExchange::build`], whose cell
    /// estimate may be one cell off).
    near: Vec<bool>,
    /// Whether any cell of `ext` contributes.
    any_contrib: bool,
    /// Patches whose grid overlaps this one's (increasing index), with the
    /// overlap (node indices, half-open) and its number of needed nodes.
    nbrs: Vec<(usize, IBox, usize)>,
    /// This patch's partial sums: `NF` per grid node, node-major (valid at
    /// `touch` nodes).
    part: Vec<f64>,
}

/// The nodes a patch's grid stores, as a half-open box of node indices
/// (as `level::node_box`).
fn grid_nodes(cells: &IBox) -> IBox {
    let e = cells.grow(GHOST);
    IBox::new(e.lo, [e.hi[0] + 1, e.hi[1] + 1])
}

/// Whether coarse cell `c` is a ring cell of the pair (see [`PatchRing`]):
/// with `exact` the fine cells it covers count, without it also those
/// within one fine cell of it.
fn is_ring_cell(fine: &Level, c: [i64; 2], exact: bool) -> bool {
    let m = i64::from(!exact);
    for fj in 2 * c[1] - m..2 * c[1] + 2 + m {
        for fi in 2 * c[0] - m..2 * c[0] + 2 + m {
            let f = [fi, fj];
            if in_any(&fine.boxes, f) && !in_any(&fine.owned, f) {
                return true;
            }
        }
    }
    false
}

impl PatchRing {
    /// The footprint on coarse patch `k` of `patches`; `exact` when the fine
    /// cells halve the coarse ones exactly (see [`is_ring_cell`]).
    fn new(k: usize, patches: &[IBox], fine: &Level, exact: bool) -> PatchRing {
        let cells = patches[k];
        let ext = cells.grow(GHOST);
        let nb = grid_nodes(&cells);
        let nn = [nb.shape()[0] as usize, nb.shape()[1] as usize];
        let ew = (nn[0] - 1, nn[1] - 1);
        // Ring flags over the cells around every grid node.
        let rb = ext.grow(1);
        let rw = rb.shape()[0] as usize;
        let ring_big: Vec<bool> = (rb.lo[1]..rb.hi[1])
            .flat_map(|j| (rb.lo[0]..rb.hi[0]).map(move |i| [i, j]))
            .map(|c| is_ring_cell(fine, c, exact))
            .collect();
        // Cell (a, b) of ext is cell (a + 1, b + 1) of rb; node (a, b) of
        // the grid is the upper-right corner of cell (a, b) of rb.
        let rbig = |a: usize, b: usize| ring_big[b * rw + a];
        let mut need = vec![false; nn[0] * nn[1]];
        for b in 0..nn[1] {
            for a in 0..nn[0] {
                need[b * nn[0] + a] =
                    rbig(a, b) || rbig(a + 1, b) || rbig(a, b + 1) || rbig(a + 1, b + 1);
            }
        }
        let corners = |a: usize, b: usize| {
            let n = b * nn[0] + a;
            [n, n + 1, n + nn[0], n + nn[0] + 1]
        };
        let mut ring = vec![false; ew.0 * ew.1];
        let mut contrib = vec![false; ew.0 * ew.1];
        let mut read = vec![false; nn[0] * nn[1]];
        let mut touched = need.clone();
        for b in 0..ew.1 {
            for a in 0..ew.0 {
                let c = b * ew.0 + a;
                ring[c] = rbig(a + 1, b + 1);
                contrib[c] = corners(a, b).iter().any(|&n| need[n]);
                for n in corners(a, b) {
                    read[n] |= ring[c];
                    touched[n] |= contrib[c];
                }
            }
        }
        let list =
            |m: &[bool]| -> Vec<u32> { (0..m.len()).filter(|&n| m[n]).map(|n| n as u32).collect() };
        let nbrs = (0..patches.len())
            .filter(|&q| q != k)
            .filter_map(|q| {
                let ov = nb.intersect(&grid_nodes(&patches[q]));
                if ov.is_empty() {
                    return None;
                }
                let cnt = (ov.lo[1]..ov.hi[1])
                    .flat_map(|j| (ov.lo[0]..ov.hi[0]).map(move |i| [i, j]))
                    .filter(|&[i, j]| {
                        need[(j - nb.lo[1]) as usize * nn[0] + (i - nb.lo[0]) as usize]
                    })
                    .count();
                Some((q, ov, cnt))
            })
            .collect();
        let mut near = vec![false; ew.0 * ew.1];
        for b in 0..ew.1 {
            for a in 0..ew.0 {
                near[b * ew.0 + a] = (b.saturating_sub(1)..(b + 2).min(ew.1)).any(|bb| {
                    (a.saturating_sub(1)..(a + 2).min(ew.0)).any(|aa| contrib[bb * ew.0 + aa])
                });
            }
        }
        PatchRing {
            ext,
            nn,
            near,
            any_contrib: contrib.iter().any(|&c| c),
            touch: list(&touched),
            read_list: list(&read),
            contrib,
            ring,
            need,
            read,
            nbrs,
            part: vec![0.0; NF * nn[0] * nn[1]],
        }
    }

    /// Storage index of node `(i, j)` (on the grid).
    #[inline]
    fn node(&self, i: i64, j: i64) -> usize {
        (j - self.ext.lo[1]) as usize * self.nn[0] + (i - self.ext.lo[0]) as usize
    }
}

impl PairLayout {
    /// Recomputes the layout-derived data when the layout of the two
    /// levels changed (never, in a simulation after its first step).
    fn update(&mut self, coarse: &Level, fine: &Level) {
        let same = self.key.as_ref().is_some_and(|(p, b, o, d)| {
            *p == coarse.patches && *b == fine.boxes && *o == fine.owned && *d == fine.domain
        });
        if same {
            return;
        }
        self.key = Some((
            coarse.patches.clone(),
            fine.boxes.clone(),
            fine.owned.clone(),
            fine.domain,
        ));
        self.depth = 0;
        self.deep.clear();
        self.deep_in.clear();
        self.owned_in = fine
            .owned
            .iter()
            .map(|b| Inside::of(b, fine.origin, fine.h))
            .collect();
        self.patches = (0..coarse.patches.len()).map(|_| None).collect();
        self.fin = vec![Vec::new(); coarse.patches.len()];
    }

    /// Sets the depth of the copies' layer, in coarse cells (see
    /// [`copy_depth`]): the deep cells are recomputed when it changes.
    fn set_depth(&mut self, depth: i64, fine: &Level) {
        if depth == self.depth {
            return;
        }
        self.depth = depth;
        self.deep = deep_boxes(&fine.owned, &fine.domain, 2 * depth);
        self.deep_in = self
            .deep
            .iter()
            .map(|b| Inside::of(b, fine.origin, fine.h))
            .collect();
    }

    /// The stress and deformation gradient of the coarse nodal field at
    /// `(x, y)` in coarse patch `k`, for a particle of material `mat` whose
    /// own values are `own` (stress `sxx, syy, sxy, szz`, then `fxx, fxy,
    /// fyx, fyy`): `None` for a group the particle keeps. It keeps both
    /// unless every stencil node with weight has mass and (with
    /// `materials`) holds only its material; and it keeps a group the
    /// field equals to round-off, so that a uniform state (at rest, uniform
    /// stress, rigid motion) stays bitwise uniform.
    #[allow(clippy::type_complexity)]
    fn smooth(
        &self,
        k: usize,
        x: f64,
        y: f64,
        mat: u32,
        own: [f64; 8],
        materials: bool,
    ) -> (Option<[f64; 4]>, Option<[f64; 4]>) {
        let (Some(pr), s) = (&self.patches[k], &self.fin[k]) else {
            return (None, None);
        };
        let Some((nodes, w)) = stencil_at(pr.ext.lo, pr.nn, self.origin, self.h, x, y) else {
            return (None, None);
        };
        let mat = mat as f64;
        let mut acc = [0.0; 8];
        for (kk, ww) in nodes.iter().zip(w) {
            if ww == 0.0 {
                continue;
            }
            debug_assert!(pr.read[*kk], "ring copies read the field at read nodes");
            let node = &s[NF * kk..NF * (kk + 1)];
            if node[0].partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                return (None, None);
            }
            let (mean, var) = (node[NF - 2], node[NF - 1]);
            if materials
                && ((mean - mat).abs() > 1e-9 * (1.0 + mat) || var > 1e-12 * (1.0 + mat * mat))
            {
                return (None, None);
            }
            for (a, v) in acc.iter_mut().zip(&node[1..NF - 2]) {
                *a += ww * v;
            }
        }
        let same = |r: std::ops::Range<usize>| {
            let scale = r
                .clone()
                .map(|c| own[c].abs().max(acc[c].abs()))
                .fold(0.0, f64::max);
            r.map(|c| (acc[c] - own[c]).abs())
                .all(|d| d <= 1e-12 * scale)
        };
        let stress = (!same(0..4)).then(|| [acc[0], acc[1], acc[2], acc[3]]);
        let grad = (!same(4..8)).then(|| [acc[4], acc[5], acc[6], acc[7]]);
        (stress, grad)
    }
}

/// Buffers of the exchange of the nodal field's partial sums between
/// ranks, kept between synchronisations.
#[derive(Default)]
struct FieldExchange {
    /// Outgoing messages, one per peer rank.
    send: Vec<(i32, Vec<u8>)>,
    /// Expected message sizes, one per peer rank.
    recv: Vec<(i32, usize)>,
    /// Incoming partial sums: (destination patch, source patch, message,
    /// offset), sorted.
    incoming: Vec<(usize, usize, usize, usize)>,
}

impl FieldExchange {
    /// The coarse level's mass-weighted nodal average of particle stress and
    /// deformation gradient (bilinear weights, all its particles: owned
    /// ones and copies of the finer level's), summed over the patches
    /// sharing a node in increasing patch index as [`Level::exchange`] sums
    /// (point-to-point with the neighbour ranks), at the nodes the ring
    /// copies read; and the ring copies to make (`cand`: coarse-owned
    /// particles whose fine cell is in the fine ghost ring). Without
    /// `materials` the material sums (the last two of the `NF`, read only
    /// by [`PairLayout::smooth`]'s material check) are left at zero.
    fn build(
        &mut self,
        pair: &mut PairLayout,
        coarse: &Level,
        fine: &Level,
        comm: &Comm,
        cand: &mut Vec<Candidate>,
        materials: bool,
    ) -> Result<u64> {
        use crate::particles::OWNED;
        let (origin, h) = (coarse.origin, coarse.h);
        pair.origin = origin;
        pair.h = h;
        let me = comm.rank();
        // The fine patch a coarse-owned particle at (x, y) is copied to:
        // its fine cell is in a fine patch but not in the fine region.
        // The fine cell of a coarse particle whose `(x - origin) / h` is
        // `(xi, yi)`: twice those, floored, when the fine cells halve the
        // coarse ones exactly (see `Coupler::sync`), else its own division.
        let halves = fine.origin == origin && fine.h * 2.0 == h;
        let fine_cell = |x: f64, y: f64, xi: f64, yi: f64| {
            if halves {
                [floor_i64(2.0 * xi), floor_i64(2.0 * yi)]
            } else {
                cell_at(fine.origin, fine.h, x, y)
            }
        };
        // The last fine patch found (patches are disjoint).
        let mut last: Option<(IBox, usize)> = None;
        let mut ring_dest = |c: [i64; 2]| {
            if in_any(&fine.owned, c) {
                return None;
            }
            match last {
                Some((b, q)) if b.contains_cell(c[0], c[1]) => Some(q),
                _ => {
                    let q = fine.find_patch(c)?;
                    last = Some((fine.patches[q], q));
                    Some(q)
                }
            }
        };
        cand.clear();
        // Partial sums of each local patch at the nodes it touches.
        for (pi, p) in coarse.local.iter().enumerate() {
            let pr = pair.patches[p.k]
                .get_or_insert_with(|| PatchRing::new(p.k, &coarse.patches, fine, halves));
            for &n in &pr.touch {
                let n = n as usize;
                pr.part[NF * n..NF * (n + 1)].fill(0.0);
            }
            if !pr.any_contrib {
                continue;
            }
            let q = &p.parts;
            let nn0 = pr.nn[0];
            let ew = [(pr.nn[0] - 1) as i64, (pr.nn[1] - 1) as i64];
            // Quick test without division: `(x - lo) * inv` is within a
            // small fraction of a cell of the exact `(x - origin) / h - lo`,
            // so its cell is at most one off the exact one. A particle whose
            // estimated cell lies inside `ext` shrunk by one cell (so the
            // exact cell is on the grid) with no contributing cell around
            // neither contributes nor can be a ring copy: skipped.
            let inv = 1.0 / h;
            let lo = [
                origin[0] + pr.ext.lo[0] as f64 * h,
                origin[1] + pr.ext.lo[1] as f64 * h,
            ];
            let (ew0, ew1) = (ew[0] as usize, ew[1] as usize);
            for i in 0..q.len() {
                let (x, y) = (q.x[i], q.y[i]);
                // Truncation: negative estimates (and NaN) give 0, which is
                // not inside; inside estimates are positive, truncation is
                // the floor there.
                let ea = ((x - lo[0]) * inv) as usize;
                let eb = ((y - lo[1]) * inv) as usize;
                if ea >= 1 && eb >= 1 && ea < ew0 - 1 && eb < ew1 - 1 && !pr.near[eb * ew0 + ea] {
                    continue;
                }
                let xi = (x - origin[0]) / h;
                let yi = (y - origin[1]) / h;
                let (ci, cj) = (floor_i64(xi), floor_i64(yi));
                let (a, b) = (ci - pr.ext.lo[0], cj - pr.ext.lo[1]);
                // Off the grid's stencils (never: a particle lies in its
                // patch's cells): nothing to sum, but a copy.
                let c = (a >= 0 && b >= 0 && a < ew[0] && b < ew[1])
                    .then(|| b as usize * ew[0] as usize + a as usize);
                if c.is_some_and(|c| pr.contrib[c]) {
                    let (fx, fy) = (xi - ci as f64, yi - cj as f64);
                    let w = [
                        (1.0 - fx) * (1.0 - fy),
                        fx * (1.0 - fy),
                        (1.0 - fx) * fy,
                        fx * fy,
                    ];
                    let n0 = b as usize * nn0 + a as usize;
                    let mat = q.material[i] as f64;
                    let vals = [
                        q.mass[i],
                        q.sxx[i],
                        q.syy[i],
                        q.sxy[i],
                        q.szz[i],
                        q.fxx[i],
                        q.fxy[i],
                        q.fyx[i],
                        q.fyy[i],
                        mat,
                        mat * mat,
                    ];
                    for (kk, ww) in [n0, n0 + 1, n0 + nn0, n0 + nn0 + 1].into_iter().zip(w) {
                        let wm = ww * q.mass[i];
                        let node = &mut pr.part[NF * kk..NF * (kk + 1)];
                        node[0] += wm;
                        for f in 1..NF - 2 {
                            node[f] += wm * vals[f];
                        }
                        if materials {
                            for f in NF - 2..NF {
                                node[f] += wm * vals[f];
                            }
                        }
                    }
                }
                if q.copy[i] == OWNED && c.map_or(true, |c| pr.ring[c]) {
                    if let Some(fq) = ring_dest(fine_cell(x, y, xi, yi)) {
                        cand.push(Candidate {
                            q: fq as u32,
                            id: q.id[i],
                            pi: pi as u32,
                            i: i as u32,
                        });
                    }
                }
            }
        }
        // Partial sums at the needed nodes shared with other ranks'
        // patches; every pair of overlapping patches sends (zeros for a
        // patch without particles), so sizes follow from the layout.
        for (_, b) in &mut self.send {
            b.clear();
        }
        for (_, n) in &mut self.recv {
            *n = 0;
        }
        let slot = |v: &mut Vec<(i32, Vec<u8>)>, r: i32| match v.binary_search_by_key(&r, |e| e.0) {
            Ok(s) => s,
            Err(s) => {
                v.insert(s, (r, Vec::new()));
                s
            }
        };
        for p in &coarse.local {
            let pr = pair.patches[p.k].as_ref().expect("built above");
            for &(q, ov, cnt) in &pr.nbrs {
                let r = coarse.owner[q];
                if r == me {
                    continue;
                }
                let s = slot(&mut self.send, r);
                let buf = &mut self.send[s].1;
                buf.extend_from_slice(&(q as u64).to_le_bytes());
                buf.extend_from_slice(&(p.k as u64).to_le_bytes());
                for j in ov.lo[1]..ov.hi[1] {
                    for i in ov.lo[0]..ov.hi[0] {
                        let n = pr.node(i, j);
                        if pr.need[n] {
                            for v in &pr.part[NF * n..NF * (n + 1)] {
                                buf.extend_from_slice(&v.to_le_bytes());
                            }
                        }
                    }
                }
                let s = match self.recv.binary_search_by_key(&r, |e| e.0) {
                    Ok(s) => s,
                    Err(s) => {
                        self.recv.insert(s, (r, 0));
                        s
                    }
                };
                self.recv[s].1 += 16 + 8 * NF * cnt;
            }
        }
        self.incoming.clear();
        let mut sent = 0u64;
        let bufs = if self.send.iter().any(|e| !e.1.is_empty()) {
            let sends: Vec<(i32, &[u8])> = self
                .send
                .iter()
                .filter(|e| !e.1.is_empty())
                .map(|e| (e.0, e.1.as_slice()))
                .collect();
            let recvs: Vec<(i32, usize)> = self.recv.iter().filter(|e| e.1 > 0).copied().collect();
            sent = sends.iter().map(|e| e.1.len() as u64).sum();
            let bufs = comm.exchange_with(&sends, &recvs, TAG_RING_FIELD)?;
            for (bi, recv) in bufs.iter().enumerate() {
                let mut at = 0;
                while at + 16 <= recv.len() {
                    let dest = rec_u64(&recv[at..], 0) as usize;
                    let src = rec_u64(&recv[at..], 1) as usize;
                    let cnt = pair.patches[dest]
                        .as_ref()
                        .and_then(|pr| pr.nbrs.iter().find(|e| e.0 == src))
                        .map(|e| e.2)
                        .ok_or_else(|| {
                            Error::new(
                                Status::Internal,
                                format!("nodal field sums for patch {dest} from patch {src}, which do not overlap here"),
                            )
                        })?;
                    self.incoming.push((dest, src, bi, at + 16));
                    at += 16 + 8 * NF * cnt;
                }
            }
            self.incoming.sort_unstable();
            bufs
        } else {
            Vec::new()
        };
        // The sums at the nodes the ring copies read: contributions in
        // increasing patch index, the own one in its place.
        let mut last = usize::MAX;
        for c in cand.iter() {
            let pi = c.pi as usize;
            if pi == last {
                continue;
            }
            last = pi;
            let k = coarse.local[pi].k;
            let pr = pair.patches[k].as_ref().expect("built above");
            let fin = &mut pair.fin[k];
            fin.resize(pr.part.len(), 0.0);
            for &n in &pr.read_list {
                let n = n as usize;
                fin[NF * n..NF * (n + 1)].fill(0.0);
            }
            let add_own = |fin: &mut Vec<f64>| {
                for &n in &pr.read_list {
                    let n = n as usize;
                    let r = NF * n..NF * (n + 1);
                    for (d, v) in fin[r.clone()].iter_mut().zip(&pr.part[r]) {
                        *d += v;
                    }
                }
            };
            let mut own_done = false;
            for &(q, ov, _) in &pr.nbrs {
                if !own_done && q > k {
                    add_own(fin);
                    own_done = true;
                }
                if coarse.owner[q] == me {
                    let qr = pair.patches[q].as_ref().expect("local patches are built");
                    for j in ov.lo[1]..ov.hi[1] {
                        for i in ov.lo[0]..ov.hi[0] {
                            let n = pr.node(i, j);
                            if pr.read[n] {
                                let m = qr.node(i, j);
                                for f in 0..NF {
                                    fin[NF * n + f] += qr.part[NF * m + f];
                                }
                            }
                        }
                    }
                } else {
                    let e = self.incoming.partition_point(|e| (e.0, e.1) < (k, q));
                    let Some(&(_, _, bi, off)) =
                        self.incoming.get(e).filter(|e| (e.0, e.1) == (k, q))
                    else {
                        return Err(Error::new(
                            Status::Internal,
                            format!("no nodal field sums arrived for patch {k} from patch {q}"),
                        ));
                    };
                    let recv = &bufs[bi][off..];
                    let mut r = 0;
                    for j in ov.lo[1]..ov.hi[1] {
                        for i in ov.lo[0]..ov.hi[0] {
                            let n = pr.node(i, j);
                            if !pr.need[n] {
                                continue;
                            }
                            if pr.read[n] {
                                for f in 0..NF {
                                    fin[NF * n + f] += rec_f64(recv, NF * r + f);
                                }
                            }
                            r += 1;
                        }
                    }
                }
            }
            if !own_done {
                add_own(fin);
            }
            // The sums as nodal averages, once per node (see
            // `PairLayout::smooth`): mass, the eight field values over the
            // mass, the material index's mean and variance.
            for &n in &pr.read_list {
                let node = &mut fin[NF * n as usize..NF * (n as usize + 1)];
                let m = node[0];
                if m.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                    continue;
                }
                for v in &mut node[1..NF - 2] {
                    *v /= m;
                }
                if materials {
                    let mean = node[NF - 2] / m;
                    node[NF - 1] = node[NF - 1] / m - mean * mean;
                    node[NF - 2] = mean;
                }
            }
        }
        Ok(sent)
    }
}

/// The nodal accelerations of the last step on grid `g`: force over mass
/// at every node with mass (after boundary conditions: the kernel zeroes
/// constrained force components), zero at nodes without (never read).
fn node_accelerations(g: &Grid, out: &mut Vec<[f64; 2]>) {
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
fn acceleration(g: &Grid, acc: &[[f64; 2]], x: f64, y: f64) -> Option<[f64; 2]> {
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

/// The four nodes of the cell holding `(x, y)` on a grid of nodes
/// starting at node `lo`, `n` nodes per axis, of a level with origin
/// `origin` and cell size `h` (storage indices), and their bilinear
/// weights; `None` when the cell's nodes are not all on the grid.
fn stencil_at(
    lo: [i64; 2],
    n: [usize; 2],
    origin: [f64; 2],
    h: f64,
    x: f64,
    y: f64,
) -> Option<([usize; 4], [f64; 4])> {
    let xi = (x - origin[0]) / h;
    let yi = (y - origin[1]) / h;
    let (i, j) = (floor_i64(xi), floor_i64(yi));
    let (fx, fy) = (xi - i as f64, yi - j as f64);
    let (i, j) = (i - lo[0], j - lo[1]);
    if i < 0 || j < 0 || i + 1 >= n[0] as i64 || j + 1 >= n[1] as i64 {
        return None;
    }
    let k = j as usize * n[0] + i as usize;
    Some((
        [k, k + 1, k + n[0], k + n[0] + 1],
        [
            (1.0 - fx) * (1.0 - fy),
            fx * (1.0 - fy),
            (1.0 - fx) * fy,
            fx * fy,
        ],
    ))
}

/// The cells of `owned` farther than `r` cells from the region's boundary
/// (sides on the domain boundary do not count as boundary): each box shrunk
/// by `r` on its inner sides. For a union of several boxes this is
/// conservative (cells near a box-to-box interface count as shallow).
fn deep_boxes(owned: &[IBox], domain: &IBox, r: i64) -> Vec<IBox> {
    owned
        .iter()
        .map(|b| {
            let mut d = *b;
            for a in 0..2 {
                if b.lo[a] > domain.lo[a] {
                    d.lo[a] += r;
                }
                if b.hi[a] < domain.hi[a] {
                    d.hi[a] -= r;
                }
            }
            d
        })
        .filter(|d| !d.is_empty())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packed_words_and_changed_fields_name_the_right_fields() {
        let n = Particles::F64_NAMES;
        assert_eq!((n[W_X - 2], n[W_Y - 2], n[F_COPY]), ("x", "y", "copy"));
        let m: Vec<&str> = MODS.iter().map(|&k| n[k]).collect();
        assert_eq!(
            m,
            ["vx", "vy", "fxx", "fxy", "fyx", "fyy", "sxx", "syy", "sxy", "szz"]
        );
    }

    #[test]
    fn the_copies_layer_is_as_deep_as_a_coarse_step_reaches() {
        // MUSL/USF: 4 hops; fine-sized particles (h/8) and coarse ones (h/4)
        // reach 4 + 0.25 + 3 * 0.125 = 4.625 cells.
        assert_eq!(copy_depth(2, 0, 0.25, 0.125, 1.0), 5);
        // USL: 2 hops, 2.375 cells.
        assert_eq!(copy_depth(1, 0, 0.25, 0.125, 1.0), 3);
        // The largest half-lengths GIMP allows (h/2 coarse, h/4 fine): 5.25.
        assert_eq!(copy_depth(2, 0, 1.0, 0.5, 2.0), 6);
        // Two XPIC passes add four hops: 8 + 0.25 + 7 * 0.125 = 9.125.
        assert_eq!(copy_depth(2, 2, 0.25, 0.125, 1.0), 10);
        // An integer reach is enough (supports are open).
        assert_eq!(copy_depth(2, 0, 0.0, 0.0, 1.0), 4);
        // A reach that is not a number copies the whole region.
        assert!(copy_depth(2, 0, f64::INFINITY, 0.0, 1.0) > 1 << 40);
        assert!(copy_depth(2, 0, 0.0, 0.0, 0.0) > 1 << 40);
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

    #[test]
    fn floor_i64_matches_floor() {
        let vals = [
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            2.999_999_999_999_999_6,
            -2.999_999_999_999_999_6,
            1e15 + 0.5,
            -1e15 - 0.5,
            9.3e18,
            -9.3e18,
            1e300,
            -1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
        ];
        for v in vals {
            assert_eq!(floor_i64(v), v.floor() as i64, "{v}");
        }
    }

    #[test]
    fn a_point_surely_inside_a_box_lies_in_one_of_its_cells() {
        // Deterministic pseudo-random points around the edges of boxes at
        // several scales and offsets of the origin.
        let mut s = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        for (o, h) in [
            ([0.0, 0.0], 1.0),
            ([-3.7, 12.25], 0.1),
            ([1e3, -2e3], 1e-7),
            ([0.0, 0.0], 1.220_703_125e-7),
        ] {
            let b = IBox::new([3, -5], [17, 9]);
            let ins = Inside::of(&b, o, h);
            for _ in 0..20_000 {
                let e = [[3.0, 17.0], [-5.0, 9.0]];
                let pick = |r: f64, a: usize| {
                    let edge = if r < 0.5 { e[a][0] } else { e[a][1] };
                    o[a] + (edge + (r - 0.5) * 1e-5) * h
                };
                let (x, y) = (pick(next(), 0), pick(next(), 1));
                if ins.holds(x, y) {
                    let c = cell_at(o, h, x, y);
                    assert!(b.contains_cell(c[0], c[1]), "({x}, {y}) h {h}");
                }
            }
        }
    }
}
