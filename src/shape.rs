//! Node–particle weight functions in 1D and 2D: linear MPM, uGIMP and cpGIMP.
//!
//! Everything here works in **cell units**: a particle at `x` on a grid with
//! node 0 at `x0` and cell size `h` sits at `xi = (x - x0) / h`, and its
//! half-length `lp` becomes `li = lp / h`. Node `i` sits at `xi = i`.
//! Gradients are d/dxi; the caller multiplies them by `1/h`.
//!
//! **Stencil.** With `li <= 1/2` a particle touches at most three nodes per
//! axis: `base, base+1, base+2` with `base = round(xi) - 1` (rounding half up,
//! `floor(xi + 1/2) - 1`). Nodes outside the support simply get weight 0, so
//! every particle uses the same 3-node (3×3 in 2D) pattern.
//!
//! **GIMP weight** (eq. 6 of the paper, Bardenhagen & Kober 2004): the average
//! of the node's hat function `S(s) = max(0, 1 - |s|)` over the particle's
//! domain `[xi - li, xi + li]`. With `d = xi - i` and `l = li`, in closed form:
//!
//! | region              | weight                      | d weight / d xi          |
//! |---------------------|-----------------------------|--------------------------|
//! | `|d| < l`           | `1 - (d² + l²) / (2l)`      | `-d / l`                 |
//! | `l <= |d| <= 1 - l` | `1 - |d|`                   | `-sign(d)`               |
//! | `1-l < |d| < 1 + l` | `(1 + l - |d|)² / (4l)`     | `-sign(d) (1+l-|d|)/(2l)`|
//! | otherwise           | `0`                         | `0`                      |
//!
//! The weight is C¹ and its gradient is continuous (the cure for MPM's
//! cell-crossing noise). As `l -> 0` it tends to the MPM hat; `l = 0` is
//! evaluated without division by zero.
//!
//! **Linear MPM** uses the hat at the particle centre; its gradient jumps by 2
//! when the particle crosses a node (cell boundary). At exactly a node the
//! particle is taken to be in the cell to the right (right limit).
//!
//! **cpGIMP** here is the paper's "rectangular without rotation" domain: an
//! axis-aligned rectangle whose half-lengths are the current lengths of the
//! domain's reference half-axes, `lpx = lpx0 |F e_x| = lpx0 √(F_xx² + F_yx²)`
//! and `lpy = lpy0 |F e_y| = lpy0 √(F_xy² + F_yy²)` (the columns of `F`: the
//! material fibres along x and y). A rigid rotation leaves them unchanged, and
//! a stretch along the axes gives `lp0 F_ii`. (Taking `lp0 F_ii` itself, as an
//! earlier version did, shrinks a turned domain to nothing at a quarter turn:
//! a free block spun with APIC went unstable within the turn.) They are
//! clamped to `h/2` by [`cpgimp_half_lengths`]: the clamp keeps the 3-node
//! stencil valid when a particle is stretched beyond a cell (the part of the
//! domain beyond `h/2` is simply not seen by the grid, which under-smooths but
//! never breaks the partition of unity).
//!
//! **Axisymmetry.** The r-weighted weights of the axisymmetric mode (the
//! weight, its gradient and the hoop weight along the radius, with the
//! treatment of the axis) are in [`axi`].

pub mod axi;
pub use axi::{
    axi_weights_1d, axi_weights_2d, AxiGimpShape, AxiMpmShape, AxiShape1D, AxiWeights1D,
    AxiWeights1DF, AxiWeights2D,
};

/// Which weight function a level uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShapeKind {
    /// Linear hat at the particle centre (plain MPM).
    Mpm,
    /// GIMP with the particle domain fixed at its reference size (uGIMP).
    UGimp,
    /// GIMP with the particle domain following the lengths of the material
    /// fibres along x and y, `|F e_x|, |F e_y|` (cpGIMP, "rectangular without
    /// rotation").
    CpGimp,
}

impl ShapeKind {
    /// True for the GIMP variants (weights depend on the particle size).
    pub fn is_gimp(self) -> bool {
        !matches!(self, ShapeKind::Mpm)
    }
}

/// Weights and gradients of one particle on the three nodes of one axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Weights1D {
    /// Index of the first node of the stencil (`round(xi) - 1`).
    pub base: i64,
    /// Weights of nodes `base, base+1, base+2`.
    pub w: [f64; 3],
    /// d weight / d xi (cell units) of the same nodes.
    pub g: [f64; 3],
}

/// [`Weights1D`] with the first stencil node as a float (an exact integer
/// for any position below 2^51 cells; NaN or huge for garbage positions),
/// which is what the kernels use: the bounds check and the index then need
/// no saturating float-to-integer conversion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Weights1DF {
    /// Index of the first node of the stencil (`floor(xi + 1/2) - 1`).
    pub base: f64,
    /// Weights of nodes `base, base+1, base+2`.
    pub w: [f64; 3],
    /// d weight / d xi (cell units) of the same nodes.
    pub g: [f64; 3],
}

/// A 1D weight function, implemented by zero-sized types so the kernel can be
/// monomorphized on it (no dispatch per particle).
pub trait Shape1D {
    /// Weights of a particle at `xi` (cell units) with half-length `li`
    /// (cell units, clamped to `[0, 1/2]`), first node as a float.
    fn eval_f(xi: f64, li: f64) -> Weights1DF;

    /// Weights of a particle at `xi` (cell units) with half-length `li`
    /// (cell units, clamped to `[0, 1/2]`).
    #[inline(always)]
    fn eval(xi: f64, li: f64) -> Weights1D {
        let f = Self::eval_f(xi, li);
        Weights1D {
            base: f.base as i64,
            w: f.w,
            g: f.g,
        }
    }

    /// True for the weights of the axisymmetric mode ([`Axi`]): along x
    /// (the radius) the kernel then takes [`Shape1D::eval_axi_f`], and it
    /// adds the hoop terms. A constant, so that the kernel's loops are
    /// compiled once per mode with no branch on it per particle.
    const AXI: bool = false;

    /// True for the GIMP weights (uGIMP, cpGIMP), whose APIC matrix is
    /// `B D^{-1}` with `D` the weights' second moments; false for MPM's
    /// hat functions, where the two are equal to the velocity gradient and
    /// the moments vanish at a node (see [`crate::kernel::Transfer`]).
    const APIC_MOMENTS: bool;

    /// The r-weighted weights along the radius (see [`axi`]) of a particle
    /// at `xi` with half-length `li` on a grid whose node 0 is at the
    /// radius `rho0` (all in cells). Read by the kernel only when
    /// [`Shape1D::AXI`]; the plane weight functions give the linear MPM
    /// form (the weights themselves, `T = w/ρ_p`).
    #[inline(always)]
    fn eval_axi_f(xi: f64, li: f64, rho0: f64) -> AxiWeights1DF {
        let p = Self::eval_f(xi, li);
        let inv_r = 1.0 / (rho0 + xi);
        AxiWeights1DF {
            base: p.base,
            s: p.w,
            g: p.g,
            t: [p.w[0] * inv_r, p.w[1] * inv_r, p.w[2] * inv_r],
            w: p.w,
        }
    }
}

/// The weights of the axisymmetric mode for the plane weight function `S`
/// (`Axi<MpmShape>`, `Axi<GimpShape>`): along y (the axis z) the plane
/// weights, along x (the radius) the r-weighted ones of [`axi`]. The
/// kernel is monomorphised on it as on the plane shapes.
#[derive(Clone, Copy, Debug, Default)]
pub struct Axi<S>(core::marker::PhantomData<S>);

impl Shape1D for Axi<MpmShape> {
    #[inline(always)]
    fn eval_f(xi: f64, li: f64) -> Weights1DF {
        MpmShape::eval_f(xi, li)
    }
    const AXI: bool = true;
    const APIC_MOMENTS: bool = false;
    #[inline(always)]
    fn eval_axi_f(xi: f64, li: f64, rho0: f64) -> AxiWeights1DF {
        AxiMpmShape::eval_f(xi, li, rho0)
    }
}

impl Shape1D for Axi<GimpShape> {
    #[inline(always)]
    fn eval_f(xi: f64, li: f64) -> Weights1DF {
        GimpShape::eval_f(xi, li)
    }
    const AXI: bool = true;
    const APIC_MOMENTS: bool = true;
    #[inline(always)]
    fn eval_axi_f(xi: f64, li: f64, rho0: f64) -> AxiWeights1DF {
        AxiGimpShape::eval_f(xi, li, rho0)
    }
}

/// Linear MPM hat functions (the particle size is ignored).
#[derive(Clone, Copy, Debug, Default)]
pub struct MpmShape;

/// GIMP volume-averaged hat functions (uGIMP and cpGIMP share them; they
/// differ only in which half-length the caller passes).
#[derive(Clone, Copy, Debug, Default)]
pub struct GimpShape;

/// `1.5 · 2^52`: adding and subtracting it rounds any `|v| < 2^51` to the
/// nearest integer (round-to-nearest is the only mode Rust code runs in).
const ROUND_MAGIC: f64 = 6755399441055744.0;

/// First stencil node: `floor(xi + 1/2) - 1`, as a float. The floor is a
/// rounding by [`ROUND_MAGIC`] and a correction: the x86-64 baseline has no
/// rounding instruction, `f64::floor` would be a library call, and a
/// float-to-integer conversion needs range checks; this is four
/// instructions, exact for `|xi| < 2^51`, NaN for NaN or infinite `xi`.
#[inline(always)]
fn base_of(xi: f64) -> f64 {
    let v = xi + 0.5;
    let t = (v + ROUND_MAGIC) - ROUND_MAGIC;
    (if t > v { t - 1.0 } else { t }) - 1.0
}

/// `x` if `x > 0`, else `0` (also for NaN): one `maxsd`.
#[inline(always)]
fn pos(x: f64) -> f64 {
    if x > 0.0 {
        x
    } else {
        0.0
    }
}

impl Shape1D for MpmShape {
    const APIC_MOMENTS: bool = false;
    #[inline(always)]
    fn eval_f(xi: f64, _li: f64) -> Weights1DF {
        let b = base_of(xi);
        let d0 = xi - b; // in [0.5, 1.5)
                         // Left: the particle is in the cell [base, base+1], else in
                         // [base+1, base+2]. Both sides are formed and one is selected, so
                         // there is no branch to mispredict.
        let left = d0 < 1.0;
        let f = if left { d0 } else { d0 - 1.0 };
        let (one, zero) = (1.0, 0.0);
        Weights1DF {
            base: b,
            w: [
                if left { 1.0 - f } else { zero },
                if left { f } else { 1.0 - f },
                if left { zero } else { f },
            ],
            g: [
                if left { -one } else { zero },
                if left { one } else { -one },
                if left { zero } else { one },
            ],
        }
    }
}

impl Shape1D for GimpShape {
    const APIC_MOMENTS: bool = true;
    #[inline(always)]
    fn eval_f(xi: f64, li: f64) -> Weights1DF {
        let l = li.clamp(0.0, 0.5);
        let b = base_of(xi);
        let d0 = xi - b; // distance to node base, in [0.5, 1.5)
        let d1 = d0 - 1.0; // signed distance to node base+1, in [-0.5, 0.5)
        let e2 = 2.0 - d0; // distance to node base+2, in (0.5, 1.5]

        // 1/(2l), used only in the regions that exist when l > 0.
        let h2 = 0.5 / l;
        let lin = 1.0 - l;
        // Outer nodes: the particle is on one side, at distance e >= 1/2 >=
        // l: weight 1 - e and slope 1 for e <= 1 - l, (1 + l - e)² / (4l)
        // and slope (1 + l - e)/(2l) for e < 1 + l, else 0. Each region's
        // value is formed and selected (no branch); `pos` makes the last
        // region 0 (and hides the NaN of l = 0).
        #[inline(always)]
        fn outer(e: f64, l: f64, h2: f64, lin: f64) -> (f64, f64) {
            let r = pos((1.0 + l - e) * h2);
            if e <= lin {
                (1.0 - e, 1.0)
            } else {
                (r * r * l, r)
            }
        }
        // (weight, |slope|) for nodes base and base+2; the slope sign is
        // negative for base (particle to its right) and positive for base+2.
        let (w0, s0) = outer(d0, l, h2, lin);
        let (w2, s2) = outer(e2, l, h2, lin);
        let a1 = d1.abs();
        let inner = a1 < l;
        let w1 = if inner {
            1.0 - (d1 * d1 + l * l) * h2
        } else {
            1.0 - a1
        };
        let sign = if d1 > 0.0 { -1.0 } else { 1.0 };
        let g1 = if inner { -2.0 * d1 * h2 } else { sign };
        Weights1DF {
            base: b,
            w: [w0, w1, w2],
            g: [-s0, g1, s2],
        }
    }
}

/// 1D weights for a given kind (uGIMP and cpGIMP evaluate the same function;
/// the caller passes the reference or the current half-length).
#[inline]
pub fn weights_1d(kind: ShapeKind, xi: f64, li: f64) -> Weights1D {
    match kind {
        ShapeKind::Mpm => MpmShape::eval(xi, li),
        ShapeKind::UGimp | ShapeKind::CpGimp => GimpShape::eval(xi, li),
    }
}

/// Weights of one particle on its 3×3 node stencil (tensor products).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Weights2D {
    /// First stencil node in x.
    pub bx: i64,
    /// First stencil node in y.
    pub by: i64,
    /// Weight of node `(bx + a, by + b)` at index `a + 3 b`.
    pub w: [f64; 9],
    /// d weight / d xi (cell units), same layout.
    pub gx: [f64; 9],
    /// d weight / d yi (cell units), same layout.
    pub gy: [f64; 9],
}

/// 2D weights: the product of the x and y 1D weights.
pub fn weights_2d(kind: ShapeKind, xi: f64, yi: f64, lix: f64, liy: f64) -> Weights2D {
    let wx = weights_1d(kind, xi, lix);
    let wy = weights_1d(kind, yi, liy);
    let mut out = Weights2D {
        bx: wx.base,
        by: wy.base,
        w: [0.0; 9],
        gx: [0.0; 9],
        gy: [0.0; 9],
    };
    for b in 0..3 {
        for a in 0..3 {
            let k = a + 3 * b;
            out.w[k] = wx.w[a] * wy.w[b];
            out.gx[k] = wx.g[a] * wy.w[b];
            out.gy[k] = wx.w[a] * wy.g[b];
        }
    }
    out
}

/// cpGIMP current half-lengths `(lpx0 |F e_x|, lpy0 |F e_y|)` from the
/// deformation gradient `[[fxx, fxy], [fyx, fyy]]`, each at most `h/2` (see
/// the module notes for why).
///
/// The column lengths are `sqrt(a² + b²)`, not `hypot`: `hypot` is a
/// library call that no loop vectorizes (it cost cpGIMP about 100
/// instructions per particle-step), and the columns of a deformation
/// gradient are far from where `a²` over- or underflows (an overflow would
/// give an infinite length, clamped to `h/2` as `hypot`'s would be). The
/// square root is correctly rounded, so a particle gets the same bits in a
/// vector lane as alone.
#[inline(always)]
pub fn cpgimp_half_lengths(lpx0: f64, lpy0: f64, f: [f64; 4], h: f64) -> (f64, f64) {
    let [fxx, fxy, fyx, fyy] = f;
    let half = 0.5 * h;
    let cx = (fxx * fxx + fyx * fyx).sqrt();
    let cy = (fxy * fxy + fyy * fyy).sqrt();
    ((lpx0 * cx).min(half), (lpy0 * cy).min(half))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Small deterministic generator (no external crates): uniform in [0, 1).
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    fn hat(s: f64) -> f64 {
        (1.0 - s.abs()).max(0.0)
    }

    const SIZES: [f64; 3] = [0.25, 0.125, 0.5];

    /// Positions to probe: random ones, nodes, cell centres (stencil switch),
    /// and a few negative (ghost-side) ones.
    fn probe_positions() -> Vec<f64> {
        let mut r = Lcg(12345);
        let mut v: Vec<f64> = (0..400).map(|_| -3.0 + 10.0 * r.next()).collect();
        for k in -2..6 {
            v.push(k as f64);
            v.push(k as f64 + 0.5);
            v.push(k as f64 + 0.25);
        }
        v
    }

    fn weight_at(kind: ShapeKind, xi: f64, li: f64, node: i64) -> (f64, f64) {
        let w = weights_1d(kind, xi, li);
        let k = node - w.base;
        if (0..3).contains(&k) {
            (w.w[k as usize], w.g[k as usize])
        } else {
            (0.0, 0.0)
        }
    }

    #[test]
    fn partition_of_unity_1d() {
        for &xi in &probe_positions() {
            for kind in [ShapeKind::Mpm, ShapeKind::UGimp] {
                for &li in &SIZES {
                    let w = weights_1d(kind, xi, li);
                    let sw: f64 = w.w.iter().sum();
                    let sg: f64 = w.g.iter().sum();
                    assert!(
                        (sw - 1.0).abs() < 1e-14,
                        "{kind:?} xi={xi} li={li} sum w={sw}"
                    );
                    assert!(sg.abs() < 1e-13, "{kind:?} xi={xi} li={li} sum g={sg}");
                    assert!(w.w.iter().all(|&x| x >= 0.0), "negative weight at xi={xi}");
                }
            }
        }
    }

    #[test]
    fn partition_of_unity_2d_mixed_sizes_on_one_grid() {
        let mut r = Lcg(777);
        for _ in 0..300 {
            let (xi, yi) = (8.0 * r.next(), 8.0 * r.next());
            for &lix in &SIZES {
                for &liy in &SIZES {
                    for kind in [ShapeKind::Mpm, ShapeKind::UGimp, ShapeKind::CpGimp] {
                        let w = weights_2d(kind, xi, yi, lix, liy);
                        let sw: f64 = w.w.iter().sum();
                        let sx: f64 = w.gx.iter().sum();
                        let sy: f64 = w.gy.iter().sum();
                        assert!((sw - 1.0).abs() < 1e-14);
                        assert!(sx.abs() < 1e-13 && sy.abs() < 1e-13);
                        // linear field reproduction in 2D
                        let mut mx = 0.0;
                        let mut my = 0.0;
                        for b in 0..3 {
                            for a in 0..3 {
                                mx += w.w[a + 3 * b] * (w.bx + a as i64) as f64;
                                my += w.w[a + 3 * b] * (w.by + b as i64) as f64;
                            }
                        }
                        assert!((mx - xi).abs() < 1e-12 && (my - yi).abs() < 1e-12);
                    }
                }
            }
        }
    }

    #[test]
    fn closed_form_matches_numerical_volume_average() {
        // eq. 6 by a 2000-point midpoint rule over the particle domain.
        let n = 2000;
        for &xi in &probe_positions() {
            for &li in &SIZES {
                let w = weights_1d(ShapeKind::UGimp, xi, li);
                for k in -1..4i64 {
                    let node = w.base + k;
                    let mut acc = 0.0;
                    for m in 0..n {
                        let s = xi - li + (m as f64 + 0.5) * (2.0 * li / n as f64);
                        acc += hat(s - node as f64);
                    }
                    let avg = acc / n as f64;
                    let (cw, cg) = weight_at(ShapeKind::UGimp, xi, li, node);
                    assert!(
                        (cw - avg).abs() < 1e-6,
                        "xi={xi} li={li} node={node}: {cw} vs {avg}"
                    );
                    // The derivative of an average over [xi-l, xi+l] is the
                    // difference of the end values over the length.
                    let dg = (hat(xi + li - node as f64) - hat(xi - li - node as f64)) / (2.0 * li);
                    assert!(
                        (cg - dg).abs() < 1e-12,
                        "gradient xi={xi} li={li} node={node}"
                    );
                }
            }
        }
    }

    #[test]
    fn gimp_gradient_continuous_mpm_gradient_jumps() {
        let eps = 1e-11;
        for &li in &SIZES {
            // Cell boundaries (nodes), stencil switches (cell centres) and the
            // region boundaries |d| = l, 1 - l, 1 + l around node 2.
            let mut pts: Vec<f64> = vec![];
            for k in 0..4 {
                pts.push(k as f64);
                pts.push(k as f64 + 0.5);
            }
            for d in [li, 1.0 - li, 1.0 + li] {
                pts.push(2.0 + d);
                pts.push(2.0 - d);
            }
            for &x in &pts {
                for node in -1..6 {
                    let (wl, gl) = weight_at(ShapeKind::UGimp, x - eps, li, node);
                    let (wr, gr) = weight_at(ShapeKind::UGimp, x + eps, li, node);
                    assert!(
                        (gl - gr).abs() < 1e-9,
                        "li={li} x={x} node={node}: {gl} vs {gr}"
                    );
                    assert!((wl - wr).abs() < 1e-9);
                }
            }
        }
        // MPM: crossing node 2 flips the slope of node 2 from +1 to -1.
        let (_, gl) = weight_at(ShapeKind::Mpm, 2.0 - eps, 0.25, 2);
        let (_, gr) = weight_at(ShapeKind::Mpm, 2.0 + eps, 0.25, 2);
        assert!((gl - gr).abs() > 1.9, "MPM gradient jump {gl} -> {gr}");
        // ... while its weights stay continuous there and at the stencil switch.
        for x in [2.0, 2.5] {
            for node in 0..5 {
                let (wl, _) = weight_at(ShapeKind::Mpm, x - eps, 0.25, node);
                let (wr, _) = weight_at(ShapeKind::Mpm, x + eps, 0.25, node);
                assert!((wl - wr).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn linear_fields_reproduced() {
        for &xi in &probe_positions() {
            for kind in [ShapeKind::Mpm, ShapeKind::UGimp] {
                for &li in &SIZES {
                    let w = weights_1d(kind, xi, li);
                    let mut m = 0.0;
                    let mut dm = 0.0;
                    for k in 0..3 {
                        let xn = (w.base + k as i64) as f64;
                        m += w.w[k] * xn;
                        dm += w.g[k] * xn;
                    }
                    assert!((m - xi).abs() < 1e-12, "{kind:?} xi={xi}: {m}");
                    assert!((dm - 1.0).abs() < 1e-12, "{kind:?} xi={xi}: gradient {dm}");
                }
            }
        }
    }

    #[test]
    fn gimp_tends_to_mpm_for_point_particles() {
        for &xi in &probe_positions() {
            let a = weights_1d(ShapeKind::UGimp, xi, 0.0);
            let b = weights_1d(ShapeKind::Mpm, xi, 0.0);
            assert_eq!(a.base, b.base);
            for k in 0..3 {
                assert!((a.w[k] - b.w[k]).abs() < 1e-15);
            }
            let c = weights_1d(ShapeKind::UGimp, xi, 1e-7);
            for k in 0..3 {
                assert!((c.w[k] - b.w[k]).abs() < 1e-7);
            }
        }
    }

    #[test]
    fn cpgimp_half_lengths_follow_stretch_and_clamp() {
        let h = 0.1;
        // A stretch along the axes: lp0 F_ii.
        let (lx, ly) = cpgimp_half_lengths(0.025, 0.025, [1.2, 0.0, 0.0, 0.9], h);
        assert!((lx - 0.03).abs() < 1e-15 && (ly - 0.0225).abs() < 1e-15);
        // Beyond half a cell: clamped.
        let (lx, ly) = cpgimp_half_lengths(0.025, 0.025, [3.0, 0.0, 0.0, 0.5], h);
        assert_eq!((lx, ly), (0.05, 0.0125));
        // A rigid rotation by any angle (a quarter turn included) keeps the
        // reference half-lengths; a rotated stretch keeps the stretched ones.
        for k in 0..16 {
            let t = k as f64 * std::f64::consts::PI / 8.0;
            let (c, s) = (t.cos(), t.sin());
            let (lx, ly) = cpgimp_half_lengths(0.025, 0.02, [c, -s, s, c], h);
            assert!((lx - 0.025).abs() < 1e-15 && (ly - 0.02).abs() < 1e-15);
            let (lx, ly) =
                cpgimp_half_lengths(0.025, 0.02, [1.2 * c, -0.9 * s, 1.2 * s, 0.9 * c], h);
            assert!((lx - 0.03).abs() < 1e-15 && (ly - 0.018).abs() < 1e-15);
        }
        // Simple shear F = [[1, g], [0, 1]]: the x fibre keeps its length,
        // the y fibre grows to √(1 + g²).
        let (lx, ly) = cpgimp_half_lengths(0.025, 0.025, [1.0, 0.75, 0.0, 1.0], h);
        assert!((lx - 0.025).abs() < 1e-15 && (ly - 0.03125).abs() < 1e-15);
    }
}
