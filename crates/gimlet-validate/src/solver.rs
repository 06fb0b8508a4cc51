//! The single-level solver: one level, one patch covering the whole domain.
//!
//! A thin configuration of the one step ([`kernel::step_patches`], the
//! step every level of a [`gimlet::sim::Simulation`] runs) on one patch
//! ([`kernel::OnePatch`]): it owns a [`Grid`] over the domain's cells plus
//! one ghost cell on every side, the particles, the material table and the
//! clock, and has no step code of its own. It serves the tests and scenes
//! that need a reference without MPI, and the kernel-only benchmark.
//!
//! **Particles leaving the domain.** A particle may drift up to half a cell
//! outside the domain (its weights still fit the ghost layer); beyond that the
//! step fails with `Status::ParticlesLeft`.
//!
//! **After a failed step** (`Unstable`, `ParticlesLeft`) the particle state is
//! that reached by the failed step (not rolled back) and the clock is not
//! advanced: the caller should stop or restart from a checkpoint.
//!
//! **Diagnostics.** Kinetic energy `Σ ½ m |v|²`; strain energy from each
//! particle's stress and deformation gradient (see
//! [`MatParams::strain_energy`]: the complementary energy `½ σ:C⁻¹:σ V` for
//! the linear law, the stored energy for Neo-Hookean); linear momentum and
//! total mass. Extensive quantities are per the plane-strain thickness `t`.

use gimlet::diag::FaceLine;
use gimlet::error::{Error, Result};
use gimlet::kernel::{
    self, BodyForce, DomainFace, Grid, OnePatch, PatchBoundary, PatchMut, PhaseTimes, Pipeline,
    Prepared, Side, SortScratch, StepParams, MASS_TOL_REL,
};
use gimlet::material::{MatParams, Material};
use gimlet::particles::{NewParticle, Particles};
use gimlet::sim::{Outflow, RunConfig, StepReport};
use gimlet::storage::FieldVec;

/// Ghost cells around the domain.
const GHOST: i64 = 1;

/// The domain of a single-patch solver: the patch covers it whole.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Domain {
    /// Domain origin (lower-left corner) `(x0, y0)`.
    pub origin: [f64; 2],
    /// Domain extents `(lx, ly)`; each must be an integer number of cells.
    pub extent: [f64; 2],
    /// Cell size.
    pub h: f64,
    /// Plane-strain thickness `t`.
    pub thickness: f64,
}

impl Domain {
    /// The domain `[x0, x0 + lx] × [y0, y0 + ly]` with cells of size `h`
    /// and thickness 1.
    pub fn new(origin: [f64; 2], extent: [f64; 2], h: f64) -> Domain {
        Domain {
            origin,
            extent,
            h,
            thickness: 1.0,
        }
    }

    /// Checks every field; returns the number of cells per axis.
    pub fn validate(&self) -> Result<[i64; 2]> {
        let fin = |v: f64| v.is_finite();
        if !(fin(self.origin[0]) && fin(self.origin[1])) {
            return Err(Error::arg("origin (x0, y0) must be finite"));
        }
        if !(fin(self.h) && self.h > 0.0) {
            return Err(Error::arg(format!("h = {} must be finite and > 0", self.h)));
        }
        let mut n = [0i64; 2];
        for (d, name) in [(0, "lx"), (1, "ly")] {
            let l = self.extent[d];
            if !(fin(l) && l > 0.0) {
                return Err(Error::arg(format!("{name} = {l} must be finite and > 0")));
            }
            let r = l / self.h;
            let k = r.round();
            if (r - k).abs() > 1e-9 * r || k < 1.0 {
                return Err(Error::arg(format!(
                    "{name} / h = {r} must be an integer (within 1e-9 relative)"
                )));
            }
            if k > (1u64 << 24) as f64 {
                return Err(Error::arg(format!(
                    "{name} / h = {k} must be <= 2^24 cells"
                )));
            }
            n[d] = k as i64;
        }
        if !(fin(self.thickness) && self.thickness > 0.0) {
            return Err(Error::arg(format!(
                "thickness t = {} must be finite and > 0",
                self.thickness
            )));
        }
        Ok(n)
    }
}

/// A rectangle to fill with particles (see [`Solver::fill_rect`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fill {
    /// The rectangle `[xlo, ylo, xhi, yhi]` (upper sides open).
    pub rect: [f64; 4],
    /// `n`: `n × n` particles per cell, in `1..=16`.
    pub n_per_cell: u32,
    /// Material index (its density gives the masses).
    pub material: u32,
    /// Initial velocity `(vx, vy)`.
    pub velocity: [f64; 2],
    /// The id of the first particle; the others follow.
    pub first_id: u64,
}

impl Fill {
    /// The rectangle `rect` filled with `n_per_cell × n_per_cell` particles
    /// per cell of `material`, at rest, ids from 0.
    pub fn new(rect: [f64; 4], n_per_cell: u32, material: u32) -> Fill {
        Fill {
            rect,
            n_per_cell,
            material,
            velocity: [0.0, 0.0],
            first_id: 0,
        }
    }
}

/// A single-level, single-patch GIMP solver (see the module notes).
#[derive(Clone, Debug)]
pub struct Solver {
    domain: Domain,
    run: RunConfig,
    ncells: [i64; 2],
    grid: Grid,
    parts: Particles,
    materials: Vec<Material>,
    params: Vec<MatParams>,
    boundary: PatchBoundary,
    time: f64,
    steps: u64,
    /// `min h/(c+|v|)` for the current state, when known.
    dt_cfl1: Option<f64>,
    /// Largest particle mass, when known (for the empty-node threshold).
    mass_ref: Option<f64>,
    body_x: FieldVec<f64>,
    body_y: FieldVec<f64>,
    body_on: bool,
    /// Phase times of the steps taken since timing was switched on.
    times: Option<PhaseTimes>,
    /// Sort the particles by stencil every this many steps.
    sort_interval: Option<u64>,
    sort_scratch: SortScratch,
    /// Merge passes (within a step and with the next step's first P2G).
    fuse: bool,
    /// What the grid's accumulators hold ahead of the next step.
    prepared: Option<Prepared>,
}

impl Solver {
    /// A solver over `domain` with the run settings `run` (checked by
    /// [`RunConfig::validate`]), no materials and no particles. Particles
    /// that leave the domain fail the step: `run.outflow` must be
    /// [`Outflow::Fail`].
    pub fn new(domain: Domain, run: RunConfig) -> Result<Solver> {
        let ncells = domain.validate()?;
        run.validate()?;
        if run.outflow != Outflow::Fail {
            return Err(Error::arg(
                "outflow must be Outflow::Fail: the single-patch solver fails a step whose particles leave the domain",
            ));
        }
        let grid = Grid::new(domain.origin, domain.h, [0, 0], ncells, GHOST)?;
        let mut boundary = PatchBoundary::default();
        let nodes = [0, ncells[0], 0, ncells[1]];
        for ((face, &node), &bc) in boundary.faces.iter_mut().zip(&nodes).zip(&run.bc) {
            *face = Some(DomainFace { node, bc });
        }
        Ok(Solver {
            domain,
            run,
            ncells,
            grid,
            parts: Particles::new(),
            materials: Vec::new(),
            params: Vec::new(),
            boundary,
            time: 0.0,
            steps: 0,
            dt_cfl1: None,
            mass_ref: None,
            body_x: FieldVec::new(),
            body_y: FieldVec::new(),
            body_on: false,
            times: None,
            sort_interval: None,
            sort_scratch: SortScratch::default(),
            fuse: true,
            prepared: None,
        })
    }

    /// The domain.
    pub fn domain(&self) -> &Domain {
        &self.domain
    }

    /// The run settings.
    pub fn run(&self) -> &RunConfig {
        &self.run
    }

    /// Cells per axis.
    pub fn num_cells(&self) -> [i64; 2] {
        self.ncells
    }

    /// The grid: nodal velocities of the last step; the accumulators (mass,
    /// momentum, force) hold the last step's P2G, or the next step's when
    /// passes are fused (see [`Solver::set_fused_passes`]).
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// The material table.
    pub fn materials(&self) -> &[Material] {
        &self.materials
    }

    /// Adds a material (validated) and returns its index.
    pub fn add_material(&mut self, m: Material) -> Result<u32> {
        m.validate()?;
        if self.materials.len() >= u32::MAX as usize {
            return Err(Error::arg("the material table is full"));
        }
        self.materials.push(m);
        self.params.push(m.params());
        Ok(self.materials.len() as u32 - 1)
    }

    /// The particles.
    pub fn particles(&self) -> &Particles {
        &self.parts
    }

    /// Mutable access to the particles. The caller keeps the invariants
    /// (material indices in the table, `0 < lp <= h/2`, positions in the
    /// domain); cached values (stable step, mass scale) are recomputed.
    pub fn particles_mut(&mut self) -> &mut Particles {
        self.dt_cfl1 = None;
        self.mass_ref = None;
        self.prepared = None;
        &mut self.parts
    }

    /// Current time.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Steps taken.
    pub fn step_count(&self) -> u64 {
        self.steps
    }

    fn check_particle(&self, p: &NewParticle) -> Result<()> {
        let c = &self.domain;
        let fin = [p.x, p.y, p.vx, p.vy, p.lpx, p.lpy, p.mass]
            .iter()
            .all(|v| v.is_finite());
        if !fin {
            return Err(Error::arg(format!(
                "particle id {}: position, velocity, half-lengths and mass must be finite",
                p.id
            )));
        }
        let (xhi, yhi) = (c.origin[0] + c.extent[0], c.origin[1] + c.extent[1]);
        if p.x < c.origin[0] || p.x > xhi || p.y < c.origin[1] || p.y > yhi {
            return Err(Error::arg(format!(
                "particle id {}: position ({}, {}) must lie in the domain [{}, {}] x [{}, {}]",
                p.id, p.x, p.y, c.origin[0], xhi, c.origin[1], yhi
            )));
        }
        let half = 0.5 * c.h * (1.0 + 1e-12);
        if !(p.lpx > 0.0 && p.lpx <= half && p.lpy > 0.0 && p.lpy <= half) {
            return Err(Error::arg(format!(
                "particle id {}: half-lengths ({}, {}) must lie in (0, h/2 = {}]",
                p.id,
                p.lpx,
                p.lpy,
                0.5 * c.h
            )));
        }
        if p.mass <= 0.0 {
            return Err(Error::arg(format!(
                "particle id {}: mass = {} must be > 0",
                p.id, p.mass
            )));
        }
        if p.material as usize >= self.materials.len() {
            return Err(Error::arg(format!(
                "particle id {}: material = {} must be < the number of materials ({})",
                p.id,
                p.material,
                self.materials.len()
            )));
        }
        Ok(())
    }

    /// Adds one particle in its reference state.
    pub fn add_particle(&mut self, p: &NewParticle) -> Result<()> {
        self.check_particle(p)?;
        self.parts.push(p, self.domain.thickness);
        self.dt_cfl1 = None;
        self.mass_ref = None;
        self.prepared = None;
        Ok(())
    }

    /// Fills the rectangle `[xlo, xhi) × [ylo, yhi)` of `fill` with `n × n`
    /// particles per cell: in every cell, the sub-cell centres that lie in
    /// the rectangle get a particle of half-length `h/(2n)` and mass
    /// `ρ (h/n)² t` of the fill's material, its velocity and the ids
    /// `first_id, first_id + 1, ...` (row by row). Returns the number of
    /// particles added.
    pub fn fill_rect(&mut self, fill: &Fill) -> Result<usize> {
        let Fill {
            rect: [xlo, ylo, xhi, yhi],
            n_per_cell,
            material,
            velocity: [vx, vy],
            first_id,
        } = *fill;
        let c = self.domain;
        if !(1..=16).contains(&n_per_cell) {
            return Err(Error::arg(format!(
                "n_per_cell = {n_per_cell} must lie in [1, 16]"
            )));
        }
        if !(xlo < xhi && ylo < yhi) {
            return Err(Error::arg(format!(
                "rectangle [{xlo}, {xhi}) x [{ylo}, {yhi}) must have xlo < xhi and ylo < yhi"
            )));
        }
        let Some(mat) = self.materials.get(material as usize) else {
            return Err(Error::arg(format!(
                "material = {material} must be < the number of materials ({})",
                self.materials.len()
            )));
        };
        let rho = mat.density();
        let n = n_per_cell as i64;
        let sub = c.h / n as f64;
        let lp = 0.5 * sub;
        let mass = rho * sub * sub * c.thickness;
        // sub-cell index range covering the rectangle, clipped to the domain
        let ntot = [self.ncells[0] * n, self.ncells[1] * n];
        let range = |lo: f64, hi: f64, o: f64, nt: i64| {
            let a = (((lo - o) / sub - 0.5).ceil() as i64).clamp(0, nt);
            let b = (((hi - o) / sub - 0.5).ceil() as i64).clamp(0, nt);
            (a, b)
        };
        let (ia, ib) = range(xlo, xhi, c.origin[0], ntot[0]);
        let (ja, jb) = range(ylo, yhi, c.origin[1], ntot[1]);
        let mut id = first_id;
        let start = self.parts.len();
        for j in ja..jb {
            let y = c.origin[1] + (j as f64 + 0.5) * sub;
            if !(y >= ylo && y < yhi) {
                continue;
            }
            for i in ia..ib {
                let x = c.origin[0] + (i as f64 + 0.5) * sub;
                if !(x >= xlo && x < xhi) {
                    continue;
                }
                let p = NewParticle {
                    id,
                    x,
                    y,
                    lpx: lp,
                    lpy: lp,
                    vx,
                    vy,
                    mass,
                    material,
                };
                if let Err(e) = self.add_particle(&p) {
                    self.parts.retain(|k| k < start);
                    return Err(e);
                }
                id += 1;
            }
        }
        Ok((id - first_id) as usize)
    }

    /// Puts a traction on the particles whose face on `side` lies on the
    /// line `at` (`x = at` for left/right, `y = at` for bottom/top, within
    /// 1e-6 h) and overlaps the segment `[lo, hi]` along the line: each gets
    /// `traction × overlap × t` added to the reference force of that face
    /// (scaled by the ramp at every step; see [`gimlet::diag::apply_traction`]).
    /// For a top face at `y = at` that is the paper's pressure loading with
    /// `traction = (0, -p)`. Returns the number of particles loaded.
    pub fn apply_traction(
        &mut self,
        side: Side,
        at: f64,
        lo: f64,
        hi: f64,
        traction: [f64; 2],
    ) -> Result<usize> {
        gimlet::diag::check_traction(at, lo, hi, traction)?;
        self.prepared = None;
        let (t, tol) = (self.domain.thickness, 1e-6 * self.domain.h);
        let line = FaceLine { side, at, lo, hi };
        gimlet::diag::apply_traction(&mut self.parts, &line, traction, t, tol)
    }

    /// Zeroes every particle's reference external force.
    pub fn clear_external_forces(&mut self) {
        self.prepared = None;
        self.parts.fext_x.fill(0.0);
        self.parts.fext_y.fill(0.0);
        self.parts.fside_x.fill(0.0);
        self.parts.fside_y.fill(0.0);
        self.parts.load_faces.fill(0.0);
    }

    /// Sets a body force per unit mass for every particle (in addition to
    /// gravity), one entry per particle slot, used by the following steps
    /// until replaced or cleared. Does not allocate once the buffers are large
    /// enough, so a caller may refresh it before every step (manufactured
    /// solutions).
    pub fn set_body_force_per_particle(&mut self, bx: &[f64], by: &[f64]) -> Result<()> {
        let n = self.parts.len();
        if bx.len() != n || by.len() != n {
            return Err(Error::arg(format!(
                "body force arrays have {} and {} entries, must have one per particle ({n})",
                bx.len(),
                by.len()
            )));
        }
        self.body_x.clear();
        self.body_x.extend_from_slice(bx);
        self.body_y.clear();
        self.body_y.extend_from_slice(by);
        self.body_on = true;
        self.prepared = None;
        Ok(())
    }

    /// Removes the per-particle body force.
    pub fn clear_body_force_per_particle(&mut self) {
        self.body_on = false;
        self.prepared = None;
    }

    fn refresh(&mut self) -> (f64, f64) {
        let dt1 = match self.dt_cfl1 {
            Some(v) => v,
            None => {
                let v = kernel::stable_dt_cfl1(&self.parts, &self.params, self.domain.h);
                self.dt_cfl1 = Some(v);
                v
            }
        };
        let mref = match self.mass_ref {
            Some(v) => v,
            None => {
                let v = self.parts.mass.iter().fold(0.0f64, |a, &b| a.max(b));
                self.mass_ref = Some(v);
                v
            }
        };
        (dt1, mref)
    }

    fn check_materials(&self) -> Result<()> {
        let nm = self.materials.len();
        if let Some(&m) = self.parts.material.iter().max() {
            if m as usize >= nm {
                return Err(Error::arg(format!(
                    "particle material index {m} must be < the number of materials ({nm})"
                )));
            }
        }
        Ok(())
    }

    /// The stable time step `cfl · min_p h / (c_p + |v_p|)` of the current
    /// state, `c_p` the plane-strain P-wave speed at the particle's current
    /// Jacobian (infinite without particles).
    pub fn stable_dt(&mut self) -> Result<f64> {
        if self.dt_cfl1.is_none() {
            self.check_materials()?;
        }
        Ok(self.run.cfl * self.refresh().0)
    }

    /// Advances one step of `dt`. Fails as [`Simulation::step`] does for a
    /// `dt` that is not positive or exceeds [`Solver::stable_dt`] (the same
    /// check, [`RunConfig::check_step_dt`]), with `Unstable` when the step
    /// produced non-finite or inverted particles, and `ParticlesLeft` when
    /// a particle left the domain (see the module notes).
    pub fn step(&mut self, dt: f64) -> Result<StepReport> {
        let run = self.run;
        run.check_step_dt(dt, || self.stable_dt())?;
        let (_, mref) = self.refresh();
        let prm = StepParams {
            dt,
            shape: run.shape,
            scheme: run.scheme,
            flip: run.flip,
            transfer: run.transfer,
            xpic_order: run.xpic_order,
            load_factor: run.ramp.factor(self.time),
            gravity: run.gravity,
            mass_tol: MASS_TOL_REL * mref,
            boundary: self.boundary,
            mode: gimlet::mode::ModeKind::PlaneStrain,
        };
        let due = |step: u64| self.sort_interval.is_some_and(|k| k > 0 && step % k == 0);
        let sort_now = due(self.steps);
        let next_sorts = due(self.steps + 1);
        if sort_now {
            let t0 = self.times.is_some().then(kernel::thread_cpu_seconds);
            let perm = kernel::sort_by_stencil(&self.grid, &mut self.parts, &mut self.sort_scratch);
            if !perm.is_empty() {
                self.prepared = None;
                if self.body_x.len() == perm.len() && self.body_y.len() == perm.len() {
                    let (bx, by) = (&self.body_x, &self.body_y);
                    let nbx: FieldVec<f64> = perm.iter().map(|&k| bx[k]).collect();
                    let nby: FieldVec<f64> = perm.iter().map(|&k| by[k]).collect();
                    self.body_x = nbx;
                    self.body_y = nby;
                }
            }
            if let (Some(t), Some(t0)) = (self.times.as_mut(), t0) {
                t.sort += kernel::thread_cpu_seconds() - t0;
            }
        }
        let body = if self.body_on {
            Some(BodyForce {
                bx: &self.body_x,
                by: &self.body_y,
            })
        } else {
            None
        };
        // The next step's first P2G rides on this step's last pass unless the
        // next step sorts first (its order would change) or a body force is
        // set (it may change before the next step).
        let pipe = Pipeline {
            next_load_factor: (self.fuse && !self.body_on && !next_sorts)
                .then(|| run.ramp.factor(self.time + dt)),
            fuse: self.fuse,
            skip_last: None,
        };
        let mut one = OnePatch {
            patch: PatchMut {
                grid: &mut self.grid,
                parts: &mut self.parts,
                body,
                prepared: &mut self.prepared,
            },
        };
        match kernel::one_patch_result(&mut one, &self.params, &prm, pipe, self.times.as_mut()) {
            Ok(st) => {
                self.time += dt;
                self.steps += 1;
                self.dt_cfl1 = Some(st.dt_cfl1);
                Ok(StepReport {
                    steps: self.steps,
                    time: self.time,
                    dt,
                    stable_dt: run.cfl * st.dt_cfl1,
                    left: 0,
                })
            }
            Err(e) => {
                self.dt_cfl1 = None;
                self.prepared = None;
                Err(e)
            }
        }
    }

    /// Sorts the particles by grid stencil (see [`kernel::sort_by_stencil`])
    /// before every `n`-th step (steps `0, n, 2n, ...`), or never (`None`
    /// or `Some(0)`, the default). Sorting makes the passes over the grid
    /// walk it in storage order, which speeds them up, but it **reorders
    /// the particle slots**: callers that keep slot indices across steps
    /// should match particles by id (or leave sorting off). A body force set
    /// per particle is reordered with the particles.
    pub fn set_sort_interval(&mut self, n: Option<u64>) {
        self.sort_interval = n;
    }

    /// Merges passes over the particles where the scheme allows (on by
    /// default): within a step (MUSL's velocity update and momentum re-map,
    /// USF's strain and force passes), and the last pass of a step with the
    /// next step's first P2G (when no per-particle body force is set and the
    /// next step does not sort). Results are bit for bit the same either
    /// way; the grid's accumulators then hold the next step's P2G between
    /// steps (see [`Solver::grid`]).
    pub fn set_fused_passes(&mut self, on: bool) {
        self.fuse = on;
        self.prepared = None;
    }

    /// Switches the per-phase timing (thread CPU time, see
    /// [`kernel::PhaseTimes`]) of the following steps on (reset to zero) or
    /// off. Timing costs a few clock reads per step.
    pub fn set_phase_timing(&mut self, on: bool) {
        self.times = on.then(PhaseTimes::default);
    }

    /// Phase times accumulated since timing was switched on (`None` when off).
    pub fn phase_times(&self) -> Option<PhaseTimes> {
        self.times
    }

    /// Kinetic energy `Σ ½ m |v|²`.
    pub fn kinetic_energy(&self) -> f64 {
        gimlet::diag::sums(&self.parts, &self.params)[0]
    }

    /// Elastic strain energy (see the module notes).
    pub fn strain_energy(&self) -> f64 {
        gimlet::diag::sums(&self.parts, &self.params)[1]
    }

    /// Linear momentum `Σ m v`.
    pub fn linear_momentum(&self) -> [f64; 2] {
        let s = gimlet::diag::sums(&self.parts, &self.params);
        [s[2], s[3]]
    }

    /// Total mass `Σ m`.
    pub fn total_mass(&self) -> f64 {
        gimlet::diag::sums(&self.parts, &self.params)[4]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gimlet::error::Status;
    use gimlet::kernel::{FaceBc, Ramp, Scheme, Transfer};
    use gimlet::shape::ShapeKind;

    const MAT: Material = Material::LinearElastic {
        e: 1.0e6,
        nu: 0.3,
        rho: 1000.0,
    };

    /// The run settings these tests were written for: uGIMP, MUSL, FLIP.
    fn ugimp_flip() -> RunConfig {
        RunConfig {
            shape: ShapeKind::UGimp,
            transfer: Transfer::Flip,
            ..RunConfig::default()
        }
    }

    fn unit_solver(n: i64) -> Solver {
        let dom = Domain::new([0.0, 0.0], [1.0, 1.0], 1.0 / n as f64);
        let mut s = Solver::new(dom, ugimp_flip()).unwrap();
        s.add_material(MAT).unwrap();
        s
    }

    /// A falling two-material block that hits the fixed floor, with a
    /// ramped traction on its top: every part of the step is exercised
    /// (mixed laws, loads, boundary conditions, large motion).
    fn impact_scene(shape: ShapeKind, scheme: Scheme) -> (Solver, f64) {
        let mut c = ugimp_flip();
        c.shape = shape;
        c.scheme = scheme;
        c.gravity = [0.0, -9.8];
        c.bc = [FaceBc::Fixed, FaceBc::Roller, FaceBc::Fixed, FaceBc::Free];
        c.ramp = Ramp { t_ramp: 0.02 };
        let dom = Domain::new([0.0, 0.0], [1.0, 1.0], 1.0 / 16.0);
        let mut s = Solver::new(dom, c).unwrap();
        let nh = Material::NeoHookean {
            e: 1.0e4,
            nu: 0.3,
            rho: 1.0,
        };
        let lin = Material::LinearElastic {
            e: 2.0e4,
            nu: 0.25,
            rho: 2.0,
        };
        let a = s.add_material(nh).unwrap();
        let b = s.add_material(lin).unwrap();
        // faces on the sub-cell lattice (h/2 = 0.03125)
        s.fill_rect(&Fill {
            velocity: [0.3, -10.0],
            ..Fill::new([0.25, 0.09375, 0.75, 0.3125], 2, a)
        })
        .unwrap();
        s.fill_rect(&Fill {
            velocity: [0.3, -10.0],
            first_id: 1000,
            ..Fill::new([0.25, 0.3125, 0.75, 0.4375], 2, b)
        })
        .unwrap();
        let n = s
            .apply_traction(Side::Top, 0.4375, 0.4, 0.6, [5.0, -50.0])
            .unwrap();
        assert_eq!(n, 8); // 6 covered fully, 2 in part
        let dt = 0.3 * (1.0 / 16.0) / (lin.p_wave_speed(1.0) + 5.0);
        (s, dt)
    }

    fn bits(p: &Particles) -> Vec<(u64, Vec<u64>)> {
        let mut v: Vec<(u64, Vec<u64>)> = (0..p.len())
            .map(|i| {
                (
                    p.id[i],
                    p.f64_fields().iter().map(|f| f[i].to_bits()).collect(),
                )
            })
            .collect();
        v.sort_by_key(|e| e.0);
        v
    }

    fn run_scene(
        shape: ShapeKind,
        scheme: Scheme,
        fuse: bool,
        sort: Option<u64>,
        steps: usize,
    ) -> Solver {
        let (mut s, dt) = impact_scene(shape, scheme);
        s.set_fused_passes(fuse);
        s.set_sort_interval(sort);
        for _ in 0..steps {
            s.step(dt).unwrap();
        }
        s
    }

    #[test]
    fn fused_passes_give_the_same_bits() {
        for shape in [ShapeKind::Mpm, ShapeKind::UGimp, ShapeKind::CpGimp] {
            for scheme in [Scheme::Usf, Scheme::Usl, Scheme::Musl] {
                for sort in [None, Some(7)] {
                    let a = run_scene(shape, scheme, false, sort, 40);
                    let b = run_scene(shape, scheme, true, sort, 40);
                    // the block has hit the floor and deformed
                    let p = b.particles();
                    let jmin = (0..p.len())
                        .map(|i| p.fxx[i] * p.fyy[i] - p.fxy[i] * p.fyx[i])
                        .fold(f64::INFINITY, f64::min);
                    assert!(jmin < 0.99, "{shape:?} {scheme:?}: J min {jmin}");
                    assert!(
                        bits(a.particles()) == bits(b.particles()),
                        "{shape:?} {scheme:?} sort {sort:?}: fused passes changed the result"
                    );
                    assert_eq!(a.time().to_bits(), b.time().to_bits());
                }
            }
        }
    }

    #[test]
    fn sorting_reorders_by_stencil_and_keeps_the_motion() {
        let plain = run_scene(ShapeKind::UGimp, Scheme::Musl, true, None, 40);
        let sorted = run_scene(ShapeKind::UGimp, Scheme::Musl, true, Some(5), 40);
        // Order: stencil key non-decreasing, ids increasing within a key.
        let mut keys = Vec::new();
        gimlet::kernel::stencil_order(sorted.grid(), sorted.particles(), &mut keys);
        let ids = &sorted.particles().id;
        let moved = (1..keys.len())
            .filter(|&i| ids[i] != ids[i - 1] + 1)
            .count();
        assert!(moved > 0, "sorting changed nothing");
        // sorted at step 35, then 5 steps of motion: nearly in order
        let out = (1..keys.len())
            .filter(|&i| (keys[i], ids[i]) < (keys[i - 1], ids[i - 1]))
            .count();
        assert!(
            out * 20 < keys.len(),
            "{out} of {} out of order",
            keys.len()
        );
        // Same motion up to the round-off of the reordered sums.
        let (a, b) = (bits(plain.particles()), bits(sorted.particles()));
        assert_eq!(a.len(), b.len());
        let scale = 10.0; // |v| of the block
        for (pa, pb) in a.iter().zip(&b) {
            assert_eq!(pa.0, pb.0);
            for f in [0usize, 1, 4, 5] {
                // x, y, vx, vy
                let (u, v) = (f64::from_bits(pa.1[f]), f64::from_bits(pb.1[f]));
                assert!(
                    (u - v).abs() < 1e-9 * scale,
                    "id {} field {f}: {u} vs {v}",
                    pa.0
                );
            }
        }
    }

    #[test]
    fn domain_and_run_settings_are_validated() {
        let mut d = Domain::new([0.0, 0.0], [1.0, 0.6], 0.1);
        assert_eq!(d.validate().unwrap(), [10, 6]);
        d.extent[1] = 0.57;
        let e = Solver::new(d, ugimp_flip()).unwrap_err();
        assert!(e.msg.contains("ly / h"), "{}", e.msg);
        d.extent[1] = 0.6;
        let mut run = ugimp_flip();
        run.cfl = 1.5;
        assert!(Solver::new(d, run).unwrap_err().msg.contains("cfl = 1.5"));
        run.cfl = 0.5;
        run.outflow = Outflow::Remove;
        assert!(Solver::new(d, run).unwrap_err().msg.contains("outflow"));
        d.h = -1.0;
        assert!(Solver::new(d, ugimp_flip())
            .unwrap_err()
            .msg
            .contains("h = -1"));
    }

    #[test]
    fn fill_rect_places_particles_with_the_right_mass() {
        let mut s = unit_solver(10);
        let n = s
            .fill_rect(&Fill {
                first_id: 100,
                ..Fill::new([0.2, 0.0, 0.6, 0.3], 2, 0)
            })
            .unwrap();
        assert_eq!(n, 8 * 6);
        assert_eq!(s.particles().id[0], 100);
        let m = s.total_mass();
        assert!((m - 1000.0 * 0.4 * 0.3).abs() < 1e-9);
        assert!(s.particles().lpx.iter().all(|&l| (l - 0.025).abs() < 1e-15));
        // bad material or counts are rejected, and nothing is added
        assert!(s.fill_rect(&Fill::new([0.0, 0.0, 1.0, 1.0], 2, 3)).is_err());
        assert!(s.fill_rect(&Fill::new([0.0, 0.0, 1.0, 1.0], 0, 0)).is_err());
        assert_eq!(s.particles().len(), 48);
    }

    #[test]
    fn traction_total_force_is_traction_times_length() {
        let mut s = unit_solver(10);
        s.fill_rect(&Fill::new([0.0, 0.0, 1.0, 0.5], 2, 0)).unwrap();
        // pressure 1e3 on [0.34, 0.66] of the top surface y = 0.5: six top
        // particles fully covered, two partly (0.01 each)
        let k = s
            .apply_traction(Side::Top, 0.5, 0.34, 0.66, [0.0, -1e3])
            .unwrap();
        assert_eq!(k, 8);
        let fy: f64 = s.particles().fext_y.iter().sum();
        assert!((fy + 1e3 * 0.32).abs() < 1e-9, "{fy}");
        // no particle below the surface was loaded
        let p = s.particles();
        assert!((0..p.len()).all(|i| p.fext_y[i] == 0.0 || (p.y[i] - 0.475).abs() < 1e-12));
    }

    #[test]
    fn free_fall_under_gravity_is_exact() {
        let mut c = ugimp_flip();
        c.gravity = [0.0, -10.0];
        for scheme in [Scheme::Usf, Scheme::Usl, Scheme::Musl] {
            c.scheme = scheme;
            let dom = Domain::new([0.0, 0.0], [1.0, 2.0], 0.1);
            let mut s = Solver::new(dom, c).unwrap();
            s.add_material(MAT).unwrap();
            s.fill_rect(&Fill::new([0.3, 1.4, 0.7, 1.8], 2, 0)).unwrap();
            let y0 = s.particles().y.clone();
            let dt = 1e-3;
            let n = 100;
            for _ in 0..n {
                s.step(dt).unwrap();
            }
            let nf = n as f64;
            for (p, &yp0) in y0.iter().enumerate() {
                // symplectic Euler: v_n = g n dt, y_n = y0 + g dt² n(n+1)/2
                let y = yp0 - 10.0 * dt * dt * nf * (nf + 1.0) / 2.0;
                assert!((s.particles().y[p] - y).abs() < 1e-12, "{scheme:?}");
                assert!((s.particles().vy[p] + 10.0 * dt * nf).abs() < 1e-12);
                assert!(s.particles().syy[p].abs() < 1e-6);
            }
            assert!((s.time() - 0.1).abs() < 1e-12 && s.step_count() == 100);
            let mom = s.linear_momentum();
            assert!((mom[1] + s.total_mass() * 10.0 * 0.1).abs() < 1e-9);
        }
    }

    #[test]
    fn time_step_above_the_bound_is_rejected() {
        let mut s = unit_solver(10);
        s.fill_rect(&Fill::new([0.0, 0.0, 1.0, 1.0], 2, 0)).unwrap();
        let dts = s.stable_dt().unwrap();
        let c = MAT.p_wave_speed(1.0);
        assert!((dts - 0.5 * 0.1 / c).abs() < 1e-15);
        let e = s.step(1.01 * dts).unwrap_err();
        assert_eq!(e.status, Status::Unstable);
        assert!(e.msg.contains("dt = "), "{}", e.msg);
        assert_eq!(s.step(-1.0).unwrap_err().status, Status::InvalidArgument);
        let r = s.step(dts).unwrap();
        assert_eq!(r.steps, 1);
        assert!((r.stable_dt - dts).abs() < 1e-12 * dts);
    }

    #[test]
    fn particles_leaving_the_domain_are_reported() {
        let mut s = unit_solver(10);
        s.fill_rect(&Fill {
            velocity: [-50.0, 0.0],
            ..Fill::new([0.0, 0.0, 0.2, 0.2], 2, 0)
        })
        .unwrap();
        let dt = 0.9 * s.stable_dt().unwrap();
        let mut status = Status::Ok;
        for _ in 0..100 {
            if let Err(e) = s.step(dt) {
                status = e.status;
                break;
            }
        }
        assert_eq!(status, Status::ParticlesLeft);
    }

    #[test]
    fn bad_particles_are_rejected() {
        let mut s = unit_solver(10);
        let mut p = NewParticle {
            id: 7,
            x: 0.5,
            y: 0.5,
            lpx: 0.06,
            lpy: 0.025,
            vx: 0.0,
            vy: 0.0,
            mass: 1.0,
            material: 0,
        };
        assert!(s.add_particle(&p).unwrap_err().msg.contains("h/2"));
        p.lpx = 0.025;
        p.x = 1.5;
        assert!(s.add_particle(&p).unwrap_err().msg.contains("domain"));
        p.x = 0.5;
        p.material = 2;
        assert!(s.add_particle(&p).unwrap_err().msg.contains("material = 2"));
        p.material = 0;
        s.add_particle(&p).unwrap();
        assert_eq!(s.particles().len(), 1);
    }
}
