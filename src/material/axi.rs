//! The laws in the axisymmetric mode, and the kinematics of the two modes.
//!
//! In axisymmetry (x the radius r, y the axis z, θ the hoop direction) the
//! deformation is torsion-free: the velocity gradient and the deformation
//! gradient are block-diagonal, an in-plane 2×2 block ([`Tensor2`]: rr, rz,
//! zr, zz) and a hoop component,
//!
//! ```text
//! L = [ L_rr L_rz  0   ]      F = [ F_rr F_rz  0   ]
//!     [ L_zr L_zz  0   ]          [ F_zr F_zz  0   ]
//!     [ 0    0    L_θθ ]          [ 0    0    F_θθ ]
//! ```
//!
//! with `L_θθ = v_r / r` (the hoop rate, [`Hoop::rate`]) and `F_θθ = r/R`
//! (the hoop stretch, [`Hoop::f`]). The spin has only the in-plane
//! component, so the stress's θθ component never rotates. The four stress
//! components of [`Stress`] are `σ_rr, σ_zz, σ_rz` and, in the slot that
//! holds `σ_zz` in plane strain, `σ_θθ`. Compared with plane strain, where
//! `D_zz = 0` and `F_zz = 1`, each law changes only where the third normal
//! component enters:
//!
//! * **linear elastic** (hypo-elastic, Jaumann, [`hypo_elastic_jaumann_axi`]):
//!   `tr D = D_rr + D_zz + L_θθ`, and `σ_θθ` gains `λ tr D Δt + 2μ L_θθ Δt`
//!   (plane strain: `λ tr D Δt`);
//! * **Neo-Hookean** ([`neo_hookean_stress_axi`]): `J = det(F_rz) F_θθ`,
//!   `B_θθ = F_θθ²`, so `σ_θθ = (μ/J)(F_θθ² − 1) + λ ln J / J`;
//! * **J2** ([`super::j2::j2_update_axi`]): the elastic trial above, then
//!   the same radial return on the 3D deviator of `(σ_rr, σ_zz, σ_rz,
//!   σ_θθ)`; `σ_θθ` has its own strain rate, where plane strain's `σ_zz`
//!   follows the constraint `D_zz = 0`.
//!
//! The laws take the mode as a type through
//! [`super::Constitutive::update_in`]: with [`crate::mode::PlaneStrain`] it is
//! [`super::Constitutive::update`] (the same bits; the hoop inputs are not
//! read), with [`Axisymmetric`] it is [`super::Constitutive::update_axi`].
//!
//! The kinematic helpers below are written once for both modes
//! (monomorphised on [`Mode`]); their plane-strain forms are the kernel's
//! expressions, operation for operation, so a kernel that switches to them
//! keeps its bits.

use super::{rotate_stress_cs, MatKind, MatParams, Stress, Tensor2};
use crate::mode::{Axisymmetric, Mode};

/// The hoop kinematics of one particle in one step (axisymmetric mode).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hoop {
    /// The hoop rate `L_θθ = v_r / r` of the step, `Σ_i v_ir T_ip` (1/s).
    pub rate: f64,
    /// The hoop stretch `F_θθ` after the step.
    pub f: f64,
}

impl Hoop {
    /// No hoop deformation (`L_θθ = 0`, `F_θθ = 1`): what plane strain
    /// would pass, and what the plane-strain update ignores anyway.
    pub const NONE: Hoop = Hoop { rate: 0.0, f: 1.0 };
}

/// Hypo-elastic Hooke law with the Jaumann rate in axisymmetry: as
/// [`super::hypo_elastic_jaumann`] (half rotation, `C:D Δt`, half
/// rotation, in the r–z plane), with the hoop rate `l_tt` as the third
/// normal strain rate. `σ_θθ` (the `zz` slot) does not rotate.
#[inline(always)]
pub fn hypo_elastic_jaumann_axi(
    lambda: f64,
    mu: f64,
    s: Stress,
    l: &Tensor2,
    l_tt: f64,
    dt: f64,
) -> Stress {
    let dxx = l.xx * dt;
    let dyy = l.yy * dt;
    let dtt = l_tt * dt;
    let dxy = 0.5 * (l.xy + l.yx) * dt;
    let a = 0.125 * (l.yx - l.xy) * dt;
    let inv = 1.0 / (1.0 + a * a);
    let (cs, sn) = ((1.0 - a * a) * inv, 2.0 * a * inv);
    let tr = dxx + dyy + dtt;
    let r = rotate_stress_cs(s, cs, sn);
    let inc = Stress {
        xx: r.xx + lambda * tr + 2.0 * mu * dxx,
        yy: r.yy + lambda * tr + 2.0 * mu * dyy,
        xy: r.xy + 2.0 * mu * dxy,
        zz: r.zz + lambda * tr + 2.0 * mu * dtt,
    };
    rotate_stress_cs(inc, cs, sn)
}

/// Compressible Neo-Hookean Cauchy stress in axisymmetry:
/// `σ = (μ/J)(B − I) + (λ ln J / J) I` with `J = det(F_rz) F_θθ`,
/// `B = F Fᵀ`, `B_θθ = F_θθ²`; `zz` is `σ_θθ`. Non-finite when `J <= 0`.
#[inline(always)]
pub fn neo_hookean_stress_axi(lambda: f64, mu: f64, f: &Tensor2, f_tt: f64) -> Stress {
    let j = f.det() * f_tt;
    let inv_j = 1.0 / j;
    let lnj = crate::ln::ln(j);
    let bxx = f.xx * f.xx + f.xy * f.xy;
    let byy = f.yx * f.yx + f.yy * f.yy;
    let bxy = f.xx * f.yx + f.xy * f.yy;
    let btt = f_tt * f_tt;
    let p = lambda * lnj * inv_j;
    Stress {
        xx: mu * inv_j * (bxx - 1.0) + p,
        yy: mu * inv_j * (byy - 1.0) + p,
        xy: mu * inv_j * bxy,
        zz: mu * inv_j * (btt - 1.0) + p,
    }
}

/// The 3D Jacobian `J = det F`: `det(F_xy)` in plane strain (`F_zz = 1`),
/// `det(F_rz) F_θθ` in axisymmetry. The current volume is `J V_0` and the
/// density `ρ_0 / J` in both modes; the laws' wave speeds
/// ([`super::Constitutive::wave_speed`]) take this `J`.
#[inline(always)]
pub fn jacobian<G: Mode>(f: &Tensor2, f_tt: f64) -> f64 {
    if G::AXISYMMETRIC {
        f.det() * f_tt
    } else {
        f.det()
    }
}

/// The dilatation rate `tr D`: `L_xx + L_yy` in plane strain, `L_rr + L_zz
/// + L_θθ` in axisymmetry.
#[inline(always)]
pub fn dilatation<G: Mode>(l: &Tensor2, l_tt: f64) -> f64 {
    if G::AXISYMMETRIC {
        l.xx + l.yy + l_tt
    } else {
        l.xx + l.yy
    }
}

/// Replaces the dilatation of the rate `(l, l_tt)` by `dbar` (the nodal
/// average of the J2 laws, see
/// [`super::Constitutive::nodal_dilatation`]), keeping the deviatoric
/// part: plane strain adds half the difference to the two in-plane normal
/// rates (`D_zz` stays 0, as the kernel does); axisymmetry adds a third to
/// each of the three normal rates. `l_tt` is left alone in plane strain.
#[inline(always)]
pub fn replace_dilatation<G: Mode>(l: &mut Tensor2, l_tt: &mut f64, dbar: f64) {
    if G::AXISYMMETRIC {
        let c = (dbar - (l.xx + l.yy + *l_tt)) * (1.0 / 3.0);
        l.xx += c;
        l.yy += c;
        *l_tt += c;
    } else {
        let c = 0.5 * (dbar - (l.xx + l.yy));
        l.xx += c;
        l.yy += c;
    }
}

/// The square of the step's strain increment `|D| Δt` (the kernel's
/// runaway test): `Δt² (D_xx² + D_yy² + 2 D_xy²)` in plane strain, plus
/// `L_θθ²` in axisymmetry.
#[inline(always)]
pub fn strain_increment2<G: Mode>(l: &Tensor2, l_tt: f64, dt: f64) -> f64 {
    let dxy = 0.5 * (l.xy + l.yx);
    if G::AXISYMMETRIC {
        dt * dt * (l.xx * l.xx + l.yy * l.yy + l_tt * l_tt + 2.0 * dxy * dxy)
    } else {
        dt * dt * (l.xx * l.xx + l.yy * l.yy + 2.0 * dxy * dxy)
    }
}

/// The hoop stretch after a step, `F_θθ (1 + Δt L_θθ)`: the θθ row of the
/// kernel's update `F ← (I + Δt L) F`. For a homogeneous radial motion
/// `v_r = ε̇ R` (constant in time), `L_θθ = ε̇ R / r` taken at the start of
/// each step, it gives `F_θθ = r/R` exactly.
#[inline(always)]
pub fn advance_hoop(f_tt: f64, l_tt: f64, dt: f64) -> f64 {
    f_tt + dt * (l_tt * f_tt)
}

/// The hoop stretch after a step of the affine transfer's objective update
/// `F ← (I − Δt/2 L)⁻¹ (I + Δt/2 L) F` (its θθ component).
#[inline(always)]
pub fn advance_hoop_midpoint(f_tt: f64, l_tt: f64, dt: f64) -> f64 {
    let k = 0.5 * dt;
    f_tt * ((1.0 + k * l_tt) / (1.0 - k * l_tt))
}

impl MatParams {
    /// [`MatParams::update_stress`] in the axisymmetric mode: the hoop rate
    /// `hoop.rate` and the new hoop stretch `hoop.f` enter as the third
    /// normal component; `s.zz` is `σ_θθ`.
    #[inline(always)]
    pub fn update_stress_axi(
        &self,
        s: Stress,
        l: &Tensor2,
        hoop: Hoop,
        dt: f64,
        f_new: &Tensor2,
        eps_p: &mut f64,
    ) -> Stress {
        match self.kind {
            MatKind::LinearElastic => {
                hypo_elastic_jaumann_axi(self.lambda, self.mu, s, l, hoop.rate, dt)
            }
            MatKind::NeoHookean => neo_hookean_stress_axi(self.lambda, self.mu, f_new, hoop.f),
            MatKind::J2 => super::j2::j2_update_axi(self, s, l, hoop.rate, dt, eps_p),
        }
    }

    /// [`MatParams::strain_energy`] in either mode: with [`crate::mode::PlaneStrain`]
    /// that function itself (`f_tt` unread); with [`Axisymmetric`] the
    /// complementary energy `½ σ:C⁻¹:σ` (with `σ_θθ`) times `J V_0`, `J`
    /// the 3D Jacobian, for the linear law and J2, and the stored energy
    /// `μ/2 (tr C − 3) − μ ln J + λ/2 (ln J)²` with `C_θθ = F_θθ²` times
    /// `V_0` for Neo-Hookean. Per radian when `vol0` is.
    pub fn strain_energy_in<G: Mode>(&self, s: &Stress, f: &Tensor2, f_tt: f64, vol0: f64) -> f64 {
        if !G::AXISYMMETRIC {
            return self.strain_energy(s, f, vol0);
        }
        let j = jacobian::<Axisymmetric>(f, f_tt);
        match self.kind {
            MatKind::LinearElastic | MatKind::J2 => {
                let (e, nu) = (self.e, self.nu);
                let w = ((s.xx * s.xx + s.yy * s.yy + s.zz * s.zz)
                    - 2.0 * nu * (s.xx * s.yy + s.yy * s.zz + s.zz * s.xx))
                    / (2.0 * e)
                    + s.xy * s.xy / (2.0 * self.mu);
                w * j * vol0
            }
            MatKind::NeoHookean => {
                let trc = f.xx * f.xx + f.xy * f.xy + f.yx * f.yx + f.yy * f.yy + f_tt * f_tt;
                let lnj = crate::ln::ln(j);
                (0.5 * self.mu * (trc - 3.0) - self.mu * lnj + 0.5 * self.lambda * lnj * lnj) * vol0
            }
        }
    }
}

#[cfg(test)]
mod tests;
