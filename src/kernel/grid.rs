//! Nodal data of one patch: structure-of-arrays over an integer node box that
//! includes the patch's ghost nodes.

use crate::error::{Error, Result};
use crate::storage::FieldVec;

/// Four values of one node stored together (32-byte aligned), so that the
/// particle loops read or update them with one vector load or store.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(32))]
pub struct Node4(pub [f64; 4]);

/// Lanes of [`Grid::mom_force`].
pub mod mf {
    /// Momentum x.
    pub const PX: usize = 0;
    /// Momentum y.
    pub const PY: usize = 1;
    /// Force x.
    pub const FX: usize = 2;
    /// Force y.
    pub const FY: usize = 3;
}

/// Lanes of [`Grid::vel`].
pub mod vl {
    /// Velocity x after the force update.
    pub const VX: usize = 0;
    /// Velocity y after the force update.
    pub const VY: usize = 1;
    /// Velocity x before the force update.
    pub const V0X: usize = 2;
    /// Velocity y before the force update.
    pub const V0Y: usize = 3;
}

/// Nodal arrays of one patch at one level.
///
/// Node `(i, j)` (integer indices of the level, node `(0, 0)` at `origin`)
/// sits at `origin + (i h, j h)`. The grid stores nodes `lo[0] ..= lo[0] +
/// n[0] - 1` by `lo[1] ..= lo[1] + n[1] - 1`, row-major in x:
/// `k = (j - lo[1]) * n[0] + (i - lo[0])`.
///
/// Arrays (one entry per node):
/// * `mass`, and `mom_force` = `[px, py, fx, fy]` (lanes [`mf`]): mass,
///   momentum and total force accumulated by P2G; zeroed by
///   [`Grid::reset`];
/// * `vel` = `[vx, vy, v0x, v0y]` (lanes [`vl`]): `v0` is the velocity
///   `p/m` before the force update (and, for MUSL, the velocity of the
///   re-mapped momentum used for the velocity gradient), `v` the velocity
///   after it, `(p + f dt)/m`.
///
/// A node's momentum and force, and its velocities, are stored together:
/// the particle loops read and update them with one vector operation per
/// node. [`Grid::acc`] and [`Grid::set_acc`] address the accumulators by
/// number for the exchanges. Each array is a [`FieldVec`], at a cache-line
/// offset of its own (see [`crate::storage`]).
///
/// `Clone` is written out so that `clone_from` copies the nodal arrays into
/// the ones `self` already has ([`FieldVec::clone_from`]: no allocation
/// once they are big enough), as the snapshot of a step does.
#[derive(Debug, PartialEq)]
pub struct Grid {
    /// Position of node `(0, 0)` of the level (the domain origin).
    pub origin: [f64; 2],
    /// Cell size.
    pub h: f64,
    /// First stored node index in x and y.
    pub lo: [i64; 2],
    /// Number of stored nodes in x and y.
    pub n: [usize; 2],
    /// Ghost cells on every side: the grid's own cells (the patch's) are
    /// `lo + ghost .. lo + n - 1 - ghost` per axis.
    pub ghost: i64,
    /// Nodal mass.
    pub mass: FieldVec<f64>,
    /// Nodal momentum and force, `[px, py, fx, fy]` (lanes [`mf`]).
    pub mom_force: FieldVec<Node4>,
    /// Nodal velocities, `[vx, vy, v0x, v0y]` (lanes [`vl`]).
    pub vel: FieldVec<Node4>,
    /// Nodal average of the dilatation of the plastic (isochoric-flow)
    /// particles, `[Σ_p S_ip V_p div_p, Σ_p S_ip V_p]` as scattered, then
    /// `[average, Σ_p S_ip V_p]` once normalised (see
    /// [`super::nodal_dilatation`]). Empty (no memory, no work) until a
    /// step with a J2 material needs it.
    pub dil: FieldVec<[f64; 2]>,
    /// Work space of the XPIC transfer ([`super::Transfer::Xpic`]), `[r_x,
    /// r_y, s_x, s_y]` per node: the current term `r_j = (I − B)^j v0` of
    /// the series and the partial sum `Σ r_j` (see [`super::xpic`]). Empty
    /// (no memory, no work) until a step with that transfer needs it.
    pub xpic: FieldVec<Node4>,
}

impl Clone for Grid {
    fn clone(&self) -> Self {
        let Grid {
            origin,
            h,
            lo,
            n,
            ghost,
            mass,
            mom_force,
            vel,
            dil,
            xpic,
        } = self;
        Grid {
            origin: *origin,
            h: *h,
            lo: *lo,
            n: *n,
            ghost: *ghost,
            mass: mass.clone(),
            mom_force: mom_force.clone(),
            vel: vel.clone(),
            dil: dil.clone(),
            xpic: xpic.clone(),
        }
    }

    fn clone_from(&mut self, src: &Self) {
        // Every field named (no `..`): a new field must be added here.
        let Grid {
            origin,
            h,
            lo,
            n,
            ghost,
            mass,
            mom_force,
            vel,
            dil,
            xpic,
        } = self;
        *origin = src.origin;
        *h = src.h;
        *lo = src.lo;
        *n = src.n;
        *ghost = src.ghost;
        mass.clone_from(&src.mass);
        mom_force.clone_from(&src.mom_force);
        vel.clone_from(&src.vel);
        dil.clone_from(&src.dil);
        xpic.clone_from(&src.xpic);
    }
}

/// `len` default values, allocated fallibly: an allocation the system
/// refuses is an error naming the size, not an abort.
fn zeroed<T: Default + Copy>(len: usize) -> Result<FieldVec<T>> {
    let mut v = FieldVec::new();
    v.try_reserve_exact(len).map_err(|_| {
        Error::new(
            crate::error::Status::InvalidState,
            format!(
                "cannot allocate a patch grid of {len} nodes ({} MB): not enough memory (use smaller patches, or fewer particles per rank)",
                len * std::mem::size_of::<T>() / 1_000_000
            ),
        )
    })?;
    v.resize(len, T::default());
    Ok(v)
}

impl Grid {
    /// A grid for the half-open cell box `[cell_lo, cell_hi)` of a level
    /// (the convention of [`crate::geom::IBox`]) grown by `ghost` cells on
    /// every side. Its nodes are `cell_lo - ghost ..= cell_hi + ghost`.
    ///
    /// A particle can be mapped when its 3-node stencil lies inside the node
    /// box, i.e. when its position in cell units lies in
    /// `[cell_lo - ghost + 1/2, cell_hi + ghost - 1/2)`: with `ghost >= 1`
    /// that is every particle of the patch's cells and up to half a cell more.
    pub fn new(
        origin: [f64; 2],
        h: f64,
        cell_lo: [i64; 2],
        cell_hi: [i64; 2],
        ghost: i64,
    ) -> Result<Grid> {
        if !(h.is_finite() && h > 0.0) {
            return Err(Error::arg(format!(
                "cell size h = {h} must be finite and > 0"
            )));
        }
        if !(origin[0].is_finite() && origin[1].is_finite()) {
            return Err(Error::arg("grid origin must be finite"));
        }
        if ghost < 0 {
            return Err(Error::arg(format!("ghost = {ghost} must be >= 0")));
        }
        for d in 0..2 {
            if cell_hi[d] <= cell_lo[d] {
                return Err(Error::arg(format!(
                    "cell box axis {d}: cell_hi = {} must be > cell_lo = {}",
                    cell_hi[d], cell_lo[d]
                )));
            }
        }
        let lo = [cell_lo[0] - ghost, cell_lo[1] - ghost];
        let n = [
            (cell_hi[0] - cell_lo[0] + 1 + 2 * ghost) as usize,
            (cell_hi[1] - cell_lo[1] + 1 + 2 * ghost) as usize,
        ];
        let len = n[0]
            .checked_mul(n[1])
            .filter(|&l| l <= (1usize << 32))
            .ok_or_else(|| Error::arg("grid node count must be <= 2^32"))?;
        Ok(Grid {
            origin,
            h,
            lo,
            n,
            ghost,
            mass: zeroed(len)?,
            mom_force: zeroed(len)?,
            vel: zeroed(len)?,
            dil: FieldVec::new(),
            xpic: FieldVec::new(),
        })
    }

    /// A grid for a patch box of a level (see [`Grid::new`]).
    pub fn from_ibox(origin: [f64; 2], h: f64, b: &crate::geom::IBox, ghost: i64) -> Result<Grid> {
        Grid::new(origin, h, b.lo, b.hi, ghost)
    }

    /// Number of stored nodes.
    pub fn len(&self) -> usize {
        self.mass.len()
    }

    /// True when the grid stores no node (never, for a grid made by `new`).
    pub fn is_empty(&self) -> bool {
        self.mass.is_empty()
    }

    /// Zeroes the P2G accumulators (mass, momentum, force).
    pub fn reset(&mut self) {
        self.mass.fill(0.0);
        self.mom_force.fill(Node4::default());
    }

    /// Number of P2G accumulators [`Grid::acc`] addresses (the dilatation
    /// sums [`Grid::DIL_NUM`] and [`Grid::DIL_DEN`] come after them).
    pub const ACCUMULATORS: usize = 5;
    /// Accumulator number of the dilatation sum `Σ_p S_ip V_p div_p`.
    pub const DIL_NUM: usize = 5;
    /// Accumulator number of the dilatation weight `Σ_p S_ip V_p`.
    pub const DIL_DEN: usize = 6;

    /// Allocates (zeroed) the dilatation sums if they are not there yet.
    pub fn ensure_dilatation(&mut self) -> Result<()> {
        if self.dil.len() != self.len() {
            self.dil = zeroed(self.len())?;
        }
        Ok(())
    }

    /// Allocates the XPIC work space ([`Grid::xpic`]) if it is not there
    /// yet (fallibly: an error names the size).
    pub fn ensure_xpic(&mut self) -> Result<()> {
        if self.xpic.len() != self.len() {
            self.xpic = zeroed(self.len())?;
        }
        Ok(())
    }

    /// Accumulator `f` of node `k`: 0 mass, 1 momentum x, 2 momentum y,
    /// 3 force x, 4 force y, 5 and 6 the dilatation sums (zero while they
    /// are not allocated).
    ///
    /// # Panics
    /// If `f >= 7` or `k >= self.len()`.
    #[inline]
    pub fn acc(&self, f: usize, k: usize) -> f64 {
        match f {
            0 => self.mass[k],
            1..=4 => self.mom_force[k].0[f - 1],
            5 | 6 if self.dil.is_empty() => {
                assert!(k < self.len(), "node {k} out of range");
                0.0
            }
            5 | 6 => self.dil[k][f - 5],
            _ => panic!("accumulator {f} does not exist (0..=6)"),
        }
    }

    /// Sets accumulator `f` (as in [`Grid::acc`]) of node `k` to `v`.
    ///
    /// # Panics
    /// If `f >= 7` or `k >= self.len()`, or `f` is 5 or 6 and the
    /// dilatation sums are not allocated ([`Grid::ensure_dilatation`]).
    #[inline]
    pub fn set_acc(&mut self, f: usize, k: usize, v: f64) {
        match f {
            0 => self.mass[k] = v,
            1..=4 => self.mom_force[k].0[f - 1] = v,
            5 | 6 => self.dil[k][f - 5] = v,
            _ => panic!("accumulator {f} does not exist (0..=6)"),
        }
    }

    /// Storage index of node `(i, j)`, if stored.
    pub fn index(&self, i: i64, j: i64) -> Option<usize> {
        let a = i - self.lo[0];
        let b = j - self.lo[1];
        if a >= 0 && b >= 0 && (a as usize) < self.n[0] && (b as usize) < self.n[1] {
            Some(b as usize * self.n[0] + a as usize)
        } else {
            None
        }
    }

    /// Position of node `(i, j)`.
    pub fn node_position(&self, i: i64, j: i64) -> [f64; 2] {
        [
            self.origin[0] + i as f64 * self.h,
            self.origin[1] + j as f64 * self.h,
        ]
    }

    /// Range of positions (cell units of the level, per axis) whose 3-node
    /// stencil lies in the grid: `[lo + 1/2, lo + n - 3/2)`.
    pub fn mappable_range(&self, axis: usize) -> (f64, f64) {
        let lo = self.lo[axis] as f64;
        (lo + 0.5, lo + self.n[axis] as f64 - 1.5)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn node_box_includes_ghosts() {
        let g = Grid::new([0.0, 0.0], 0.5, [2, 3], [6, 5], 1).unwrap();
        assert_eq!(g.lo, [1, 2]);
        assert_eq!(g.n, [7, 5]); // nodes 1..=7, 2..=6
        assert_eq!(g.index(1, 2), Some(0));
        assert_eq!(g.index(7, 6), Some(34));
        assert_eq!(g.index(8, 6), None);
        assert_eq!(g.index(1, 1), None);
        assert_eq!(g.node_position(2, 4), [1.0, 2.0]);
        assert_eq!(g.mappable_range(0), (1.5, 6.5));
        assert!(Grid::new([0.0, 0.0], 0.0, [0, 0], [2, 2], 1)
            .unwrap_err()
            .msg
            .contains("h = 0"));
    }

    #[test]
    fn accumulators_by_number_address_mass_momentum_and_force() {
        let mut g = Grid::new([0.0, 0.0], 1.0, [0, 0], [2, 2], 0).unwrap();
        for f in 0..Grid::ACCUMULATORS {
            g.set_acc(f, 4, 10.0 + f as f64);
        }
        assert_eq!(g.mass[4], 10.0);
        assert_eq!(g.mom_force[4].0[mf::PX], 11.0);
        assert_eq!(g.mom_force[4].0[mf::PY], 12.0);
        assert_eq!(g.mom_force[4].0[mf::FX], 13.0);
        assert_eq!(g.mom_force[4].0[mf::FY], 14.0);
        assert_eq!(g.acc(3, 4), 13.0);
        assert_eq!(g.vel[4], Node4::default());
        g.reset();
        assert!((0..Grid::ACCUMULATORS).all(|f| g.acc(f, 4) == 0.0));
        // the node arrays are 32-byte aligned for the vector loads
        assert_eq!(g.vel.as_ptr() as usize % 32, 0);
        assert_eq!(g.mom_force.as_ptr() as usize % 32, 0);
    }
}
