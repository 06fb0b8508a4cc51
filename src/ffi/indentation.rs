//! The analysis of a load–depth curve with unloading (hardness, unloading
//! stiffness, reduced modulus, residual depth) for a plane-strain
//! indenter: `gimlet_indentation_analysis`. Pure and local: it takes no
//! handle, communicates with nobody and may be called before MPI is
//! initialised. The relations are those of `crate::indentation` (and
//! `docs/method.md`): `H = P_max / (2a)`, `E_r = 2 S arccosh(r0/a) / π` with the
//! depths measured relative to the surface point at distance `r0` from the
//! axis.

use super::{check_len, guard, nonnull, slice};
use crate::indentation::wedge::analyse_wedge;
use crate::indentation::{analyse, Options, Series};
use std::os::raw::c_int;

/// Result index: the largest load of the series (N/m).
pub const GIMLET_INDENTATION_MAX_LOAD: c_int = 0;
/// Result index: the depth at the largest load (m).
pub const GIMLET_INDENTATION_DEPTH_AT_MAX_LOAD: c_int = 1;
/// Result index: the largest depth of the series (m).
pub const GIMLET_INDENTATION_MAX_DEPTH: c_int = 2;
/// Result index: `P_max`, the load at the start of unloading (the last
/// point at the largest depth), used for the hardness and the fit window
/// (N/m).
pub const GIMLET_INDENTATION_UNLOAD_LOAD: c_int = 3;
/// Result index: the contact half-width used (m).
pub const GIMLET_INDENTATION_CONTACT_HALF_WIDTH: c_int = 4;
/// Result index: `α` of the fit `P = α (h − h_f)^m`.
pub const GIMLET_INDENTATION_FIT_ALPHA: c_int = 5;
/// Result index: the exponent `m` of the fit.
pub const GIMLET_INDENTATION_FIT_M: c_int = 6;
/// Result index: `h_f` of the fit, in the relative-depth measure (m).
pub const GIMLET_INDENTATION_FIT_H_F: c_int = 7;
/// Result index: the RMS residual of the fit relative to `P_max`.
pub const GIMLET_INDENTATION_FIT_RMS: c_int = 8;
/// Result index: the number of points in the fit window.
pub const GIMLET_INDENTATION_FIT_POINTS: c_int = 9;
/// Result index: the unloading stiffness `S = dP/dh` at the start of
/// unloading (Pa).
pub const GIMLET_INDENTATION_STIFFNESS: c_int = 10;
/// Result index: the absolute depth at which the load first returns to
/// zero on unloading (m; NaN if it does not within the series).
pub const GIMLET_INDENTATION_RESIDUAL_DEPTH: c_int = 11;
/// Result index: the hardness `P_max / (2a)` (Pa).
pub const GIMLET_INDENTATION_HARDNESS: c_int = 12;
/// Result index: the reduced modulus `E_r = 2 S arccosh(r0/a) / π` (Pa).
pub const GIMLET_INDENTATION_REDUCED_MODULUS: c_int = 13;
/// The number of values `gimlet_indentation_analysis` writes.
pub const GIMLET_INDENTATION_RESULTS: c_int = 14;

/// The series of `n` points the analyses read (`sink` may be NULL).
///
/// # Safety
/// Each non-null pointer holds `n` values.
unsafe fn series<'a>(
    n: i64,
    depth: *const f64,
    load: *const f64,
    sink: *const f64,
) -> crate::error::Result<Series<'a>> {
    let n = check_len(n, "n", 1 << 30)?;
    Ok(Series {
        depth: slice(depth, n, "depth")?,
        load: slice(load, n, "load")?,
        sink: if sink.is_null() {
            None
        } else {
            Some(slice(sink, n, "sink")?)
        },
    })
}

/// Writes an analysis to `results` in the `GIMLET_INDENTATION_*` order.
///
/// # Safety
/// `results` has room for `GIMLET_INDENTATION_RESULTS` values.
unsafe fn write_results(r: &crate::indentation::Analysis, results: *mut f64) {
    let v = [
        r.max_load,
        r.depth_at_max_load,
        r.max_depth,
        r.unload_load,
        r.contact_half_width,
        r.fit_alpha,
        r.fit_m,
        r.fit_h_f,
        r.fit_rms,
        r.fit_points as f64,
        r.stiffness,
        r.residual_depth,
        r.hardness,
        r.reduced_modulus,
    ];
    debug_assert_eq!(v.len(), GIMLET_INDENTATION_RESULTS as usize);
    std::ptr::copy_nonoverlapping(v.as_ptr(), results, v.len());
}

/// Analyses a plane-strain load–depth series of `n` (>= 4) points in time
/// order, with loading and unloading: `depth` (the tip's depth below the
/// undeformed surface, m), `load` (per unit thickness, N/m, > 0 pushes the
/// indenter up) and `sink` (the downward displacement of the surface point
/// at distance `r0` from the axis, m; NULL when `depth` is already measured
/// relative to that point). `contact_half_width` (> 0, m) is the contact
/// half-width `a` at the start of unloading (e.g. from
/// `gimlet_get_contacts`); `r0` must exceed it (a few `a`, well inside the
/// body). The power law `P = α (h − h_f)^m` is fitted, in `P`, to the
/// unloading points with loads between `fit_lower` and `fit_upper` times
/// `P_max` (`0 < fit_lower < fit_upper <= 1`; 0.5 and 1 fit the upper half
/// of the branch); at least 3 are needed. `results` (room for
/// `GIMLET_INDENTATION_RESULTS` values) receives the values indexed by
/// `GIMLET_INDENTATION_*`, only on success. Local and pure: no handle, no
/// communication.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn gimlet_indentation_analysis(
    n: i64,
    depth: *const f64,
    load: *const f64,
    sink: *const f64,
    r0: f64,
    contact_half_width: f64,
    fit_lower: f64,
    fit_upper: f64,
    results: *mut f64,
) -> c_int {
    guard("gimlet_indentation_analysis", || {
        nonnull(results, "results")?;
        let series = series(n, depth, load, sink)?;
        let r = analyse(
            series,
            Options {
                r0,
                contact_half_width,
                fit_lower,
                fit_upper,
            },
        )?;
        write_results(&r, results);
        Ok(())
    })
}

/// `gimlet_indentation_analysis` for a wedge of tip half-angle
/// `half_angle_deg` (0 to 90, exclusive), with the contact half-width taken
/// from Oliver–Pharr's contact depth instead of measured: `a` solves
/// `a = (h − ε P/S) tan ψ` at the start of unloading, `h` the depth relative
/// to the surface point at `r0`, with the plane-strain elastic wedge's
/// `ε(a/r0) = 1 + (r0 arcsin(a/r0) − πa/2)/(a arccosh(r0/a))` (0.72 at
/// `r0 = 4a`, as Oliver–Pharr's cone). `results[GIMLET_INDENTATION_CONTACT_HALF_WIDTH]`
/// is that `a`; hardness and modulus use it. It does not depend on the
/// weight function (the particles' measured half-width moves in steps of a
/// particle), but, like Oliver–Pharr's, it assumes elastic sink-in: with
/// pile-up it is too small. The other arguments and the results are those
/// of `gimlet_indentation_analysis`. Local and pure: no handle, no
/// communication.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn gimlet_indentation_analysis_wedge(
    n: i64,
    depth: *const f64,
    load: *const f64,
    sink: *const f64,
    r0: f64,
    half_angle_deg: f64,
    fit_lower: f64,
    fit_upper: f64,
    results: *mut f64,
) -> c_int {
    guard("gimlet_indentation_analysis_wedge", || {
        nonnull(results, "results")?;
        let series = series(n, depth, load, sink)?;
        let r = analyse_wedge(series, r0, half_angle_deg, fit_lower, fit_upper)?;
        write_results(&r, results);
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ffi::tests::message;
    use crate::ffi::{GIMLET_ERR_INVALID_ARGUMENT, GIMLET_ERR_NULL_POINTER};

    /// Linear loading to (1, 2), linear unloading `P = 4 (h − 0.5)`.
    fn curve() -> (Vec<f64>, Vec<f64>) {
        let mut d: Vec<f64> = (0..=10).map(|i| 0.1 * i as f64).collect();
        let mut l: Vec<f64> = d.iter().map(|h| 2.0 * h).collect();
        for i in 1..=10 {
            let h = 1.0 - 0.05 * i as f64;
            d.push(h);
            l.push(4.0 * (h - 0.5));
        }
        (d, l)
    }

    #[test]
    fn writes_the_results_in_their_slots() {
        let (d, l) = curve();
        let mut out = [f64::NAN; GIMLET_INDENTATION_RESULTS as usize];
        // SAFETY: arrays of the lengths passed.
        let rc = unsafe {
            gimlet_indentation_analysis(
                d.len() as i64,
                d.as_ptr(),
                l.as_ptr(),
                std::ptr::null(),
                3.0,
                0.5,
                0.3,
                1.0,
                out.as_mut_ptr(),
            )
        };
        assert_eq!(rc, 0, "{}", message());
        let at = |k: c_int| out[k as usize];
        assert_eq!(at(GIMLET_INDENTATION_MAX_LOAD), 2.0);
        assert_eq!(at(GIMLET_INDENTATION_MAX_DEPTH), 1.0);
        assert_eq!(at(GIMLET_INDENTATION_UNLOAD_LOAD), 2.0);
        assert_eq!(at(GIMLET_INDENTATION_HARDNESS), 2.0);
        assert!((at(GIMLET_INDENTATION_STIFFNESS) - 4.0).abs() < 1e-8);
        assert!((at(GIMLET_INDENTATION_FIT_M) - 1.0).abs() < 1e-8);
        assert!((at(GIMLET_INDENTATION_RESIDUAL_DEPTH) - 0.5).abs() < 1e-12);
        let e = 2.0 * 4.0 * 6f64.acosh() / std::f64::consts::PI;
        assert!((at(GIMLET_INDENTATION_REDUCED_MODULUS) / e - 1.0).abs() < 1e-8);
        assert_eq!(at(GIMLET_INDENTATION_CONTACT_HALF_WIDTH), 0.5);
    }

    /// The wedge variant on the same curve: its half-width solves
    /// `a = (h − ε(a/r0) P/S) tan ψ` (h 1, P 2, S 4, ψ 45°), and hardness and
    /// modulus use it; a half-angle out of range writes nothing.
    #[test]
    fn wedge_variant_takes_the_contact_depth() {
        let (d, l) = curve();
        let mut out = [f64::NAN; GIMLET_INDENTATION_RESULTS as usize];
        let call = |psi: f64, out: &mut [f64]| unsafe {
            gimlet_indentation_analysis_wedge(
                d.len() as i64,
                d.as_ptr(),
                l.as_ptr(),
                std::ptr::null(),
                3.0,
                psi,
                0.3,
                1.0,
                out.as_mut_ptr(),
            )
        };
        assert_eq!(call(45.0, &mut out), 0, "{}", message());
        let at = |k: c_int| out[k as usize];
        let a = at(GIMLET_INDENTATION_CONTACT_HALF_WIDTH);
        let eps = crate::indentation::wedge::epsilon(a / 3.0);
        assert!(
            (a - (1.0 - eps * 2.0 / 4.0)).abs() < 1e-9,
            "a = {a}, eps = {eps}"
        );
        assert!((at(GIMLET_INDENTATION_HARDNESS) - 2.0 / (2.0 * a)).abs() < 1e-12);
        let e = 2.0 * 4.0 * (3.0 / a).acosh() / std::f64::consts::PI;
        assert!((at(GIMLET_INDENTATION_REDUCED_MODULUS) / e - 1.0).abs() < 1e-8);
        let mut kept = [7.0; GIMLET_INDENTATION_RESULTS as usize];
        assert_eq!(call(0.0, &mut kept), GIMLET_ERR_INVALID_ARGUMENT);
        assert!(message().contains("half_angle = 0"), "{}", message());
        assert!(kept.iter().all(|&v| v == 7.0));
    }

    #[test]
    fn rejects_bad_arguments_without_writing() {
        let (d, l) = curve();
        let mut out = [7.0; GIMLET_INDENTATION_RESULTS as usize];
        let call = |n: i64, depth: *const f64, r0: f64, a: f64, lo: f64, res: *mut f64| {
            // SAFETY: arrays of at least the lengths passed (or NULL).
            unsafe {
                gimlet_indentation_analysis(
                    n,
                    depth,
                    l.as_ptr(),
                    std::ptr::null(),
                    r0,
                    a,
                    lo,
                    1.0,
                    res,
                )
            }
        };
        let nn = d.len() as i64;
        assert_eq!(
            call(nn, d.as_ptr(), 3.0, 0.5, 0.3, std::ptr::null_mut()),
            GIMLET_ERR_NULL_POINTER
        );
        assert_eq!(message(), "gimlet_indentation_analysis: results is NULL");
        assert_eq!(
            call(nn, std::ptr::null(), 3.0, 0.5, 0.3, out.as_mut_ptr()),
            GIMLET_ERR_NULL_POINTER
        );
        assert_eq!(message(), "gimlet_indentation_analysis: depth is NULL");
        assert_eq!(
            call(-1, d.as_ptr(), 3.0, 0.5, 0.3, out.as_mut_ptr()),
            GIMLET_ERR_INVALID_ARGUMENT
        );
        assert!(message().contains("n = -1 must be between 0 and"));
        assert_eq!(
            call(nn, d.as_ptr(), 0.4, 0.5, 0.3, out.as_mut_ptr()),
            GIMLET_ERR_INVALID_ARGUMENT
        );
        assert!(message().contains("r0 = 0.4 must be finite and > contact_half_width = 0.5"));
        assert_eq!(
            call(nn, d.as_ptr(), 3.0, 0.5, 1.5, out.as_mut_ptr()),
            GIMLET_ERR_INVALID_ARGUMENT
        );
        assert!(message().contains("fit_lower = 1.5 must lie in (0, 1)"));
        assert!(out.iter().all(|&v| v == 7.0));
    }
}
