//! The run settings and the step: checks of a step size, the stable step,
//! the preparation of the levels, one step of the whole hierarchy, and an
//! advance to a time.

use super::Simulation;
use crate::coupling::{Advance, Coupler};
use crate::error::{Error, Result, Status};
use crate::kernel::{FaceBc, Ramp, Scheme, StepParams, Transfer, MASS_TOL_REL};
use crate::limits;
use crate::mode::ModeKind;
use crate::shape::ShapeKind;

/// What happens to particles that leave the domain during a step.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Outflow {
    /// A step in which particles leave the domain fails with
    /// `ParticlesLeft` and is undone like any failed step (see
    /// [`Simulation::step`]): the particles stay, the lost list is
    /// unchanged. (Before transactional steps the state was advanced with
    /// the particles removed and recorded.)
    #[default]
    Fail,
    /// They are removed and recorded; the step succeeds.
    Remove,
}

/// The XPIC order a simulation starts with ([`RunConfig::xpic_order`]).
pub const DEFAULT_XPIC_ORDER: u32 = 5;

/// Settings of the time integration (changeable between steps).
///
/// The defaults ([`RunConfig::default`]) are cpGIMP weights, MUSL and the
/// APIC transfer: the one combination that passes every hard case of the
/// stability suite (rigid rotation, tension past 50 %, impact, long run,
/// crossings, free flight; README, "The default scheme and why"). The
/// paper's scenes set uGIMP and FLIP explicitly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunConfig {
    /// Weight function.
    pub shape: ShapeKind,
    /// Update scheme.
    pub scheme: Scheme,
    /// FLIP fraction in `[0, 1]` (ignored by [`Transfer::Apic`]).
    pub flip: f64,
    /// Particle–grid velocity transfer.
    pub transfer: Transfer,
    /// Order of [`Transfer::Xpic`] in `1..=`[`crate::kernel::xpic::MAX_XPIC_ORDER`]
    /// (kept, and read only while that transfer is set).
    pub xpic_order: u32,
    /// Courant number in `(0, 1]`.
    pub cfl: f64,
    /// Gravity.
    pub gravity: [f64; 2],
    /// Face conditions: left, right, bottom, top.
    pub bc: [FaceBc; 4],
    /// Load ramp of the particles' reference external forces.
    pub ramp: Ramp,
    /// Outflow policy.
    pub outflow: Outflow,
}

impl RunConfig {
    /// Checks the settings: `flip` in `[0, 1]`, `cfl` in `(0, 1]`, gravity
    /// components and `t_ramp >= 0` within the magnitude window of
    /// [`crate::limits`].
    pub fn validate(&self) -> Result<()> {
        if !(0.0..=1.0).contains(&self.flip) {
            return Err(Error::arg(format!(
                "flip = {} must lie in [0, 1]",
                self.flip
            )));
        }
        crate::kernel::xpic::xpic_order(self.xpic_order.into())?;
        if !(self.cfl > 0.0 && self.cfl <= 1.0) {
            return Err(Error::arg(format!("cfl = {} must lie in (0, 1]", self.cfl)));
        }
        for (name, g) in [
            ("gravity gx", self.gravity[0]),
            ("gravity gy", self.gravity[1]),
        ] {
            limits::magnitude(name, g)?;
        }
        let t = self.ramp.t_ramp;
        if t.is_nan() || t < 0.0 {
            return Err(Error::arg(format!("t_ramp = {t} must be finite and >= 0")));
        }
        limits::magnitude("t_ramp", t)
    }

    /// Checks the `dt` of a step taken with these settings: finite and
    /// positive (else `InvalidArgument`), then at most the stable step that
    /// `stable` computes for the state (`cfl` times `min h/(c + |v|)`,
    /// else `Unstable`; a relative excess of 1e-12 is round-off and
    /// passes). Returns the stable step. The one check of a step size,
    /// for [`Simulation::step`] and any single-patch reference.
    pub fn check_step_dt(&self, dt: f64, stable: impl FnOnce() -> Result<f64>) -> Result<f64> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(Error::arg(format!("dt = {dt} must be finite and > 0")));
        }
        let stable = stable()?;
        if dt > stable * (1.0 + 1e-12) {
            return Err(Error::new(
                Status::Unstable,
                format!(
                    "dt = {dt} must be <= the stable step {stable} (cfl = {} times min h/(c + |v|))",
                    self.cfl
                ),
            ));
        }
        Ok(stable)
    }
}

impl Default for RunConfig {
    fn default() -> Self {
        RunConfig {
            shape: ShapeKind::CpGimp,
            scheme: Scheme::Musl,
            flip: 1.0,
            transfer: Transfer::Apic,
            xpic_order: DEFAULT_XPIC_ORDER,
            cfl: 0.5,
            gravity: [0.0, 0.0],
            bc: [FaceBc::Free; 4],
            ramp: Ramp::default(),
            outflow: Outflow::Fail,
        }
    }
}

/// What one step (or an advance to a time) did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepReport {
    /// Steps taken so far.
    pub steps: u64,
    /// Time reached.
    pub time: f64,
    /// The last step size.
    pub dt: f64,
    /// The stable step of the new state (CFL included).
    pub stable_dt: f64,
    /// Particles that left the domain during the call (global count).
    pub left: u64,
}

impl Simulation {
    /// Changes the run settings (checked); caches that depend on them are
    /// refreshed.
    pub fn set_run(&mut self, run: RunConfig) -> Result<()> {
        run.validate()?;
        if run != self.run {
            self.invalidate_snapshot();
        }
        // More XPIC passes reach deeper than the layer of copies the last
        // synchronisation made (see `coupling::copy_depth`): make them again.
        if Coupler::smoothing(run.transfer, run.xpic_order)
            > Coupler::smoothing(self.run.transfer, self.run.xpic_order)
        {
            self.synced = false;
        }
        self.run = run;
        let bc = self.level_bc(&run);
        for l in &mut self.levels {
            l.bc = bc;
        }
        Ok(())
    }

    /// Checks that the simulation can step or report its stable step
    /// (local): a material exists and the layout can be frozen.
    pub fn check_steppable(&self) -> Result<()> {
        if self.materials.is_empty() {
            return Err(Error::state(
                "no material is defined: add one before stepping",
            ));
        }
        self.check_layout()
    }

    /// Checks the `dt` of a step (local): finite, `<= MAG_MAX`, and large
    /// enough to advance the clock (`time + dt > time`); `dt <= 0` asks for
    /// the stable step (checked when it is known, see
    /// [`Simulation::check_stable_dt`]).
    pub fn check_dt(&self, dt: f64) -> Result<()> {
        if !dt.is_finite() || dt.abs() > limits::MAG_MAX {
            return Err(Error::arg(format!(
                "dt = {dt} must be finite with |dt| <= {:e} (dt <= 0 takes the stable step)",
                limits::MAG_MAX
            )));
        }
        self.check_steppable()?;
        if dt > 0.0 && self.time + dt == self.time {
            return Err(Error::arg(format!(
                "dt = {dt} is too small to advance the time {} (time + dt == time)",
                self.time
            )));
        }
        Ok(())
    }

    /// Checks a stable step `dt` for a step of `dt <= 0`: infinite without
    /// particles (then the step is refused with `InvalidState`: pass
    /// `dt > 0` to advance the clock of an empty simulation), and otherwise
    /// large enough to advance the clock.
    pub fn check_stable_dt(&self, dt: f64) -> Result<()> {
        if dt.is_infinite() {
            return Err(Error::state(
                "dt <= 0 asks for the stable step, which is undefined (infinite) without particles: pass dt > 0 to advance the clock of an empty simulation",
            ));
        }
        if !(dt > 0.0 && self.time + dt > self.time) {
            return Err(Error::new(
                Status::Unstable,
                format!("the stable step {dt} cannot advance the time {}", self.time),
            ));
        }
        Ok(())
    }

    /// The global stable step `cfl · min h/(c+|v|)` of the current state
    /// (collective; infinite without particles).
    pub fn stable_dt(&mut self) -> Result<f64> {
        self.check_steppable()?;
        self.freeze();
        if self.dt_cfl1.is_none() {
            let mats = self.mat_params();
            // Level l takes steps of dt / 2^l.
            let mut v = [self
                .levels
                .iter()
                .map(|l| l.local_dt_cfl1(&mats) * (1u64 << l.l) as f64)
                .fold(f64::INFINITY, f64::min)];
            self.comm.min_f64(&mut v)?;
            self.dt_cfl1 = Some(v[0]);
        }
        Ok(self.run.cfl * self.dt_cfl1.unwrap_or(f64::INFINITY))
    }

    /// This rank's `min h/(c+|v|)` over the particles after a successful
    /// step, from the step's own passes and synchronisations (see
    /// `step_once`), scaled to level 0's steps as
    /// [`Simulation::stable_dt`] scales each level's: `None` when they do not
    /// give it. Level `l`'s particles that came from level `l + 1` in the
    /// step's synchronisations count in level `l + 1`'s figure; the two are
    /// the same number when `h_l = 2 h_(l+1)` exactly (a division correctly
    /// rounded, times a power of two), which is checked. Axisymmetric runs
    /// on several levels take the pass: the kernel's wave speed there uses
    /// the volume ratio with the hoop stretch, the pass (and the copies'
    /// figure) the in-plane one. Every rank gets `Some` or every rank
    /// `None`: the inputs are the same everywhere (the layout, and the
    /// synchronisations, which agree on their outcome).
    fn step_dt_cfl1(&self) -> Option<f64> {
        let n = self.levels.len();
        if n > 1 && self.mode == ModeKind::Axisymmetric {
            return None;
        }
        let h0 = self.levels.first()?.h;
        let mut dt = f64::INFINITY;
        for lv in &self.levels {
            let scale = (1u64 << lv.l) as f64;
            if lv.h * scale != h0 {
                return None;
            }
            let copies = self.coupling.copies_dt_cfl1(lv.l, n)?;
            dt = dt.min(lv.step_dt_cfl1.min(copies) * scale);
        }
        Some(dt)
    }

    pub(super) fn prepare(&mut self) -> Result<f64> {
        if !self.balanced {
            for l in &mut self.levels {
                l.rebalance(&self.comm)?;
            }
            self.balanced = true;
        }
        if self.coupling.pending.len() != self.levels.len() {
            self.coupling.pending = vec![Vec::new(); self.levels.len()];
        }
        if !self.synced {
            self.coupling
                .set_transfer(self.run.transfer, self.run.xpic_order);
            self.coupling.set_materials(&self.mat_params());
            for l in 0..self.levels.len().saturating_sub(1) {
                self.coupling.sync(&mut self.levels, l, &self.comm)?;
            }
            self.synced = true;
            self.dt_cfl1 = None;
        }
        if self.mass_ref.is_none() {
            let mut m = [self
                .levels
                .iter()
                .flat_map(|l| l.particle_sets())
                .flat_map(|p| p.mass.iter().copied())
                .fold(0.0f64, f64::max)];
            self.comm.max_f64(&mut m)?;
            self.mass_ref = Some(m[0]);
        }
        Ok(self.mass_ref.unwrap_or(0.0))
    }

    /// One step of `dt` without the transaction (see [`Simulation::step`]):
    /// on an error the state is broken and must be rolled back; every rank
    /// returns an error together.
    pub(super) fn step_once(&mut self, dt: f64) -> Result<StepReport> {
        let mref = self.prepare()?;
        let mats = self.mat_params();
        let prm = StepParams {
            dt,
            shape: self.run.shape,
            scheme: self.run.scheme,
            flip: self.run.flip,
            transfer: self.run.transfer,
            xpic_order: self.run.xpic_order,
            load_factor: self.run.ramp.factor(self.time),
            gravity: self.run.gravity,
            mass_tol: MASS_TOL_REL * mref,
            boundary: Default::default(),
            mode: self.mode,
        };
        self.dt_cfl1 = None;
        let mut lost = Vec::new();
        let t0 = self.time;
        let ramp = self.run.ramp;
        self.contact.begin_step(dt);
        let mut run = Advance {
            comm: &self.comm,
            mats: &mats,
            base: &prm,
            ramp: &ramp,
            contact: &mut self.contact,
            thickness: self.thickness,
            lost: &mut lost,
        };
        let r = self.coupling.advance(&mut self.levels, &mut run, 0, t0);
        // The errors of the advance are agreed where they arise; this
        // reduction (which also counts the particles that left) makes sure.
        let mut left = [lost.len() as u64, r.is_err() as u64];
        self.comm.sum_u64(&mut left)?;
        r?;
        if left[1] > 0 {
            return Err(Error::elsewhere(
                Status::Unstable,
                "the step failed on another rank; see that rank's message",
            ));
        }
        self.time += dt;
        self.steps += 1;
        // The stable step of the new state comes from the step itself: the
        // last pass of each level's last step gives `min h/(c+|v|)` over
        // its owned particles, bit for bit what a separate pass would
        // compute for them, and the synchronisations that end the step give
        // it for the copies they make (see `Coupler::copies_dt_cfl1`). So
        // the stable step below needs no pass of its own, only the
        // reduction it would make anyway, unless particles left (they were
        // in the passes but are gone).
        self.dt_cfl1 = None;
        if left[0] == 0 {
            if let Some(dt) = self.step_dt_cfl1() {
                let mut v = [dt];
                self.comm.min_f64(&mut v)?;
                self.dt_cfl1 = Some(v[0]);
            }
        }
        if left[0] > 0 && self.run.outflow == Outflow::Fail {
            let first = lost
                .first()
                .map(|d| {
                    format!(
                        " (on rank {}: particle id {} at ({}, {}), and {} more)",
                        self.comm.rank(),
                        d.id,
                        d.x,
                        d.y,
                        lost.len() - 1
                    )
                })
                .unwrap_or_default();
            return Err(Error::new(
                Status::ParticlesLeft,
                format!(
                    "{} particle(s) would leave the domain during step {}{first}; under GIMLET_OUTFLOW_FAIL the step is undone and nothing changed (lower dt, or let them go with GIMLET_OUTFLOW_REMOVE)",
                    left[0], self.steps
                ),
            ));
        }
        self.lost.extend(lost);
        if left[0] > 0 {
            self.mass_ref = None;
            self.balanced = false;
        }
        let stable = self.stable_dt()?;
        if !(stable > 0.0 && self.time + stable > self.time) {
            return Err(Error::new(
                Status::Unstable,
                format!(
                    "the step of dt = {dt} leads to a state whose stable step {stable} cannot advance the time {}; the step is undone (lower dt)",
                    self.time
                ),
            ));
        }
        Ok(StepReport {
            steps: self.steps,
            time: self.time,
            dt,
            stable_dt: stable,
            left: left[0],
        })
    }

    /// Advances to time `t_end` with stable steps (the last one shortened
    /// to land on `t_end`), at most `max_steps` steps (collective).
    pub fn advance_to(&mut self, t_end: f64, max_steps: u64) -> Result<StepReport> {
        if !t_end.is_finite() || t_end < self.time {
            return Err(Error::arg(format!(
                "t_end = {t_end} must be finite and >= the current time {}",
                self.time
            )));
        }
        let mut rep = StepReport {
            steps: self.steps,
            time: self.time,
            dt: 0.0,
            stable_dt: self.stable_dt()?,
            left: 0,
        };
        let mut n = 0;
        let mut left = 0;
        while self.time < t_end {
            if n >= max_steps {
                return Err(Error::state(format!(
                    "max_steps = {max_steps} steps were taken before reaching t_end = {t_end} (time is {})",
                    self.time
                )));
            }
            let stable = self.stable_dt()?;
            let rest = t_end - self.time;
            // Equal steps that land on t_end, none above the stable step.
            let dt = rest / (rest / stable).ceil().max(1.0);
            if !(dt > 0.0 && self.time + dt > self.time) {
                // `step` would refuse this `dt` as an argument the caller
                // never passed: say what is wrong with the state instead.
                return Err(Error::new(
                    Status::Unstable,
                    format!(
                        "the stable step {stable} is too small to advance from time {} towards t_end = {t_end}",
                        self.time
                    ),
                ));
            }
            rep = self.step(dt)?;
            left += rep.left;
            if (self.time - t_end).abs() <= 1e-14 * t_end.abs().max(1.0) {
                self.land_last_step_on(t_end);
            }
            n += 1;
        }
        rep.left = left;
        rep.time = self.time;
        Ok(rep)
    }
}
