//! r-weighted weights for the axisymmetric mode (x is the radius r, y the
//! axis z): linear MPM, uGIMP and cpGIMP along the radial axis.
//!
//! # What a particle sees
//!
//! In axisymmetry every particle quantity is per radian: a particle whose
//! domain is the rectangle `Ω_p = [r_p − l_r, r_p + l_r] × [z_p − l_z,
//! z_p + l_z]` (area `A_p = 4 l_r l_z`) has the volume `V_p = ∫_Ω r dA =
//! A_p r_p` and the mass `ρ A_p r_p`. The node weights are averages over
//! that volume (Nairn & Guilkey, IJNME 101, 2015):
//!
//! * `S_ip = (1/V_p) ∫_Ω N_i r dA` — mass, momentum, and every particle →
//!   node transfer of a quantity that lives in the volume;
//! * `G_ip = (1/V_p) ∫_Ω ∇N_i r dA` — the velocity gradient and the
//!   internal force. It is **not** the derivative of `S_ip` with respect
//!   to the particle position (see below);
//! * `T_ip = (1/V_p) ∫_Ω N_i dA = S^plane_ip / r_p` — the hoop weight: the
//!   hoop rate `L_θθ = Σ_i v_ir T_ip` and the hoop force `σ_θθ V_p T_ip`.
//!
//! The node hat is a tensor product `N_i(r, z) = N_a(r) N_b(z)` and the
//! domain a rectangle, so the weights factor too. Along z nothing changes:
//! the plane weights `w^z_b`, `g^z_b` of [`super::GimpShape`] (or
//! [`super::MpmShape`]). Along r this module gives, per node `a`,
//!
//! ```text
//! S_a = (1/(2 l ρ_p)) ∫ N_a(ξ) ρ(ξ) dξ      (the r-weighted weight)
//! G_a = (1/(2 l ρ_p)) ∫ N_a'(ξ) ρ(ξ) dξ     (its gradient, d/dξ)
//! T_a = (1/(2 l ρ_p)) ∫ N_a(ξ) dξ = w_a/ρ_p (the hoop weight)
//! w_a = (1/(2 l)) ∫ N_a(ξ) dξ              (the plane weight)
//! ```
//!
//! over `[ξ_p − l, ξ_p + l]`, and the 2D weights are the products
//!
//! ```text
//! S_ab = S_a w_b      G_ab,r = G_a w_b      G_ab,z = S_a g_b      T_ab = T_a w_b
//! ```
//!
//! (the z-gradient takes the **r-weighted** `S_a`: `∫ N_a ∂N_b/∂z r dA`).
//!
//! # Units and conventions
//!
//! Cell units as in the rest of [`crate::shape`]: `ξ = (r − x0)/h`, `l =
//! lp/h`, node `i` at `ξ = i`. The radius enters through `ρ0 = x0/h`, the
//! radius of grid node 0 in cells (0 when the grid's origin is on the axis;
//! any real otherwise: nodes need not sit at multiples of `h` from the
//! axis), so that `ρ(ξ) = ρ0 + ξ` and `ρ_p = ρ0 + ξ_p = r_p/h`. `S` and `w`
//! are dimensionless; `G` is `d/dξ` and `T` is per cell — the caller
//! multiplies both by `1/h`, as for the plane gradients.
//!
//! # Closed forms
//!
//! Writing `ρ(ξ) = ρ_p + (ξ − ξ_p)` splits each weight into the plane one
//! and a correction divided by `ρ_p`:
//!
//! ```text
//! S_a = w_a + m_a/ρ_p     G_a = g_a + n_a/ρ_p     T_a = w_a/ρ_p
//! ```
//!
//! with the centred first moment `m_a = (1/(2l)) ∫ N_a(ξ) (ξ − ξ_p) dξ` and,
//! integrating `G` by parts, `n_a = (N_a(ξ_p + l) + N_a(ξ_p − l))/2 − w_a`
//! (the hat's mean at the domain's two ends minus its mean over the
//! domain). Both depend only on `d = ξ_p − a` and `l`, piecewise
//! polynomials in the regions of the plane weight (see [`super`]):
//!
//! | region             | `m_a`                       | `n_a`               |
//! |--------------------|-----------------------------|---------------------|
//! | `|d| < l`          | `−d l/2 + d³/(6l)`          | `(d² − l²)/(2l)`    |
//! | `l ≤ |d| ≤ 1 − l`  | `−sign(d) l²/3`             | `0`                 |
//! | `1−l < |d| < 1+l`  | `−sign(d) (l²/3) s²(3 − 2s)`| `l s (1 − s)`       |
//! | otherwise          | `0`                         | `0`                 |
//!
//! where `s = (1 + l − |d|)/(2l)` is the plane weight's `|slope|` in the
//! third region. Since that slope is 1 in the second region and 0 beyond
//! the support, the outer nodes of the stencil (at distance `e ≥ 1/2 ≥ l`)
//! take one formula in the three regions they can be in, `m = ∓ (l²/3)
//! s²(3 − 2s)`, `n = l s (1 − s)`, with the `s` the plane weight already
//! selected: no further branch, and no `1/l` (so `l = 0` is safe). The
//! middle node selects between the first two rows, as the plane weight
//! does.
//!
//! # Identities (exact, tested to round-off)
//!
//! With `ρ_i = ρ0 + i` the nodes' radii (cells):
//! * `Σ S_a = 1`, `Σ G_a = 0`, `Σ w_a = 1`;
//! * `Σ T_a ρ_a = 1` and `Σ G_a ρ_a = 1`: the homogeneous expansion `v_r =
//!   ε̇ r` gives `L_θθ = L_rr = ε̇` exactly, in every column including the
//!   first; more generally an affine field `v_r = α + β r + γ z` gives the
//!   exact particle averages `L_rr = β`, `L_rz = γ`, `L_θθ = (1/V_p) ∫ v_r
//!   dA = (α + β r_p + γ z_p)/r_p`;
//! * `Σ w_a ρ_a = ρ_p` (the plane weights put the domain's centre where it
//!   is), while `Σ S_a ρ_a = ρ_p + l²/(3ρ_p)`: the r-weighted weights
//!   reproduce the **r-weighted centroid** of the domain (where its mass
//!   is), not its centre. This matters for the position update and the
//!   affine transfers (see the integration notes below);
//! * `dS_a/dξ_p = G_a − m_a/ρ_p²`: the gradient is not the derivative of
//!   the weight;
//! * `|S_a − w_a| ≤ l²/(3ρ_p)`, `|G_a − g_a| ≤ l/(2ρ_p)`: far from the axis
//!   the weights tend to the plane ones; as `l → 0` they tend to the MPM
//!   ones (`S = N(ξ_p)`, `G = N'(ξ_p)`, `T = N(ξ_p)/ρ_p`), which is what
//!   [`AxiMpmShape`] evaluates.
//!
//! # The axis
//!
//! The particles lie at `r_p > 0`. A domain that reaches the axis
//! (`r_p ≤ lp`, e.g. the first column of a cell filled with 2 × 2
//! particles, where `r_p = lp` and the domain is `[0, 2lp]`) is treated by
//! **clamping the radial half-length to the radius**, `l = min(lp, r_p)`:
//! the grid sees the domain `[0, 2 r_p]`, centred where the particle is,
//! never across `r = 0`. With `r_p ≥ lp` — every particle a valid
//! insertion makes — the clamp is inactive and the weights are the exact
//! integrals above; a particle that later comes closer to the axis than
//! its half-length keeps every identity above (a partition of unity,
//! positive weights, exact affine strain rates) with a smaller domain, as
//! cpGIMP's clamp to `h/2` does on the other side. As `r_p → 0` the
//! weights tend to the MPM ones; `T` of the axis node grows like `1/r_p`,
//! but the axis node's radial velocity is zero (so it does not enter
//! `L_θθ`) and its hoop force `V_p σ_θθ T_ip = A_p σ_θθ w_ip` stays finite
//! (the `r_p` of the volume cancels). Consequences, tested:
//! * a node at negative radius gets exactly zero `S`, `G`, `T` (the hat of
//!   the node at `−h` ends on the axis, where the domain starts), for any
//!   `r_p` above the round-off of the node distances (`1 + r_p/h` must
//!   differ from 1: `r_p > ~1e-16 h`; below, its weight is `−r_p/(3h)`);
//! * the node on the axis gets a positive mass weight (its radial velocity
//!   is then set to zero by the axis condition);
//! * the weights are finite for any `r_p > 0` down to the smallest normal
//!   number. `r_p ≤ 0` is outside the mode's domain: the weights are not
//!   finite there, and the kernel must treat such a particle as having left
//!   the domain (`r > 0` is the test, not `r ≥ 0`).
//!
//! # Cost
//!
//! [`AxiGimpShape::eval_f`] is [`super::GimpShape::eval_f`] plus one
//! division (`1/ρ_p`, beside the `1/(2l)` both take), the axis clamp (one
//! `min`), and per node a few multiplications for `m`, `n` and three for
//! `S`, `G`, `T`, all branch-free selects as in the plane weights; the
//! benchmark `gimlet-bench-weights` measures it against the plane weights
//! (instructions per evaluation under callgrind, and time).
//!
//! # Integration notes (for the kernel, levels, contact, io and FFI)
//!
//! The mode is a type ([`crate::mode::Mode`]) fixed for a whole pass: the
//! kernel is monomorphised over it as over the shape and the law. Along r
//! the kernel evaluates an [`AxiShape1D`] (`AxiGimpShape` for uGIMP and
//! cpGIMP, `AxiMpmShape` for MPM) with `ρ0 = origin_x / h` (a constant of
//! the pass); along z the plane [`super::Shape1D`]. A block then holds per
//! lane `S_a, G_a, T_a` (and `w_a` where used) along r, `w_b, g_b` along z.
//!
//! * **p2g**: nodal mass `Σ S_ab m_p` and momentum `Σ S_ab m_p v_p` with the
//!   per-radian mass `m_p = ρ0 A_p0 r_p0` (constant in time). Internal force
//!   per radian, `V_p = J A_p0 r_p0` the current volume:
//!   `f_r = −V_p (σ_rr G_ab,r + σ_rz G_ab,z + σ_θθ T_ab)`,
//!   `f_z = −V_p (σ_rz G_ab,r + σ_zz G_ab,z)`. External forces (body force
//!   `m_p b S_ab`, tractions) per radian likewise.
//! * **grid update**: the nodes on the axis (`ρ_i = 0`) get `v_r = 0` (and
//!   zero radial force and momentum), as a roller face would; nodes at
//!   negative radius carry nothing (their weights are zero) and may sit in
//!   the ghost layer.
//! * **g2p**: `L_rr = Σ v_r G_r`, `L_rz = Σ v_r G_z`, `L_zr = Σ v_z G_r`,
//!   `L_zz = Σ v_z G_z` (times `1/h`), `L_θθ = Σ v_r T` (times `1/h`);
//!   `F_θθ ← F_θθ (1 + Δt L_θθ)` (or the midpoint form of the affine mode,
//!   [`crate::material::axi::advance_hoop`]), the 3D `J = det F_rz · F_θθ`,
//!   and the law's [`crate::material::Constitutive::update_in`] with the
//!   hoop rate and `F_θθ`. The particle velocity `Σ S v` (FLIP/PIC) is the
//!   mass-averaged one. The **position** of the domain's centre should move
//!   with `Σ w_a w_b v` (the velocity at `r_p`; exact for an affine
//!   field): `Σ S v` is the velocity at the r-weighted centroid, which lies
//!   `lp²/(3 r_p)` further out (a third of `r_p` in the first column), and
//!   would push the particles off the axis under a homogeneous expansion.
//! * **affine transfers (APIC, XPIC)**: with `S`, `Σ S_a (ρ_a − ρ_p) =
//!   l²/(3ρ_p) ≠ 0`; expand the affine field about the r-weighted centroid
//!   `ρ_p + l²/(3ρ_p)` (where `Σ S_a (ρ_a − ρ̄) = 0`) or correct the
//!   inertia tensor, and test that an affine velocity field survives a
//!   p2g–g2p round trip.
//! * **nodal dilatation (J2)**: the dilatation is `L_rr + L_zz + L_θθ` and
//!   the B-bar correction adds a third of the difference to each of the
//!   three normal rates ([`crate::material::axi::replace_dilatation`]).
//! * **cpGIMP**: the radial half-length is `lp0_r |F e_r|`, clamped to
//!   `h/2` ([`super::cpgimp_half_lengths`], unchanged) and, here, to `r_p`.
//! * **levels and copies**: nothing changes but the per-radian mass of a
//!   copy, which is the original's (the copy is the same material); the
//!   coarse level's weights are evaluated with its own `h` and `ρ0`.
//! * **contact and tractions**: the face integrals become `∫_face N_i r
//!   ds`. On a face along r (a top surface under the indenter) at fixed
//!   `z`, `∫ N_a(r) r dr` over `[r_p − l, r_p + l]` is `2 l r_p S_a`
//!   (cell units times `h²`): the r-weighted weight of this module times
//!   the face's per-radian length; on a face along z at radius `r_f` it is
//!   `r_f` times the plane integral. The indenter force is per radian
//!   inside, `2π` times that at the edge.
//! * **io and FFI**: `σ_θθ` is the stress's fourth component (the
//!   plane-strain `σ_zz` slot); `F_θθ` is a new particle field (1 in plane
//!   strain) to write, checkpoint and copy; whole-body figures (forces,
//!   energies) are `2π` times the per-radian sums, at the edge only.

use super::{base_of, pos, MpmShape, Shape1D};

/// r-weighted weights of one particle on the three nodes of the radial
/// axis, first node as a float (see the module notes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxiWeights1DF {
    /// Index of the first node of the stencil (`floor(xi + 1/2) − 1`), as
    /// for the plane weights.
    pub base: f64,
    /// r-weighted weights `S_a` of nodes `base, base+1, base+2`.
    pub s: [f64; 3],
    /// r-weighted gradients `G_a` (d/dxi, cell units).
    pub g: [f64; 3],
    /// Hoop weights `T_a = w_a / ρ_p` (per cell).
    pub t: [f64; 3],
    /// Plane weights `w_a` (of the clamped domain), for what moves with the
    /// domain's centre (the position update).
    pub w: [f64; 3],
}

/// [`AxiWeights1DF`] with the first node as an integer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxiWeights1D {
    /// Index of the first node of the stencil.
    pub base: i64,
    /// r-weighted weights `S_a`.
    pub s: [f64; 3],
    /// r-weighted gradients `G_a` (d/dxi).
    pub g: [f64; 3],
    /// Hoop weights `T_a` (per cell).
    pub t: [f64; 3],
    /// Plane weights `w_a`.
    pub w: [f64; 3],
}

/// A 1D r-weighted weight function along the radial axis, implemented by
/// zero-sized types so the kernel can be monomorphised on it (the
/// counterpart of [`Shape1D`]).
pub trait AxiShape1D {
    /// Weights of a particle at `xi` (cell units from grid node 0) with
    /// radial half-length `li` (cell units, clamped to `[0, 1/2]` and to
    /// the radius), on a grid whose node 0 lies at the radius `rho0` (cell
    /// units). The particle's radius `rho0 + xi` must be `> 0`.
    fn eval_f(xi: f64, li: f64, rho0: f64) -> AxiWeights1DF;

    /// [`AxiShape1D::eval_f`] with the first node as an integer.
    #[inline(always)]
    fn eval(xi: f64, li: f64, rho0: f64) -> AxiWeights1D {
        let f = Self::eval_f(xi, li, rho0);
        AxiWeights1D {
            base: f.base as i64,
            s: f.s,
            g: f.g,
            t: f.t,
            w: f.w,
        }
    }
}

/// r-weighted linear MPM: the particle is a point at `r_p`, so `S = N(ξ_p)`,
/// `G = N'(ξ_p)` (the plane MPM ones) and `T = N(ξ_p)/ρ_p`.
#[derive(Clone, Copy, Debug, Default)]
pub struct AxiMpmShape;

/// r-weighted GIMP (uGIMP and cpGIMP share it; the caller passes the
/// reference or the current radial half-length).
#[derive(Clone, Copy, Debug, Default)]
pub struct AxiGimpShape;

impl AxiShape1D for AxiMpmShape {
    #[inline(always)]
    fn eval_f(xi: f64, li: f64, rho0: f64) -> AxiWeights1DF {
        let inv_r = 1.0 / (rho0 + xi);
        let p = MpmShape::eval_f(xi, li);
        AxiWeights1DF {
            base: p.base,
            s: p.w,
            g: p.g,
            t: [p.w[0] * inv_r, p.w[1] * inv_r, p.w[2] * inv_r],
            w: p.w,
        }
    }
}

impl AxiShape1D for AxiGimpShape {
    #[inline(always)]
    fn eval_f(xi: f64, li: f64, rho0: f64) -> AxiWeights1DF {
        let rho = rho0 + xi;
        let inv_r = 1.0 / rho;
        // The axis clamp: the domain never reaches below r = 0. `pos`
        // keeps l >= 0 for a radius <= 0 (outside the mode's domain).
        let l = pos(li.clamp(0.0, 0.5).min(rho));
        let b = base_of(xi);
        let d0 = xi - b; // distance to node base, in [0.5, 1.5)
        let d1 = d0 - 1.0; // signed distance to node base+1, in [-0.5, 0.5)
        let e2 = 2.0 - d0; // distance to node base+2, in (0.5, 1.5]

        let h2 = 0.5 / l; // 1/(2l), used only where l > 0
        let lin = 1.0 - l;
        let l2_3 = l * l * (1.0 / 3.0);
        // Outer nodes (the particle on one side, at distance e >= 1/2 >=
        // l): the plane weight and |slope| s as in GimpShape, then from s
        // alone |m| = (l²/3) s² (3 − 2s) and n = l s (1 − s) (s = 1 in the
        // linear region, 0 beyond the support).
        #[inline(always)]
        fn outer(e: f64, l: f64, h2: f64, lin: f64, l2_3: f64) -> (f64, f64, f64, f64) {
            let r = pos((1.0 + l - e) * h2);
            let (w, s) = if e <= lin {
                (1.0 - e, 1.0)
            } else {
                (r * r * l, r)
            };
            let m = l2_3 * (s * s * (3.0 - 2.0 * s));
            let n = l * (s * (1.0 - s));
            (w, s, m, n)
        }
        let (w0, s0, m0, n0) = outer(d0, l, h2, lin, l2_3);
        let (w2, s2, m2, n2) = outer(e2, l, h2, lin, l2_3);
        let a1 = d1.abs();
        let inner = a1 < l;
        let w1 = if inner {
            1.0 - (d1 * d1 + l * l) * h2
        } else {
            1.0 - a1
        };
        let sign = if d1 > 0.0 { -1.0 } else { 1.0 };
        let g1 = if inner { -2.0 * d1 * h2 } else { sign };
        let m1 = if inner {
            -d1 * (0.5 * l - d1 * d1 * h2 * (1.0 / 3.0))
        } else {
            sign * l2_3
        };
        let n1 = if inner { (d1 * d1 - l * l) * h2 } else { 0.0 };
        // Node base has the particle to its right (m < 0), node base+2 to
        // its left (m > 0); n is even in the distance.
        AxiWeights1DF {
            base: b,
            s: [w0 - m0 * inv_r, w1 + m1 * inv_r, w2 + m2 * inv_r],
            g: [-s0 + n0 * inv_r, g1 + n1 * inv_r, s2 + n2 * inv_r],
            t: [w0 * inv_r, w1 * inv_r, w2 * inv_r],
            w: [w0, w1, w2],
        }
    }
}

/// Which r-weighted weight function a shape kind uses along r: MPM for
/// [`super::ShapeKind::Mpm`], GIMP for uGIMP and cpGIMP (the caller passes
/// the reference or the current half-length).
#[inline]
pub fn axi_weights_1d(kind: super::ShapeKind, xi: f64, li: f64, rho0: f64) -> AxiWeights1D {
    match kind {
        super::ShapeKind::Mpm => AxiMpmShape::eval(xi, li, rho0),
        super::ShapeKind::UGimp | super::ShapeKind::CpGimp => AxiGimpShape::eval(xi, li, rho0),
    }
}

/// r-weighted weights of one particle on its 3×3 node stencil.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxiWeights2D {
    /// First stencil node along r.
    pub br: i64,
    /// First stencil node along z.
    pub bz: i64,
    /// `S_ab` of node `(br + a, bz + b)` at index `a + 3 b`.
    pub s: [f64; 9],
    /// `G_ab,r` (d/dxi, cell units), same layout.
    pub gr: [f64; 9],
    /// `G_ab,z` (d/dyi, cell units), same layout.
    pub gz: [f64; 9],
    /// `T_ab` (per cell), same layout.
    pub t: [f64; 9],
}

/// 2D r-weighted weights: the r-weighted radial weights times the plane
/// axial ones (`S = S_a w_b`, `G_r = G_a w_b`, `G_z = S_a g_b`, `T = T_a
/// w_b`). `xi`, `yi` are cell units from grid node 0, whose radius is
/// `rho0` cells.
pub fn axi_weights_2d(
    kind: super::ShapeKind,
    xi: f64,
    yi: f64,
    lix: f64,
    liy: f64,
    rho0: f64,
) -> AxiWeights2D {
    let wr = axi_weights_1d(kind, xi, lix, rho0);
    let wz = super::weights_1d(kind, yi, liy);
    let mut out = AxiWeights2D {
        br: wr.base,
        bz: wz.base,
        s: [0.0; 9],
        gr: [0.0; 9],
        gz: [0.0; 9],
        t: [0.0; 9],
    };
    for b in 0..3 {
        for a in 0..3 {
            let k = a + 3 * b;
            out.s[k] = wr.s[a] * wz.w[b];
            out.gr[k] = wr.g[a] * wz.w[b];
            out.gz[k] = wr.s[a] * wz.g[b];
            out.t[k] = wr.t[a] * wz.w[b];
        }
    }
    out
}

#[cfg(test)]
mod tests;
