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
//! values** (USF; see the last detail for USL and MUSL). On the coarse
//! grid the velocity gradient is constant over most
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
//! **For laws that take the nodal dilatation (J2) the field sums the
//! coarse level's owned particles only**, not its copies of the finer
//! level's. With the copies the field's stress feeds back into itself: the
//! fine particles next to the region's edge enter the coarse nodal field
//! (as the coarse level's copies of them), the field sets the ring
//! copies' stress, the ring copies' stress and dilatation drive those same
//! fine particles, and the nodal dilatation ties their pressure to the
//! ring copies' motion. Under a slow push that loop grows over thousands
//! of synchronisations. Measured on `examples-c/slow_punch` (flat punch,
//! elastic-perfectly-plastic J2 aluminium, 3 levels 500/250/125 nm, cpGIMP
//! MUSL APIC, pushed from rest, 2 ranks), load at 10 nm: with the copies
//! in the field 29.0 N/m (the particles at the edges of the finest box run
//! away from coarse step ~3400; a step is refused at 5359); the field's
//! deviator only, 399.6 N/m and falling; its pressure only, a step refused
//! at 1727; J2 with its own dilatation instead of the nodal one, 368.5
//! N/m; the owned particles only, 365.8 N/m. Ring copies that keep their
//! own stress also cure the slow push (367.7 N/m) but bring back the
//! staircase where the flow is plastic: the Prandtl punch on 3 levels
//! (`plastic_prandtl_np2`) then blows up at depth 0.056 a. The field of
//! owned particles is one-sided next to the refined region; for the
//! linear elastic plate it is 4.3x / 6.8x worse than the field with the
//! copies at cfl 0.5 / 0.125, so the other laws keep the copies. Not a
//! ring-depth or layer-depth matter: a ring of 6 fine cells, or layers 2
//! and 5 cells deeper, change nothing.
//!
//! **The owned-only field is one-sided next to the refined region**, and
//! its nodal mean there is off by the stress's slope times the particles'
//! centroid offset: J2's unloading next to a level boundary came out
//! stiff (the J2 wedge whose plastic zone crosses the finest box's edge:
//! E_r +56 % against the uniform twin's +9.7 %). For these laws each node
//! takes the value of the mass-weighted least-squares plane through its
//! particles instead, its correction to the mean limited to one standard
//! deviation of their values (see `ring_field::limited_plane`): E_r
//! +12.6 %, the load at 600 nm 2.3 % below the twin's (the mean: 0.7 %).
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
//!
//! **The ghost ring moves with the coarse level.** Left to itself, the fine
//! level's ghost ring (copies of coarse particles, advanced by the fine
//! level between two synchronisations) makes the boundary between the
//! levels act like a spring in series with a dashpot: a held load relaxes
//! (docs/validation.md, "A held load relaxes on nested levels"). After
//! every fine grid update (and contact phase), and after MUSL's re-map,
//! every fine node touching a cell inside the domain but outside the
//! refined region (the region's edge and the ring) therefore gets the
//! coarse level's nodal velocity: the coarse linear hats over the coarse
//! nodes that carry mass, linear in time between the coarse step's start
//! (`p/m`, rebuilt as `v - dt f/m`) and end velocities at the fractions
//! `1/4 -> 3/4` and `3/4 -> 5/4` of the coarse step for the two substeps
//! (see `ring_velocity`). Measured in the experiment that found it (1 rank,
//! docs/experiments/ring-velocity.md): the held punch's stored energy over 4 s of
//! hold -3.7 % -> +0.3 % (uniform twin +0.3 %), the axisymmetric one
//! -4.6 % -> +0.02 %, the slow punch's load error -3.8 % -> +0.015 %, the
//! pressure indentation's L2 error 1.18e-2 -> 2.3e-3; the unshifted
//! fractions `0 -> 1/2`, `1/2 -> 1` fail the vibrating plate's accuracy
//! test. USF steps prescribe nothing (the kernel calls no grid hook in
//! them): its velocities lead the stress, and the time levels the ring
//! would need there were not derived.
//!
//! **With the ring prescribed, ring copies keep their owners' values.**
//! The stress field of the first detail above (and J2's owned-only sums
//! and limited plane) answered forces the ring copies put on the fine
//! nodes next to the region's edge; with those nodes moving with the
//! coarse level, the ring copies' own (staircase) values do as well as the
//! field (the experiment of docs/experiments/ring-velocity.md, 1 rank: the
//! plate 0.604 / 0.611 against 0.621 / 0.627 at cfl 0.5 / 0.125, the
//! pressure indentation's L2 error 2.338e-3 against 2.333e-3, the held and
//! slow punches and the J2 wedge the same, the Prandtl punch's limit load
//! +3.83 % against +3.57 %), and the synchronisation neither sums nor
//! exchanges the field (the main job about 7 % faster). The one case that
//! pays is material crossing the boundary: ring copies that move inward
//! carry their staircase stress onto interior fine nodes, and the
//! vibrating block crossing levels (`tests/c/test_hard.c`, `crossings`)
//! changes its momentum by 2.1 % against 1.3 % with the field. So a
//! synchronisation inside [`Coupler::advance`] with USL or MUSL makes ring
//! copies with their
//! owners' values; with USF, and outside a step (the scheme may change
//! before the next one), they take the field. Ring copies that carry no
//! stress at all fail: a ring copy next to the edge reaches interior fine
//! nodes as soon as it moves inward or cpGIMP stretches it.
//!
//! With their owners' values the ring copies need nothing from the coarse
//! level's fresh copies, so both kinds are made first and go to their
//! ranks in one exchange ([`copies`]' `deliver_copy_pair`): the rank that
//! makes most ring copies (the owner of the coarse patch around the
//! region) and the rank that merges most coarse copies no longer wait for
//! each other twice (the main job about 12 % faster on 2 ranks, results
//! bitwise the same). With the field, the coarse copies are delivered
//! before the ring copies are made, in two exchanges.

mod copies;
mod layout;
mod ring_field;
mod ring_velocity;
mod sync;

use crate::comm::Comm;
use crate::contact::Contact;
use crate::error::Result;
use crate::kernel::{Ramp, Scheme, StepParams, Transfer};
use crate::level::{Departure, Level};
use crate::material::{AnyLaw, Constitutive, MatParams};
use crate::particles::{CopyKind, Packed};
use ring_velocity::{RingHook, RingVelocities};
use sync::SyncScratch;

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

/// What one step of the whole hierarchy needs besides the levels (see
/// [`Coupler::advance`]).
pub struct Advance<'a> {
    /// The simulation's communicator.
    pub comm: &'a Comm,
    /// The material table.
    pub mats: &'a [MatParams],
    /// The coarsest level's step parameters (each level's step size and
    /// load factor follow from them).
    pub base: &'a StepParams,
    /// The load ramp.
    pub ramp: &'a Ramp,
    /// The indenters and their contact state.
    pub contact: &'a mut Contact,
    /// The plane-strain thickness.
    pub thickness: f64,
    /// Owned particles that left the domain during the step, in order.
    pub lost: &'a mut Vec<Departure>,
}

/// State of the coupling between levels.
#[derive(Clone, Debug, Default)]
pub struct Coupler {
    /// Owned particles that left a refined level's computational region
    /// during its steps, packed, to be handed to the next coarser level at
    /// the next synchronisation (indexed by level).
    pub pending: Vec<Vec<Packed>>,
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
    /// Per material index: the ring copies' nodal field sums only the
    /// coarse level's owned particles of it, not its copies of the finer
    /// level's (laws that take the nodal dilatation; see the module
    /// notes), set by [`Coupler::set_materials`].
    owned_only: Vec<bool>,
    /// Mappings and smoothing passes of a step of the scheme (see
    /// [`copy_depth`]), set by [`Coupler::set_transfer`]; two mappings and no
    /// smoothing until then.
    reach: Option<(u32, u32)>,
    /// Buffers and layout masks of [`Coupler::sync`], kept between
    /// synchronisations (no state: a clone starts empty).
    scratch: SyncScratch,
    /// The coarse velocities prescribed on each refined level's ghost ring
    /// (see the module notes): plans and the last coarse step's values,
    /// recomputed before every use (a clone starts empty).
    ring: RingVelocities,
    /// The material table, set by [`Coupler::set_materials`].
    mats: Vec<MatParams>,
    /// Per level, `h / max (c + |v|)` over the copies the last
    /// synchronisation of [`Coupler::advance`] made on it: `[0]` of the
    /// finer level's particles, `[1]` of the coarser's (infinite for none;
    /// see [`Coupler::copies_dt_cfl1`]).
    copies_dt: Vec<[f64; 2]>,
    /// The synchronisation running is the last of its pair in the step of
    /// [`Coupler::advance`] (its copies are the ones the step leaves).
    final_sync: bool,
    /// Such synchronisations done in the running step.
    final_syncs: usize,
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

    /// Tells the coupling the material table (which materials' particles
    /// enter the ring copies' nodal field only as owned particles; see the
    /// module notes). Allocates only when the table grows.
    pub fn set_materials(&mut self, mats: &[MatParams]) {
        self.owned_only.clear();
        self.owned_only
            .extend(mats.iter().map(<AnyLaw as Constitutive>::nodal_dilatation));
        self.mats.clear();
        self.mats.extend_from_slice(mats);
    }

    /// The stable step at CFL 1 of the copies on `level` that the last
    /// [`Coupler::advance`] left, `h / max (c + |v|)` over them (the
    /// smaller of the two kinds; infinite for none, and on one level), when
    /// that advance synchronised every pair of its `levels` levels at its
    /// end; `None` otherwise (no step yet, a failed one, or copies made
    /// since by a synchronisation outside a step). With the level steps' own stable
    /// steps (whose last passes leave copies out, see
    /// [`crate::kernel::PassStats::dt_cfl1`]) it gives the stable step of
    /// the state after the step without a pass over the particles.
    pub fn copies_dt_cfl1(&self, level: usize, levels: usize) -> Option<f64> {
        if self.final_syncs + 1 != levels {
            return None;
        }
        self.copies_dt.get(level).map(|d| d[0].min(d[1]))
    }

    /// The grid-particle-grid smoothing passes of a step with `transfer`
    /// (XPIC of order `m`: `m - 1`).
    pub fn smoothing(transfer: Transfer, xpic_order: u32) -> u32 {
        match transfer {
            Transfer::Xpic => xpic_order.saturating_sub(1),
            Transfer::Flip | Transfer::Apic => 0,
        }
    }

    /// Advances level `l` by one step of `run.base.dt / 2^l` starting at
    /// time `t`, then (recursively) the finer levels by two half steps
    /// each, and synchronises each pair when they meet (the paper's fig. 8).
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
    pub fn advance(
        &mut self,
        levels: &mut [Level],
        run: &mut Advance,
        l: usize,
        t: f64,
    ) -> Result<()> {
        self.final_syncs = 0;
        self.copies_dt.clear();
        self.copies_dt
            .resize(levels.len(), [f64::INFINITY, f64::INFINITY]);
        let r = self.advance_level(levels, run, l, t, false, l == 0);
        if r.is_err() {
            self.final_syncs = 0;
        }
        r
    }

    /// [`Coupler::advance`] of level `l`, whose step is the second of the
    /// two of its coarser level's step when `second`, and its last in the
    /// step of level 0 when `last`.
    fn advance_level(
        &mut self,
        levels: &mut [Level],
        run: &mut Advance,
        l: usize,
        t: f64,
        second: bool,
        last: bool,
    ) -> Result<()> {
        let Advance {
            comm,
            mats,
            base,
            ramp,
            ..
        } = *run;
        let mut prm = *base;
        prm.dt = base.dt / (1u64 << l) as f64;
        prm.load_factor = ramp.factor(t);
        if l == 0 {
            self.set_transfer(base.transfer, base.xpic_order);
            self.dt = vec![0.0; levels.len()];
            self.one_material = mats.len() == 1;
            self.set_materials(mats);
            self.lag = match base.scheme {
                Scheme::Usf => -1.0,
                Scheme::Usl | Scheme::Musl => 1.0,
            };
        }
        // The ghost ring's prescribed velocities (USL, MUSL): level `l`
        // saves the coarse values for level `l + 1` in its step, and
        // prescribes its own ring from level `l - 1`'s.
        let ring_on = levels.len() > 1 && base.scheme != Scheme::Usf;
        if ring_on {
            if self.ring.levels.len() != levels.len() {
                self.ring.levels.resize_with(levels.len(), Default::default);
            }
            if l + 1 < levels.len() {
                self.ring.levels[l + 1].update(&levels[l], &levels[l + 1], comm.rank());
            }
            if l > 0 {
                self.ring.levels[l].set_substep(second);
            }
        }
        let mut hook = ring_on.then(|| {
            let (lo, hi) = self.ring.levels.split_at_mut(l + 1);
            RingHook {
                prescribe: (l > 0).then_some(&lo[l]),
                capture: hi.first_mut(),
                me: comm.rank(),
            }
        });
        let ctx = run.contact.level_step(l, t + prm.dt, run.thickness);
        // On one level nothing reads the grids between two steps (the
        // coupling of levels reads the last step's nodal forces): the last
        // pass may prepare the next step's first mapping.
        let next = (levels.len() == 1).then(|| ramp.factor(t + prm.dt));
        let finest = l + 1 == levels.len();
        let skip = if !finest {
            Some(CopyKind::FromFiner)
        } else if second && l > 0 {
            Some(CopyKind::FromCoarser)
        } else {
            None
        };
        let hook_dyn = hook.as_mut().map(|h| h as &mut dyn crate::level::GridHook);
        let departures = match levels[l].step(comm, mats, &prm, ctx, next, skip, hook_dyn) {
            Ok(d) => d,
            Err(e) => {
                self.dt.clear();
                return Err(e);
            }
        };
        if ring_on && l + 1 < levels.len() {
            if let Err(e) = self.ring.levels[l + 1].exchange(comm) {
                self.dt.clear();
                return Err(e);
            }
        }
        self.dt[l] = prm.dt;
        if l == 0 {
            run.lost.extend(departures.into_iter().map(|d| d.0));
        } else {
            self.pending[l].extend(departures.into_iter().map(|d| d.1));
        }
        if l + 1 < levels.len() {
            self.advance_level(levels, run, l + 1, t, false, false)?;
            self.advance_level(levels, run, l + 1, t + 0.5 * prm.dt, true, last)?;
            let t0 = std::time::Instant::now();
            self.final_sync = last;
            let r = self.sync(levels, l, comm);
            self.final_sync = false;
            self.final_syncs += usize::from(last && r.is_ok());
            run.lost.append(&mut self.outflow);
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
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
