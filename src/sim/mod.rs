//! The simulation a C handle stands for: the communicator, the hierarchy
//! layout, materials, and each level's local particles with the patch
//! layout and patch owners. MPI enters only through `comm`.

mod fields;
mod insert;
mod restore;
mod run;
mod transaction;

pub use fields::Field;
pub use insert::{Fill, ParticleArrays};
pub use restore::Restore;
pub use run::{Outflow, RunConfig, StepReport, DEFAULT_XPIC_ORDER};
pub use transaction::SNAPSHOT_EVERY;

use crate::balance::balance;
use crate::comm::Comm;
use crate::coupling::Coupler;
use crate::error::{Error, Result, Status};
use crate::geom::{Hierarchy, IBox, RING};
use crate::kernel::{FaceBc, Side};
use crate::level::{Departure, Level, LevelLayout};
use crate::limits;
use crate::material::{MatParams, Material};
use crate::mode::ModeKind;
use crate::particles::LoadKind;
use transaction::Snapshot;

/// A simulation: hierarchy, materials and distributed particles.
#[derive(Debug)]
pub struct Simulation {
    /// Duplicate of the caller's communicator.
    comm: Comm,
    /// Layout of levels and patches.
    hier: Hierarchy,
    /// Plane-strain thickness (mass and forces are per this thickness).
    thickness: f64,
    /// Plane strain or axisymmetry (chosen before the first insertion).
    mode: ModeKind,
    /// Material table; particles refer to it by index.
    materials: Vec<Material>,
    /// Per-level state; empty until the layout is frozen.
    levels: Vec<Level>,
    /// Next unused global particle id (the same on every rank).
    next_id: u64,
    /// Time integration settings.
    run: RunConfig,
    /// Simulated time.
    time: f64,
    /// Steps taken.
    steps: u64,
    /// Particles (this rank's) that left the domain, in order of leaving.
    lost: Vec<Departure>,
    /// Global `min h/(c+|v|)` of the current state, when known.
    dt_cfl1: Option<f64>,
    /// Global largest particle mass, when known (empty-node threshold).
    mass_ref: Option<f64>,
    /// Whether patches have been balanced by particle count.
    balanced: bool,
    /// Whether the copies that couple levels are current.
    synced: bool,
    /// The coupling of levels (pending transfers, counters).
    coupling: Coupler,
    /// Rigid indenters and the contact state, which the C API configures
    /// directly (the `contact` module keeps its invariants; a step's
    /// snapshot covers its per-level state).
    pub contact: crate::contact::Contact,
    /// The state a failed step returns to (see [`Simulation::step`]) when
    /// [`Snapshot::valid`]; an invalid one only lends its buffers to the
    /// next snapshot.
    txn: Option<Box<Snapshot>>,
}

impl Simulation {
    /// A one-level simulation over the domain, on a duplicate of `comm`.
    pub fn new(comm: Comm, x0: f64, y0: f64, lx: f64, ly: f64, h: f64) -> Result<Simulation> {
        Ok(Simulation::on(comm, Hierarchy::new(x0, y0, lx, ly, h)?))
    }

    /// A simulation of layout `hier` on `comm`, with the default settings
    /// and nothing in it.
    fn on(comm: Comm, hier: Hierarchy) -> Simulation {
        Simulation {
            comm,
            hier,
            thickness: 1.0,
            mode: ModeKind::PlaneStrain,
            materials: Vec::new(),
            levels: Vec::new(),
            next_id: 0,
            run: RunConfig::default(),
            time: 0.0,
            steps: 0,
            lost: Vec::new(),
            dt_cfl1: None,
            mass_ref: None,
            balanced: false,
            synced: false,
            coupling: Coupler::default(),
            contact: Default::default(),
            txn: None,
        }
    }

    /// The simulation's communicator (a duplicate of the caller's).
    pub fn comm(&self) -> &Comm {
        &self.comm
    }

    /// The layout of levels and patches.
    pub fn hier(&self) -> &Hierarchy {
        &self.hier
    }

    /// Replaces the layout of levels and patches by `h` (checked by its
    /// own setters), before the first particle insertion.
    pub fn set_hierarchy(&mut self, h: Hierarchy) -> Result<()> {
        self.check_layout_open("the hierarchy")?;
        self.hier = h;
        Ok(())
    }

    /// The plane-strain thickness.
    pub fn thickness(&self) -> f64 {
        self.thickness
    }

    /// Plane strain or axisymmetry.
    pub fn mode(&self) -> ModeKind {
        self.mode
    }

    /// The out-of-plane measure of a particle or face at `x`: the
    /// thickness in plane strain, the radius `x` in axisymmetry (where
    /// every volume, mass and force is per radian).
    pub fn out_of_plane(&self, x: f64) -> f64 {
        match self.mode {
            ModeKind::PlaneStrain => self.thickness,
            ModeKind::Axisymmetric => x,
        }
    }

    /// The face conditions the levels apply: the run's, except that in
    /// axisymmetry a free left face on the axis (x0 = 0) is a roller, the
    /// axis condition `v_r = 0`.
    pub(crate) fn level_bc(&self, run: &RunConfig) -> [FaceBc; 4] {
        let mut bc = run.bc;
        if self.mode == ModeKind::Axisymmetric
            && self.hier.origin[0] == 0.0
            && bc[Side::Left as usize] == FaceBc::Free
        {
            bc[Side::Left as usize] = FaceBc::Roller;
        }
        bc
    }

    /// Checks a mode for [`Simulation::set_mode`] (local): before particles
    /// exist; axisymmetry needs the domain at x0 >= 0 (x is the radius) and
    /// the default thickness (the thickness has no meaning there).
    pub fn check_mode(&self, mode: ModeKind) -> Result<()> {
        self.check_layout_open("gimlet_set_geometry")?;
        if mode == ModeKind::Axisymmetric {
            let x0 = self.hier.origin[0];
            if !(x0 >= 0.0) {
                return Err(Error::arg(format!(
                    "geometry = GIMLET_AXISYMMETRIC needs the domain's left face at x0 >= 0 (x is the radius), but x0 = {x0}"
                )));
            }
            for ind in &self.contact.indenters {
                if !ind.lateral().0.is_empty() {
                    return Err(Error::state(
                        "geometry = GIMLET_AXISYMMETRIC: an indenter has a sideways motion (gimlet_set_indenter_lateral); an axisymmetric indenter cannot move sideways",
                    ));
                }
                let x = ind.tip(0.0)[0] - ind.lateral_offset(0.0);
                if x != 0.0 {
                    return Err(Error::state(format!(
                        "geometry = GIMLET_AXISYMMETRIC: an indenter has its tip at x = {x}; in axisymmetry every indenter's tip must lie on the axis x = 0"
                    )));
                }
            }
            if self.thickness != 1.0 {
                return Err(Error::state(format!(
                    "geometry = GIMLET_AXISYMMETRIC: a thickness ({}) was set; axisymmetric quantities are per radian and take no thickness",
                    self.thickness
                )));
            }
        }
        Ok(())
    }

    /// In axisymmetry an indenter is a body of revolution about the axis:
    /// its tip must lie on it (`x_tip = 0`) and it may not move sideways.
    /// Checks a tip `x_tip` and whether a sideways table is set (`lateral`)
    /// against the mode (local; plane strain accepts all).
    pub fn check_indenter_axis(&self, x_tip: f64, lateral: bool) -> Result<()> {
        if self.mode != ModeKind::Axisymmetric {
            return Ok(());
        }
        if x_tip != 0.0 {
            return Err(Error::arg(format!(
                "x_tip = {x_tip} must be 0 in axisymmetry: the indenter (a cone, sphere or cylindrical punch) is a body of revolution about the axis x = 0"
            )));
        }
        if lateral {
            return Err(Error::arg(
                "an axisymmetric indenter cannot move sideways: gimlet_set_indenter_lateral is for plane strain only",
            ));
        }
        Ok(())
    }

    /// The factor from per-radian forces and energies to the whole body's:
    /// 2π in axisymmetry, 1 in plane strain (whose figures stay per the
    /// thickness).
    pub fn whole_body(&self) -> f64 {
        match self.mode {
            ModeKind::PlaneStrain => 1.0,
            ModeKind::Axisymmetric => std::f64::consts::TAU,
        }
    }

    /// The force on indenter `k` as the C API reports it: per the thickness
    /// in plane strain; in axisymmetry the whole body's (2π per radian),
    /// whose radial components cancel (x = 0). The mean over the last
    /// coarse step, as [`Contact::force`](crate::contact::Contact::force).
    pub fn indenter_force(&self, k: usize) -> [f64; 2] {
        let f = self.contact.force(k);
        match self.mode {
            ModeKind::PlaneStrain => f,
            ModeKind::Axisymmetric => [0.0, self.whole_body() * f[1]],
        }
    }

    /// Sets plane strain or axisymmetry (before particles exist).
    pub fn set_mode(&mut self, mode: ModeKind) -> Result<()> {
        self.check_mode(mode)?;
        self.mode = mode;
        Ok(())
    }

    /// The material table.
    pub fn materials(&self) -> &[Material] {
        &self.materials
    }

    /// Each level's state on this rank (empty until the layout is frozen).
    pub fn levels(&self) -> &[Level] {
        &self.levels
    }

    /// The next unused global particle id (the same on every rank).
    pub fn next_id(&self) -> u64 {
        self.next_id
    }

    /// The run settings.
    pub fn run(&self) -> RunConfig {
        self.run
    }

    /// Simulated time.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Steps taken.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// This rank's particles that left the domain, in order of leaving.
    pub fn lost(&self) -> &[Departure] {
        &self.lost
    }

    /// The coupling of levels (pending transfers, counters).
    pub fn coupling(&self) -> &Coupler {
        &self.coupling
    }

    /// True once particles exist: the layout can no longer change.
    pub fn is_frozen(&self) -> bool {
        !self.levels.is_empty()
    }

    /// Fails when the layout is frozen, naming the call.
    pub fn check_layout_open(&self, what: &str) -> Result<()> {
        if self.is_frozen() {
            return Err(Error::state(format!(
                "{what} must be called before the first particle insertion; the hierarchy is frozen once particles exist"
            )));
        }
        Ok(())
    }

    /// Checks a plane-strain thickness for [`Simulation::set_thickness`]
    /// (local): before particles exist, in the magnitude window of
    /// [`crate::limits`].
    pub fn check_thickness(&self, t: f64) -> Result<()> {
        self.check_layout_open("gimlet_set_thickness")?;
        if self.mode == ModeKind::Axisymmetric {
            return Err(Error::state(
                "gimlet_set_thickness: the simulation is axisymmetric, where quantities are per radian and there is no thickness",
            ));
        }
        limits::positive("thickness", t)
    }

    /// Sets the plane-strain thickness (before particles exist).
    pub fn set_thickness(&mut self, t: f64) -> Result<()> {
        self.check_thickness(t)?;
        self.thickness = t;
        Ok(())
    }

    /// Checks a material for [`Simulation::add_material`] (local).
    pub fn check_material(&self, m: &Material) -> Result<()> {
        m.validate()?;
        if self.materials.len() >= 1 << 16 {
            return Err(Error::arg("the material table is full (65536 materials)"));
        }
        Ok(())
    }

    /// Adds a material and returns its index.
    pub fn add_material(&mut self, m: Material) -> Result<u32> {
        self.check_material(&m)?;
        self.invalidate_snapshot();
        self.materials.push(m);
        Ok(self.materials.len() as u32 - 1)
    }

    /// Checks that the layout can be frozen (local; nothing to check once it
    /// is): every level has at most [`limits::MAX_PATCHES_PER_LEVEL`]
    /// patches, and every patch's grid at most [`limits::MAX_PATCH_NODES`]
    /// nodes. The same on every rank (the layout is).
    pub fn check_layout(&self) -> Result<()> {
        if self.is_frozen() {
            return Ok(());
        }
        for l in 0..self.hier.num_levels() {
            let lv = &self.hier.levels[l];
            let boxes = self.hier.computational_boxes(l, RING);
            check_patches(l, &boxes, lv.patch_size)?;
        }
        Ok(())
    }

    /// Freezes the layout: computes patches and assigns them to ranks,
    /// balancing cells greedily (largest patch to the least-loaded rank,
    /// ties to the lowest rank), the same on every rank. Patches are
    /// re-balanced by particle count before the first step.
    pub fn freeze(&mut self) {
        if self.is_frozen() {
            return;
        }
        let nranks = self.comm.size().max(1) as usize;
        let rank = self.comm.rank();
        self.levels = (0..self.hier.num_levels())
            .map(|l| {
                let lv = &self.hier.levels[l];
                let boxes = self.hier.computational_boxes(l, RING);
                let w: Vec<u64> = boxes
                    .iter()
                    .flat_map(|b| b.tile(lv.patch_size))
                    .map(|p| p.num_cells() as u64)
                    .collect();
                let layout = LevelLayout {
                    l,
                    h: lv.h,
                    origin: self.hier.origin,
                    domain: self.hier.domain_box(l),
                    boxes,
                    owned: lv.boxes.clone(),
                    patch_size: lv.patch_size,
                };
                let mut level = Level::new(layout, balance(&w, nranks), rank);
                level.bc = self.level_bc(&self.run);
                level
            })
            .collect();
    }

    /// The (level, patch) that owns a point: the finest level holding it and
    /// that level's patch holding its cell.
    pub fn locate(&self, x: f64, y: f64) -> (usize, usize) {
        let l = self.hier.level_of_point(x, y);
        let c = self.hier.cell_of(l, x, y);
        let k = self.levels[l]
            .find_patch(c)
            .expect("the patches of a level tile its boxes");
        (l, k)
    }

    /// Whether the copies that couple levels are current (they are after
    /// every step; insertion and `scatter` make them stale).
    pub fn copies_current(&self) -> bool {
        self.synced
    }

    /// Forgets cached quantities that depend on the particle set.
    fn particles_changed(&mut self) {
        self.invalidate_snapshot();
        self.dt_cfl1 = None;
        self.mass_ref = None;
        self.balanced = false;
        self.synced = false;
    }

    /// Local and global particle counts (collective).
    pub fn counts(&self) -> Result<(u64, u64)> {
        let local = self.num_local() as u64;
        let mut g = [local];
        self.comm.sum_u64(&mut g)?;
        Ok((local, g[0]))
    }

    /// Material parameters as the kernel uses them.
    pub fn mat_params(&self) -> Vec<MatParams> {
        self.materials.iter().map(|m| m.params()).collect()
    }

    /// Applies a dead traction on particle faces (see
    /// [`crate::diag::apply_traction`]); returns the global count loaded
    /// (collective).
    pub fn apply_traction(
        &mut self,
        side: Side,
        at: f64,
        lo: f64,
        hi: f64,
        t: [f64; 2],
    ) -> Result<u64> {
        self.apply_traction_of(side, at, lo, hi, t, LoadKind::Dead)
    }

    /// Applies a traction of `kind` on particle faces (see
    /// [`crate::diag::apply_traction`] and [`LoadKind`]); returns the
    /// global count loaded (collective). A particle already loaded by a
    /// traction of the other kind is an error, and then nothing is loaded
    /// anywhere.
    pub fn apply_traction_of(
        &mut self,
        side: Side,
        at: f64,
        lo: f64,
        hi: f64,
        t: [f64; 2],
        kind: LoadKind,
    ) -> Result<u64> {
        crate::diag::check_traction(at, lo, hi, t)?;
        let axi = self.mode == ModeKind::Axisymmetric;
        if axi && kind != LoadKind::Dead {
            return Err(Error::arg(
                "follower tractions are not available in axisymmetry (their area change would need F_θθ): use gimlet_apply_traction",
            ));
        }
        self.freeze();
        self.invalidate_snapshot();
        let th = self.thickness;
        // Every patch is checked first, on every rank: a traction rejected
        // anywhere loads nothing anywhere.
        let mut targets = Vec::new();
        let mut local_err = None;
        for l in &self.levels {
            let tol = 1e-6 * l.h;
            for p in &l.local {
                match crate::diag::traction_targets(&p.parts, side, at, lo, hi, tol, kind) {
                    Ok(mut h) => {
                        if axi {
                            // Per radian: the overlap's ∫ r ds (a face in x
                            // sits at one radius; a face in y spans radii).
                            let q = &p.parts;
                            for (k, ov) in h.iter_mut() {
                                let r = match side {
                                    Side::Left => q.x[*k] - q.lpx[*k],
                                    Side::Right => q.x[*k] + q.lpx[*k],
                                    Side::Bottom | Side::Top => {
                                        let a = (q.x[*k] - q.lpx[*k]).max(lo);
                                        let b = (q.x[*k] + q.lpx[*k]).min(hi);
                                        0.5 * (a + b)
                                    }
                                };
                                *ov *= r;
                            }
                        }
                        targets.push(h)
                    }
                    Err(e) => {
                        local_err.get_or_insert(e);
                        targets.push(Vec::new());
                    }
                }
            }
        }
        let any_bad = self.comm.any(local_err.is_some())?;
        if let Some(e) = local_err {
            return Err(e);
        }
        if any_bad {
            return Err(Error::elsewhere(
                Status::InvalidArgument,
                "the traction was rejected on another rank (a particle there already carries a load on the opposite face, or one of the other kind); nothing was loaded",
            ));
        }
        let mut n = [0u64];
        let mut hits = targets.iter();
        for l in &mut self.levels {
            for p in &mut l.local {
                let h = hits.next().expect("one target list per local patch");
                crate::diag::load_faces(&mut p.parts, side, h, t, th, kind);
                n[0] += h.len() as u64;
            }
        }
        self.comm.sum_u64(&mut n)?;
        Ok(n[0])
    }

    /// Global kinetic energy, strain energy, momentum x, y and mass
    /// (collective). Summed per patch, then over patches in (level, patch)
    /// order, so the result does not depend on which rank owns which patch.
    pub fn diagnostics(&self) -> Result<[f64; 5]> {
        let mats = self.mat_params();
        let np: usize = self.levels.iter().map(|l| l.patches.len()).sum();
        let mut per = vec![0.0; 5 * np];
        let mut base = 0;
        for l in &self.levels {
            for p in &l.local {
                let s = match self.mode {
                    ModeKind::PlaneStrain => crate::diag::sums(&p.parts, &mats),
                    ModeKind::Axisymmetric => {
                        crate::diag::sums_in::<crate::mode::Axisymmetric>(&p.parts, &mats)
                    }
                };
                per[5 * (base + p.k)..5 * (base + p.k + 1)].copy_from_slice(&s);
            }
            base += l.patches.len();
        }
        // One rank contributes to each slot: the sum is exact.
        self.comm.sum_f64(&mut per)?;
        let mut acc = [0.0; 5];
        for c in per.chunks_exact(5) {
            for k in 0..5 {
                acc[k] += c[k];
            }
        }
        if self.mode == ModeKind::Axisymmetric {
            // The whole body: 2π per radian; the radial momenta cancel.
            let w = self.whole_body();
            acc = [w * acc[0], w * acc[1], 0.0, w * acc[3], w * acc[4]];
        }
        Ok(acc)
    }
}

/// Checks the patches that tiling `boxes` of level `l` by `size` makes
/// (without making them): their number and each one's grid size (see
/// [`crate::limits`]).
pub fn check_patches(l: usize, boxes: &[IBox], size: [i64; 2]) -> Result<()> {
    let mut count = 0u64;
    for b in boxes {
        let s = b.shape();
        let nt = [
            (s[0] + size[0] - 1) / size[0].max(1),
            (s[1] + size[1] - 1) / size[1].max(1),
        ];
        count = count.saturating_add((nt[0].max(0) as u64).saturating_mul(nt[1].max(0) as u64));
        // The largest tile of this box, with the grid's ghost nodes.
        let cells = [s[0].min(size[0]), s[1].min(size[1])];
        let g = 2 * crate::level::GHOST + 1;
        let nodes = ((cells[0] + g) as u64).saturating_mul((cells[1] + g) as u64);
        limits::patch_nodes(l, cells, nodes)?;
    }
    if count > limits::MAX_PATCHES_PER_LEVEL {
        return Err(Error::arg(format!(
            "level {l} would have {count} patches of {} x {} cells, more than the {} a level may have: choose a larger patch size",
            size[0],
            size[1],
            limits::MAX_PATCHES_PER_LEVEL
        )));
    }
    Ok(())
}
