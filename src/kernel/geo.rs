//! Where a patch's grid sits, in the form the per-particle loops read it
//! ([`Geo`]): origin, node box and the own-cell bounds, as plain numbers
//! copied out of the [`Grid`] once per pass.

use super::Grid;

/// Where a patch's grid sits, in the form the per-particle loops use.
#[derive(Clone, Copy)]
pub(crate) struct Geo {
    pub(crate) inv_h: f64,
    pub(crate) ox: f64,
    pub(crate) oy: f64,
    pub(crate) lox: i64,
    pub(crate) loy: i64,
    pub(crate) nx: usize,
    pub(crate) nxi: i64,
    pub(crate) nyi: i64,
    /// `lo` as floats.
    pub(crate) lof: [f64; 2],
    /// Largest first stencil node (local), `n - 3`, as floats.
    maxf: [f64; 2],
    /// The grid's own cells per axis, in cell units of the level, shrunk
    /// by a margin: a position `xi` (as [`super::g2p`] computes it, `(x -
    /// origin) / h` with a multiplication by `1/h`) inside `[home.0,
    /// home.1)` on both axes has its cell (`floor((x - origin) / h)`, with
    /// a division) among the own cells. The margin (1e-9 relative) covers the
    /// rounding difference of the two forms, a few units in the last place.
    pub(crate) home: [(f64, f64); 2],
}

impl Geo {
    pub(crate) fn of(grid: &Grid) -> Geo {
        Geo {
            inv_h: 1.0 / grid.h,
            ox: grid.origin[0],
            oy: grid.origin[1],
            lox: grid.lo[0],
            loy: grid.lo[1],
            nx: grid.n[0],
            nxi: grid.n[0] as i64,
            nyi: grid.n[1] as i64,
            lof: [grid.lo[0] as f64, grid.lo[1] as f64],
            maxf: [grid.n[0] as f64 - 3.0, grid.n[1] as f64 - 3.0],
            home: [0, 1].map(|d| {
                let lo = (grid.lo[d] + grid.ghost) as f64;
                let hi = (grid.lo[d] + grid.n[d] as i64 - 1 - grid.ghost) as f64;
                let m = 1e-9 * (1.0 + lo.abs().max(hi.abs()));
                (lo + m, hi - m)
            }),
        }
    }

    /// Origin of the level's node 0 (`(ox, oy)`).
    #[inline(always)]
    pub(crate) fn origin(&self) -> [f64; 2] {
        [self.ox, self.oy]
    }

    /// The grid's first node index per axis, as floats.
    #[inline(always)]
    pub(crate) fn lo_f(&self) -> [f64; 2] {
        self.lof
    }

    /// Largest first stencil node (local index), `n - 3` per axis, as
    /// floats.
    #[inline(always)]
    pub(crate) fn max_first(&self) -> [f64; 2] {
        self.maxf
    }

    /// Number of nodes every grid array must hold for the unchecked
    /// stencil access (`nx * ny`).
    pub(crate) fn nodes(&self) -> usize {
        self.nx * self.nyi as usize
    }
}
