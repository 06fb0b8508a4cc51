//! The Oliver–Pharr analysis of an axisymmetric indentation (cone, sphere,
//! flat punch, or a tabulated area function), as instruments report it:
//! hardness, reduced modulus, contact depth, stiffness, and beside them
//! the true contact area the simulation knows, so that pile-up and
//! sink-in show as the difference. Pure: no MPI, no handle.
//!
//! # The relations (Oliver & Pharr, J. Mater. Res. 7, 1992)
//!
//! Loads are for the whole body (N: `2π` times the simulation's
//! per-radian force); depths are the tip's displacement below the
//! undeformed surface (m).
//!
//! * **Unloading fit** `P = B (h − h_f)^m` over the unloading points with
//!   `fit_lower P_max ≤ P ≤ fit_upper P_max` (default 40–98 %), least
//!   squares in `P` (the fit of [`super`]); `P_max`, `h_max` are taken at
//!   the start of unloading (the last instant at the largest depth).
//! * **Stiffness** `S = m B (h_max − h_f)^(m−1)`.
//! * **Contact depth** `h_c = h_max − ε P_max / S`, `ε` the tip's geometry
//!   constant ([`Tip::epsilon`]: cone `2(π − 2)/π`, paraboloid and sphere
//!   0.75, flat punch 1), or a given one.
//! * **Projected area** `A = A(h_c)` ([`Tip::area`]): cone `π tan²ψ h_c²`
//!   (70.3°: `24.5 h_c²`), sphere `π (2R h_c − h_c²)`, paraboloid
//!   `2πR h_c`, punch `π a²`, or the series `C0 h_c² + C1 h_c + C2
//!   h_c^(1/2) + C3 h_c^(1/4) + C4 h_c^(1/8)`.
//! * **Hardness** `H = P_max / A`; **reduced modulus** `E_r = (√π /
//!   (2β)) S / √A`, with `β` = 1 for a body of revolution (the default;
//!   about 1.034 for a Berkovich tip); `1/E_r = (1 − ν²)/E + (1 −
//!   ν_i²)/E_i` ([`sample_modulus`] inverts it).
//! * **True contact**: given the contact radius `a` at the start of
//!   unloading (from the contact query), the true projected area `π a²`,
//!   the hardness and modulus it gives, the ratio of the true area to the
//!   Oliver–Pharr one (above 1 with pile-up, below with sink-in), and the
//!   contact depth whose area is the true one.
//!
//! On the elastic closed forms of [`super::closed_form`] these relations
//! are exact: Sneddon's cone (`m = 2`, `h_c = 2h/π`, `S = 2E* a`), Hertz's
//! paraboloid (`m = 3/2`, `h_c = h/2`) and the flat punch (`m = 1`)
//! give back `E*` and the contact area to the round-off of the fit.
//!
//! # Where Gimlet departs from Oliver–Pharr 1992 and ISO 14577
//!
//! * **ε of the cone** is Sneddon's exact `2(π − 2)/π = 0.7268` by
//!   default. Oliver and Pharr tabulate 0.72, its rounding; that value
//!   biases the contact depth of an elastic cone by +0.53 % and `E_r` by
//!   −0.53 %. Pass `epsilon = Some(0.72)` to reproduce the tabulated
//!   constant. The paraboloid's 0.75 and the punch's 1 are exact.
//! * **The area function is the ideal geometry's.** The simulated tip is
//!   exact, so no tip-rounding calibration on fused silica is needed or
//!   made; for a measured tip, pass its series coefficients.
//! * **No frame compliance, drift or creep corrections by default.** The
//!   simulated frame is rigid and the laws are rate-independent; ISO 14577
//!   requires the frame compliance to be measured and the thermal drift
//!   corrected. A frame compliance `C_f` may be given: depths become
//!   `h − C_f P`. The zero of depth is the undeformed surface, exactly (no
//!   contact-point detection).
//! * **β is a parameter** (1 by default) and no correction for the
//!   surface's radial displacement (Hay, Bolshakov & Pharr 1999) is
//!   applied: against a simulation of a blunt cone on an elastic body, `E_r`
//!   is expected a few per cent above `E*`, as finite elements find.
//! * **The fit** is the three-parameter power law by least squares in
//!   `P` over a window of the unloading branch; the window is a parameter
//!   (default 40–98 % of `P_max`). The stiffness is the fit's slope at the
//!   start of unloading.
//! * **The true contact area** is reported beside the Oliver–Pharr one;
//!   the method itself cannot see pile-up. ISO 14577's indentation hardness
//!   `H_IT` is this `H` (projected area at `h_c`), its indentation modulus
//!   `E_IT` is [`sample_modulus`] of `E_r`.

use super::{check_finite, fit_unloading, residual_depth};
use crate::error::{Error, Result};
use std::f64::consts::PI;

/// The indenter's shape, for its area function and geometry constant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Tip {
    /// A cone of half-angle `half_angle` (rad, in `(0, π/2)`; 70.3° for
    /// the Berkovich/Vickers-equivalent cone).
    Cone {
        /// Half-angle between the axis and a face (rad).
        half_angle: f64,
    },
    /// A sphere of radius `radius` (m): the exact cap area `π (2R h_c −
    /// h_c²)`, for `h_c ≤ R`.
    Sphere {
        /// Radius (m).
        radius: f64,
    },
    /// A paraboloid of tip radius `radius` (m): `2πR h_c` (Hertz's
    /// approximation of a sphere).
    Paraboloid {
        /// Tip radius (m).
        radius: f64,
    },
    /// A flat-ended cylindrical punch of radius `radius` (m): `π a²`.
    FlatPunch {
        /// Radius (m).
        radius: f64,
    },
    /// A tabulated area function `C0 h² + C1 h + C2 h^(1/2) + C3 h^(1/4) +
    /// C4 h^(1/8)` (SI: m², m, m^(3/2), …), as Oliver and Pharr fit a real
    /// tip's; `ε` 0.75 by default.
    Series {
        /// `C0 … C4`.
        c: [f64; 5],
    },
}

impl Tip {
    /// The geometry constant `ε` of `h_c = h_max − ε P_max / S`: cone
    /// `2(π − 2)/π` (Sneddon; tabulated as 0.72), paraboloid and sphere
    /// 0.75, flat punch 1, series 0.75.
    pub fn epsilon(&self) -> f64 {
        match self {
            Tip::Cone { .. } => 2.0 * (PI - 2.0) / PI,
            Tip::Sphere { .. } | Tip::Paraboloid { .. } | Tip::Series { .. } => 0.75,
            Tip::FlatPunch { .. } => 1.0,
        }
    }

    /// The projected contact area at contact depth `h_c` (m²).
    pub fn area(&self, h_c: f64) -> f64 {
        match *self {
            Tip::Cone { half_angle } => {
                let t = half_angle.tan();
                PI * t * t * h_c * h_c
            }
            Tip::Sphere { radius } => PI * (2.0 * radius * h_c - h_c * h_c),
            Tip::Paraboloid { radius } => 2.0 * PI * radius * h_c,
            Tip::FlatPunch { radius } => PI * radius * radius,
            Tip::Series { c } => {
                let s2 = h_c.sqrt();
                let s4 = s2.sqrt();
                c[0] * h_c * h_c + c[1] * h_c + c[2] * s2 + c[3] * s4 + c[4] * s4.sqrt()
            }
        }
    }

    /// The contact depth whose projected area is `area` (the inverse of
    /// [`Tip::area`]); NaN for the flat punch (its area does not depend on
    /// the depth) and for a sphere's area above `π R²`.
    pub fn depth_of_area(&self, area: f64) -> f64 {
        match *self {
            Tip::Cone { half_angle } => (area / PI).sqrt() / half_angle.tan(),
            Tip::Sphere { radius } => {
                let q = radius * radius - area / PI;
                if q >= 0.0 {
                    radius - q.sqrt()
                } else {
                    f64::NAN
                }
            }
            Tip::Paraboloid { radius } => area / (2.0 * PI * radius),
            Tip::FlatPunch { .. } => f64::NAN,
            Tip::Series { .. } => {
                // Increasing in h for non-negative coefficients: bracket,
                // then bisect.
                let mut hi = 1e-9;
                while self.area(hi) < area && hi < 1e3 {
                    hi *= 2.0;
                }
                let mut lo = 0.0;
                for _ in 0..200 {
                    let m = 0.5 * (lo + hi);
                    if self.area(m) < area {
                        lo = m;
                    } else {
                        hi = m;
                    }
                }
                0.5 * (lo + hi)
            }
        }
    }

    fn validate(&self) -> Result<()> {
        let positive = |v: f64, name: &str| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(Error::arg(format!("{name} = {v} must be finite and > 0")))
            }
        };
        match *self {
            Tip::Cone { half_angle } => {
                if !(half_angle > 0.0 && half_angle < PI / 2.0) {
                    return Err(Error::arg(format!(
                        "cone half_angle = {half_angle} rad must lie in (0, pi/2)"
                    )));
                }
                Ok(())
            }
            Tip::Sphere { radius } => positive(radius, "sphere radius"),
            Tip::Paraboloid { radius } => positive(radius, "paraboloid radius"),
            Tip::FlatPunch { radius } => positive(radius, "punch radius"),
            Tip::Series { c } => {
                if let Some(k) = c.iter().position(|v| !(v.is_finite() && *v >= 0.0)) {
                    return Err(Error::arg(format!(
                        "area coefficient c[{k}] = {} must be finite and >= 0",
                        c[k]
                    )));
                }
                if c.iter().all(|&v| v == 0.0) {
                    return Err(Error::arg(
                        "area coefficients c = [0, 0, 0, 0, 0]: at least one must be > 0"
                            .to_string(),
                    ));
                }
                Ok(())
            }
        }
    }
}

/// A load–depth series with loading and unloading, in time order.
#[derive(Clone, Copy, Debug)]
pub struct Series<'a> {
    /// Depth of the tip below the undeformed surface (m).
    pub depth: &'a [f64],
    /// Load on the indenter for the whole body (N, pushing it up > 0).
    pub load: &'a [f64],
}

/// Parameters of the analysis.
#[derive(Clone, Copy, Debug)]
pub struct Options {
    /// The indenter's shape.
    pub tip: Tip,
    /// The geometry constant `ε`; `None`: [`Tip::epsilon`].
    pub epsilon: Option<f64>,
    /// `β` of `E_r = (√π/(2β)) S/√A` (1 for a body of revolution).
    pub beta: f64,
    /// Lower end of the fit window, as a fraction of `P_max`, in `(0, 1)`.
    pub fit_lower: f64,
    /// Upper end of the fit window, in `(fit_lower, 1]`.
    pub fit_upper: f64,
    /// Frame compliance `C_f` (m/N, ≥ 0): the depths become `h − C_f P`.
    pub frame_compliance: f64,
    /// The true contact radius at the start of unloading (m, > 0), e.g.
    /// from the contact query; `None` leaves the true-area figures NaN.
    pub contact_radius: Option<f64>,
}

impl Options {
    /// The defaults for a tip: its `ε`, `β = 1`, the window 40–98 % of
    /// `P_max`, no frame compliance, no true contact radius.
    pub fn new(tip: Tip) -> Options {
        Options {
            tip,
            epsilon: None,
            beta: 1.0,
            fit_lower: 0.4,
            fit_upper: 0.98,
            frame_compliance: 0.0,
            contact_radius: None,
        }
    }
}

/// What the analysis finds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Analysis {
    /// The largest load of the series (N).
    pub max_load: f64,
    /// `P_max`: the load at the start of unloading (N).
    pub unload_load: f64,
    /// `h_max`: the depth at the start of unloading, after the frame
    /// compliance (m).
    pub unload_depth: f64,
    /// Fit coefficient `B` of `P = B (h − h_f)^m` (N/m^m).
    pub fit_b: f64,
    /// Fit exponent `m` (2 for an elastic cone, 1.5 for a paraboloid, 1
    /// for a flat punch).
    pub fit_m: f64,
    /// Fit offset `h_f` (m).
    pub fit_h_f: f64,
    /// RMS residual of the fit over the window, relative to `P_max`.
    pub fit_rms: f64,
    /// Number of points in the fit window.
    pub fit_points: usize,
    /// Unloading stiffness `S = dP/dh` at the start of unloading (N/m).
    pub stiffness: f64,
    /// The `ε` used.
    pub epsilon: f64,
    /// The `β` used.
    pub beta: f64,
    /// Contact depth `h_c = h_max − ε P_max / S` (m).
    pub contact_depth: f64,
    /// Projected contact area `A(h_c)` (m²).
    pub area: f64,
    /// Hardness `P_max / A` (Pa).
    pub hardness: f64,
    /// Reduced modulus `(√π/(2β)) S / √A` (Pa).
    pub reduced_modulus: f64,
    /// Absolute depth at which the load first returns to zero on unloading
    /// (m); NaN if it never does within the series.
    pub residual_depth: f64,
    /// The true contact radius given (m; NaN if none).
    pub true_contact_radius: f64,
    /// The true projected area `π a²` (m²; NaN if no radius was given).
    pub true_area: f64,
    /// `P_max` over the true area (Pa).
    pub true_hardness: f64,
    /// `(√π/(2β)) S / √(true area)` (Pa).
    pub true_reduced_modulus: f64,
    /// True area over the Oliver–Pharr area: above 1 with pile-up, below 1
    /// with sink-in.
    pub area_ratio: f64,
    /// The contact depth whose area is the true one ([`Tip::depth_of_area`];
    /// NaN for a flat punch): above `contact_depth` with pile-up.
    pub true_contact_depth: f64,
}

/// The sample's modulus from the reduced modulus: `E = (1 − ν²) / (1/E_r −
/// (1 − ν_i²)/E_i)` (`E_i = ∞` for a rigid indenter; ISO 14577's `E_IT`).
pub fn sample_modulus(e_r: f64, nu: f64, e_i: f64, nu_i: f64) -> f64 {
    (1.0 - nu * nu) / (1.0 / e_r - (1.0 - nu_i * nu_i) / e_i)
}

/// Analyses an axisymmetric load–depth series with unloading (see the
/// module documentation). Errors name the argument and the bound it broke:
/// series of different lengths, shorter than 4 or with non-finite values;
/// tip parameters out of range; `epsilon` outside `(0, 1]`; `beta` not
/// finite and > 0; a fit window outside `0 < fit_lower < fit_upper <= 1`;
/// a negative or non-finite frame compliance; a contact radius not finite
/// and > 0; a non-positive `P_max`; fewer than 3 distinct unloading points
/// in the window; a contact depth that is not > 0 (or above a sphere's
/// radius).
pub fn analyse(series: Series<'_>, opts: Options) -> Result<Analysis> {
    let n = series.depth.len();
    if series.load.len() != n {
        return Err(Error::arg(format!(
            "load has {} values but depth has {n}: they must have the same length",
            series.load.len()
        )));
    }
    if n < 4 {
        return Err(Error::arg(format!(
            "n = {n} must be >= 4 (a loading and an unloading branch)"
        )));
    }
    check_finite(series.depth, "depth")?;
    check_finite(series.load, "load")?;
    opts.tip.validate()?;
    let eps = opts.epsilon.unwrap_or(opts.tip.epsilon());
    if !(eps > 0.0 && eps <= 1.0) {
        return Err(Error::arg(format!("epsilon = {eps} must lie in (0, 1]")));
    }
    let beta = opts.beta;
    if !(beta.is_finite() && beta > 0.0) {
        return Err(Error::arg(format!("beta = {beta} must be finite and > 0")));
    }
    let (lo, hi) = (opts.fit_lower, opts.fit_upper);
    if !(lo.is_finite() && lo > 0.0 && lo < 1.0) {
        return Err(Error::arg(format!("fit_lower = {lo} must lie in (0, 1)")));
    }
    if !(hi.is_finite() && hi > lo && hi <= 1.0) {
        return Err(Error::arg(format!(
            "fit_upper = {hi} must lie in (fit_lower = {lo}, 1]"
        )));
    }
    let cf = opts.frame_compliance;
    if !(cf.is_finite() && cf >= 0.0) {
        return Err(Error::arg(format!(
            "frame_compliance = {cf} must be finite and >= 0"
        )));
    }
    if let Some(a) = opts.contact_radius {
        if !(a.is_finite() && a > 0.0) {
            return Err(Error::arg(format!(
                "contact_radius = {a} must be finite and > 0"
            )));
        }
    }

    let depth = |i: usize| series.depth[i] - cf * series.load[i];
    let u = fit_unloading(series.depth, series.load, lo, hi, depth)?;
    let (iu, pu, fit, stiffness) = (u.iu, u.pu, u.fit, u.stiffness);
    let hu = depth(iu);
    let hc = hu - eps * pu / stiffness;
    let punch = matches!(opts.tip, Tip::FlatPunch { .. });
    // Written so that NaN fails.
    if !punch && (hc.is_nan() || hc <= 0.0) {
        return Err(Error::arg(format!(
            "the contact depth h_c = h_max - epsilon P_max / S = {hu} - {eps} * {pu} / {stiffness} = {hc} \
             must be > 0 (the unloading branch is too compliant for this epsilon)"
        )));
    }
    if let Tip::Sphere { radius } = opts.tip {
        if hc > radius {
            return Err(Error::arg(format!(
                "the contact depth h_c = {hc} must not exceed the sphere radius R = {radius}"
            )));
        }
    }
    let area = opts.tip.area(hc);
    let k = PI.sqrt() / (2.0 * beta);
    let mut out = Analysis {
        max_load: series.load[u.imax_p],
        unload_load: pu,
        unload_depth: hu,
        fit_b: fit.alpha,
        fit_m: fit.m,
        fit_h_f: fit.h_f,
        fit_rms: u.rms,
        fit_points: u.points,
        stiffness,
        epsilon: eps,
        beta,
        contact_depth: hc,
        area,
        hardness: pu / area,
        reduced_modulus: k * stiffness / area.sqrt(),
        residual_depth: f64::NAN,
        true_contact_radius: f64::NAN,
        true_area: f64::NAN,
        true_hardness: f64::NAN,
        true_reduced_modulus: f64::NAN,
        area_ratio: f64::NAN,
        true_contact_depth: f64::NAN,
    };
    if let Some(a) = opts.contact_radius {
        let ta = PI * a * a;
        out.true_contact_radius = a;
        out.true_area = ta;
        out.true_hardness = pu / ta;
        out.true_reduced_modulus = k * stiffness / ta.sqrt();
        out.area_ratio = ta / area;
        out.true_contact_depth = opts.tip.depth_of_area(ta);
    }
    out.residual_depth = residual_depth(series.load, iu, depth);
    Ok(out)
}

#[cfg(test)]
mod tests;
