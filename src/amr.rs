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

use crate::comm::Comm;
use crate::error::{Error, Result, Status};
use crate::geom::IBox;
use crate::kernel::{Ramp, StepParams};
use crate::level::{Departure, Level};
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
    ) -> Result<()> {
        let mut prm = *base;
        prm.dt = base.dt / (1u64 << l) as f64;
        prm.load_factor = ramp.factor(t);
        let departures = levels[l].step(comm, mats, &prm)?;
        if l == 0 {
            lost.extend(departures.into_iter().map(|d| d.0));
        } else {
            self.pending[l].extend(departures.into_iter().map(|d| d.1));
        }
        if l + 1 < levels.len() {
            self.advance(levels, comm, l + 1, t, mats, base, ramp, lost)?;
            self.advance(
                levels,
                comm,
                l + 1,
                t + 0.5 * prm.dt,
                mats,
                base,
                ramp,
                lost,
            )?;
            self.sync(levels, l, comm)?;
        }
        Ok(())
    }

    /// Synchronises level `l` with level `l + 1` (collective): owned
    /// particles that crossed the fine region's boundary change level, the
    /// old copies are deleted, and fresh copies are made: coarse-owned
    /// particles in the fine ghost ring onto the fine level, fine-owned
    /// particles within `COPY_DEPTH` coarse cells inside the fine region onto
    /// the coarse level. Copies are recreated rather than matched, so no
    /// search between levels is needed; arrivals are ordered by global id.
    pub fn sync(&mut self, levels: &mut [Level], l: usize, comm: &Comm) -> Result<()> {
        use crate::particles::{COPY_FROM_COARSER, COPY_FROM_FINER, OWNED};
        let nr = comm.size() as usize;
        let f = l + 1;
        let mut to_coarse: Vec<Vec<u8>> = vec![Vec::new(); nr];
        let mut to_fine: Vec<Vec<u8>> = vec![Vec::new(); nr];
        let mut transfers = 0u64;
        // Fine level: drop copies from the coarse level; hand owned
        // particles outside the fine region to the coarse level.
        let (lo, hi) = levels.split_at_mut(f);
        let (coarse, fine) = (&mut lo[l], &mut hi[0]);
        for rec in self.pending[f].drain(..) {
            let mut one = Particles::new();
            one.push_packed(&rec);
            if !coarse.pack_for(&one, 0, &mut to_coarse) {
                return Err(Error::new(
                    Status::Internal,
                    format!(
                        "particle {} left level {f} and lies in no patch of level {l}",
                        one.id[0]
                    ),
                ));
            }
            transfers += 1;
        }
        for p in &mut fine.local {
            let parts = &p.parts;
            let mut drop = vec![false; parts.len()];
            for i in 0..parts.len() {
                if parts.copy[i] == COPY_FROM_COARSER {
                    drop[i] = true;
                } else if parts.copy[i] == OWNED
                    && !fine.owned.iter().any(|b| {
                        let c = [
                            ((parts.x[i] - fine.origin[0]) / fine.h).floor() as i64,
                            ((parts.y[i] - fine.origin[1]) / fine.h).floor() as i64,
                        ];
                        b.contains_cell(c[0], c[1])
                    })
                {
                    if coarse.pack_for(parts, i, &mut to_coarse) {
                        transfers += 1;
                        drop[i] = true;
                    }
                }
            }
            p.parts.retain(|i| !drop[i]);
        }
        // Coarse level: drop copies from the fine level; hand owned
        // particles inside the fine region to the fine level.
        for p in &mut coarse.local {
            let parts = &p.parts;
            let mut drop = vec![false; parts.len()];
            for i in 0..parts.len() {
                if parts.copy[i] == COPY_FROM_FINER {
                    drop[i] = true;
                } else if parts.copy[i] == OWNED
                    && fine.owns_cell(fine.cell_of(parts.x[i], parts.y[i]))
                {
                    if fine.pack_for(parts, i, &mut to_fine) {
                        transfers += 1;
                        drop[i] = true;
                    }
                }
            }
            p.parts.retain(|i| !drop[i]);
        }
        coarse.deliver(comm, &to_coarse)?;
        fine.deliver(comm, &to_fine)?;
        // Fresh copies.
        for b in to_coarse.iter_mut().chain(to_fine.iter_mut()) {
            b.clear();
        }
        for p in &coarse.local {
            let parts = &p.parts;
            for i in 0..parts.len() {
                if parts.copy[i] != OWNED {
                    continue;
                }
                let c = fine.cell_of(parts.x[i], parts.y[i]);
                if !fine.owns_cell(c) {
                    // In the fine ghost ring when a fine patch holds the cell.
                    fine.pack_as(parts, i, Some(COPY_FROM_COARSER), &mut to_fine);
                }
            }
        }
        let deep = deep_boxes(&fine.owned, &fine.domain, 2 * COPY_DEPTH);
        for p in &fine.local {
            let parts = &p.parts;
            for i in 0..parts.len() {
                if parts.copy[i] != OWNED {
                    continue;
                }
                let c = fine.cell_of(parts.x[i], parts.y[i]);
                if !deep.iter().any(|b| b.contains_cell(c[0], c[1])) {
                    coarse.pack_as(parts, i, Some(COPY_FROM_FINER), &mut to_coarse);
                }
            }
        }
        coarse.deliver(comm, &to_coarse)?;
        fine.deliver(comm, &to_fine)?;
        self.transfers += transfers;
        Ok(())
    }
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
