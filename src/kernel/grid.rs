//! Nodal data of one patch: structure-of-arrays over an integer node box that
//! includes the patch's ghost nodes.

use crate::error::{Error, Result};

/// Nodal arrays of one patch at one level.
///
/// Node `(i, j)` (integer indices of the level, node `(0, 0)` at `origin`)
/// sits at `origin + (i h, j h)`. The grid stores nodes `lo[0] ..= lo[0] +
/// n[0] - 1` by `lo[1] ..= lo[1] + n[1] - 1`, row-major in x:
/// `k = (j - lo[1]) * n[0] + (i - lo[0])`.
///
/// Arrays:
/// * `mass`, `px`, `py`, `fx`, `fy`: accumulated by P2G (mass, momentum,
///   total force); zeroed by [`Grid::reset`];
/// * `v0x`, `v0y`: velocity `p/m` before the force update (and, for MUSL,
///   the velocity of the re-mapped momentum used for the velocity gradient);
/// * `vx`, `vy`: velocity after the force update, `(p + f dt)/m`.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    /// Position of node `(0, 0)` of the level (the domain origin).
    pub origin: [f64; 2],
    /// Cell size.
    pub h: f64,
    /// First stored node index in x and y.
    pub lo: [i64; 2],
    /// Number of stored nodes in x and y.
    pub n: [usize; 2],
    /// Nodal mass.
    pub mass: Vec<f64>,
    /// Nodal momentum x.
    pub px: Vec<f64>,
    /// Nodal momentum y.
    pub py: Vec<f64>,
    /// Nodal force x (internal + external).
    pub fx: Vec<f64>,
    /// Nodal force y.
    pub fy: Vec<f64>,
    /// Nodal velocity x before the force update (see the type notes).
    pub v0x: Vec<f64>,
    /// Nodal velocity y before the force update.
    pub v0y: Vec<f64>,
    /// Nodal velocity x after the force update.
    pub vx: Vec<f64>,
    /// Nodal velocity y after the force update.
    pub vy: Vec<f64>,
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
        let z = || vec![0.0; len];
        Ok(Grid {
            origin,
            h,
            lo,
            n,
            mass: z(),
            px: z(),
            py: z(),
            fx: z(),
            fy: z(),
            v0x: z(),
            v0y: z(),
            vx: z(),
            vy: z(),
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
        for v in [
            &mut self.mass,
            &mut self.px,
            &mut self.py,
            &mut self.fx,
            &mut self.fy,
        ] {
            v.fill(0.0);
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
}
