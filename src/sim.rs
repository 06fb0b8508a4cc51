//! The simulation a C handle stands for: the communicator, the hierarchy
//! layout, materials, and each level's local particles with the patch
//! layout and patch owners. MPI enters only through `comm`.

use crate::balance::balance;
use crate::comm::Comm;
use crate::coupling::Coupler;
use crate::error::{Error, Result, Status};
use crate::geom::{Hierarchy, IBox, RING};
use crate::kernel::{FaceBc, Ramp, Scheme, Side, StepParams, Transfer, MASS_TOL_REL};
use crate::level::{Departure, Level, LevelLayout};
use crate::limits;
use crate::material::{MatParams, Material};
use crate::particles::{LoadKind, NewParticle, Particles};
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

/// A simulation: hierarchy, materials and distributed particles.
#[derive(Debug)]
pub struct Simulation {
    /// Duplicate of the caller's communicator.
    pub comm: Comm,
    /// Layout of levels and patches.
    pub hier: Hierarchy,
    /// Plane-strain thickness (mass and forces are per this thickness).
    pub thickness: f64,
    /// Material table; particles refer to it by index.
    pub materials: Vec<Material>,
    /// Per-level state; empty until the layout is frozen.
    pub levels: Vec<Level>,
    /// Next unused global particle id (the same on every rank).
    pub next_id: u64,
    /// Time integration settings.
    pub run: RunConfig,
    /// Simulated time.
    pub time: f64,
    /// Steps taken.
    pub steps: u64,
    /// Particles (this rank's) that left the domain, in order of leaving.
    pub lost: Vec<Departure>,
    /// Global `min h/(c+|v|)` of the current state, when known.
    dt_cfl1: Option<f64>,
    /// Global largest particle mass, when known (empty-node threshold).
    mass_ref: Option<f64>,
    /// Whether patches have been balanced by particle count.
    balanced: bool,
    /// Whether the copies that couple levels are current.
    synced: bool,
    /// The coupling of levels (pending transfers, counters).
    pub coupling: Coupler,
    /// Rigid indenters and the contact state.
    pub contact: crate::contact::Contact,
    /// Output settings (HDF5/XDMF series and CSV series); not part of the
    /// simulated state, so a checkpoint read keeps them.
    pub output: crate::io::Outputs,
    /// The state a failed step returns to (see [`Simulation::step`]) when
    /// [`Snapshot::valid`]; an invalid one only lends its buffers to the
    /// next snapshot.
    txn: Option<Box<Snapshot>>,
}

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
struct Snapshot {
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

/// Bytes per particle in an insertion message.
const NEW_BYTES: usize = 9 * 8;

fn encode(p: &NewParticle, out: &mut Vec<u8>) {
    out.extend_from_slice(&p.id.to_le_bytes());
    for v in [p.x, p.y, p.lpx, p.lpy, p.vx, p.vy, p.mass] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(&(p.material as u64).to_le_bytes());
}

fn decode(b: &[u8]) -> NewParticle {
    let w = |k: usize| u64::from_le_bytes(b[8 * k..8 * k + 8].try_into().unwrap());
    let f = |k: usize| f64::from_bits(w(k));
    NewParticle {
        id: w(0),
        x: f(1),
        y: f(2),
        lpx: f(3),
        lpy: f(4),
        vx: f(5),
        vy: f(6),
        mass: f(7),
        material: w(8) as u32,
    }
}

/// Particle arrays as given by the caller for insertion (all of length n).
pub struct ParticleArrays<'a> {
    /// Positions.
    pub x: &'a [f64],
    /// Positions.
    pub y: &'a [f64],
    /// Half-lengths.
    pub lpx: &'a [f64],
    /// Half-lengths.
    pub lpy: &'a [f64],
    /// Velocities.
    pub vx: &'a [f64],
    /// Velocities.
    pub vy: &'a [f64],
    /// Masses, or `None` when `density` is given.
    pub mass: Option<&'a [f64]>,
    /// Densities, or `None` when `mass` is given.
    pub density: Option<&'a [f64]>,
    /// Material indices.
    pub material: &'a [i32],
}

impl Simulation {
    /// A one-level simulation over the domain, on a duplicate of `comm`.
    pub fn new(comm: Comm, x0: f64, y0: f64, lx: f64, ly: f64, h: f64) -> Result<Simulation> {
        let hier = Hierarchy::new(x0, y0, lx, ly, h)?;
        Ok(Simulation {
            comm,
            hier,
            thickness: 1.0,
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
            output: Default::default(),
            txn: None,
        })
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
                level.bc = self.run.bc;
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

    /// Collective insertion of caller arrays (each rank passes its own). All
    /// arrays are checked on every rank first; if any rank's input is bad,
    /// every rank fails and nothing is inserted. Global ids follow rank order,
    /// then array order.
    pub fn insert(&mut self, a: &ParticleArrays) -> Result<()> {
        let local_err = self.check_arrays(a).err();
        let any_bad = self.comm.any(local_err.is_some())?;
        if let Some(e) = local_err {
            return Err(e);
        }
        if any_bad {
            return Err(Error::elsewhere(
                Status::InvalidArgument,
                "particles were rejected on another rank of the communicator; nothing was inserted",
            ));
        }
        self.insert_checked(a)
    }

    /// The collective part of [`Simulation::insert`], for arrays that
    /// [`Simulation::check_arrays`] accepted on every rank (the C ABI agrees
    /// on that first).
    pub fn insert_checked(&mut self, a: &ParticleArrays) -> Result<()> {
        let n = a.x.len();
        let first = self.next_id + self.comm.exscan_u64(n as u64)?;
        let mut total = [n as u64];
        self.comm.sum_u64(&mut total)?;
        if total[0] > limits::MAX_NEW_PARTICLES {
            return Err(Error::arg(format!(
                "the ranks pass {} particles in all, more than the {} one insertion may add",
                total[0],
                limits::MAX_NEW_PARTICLES
            )));
        }
        let t = self.thickness;
        let parts = (0..n).map(|i| {
            let mass = match (a.mass, a.density) {
                (Some(m), _) => m[i],
                (None, Some(d)) => d[i] * 4.0 * a.lpx[i] * a.lpy[i] * t,
                (None, None) => unreachable!("checked"),
            };
            NewParticle {
                id: first + i as u64,
                x: a.x[i],
                y: a.y[i],
                lpx: a.lpx[i],
                lpy: a.lpy[i],
                vx: a.vx[i],
                vy: a.vy[i],
                mass,
                material: a.material[i] as u32,
            }
        });
        let parts: Vec<NewParticle> = parts.collect();
        self.route(&parts)?;
        self.next_id += total[0];
        Ok(())
    }

    /// Checks this rank's arrays for an insertion (local): positions in the
    /// domain, half-lengths, velocities, masses or densities and material
    /// indices within their bounds (see [`crate::limits`]), the layout
    /// freezable, and memory for the particles.
    pub fn check_arrays(&self, a: &ParticleArrays) -> Result<()> {
        let n = a.x.len();
        let nm = self.materials.len();
        if nm == 0 && n > 0 {
            return Err(Error::state(
                "no material is defined: add a material before inserting particles",
            ));
        }
        self.check_layout()?;
        limits::new_particles(n as f64, n as f64)?;
        let up = self.hier.upper();
        let lo = self.hier.origin;
        let hmin = self.hier.h(self.hier.num_levels() - 1);
        for i in 0..n {
            let (x, y) = (a.x[i], a.y[i]);
            if !(x.is_finite() && y.is_finite() && self.hier.contains_point(x, y)) {
                return Err(Error::arg(format!(
                    "particle {i}: position ({x}, {y}) is outside the domain [{}, {}] x [{}, {}]",
                    lo[0], up[0], lo[1], up[1]
                )));
            }
            let l = self.hier.level_of_point(x, y);
            let h = self.hier.h(l);
            for (name, v) in [("lpx", a.lpx[i]), ("lpy", a.lpy[i])] {
                if !(v.is_finite() && v >= limits::MAG_MIN && v <= 0.5 * h) {
                    return Err(Error::arg(format!(
                        "particle {i}: {name} = {v} must be >= {:e} and <= h/2 = {} of level {l} that holds it (finest h = {hmin})",
                        limits::MAG_MIN,
                        0.5 * h
                    )));
                }
            }
            for (name, v) in [("vx", a.vx[i]), ("vy", a.vy[i])] {
                limits::magnitude(name, v)
                    .map_err(|e| Error::arg(format!("particle {i}: {}", e.msg)))?;
            }
            let (name, v) = match (a.mass, a.density) {
                (Some(m), _) => ("mass", m[i]),
                (None, Some(d)) => ("density", d[i]),
                (None, None) => {
                    return Err(Error::new(
                        Status::NullPointer,
                        "mass and density are both NULL: pass exactly one of them",
                    ))
                }
            };
            // The density a mass implies must lie in the window too.
            let rho = if name == "mass" {
                v / (4.0 * a.lpx[i] * a.lpy[i] * self.thickness)
            } else {
                v
            };
            if !(v.is_finite() && v > 0.0) || limits::positive("density", rho).is_err() {
                return Err(Error::arg(format!(
                    "particle {i}: {name} = {} must be finite and > 0, with the density it gives ({}) between {:e} and {:e}",
                    limits::num(v),
                    limits::num(rho),
                    limits::MAG_MIN,
                    limits::MAG_MAX
                )));
            }
            let m = a.material[i];
            if m < 0 || m as usize >= nm {
                return Err(Error::arg(format!(
                    "particle {i}: material = {m} must be in [0, {nm}) (the materials defined so far)"
                )));
            }
        }
        Ok(())
    }

    /// Checks the arguments of [`Simulation::fill_rectangle`] (local): the
    /// rectangle inside the domain, `n` in 1..=8, the material, the density
    /// and velocity within their bounds (see [`crate::limits`]), the layout
    /// freezable, and memory for the particles it adds.
    #[allow(clippy::too_many_arguments)]
    pub fn check_fill(
        &self,
        rect: [f64; 4],
        n: i32,
        material: i32,
        rho: f64,
        vx: f64,
        vy: f64,
    ) -> Result<()> {
        if rect.iter().any(|v| !v.is_finite()) || !(rect[2] > rect[0] && rect[3] > rect[1]) {
            return Err(Error::arg(format!(
                "rect = [{}, {}, {}, {}] must be finite with xhi > xlo and yhi > ylo",
                rect[0], rect[1], rect[2], rect[3]
            )));
        }
        // The domain's upper corner is origin + n h, which may round below a
        // caller's origin + l: allow a relative slack of 1e-9 cells.
        let slack = 1e-9 * self.hier.h(0);
        let (lo, up) = (self.hier.origin, self.hier.upper());
        let inside = |x: f64, y: f64| {
            x >= lo[0] - slack && x <= up[0] + slack && y >= lo[1] - slack && y <= up[1] + slack
        };
        if !(inside(rect[0], rect[1]) && inside(rect[2], rect[3])) {
            let up = self.hier.upper();
            return Err(Error::arg(format!(
                "rect = [{}, {}, {}, {}] is not inside the domain [{}, {}, {}, {}]",
                rect[0],
                rect[1],
                rect[2],
                rect[3],
                self.hier.origin[0],
                self.hier.origin[1],
                up[0],
                up[1]
            )));
        }
        if !(1..=8).contains(&n) {
            return Err(Error::arg(format!(
                "n_per_cell = {n} must be between 1 and 8"
            )));
        }
        if material < 0 || material as usize >= self.materials.len() {
            return Err(Error::arg(format!(
                "material = {material} must be in [0, {}) (the materials defined so far)",
                self.materials.len()
            )));
        }
        limits::positive("density", rho)?;
        limits::magnitude("vx", vx)?;
        limits::magnitude("vy", vy)?;
        self.check_layout()?;
        // An upper bound of the particles added: every cell of every level's
        // boxes (its patches) overlapping the rectangle with the band's
        // (2n)^2 particles. (Not the level's whole domain: a deep hierarchy
        // would be refused for the memory its finest level would take over
        // the whole domain.)
        let mut bound = 0.0f64;
        for l in 0..self.hier.num_levels() {
            let h = self.hier.h(l);
            let o = self.hier.origin;
            // (The casts saturate; the intersection with a patch bounds it.)
            let cells = crate::geom::IBox::new(
                [
                    ((rect[0] - o[0]) / h).floor() as i64,
                    ((rect[1] - o[1]) / h).floor() as i64,
                ],
                [
                    ((rect[2] - o[0]) / h).ceil() as i64,
                    ((rect[3] - o[1]) / h).ceil() as i64,
                ],
            );
            for pb in self.hier.patches(l) {
                let c = pb.intersect(&cells);
                if !c.is_empty() {
                    bound += c.num_cells() as f64 * f64::from(4 * n * n);
                }
            }
        }
        limits::new_particles(bound, bound / f64::from(self.comm.size().max(1)))?;
        Ok(())
    }

    /// Collective fill of the rectangle with `n × n` particles per cell of the
    /// level that owns each cell, density `rho`, velocity `(vx, vy)`. Every
    /// rank passes the same arguments; ids follow the cell lattice (level,
    /// then row-major), so they do not depend on the number of ranks.
    #[allow(clippy::too_many_arguments)]
    pub fn fill_rectangle(
        &mut self,
        rect: [f64; 4],
        n: i32,
        material: i32,
        rho: f64,
        vx: f64,
        vy: f64,
    ) -> Result<u64> {
        self.check_fill(rect, n, material, rho, vx, vy)?;
        self.freeze();
        let rank = self.comm.rank();
        let nranks = self.comm.size();
        let t = self.thickness;
        let mut mine = Vec::new();
        let mut id = self.next_id;
        for l in 0..self.hier.num_levels() {
            let h = self.hier.h(l);
            let o = self.hier.origin;
            let bx = self.hier.domain_box(l);
            // Cells of level l overlapping the rectangle.
            let i0 = (((rect[0] - o[0]) / h).floor() as i64).max(0);
            let j0 = (((rect[1] - o[1]) / h).floor() as i64).max(0);
            let i1 = (((rect[2] - o[0]) / h).ceil() as i64).min(bx.hi[0]);
            let j1 = (((rect[3] - o[1]) / h).ceil() as i64).min(bx.hi[1]);
            // Cells of level l within the band around the next finer level
            // get particles of the finer level's size.
            let band: Vec<IBox> = if l + 1 < self.hier.num_levels() {
                self.hier.levels[l + 1]
                    .boxes
                    .iter()
                    .map(|b| b.coarsen().grow(self.hier.nest_buffer))
                    .collect()
            } else {
                Vec::new()
            };
            for j in j0..j1 {
                for i in i0..i1 {
                    let m = if band.iter().any(|b| b.contains_cell(i, j)) {
                        2 * n
                    } else {
                        n
                    };
                    let mf = m as f64;
                    let lp = 0.5 * h / mf;
                    for b in 0..m {
                        for a in 0..m {
                            let x = o[0] + (i as f64 + (a as f64 + 0.5) / mf) * h;
                            let y = o[1] + (j as f64 + (b as f64 + 0.5) / mf) * h;
                            if x < rect[0] || x > rect[2] || y < rect[1] || y > rect[3] {
                                continue;
                            }
                            if self.hier.level_of_point(x, y) != l {
                                continue;
                            }
                            let this = id;
                            id += 1;
                            let (pl, k) = self.locate(x, y);
                            let owner = self.levels[pl].owner[k];
                            if owner != rank && nranks > 1 {
                                continue;
                            }
                            mine.push(NewParticle {
                                id: this,
                                x,
                                y,
                                lpx: lp,
                                lpy: lp,
                                vx,
                                vy,
                                mass: rho * 4.0 * lp * lp * t,
                                material: material as u32,
                            });
                        }
                    }
                }
            }
        }
        let added = id - self.next_id;
        for p in &mine {
            self.store(p);
        }
        self.next_id = id;
        self.particles_changed();
        Ok(added)
    }

    /// Sends each particle to the rank owning its patch and stores it there.
    fn route(&mut self, parts: &[NewParticle]) -> Result<()> {
        self.freeze();
        let nr = self.comm.size() as usize;
        let mut send = vec![Vec::new(); nr];
        for p in parts {
            let (l, k) = self.locate(p.x, p.y);
            encode(p, &mut send[self.levels[l].owner[k] as usize]);
        }
        let (recv, _) = self.comm.alltoallv_bytes(&send)?;
        for chunk in recv.chunks_exact(NEW_BYTES) {
            self.store(&decode(chunk));
        }
        self.particles_changed();
        Ok(())
    }

    /// Stores a new particle in the local patch that owns its position.
    fn store(&mut self, p: &NewParticle) {
        let (l, k) = self.locate(p.x, p.y);
        let t = self.thickness;
        self.levels[l]
            .local_mut(k)
            .expect("a particle is stored on the rank owning its patch")
            .parts
            .push(p, t);
    }

    /// Replaces the whole simulated state by `other`'s (a simulation read
    /// from a checkpoint, built on a duplicate of this communicator), keeping
    /// this handle's communicator and output settings; caches are
    /// recomputed from the new state. Collective (the duplicate communicator
    /// `other` came with is freed).
    pub fn replace_state(&mut self, mut other: Simulation) {
        let synced = other.synced;
        std::mem::swap(&mut self.comm, &mut other.comm);
        std::mem::swap(&mut self.output, &mut other.output);
        std::mem::swap(self, &mut other);
        self.particles_changed();
        self.synced = synced;
    }

    /// Whether the copies that couple levels are current (they are after
    /// every step; insertion and `scatter` make them stale).
    pub fn copies_current(&self) -> bool {
        self.synced
    }

    /// Marks the copies that couple levels as current or stale (restart:
    /// a checkpoint stores them with the other particles).
    pub fn set_copies_current(&mut self, current: bool) {
        self.synced = current;
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

/// Number of components of each particle field (see [`Simulation::gather`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Field {
    /// x, y.
    Position,
    /// vx, vy.
    Velocity,
    /// Cauchy stress xx, yy, xy, zz.
    Stress,
    /// Green–Lagrange strain xx, yy, xy from F.
    Strain,
    /// Deformation gradient xx, xy, yx, yy.
    DefGrad,
    /// Current half-lengths lpx, lpy.
    HalfLength,
    /// Mass.
    Mass,
    /// Level of the particle (as a number).
    Level,
    /// Reference volume.
    Volume0,
    /// Reference (initial) position x0, y0.
    Reference,
    /// Contact pressure after the particle's level's last step (0 when the
    /// particle is not in contact with an indenter).
    ContactPressure,
    /// Equivalent plastic strain (0 for the elastic laws).
    PlasticStrain,
    /// The APIC affine velocity matrix C xx, xy, yx, yy.
    Affine,
}

impl Field {
    /// Components per particle.
    pub fn ncomp(self) -> usize {
        match self {
            Field::Position | Field::Velocity | Field::HalfLength | Field::Reference => 2,
            Field::Stress | Field::DefGrad | Field::Affine => 4,
            Field::Strain => 3,
            Field::Mass
            | Field::Level
            | Field::Volume0
            | Field::ContactPressure
            | Field::PlasticStrain => 1,
        }
    }
}

impl Simulation {
    /// Material parameters as the kernel uses them.
    pub fn mat_params(&self) -> Vec<MatParams> {
        self.materials.iter().map(|m| m.params()).collect()
    }

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
        for l in &mut self.levels {
            l.bc = run.bc;
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

    fn prepare(&mut self) -> Result<f64> {
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
        if !(dt.is_finite() && dt > 0.0) {
            return Err(Error::arg(format!("dt = {dt} must be finite and > 0")));
        }
        let stable = self.stable_dt()?;
        if dt > stable * (1.0 + 1e-12) {
            return Err(Error::new(
                Status::Unstable,
                format!(
                    "dt = {dt} must be <= the stable step {stable} (cfl = {} times min h/(c + |v|))",
                    self.run.cfl
                ),
            ));
        }
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

    /// One step of `dt` without the transaction (see [`Simulation::step`]):
    /// on an error the state is broken and must be rolled back; every rank
    /// returns an error together.
    fn step_once(&mut self, dt: f64) -> Result<StepReport> {
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
        };
        self.dt_cfl1 = None;
        let mut lost = Vec::new();
        let t0 = self.time;
        let ramp = self.run.ramp;
        self.contact.begin_step(dt);
        let r = self.coupling.advance(
            &mut self.levels,
            &self.comm,
            0,
            t0,
            &mats,
            &prm,
            &ramp,
            &mut lost,
            &mut self.contact,
            self.thickness,
        );
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
        // On one level, the stable step of the new state comes from the
        // step's last pass: its `min h/(c+|v|)` is bit for bit what a
        // separate pass over the particles would compute, as long as nothing
        // touched them after it (on several levels the synchronisation does:
        // copies are made afresh; particles that left were in the pass but
        // are gone), so the stable step below needs no pass of its own, only
        // the reduction it would make anyway.
        self.dt_cfl1 = None;
        if self.levels.len() == 1 && left[0] == 0 {
            let mut v = [self.levels[0].step_dt_cfl1];
            self.comm.min_f64(&mut v)?;
            self.dt_cfl1 = Some(v[0]);
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
                self.time = t_end;
                // The replay of a failed later step lands here too.
                if let Some(last) = self.txn.as_mut().and_then(|s| s.log.last_mut()) {
                    last.1 = t_end;
                }
            }
            n += 1;
        }
        rep.left = left;
        rep.time = self.time;
        Ok(rep)
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
                    Ok(h) => targets.push(h),
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
                let s = crate::diag::sums(&p.parts, &mats);
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
        Ok(acc)
    }

    /// Number of local particles (owned ones: copies that couple levels
    /// are not counted).
    pub fn num_local(&self) -> usize {
        self.local_sets()
            .map(|(_, p)| {
                p.copy
                    .iter()
                    .filter(|&&c| c == crate::particles::OWNED)
                    .count()
            })
            .sum()
    }

    /// Every local particle set with its level, in the order queries use
    /// (levels, then patches, then slots).
    pub fn local_sets(&self) -> impl Iterator<Item = (usize, &Particles)> {
        self.levels
            .iter()
            .flat_map(|l| l.particle_sets().map(move |p| (l.l, p)))
    }

    /// Sets `field` (velocity or stress only) of every local owned particle
    /// from `values` (`ncomp` per particle, the order of
    /// [`Simulation::gather`]). Copies are refreshed before the next step.
    pub fn scatter(&mut self, field: Field, values: &[f64]) -> Result<()> {
        self.check_scatter(field, values)?;
        self.scatter_checked(field, values);
        Ok(())
    }

    /// Checks the arguments of [`Simulation::scatter`] (local): a settable
    /// field, one value set per local particle, every value within the
    /// magnitude window of [`crate::limits`].
    pub fn check_scatter(&self, field: Field, values: &[f64]) -> Result<()> {
        if !matches!(field, Field::Velocity | Field::Stress | Field::Affine) {
            return Err(Error::arg(
                "field must be GIMLET_FIELD_VELOCITY, GIMLET_FIELD_STRESS or GIMLET_FIELD_AFFINE (the others follow from the motion)",
            ));
        }
        let nc = field.ncomp();
        let n = self.num_local();
        if values.len() != n * nc {
            return Err(Error::arg(format!(
                "n = {} values must equal the {n} local particles times {nc} components",
                values.len() / nc.max(1)
            )));
        }
        if let Some(k) = values
            .iter()
            .position(|v| !(v.is_finite() && v.abs() <= limits::MAG_MAX))
        {
            return Err(Error::arg(format!(
                "values[{k}] = {} must be finite with magnitude <= {:e}",
                values[k],
                limits::MAG_MAX
            )));
        }
        Ok(())
    }

    /// [`Simulation::scatter`] of checked values.
    pub fn scatter_checked(&mut self, field: Field, values: &[f64]) {
        let nc = field.ncomp();
        let mut k = 0;
        for l in &mut self.levels {
            for lp in &mut l.local {
                let p = &mut lp.parts;
                for i in 0..p.len() {
                    if p.copy[i] != crate::particles::OWNED {
                        continue;
                    }
                    let v = &values[k * nc..(k + 1) * nc];
                    match field {
                        Field::Velocity => {
                            p.vx[i] = v[0];
                            p.vy[i] = v[1];
                        }
                        Field::Affine => {
                            p.cxx[i] = v[0];
                            p.cxy[i] = v[1];
                            p.cyx[i] = v[2];
                            p.cyy[i] = v[3];
                        }
                        _ => {
                            p.sxx[i] = v[0];
                            p.syy[i] = v[1];
                            p.sxy[i] = v[2];
                            p.szz[i] = v[3];
                        }
                    }
                    k += 1;
                }
            }
        }
        self.dt_cfl1 = None;
        self.synced = false;
        self.invalidate_snapshot();
    }

    /// The values of `field` of every local particle, `ncomp` per particle,
    /// in the order of [`Simulation::local_sets`].
    pub fn gather(&self, field: Field, out: &mut Vec<f64>) {
        out.clear();
        if field == Field::ContactPressure {
            // Owned particles in contact, by (level, id); several indenters
            // on one particle add up.
            let mut by_id: std::collections::HashMap<(usize, u64), f64> = Default::default();
            for c in self.contact.points().filter(|c| c.owned) {
                *by_id.entry((c.level as usize, c.id)).or_insert(0.0) += c.pressure;
            }
            for (l, p) in self.local_sets() {
                for i in 0..p.len() {
                    if p.copy[i] == crate::particles::OWNED {
                        out.push(by_id.get(&(l, p.id[i])).copied().unwrap_or(0.0));
                    }
                }
            }
            return;
        }
        for (l, p) in self.local_sets() {
            for i in 0..p.len() {
                if p.copy[i] != crate::particles::OWNED {
                    continue;
                }
                match field {
                    Field::Position => out.extend_from_slice(&[p.x[i], p.y[i]]),
                    Field::Velocity => out.extend_from_slice(&[p.vx[i], p.vy[i]]),
                    Field::Stress => {
                        out.extend_from_slice(&[p.sxx[i], p.syy[i], p.sxy[i], p.szz[i]])
                    }
                    Field::Strain => {
                        let (a, b, c, d) = (p.fxx[i], p.fxy[i], p.fyx[i], p.fyy[i]);
                        // E = (F^T F - I)/2
                        out.extend_from_slice(&[
                            0.5 * (a * a + c * c - 1.0),
                            0.5 * (b * b + d * d - 1.0),
                            0.5 * (a * b + c * d),
                        ]);
                    }
                    Field::DefGrad => {
                        out.extend_from_slice(&[p.fxx[i], p.fxy[i], p.fyx[i], p.fyy[i]])
                    }
                    Field::HalfLength => out.extend_from_slice(&[p.lpx[i], p.lpy[i]]),
                    Field::Mass => out.push(p.mass[i]),
                    Field::Level => out.push(l as f64),
                    Field::Volume0 => out.push(p.vol0[i]),
                    Field::Reference => out.extend_from_slice(&[p.x0[i], p.y0[i]]),
                    Field::ContactPressure => unreachable!("handled above"),
                    Field::PlasticStrain => out.push(p.eps_p[i]),
                    Field::Affine => {
                        out.extend_from_slice(&[p.cxx[i], p.cxy[i], p.cyx[i], p.cyy[i]])
                    }
                }
            }
        }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn particle_message_round_trip() {
        let p = NewParticle {
            id: 7,
            x: 1.5,
            y: -2.0,
            lpx: 0.25,
            lpy: 0.125,
            vx: 3.0,
            vy: 4.0,
            mass: 9.0,
            material: 3,
        };
        let mut b = Vec::new();
        encode(&p, &mut b);
        assert_eq!(b.len(), NEW_BYTES);
        assert_eq!(decode(&b), p);
    }
}
