//! Transactional steps: the snapshot a failed step returns to, and the
//! replay of the successful steps since it.

use super::{RunConfig, Simulation, StepReport};
use crate::coupling::Coupler;
use crate::error::{Error, Result, Status};
use crate::level::Level;

/// Steps a [`Snapshot`] serves before a fresh one is taken: a failed step
/// replays at most this many successful steps, and the copy of the state
/// costs 1/`SNAPSHOT_EVERY` of a copy per step.
pub const SNAPSHOT_EVERY: usize = 32;

/// A copy of everything a step changes, taken before a step, and the
/// successful steps taken since (see [`Simulation::step`]).
///
/// A snapshot is taken into the buffers of the previous one (`clone_from`
/// of the levels: particle arrays and grids are copied into the arrays
/// already there), so that once the first is taken, later ones allocate
/// nothing while the particle counts do not outgrow them: a fresh copy each
/// time cost page faults on every first touch of its pages, a few per cent
/// of the step on the comparison scene.
#[derive(Debug)]
pub(super) struct Snapshot {
    /// Whether this is the state a failed step returns to; false once
    /// [`Simulation::invalidate_snapshot`] forgot it (the buffers stay for
    /// the next snapshot).
    valid: bool,
    levels: Vec<Level>,
    time: f64,
    steps: u64,
    lost_len: usize,
    next_id: u64,
    dt_cfl1: Option<f64>,
    mass_ref: Option<f64>,
    balanced: bool,
    synced: bool,
    coupling: Coupler,
    contact_levels: Vec<crate::contact::LevelContact>,
    coarse_dt: f64,
    /// The run settings the steps since were taken with (a change
    /// invalidates the snapshot).
    run: RunConfig,
    /// The successful steps since: `(dt, time after the step)`.
    log: Vec<(f64, f64)>,
}

impl Snapshot {
    /// An invalid snapshot without buffers (the first
    /// [`Simulation::begin_transaction`] fills it).
    fn empty() -> Snapshot {
        Snapshot {
            valid: false,
            levels: Vec::new(),
            time: 0.0,
            steps: 0,
            lost_len: 0,
            next_id: 0,
            dt_cfl1: None,
            mass_ref: None,
            balanced: false,
            synced: false,
            coupling: Coupler::default(),
            contact_levels: Vec::new(),
            coarse_dt: 0.0,
            run: RunConfig::default(),
            log: Vec::with_capacity(SNAPSHOT_EVERY),
        }
    }
}

impl Simulation {
    /// Advances one step of `dt` (collective; every rank passes the same
    /// `dt`). A `dt` above the stable step is rejected with `Unstable` and
    /// nothing changes.
    ///
    /// **Steps are transactional.** A step that fails for any reason
    /// (`Unstable`: non-finite values or an inverted deformation gradient,
    /// or a new state whose stable step is zero or cannot advance the
    /// clock; `ParticlesLeft` under [`Outflow::Fail`]; a contact solve;
    /// an internal error) leaves the state bitwise as it was before the
    /// call on every rank: particles of every level and patch (copies,
    /// plastic strain included), the clock, the step count, the lost list
    /// and the contact state; the caller may lower `dt` and retry. Errors
    /// are agreed across ranks inside the step before any collective
    /// follow-up, so every rank fails together. The mechanism: a copy of
    /// the state taken at most every [`SNAPSHOT_EVERY`] steps (and after
    /// any change outside stepping, see
    /// [`Simulation::invalidate_snapshot`]) plus the step sizes since; a
    /// failed step restores the copy and replays the successful steps
    /// since it, which is bitwise since a step is deterministic. Each copy
    /// is made into the previous one's buffers (particle arrays and grids
    /// included, see `Level`'s `clone_from`), so that steps allocate no
    /// state-sized memory once the first copy is taken.
    /// Particles that leave the domain are removed and recorded under
    /// [`Outflow::Remove`].
    pub fn step(&mut self, dt: f64) -> Result<StepReport> {
        let run = self.run;
        run.check_step_dt(dt, || self.stable_dt())?;
        self.begin_transaction();
        match self.step_once(dt) {
            Ok(rep) => {
                if let Some(s) = &mut self.txn {
                    s.log.push((dt, self.time));
                }
                Ok(rep)
            }
            Err(e) => {
                self.roll_back()?;
                Err(e)
            }
        }
    }

    /// Forgets the snapshot failed steps return to, so that the next step
    /// takes a fresh one. Every change of the state outside stepping must
    /// call it (the C API does for every call that is not a step or a
    /// query): a failed step replays the steps since the snapshot, which
    /// reproduces the state only when nothing else changed it, and the
    /// next step's first mapping, which the last step may have prepared on
    /// the grids, holds only when nothing changed the particles since.
    pub fn invalidate_snapshot(&mut self) {
        // Forgotten, not freed: the next snapshot reuses its buffers.
        if let Some(s) = &mut self.txn {
            s.valid = false;
        }
        // The same changes make the first mapping the last step prepared
        // on the grids stale (see `Level::unprepare`).
        for l in &mut self.levels {
            l.unprepare();
        }
    }

    /// Takes a snapshot when there is none, when the current one has served
    /// [`SNAPSHOT_EVERY`] steps, or when the run settings changed.
    fn begin_transaction(&mut self) {
        let fresh = match &self.txn {
            Some(s) => !s.valid || s.log.len() >= SNAPSHOT_EVERY || s.run != self.run,
            None => true,
        };
        if !fresh {
            return;
        }
        // Into the previous snapshot's buffers (see `Snapshot`): the
        // result equals a fresh clone field by field.
        let mut snap = self
            .txn
            .take()
            .unwrap_or_else(|| Box::new(Snapshot::empty()));
        // Every field named (no `..`): a new one must be taken here.
        let Snapshot {
            valid,
            levels,
            time,
            steps,
            lost_len,
            next_id,
            dt_cfl1,
            mass_ref,
            balanced,
            synced,
            coupling,
            contact_levels,
            coarse_dt,
            run,
            log,
        } = &mut *snap;
        levels.clone_from(&self.levels);
        *time = self.time;
        *steps = self.steps;
        *lost_len = self.lost.len();
        *next_id = self.next_id;
        *dt_cfl1 = self.dt_cfl1;
        *mass_ref = self.mass_ref;
        *balanced = self.balanced;
        *synced = self.synced;
        coupling.clone_from(&self.coupling);
        contact_levels.clone_from(&self.contact.levels);
        *coarse_dt = self.contact.coarse_dt;
        *run = self.run;
        log.clear();
        *valid = true;
        self.txn = Some(snap);
    }

    /// Puts the state back as it was before the failed step: restores the
    /// snapshot and replays the successful steps since it (collective:
    /// every rank rolls back, as step errors are agreed).
    fn roll_back(&mut self) -> Result<()> {
        let Some(snap) = self.txn.take().filter(|s| s.valid) else {
            return Err(Error::new(
                Status::Internal,
                "a step failed without a snapshot to return to",
            ));
        };
        self.levels.clone_from(&snap.levels);
        self.time = snap.time;
        self.steps = snap.steps;
        self.lost.truncate(snap.lost_len);
        self.next_id = snap.next_id;
        self.dt_cfl1 = snap.dt_cfl1;
        self.mass_ref = snap.mass_ref;
        self.balanced = snap.balanced;
        self.synced = snap.synced;
        self.coupling.clone_from(&snap.coupling);
        self.contact.levels.clone_from(&snap.contact_levels);
        self.contact.coarse_dt = snap.coarse_dt;
        let (steps, time) = (
            snap.steps + snap.log.len() as u64,
            snap.log.last().map(|e| e.1),
        );
        for (k, &(dt, t)) in snap.log.iter().enumerate() {
            if let Err(e) = self.step_once(dt) {
                return Err(Error::new(
                    Status::Internal,
                    format!(
                        "replaying step {} of {} since the snapshot (dt = {dt}) to undo a failed step failed: {}",
                        k + 1,
                        snap.log.len(),
                        e.msg
                    ),
                ));
            }
            // gimlet_advance_to may have set the clock to land on t_end.
            self.time = t;
        }
        if self.steps != steps || time.is_some_and(|t| t.to_bits() != self.time.to_bits()) {
            return Err(Error::new(
                Status::Internal,
                "undoing a failed step did not reproduce the step count and clock",
            ));
        }
        self.txn = Some(snap);
        Ok(())
    }

    /// Sets the clock after the last step to `t` (an advance to a time
    /// lands on it exactly), in the snapshot's log too, so that the replay
    /// of a failed later step lands there as well.
    pub(super) fn land_last_step_on(&mut self, t: f64) {
        self.time = t;
        if let Some(last) = self.txn.as_mut().and_then(|s| s.log.last_mut()) {
            last.1 = t;
        }
    }
}
