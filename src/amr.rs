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
//! `COPY_DEPTH` coarse cells deep inside the refined region (deeper, it holds
//! nothing and does no work). Copies are advanced with their level and
//! thrown away at the next synchronisation, where fresh ones are made from
//! the owners. Because copies are recreated rather than updated in place,
//! no search for the matching particle on the other level is needed (the
//! paper's main cost): synchronisation is one pass over the particles of the
//! two levels plus one exchange; global ids identify particles across levels
//! and ranks, and arrivals are ordered by id so that results do not depend
//! on the number of ranks.
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
use crate::kernel::{Grid, Ramp, Scheme, StepParams};
use crate::level::{Departure, Fields, Level, GHOST};
use crate::material::MatParams;
use crate::particles::Particles;

/// Depth, in coarse cells, of the layer inside a refined region in which
/// the coarse level keeps copies of the fine particles: deep enough that a
/// coarse MUSL step (two mappings) of the coarse-owned particles outside the
/// region sees complete nodal data. Deeper inside, the coarse level holds no
/// particles and does no work.
pub const COPY_DEPTH: i64 = 6;

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
    /// check, one nodal exchange fewer).
    one_material: bool,
}

impl Coupler {
    /// Advances level `l` by one step of `prm.dt / 2^l` starting at time
    /// `t`, then (recursively) the finer levels by two half steps each, and
    /// synchronises each pair when they meet (the paper's fig. 8).
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
        let mut prm = *base;
        prm.dt = base.dt / (1u64 << l) as f64;
        prm.load_factor = ramp.factor(t);
        if l == 0 {
            self.dt = vec![0.0; levels.len()];
            self.one_material = mats.len() == 1;
            self.lag = match base.scheme {
                Scheme::Usf => -1.0,
                Scheme::Usl | Scheme::Musl => 1.0,
            };
        }
        let ctx = contact.level_step(l, t + prm.dt, thickness);
        let departures = match levels[l].step(comm, mats, &prm, ctx) {
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
            self.advance(
                levels,
                comm,
                l + 1,
                t,
                mats,
                base,
                ramp,
                lost,
                contact,
                thickness,
            )?;
            self.advance(
                levels,
                comm,
                l + 1,
                t + 0.5 * prm.dt,
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
    /// particles within `COPY_DEPTH` coarse cells inside the fine region onto
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
    pub fn sync(&mut self, levels: &mut [Level], l: usize, comm: &Comm) -> Result<()> {
        use crate::particles::{COPY_FROM_COARSER, COPY_FROM_FINER, OWNED};
        let nr = comm.size() as usize;
        let f = l + 1;
        let mut to_coarse: Vec<Vec<u8>> = vec![Vec::new(); nr];
        let mut to_fine: Vec<Vec<u8>> = vec![Vec::new(); nr];
        let mut transfers = 0u64;
        let mut err: Option<Error> = None;
        let mut note = |r: Result<()>| {
            if let Err(e) = r {
                err.get_or_insert(e);
            }
        };
        // Fine level: drop copies from the coarse level; hand owned
        // particles outside the fine region to the coarse level.
        let (lo, hi) = levels.split_at_mut(f);
        let (coarse, fine) = (&mut lo[l], &mut hi[0]);
        let pending = std::mem::take(&mut self.pending[f]);
        for rec in pending {
            let mut one = Particles::new();
            one.push_packed(&rec);
            if coarse.pack_for(&one, 0, &mut to_coarse) {
                transfers += 1;
                continue;
            }
            let c = coarse.cell_of(one.x[0], one.y[0]);
            if !coarse.domain.contains_cell(c[0], c[1]) {
                self.outflow.push(Departure {
                    id: one.id[0],
                    x: one.x[0],
                    y: one.y[0],
                });
            } else if l > 0 {
                self.pending[l].push(rec);
            } else {
                note(Err(Error::new(
                    Status::Internal,
                    format!(
                        "particle {} at ({}, {}) left level {f} and lies in no patch of level {l}",
                        one.id[0], one.x[0], one.y[0]
                    ),
                )));
            }
        }
        let (fo, fh) = (fine.origin, fine.h);
        for p in &mut fine.local {
            let parts = &p.parts;
            let drop: Vec<bool> = (0..parts.len())
                .map(|i| {
                    if parts.copy[i] == COPY_FROM_COARSER {
                        return true;
                    }
                    // Owned and outside the fine region: to the coarse level.
                    let c = [
                        ((parts.x[i] - fo[0]) / fh).floor() as i64,
                        ((parts.y[i] - fo[1]) / fh).floor() as i64,
                    ];
                    let moved = parts.copy[i] == OWNED
                        && !fine.owned.iter().any(|b| b.contains_cell(c[0], c[1]))
                        && coarse.pack_for(parts, i, &mut to_coarse);
                    transfers += moved as u64;
                    moved
                })
                .collect();
            p.parts.retain(|i| !drop[i]);
        }
        // Coarse level: drop copies from the fine level; hand owned
        // particles inside the fine region to the fine level.
        for p in &mut coarse.local {
            let parts = &p.parts;
            let drop: Vec<bool> = (0..parts.len())
                .map(|i| {
                    if parts.copy[i] == COPY_FROM_FINER {
                        return true;
                    }
                    let c = fine.cell_of(parts.x[i], parts.y[i]);
                    let moved = parts.copy[i] == OWNED
                        && fine.owns_cell(c)
                        && fine.pack_for(parts, i, &mut to_fine);
                    transfers += moved as u64;
                    moved
                })
                .collect();
            p.parts.retain(|i| !drop[i]);
        }
        note(coarse.deliver(comm, &to_coarse));
        note(fine.deliver(comm, &to_fine));
        // Fresh copies of the fine particles on the coarse level first: the
        // coarse nodal field the ring copies are smoothed with needs them.
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
        let mut one = Particles::new();
        let deep = deep_boxes(&fine.owned, &fine.domain, 2 * COPY_DEPTH);
        for p in &fine.local {
            let parts = &p.parts;
            for i in 0..parts.len() {
                if parts.copy[i] != OWNED {
                    continue;
                }
                let c = fine.cell_of(parts.x[i], parts.y[i]);
                if !deep.iter().any(|b| b.contains_cell(c[0], c[1])) {
                    one.clear();
                    one.push_from(parts, i);
                    if shift != 0.0 {
                        if let Some(a) = p.grid.as_ref().and_then(|g| acceleration(g, &one)) {
                            one.vx[0] -= shift * a[0];
                            one.vy[0] -= shift * a[1];
                        }
                    }
                    coarse.pack_as(&one, 0, Some(COPY_FROM_FINER), &mut to_coarse);
                }
            }
        }
        note(coarse.deliver(comm, &to_coarse));
        // Fresh ring copies of the coarse particles, with the coarse level's
        // nodal stress and deformation gradient at their positions.
        let (field, r) = NodalField::build(coarse, comm, self.dt.is_empty() || !self.one_material)?;
        note(r);
        for (pi, p) in coarse.local.iter().enumerate() {
            let parts = &p.parts;
            for i in 0..parts.len() {
                if parts.copy[i] != OWNED {
                    continue;
                }
                let c = fine.cell_of(parts.x[i], parts.y[i]);
                if fine.owns_cell(c) || fine.find_patch(c).is_none() {
                    continue;
                }
                // In the fine ghost ring.
                one.clear();
                one.push_from(parts, i);
                if shift != 0.0 {
                    if let Some(a) = p.grid.as_ref().and_then(|g| acceleration(g, &one)) {
                        one.vx[0] += shift * a[0];
                        one.vy[0] += shift * a[1];
                    }
                }
                field.smooth(coarse, pi, &mut one);
                fine.pack_as(&one, 0, Some(COPY_FROM_COARSER), &mut to_fine);
            }
        }
        note(fine.deliver(comm, &to_fine));
        let bad = comm.any(err.is_some())?;
        if let Some(e) = err {
            return Err(e);
        }
        if bad {
            return Err(Error::new(
                Status::Internal,
                format!("the synchronisation of levels {l} and {f} failed on another rank; see that rank's message"),
            ));
        }
        self.transfers += transfers;
        Ok(())
    }
}

/// Number of nodal sums in a [`NodalField`]: mass, mass times the four
/// stress components, the four deformation-gradient components, the
/// material index and its square.
const NF: usize = 11;

/// A level's mass-weighted nodal average of particle stress and deformation
/// gradient (bilinear weights), summed over the patches sharing a node, to
/// interpolate a continuous field at the fine ring copies.
struct NodalField {
    /// Per local patch (same order as `Level::local`): `NF` sums per node
    /// of the patch's grid, node-major; empty for a patch without grid.
    sums: Vec<Vec<f64>>,
    /// Whether the material sums are complete (otherwise every particle of
    /// the level has the same material and they are not checked).
    materials: bool,
}

impl NodalField {
    /// Scatters every particle of `lv` (owned and copies) to its patch's
    /// grid and sums shared nodes over patches and ranks (collective). The
    /// grids' accumulators are used as scratch (the next step resets them);
    /// a patch that holds particles but no grid gets one. `materials`:
    /// whether to sum the material tags too (not needed when the material
    /// table has one material). A grid this rank cannot allocate is
    /// returned as the second value, after the exchanges (the caller agrees
    /// on it); the first error is an MPI failure.
    fn build(lv: &mut Level, comm: &Comm, materials: bool) -> Result<(NodalField, Result<()>)> {
        let (origin, h) = (lv.origin, lv.h);
        let mut alloc = Ok(());
        for p in &mut lv.local {
            if p.grid.is_none() && !p.parts.is_empty() {
                match Grid::from_ibox(origin, h, &p.cells, GHOST) {
                    Ok(g) => p.grid = Some(g),
                    Err(e) => alloc = Err(e),
                }
            }
        }
        // The last step's nodal mass and force, kept for the accelerations
        // a later synchronisation with the next coarser level reads.
        let kept: Vec<_> = lv
            .local
            .iter()
            .map(|p| {
                p.grid
                    .as_ref()
                    .map(|g| (g.mass.clone(), g.mom_force.clone()))
            })
            .collect();
        let mut sums: Vec<Vec<f64>> = lv
            .local
            .iter()
            .map(|p| vec![0.0; p.grid.as_ref().map_or(0, |g| NF * g.len())])
            .collect();
        for (p, s) in lv.local.iter().zip(&mut sums) {
            let Some(g) = &p.grid else { continue };
            let q = &p.parts;
            for i in 0..q.len() {
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
                    q.material[i] as f64,
                    (q.material[i] as f64) * (q.material[i] as f64),
                ];
                let Some((k, w)) = stencil(g, q.x[i], q.y[i]) else {
                    continue;
                };
                for (kk, ww) in k.iter().zip(w) {
                    let wm = ww * q.mass[i];
                    let node = &mut s[NF * kk..NF * (kk + 1)];
                    node[0] += wm;
                    for f in 1..NF {
                        node[f] += wm * vals[f];
                    }
                }
            }
        }
        // Sum over patches: five, then five, then one field per exchange,
        // through the grids' accumulators.
        let rounds: [(&[usize], Fields); 3] = [
            (&[0, 1, 2, 3, 4], Fields::MassMomentumForce),
            (&[5, 6, 7, 8, 9], Fields::MassMomentumForce),
            (&[10], Fields::Force),
        ];
        for (which, fields) in rounds.into_iter().take(if materials { 3 } else { 2 }) {
            for (p, s) in lv.local.iter_mut().zip(&sums) {
                let Some(g) = &mut p.grid else { continue };
                for (slot, &f) in which.iter().enumerate() {
                    let acc = accumulator(fields, slot);
                    for n in 0..g.len() {
                        g.set_acc(acc, n, s[NF * n + f]);
                    }
                }
            }
            lv.exchange(comm, fields)?;
            for (p, s) in lv.local.iter().zip(&mut sums) {
                let Some(g) = &p.grid else { continue };
                for (slot, &f) in which.iter().enumerate() {
                    let acc = accumulator(fields, slot);
                    for n in 0..g.len() {
                        s[NF * n + f] = g.acc(acc, n);
                    }
                }
            }
        }
        for (p, k) in lv.local.iter_mut().zip(kept) {
            if let (Some(g), Some((m, kept_mf))) = (&mut p.grid, k) {
                // The step's mass and force back (the momentum is not read
                // before the next P2G).
                g.mass = m;
                for (d, o) in g.mom_force.iter_mut().zip(kept_mf) {
                    d.0[mf::FX] = o.0[mf::FX];
                    d.0[mf::FY] = o.0[mf::FY];
                }
            }
        }
        Ok((NodalField { sums, materials }, alloc))
    }

    /// Replaces the stress and deformation gradient of particle 0 of `one`
    /// (a particle of local patch `pi` of `lv`) by the field interpolated at
    /// its position, when every stencil node with weight has mass and holds
    /// only the particle's material; otherwise leaves them. Each group
    /// (stress, deformation gradient) the field matches to round-off is
    /// left as it is.
    fn smooth(&self, lv: &Level, pi: usize, one: &mut Particles) {
        let Some(g) = &lv.local[pi].grid else { return };
        let s = &self.sums[pi];
        let Some((k, w)) = stencil(g, one.x[0], one.y[0]) else {
            return;
        };
        let mat = one.material[0] as f64;
        let mut acc = [0.0; 8];
        for (kk, ww) in k.iter().zip(w) {
            if ww == 0.0 {
                continue;
            }
            let node = &s[NF * kk..NF * (kk + 1)];
            let m = node[0];
            if m.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                return;
            }
            let mean = node[9] / m;
            let var = node[10] / m - mean * mean;
            if self.materials
                && ((mean - mat).abs() > 1e-9 * (1.0 + mat) || var > 1e-12 * (1.0 + mat * mat))
            {
                return;
            }
            for (a, v) in acc.iter_mut().zip(&node[1..9]) {
                *a += ww * v / m;
            }
        }
        // A group (stress, deformation gradient) whose field equals the
        // particle's own values to round-off keeps them: a uniform state
        // (at rest, uniform stress, rigid motion) stays bitwise uniform.
        let own = [
            one.sxx[0], one.syy[0], one.sxy[0], one.szz[0], one.fxx[0], one.fxy[0], one.fyx[0],
            one.fyy[0],
        ];
        let same = |r: std::ops::Range<usize>| {
            let scale = r
                .clone()
                .map(|c| own[c].abs().max(acc[c].abs()))
                .fold(0.0, f64::max);
            r.map(|c| (acc[c] - own[c]).abs())
                .all(|d| d <= 1e-12 * scale)
        };
        if !same(0..4) {
            one.sxx[0] = acc[0];
            one.syy[0] = acc[1];
            one.sxy[0] = acc[2];
            one.szz[0] = acc[3];
        }
        if !same(4..8) {
            one.fxx[0] = acc[4];
            one.fxy[0] = acc[5];
            one.fyx[0] = acc[6];
            one.fyy[0] = acc[7];
        }
    }
}

/// The accumulator (numbered as in [`Grid::acc`]) that carries slot `slot`
/// of an exchange of `fields`: force x for [`Fields::Force`], else mass,
/// momentum x, momentum y, force x, force y in turn.
fn accumulator(fields: Fields, slot: usize) -> usize {
    if fields == Fields::Force {
        1 + mf::FX
    } else {
        slot
    }
}

/// The acceleration of the last step at particle 0 of `one`: the nodal
/// force over nodal mass of its grid (after boundary conditions: the
/// kernel zeroes constrained force components), interpolated bilinearly
/// over the nodes with mass; `None` when no stencil node has mass.
fn acceleration(g: &Grid, one: &Particles) -> Option<[f64; 2]> {
    let (k, w) = stencil(g, one.x[0], one.y[0])?;
    let mut a = [0.0; 2];
    let mut ws = 0.0;
    for (kk, ww) in k.iter().zip(w) {
        let m = g.mass[*kk];
        if ww > 0.0 && m > 0.0 {
            let f = &g.mom_force[*kk].0;
            a[0] += ww * f[mf::FX] / m;
            a[1] += ww * f[mf::FY] / m;
            ws += ww;
        }
    }
    (ws > 0.0).then(|| [a[0] / ws, a[1] / ws])
}

/// The four nodes of the cell of `g` holding `(x, y)` (storage indices)
/// and their bilinear weights; `None` when the cell's nodes are not all on
/// the grid.
fn stencil(g: &Grid, x: f64, y: f64) -> Option<([usize; 4], [f64; 4])> {
    let xi = (x - g.origin[0]) / g.h;
    let yi = (y - g.origin[1]) / g.h;
    let (i, j) = (xi.floor(), yi.floor());
    let (fx, fy) = (xi - i, yi - j);
    let (i, j) = (i as i64 - g.lo[0], j as i64 - g.lo[1]);
    if i < 0 || j < 0 || i + 1 >= g.n[0] as i64 || j + 1 >= g.n[1] as i64 {
        return None;
    }
    let k = j as usize * g.n[0] + i as usize;
    Some((
        [k, k + 1, k + g.n[0], k + g.n[0] + 1],
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
