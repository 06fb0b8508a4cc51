//! Weights of a block of consecutive particles, evaluated lane by lane.
//!
//! The per-particle loops take their particles [`LANES`] at a time: the
//! stencils of the whole block are evaluated first, one loop over the lanes
//! per axis whose body is the branch-free scalar weight function
//! ([`Shape1D::eval_f`]), which the compiler turns into vector instructions
//! over the particles (four per 256-bit register where the CPU has them).
//! Lane `l` holds bit for bit what `eval_f` gives for that particle alone:
//! the same IEEE operations, only several particles per instruction.
//!
//! The results are stored as structure-of-arrays (`w[a][l]`), so that the
//! per-particle gather and scatter read each weight with one broadcast load.

// Lane loops index several arrays by the lane on purpose: that is the
// form the compiler turns into vector instructions.
#![allow(clippy::needless_range_loop)]

use super::geo::Geo;
use crate::shape::Shape1D;

/// Particles per block.
pub(crate) const LANES: usize = 8;

/// Stencils of up to [`LANES`] particles.
///
/// Aligned to a cache line, as are the other per-block buffers of the
/// particle loops: they live on the stack, whose offset the system
/// randomizes per process, and unaligned, their vector loads and stores
/// straddled cache lines in about half of the processes (19 instead of
/// 21.5 M particle-steps/s on the comparison scene, by process).
#[derive(Clone, Copy)]
#[repr(align(64))]
pub(crate) struct Block {
    /// Storage index of the first stencil node of each lane (meaningful
    /// where `ok`).
    pub(crate) k0: [usize; LANES],
    /// The lane's 3×3 stencil is inside the grid (false also for
    /// non-finite positions).
    pub(crate) ok: [bool; LANES],
    /// x weights of nodes `base, base+1, base+2`.
    pub(crate) wx: [[f64; LANES]; 3],
    /// Their slopes (cell units).
    pub(crate) gx: [[f64; LANES]; 3],
    /// y weights.
    pub(crate) wy: [[f64; LANES]; 3],
    /// y slopes.
    pub(crate) gy: [[f64; LANES]; 3],
    /// The hoop weights `T_a = w_a/ρ_p` along x (per cell) of the
    /// axisymmetric mode (filled only for a shape with
    /// [`Shape1D::AXI`], whose `wx`, `gx` are then the r-weighted weights
    /// and their gradients).
    pub(crate) tx: [[f64; LANES]; 3],
    /// The weights times the nodes' offsets from the particle, in cells,
    /// per axis: `wx_a (a − u_x)` and `wy_b (b − u_y)`, with `u` the
    /// particle's position relative to the first stencil node (`xi − base`,
    /// in `[1/2, 3/2)`; the centroid of the r-weighted volume along the
    /// radius of the axisymmetric mode). The affine transfer's `S (x_i −
    /// x_p)` per axis. Filled only by [`Block::eval_into_aff`] with `AFF`.
    pub(crate) wd: [[[f64; LANES]; 3]; 2],
    /// The weights' second moments per axis, `Σ_a wx_a (a − u_x)²` and the
    /// same along y (cells²; the APIC matrix `D_p` of the GIMP weights).
    /// Filled only with `AFF`.
    pub(crate) d2: [[f64; LANES]; 2],
}

/// One particle's weights in a [`Block`].
#[derive(Clone, Copy)]
pub(crate) struct Lane<'a> {
    b: &'a Block,
    l: usize,
}

impl Lane<'_> {
    /// `wx_a`.
    #[inline(always)]
    pub(crate) fn wx(&self, a: usize) -> f64 {
        self.b.wx[a][self.l]
    }
    /// `gx_a`.
    #[inline(always)]
    pub(crate) fn gx(&self, a: usize) -> f64 {
        self.b.gx[a][self.l]
    }
    /// `wy_b`.
    #[inline(always)]
    pub(crate) fn wy(&self, b: usize) -> f64 {
        self.b.wy[b][self.l]
    }
    /// `gy_b`.
    #[inline(always)]
    pub(crate) fn gy(&self, b: usize) -> f64 {
        self.b.gy[b][self.l]
    }
    /// `tx_a`, the hoop weight (axisymmetric shapes only).
    #[inline(always)]
    pub(crate) fn tx(&self, a: usize) -> f64 {
        self.b.tx[a][self.l]
    }
    /// First stencil node.
    #[inline(always)]
    pub(crate) fn k0(&self) -> usize {
        self.b.k0[self.l]
    }
    /// `wx_a` times the offset of node `a` (x) from the particle, in cells
    /// (only after [`Block::eval_into_aff`] with `AFF`).
    #[inline(always)]
    pub(crate) fn wdx(&self, a: usize) -> f64 {
        self.b.wd[0][a][self.l]
    }
    /// `wy_b` times the offset of node `b` (y) from the particle, in cells
    /// (only after [`Block::eval_into_aff`] with `AFF`).
    #[inline(always)]
    pub(crate) fn wdy(&self, b: usize) -> f64 {
        self.b.wd[1][b][self.l]
    }
}

impl Block {
    /// Lane `l`.
    #[inline(always)]
    pub(crate) fn lane(&self, l: usize) -> Lane<'_> {
        Lane { b: self, l }
    }

    /// A block with every lane off the grid (to be filled by
    /// [`Block::eval_into`]).
    pub(crate) fn new() -> Block {
        Block {
            k0: [0; LANES],
            ok: [false; LANES],
            wx: [[0.0; LANES]; 3],
            gx: [[0.0; LANES]; 3],
            wy: [[0.0; LANES]; 3],
            gy: [[0.0; LANES]; 3],
            tx: [[0.0; LANES]; 3],
            wd: [[[0.0; LANES]; 3]; 2],
            d2: [[0.0; LANES]; 2],
        }
    }

    /// [`Block::eval_into`] into a new block.
    #[cfg(test)]
    pub(crate) fn eval<S: Shape1D>(
        geo: &Geo,
        x: &[f64],
        y: &[f64],
        lx: &[f64],
        ly: &[f64],
    ) -> Block {
        let mut b = Block::new();
        b.eval_into::<S>(geo, x, y, lx, ly);
        b
    }

    /// Overwrites every lane with the stencils of the particles at
    /// `(x[l], y[l])` with half-lengths `(lx[l], ly[l])`, for the first
    /// `n <= LANES` entries of the slices (lanes past `n` are evaluated on
    /// zeros and marked not `ok`). Lane `l` is what the scalar weight
    /// function gives for that particle. (Filling a block kept across the
    /// loop, rather than returning a new one, spares the zeroing and the
    /// copy of ~1 KB per block.)
    #[inline(always)]
    pub(crate) fn eval_into<S: Shape1D>(
        &mut self,
        geo: &Geo,
        x: &[f64],
        y: &[f64],
        lx: &[f64],
        ly: &[f64],
    ) {
        self.eval_into_aff::<S, false>(geo, x, y, lx, ly);
    }

    /// [`Block::eval_into`], and with `AFF` also the weighted offsets of
    /// the nodes from the particles ([`Block::wd`]) and their second
    /// moments ([`Block::d2`]), across the lanes; the weights are the same
    /// bits either way.
    #[inline(always)]
    pub(crate) fn eval_into_aff<S: Shape1D, const AFF: bool>(
        &mut self,
        geo: &Geo,
        x: &[f64],
        y: &[f64],
        lx: &[f64],
        ly: &[f64],
    ) {
        let n = x.len().min(LANES);
        let mut inp = [[0.0f64; LANES]; 4];
        for (dst, src) in inp.iter_mut().zip([x, y, lx, ly]) {
            match src.first_chunk::<LANES>() {
                // A full block: a fixed-size copy (no library call).
                Some(full) => *dst = *full,
                None => dst[..n].copy_from_slice(&src[..n]),
            }
        }
        let mut bx = [0.0f64; LANES];
        let mut by = [0.0f64; LANES];
        let (o, lo, maxf) = (geo.origin(), geo.lo_f(), geo.max_first());
        let inv_h = geo.inv_h;
        if S::AXI {
            // The radius of the grid's node 0, in cells.
            let rho0 = o[0] * inv_h;
            for l in 0..LANES {
                let xi = (inp[0][l] - o[0]) * inv_h;
                let w = S::eval_axi_f(xi, inp[2][l] * inv_h, rho0);
                bx[l] = w.base - lo[0];
                if AFF {
                    // The affine transfer expands about the centroid of
                    // the particle's volume, `Σ_a S_a a` (r-weighted: l²/(3
                    // ρ_p) out from the centre for GIMP), so that `Σ S
                    // (x_i − x̄_p) = 0` and the affine part adds no momentum.
                    self.affine(0, l, w.s, w.s[1] + 2.0 * w.s[2]);
                }
                for a in 0..3 {
                    self.wx[a][l] = w.s[a];
                    self.gx[a][l] = w.g[a];
                    self.tx[a][l] = w.t[a];
                }
            }
        } else {
            for l in 0..LANES {
                let xi = (inp[0][l] - o[0]) * inv_h;
                let w = S::eval_f(xi, inp[2][l] * inv_h);
                bx[l] = w.base - lo[0];
                if AFF {
                    self.affine(0, l, w.w, xi - w.base);
                }
                for a in 0..3 {
                    self.wx[a][l] = w.w[a];
                    self.gx[a][l] = w.g[a];
                }
            }
        }
        for l in 0..LANES {
            let yi = (inp[1][l] - o[1]) * inv_h;
            let w = S::eval_f(yi, inp[3][l] * inv_h);
            by[l] = w.base - lo[1];
            if AFF {
                self.affine(1, l, w.w, yi - w.base);
            }
            for b in 0..3 {
                self.wy[b][l] = w.w[b];
                self.gy[b][l] = w.g[b];
            }
        }
        for l in 0..LANES {
            // Written so that NaN fails; `&` rather than `&&`, so that the
            // lanes compare as vectors instead of branching per lane (this
            // check took 10 instructions per particle).
            let inside = (0.0 <= bx[l]) & (bx[l] <= maxf[0]) & (0.0 <= by[l]) & (by[l] <= maxf[1]);
            self.ok[l] = inside & (l < n);
            // Integers in [0, n - 3] where inside; 0 elsewhere (never used).
            let (ix, iy) = if self.ok[l] {
                (bx[l], by[l])
            } else {
                (0.0, 0.0)
            };
            // SAFETY: `ix`, `iy` are 0 or integer-valued floats in
            // `[0, n - 3]` (differences of integers below 2^51), so they
            // convert exactly.
            let (ix, iy) = unsafe {
                (
                    ix.to_int_unchecked::<i64>() as usize,
                    iy.to_int_unchecked::<i64>() as usize,
                )
            };
            self.k0[l] = iy * geo.nx + ix;
        }
    }

    /// The affine terms ([`Block::wd`], [`Block::d2`]) along `axis` (0: x,
    /// 1: y) of lane `l`, with weights `w` and the particle at `u` from the
    /// first stencil node (cells).
    #[inline(always)]
    fn affine(&mut self, axis: usize, l: usize, w: [f64; 3], u: f64) {
        let mut d2 = 0.0;
        for a in 0..3 {
            let d = a as f64 - u;
            let wd = w[a] * d;
            self.wd[axis][a][l] = wd;
            d2 += wd * d;
        }
        self.d2[axis][l] = d2;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::grid::Grid;
    use crate::shape::Shape1D;
    use crate::shape::{GimpShape, MpmShape};

    fn check<S: Shape1D>() {
        let grid = Grid::new([-0.5, -0.75], 0.25, [0, 0], [40, 30], 2).unwrap();
        let geo = Geo::of(&grid);
        let mut s = 0x9E3779B97F4A7C15u64;
        let mut rnd = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut inside = 0;
        for n in 0..=LANES {
            for _ in 0..200 {
                let mut v = [[0.0; LANES]; 4];
                for l in 0..LANES {
                    v[0][l] = -1.0 + 12.0 * rnd();
                    v[1][l] = -1.5 + 9.5 * rnd();
                    v[2][l] = 0.2 * rnd() - 0.02;
                    v[3][l] = 0.2 * rnd() - 0.02;
                }
                v[0][0] = f64::NAN;
                let blk = Block::eval::<S>(&geo, &v[0][..n], &v[1][..n], &v[2][..n], &v[3][..n]);
                for l in 0..LANES {
                    // The scalar evaluation of the same particle.
                    let wx = S::eval_f((v[0][l] + 0.5) * 4.0, v[2][l] * 4.0);
                    let wy = S::eval_f((v[1][l] + 0.75) * 4.0, v[3][l] * 4.0);
                    // Grid nodes 0..=44 x 0..=34 (cells 0..40 x 0..30 plus 2
                    // ghost cells), first node -2, so local first node
                    // base + 2 must be in [0, 42] x [0, 32].
                    let (ix, iy) = (wx.base + 2.0, wy.base + 2.0);
                    let fits = (0.0..=42.0).contains(&ix) && (0.0..=32.0).contains(&iy);
                    if !(fits && l < n) {
                        assert!(!blk.ok[l], "lane {l} of {n}");
                        continue;
                    }
                    inside += 1;
                    assert!(blk.ok[l]);
                    assert_eq!(blk.k0[l], iy as usize * 45 + ix as usize);
                    let ln = blk.lane(l);
                    for a in 0..3 {
                        assert_eq!(ln.wx(a).to_bits(), wx.w[a].to_bits());
                        assert_eq!(ln.wy(a).to_bits(), wy.w[a].to_bits());
                        assert_eq!(blk.gx[a][l].to_bits(), wx.g[a].to_bits());
                        assert_eq!(blk.gy[a][l].to_bits(), wy.g[a].to_bits());
                    }
                }
            }
        }
        assert!(inside > 3000, "{inside} lanes inside");
    }

    #[test]
    fn block_lanes_match_the_single_particle_stencil_bit_for_bit() {
        check::<GimpShape>();
        check::<MpmShape>();
    }
}
