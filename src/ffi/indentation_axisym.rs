//! The Oliver–Pharr analysis of an axisymmetric load–depth curve (cone,
//! sphere, paraboloid, flat cylindrical punch) through the C API:
//! `gimlet_indentation_analysis_axisym`. Pure and local, like the
//! plane-strain analyses of [`super::indentation`]; the relations and
//! where they depart from ISO 14577 are in [`crate::indentation::axisym`].

use super::{check_len, guard, nonnull, slice};
use crate::error::Error;
use crate::indentation::axisym::{analyse, Options, Series, Tip};
use std::os::raw::c_int;

/// `tip` of [`gimlet_indentation_analysis_axisym`]: a cone, `size` its
/// half-angle in degrees (70.3 for the Berkovich/Vickers equivalent).
pub const GIMLET_TIP_CONE: c_int = 0;
/// `tip`: a sphere, `size` its radius (m; the exact cap area).
pub const GIMLET_TIP_SPHERE: c_int = 1;
/// `tip`: a paraboloid, `size` its tip radius (m; Hertz's area `2πR h_c`).
pub const GIMLET_TIP_PARABOLOID: c_int = 2;
/// `tip`: a flat cylindrical punch, `size` its radius (m).
pub const GIMLET_TIP_FLAT_PUNCH: c_int = 3;

/// Result index of the axisymmetric analysis: the largest load (N).
pub const GIMLET_OP_MAX_LOAD: c_int = 0;
/// Result index: `P_max`, the load at the start of unloading (N).
pub const GIMLET_OP_UNLOAD_LOAD: c_int = 1;
/// Result index: `h_max`, the depth at the start of unloading (m).
pub const GIMLET_OP_UNLOAD_DEPTH: c_int = 2;
/// Result index: `B` of the fit `P = B (h − h_f)^m` (N/m^m).
pub const GIMLET_OP_FIT_B: c_int = 3;
/// Result index: the exponent `m` of the fit.
pub const GIMLET_OP_FIT_M: c_int = 4;
/// Result index: `h_f` of the fit (m).
pub const GIMLET_OP_FIT_H_F: c_int = 5;
/// Result index: the RMS residual of the fit relative to `P_max`.
pub const GIMLET_OP_FIT_RMS: c_int = 6;
/// Result index: the number of points in the fit window.
pub const GIMLET_OP_FIT_POINTS: c_int = 7;
/// Result index: the unloading stiffness `S` (N/m).
pub const GIMLET_OP_STIFFNESS: c_int = 8;
/// Result index: the geometry constant `ε` used.
pub const GIMLET_OP_EPSILON: c_int = 9;
/// Result index: `β` used.
pub const GIMLET_OP_BETA: c_int = 10;
/// Result index: the contact depth `h_c = h_max − ε P_max / S` (m).
pub const GIMLET_OP_CONTACT_DEPTH: c_int = 11;
/// Result index: the projected area `A(h_c)` of the tip's area function
/// (m²).
pub const GIMLET_OP_AREA: c_int = 12;
/// Result index: the hardness `P_max / A` (Pa; ISO 14577's `H_IT`).
pub const GIMLET_OP_HARDNESS: c_int = 13;
/// Result index: the reduced modulus `E_r = √π S / (2 β √A)` (Pa).
pub const GIMLET_OP_REDUCED_MODULUS: c_int = 14;
/// Result index: the depth at which the load returns to zero (m; NaN if it
/// does not within the series).
pub const GIMLET_OP_RESIDUAL_DEPTH: c_int = 15;
/// Result index: the true contact radius passed (m; NaN without one).
pub const GIMLET_OP_TRUE_CONTACT_RADIUS: c_int = 16;
/// Result index: the true contact area `π a²` (m²; NaN without a radius).
pub const GIMLET_OP_TRUE_AREA: c_int = 17;
/// Result index: the hardness with the true area (Pa).
pub const GIMLET_OP_TRUE_HARDNESS: c_int = 18;
/// Result index: the reduced modulus with the true area (Pa).
pub const GIMLET_OP_TRUE_REDUCED_MODULUS: c_int = 19;
/// Result index: true area over Oliver–Pharr area (> 1: pile-up).
pub const GIMLET_OP_AREA_RATIO: c_int = 20;
/// Result index: the contact depth the true radius gives on the tip's area
/// function (m; NaN without a radius).
pub const GIMLET_OP_TRUE_CONTACT_DEPTH: c_int = 21;
/// The number of values `gimlet_indentation_analysis_axisym` writes.
pub const GIMLET_OP_RESULTS: c_int = 22;

/// Analyses an axisymmetric load–depth series of `n` (>= 4) points in time
/// order, with loading and unloading, by Oliver and Pharr: `depth` (the
/// tip's depth below the undeformed surface, m) and `load` (the whole
/// body's, N, > 0 pushes the indenter up; what `gimlet_indenter_state`
/// reports in axisymmetry). `tip` is a `GIMLET_TIP_*` with its `size`.
/// `epsilon` is the geometry constant (NaN: the tip's own, 2(π − 2)/π ≈
/// 0.727 for a cone, 0.75 for a sphere or paraboloid, 1 for a punch);
/// `beta` (> 0; 1 for a body of revolution); the fit window `[fit_lower,
/// fit_upper]` of `P_max` (0 < lower < upper <= 1; 0.4 and 0.98 are the
/// usual); `frame_compliance` (>= 0, m/N: the depths become `h − C_f P`);
/// `contact_radius` (> 0, m: the true contact radius at the start of
/// unloading, from `gimlet_get_contacts`; NaN or 0: none, and the true-area
/// results are NaN). `results` receives `GIMLET_OP_RESULTS` values in the
/// `GIMLET_OP_*` order. Bad input is refused with the argument and its
/// bound named. Local and pure: no handle, no MPI.
///
/// # Safety
/// `depth` and `load` hold `n` values; `results` has room for
/// `GIMLET_OP_RESULTS` values.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn gimlet_indentation_analysis_axisym(
    n: i64,
    depth: *const f64,
    load: *const f64,
    tip: c_int,
    size: f64,
    epsilon: f64,
    beta: f64,
    fit_lower: f64,
    fit_upper: f64,
    frame_compliance: f64,
    contact_radius: f64,
    results: *mut f64,
) -> c_int {
    guard("gimlet_indentation_analysis_axisym", || {
        nonnull(results, "results")?;
        let n = check_len(n, "n", 1 << 30)?;
        let series = Series {
            depth: slice(depth, n, "depth")?,
            load: slice(load, n, "load")?,
        };
        let tip = match tip {
            GIMLET_TIP_CONE => {
                if !(size.is_finite() && size > 0.0 && size < 90.0) {
                    return Err(Error::arg(format!(
                        "size = {size} must be the cone's half-angle in (0, 90) degrees"
                    )));
                }
                Tip::Cone {
                    half_angle: size.to_radians(),
                }
            }
            GIMLET_TIP_SPHERE => Tip::Sphere { radius: size },
            GIMLET_TIP_PARABOLOID => Tip::Paraboloid { radius: size },
            GIMLET_TIP_FLAT_PUNCH => Tip::FlatPunch { radius: size },
            _ => {
                return Err(Error::arg(format!(
                    "tip = {tip} must be GIMLET_TIP_CONE (0), _SPHERE (1), _PARABOLOID (2) or _FLAT_PUNCH (3)"
                )))
            }
        };
        let mut opts = Options::new(tip);
        opts.epsilon = (!epsilon.is_nan()).then_some(epsilon);
        opts.beta = beta;
        opts.fit_lower = fit_lower;
        opts.fit_upper = fit_upper;
        opts.frame_compliance = frame_compliance;
        opts.contact_radius =
            (!contact_radius.is_nan() && contact_radius != 0.0).then_some(contact_radius);
        let r = analyse(series, opts)?;
        let v = [
            r.max_load,
            r.unload_load,
            r.unload_depth,
            r.fit_b,
            r.fit_m,
            r.fit_h_f,
            r.fit_rms,
            r.fit_points as f64,
            r.stiffness,
            r.epsilon,
            r.beta,
            r.contact_depth,
            r.area,
            r.hardness,
            r.reduced_modulus,
            r.residual_depth,
            r.true_contact_radius,
            r.true_area,
            r.true_hardness,
            r.true_reduced_modulus,
            r.area_ratio,
            r.true_contact_depth,
        ];
        debug_assert_eq!(v.len(), GIMLET_OP_RESULTS as usize);
        // SAFETY: the caller's contract (room for GIMLET_OP_RESULTS).
        unsafe { std::ptr::copy_nonoverlapping(v.as_ptr(), results, v.len()) };
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ffi::tests::message;
    use crate::ffi::GIMLET_ERR_INVALID_ARGUMENT;

    /// Sneddon's elastic cone loaded and unloaded along `P = C h²` (an
    /// elastic cone unloads along its loading curve): Oliver–Pharr with the
    /// cone's ε gives the contact depth `(2/π) h`, the area `π a²` with
    /// Sneddon's radius, and `E_r = E*` exactly (to the fit's round-off).
    #[test]
    fn sneddons_cone_gives_back_its_modulus() {
        let (es, psi) = (70e9, 70.3f64.to_radians());
        let c = 2.0 / std::f64::consts::PI * es * psi.tan();
        let hm = 1e-6;
        let mut d: Vec<f64> = (0..=50).map(|i| hm * i as f64 / 50.0).collect();
        d.extend((1..=50).map(|i| hm * (1.0 - 0.01 * i as f64)));
        let l: Vec<f64> = d.iter().map(|h| c * h * h).collect();
        let mut out = [f64::NAN; GIMLET_OP_RESULTS as usize];
        // The cone's analysis with tip kind `tip`, the cone's own ε, β = 1,
        // the fit over 40–98 % of P_max, no frame compliance, no true radius.
        let analyse = |tip: c_int, out: &mut [f64]| {
            // SAFETY: arrays of the lengths passed.
            unsafe {
                gimlet_indentation_analysis_axisym(
                    d.len() as i64,
                    d.as_ptr(),
                    l.as_ptr(),
                    tip,
                    70.3,
                    f64::NAN,
                    1.0,
                    0.4,
                    0.98,
                    0.0,
                    f64::NAN,
                    out.as_mut_ptr(),
                )
            }
        };
        let rc = analyse(GIMLET_TIP_CONE, &mut out);
        assert_eq!(rc, 0, "{}", message());
        let e_r = out[GIMLET_OP_REDUCED_MODULUS as usize];
        assert!((e_r / es - 1.0).abs() < 1e-6, "E_r {e_r} against {es}");
        let hc = out[GIMLET_OP_CONTACT_DEPTH as usize];
        assert!((hc / (2.0 / std::f64::consts::PI * hm) - 1.0).abs() < 1e-6);
        assert!(out[GIMLET_OP_TRUE_AREA as usize].is_nan());
        // A bad tip is refused with the argument named.
        let rc = analyse(7, &mut out);
        assert_eq!(rc, GIMLET_ERR_INVALID_ARGUMENT);
        assert!(message().contains("tip"), "{}", message());
    }
}
