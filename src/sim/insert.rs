//! Particle insertion: caller arrays and filled rectangles, checked on
//! every rank, routed to the ranks that own their patches.

use super::Simulation;
use crate::error::{Error, Result, Status};
use crate::geom::IBox;
use crate::limits;
use crate::particles::NewParticle;
use crate::records::NewRecord;

/// A rectangle to fill with particles (see [`Simulation::fill_rectangle`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fill {
    /// The rectangle `[xlo, ylo, xhi, yhi]`.
    pub rect: [f64; 4],
    /// `n`: `n × n` particles per cell of the level that owns the cell
    /// (`2n × 2n` in the band around a finer level), in `1..=8`.
    pub n_per_cell: i32,
    /// Material index.
    pub material: i32,
    /// Density.
    pub density: f64,
    /// Initial velocity `(vx, vy)`.
    pub velocity: [f64; 2],
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
        let parts = (0..n).map(|i| {
            let t = self.out_of_plane(a.x[i]);
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
            if self.mode() == crate::mode::ModeKind::Axisymmetric && x - a.lpx[i] < 0.0 {
                return Err(Error::arg(format!(
                    "particle {i}: x - lpx = {} - {} must be >= 0 in axisymmetry (x is the radius: a particle's domain may touch the axis, not cross it)",
                    x, a.lpx[i]
                )));
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
                v / (4.0 * a.lpx[i] * a.lpy[i] * self.out_of_plane(x))
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

    /// Checks a fill for [`Simulation::fill_rectangle`] (local): the
    /// rectangle inside the domain, `n` in 1..=8, the material, the density
    /// and velocity within their bounds (see [`crate::limits`]), the layout
    /// freezable, and memory for the particles it adds.
    pub fn check_fill(&self, fill: &Fill) -> Result<()> {
        let Fill {
            rect,
            n_per_cell: n,
            material,
            density: rho,
            velocity: [vx, vy],
        } = *fill;
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
    /// level that owns each cell (see [`Fill`]). Every rank passes the same
    /// fill; ids follow the cell lattice (level, then row-major), so they do
    /// not depend on the number of ranks. Returns the number added.
    pub fn fill_rectangle(&mut self, fill: &Fill) -> Result<u64> {
        self.check_fill(fill)?;
        let Fill {
            rect,
            n_per_cell: n,
            material,
            density: rho,
            velocity: [vx, vy],
        } = *fill;
        self.freeze();
        let rank = self.comm.rank();
        let nranks = self.comm.size();
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
            // Only the cells inside level l's boxes can hold points of
            // level l (level 0's box is the domain); the boxes of a level
            // are disjoint, so walking each row's boxes from left to right
            // visits the same cells in the same (row-major) order as the
            // whole row would, in time proportional to the boxes' cells
            // rather than to the level's whole domain.
            let mut row: Vec<(i64, i64)> = Vec::new();
            for j in j0..j1 {
                row.clear();
                row.extend(
                    self.hier.levels[l]
                        .boxes
                        .iter()
                        .filter(|b| b.lo[1] <= j && j < b.hi[1])
                        .map(|b| (b.lo[0].max(i0), b.hi[0].min(i1)))
                        .filter(|r| r.0 < r.1),
                );
                row.sort_unstable();
                for i in row.iter().flat_map(|r| r.0..r.1) {
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
                                mass: rho * 4.0 * lp * lp * self.out_of_plane(x),
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
            NewRecord::write(&mut send[self.levels[l].owner[k] as usize], p);
        }
        let (recv, _) = self.comm.alltoallv_bytes(&send)?;
        for rec in recv.chunks_exact(NewRecord::BYTES) {
            self.store(&NewRecord::read(rec));
        }
        self.particles_changed();
        Ok(())
    }

    /// Stores a new particle in the local patch that owns its position.
    fn store(&mut self, p: &NewParticle) {
        let (l, k) = self.locate(p.x, p.y);
        let t = self.out_of_plane(p.x);
        self.levels[l]
            .local_mut(k)
            .expect("a particle is stored on the rank owning its patch")
            .parts
            .push(p, t);
    }
}
