//! Constitutive models, one particle at a time, in plane strain and (see
//! [`axi`]) in axisymmetry.
//!
//! * [`Material::LinearElastic`]: hypo-elastic Hooke law driven by the rate of
//!   deformation `D = sym(L)`, made objective with the **Jaumann** rate.
//!   Jaumann rather than Truesdell because it needs only the spin `W = skew(L)`
//!   (no `tr(D) σ` or `L σ` terms, so the stress increment is exactly `C:D Δt`
//!   in the co-rotated frame, which is what the small-strain checks and the
//!   FEM codes the paper compares against use), and because its spin
//!   integrates as a pure rotation. In 2D the spin is one angle rate
//!   `ω = (L_yx − L_xy)/2`; we apply half the step's rotation, add `C:D Δt`,
//!   and apply the other half (`σ⁺ = R_½ (R_½ σ R_½ᵀ + Δt C:D) R_½ᵀ`), with
//!   `R_½` the Cayley (Hughes–Winget) rotation `(I − W Δt/4)⁻¹ (I + W Δt/4)`:
//!   exactly orthogonal, so objective for any step size, second-order accurate
//!   in the angle (`2 atan(ω Δt / 4)` instead of `ω Δt / 2`), and free of
//!   trigonometric calls in the hot loop. (Its known defect, oscillating shear
//!   stress under very large simple shear, does not arise at the strains
//!   Gimlet's examples reach.) Plane strain: `D_zz = 0`, so
//!   `σ_zz` accumulates `λ tr(D) Δt` and does not rotate.
//! * [`Material::NeoHookean`]: compressible Neo-Hookean, hyper-elastic, from
//!   the deformation gradient: `σ = (μ/J)(B − I) + (λ ln J / J) I` with
//!   `B = F Fᵀ`, plane strain `F_zz = 1` (so `B_zz = 1` and
//!   `σ_zz = λ ln J / J`).
//! * [`Material::J2`]: rate-independent von Mises plasticity with isotropic
//!   hardening on the hypo-elastic Jaumann update (elastic trial, radial
//!   return), with the equivalent plastic strain as a particle state; see
//!   [`j2`].
//!
//! Lamé constants are the 3D ones, `λ = Eν/((1+ν)(1−2ν))`, `μ = E/(2(1+ν))`
//! (plane strain keeps them).
//!
//! **Modes.** Every law also has its axisymmetric form ([`axi`]), where the
//! out-of-plane component is the hoop component with a strain rate and a
//! stretch of its own. The kernel reaches either through
//! [`Constitutive::update_in`], monomorphised on the mode
//! ([`crate::mode::Mode`]); in plane strain that is [`Constitutive::update`]
//! itself.

use crate::error::{Error, Result};
use crate::mode::Mode;

pub mod axi;
pub mod j2;
pub use axi::Hoop;
pub use j2::{Hardening, J2Law};

/// A material law and its parameters (SI in the examples).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Material {
    /// Hypo-elastic linear elasticity with the Jaumann rate.
    LinearElastic {
        /// Young's modulus, > 0.
        e: f64,
        /// Poisson's ratio, in (−1, 0.5).
        nu: f64,
        /// Reference density, > 0.
        rho: f64,
    },
    /// Compressible Neo-Hookean hyper-elasticity.
    NeoHookean {
        /// Young's modulus (small-strain), > 0.
        e: f64,
        /// Poisson's ratio (small-strain), in (−1, 0.5).
        nu: f64,
        /// Reference density, > 0.
        rho: f64,
    },
    /// J2 (von Mises) plasticity with isotropic hardening on the
    /// hypo-elastic Jaumann law ([`j2`]).
    J2 {
        /// Young's modulus, > 0.
        e: f64,
        /// Poisson's ratio, in (−1, 0.5).
        nu: f64,
        /// Reference density, > 0.
        rho: f64,
        /// The flow stress as a function of the equivalent plastic strain.
        hardening: Hardening,
    },
}

/// Which law a [`MatParams`] describes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MatKind {
    /// See [`Material::LinearElastic`].
    LinearElastic,
    /// See [`Material::NeoHookean`].
    NeoHookean,
    /// See [`Material::J2`].
    J2,
}

/// Precomputed parameters of one material, as the kernel uses them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MatParams {
    /// The law.
    pub kind: MatKind,
    /// First Lamé constant.
    pub lambda: f64,
    /// Shear modulus.
    pub mu: f64,
    /// Reference density.
    pub rho0: f64,
    /// Young's modulus (for the energy of the linear law).
    pub e: f64,
    /// Poisson's ratio (for the energy of the linear law).
    pub nu: f64,
    /// The hardening of a J2 material; `None` for the laws that do not
    /// yield.
    pub hardening: Option<Hardening>,
}

/// In-plane Cauchy stress plus the plane-strain out-of-plane component.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Stress {
    /// σ_xx.
    pub xx: f64,
    /// σ_yy.
    pub yy: f64,
    /// σ_xy.
    pub xy: f64,
    /// σ_zz.
    pub zz: f64,
}

/// A general 2×2 tensor (velocity gradient or deformation gradient),
/// `xy` meaning row x, column y (`L_xy = ∂v_x/∂y`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tensor2 {
    /// Component xx.
    pub xx: f64,
    /// Component xy.
    pub xy: f64,
    /// Component yx.
    pub yx: f64,
    /// Component yy.
    pub yy: f64,
}

impl Tensor2 {
    /// The identity.
    pub const IDENTITY: Tensor2 = Tensor2 {
        xx: 1.0,
        xy: 0.0,
        yx: 0.0,
        yy: 1.0,
    };
    /// Determinant.
    #[inline(always)]
    pub fn det(&self) -> f64 {
        self.xx * self.yy - self.xy * self.yx
    }
}

impl Material {
    /// Checks the parameters: `E > 0`, `−1 < ν < 0.5`, `ρ > 0`, all finite,
    /// and for [`Material::J2`] the hardening's ([`Hardening::validate`]).
    pub fn validate(&self) -> Result<()> {
        use crate::limits::{MAG_MAX, MAG_MIN};
        let (e, nu, rho) = self.constants();
        if !(e.is_finite() && (MAG_MIN..=MAG_MAX).contains(&e)) {
            return Err(Error::arg(format!(
                "Young's modulus e = {} must be finite and between {MAG_MIN:e} and {MAG_MAX:e}",
                crate::limits::num(e)
            )));
        }
        if !(nu > -1.0 && nu < 0.5) {
            return Err(Error::arg(format!(
                "Poisson's ratio nu = {nu} must lie in (-1, 0.5)"
            )));
        }
        if !(rho.is_finite() && (MAG_MIN..=MAG_MAX).contains(&rho)) {
            return Err(Error::arg(format!(
                "density rho = {} must be finite and between {MAG_MIN:e} and {MAG_MAX:e}",
                crate::limits::num(rho)
            )));
        }
        // The P-wave speed sets the stable step: it must be finite and > 0
        // (always so within the windows above; checked to be sure).
        let (lambda, mu) = self.lame();
        let c = ((lambda + 2.0 * mu) / rho).sqrt();
        if !(c.is_finite() && c > 0.0) {
            return Err(Error::arg(format!(
                "e = {e}, nu = {nu} and rho = {rho} give the wave speed {c}, which must be finite and > 0"
            )));
        }
        if let Material::J2 { hardening, .. } = self {
            hardening.validate()?;
        }
        Ok(())
    }

    fn constants(&self) -> (f64, f64, f64) {
        match *self {
            Material::LinearElastic { e, nu, rho }
            | Material::NeoHookean { e, nu, rho }
            | Material::J2 { e, nu, rho, .. } => (e, nu, rho),
        }
    }

    /// Reference density.
    pub fn density(&self) -> f64 {
        self.constants().2
    }

    /// Lamé constants `(λ, μ)`.
    pub fn lame(&self) -> (f64, f64) {
        let (e, nu, _) = self.constants();
        (
            e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)),
            e / (2.0 * (1.0 + nu)),
        )
    }

    /// The kernel's parameter record.
    pub fn params(&self) -> MatParams {
        let (e, nu, rho0) = self.constants();
        let (lambda, mu) = self.lame();
        let (kind, hardening) = match *self {
            Material::LinearElastic { .. } => (MatKind::LinearElastic, None),
            Material::NeoHookean { .. } => (MatKind::NeoHookean, None),
            Material::J2 { hardening, .. } => (MatKind::J2, Some(hardening)),
        };
        MatParams {
            kind,
            lambda,
            mu,
            rho0,
            e,
            nu,
            hardening,
        }
    }

    /// Plane-strain P-wave speed at the current Jacobian `j` (see
    /// [`MatParams::p_wave_speed`]).
    pub fn p_wave_speed(&self, j: f64) -> f64 {
        self.params().p_wave_speed(j)
    }
}

impl MatParams {
    /// Plane-strain P-wave speed at Jacobian `j`.
    ///
    /// Linear elastic and J2 (its elastic speed; plasticity only softens):
    /// `√((λ+2μ)/ρ)` with the current density `ρ = ρ0/J` (the time step of
    /// `docs/method.md`). Neo-Hookean: the tangent P-wave modulus of the
    /// isotropically stretched state, `(λ + 2μ − 2λ ln J)/J`, over the current
    /// density, but never below the reference speed (so tension does not
    /// under-estimate the speed the stress stiffening adds):
    /// `c² = max(λ+2μ, λ+2μ−2λ ln J)/ρ0`. Returns 0 for `j <= 0` (the kernel
    /// reports an inverted particle before it asks).
    #[inline(always)]
    pub fn p_wave_speed(&self, j: f64) -> f64 {
        let m = self.lambda + 2.0 * self.mu;
        match self.kind {
            MatKind::LinearElastic | MatKind::J2 => (m * j.max(0.0) / self.rho0).sqrt(),
            MatKind::NeoHookean => {
                let lnj = if j > 0.0 { crate::ln::ln(j) } else { 0.0 };
                (m.max(m - 2.0 * self.lambda * lnj) / self.rho0).sqrt()
            }
        }
    }

    /// Stress after one step: the hypo-elastic update from the old stress, the
    /// velocity gradient `l` and `dt`, or the hyper-elastic stress at the new
    /// deformation gradient `f_new`, or the J2 update (which also advances
    /// the equivalent plastic strain `eps_p`; the elastic laws leave it).
    #[inline(always)]
    pub fn update_stress(
        &self,
        s: Stress,
        l: &Tensor2,
        dt: f64,
        f_new: &Tensor2,
        eps_p: &mut f64,
    ) -> Stress {
        match self.kind {
            MatKind::LinearElastic => hypo_elastic_jaumann(self.lambda, self.mu, s, l, dt),
            MatKind::NeoHookean => neo_hookean_stress(self.lambda, self.mu, f_new),
            MatKind::J2 => j2::j2_update(self, s, l, dt, eps_p),
        }
    }

    /// Elastic strain energy of one particle (reference volume `vol0`).
    ///
    /// Linear elastic and J2 (the stored elastic energy; the plastic work
    /// is dissipated): the complementary energy `½ σ:C⁻¹:σ` times the
    /// current volume `J vol0`. For a linear law it equals `½ σ:ε V`, needs no extra
    /// particle state and is invariant under rotations (unlike a small-strain
    /// `ε` computed from `F`). Neo-Hookean: the stored energy
    /// `μ/2 (tr C − 3) − μ ln J + λ/2 (ln J)²` (with `C_zz = 1`) times `vol0`.
    pub fn strain_energy(&self, s: &Stress, f: &Tensor2, vol0: f64) -> f64 {
        let j = f.det();
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
                let trc = f.xx * f.xx + f.xy * f.xy + f.yx * f.yx + f.yy * f.yy + 1.0;
                let lnj = crate::ln::ln(j);
                (0.5 * self.mu * (trc - 3.0) - self.mu * lnj + 0.5 * self.lambda * lnj * lnj) * vol0
            }
        }
    }
}

/// Rotates a symmetric in-plane stress by angle `theta` (`R σ Rᵀ`, `R` the
/// counter-clockwise rotation); `zz` is unchanged.
#[inline]
pub fn rotate_stress(s: Stress, theta: f64) -> Stress {
    let (sn, cs) = theta.sin_cos();
    rotate_stress_cs(s, cs, sn)
}

/// [`rotate_stress`] given the rotation's cosine and sine.
#[inline(always)]
pub fn rotate_stress_cs(s: Stress, cs: f64, sn: f64) -> Stress {
    let (c2, s2, cs2) = (cs * cs, sn * sn, cs * sn);
    Stress {
        xx: c2 * s.xx - 2.0 * cs2 * s.xy + s2 * s.yy,
        yy: s2 * s.xx + 2.0 * cs2 * s.xy + c2 * s.yy,
        xy: cs2 * (s.xx - s.yy) + (c2 - s2) * s.xy,
        zz: s.zz,
    }
}

/// Hypo-elastic plane-strain Hooke law with the Jaumann rate (see the module
/// notes): half rotation, `C:D Δt`, half rotation.
#[inline(always)]
pub fn hypo_elastic_jaumann(lambda: f64, mu: f64, s: Stress, l: &Tensor2, dt: f64) -> Stress {
    let dxx = l.xx * dt;
    let dyy = l.yy * dt;
    let dxy = 0.5 * (l.xy + l.yx) * dt;
    // Cayley rotation by ~ω dt / 2: tan(angle/2) = a = ω dt / 4.
    let a = 0.125 * (l.yx - l.xy) * dt;
    let inv = 1.0 / (1.0 + a * a);
    let (cs, sn) = ((1.0 - a * a) * inv, 2.0 * a * inv);
    let tr = dxx + dyy;
    let r = rotate_stress_cs(s, cs, sn);
    let inc = Stress {
        xx: r.xx + lambda * tr + 2.0 * mu * dxx,
        yy: r.yy + lambda * tr + 2.0 * mu * dyy,
        xy: r.xy + 2.0 * mu * dxy,
        zz: r.zz + lambda * tr,
    };
    rotate_stress_cs(inc, cs, sn)
}

/// Compressible Neo-Hookean Cauchy stress in plane strain:
/// `σ = (μ/J)(B − I) + (λ ln J / J) I`, `B = F Fᵀ`, `B_zz = 1`.
/// Non-finite (NaN) when `J <= 0`.
#[inline(always)]
pub fn neo_hookean_stress(lambda: f64, mu: f64, f: &Tensor2) -> Stress {
    let j = f.det();
    let inv_j = 1.0 / j;
    let lnj = crate::ln::ln(j);
    let bxx = f.xx * f.xx + f.xy * f.xy;
    let byy = f.yx * f.yx + f.yy * f.yy;
    let bxy = f.xx * f.yx + f.xy * f.yy;
    let p = lambda * lnj * inv_j;
    Stress {
        xx: mu * inv_j * (bxx - 1.0) + p,
        yy: mu * inv_j * (byy - 1.0) + p,
        xy: mu * inv_j * bxy,
        zz: p,
    }
}

/// A constitutive law as a type, so the kernel can be monomorphized on it:
/// with one law on a patch there is no branch on the law per particle.
pub trait Constitutive {
    /// See [`MatParams::update_stress`]. `state` is the particle's
    /// equivalent plastic strain when [`Constitutive::HAS_STATE`], a
    /// scratch value otherwise (laws without state ignore it).
    fn update(
        p: &MatParams,
        s: Stress,
        l: &Tensor2,
        dt: f64,
        f_new: &Tensor2,
        state: &mut f64,
    ) -> Stress;
    /// The law's update in the axisymmetric mode (see [`axi`]): as
    /// [`Constitutive::update`], with the hoop rate `hoop.rate` (`L_θθ`)
    /// and the hoop stretch after the step `hoop.f` (`F_θθ`) as the third
    /// normal component; `s.zz` and the result's `zz` are `σ_θθ`.
    fn update_axi(
        p: &MatParams,
        s: Stress,
        l: &Tensor2,
        hoop: Hoop,
        dt: f64,
        f_new: &Tensor2,
        state: &mut f64,
    ) -> Stress;
    /// The update in the mode `G`, chosen at compile time:
    /// [`Constitutive::update`] in plane strain (`hoop` is not read: the
    /// same operations and bits as calling it directly), and
    /// [`Constitutive::update_axi`] in axisymmetry.
    #[inline(always)]
    fn update_in<G: Mode>(
        p: &MatParams,
        s: Stress,
        l: &Tensor2,
        hoop: Hoop,
        dt: f64,
        f_new: &Tensor2,
        state: &mut f64,
    ) -> Stress {
        if G::AXISYMMETRIC {
            Self::update_axi(p, s, l, hoop, dt, f_new, state)
        } else {
            Self::update(p, s, l, dt, f_new, state)
        }
    }
    /// See [`MatParams::p_wave_speed`]. `j` is the 3D Jacobian (in
    /// axisymmetry `det(F_rz) F_θθ`, [`axi::jacobian`]): the same speed
    /// formula serves both modes.
    fn wave_speed(p: &MatParams, j: f64) -> f64;
    /// The stress is a function of the new deformation gradient alone
    /// (`update` ignores the old stress, `L` and `dt`): the kernel then
    /// evaluates it, and the wave speed, for a block of particles at once,
    /// in vector instructions.
    const FROM_F: bool = false;
    /// The law reads and writes a per-particle state (the equivalent
    /// plastic strain): the kernel passes the particle's own slot to
    /// `update`. Without it the kernel never touches that field, so the
    /// elastic laws' loops are what they were before the field existed.
    const HAS_STATE: bool = false;
    /// Some materials of the law flow at constant volume (J2 plasticity)
    /// and take the nodal average of the dilatation instead of their own
    /// ([`Constitutive::nodal_dilatation`]). Without it the kernel never
    /// computes or reads that average.
    const NODAL_DILATATION: bool = false;
    /// Whether material `p` replaces the volumetric part of its velocity
    /// gradient by the nodal average of the dilatation: with 2 × 2
    /// particles per cell a bilinear velocity field cannot satisfy four
    /// incompressibility constraints per cell, and isochoric plastic flow
    /// locks (the flat punch's limit load came out 21 % high with cells
    /// a/8). Averaging the dilatation over the particles around each node
    /// (weighted by `S_ip V_p`) and interpolating it back leaves about one
    /// constraint per node, the B-bar / F-bar idea, while the deviatoric
    /// part stays at the particle.
    #[inline(always)]
    fn nodal_dilatation(_p: &MatParams) -> bool {
        Self::NODAL_DILATATION
    }
}

/// Every material on the patch is [`MatKind::LinearElastic`].
#[derive(Clone, Copy, Debug, Default)]
pub struct LinearElasticLaw;
/// Every material on the patch is [`MatKind::NeoHookean`].
#[derive(Clone, Copy, Debug, Default)]
pub struct NeoHookeanLaw;
/// Mixed laws: branches on the (small, predictable) kind tag per particle.
#[derive(Clone, Copy, Debug, Default)]
pub struct AnyLaw;

impl Constitutive for LinearElasticLaw {
    #[inline(always)]
    fn update(
        p: &MatParams,
        s: Stress,
        l: &Tensor2,
        dt: f64,
        _f: &Tensor2,
        _state: &mut f64,
    ) -> Stress {
        hypo_elastic_jaumann(p.lambda, p.mu, s, l, dt)
    }
    #[inline(always)]
    fn update_axi(
        p: &MatParams,
        s: Stress,
        l: &Tensor2,
        hoop: Hoop,
        dt: f64,
        _f: &Tensor2,
        _state: &mut f64,
    ) -> Stress {
        axi::hypo_elastic_jaumann_axi(p.lambda, p.mu, s, l, hoop.rate, dt)
    }
    #[inline(always)]
    fn wave_speed(p: &MatParams, j: f64) -> f64 {
        ((p.lambda + 2.0 * p.mu) * j.max(0.0) / p.rho0).sqrt()
    }
}

impl Constitutive for NeoHookeanLaw {
    const FROM_F: bool = true;
    #[inline(always)]
    fn update(
        p: &MatParams,
        _s: Stress,
        _l: &Tensor2,
        _dt: f64,
        f: &Tensor2,
        _state: &mut f64,
    ) -> Stress {
        neo_hookean_stress(p.lambda, p.mu, f)
    }
    #[inline(always)]
    fn update_axi(
        p: &MatParams,
        _s: Stress,
        _l: &Tensor2,
        hoop: Hoop,
        _dt: f64,
        f: &Tensor2,
        _state: &mut f64,
    ) -> Stress {
        axi::neo_hookean_stress_axi(p.lambda, p.mu, f, hoop.f)
    }
    /// [`MatParams::p_wave_speed`] for this law, without the branch on
    /// the kind (same operations, same bits).
    #[inline(always)]
    fn wave_speed(p: &MatParams, j: f64) -> f64 {
        let m = p.lambda + 2.0 * p.mu;
        let lnj = if j > 0.0 { crate::ln::ln(j) } else { 0.0 };
        (m.max(m - 2.0 * p.lambda * lnj) / p.rho0).sqrt()
    }
}

/// Mixed tables may hold J2 materials: the state is passed, and only the
/// J2 branch of the per-particle kind test reads or writes it.
impl Constitutive for AnyLaw {
    const HAS_STATE: bool = true;
    const NODAL_DILATATION: bool = true;
    #[inline(always)]
    fn nodal_dilatation(p: &MatParams) -> bool {
        p.kind == MatKind::J2
    }
    #[inline(always)]
    fn update(
        p: &MatParams,
        s: Stress,
        l: &Tensor2,
        dt: f64,
        f: &Tensor2,
        state: &mut f64,
    ) -> Stress {
        p.update_stress(s, l, dt, f, state)
    }
    #[inline(always)]
    fn update_axi(
        p: &MatParams,
        s: Stress,
        l: &Tensor2,
        hoop: Hoop,
        dt: f64,
        f: &Tensor2,
        state: &mut f64,
    ) -> Stress {
        p.update_stress_axi(s, l, hoop, dt, f, state)
    }
    #[inline(always)]
    fn wave_speed(p: &MatParams, j: f64) -> f64 {
        p.p_wave_speed(j)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const LIN: Material = Material::LinearElastic {
        e: 1.0e7,
        nu: 0.3,
        rho: 1000.0,
    };
    const NH: Material = Material::NeoHookean {
        e: 1.0e7,
        nu: 0.3,
        rho: 1000.0,
    };

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs().max(1e-300)
    }

    #[test]
    fn validation_names_parameter_and_bound() {
        assert!(LIN.validate().is_ok());
        let bad = [
            (
                Material::LinearElastic {
                    e: 0.0,
                    nu: 0.3,
                    rho: 1.0,
                },
                "e = 0",
            ),
            (
                Material::NeoHookean {
                    e: 1.0,
                    nu: 0.5,
                    rho: 1.0,
                },
                "nu = 0.5",
            ),
            (
                Material::NeoHookean {
                    e: 1.0,
                    nu: -1.0,
                    rho: 1.0,
                },
                "nu = -1",
            ),
            (
                Material::LinearElastic {
                    e: 1.0,
                    nu: 0.2,
                    rho: -2.0,
                },
                "rho = -2",
            ),
            (
                Material::LinearElastic {
                    e: f64::NAN,
                    nu: 0.2,
                    rho: 1.0,
                },
                "e = NaN",
            ),
        ];
        for (m, needle) in bad {
            let err = m.validate().unwrap_err();
            assert_eq!(err.status, crate::error::Status::InvalidArgument);
            assert!(err.msg.contains(needle), "{}", err.msg);
        }
    }

    #[test]
    fn lame_and_wave_speed() {
        let (l, m) = LIN.lame();
        assert!(rel(l, 1.0e7 * 0.3 / (1.3 * 0.4)) < 1e-14);
        assert!(rel(m, 1.0e7 / 2.6) < 1e-14);
        let c0 = ((l + 2.0 * m) / 1000.0).sqrt();
        assert!(rel(LIN.p_wave_speed(1.0), c0) < 1e-14);
        assert!(rel(NH.p_wave_speed(1.0), c0) < 1e-14);
        // current density: rho = rho0 / J
        assert!(rel(LIN.p_wave_speed(0.81), 0.9 * c0) < 1e-14);
        // Neo-Hookean stiffens in compression, never softens below c0
        assert!(NH.p_wave_speed(0.8) > c0 && rel(NH.p_wave_speed(1.3), c0) < 1e-14);
    }

    #[test]
    fn uniaxial_strain_matches_hooke() {
        let p = LIN.params();
        let rate = 1e-3;
        let dt = 0.1;
        let n = 1000; // total strain 1e-4
        let l = Tensor2 {
            xx: rate,
            xy: 0.0,
            yx: 0.0,
            yy: 0.0,
        };
        let mut s = Stress::default();
        for _ in 0..n {
            s = p.update_stress(s, &l, dt, &Tensor2::IDENTITY, &mut 0.0);
        }
        let eps = rate * dt * n as f64;
        assert!(rel(s.xx, (p.lambda + 2.0 * p.mu) * eps) < 1e-12);
        assert!(rel(s.yy, p.lambda * eps) < 1e-12);
        assert!(rel(s.zz, p.lambda * eps) < 1e-12);
        assert!(s.xy.abs() < 1e-12 * s.xx.abs());
        // plane strain: σ_zz = ν (σ_xx + σ_yy)
        assert!(rel(s.zz, p.nu * (s.xx + s.yy)) < 1e-12);
    }

    #[test]
    fn rigid_rotation_rotates_prestress() {
        let p = LIN.params();
        let s0 = Stress {
            xx: 3.0e5,
            yy: 1.0e5,
            xy: 0.5e5,
            zz: 1.2e5,
        };
        let n = 2000;
        let total = std::f64::consts::FRAC_PI_2;
        let dt = 1e-3;
        let w = total / (n as f64 * dt);
        let l = Tensor2 {
            xx: 0.0,
            xy: -w,
            yx: w,
            yy: 0.0,
        };
        let mut s = s0;
        let mut f = Tensor2::IDENTITY;
        for _ in 0..n {
            // F_new = (I + dt L) F, as the kernel does
            f = Tensor2 {
                xx: f.xx + dt * (l.xx * f.xx + l.xy * f.yx),
                xy: f.xy + dt * (l.xx * f.xy + l.xy * f.yy),
                yx: f.yx + dt * (l.yx * f.xx + l.yy * f.yx),
                yy: f.yy + dt * (l.yx * f.xy + l.yy * f.yy),
            };
            s = p.update_stress(s, &l, dt, &f, &mut 0.0);
        }
        // rotated by +90°: xx <- yy, yy <- xx, xy <- -xy, zz unchanged
        let scale = 3.0e5;
        assert!((s.xx - s0.yy).abs() < 1e-6 * scale, "{s:?}");
        assert!((s.yy - s0.xx).abs() < 1e-6 * scale, "{s:?}");
        assert!((s.xy + s0.xy).abs() < 1e-6 * scale, "{s:?}");
        assert!((s.zz - s0.zz).abs() < 1e-6 * scale, "{s:?}");
        // Coarse steps (10 × 9°): the update is still an exact rotation, so
        // the invariants (trace, determinant) are kept to round-off.
        let mut s = s0;
        let dt = 1.0;
        let w = total / 10.0;
        let l = Tensor2 {
            xx: 0.0,
            xy: -w,
            yx: w,
            yy: 0.0,
        };
        for _ in 0..10 {
            s = p.update_stress(s, &l, dt, &Tensor2::IDENTITY, &mut 0.0);
        }
        let det = |s: &Stress| s.xx * s.yy - s.xy * s.xy;
        assert!((s.xx + s.yy - s0.xx - s0.yy).abs() < 1e-12 * scale);
        assert!((det(&s) - det(&s0)).abs() < 1e-12 * scale * scale);
        assert!(s.xy.abs() > 1e3, "a rotated state, not the original: {s:?}");
    }

    #[test]
    fn neo_hookean_is_objective() {
        let p = NH.params();
        let f0 = Tensor2 {
            xx: 1.02,
            xy: 0.01,
            yx: -0.005,
            yy: 0.97,
        };
        let s0 = p.update_stress(Stress::default(), &f0, 0.0, &f0, &mut 0.0);
        let th: f64 = 0.7;
        let (sn, c) = th.sin_cos();
        let f = Tensor2 {
            xx: c * f0.xx - sn * f0.yx,
            xy: c * f0.xy - sn * f0.yy,
            yx: sn * f0.xx + c * f0.yx,
            yy: sn * f0.xy + c * f0.yy,
        };
        let s = p.update_stress(Stress::default(), &f, 0.0, &f, &mut 0.0);
        let r = rotate_stress(s0, th);
        let scale = s0.xx.abs().max(s0.yy.abs());
        for (a, b) in [(s.xx, r.xx), (s.yy, r.yy), (s.xy, r.xy), (s.zz, r.zz)] {
            assert!((a - b).abs() < 1e-9 * scale);
        }
    }

    #[test]
    fn neo_hookean_matches_hooke_to_second_order() {
        let p = NH.params();
        let diff = |eps: f64| {
            // a general small symmetric strain
            let (exx, eyy, exy) = (eps, -0.4 * eps, 0.7 * eps);
            let f = Tensor2 {
                xx: 1.0 + exx,
                xy: exy,
                yx: exy,
                yy: 1.0 + eyy,
            };
            let s = neo_hookean_stress(p.lambda, p.mu, &f);
            let tr = exx + eyy;
            let lin = Stress {
                xx: p.lambda * tr + 2.0 * p.mu * exx,
                yy: p.lambda * tr + 2.0 * p.mu * eyy,
                xy: 2.0 * p.mu * exy,
                zz: p.lambda * tr,
            };
            [s.xx - lin.xx, s.yy - lin.yy, s.xy - lin.xy, s.zz - lin.zz]
                .iter()
                .fold(0.0f64, |a, &b| a.max(b.abs()))
        };
        let (d3, d4) = (diff(1e-3), diff(1e-4));
        // O(strain²): the difference is a modest multiple of E ε² and drops by
        // ~100 when ε drops by 10.
        assert!(d3 < 5.0 * 1e7 * 1e-6, "d3 = {d3}");
        let ratio = d3 / d4;
        assert!(ratio > 80.0 && ratio < 120.0, "ratio = {ratio}");
        // plane strain σ_zz = λ ln J / J
        let f = Tensor2 {
            xx: 1.1,
            xy: 0.0,
            yx: 0.0,
            yy: 0.95,
        };
        let s = neo_hookean_stress(p.lambda, p.mu, &f);
        let j: f64 = 1.1 * 0.95;
        assert!(rel(s.zz, p.lambda * j.ln() / j) < 1e-14);
        // inverted: non-finite
        let f = Tensor2 {
            xx: -0.1,
            xy: 0.0,
            yx: 0.0,
            yy: 1.0,
        };
        assert!(!neo_hookean_stress(p.lambda, p.mu, &f).xx.is_finite());
    }

    #[test]
    fn strain_energy_equals_half_stress_strain() {
        // Uniaxial strain eps: W = ½ (λ+2μ) eps² V for both laws at small strain.
        let eps = 1e-4;
        let vol0 = 2.0;
        for m in [LIN, NH] {
            let p = m.params();
            let f = Tensor2 {
                xx: 1.0 + eps,
                xy: 0.0,
                yx: 0.0,
                yy: 1.0,
            };
            let s = match p.kind {
                MatKind::LinearElastic => Stress {
                    xx: (p.lambda + 2.0 * p.mu) * eps,
                    yy: p.lambda * eps,
                    xy: 0.0,
                    zz: p.lambda * eps,
                },
                MatKind::NeoHookean => neo_hookean_stress(p.lambda, p.mu, &f),
                MatKind::J2 => unreachable!("elastic laws only"),
            };
            let w = p.strain_energy(&s, &f, vol0);
            let expect = 0.5 * (p.lambda + 2.0 * p.mu) * eps * eps * vol0;
            assert!(rel(w, expect) < 5e-4, "{:?}: {w} vs {expect}", p.kind);
        }
    }
}
