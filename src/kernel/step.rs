//! The explicit step, written once: the phases of a scheme over a set of
//! patches, with the sums over shared nodes and the contact phase left to
//! the owner of the patches ([`Patches`]). A level of patches over MPI ranks
//! ([`crate::level::Level`]) sums through its communicator; one patch that
//! owns the whole domain ([`OnePatch`]: the single-patch reference solver,
//! [`super::step_patch`]) has nothing to sum. Both run this code, so there
//! is one step to make fast and to keep correct.
//!
//! **Merged passes.** Within a step a G2P pass and the P2G the scheme does
//! next run as one loop where the scheme allows (MUSL's velocity update and
//! momentum re-map, USF's strain and force passes). Across steps, the last
//! pass may also scatter the next step's first P2G ([`Pipeline`]); the
//! patch then remembers what it scattered ([`Prepared`]) and the next step
//! skips its first P2G on that patch when the step's loads match and
//! nothing changed the patch's particles since (the owner forgets the
//! preparation of a patch whose particles it changes: migration, insertion,
//! any change between steps). Every choice gives bit for bit the same
//! result: particles are visited in the same order and the same arithmetic
//! is done; only the number of sweeps over the particle arrays changes.
//!
//! **Errors.** A problem on one patch (a P2G that finds a particle off its
//! grid, a dilatation buffer that cannot be allocated) is noted and the
//! step goes on, so that every owner of patches takes part in every sum;
//! the first one is returned with the stats ([`StepOutcome`]). A failed sum
//! or contact phase ends the step at once.

use super::{
    g2p, g2p_except, g2p_p2g, grid_update, grid_velocity, needs_nodal_dilatation, nodal_dilatation,
    normalise_dilatation, p2g, reset_force, reset_momentum, xpic, BodyForce, G2pPass, Grid, Laps,
    Mapping, PassStats, PhaseTimes, Scheme, StepParams, Transfer,
};
use crate::error::{Error, Result};
use crate::material::MatParams;
use crate::particles::Particles;
use crate::shape::ShapeKind;

/// Which nodal accumulators a sum over shared nodes covers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fields {
    /// Mass, momentum and force (USL, MUSL first mapping).
    MassMomentumForce,
    /// Mass and momentum (USF first mapping).
    MassMomentum,
    /// Momentum (MUSL second mapping).
    Momentum,
    /// Force (USF second mapping).
    Force,
    /// The nodal dilatation sums (before the strain pass, J2 materials).
    Dilatation,
}

impl Fields {
    /// The accumulator indices (see [`Grid::acc`]) of these fields.
    pub fn list(self) -> &'static [usize] {
        match self {
            Fields::MassMomentumForce => &[0, 1, 2, 3, 4],
            Fields::MassMomentum => &[0, 1, 2],
            Fields::Momentum => &[1, 2],
            Fields::Force => &[3, 4],
            Fields::Dilatation => &[Grid::DIL_NUM, Grid::DIL_DEN],
        }
    }
}

/// What a patch's grid accumulators hold ahead of its next step: that
/// step's first P2G, scattered by the last pass of the step before with
/// these settings (the only ones a P2G reads besides the particles; a
/// follower load reads the particles' deformation gradient, which is part
/// of them).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Prepared {
    shape: ShapeKind,
    transfer: Transfer,
    first: Fields,
    load_factor: u64,
    gravity: [u64; 2],
}

impl Prepared {
    /// The first P2G of a step with `prm` (exact comparison of the loads).
    fn of(prm: &StepParams, load_factor: f64) -> Prepared {
        Prepared {
            shape: prm.shape,
            transfer: prm.transfer,
            first: first_fields(prm.scheme),
            load_factor: load_factor.to_bits(),
            gravity: [prm.gravity[0].to_bits(), prm.gravity[1].to_bits()],
        }
    }
}

#[cfg(test)]
impl Prepared {
    /// A preparation of a uGIMP FLIP USL step with load factor
    /// `load_factor` (tests of the level copies).
    pub(crate) fn sample(load_factor: f64) -> Prepared {
        Prepared {
            shape: ShapeKind::UGimp,
            transfer: Transfer::Flip,
            first: Fields::MassMomentumForce,
            load_factor: load_factor.to_bits(),
            gravity: [0, (-9.8f64).to_bits()],
        }
    }
}

/// One patch as a step sees it.
pub struct PatchMut<'a> {
    /// The patch's grid (its cells and ghost nodes).
    pub grid: &'a mut Grid,
    /// The patch's particles.
    pub parts: &'a mut Particles,
    /// Per-particle body force per unit mass, if any.
    pub body: Option<BodyForce<'a>>,
    /// What the grid holds ahead of this step (see [`Prepared`]); the step
    /// reads it and leaves what it prepared for the next one.
    pub prepared: &'a mut Option<Prepared>,
}

/// The owner of the patches a step advances: it hands them out, sums the
/// nodal accumulators over nodes several patches share, and runs the
/// contact phase. An owner that sums over MPI must take part in every sum
/// the step asks for, whatever its patches hold.
pub trait Patches {
    /// Number of patches (some may have no grid).
    fn count(&self) -> usize;
    /// Patch `i`, or `None` when it has no grid (no particles): the step
    /// skips it.
    fn patch(&mut self, i: usize) -> Option<PatchMut<'_>>;
    /// Sums `fields` over every node several patches store, so that every
    /// copy of a node holds the same sum.
    fn sum(&mut self, fields: Fields) -> Result<()>;
    /// The contact phase, between the grid update and the passes that read
    /// the updated grid velocities.
    fn contact(&mut self, prm: &StepParams) -> Result<()>;
    /// Called after a grid update that the particles read next, so that the
    /// owner may prescribe nodal values (the coupling of nested levels
    /// prescribes the coarse level's velocities on a refined level's ghost
    /// ring, see [`crate::coupling`]) or read the updated grids:
    /// [`GridPhase::Updated`] after the grid update and the contact phase
    /// of USL and MUSL (before XPIC's filter, which then filters the
    /// prescribed start velocities), [`GridPhase::Remapped`] after MUSL's
    /// velocities of the re-mapped momentum. USF steps never call it.
    /// The default does nothing.
    fn grid_hook(&mut self, _prm: &StepParams, _phase: GridPhase) {}
}

/// Where in a step [`Patches::grid_hook`] is called.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GridPhase {
    /// After the grid update with the forces and the contact phase (USL,
    /// MUSL): `v0 = p/m`, `v = (p + f dt)/m` on every node.
    Updated,
    /// After MUSL's velocities of the re-mapped momentum: `v0 = p/m` of the
    /// re-mapped `p`; `v` and the forces as the update left them.
    Remapped,
}

/// One patch that owns every node it touches: nothing to sum, no contact.
pub struct OnePatch<'a> {
    /// The patch.
    pub patch: PatchMut<'a>,
}

impl Patches for OnePatch<'_> {
    fn count(&self) -> usize {
        1
    }

    fn patch(&mut self, _i: usize) -> Option<PatchMut<'_>> {
        let p = &mut self.patch;
        Some(PatchMut {
            grid: &mut *p.grid,
            parts: &mut *p.parts,
            body: p.body,
            prepared: &mut *p.prepared,
        })
    }

    fn sum(&mut self, _fields: Fields) -> Result<()> {
        Ok(())
    }

    fn contact(&mut self, _prm: &StepParams) -> Result<()> {
        Ok(())
    }
}

/// How a step merges its passes (see the module notes).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Pipeline {
    /// Let the last pass scatter the next step's first P2G, with this
    /// external-force factor (the ramp at the next step's start), this
    /// step's gravity and no body force, on every patch without a body
    /// force; such patches are left [`Prepared`].
    pub next_load_factor: Option<f64>,
    /// Within the step, run a G2P pass and the P2G after it in one loop
    /// where the scheme allows.
    pub fuse: bool,
    /// Particles whose copy flag ([`Particles::copy`]) is this value, in
    /// whole blocks, are left as they are by the last pass (see
    /// [`super::g2p_except`]): copies that their owner replaces before
    /// anything reads their state after this step, so that the pass's
    /// update of them would be thrown away. Ignored where the last pass
    /// scatters the next step's first P2G (it would miss them).
    pub skip_last: Option<f64>,
}

/// What a step found: per patch, the stats of its passes (the last pass's
/// `dt_cfl1`, the first problems, the slots that may have left the patch;
/// untouched for a patch without grid), and the first problem noted on any
/// patch.
#[derive(Debug)]
pub struct StepOutcome {
    /// Per patch.
    pub stats: Vec<PassStats>,
    /// The first error a phase returned on a patch.
    pub first_err: Option<Error>,
}

/// The fields of a scheme's first P2G.
fn first_fields(scheme: Scheme) -> Fields {
    match scheme {
        Scheme::Usl | Scheme::Musl => Fields::MassMomentumForce,
        Scheme::Usf => Fields::MassMomentum,
    }
}

/// Which accumulators a P2G of `f` scatters: (mass, momentum, force).
fn what(f: Fields) -> (bool, bool, bool) {
    match f {
        Fields::MassMomentumForce => (true, true, true),
        Fields::MassMomentum => (true, true, false),
        Fields::Momentum => (false, true, false),
        Fields::Force => (false, false, true),
        Fields::Dilatation => (false, false, false),
    }
}

fn note(r: Result<()>, e: &mut Option<Error>) {
    if let Err(x) = r {
        e.get_or_insert(x);
    }
}

/// The stepper's state over one call of [`step_patches`].
struct Run<'m, 't> {
    mats: &'m [MatParams],
    prm: StepParams,
    pipe: Pipeline,
    stats: Vec<PassStats>,
    first_err: Option<Error>,
    t: Laps<'t>,
}

/// Calls `f` on every patch of `set` that has a grid, in order.
fn each<P: Patches>(set: &mut P, mut f: impl FnMut(usize, PatchMut<'_>)) {
    for i in 0..set.count() {
        if let Some(p) = set.patch(i) {
            f(i, p);
        }
    }
}

impl Run<'_, '_> {
    /// The first P2G on every patch not already prepared for it.
    fn first_mapping<P: Patches>(&mut self, set: &mut P, f: Fields) {
        let key = Prepared::of(&self.prm, self.prm.load_factor);
        let (prm, err) = (&self.prm, &mut self.first_err);
        each(set, |_, p| {
            let ready = p.body.is_none() && *p.prepared == Some(key);
            *p.prepared = None;
            if !ready {
                p.grid.reset();
                note(p2g(p.grid, p.parts, prm, p.body, what(f)), err);
            }
        });
        self.t.lap(|t| &mut t.p2g);
    }

    /// The grid update with the forces (`velocity_only`: the velocities
    /// from the momenta) and the boundary conditions, on every patch.
    fn grid<P: Patches>(&mut self, set: &mut P, velocity_only: bool) {
        let (dt, bnd) = (self.prm.dt, &self.prm.boundary);
        each(set, |_, p| {
            if velocity_only {
                grid_velocity(p.grid, bnd)
            } else {
                grid_update(p.grid, dt, bnd)
            }
        });
        self.t.lap(|t| &mut t.grid);
    }

    /// The nodal dilatation before the strain pass (material tables with a
    /// J2 material only): scatter, sum over the patches, normalise.
    fn dilatation<P: Patches>(&mut self, set: &mut P, from_v0: bool) -> Result<()> {
        if !needs_nodal_dilatation(self.mats) {
            return Ok(());
        }
        let (mats, prm, err) = (self.mats, &self.prm, &mut self.first_err);
        each(set, |_, p| {
            note(nodal_dilatation(p.grid, p.parts, mats, prm, from_v0), err);
        });
        set.sum(Fields::Dilatation)?;
        // A grid whose allocation failed is skipped (the error is noted).
        each(set, |_, p| {
            if p.grid.dil.len() == p.grid.len() {
                normalise_dilatation(p.grid);
            }
        });
        self.t.lap(|t| &mut t.grid);
        Ok(())
    }

    /// The XPIC filter of the grid's start-of-step velocities (transfer
    /// [`Transfer::Xpic`] only; see [`xpic`]), after the grid update and
    /// the contact phase and before the pass that updates the particle
    /// velocities: `m − 1` applications of `B`, each a particle pass, a sum
    /// of the momentum over shared nodes and a grid pass; then the `v0`
    /// lanes hold what the velocity pass reads.
    fn xpic<P: Patches>(&mut self, set: &mut P) -> Result<()> {
        if self.prm.transfer != Transfer::Xpic {
            return Ok(());
        }
        let Run {
            prm,
            first_err: err,
            t,
            ..
        } = self;
        each(set, |_, p| note(xpic::xpic_start(p.grid), err));
        for _ in 1..prm.xpic_order {
            each(set, |_, p| {
                note(
                    xpic::xpic_scatter(p.grid, p.parts, prm.shape, prm.mode),
                    err,
                )
            });
            t.lap(|t| &mut t.p2g);
            set.sum(Fields::Momentum)?;
            each(set, |_, p| xpic::xpic_next(p.grid, &prm.boundary));
            t.lap(|t| &mut t.grid);
        }
        each(set, |_, p| xpic::xpic_finish(p.grid, prm.flip));
        t.lap(|t| &mut t.grid);
        Ok(())
    }

    /// A middle pass (`pass`) and the P2G of `f` after it, in one loop when
    /// fusing; `reset` zeroes what the P2G scatters first.
    fn pass_then_map<P: Patches>(
        &mut self,
        set: &mut P,
        pass: G2pPass,
        f: Fields,
        reset: fn(&mut Grid),
    ) {
        let Run {
            mats,
            prm,
            pipe,
            stats,
            first_err: err,
            t,
        } = self;
        let lf = prm.load_factor;
        each(set, |i, p| {
            if pipe.fuse {
                reset(p.grid);
                let map = Mapping {
                    what: what(f),
                    load_factor: lf,
                    body: p.body,
                };
                let r = g2p_p2g(p.grid, p.parts, mats, prm, pass, map);
                note(r.map(|s| stats[i] = s), err);
                t.lap(|t| &mut t.mid);
            } else {
                stats[i] = g2p(p.grid, p.parts, mats, prm, pass);
                t.lap(|t| &mut t.g2p);
                reset(p.grid);
                note(p2g(p.grid, p.parts, prm, p.body, what(f)), err);
                t.lap(|t| &mut t.p2g);
            }
        });
    }

    /// The last pass, alone or with the next step's first P2G (of `next`).
    fn last_pass<P: Patches>(&mut self, set: &mut P, pass: G2pPass, next: Fields) {
        let (mats, prm, stats, err) = (self.mats, &self.prm, &mut self.stats, &mut self.first_err);
        let skip = self.pipe.skip_last;
        each(set, |i, p| {
            let st = match self.pipe.next_load_factor {
                Some(lf) if p.body.is_none() => {
                    p.grid.reset();
                    let map = Mapping {
                        what: what(next),
                        load_factor: lf,
                        body: None,
                    };
                    match g2p_p2g(p.grid, p.parts, mats, prm, pass, map) {
                        Ok(s) => {
                            *p.prepared = Some(Prepared::of(prm, lf));
                            s
                        }
                        Err(e) => {
                            err.get_or_insert(e);
                            return;
                        }
                    }
                }
                _ => g2p_except(p.grid, p.parts, mats, prm, pass, skip),
            };
            // The last pass's stats come first (its dt_cfl1), the middle
            // pass's problems and leaving range are merged in.
            let mut b = st;
            b.merge(&stats[i]);
            stats[i] = b;
        });
        if self.pipe.next_load_factor.is_some() {
            self.t.lap(|t| &mut t.fused);
        } else {
            self.t.lap(|t| &mut t.g2p);
        }
    }
}

/// One explicit step of `prm.dt` over the patches of `set` (see the module
/// notes): the phases of `prm.scheme` on every patch with a grid, with
/// [`Patches::sum`] after every P2G and [`Patches::contact`] after the
/// grid update. `prm.boundary` applies to every patch. The caller checks
/// the stats ([`PassStats::to_result`]) and moves the particles that left
/// their patch. Phase times are added to `times` when given.
pub fn step_patches<P: Patches>(
    set: &mut P,
    mats: &[MatParams],
    prm: &StepParams,
    pipe: Pipeline,
    times: Option<&mut PhaseTimes>,
) -> Result<StepOutcome> {
    // dt_cfl1 starts infinite: only the pass that moves the particles sets it.
    let fresh = PassStats {
        dt_cfl1: f64::INFINITY,
        ..PassStats::default()
    };
    let mut run = Run {
        mats,
        prm: *prm,
        pipe,
        stats: vec![fresh; set.count()],
        first_err: None,
        t: Laps::new(times),
    };
    let first = first_fields(prm.scheme);
    run.first_mapping(set, first);
    set.sum(first)?;
    match prm.scheme {
        Scheme::Usl => {
            run.grid(set, false);
            set.contact(&run.prm)?;
            set.grid_hook(&run.prm, GridPhase::Updated);
            run.xpic(set)?;
            run.dilatation(set, false)?;
            run.last_pass(set, G2pPass::UslAll, first);
        }
        Scheme::Musl => {
            run.grid(set, false);
            set.contact(&run.prm)?;
            set.grid_hook(&run.prm, GridPhase::Updated);
            run.xpic(set)?;
            // The velocity pass reads only the grid's velocities, so the
            // momentum it re-maps is zeroed first.
            run.pass_then_map(set, G2pPass::MuslVelocity, Fields::Momentum, reset_momentum);
            set.sum(Fields::Momentum)?;
            run.grid(set, true);
            set.grid_hook(&run.prm, GridPhase::Remapped);
            run.dilatation(set, true)?;
            run.last_pass(set, G2pPass::MuslPositionStrain, first);
        }
        Scheme::Usf => {
            run.grid(set, true);
            run.dilatation(set, true)?;
            // The strain pass reads only the grid's velocities: the forces
            // are zeroed first.
            run.pass_then_map(set, G2pPass::UsfStrain, Fields::Force, reset_force);
            set.sum(Fields::Force)?;
            run.grid(set, false);
            set.contact(&run.prm)?;
            run.xpic(set)?;
            run.last_pass(set, G2pPass::UsfVelocityPosition, first);
        }
    }
    run.t.count_step();
    Ok(StepOutcome {
        stats: run.stats,
        first_err: run.first_err,
    })
}
