//! The simulation a C handle stands for: the communicator, the hierarchy
//! layout, materials, and each level's local particles with the patch
//! layout and patch owners. MPI enters only through `comm`.

use crate::comm::Comm;
use crate::error::{Error, Result, Status};
use crate::geom::{Hierarchy, IBox};
use crate::material::Material;
use crate::particles::{NewParticle, Particles};

/// One level's distributed state on this rank.
#[derive(Clone, Debug, Default)]
pub struct LevelState {
    /// Patches of the level (the same list on every rank).
    pub patches: Vec<IBox>,
    /// The rank that owns each patch.
    pub owner: Vec<i32>,
    /// Particles of this level owned by this rank.
    pub parts: Particles,
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
    pub levels: Vec<LevelState>,
    /// Next unused global particle id (the same on every rank).
    pub next_id: u64,
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

    /// Sets the plane-strain thickness (before particles exist).
    pub fn set_thickness(&mut self, t: f64) -> Result<()> {
        self.check_layout_open("gimlet_set_thickness")?;
        if !(t.is_finite() && t > 0.0) {
            return Err(Error::arg(format!(
                "thickness = {t} must be finite and > 0"
            )));
        }
        self.thickness = t;
        Ok(())
    }

    /// Adds a material and returns its index.
    pub fn add_material(&mut self, m: Material) -> Result<u32> {
        m.validate()?;
        if self.materials.len() >= 1 << 16 {
            return Err(Error::arg("the material table is full (65536 materials)"));
        }
        self.materials.push(m);
        Ok(self.materials.len() as u32 - 1)
    }

    /// Freezes the layout: computes patches and assigns them to ranks,
    /// balancing cells greedily (largest patch to the least-loaded rank,
    /// ties to the lowest rank), the same on every rank.
    pub fn freeze(&mut self) {
        if self.is_frozen() {
            return;
        }
        let nranks = self.comm.size().max(1) as usize;
        self.levels = (0..self.hier.num_levels())
            .map(|l| {
                let patches = self.hier.patches(l);
                let owner = balance(
                    &patches
                        .iter()
                        .map(|p| p.num_cells() as u64)
                        .collect::<Vec<_>>(),
                    nranks,
                );
                LevelState {
                    patches,
                    owner,
                    parts: Particles::new(),
                }
            })
            .collect();
    }

    /// The (level, patch) that owns a point: the finest level holding it and
    /// that level's patch holding its cell.
    pub fn locate(&self, x: f64, y: f64) -> (usize, usize) {
        let l = self.hier.level_of_point(x, y);
        let c = self.hier.cell_of(l, x, y);
        let k = self
            .hier
            .patch_of_cell(&self.levels[l].patches, c)
            .expect("the patches of a level tile its boxes");
        (l, k)
    }

    /// Collective insertion of caller arrays (each rank passes its own). All
    /// arrays are checked on every rank first; if any rank's input is bad,
    /// every rank fails and nothing is inserted. Global ids follow rank order,
    /// then array order.
    pub fn insert(&mut self, a: &ParticleArrays) -> Result<()> {
        let n = a.x.len();
        let local_err = self.check_arrays(a).err();
        let any_bad = self.comm.any(local_err.is_some())?;
        if let Some(e) = local_err {
            return Err(e);
        }
        if any_bad {
            return Err(Error::arg(
                "particles were rejected on another rank of the communicator; nothing was inserted",
            ));
        }
        let first = self.next_id + self.comm.exscan_u64(n as u64)?;
        let mut total = [n as u64];
        self.comm.sum_u64(&mut total)?;
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

    fn check_arrays(&self, a: &ParticleArrays) -> Result<()> {
        let n = a.x.len();
        let nm = self.materials.len();
        if nm == 0 && n > 0 {
            return Err(Error::state(
                "no material is defined: add a material before inserting particles",
            ));
        }
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
                if !(v.is_finite() && v > 0.0 && v <= 0.5 * h) {
                    return Err(Error::arg(format!(
                        "particle {i}: {name} = {v} must be > 0 and <= h/2 = {} of level {l} that holds it (finest h = {hmin})",
                        0.5 * h
                    )));
                }
            }
            for (name, v) in [("vx", a.vx[i]), ("vy", a.vy[i])] {
                if !v.is_finite() {
                    return Err(Error::arg(format!(
                        "particle {i}: {name} = {v} must be finite"
                    )));
                }
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
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::arg(format!(
                    "particle {i}: {name} = {v} must be finite and > 0"
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
        if rect.iter().any(|v| !v.is_finite()) || !(rect[2] > rect[0] && rect[3] > rect[1]) {
            return Err(Error::arg(format!(
                "rect = [{}, {}, {}, {}] must be finite with xhi > xlo and yhi > ylo",
                rect[0], rect[1], rect[2], rect[3]
            )));
        }
        if !(self.hier.contains_point(rect[0], rect[1])
            && self.hier.contains_point(rect[2], rect[3]))
        {
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
        for (name, v) in [("density", rho), ("vx", vx), ("vy", vy)] {
            if !v.is_finite() || (name == "density" && v <= 0.0) {
                return Err(Error::arg(format!(
                    "{name} = {v} must be finite{}",
                    if name == "density" { " and > 0" } else { "" }
                )));
            }
        }
        self.freeze();
        let rank = self.comm.rank();
        let nranks = self.comm.size();
        let t = self.thickness;
        let mut mine = Vec::new();
        let mut id = self.next_id;
        let nf = n as f64;
        for l in 0..self.hier.num_levels() {
            let h = self.hier.h(l);
            let lp = 0.5 * h / nf;
            let o = self.hier.origin;
            let bx = self.hier.domain_box(l);
            // Cells of level l overlapping the rectangle.
            let i0 = (((rect[0] - o[0]) / h).floor() as i64).max(0);
            let j0 = (((rect[1] - o[1]) / h).floor() as i64).max(0);
            let i1 = (((rect[2] - o[0]) / h).ceil() as i64).min(bx.hi[0]);
            let j1 = (((rect[3] - o[1]) / h).ceil() as i64).min(bx.hi[1]);
            for j in j0..j1 {
                for i in i0..i1 {
                    for b in 0..n {
                        for a in 0..n {
                            let x = o[0] + (i as f64 + (a as f64 + 0.5) / nf) * h;
                            let y = o[1] + (j as f64 + (b as f64 + 0.5) / nf) * h;
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
            let (l, _) = self.locate(p.x, p.y);
            self.levels[l].parts.push(p, t);
        }
        self.next_id = id;
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
        let t = self.thickness;
        for chunk in recv.chunks_exact(NEW_BYTES) {
            let p = decode(chunk);
            let (l, _) = self.locate(p.x, p.y);
            self.levels[l].parts.push(&p, t);
        }
        Ok(())
    }

    /// Local and global particle counts (collective).
    pub fn counts(&self) -> Result<(u64, u64)> {
        let local: u64 = self.levels.iter().map(|l| l.parts.len() as u64).sum();
        let mut g = [local];
        self.comm.sum_u64(&mut g)?;
        Ok((local, g[0]))
    }
}

/// Assigns items of the given weights to `nranks` ranks: largest first to
/// the least-loaded rank (ties to the lowest rank). Deterministic.
pub fn balance(weights: &[u64], nranks: usize) -> Vec<i32> {
    let mut order: Vec<usize> = (0..weights.len()).collect();
    order.sort_by(|&a, &b| weights[b].cmp(&weights[a]).then(a.cmp(&b)));
    let mut load = vec![0u64; nranks];
    let mut owner = vec![0i32; weights.len()];
    for k in order {
        let r = (0..nranks).min_by_key(|&r| (load[r], r)).unwrap_or(0);
        owner[k] = r as i32;
        load[r] += weights[k];
    }
    owner
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn balance_is_greedy_and_deterministic() {
        let o = balance(&[10, 1, 7, 3, 3], 2);
        let mut load = [0u64; 2];
        for (k, &r) in o.iter().enumerate() {
            load[r as usize] += [10, 1, 7, 3, 3][k];
        }
        assert!(load[0].abs_diff(load[1]) <= 1, "{load:?}");
        assert_eq!(o, balance(&[10, 1, 7, 3, 3], 2));
    }

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
