//! Rate-independent J2 (von Mises) plasticity with isotropic hardening, in
//! plane strain, on the hypo-elastic Jaumann update of
//! [`super::Material::LinearElastic`]. In axisymmetry ([`j2_update_axi`])
//! only the elastic trial changes: the fourth component is `σ_θθ`, driven
//! by the hoop rate, where plane strain's `σ_zz` follows `D_zz = 0`.
//!
//! One step of a particle:
//!
//! 1. **Elastic trial**: the stress of the linear elastic law after the
//!    step, `σ* = R_½ (R_½ σ R_½ᵀ + Δt C:D) R_½ᵀ` (Hughes–Winget half
//!    rotations; plane strain `D_zz = 0`, so `σ_zz` gains `λ tr(D) Δt`),
//!    see [`super::hypo_elastic_jaumann`].
//! 2. **Yield check** on the 3D deviator of `(σxx, σyy, σxy, σzz)`:
//!    `p = (σxx + σyy + σzz)/3`, `s = σ − p I`, von Mises
//!    `q = √(3/2 s:s)` with `s:s = sxx² + syy² + szz² + 2 sxy²`. Elastic
//!    when `q*² ≤ σ_y(ε_p)²` (squares: no square root, and for the power
//!    law no power either while `q* ≤ σ_0`, the smallest flow stress).
//! 3. **Radial return** otherwise: the plastic flow is normal to the von
//!    Mises cylinder and leaves `p` unchanged (plastic incompressibility),
//!    so the new deviator is the trial one scaled by `q/q*`, with the
//!    equivalent plastic strain increment `Δε_p` the root of
//!    `q* − 3μ Δε_p − σ_y(ε_p + Δε_p) = 0`. `σ_zz` is returned with the
//!    others (its deviator scales too): `D_zz = 0` is a total-strain
//!    constraint, the plastic part `D^p_zz = 3/2 Δε_p s_zz/q` is taken up by
//!    the elastic part.
//!
//! Returning after the second half rotation instead of between the halves
//! gives the same stress: the return scales the deviator, which commutes
//! with a rotation. Objectivity and the invariants under rigid rotation are
//! those of the elastic update (an exactly orthogonal rotation).
//!
//! Hardening ([`Hardening`]), `ε_p` the equivalent plastic strain (a
//! particle field, [`crate::particles::Particles::eps_p`]):
//! * linear, `σ_y(ε_p) = σ_y + h ε_p` (`h = 0`: perfectly plastic); the
//!   increment is closed-form, `Δε_p = (q* − σ_y(ε_p)) / (3μ + h)`;
//! * power law, `σ_y(ε_p) = σ_0 (1 + ε_p/ε_0)^n`, `0 ≤ n < 1`: the residual
//!   `g(x) = q* − 3μ x − σ_y(ε_p + x)` is convex and decreasing, positive at
//!   0 and non-positive at `x_max = (q* − σ_y(ε_p))/(3μ)`; a safeguarded
//!   Halley iteration (Newton's with the curvature, third order) keeps that
//!   bracket and falls back to Newton, then to bisection in
//!   `ln(ε_0 + ε_p + x)` (the scale on which a steep start — tiny `ε_0` —
//!   is resolved in a few halvings) whenever a step leaves the bracket or
//!   does not at least halve the previous one; it stops when the predicted
//!   error of a step, or the step itself, is at the round-off of `x`, so
//!   the returned stress is on the yield surface to round-off. In explicit
//!   steps that is one evaluation of the power after the first step (which
//!   needs none), so a yielding particle pays two powers with the yield
//!   check.
//!
//! The stable time step is the elastic one (P-wave speed of the linear law):
//! plasticity only softens.

use super::{hypo_elastic_jaumann, Constitutive, MatParams, Stress, Tensor2};
use crate::error::{Error, Result};

/// Isotropic hardening: the flow stress as a function of the equivalent
/// plastic strain `ε_p`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Hardening {
    /// `σ_y(ε_p) = sigma_y + h ε_p`.
    Linear {
        /// Initial yield stress (uniaxial), > 0.
        sigma_y: f64,
        /// Hardening modulus, ≥ 0 (0: perfectly plastic).
        h: f64,
    },
    /// `σ_y(ε_p) = sigma_0 (1 + ε_p / eps_0)^n`.
    Power {
        /// Initial yield stress (uniaxial), > 0.
        sigma_0: f64,
        /// Hardening exponent, in `[0, 1)`.
        n: f64,
        /// Reference strain, > 0.
        eps_0: f64,
    },
}

/// The result of the return's scalar equation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlasticIncrement {
    /// The equivalent plastic strain increment `Δε_p ≥ 0`.
    pub deps: f64,
    /// Evaluations of the flow stress the iteration needed (each one
    /// power; 0 for the closed form, and when the first step, from the
    /// known `σ_y(ε_p)`, is already converged).
    pub iterations: u32,
}

/// Most iterations of the power-law return (never reached in the tests:
/// bisection alone in a bracket of `2^k` orders of magnitude needs ~60).
const MAX_ITER: u32 = 200;

impl Hardening {
    /// Checks the parameters, naming the one out of bounds: `sigma_y > 0`
    /// and `h ≥ 0`, or `sigma_0 > 0`, `0 ≤ n < 1` and `eps_0 > 0`, all
    /// finite.
    pub fn validate(&self) -> Result<()> {
        let positive = |v: f64, name: &str| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(Error::arg(format!("{name} = {v} must be finite and > 0")))
            }
        };
        match *self {
            Hardening::Linear { sigma_y, h } => {
                positive(sigma_y, "yield stress sigma_y")?;
                if !(h.is_finite() && h >= 0.0) {
                    return Err(Error::arg(format!(
                        "hardening modulus h = {h} must be finite and >= 0"
                    )));
                }
            }
            Hardening::Power { sigma_0, n, eps_0 } => {
                positive(sigma_0, "yield stress sigma_0")?;
                if !(0.0..1.0).contains(&n) {
                    return Err(Error::arg(format!(
                        "hardening exponent n = {n} must lie in [0, 1)"
                    )));
                }
                positive(eps_0, "reference strain eps_0")?;
            }
        }
        Ok(())
    }

    /// The smallest flow stress, `σ_y(0)`.
    pub fn initial_yield(&self) -> f64 {
        match *self {
            Hardening::Linear { sigma_y, .. } => sigma_y,
            Hardening::Power { sigma_0, .. } => sigma_0,
        }
    }

    /// The flow stress `σ_y(ε_p)`.
    #[inline]
    pub fn flow_stress(&self, eps_p: f64) -> f64 {
        match *self {
            Hardening::Linear { sigma_y, h } => sigma_y + h * eps_p,
            Hardening::Power { sigma_0, n, eps_0 } => sigma_0 * (1.0 + eps_p / eps_0).powf(n),
        }
    }

    /// The hardening slope `dσ_y/dε_p` at `ε_p`.
    #[inline]
    pub fn slope(&self, eps_p: f64) -> f64 {
        match *self {
            Hardening::Linear { h, .. } => h,
            Hardening::Power { sigma_0, n, eps_0 } => {
                let a = 1.0 + eps_p / eps_0;
                n * sigma_0 * a.powf(n) / (eps_0 * a)
            }
        }
    }

    /// The root `Δε_p` of `q* − 3μ Δε_p − σ_y(ε_p + Δε_p) = 0` for a trial
    /// von Mises stress `q_trial > σ_y(ε_p) = sy` (`mu3 = 3μ`). Closed form
    /// for the linear law; safeguarded Halley for the power law (see the
    /// module notes).
    #[inline]
    pub fn increment(&self, q_trial: f64, mu3: f64, eps_p: f64, sy: f64) -> PlasticIncrement {
        match *self {
            Hardening::Linear { h, .. } => PlasticIncrement {
                deps: (q_trial - sy) / (mu3 + h),
                iterations: 0,
            },
            Hardening::Power { sigma_0, n, eps_0 } => {
                power_increment(q_trial, mu3, eps_p, sy, sigma_0, n, eps_0)
            }
        }
    }
}

/// The power-law return (see the module notes): the root of
/// `g(x) = q − 3μx − σ_y(ε_p + x)` in the bracket `[0, (q − sy)/(3μ)]`.
///
/// Halley steps (third order; the derivatives of `g` come with the one
/// power that `g` needs), kept inside the bracket, which shrinks with every
/// evaluation; a Newton step when Halley's leaves it, and bisection in
/// `ln(ε_0 + ε_p + x)` when that leaves it too or a step does not halve the
/// one before. The first step, from 0, needs no power (`σ_y(ε_p) = sy` is
/// known). It stops when a Halley step's predicted error,
/// `|(g₂/2g₁)² − g₃/6g₁| · step³` (`g_k` the k-th derivative), is below the
/// round-off of `x` (after one evaluation in explicit steps; see the
/// tests), or when a step or the bracket is at round-off.
#[inline(never)]
fn power_increment(
    q: f64,
    mu3: f64,
    eps_p: f64,
    sy: f64,
    sigma_0: f64,
    n: f64,
    eps_0: f64,
) -> PlasticIncrement {
    // The derivatives of g from σ_y = s at a = 1 + (ε_p + x)/ε_0,
    // r = 1/(ε_0 a): σ_y' = n s r, σ_y'' = n(n−1) s r², σ_y''' =
    // n(n−1)(n−2) s r³.
    let derivs = |s: f64, r: f64| {
        let d1 = -(mu3 + n * s * r);
        let d2 = n * (1.0 - n) * s * r * r;
        let d3 = -n * (1.0 - n) * (2.0 - n) * s * r * r * r;
        (d1, d2, d3)
    };
    let (mut lo, mut hi) = (0.0f64, (q - sy) / mu3);
    let w0 = eps_0 + eps_p; // ln(w0 + x) is the bisection variable
    let (mut x, mut g) = (0.0f64, q - sy);
    let (mut d1, mut d2, mut d3) = derivs(sy, 1.0 / w0);
    let mut dx_old = hi - lo;
    let mut dx = dx_old;
    for it in 0..MAX_ITER {
        // The candidate steps from x.
        let newton = -g / d1;
        let den = 1.0 + 0.5 * newton * d2 / d1;
        let halley = if den > 0.5 { newton / den } else { newton };
        let inside = |d: f64| x + d > lo && x + d < hi;
        let (step, order3) = if inside(halley) && (2.0 * halley).abs() <= dx_old.abs() {
            (halley, den > 0.5)
        } else if inside(newton) && (2.0 * newton).abs() <= dx_old.abs() {
            (newton, false)
        } else {
            // Bisection of the bracket in ln(w0 + x): the geometric mean of
            // its ends (the arithmetic one when that is not inside).
            let m = ((w0 + lo) * (w0 + hi)).sqrt() - w0;
            let m = if m > lo && m < hi { m } else { 0.5 * (lo + hi) };
            (m - x, false)
        };
        dx_old = dx;
        dx = step;
        let x_new = x + step;
        let c = 0.5 * d2 / d1;
        let c3 = c * c - d3 / (6.0 * d1);
        let done = (order3 && (c3 * step * step * step).abs() <= f64::EPSILON * x_new)
            || step.abs() <= 4.0 * f64::EPSILON * x_new
            || hi - lo <= 4.0 * f64::EPSILON * hi;
        if done {
            return PlasticIncrement {
                deps: x_new,
                iterations: it,
            };
        }
        x = x_new;
        let a = 1.0 + (eps_p + x) / eps_0;
        let s = sigma_0 * a.powf(n);
        g = q - mu3 * x - s;
        if g == 0.0 {
            return PlasticIncrement {
                deps: x,
                iterations: it + 1,
            };
        }
        if g > 0.0 {
            lo = x;
        } else {
            hi = x;
        }
        (d1, d2, d3) = derivs(s, 1.0 / (eps_0 * a));
    }
    PlasticIncrement {
        deps: x,
        iterations: MAX_ITER,
    }
}

/// Von Mises equivalent stress `q = √(3/2 s:s)` of the 3D deviator of
/// `(σxx, σyy, σxy, σzz)`.
#[inline]
pub fn von_mises(s: &Stress) -> f64 {
    let p = pressure_mean(s);
    let (dx, dy, dz) = (s.xx - p, s.yy - p, s.zz - p);
    (1.5 * (dx * dx + dy * dy + dz * dz + 2.0 * s.xy * s.xy)).sqrt()
}

/// Mean stress `(σxx + σyy + σzz)/3` (minus the pressure).
#[inline]
pub fn pressure_mean(s: &Stress) -> f64 {
    (s.xx + s.yy + s.zz) / 3.0
}

/// The radial return of a trial stress: the trial itself when it lies on
/// or inside the yield surface `q = σ_y(ε_p)`, else the stress on the
/// surface with the deviator scaled, and `eps_p` increased by `Δε_p`.
/// `hardening = None` never yields.
#[inline(always)]
pub fn radial_return(mu: f64, hardening: &Option<Hardening>, t: Stress, eps_p: &mut f64) -> Stress {
    let Some(hard) = hardening else { return t };
    let pm = (t.xx + t.yy + t.zz) * (1.0 / 3.0);
    let (dx, dy, dz) = (t.xx - pm, t.yy - pm, t.zz - pm);
    let q2 = 1.5 * (dx * dx + dy * dy + dz * dz + 2.0 * t.xy * t.xy);
    let ep = *eps_p;
    // Elastic unless q² > σ_y(ε_p)²; σ_y(ε_p) ≥ σ_y(0), which spares the
    // power of the power law below the initial yield stress.
    let s0 = hard.initial_yield();
    if q2 <= s0 * s0 {
        return t;
    }
    let sy = hard.flow_stress(ep);
    if q2 <= sy * sy {
        return t;
    }
    plastic_return(mu, hard, t, pm, [dx, dy, dz], q2, sy, eps_p)
}

/// The plastic branch of [`radial_return`] (kept out of line: the elastic
/// check is what every particle pays).
#[inline(never)]
#[allow(clippy::too_many_arguments)]
fn plastic_return(
    mu: f64,
    hard: &Hardening,
    t: Stress,
    pm: f64,
    d: [f64; 3],
    q2: f64,
    sy: f64,
    eps_p: &mut f64,
) -> Stress {
    let q = q2.sqrt();
    let mu3 = 3.0 * mu;
    let inc = hard.increment(q, mu3, *eps_p, sy);
    *eps_p += inc.deps;
    // The deviator scaled by q_new / q = 1 − 3μ Δε_p / q.
    let k = 1.0 - mu3 * inc.deps / q;
    Stress {
        xx: pm + k * d[0],
        yy: pm + k * d[1],
        xy: k * t.xy,
        zz: pm + k * d[2],
    }
}

/// One J2 step: the elastic trial of the hypo-elastic Jaumann law, then the
/// radial return (see the module notes).
#[inline(always)]
pub fn j2_update(p: &MatParams, s: Stress, l: &Tensor2, dt: f64, eps_p: &mut f64) -> Stress {
    let trial = hypo_elastic_jaumann(p.lambda, p.mu, s, l, dt);
    radial_return(p.mu, &p.hardening, trial, eps_p)
}

/// One J2 step in axisymmetry: the elastic trial of the hypo-elastic
/// Jaumann law with the hoop rate `l_tt` as the third normal rate
/// ([`super::axi::hypo_elastic_jaumann_axi`]), then the same radial return
/// (the `zz` slot is `σ_θθ`, with a strain rate of its own instead of the
/// plane-strain constraint).
#[inline(always)]
pub fn j2_update_axi(
    p: &MatParams,
    s: Stress,
    l: &Tensor2,
    l_tt: f64,
    dt: f64,
    eps_p: &mut f64,
) -> Stress {
    let trial = super::axi::hypo_elastic_jaumann_axi(p.lambda, p.mu, s, l, l_tt, dt);
    radial_return(p.mu, &p.hardening, trial, eps_p)
}

/// Every material on the patch is [`super::MatKind::J2`].
#[derive(Clone, Copy, Debug, Default)]
pub struct J2Law;

impl Constitutive for J2Law {
    const HAS_STATE: bool = true;
    const NODAL_DILATATION: bool = true;
    #[inline(always)]
    fn update(
        p: &MatParams,
        s: Stress,
        l: &Tensor2,
        dt: f64,
        _f: &Tensor2,
        eps_p: &mut f64,
    ) -> Stress {
        j2_update(p, s, l, dt, eps_p)
    }
    #[inline(always)]
    fn update_axi(
        p: &MatParams,
        s: Stress,
        l: &Tensor2,
        hoop: super::Hoop,
        dt: f64,
        _f: &Tensor2,
        eps_p: &mut f64,
    ) -> Stress {
        j2_update_axi(p, s, l, hoop.rate, dt, eps_p)
    }
    /// The elastic P-wave speed (as [`super::LinearElasticLaw`]).
    #[inline(always)]
    fn wave_speed(p: &MatParams, j: f64) -> f64 {
        ((p.lambda + 2.0 * p.mu) * j.max(0.0) / p.rho0).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hardening_validation_names_parameter_and_bound() {
        let ok = [
            Hardening::Linear {
                sigma_y: 1.0,
                h: 0.0,
            },
            Hardening::Power {
                sigma_0: 1.0,
                n: 0.0,
                eps_0: 1e-12,
            },
        ];
        for h in ok {
            assert!(h.validate().is_ok(), "{h:?}");
        }
        let bad = [
            (
                Hardening::Linear {
                    sigma_y: 0.0,
                    h: 1.0,
                },
                "sigma_y = 0",
            ),
            (
                Hardening::Linear {
                    sigma_y: 1.0,
                    h: -1.0,
                },
                "h = -1",
            ),
            (
                Hardening::Linear {
                    sigma_y: 1.0,
                    h: f64::INFINITY,
                },
                "h = inf",
            ),
            (
                Hardening::Power {
                    sigma_0: f64::NAN,
                    n: 0.1,
                    eps_0: 1.0,
                },
                "sigma_0 = NaN",
            ),
            (
                Hardening::Power {
                    sigma_0: 1.0,
                    n: 1.0,
                    eps_0: 1.0,
                },
                "n = 1",
            ),
            (
                Hardening::Power {
                    sigma_0: 1.0,
                    n: -0.1,
                    eps_0: 1.0,
                },
                "n = -0.1",
            ),
            (
                Hardening::Power {
                    sigma_0: 1.0,
                    n: 0.5,
                    eps_0: 0.0,
                },
                "eps_0 = 0",
            ),
        ];
        for (h, needle) in bad {
            let e = h.validate().unwrap_err();
            assert_eq!(e.status, crate::error::Status::InvalidArgument);
            assert!(e.msg.contains(needle), "{}", e.msg);
        }
    }

    #[test]
    fn slope_is_the_derivative_of_the_flow_stress() {
        let h = Hardening::Power {
            sigma_0: 100e6,
            n: 0.1,
            eps_0: 1.4e-3,
        };
        for ep in [1e-4, 0.02, 0.7] {
            let d = 1e-6 * ep;
            let fd = (h.flow_stress(ep + d) - h.flow_stress(ep - d)) / (2.0 * d);
            let rel = (fd - h.slope(ep)).abs() / h.slope(ep);
            assert!(rel < 1e-4, "eps_p = {ep}: {fd} vs {}", h.slope(ep));
        }
    }
}
