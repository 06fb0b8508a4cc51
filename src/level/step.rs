//! The level step: the kernel's one step on the local patches, with the
//! nodal sums and the contact phase between its phases, then migration.

use super::{Departure, Fields, Level};
use crate::comm::Comm;
use crate::contact::resolve::{LevelGeometry, PatchRef};
use crate::contact::LevelStepContact;
use crate::error::{Error, Result, Status};
use crate::kernel::{self, GridPhase, PatchMut, Patches, Pipeline, StepParams};
use crate::material::MatParams;
use crate::particles::{CopyKind, Packed};

/// What a level step does to its local patches' grids at
/// [`Patches::grid_hook`] (after the grid updates the particles read): the
/// coupling of nested levels prescribes the coarse level's velocities on a
/// refined level's ghost ring and saves a coarse level's nodal velocities
/// for the finer one (see [`crate::coupling`]).
pub trait GridHook {
    /// Called with the level's local patches (in increasing patch index;
    /// a patch without particles has no grid) at `phase` of a step with
    /// `prm` (the level's step parameters, its boundary included).
    fn grid_hook(&mut self, local: &mut [super::LocalPatch], prm: &StepParams, phase: GridPhase);
}

impl Level {
    /// Advances the level by one step of `prm.dt` (collective): the one
    /// step, [`kernel::step_patches`], on the local patches, with the nodal
    /// sums over shared nodes ([`Level::exchange`]) and the contact phase
    /// (with `contact`, see [`crate::contact::resolve`]) between its
    /// phases, then particle migration, which looks only at the particles
    /// the last pass noted as possibly leaving their patch
    /// ([`kernel::PassStats::leaving`]). With `next_load_factor`, the last
    /// pass also scatters the next step's first P2G (loads at that factor)
    /// on every patch, and the next step skips it on the patches whose
    /// particles nothing changed (bit for bit the same result; see
    /// [`kernel::Pipeline`]); pass it only when nothing reads the grids'
    /// accumulators between the steps. With `skip_last`, the last pass
    /// leaves the copies with that copy flag as they are (in whole blocks,
    /// see [`kernel::Pipeline::skip_last`]): pass it only for copies that
    /// are replaced before anything reads them after this step. Returns the
    /// owned particles that left the level (see [`Level::migrate`]). With
    /// `hook`, [`GridHook::grid_hook`] runs at every
    /// [`Patches::grid_hook`] of the step. On an error every rank fails
    /// (the state is that reached by the step).
    #[allow(clippy::too_many_arguments)]
    pub fn step(
        &mut self,
        comm: &Comm,
        mats: &[MatParams],
        prm: &StepParams,
        contact: Option<LevelStepContact>,
        next_load_factor: Option<f64>,
        skip_last: Option<CopyKind>,
        hook: Option<&mut dyn GridHook>,
    ) -> Result<Vec<(Departure, Packed)>> {
        let t0 = std::time::Instant::now();
        let before = self.stats;
        let r = self.step_inner(comm, mats, prm, contact, next_load_factor, skip_last, hook);
        let other = (self.stats.exchange - before.exchange) + (self.stats.migrate - before.migrate);
        self.stats.compute += t0.elapsed().as_secs_f64() - other;
        self.stats.steps += 1;
        r
    }

    /// The contact phase (see [`crate::contact::resolve`]) on the local
    /// patches' grids after their grid update.
    fn contact_phase(
        &mut self,
        comm: &Comm,
        prm: &StepParams,
        c: &mut LevelStepContact,
    ) -> Result<()> {
        let h = self.h;
        let o = self.origin;
        let mut extent = [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ];
        for b in &self.patches {
            extent[0] = extent[0].min(o[0] + b.lo[0] as f64 * h);
            extent[1] = extent[1].min(o[1] + b.lo[1] as f64 * h);
            extent[2] = extent[2].max(o[0] + b.hi[0] as f64 * h);
            extent[3] = extent[3].max(o[1] + b.hi[1] as f64 * h);
        }
        let geo = LevelGeometry {
            l: self.l,
            h,
            origin: o,
            extent,
            boundary: prm.boundary,
            shape: prm.shape,
            mass_tol: prm.mass_tol,
            dt: prm.dt,
            t_end: c.t_end,
            thickness: c.thickness,
            axi: prm.mode == crate::mode::ModeKind::Axisymmetric,
            catch_up: if c.out.last_dt > 0.0 {
                (prm.dt / c.out.last_dt).min(1.0)
            } else {
                1.0
            },
        };
        let mut refs: Vec<PatchRef> = self
            .local
            .iter_mut()
            .filter_map(|p| {
                p.grid.as_mut().map(|g| PatchRef {
                    parts: &p.parts,
                    grid: g,
                })
            })
            .collect();
        crate::contact::resolve::resolve(
            &mut refs,
            &geo,
            comm,
            c.indenters,
            c.opts,
            c.solver,
            c.out,
        )
    }

    #[allow(clippy::too_many_arguments)]
    fn step_inner(
        &mut self,
        comm: &Comm,
        mats: &[MatParams],
        prm: &StepParams,
        contact: Option<LevelStepContact>,
        next_load_factor: Option<f64>,
        skip_last: Option<CopyKind>,
        hook: Option<&mut dyn GridHook>,
    ) -> Result<Vec<(Departure, Packed)>> {
        let mut prm = *prm;
        prm.boundary = self.boundary();
        let mut first_err: Option<Error> = None;
        let note = |r: Result<()>, e: &mut Option<Error>| {
            if let Err(x) = r {
                e.get_or_insert(x);
            }
        };
        // A grid this rank cannot allocate fails the step on every rank
        // (agreed below), not this rank alone before the exchanges.
        note(self.ensure_grids(), &mut first_err);
        let pipe = Pipeline {
            next_load_factor,
            fuse: true,
            skip_last: skip_last.map(CopyKind::flag),
        };
        let mut set = LevelPatches {
            lv: self,
            comm,
            contact,
            hook,
        };
        let out = kernel::step_patches(&mut set, mats, &prm, pipe, None)?;
        if let Some(e) = out.first_err {
            first_err.get_or_insert(e);
        }
        let mut stats = out.stats;
        // Non-finite or inverted particles (checked before migration, so the
        // message names a particle this rank holds, with its level and
        // patch). Particles off a patch's grid are not a problem here:
        // migration moves them. A rank that failed migrates nothing (a
        // broken particle is never sent anywhere) but still takes part in
        // the migration's exchange, so no rank waits for it there; the ranks
        // agree at the end (one reduction per level step, as without the
        // failure).
        let l = self.l;
        for (p, st) in self.local.iter().zip(&mut stats) {
            st.first_outside = None;
            note(
                st.to_result(&p.parts).map_err(|e| {
                    Error::new(e.status, format!("{} (level {l}, patch {})", e.msg, p.k))
                }),
                &mut first_err,
            );
        }
        let departures = if first_err.is_some() {
            self.migrate_nothing(comm).map(|()| Vec::new())
        } else {
            // The last pass moved the particles and noted the slots that
            // may have left their patch: migration looks at those only.
            let leaving: Vec<_> = stats.iter().map(|s| s.leaving).collect();
            self.migrate(comm, Some(&leaving))
        };
        let departures = match departures {
            Ok(d) => d,
            Err(e) => {
                first_err.get_or_insert(e);
                Vec::new()
            }
        };
        note(self.ensure_grids(), &mut first_err);
        if first_err.is_some() {
            self.unprepare();
        }
        agreed(comm, &mut first_err)?;
        self.step_dt_cfl1 = stats
            .iter()
            .map(|s| s.dt_cfl1)
            .fold(f64::INFINITY, f64::min);
        Ok(departures)
    }
}

/// A level's local patches as the kernel's step sees them: sums through
/// [`Level::exchange`], contact through the level's contact phase, the
/// grid hook through the caller's [`GridHook`].
struct LevelPatches<'l, 'c, 'h> {
    lv: &'l mut Level,
    comm: &'l Comm,
    contact: Option<LevelStepContact<'c>>,
    hook: Option<&'h mut dyn GridHook>,
}

impl Patches for LevelPatches<'_, '_, '_> {
    fn count(&self) -> usize {
        self.lv.local.len()
    }

    fn patch(&mut self, i: usize) -> Option<PatchMut<'_>> {
        let p = &mut self.lv.local[i];
        let grid = p.grid.as_mut()?;
        Some(PatchMut {
            grid,
            parts: &mut p.parts,
            body: None,
            prepared: &mut p.prepared,
        })
    }

    fn sum(&mut self, fields: Fields) -> Result<()> {
        self.lv.exchange(self.comm, fields)
    }

    fn contact(&mut self, prm: &StepParams) -> Result<()> {
        match &mut self.contact {
            Some(c) => self.lv.contact_phase(self.comm, prm, c),
            None => Ok(()),
        }
    }

    fn grid_hook(&mut self, prm: &StepParams, phase: GridPhase) {
        if let Some(h) = self.hook.as_deref_mut() {
            h.grid_hook(&mut self.lv.local, prm, phase);
        }
    }
}

/// Agrees across the ranks of `comm` whether any has an error in `err`
/// (collective): every rank returns an error when one does, this rank's own
/// or, on a rank without one, a pointer to the failing rank's message.
fn agreed(comm: &Comm, err: &mut Option<Error>) -> Result<()> {
    let bad = comm.any(err.is_some())?;
    if let Some(e) = err.take() {
        return Err(e);
    }
    if bad {
        return Err(Error::elsewhere(
            Status::Unstable,
            "the level step failed on another rank (for example non-finite or inverted particles there); see that rank's message",
        ));
    }
    Ok(())
}
