//! What a nanoindentation user reads off a load–depth curve with unloading,
//! for a 2D (plane-strain) indenter: maximum load and depth, unloading
//! stiffness from a power-law fit of the upper unloading branch (the method
//! of Oliver & Pharr, J. Mater. Res. 7, 1992, adapted to plane strain as
//! below), residual depth, hardness and reduced modulus. Pure: no MPI, no
//! handle, no allocation beyond the fit window.
//!
//! # The plane-strain relations
//!
//! Loads are per unit thickness (N/m); `a` is the contact **half**-width at
//! the start of unloading (the projected contact width is `2a`).
//!
//! * **Hardness** `H = P_max / (2a)`, with `P_max` the load at the start of
//!   unloading (the peak of Oliver–Pharr's curve).
//! * **Stiffness and modulus.** In 3D, Oliver–Pharr use `S = dP/dh =
//!   (2/√π) E_r √A` (Sneddon; for a circle `S = 2 E_r a`): the elastic
//!   half-space has a finite punch compliance. In plane strain it has not:
//!   the surface displacement under a line load grows like `ln|x|`, so the
//!   approach of an indenter towards a distant point, and with it `dP/dh`,
//!   depends on the size of the body, and no relation `S = c E_r a` exists.
//!   What is well defined is the approach relative to a surface point at a
//!   distance `r0 > a` from the axis. For a rigid flat punch of half-width
//!   `a` on an elastic half-space (pressure `P / (π √(a² − x²))`) the
//!   surface slope outside the punch is `du/dx = −(2P/(π E_r)) /
//!   √(x² − a²)` (Johnson, *Contact Mechanics*, §2.8 with the Flamant
//!   kernel `u = −(2P/(π E_r)) ln|x|`), hence the punch sinks below the
//!   surface point at `r0` by `h = (2P/(π E_r)) arccosh(r0/a)`:
//!
//!   `S = dP/dh = π E_r / (2 arccosh(r0/a))`, so `E_r = 2 S arccosh(r0/a) / π`.
//!
//!   By the argument of Sneddon and Barber (for frictionless elastic
//!   unloading, `dP/dh` at contact half-width `a` is that of a flat punch of
//!   the same width, whatever the indenter's profile), this is the unloading
//!   stiffness of any indenter, measured with depths relative to the surface
//!   at `r0`. On a finite body it holds to `O((r0/L)²)` for a body of size
//!   `L` (the body's far-field correction is smooth and even in `x`): take
//!   `r0` a few contact widths from the axis and well inside the body. The
//!   log makes `E_r` forgiving of `a`: `δE_r/E_r ≈ (δa/a) / arccosh(r0/a)`,
//!   about half the relative error in `a` at `r0 = 5a` (in 3D the two are
//!   equal).
//! * **Power-law fit** `P = α (h − h_f)^m` (least squares in `P`, over the
//!   unloading points with `P` between `fit_lower` and `fit_upper` times
//!   `P_max`), `S = m α (h_max − h_f)^(m−1)`; `h` is the relative depth.
//!   For a rigid wedge with flanks at `β` to the surface on an elastic
//!   half-space, `P = E_r a tan β` and, integrating the compliance above,
//!   `h = (2 tan β/π) (a arccosh(r0/a) + r0 arcsin(a/r0))`: no exact power
//!   law (local exponent `1 + 1/ln(2r0/a)` roughly), but a fit over the
//!   upper half of the branch gives `E_r` to −0.66 % at `r0 = 5a` and
//!   −0.38 % at `r0 = 10a` (−2.1 % over 20–100 % of `P_max`; the unit
//!   tests measure it).
//! * `1/E_r = (1 − ν²)/E + (1 − ν_i²)/E_i`; for a rigid indenter `E_r = E* =
//!   E/(1 − ν²)`, the plane-strain modulus.
//! * **Residual depth**: the absolute depth (below the undeformed surface)
//!   at which the load first returns to zero on unloading, interpolated
//!   linearly; NaN when the series stops before. The fit's `h_f` is
//!   reported too (in the relative measure).
//!
//! # Axisymmetry
//!
//! The axisymmetric analysis (cone, sphere, flat punch: Oliver–Pharr as
//! instruments report it, with the true contact area beside it) is
//! [`axisym`]; the closed forms the axisymmetric validation compares with
//! (Lamé, Sneddon, Hertz, the exact sphere, the flat punch) are
//! [`closed_form`]. A level layout for an indentation, from a target number
//! of particles across the expected contact half-width, is [`layout`].
//! The analysis of a wedge with the contact half-width from Oliver–Pharr's
//! contact depth instead of a measured one is [`wedge`].

use crate::error::{Error, Result};

pub mod axisym;
pub mod closed_form;
pub mod layout;
pub mod wedge;

/// A load–depth series with loading and unloading, in time order.
#[derive(Clone, Copy, Debug)]
pub struct Series<'a> {
    /// Depth of the indenter tip below the undeformed surface (m).
    pub depth: &'a [f64],
    /// Load on the indenter per unit thickness (N/m, pushing it up > 0).
    pub load: &'a [f64],
    /// Downward displacement of the surface point at distance `r0` from the
    /// axis at the same instants (m); the relative depth is `depth − sink`.
    /// `None`: the depths are already relative to that point.
    pub sink: Option<&'a [f64]>,
}

/// Parameters of the analysis.
#[derive(Clone, Copy, Debug)]
pub struct Options {
    /// Distance from the axis of the surface point the relative depth is
    /// measured from (m, `> contact_half_width`).
    pub r0: f64,
    /// Contact half-width at the start of unloading (m, `> 0`), e.g. from
    /// the contact-surface query.
    pub contact_half_width: f64,
    /// Lower end of the fit window as a fraction of `P_max` (in `(0, 1)`).
    pub fit_lower: f64,
    /// Upper end of the fit window as a fraction of `P_max` (in
    /// `(fit_lower, 1]`).
    pub fit_upper: f64,
}

impl Default for Options {
    /// `r0 = 0`, `a = 0` (both must be set), fit window 50–100 % of `P_max`.
    fn default() -> Self {
        Options {
            r0: 0.0,
            contact_half_width: 0.0,
            fit_lower: 0.5,
            fit_upper: 1.0,
        }
    }
}

/// What the analysis finds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Analysis {
    /// The largest load of the series (N/m).
    pub max_load: f64,
    /// The depth at the largest load (m).
    pub depth_at_max_load: f64,
    /// The largest depth of the series (m).
    pub max_depth: f64,
    /// `P_max`: the load at the start of unloading, the last instant at the
    /// largest depth (N/m).
    pub unload_load: f64,
    /// The contact half-width used (m).
    pub contact_half_width: f64,
    /// Fit coefficient `α` of `P = α (h − h_f)^m` (N/m per m^m).
    pub fit_alpha: f64,
    /// Fit exponent `m`.
    pub fit_m: f64,
    /// Fit offset `h_f`, in the relative-depth measure (m).
    pub fit_h_f: f64,
    /// RMS residual of the fit over the window, relative to `P_max`.
    pub fit_rms: f64,
    /// Number of points in the fit window.
    pub fit_points: usize,
    /// The relative depth (`depth − sink`) at the start of unloading (m).
    pub unload_relative_depth: f64,
    /// Unloading stiffness `S = dP/dh` at the start of unloading (Pa: N/m
    /// per m of depth).
    pub stiffness: f64,
    /// Absolute depth at which the load first returns to zero on unloading
    /// (m); NaN if it never does within the series.
    pub residual_depth: f64,
    /// Hardness `P_max / (2a)` (Pa).
    pub hardness: f64,
    /// Reduced modulus `E_r = 2 S arccosh(r0/a) / π` (Pa).
    pub reduced_modulus: f64,
}

fn check_finite(v: &[f64], name: &str) -> Result<()> {
    if let Some(k) = v.iter().position(|x| !x.is_finite()) {
        return Err(Error::arg(format!("{name}[{k}] = {} must be finite", v[k])));
    }
    Ok(())
}

/// Analyses a load–depth series with unloading (see the module
/// documentation for the relations). Errors name the argument and the
/// bound it broke: series of different lengths or with non-finite values,
/// `r0 <= a`, `a <= 0`, a fit window outside `0 < fit_lower < fit_upper <=
/// 1`, a non-positive `P_max`, or fewer than 3 distinct unloading points in
/// the window.
pub fn analyse(series: Series<'_>, opts: Options) -> Result<Analysis> {
    let n = series.depth.len();
    if series.load.len() != n {
        return Err(Error::arg(format!(
            "load has {} values but depth has {n}: they must have the same length",
            series.load.len()
        )));
    }
    if let Some(s) = series.sink {
        if s.len() != n {
            return Err(Error::arg(format!(
                "sink has {} values but depth has {n}: they must have the same length",
                s.len()
            )));
        }
        check_finite(s, "sink")?;
    }
    if n < 4 {
        return Err(Error::arg(format!(
            "n = {n} must be >= 4 (a loading and an unloading branch)"
        )));
    }
    check_finite(series.depth, "depth")?;
    check_finite(series.load, "load")?;
    let a = opts.contact_half_width;
    if !(a.is_finite() && a > 0.0) {
        return Err(Error::arg(format!(
            "contact_half_width = {a} must be finite and > 0"
        )));
    }
    if !(opts.r0.is_finite() && opts.r0 > a) {
        return Err(Error::arg(format!(
            "r0 = {} must be finite and > contact_half_width = {a}",
            opts.r0
        )));
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

    let rel = |i: usize| series.depth[i] - series.sink.map_or(0.0, |s| s[i]);
    let mut out = Analysis {
        contact_half_width: a,
        ..Default::default()
    };
    let u = fit_unloading(series.depth, series.load, lo, hi, rel)?;
    out.max_load = series.load[u.imax_p];
    out.depth_at_max_load = series.depth[u.imax_p];
    out.max_depth = series.depth[u.imax_d];
    out.unload_load = u.pu;
    out.unload_relative_depth = rel(u.iu);
    out.fit_alpha = u.fit.alpha;
    out.fit_m = u.fit.m;
    out.fit_h_f = u.fit.h_f;
    out.fit_points = u.points;
    out.fit_rms = u.rms;
    out.stiffness = u.stiffness;
    out.hardness = u.pu / (2.0 * a);
    out.reduced_modulus = 2.0 * out.stiffness * (opts.r0 / a).acosh() / std::f64::consts::PI;
    out.residual_depth = residual_depth(series.load, u.iu, |i| series.depth[i]);
    Ok(out)
}

/// The unloading branch of a load–depth series and its power-law fit, the
/// part of the analysis that does not depend on the geometry.
struct Unloading {
    /// The index of the largest load (the first, when it repeats).
    imax_p: usize,
    /// The index of the largest depth (the first, when it repeats).
    imax_d: usize,
    /// The start of unloading: the last instant at the largest depth (a
    /// hold at the deepest point repeats the depth exactly).
    iu: usize,
    /// The load at `iu` (> 0).
    pu: f64,
    /// The fit `P = α (h − h_f)^m` over the fit window.
    fit: Fit,
    /// The number of points in the fit window.
    points: usize,
    /// The fit's RMS residual over `pu`.
    rms: f64,
    /// `dP/dh` of the fit at the depth of `iu` (NaN when that depth is not
    /// beyond `h_f`).
    stiffness: f64,
}

/// Finds the start of unloading in `depth`/`load` (the raw depths decide
/// it) and fits `P = α (h − h_f)^m` to the unloading points with
/// `lo P_u ≤ P ≤ hi P_u`, `h` measured by `h_of(i)`. Errors name the load at
/// the start of unloading when it is not positive, and the window when it
/// holds fewer than 3 distinct depths.
fn fit_unloading(
    depth: &[f64],
    load: &[f64],
    lo: f64,
    hi: f64,
    h_of: impl Fn(usize) -> f64,
) -> Result<Unloading> {
    let n = depth.len();
    let (mut imax_p, mut imax_d) = (0, 0);
    for i in 0..n {
        if load[i] > load[imax_p] {
            imax_p = i;
        }
        if depth[i] > depth[imax_d] {
            imax_d = i;
        }
    }
    let hmax = depth[imax_d];
    let tol = 1e-9 * hmax.abs();
    let iu = (0..n)
        .rev()
        .find(|&i| depth[i] >= hmax - tol)
        .unwrap_or(imax_d);
    let pu = load[iu];
    if pu <= 0.0 {
        return Err(Error::arg(format!(
            "load[{iu}] = {pu} at the start of unloading (the last point at the largest depth) must be > 0"
        )));
    }
    // The fit window: unloading points with lo P_max <= P <= hi P_max.
    let mut h = Vec::new();
    let mut p = Vec::new();
    for (i, &l) in load.iter().enumerate().skip(iu) {
        if l >= lo * pu && l <= hi * pu * (1.0 + 1e-12) {
            h.push(h_of(i));
            p.push(l);
        }
    }
    let hmin = h.iter().cloned().fold(f64::INFINITY, f64::min);
    let hmaxw = h.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    if h.len() < 3 || hmaxw - hmin <= 1e-12 * hmaxw.abs().max(f64::MIN_POSITIVE) {
        return Err(Error::arg(format!(
            "the unloading branch has {} point(s) with loads between fit_lower = {lo} and fit_upper = {hi} \
             times P_max = {pu} (at distinct depths); at least 3 are needed",
            h.len()
        )));
    }
    let fit = fit_power_law(&h, &p);
    let hu = h_of(iu);
    let stiffness = if hu > fit.h_f {
        fit.m * fit.alpha * (hu - fit.h_f).powf(fit.m - 1.0)
    } else {
        f64::NAN
    };
    Ok(Unloading {
        imax_p,
        imax_d,
        iu,
        pu,
        fit,
        points: h.len(),
        rms: (fit.sse / h.len() as f64).sqrt() / pu,
        stiffness,
    })
}

/// The depth at which the load first returns to zero after `iu`,
/// interpolated linearly between the samples (depths `h_of(i)`); NaN when
/// the series stops before.
fn residual_depth(load: &[f64], iu: usize, h_of: impl Fn(usize) -> f64) -> f64 {
    for i in iu + 1..load.len() {
        let (l0, l1) = (load[i - 1], load[i]);
        if l1 <= 0.0 {
            let (d0, d1) = (h_of(i - 1), h_of(i));
            return if l0 > 0.0 {
                d0 + (d1 - d0) * l0 / (l0 - l1)
            } else {
                d1
            };
        }
    }
    f64::NAN
}

/// A fit `P = α (h − h_f)^m` and its sum of squared residuals in `P`.
#[derive(Clone, Copy, Debug)]
struct Fit {
    alpha: f64,
    m: f64,
    h_f: f64,
    sse: f64,
}

/// For a given `h_f`: `α` and `m` by linear least squares on the logs, and
/// the sum of squared residuals in `P`.
fn fit_at(h: &[f64], p: &[f64], h_f: f64) -> Fit {
    let k = h.len() as f64;
    let (mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0);
    for (&hi, &pi) in h.iter().zip(p) {
        let x = (hi - h_f).ln();
        let y = pi.ln();
        sx += x;
        sy += y;
        sxx += x * x;
        sxy += x * y;
    }
    let den = k * sxx - sx * sx;
    let m = if den.abs() > 0.0 {
        (k * sxy - sx * sy) / den
    } else {
        1.0
    };
    let alpha = ((sy - m * sx) / k).exp();
    Fit {
        alpha,
        m,
        h_f,
        sse: sse(h, p, alpha, m, h_f),
    }
}

fn sse(h: &[f64], p: &[f64], alpha: f64, m: f64, h_f: f64) -> f64 {
    let s: f64 = h
        .iter()
        .zip(p)
        .map(|(&hi, &pi)| {
            let r = alpha * (hi - h_f).powf(m) - pi;
            r * r
        })
        .sum();
    if s.is_finite() {
        s
    } else {
        f64::INFINITY
    }
}

/// Least squares in `P` of `P = α (h − h_f)^m` over the points (`h`
/// distinct, `P > 0`): the `h_f` profile of the log-linear fit is scanned
/// and refined by golden sections, then Levenberg–Marquardt polishes all
/// three parameters in `P`.
fn fit_power_law(h: &[f64], p: &[f64]) -> Fit {
    let hmin = h.iter().cloned().fold(f64::INFINITY, f64::min);
    let hmax = h.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let span = hmax - hmin;
    // h_f = hmin − d, d from 1e-6 span to 1e4 span, log-spaced.
    let (lo, hi) = ((1e-6f64).ln(), (1e4f64).ln());
    let steps: usize = 200;
    let at = |t: f64| fit_at(h, p, hmin - span * t.exp());
    let mut best = (0usize, at(lo));
    for j in 1..=steps {
        let t = lo + (hi - lo) * j as f64 / steps as f64;
        let f = at(t);
        if f.sse < best.1.sse {
            best = (j, f);
        }
    }
    let tj = |j: usize| lo + (hi - lo) * j as f64 / steps as f64;
    let (mut a, mut b) = (tj(best.0.saturating_sub(1)), tj((best.0 + 1).min(steps)));
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
    let (mut fc, mut fd) = (at(c).sse, at(d).sse);
    for _ in 0..80 {
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - g * (b - a);
            fc = at(c).sse;
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + g * (b - a);
            fd = at(d).sse;
        }
    }
    let mut f = at(0.5 * (a + b));
    if best.1.sse < f.sse {
        f = best.1;
    }
    polish(h, p, f, hmin)
}

/// Levenberg–Marquardt on `(α, m, h_f)` with residuals in `P`, keeping
/// `h_f < hmin`; returns the better of the start and the result.
fn polish(h: &[f64], p: &[f64], start: Fit, hmin: f64) -> Fit {
    use nalgebra::{Matrix3, Vector3};
    let mut f = start;
    let mut lambda = 1e-3;
    for _ in 0..100 {
        let mut jtj = Matrix3::<f64>::zeros();
        let mut jtr = Vector3::<f64>::zeros();
        for (&hi, &pi) in h.iter().zip(p) {
            let x = hi - f.h_f;
            let g = x.powf(f.m);
            let r = f.alpha * g - pi;
            let j = Vector3::new(g, f.alpha * g * x.ln(), -f.alpha * f.m * g / x);
            jtj += j * j.transpose();
            jtr += j * r;
        }
        let mut improved = false;
        for _ in 0..20 {
            let mut a = jtj;
            for k in 0..3 {
                a[(k, k)] += lambda * jtj[(k, k)].max(f64::MIN_POSITIVE);
            }
            let Some(step) = a.lu().solve(&(-jtr)) else {
                lambda *= 10.0;
                continue;
            };
            let (alpha, m, h_f) = (f.alpha + step[0], f.m + step[1], f.h_f + step[2]);
            if alpha > 0.0 && h_f < hmin && m.is_finite() {
                let s = sse(h, p, alpha, m, h_f);
                if s < f.sse {
                    let rel = (f.sse - s) / f.sse.max(f64::MIN_POSITIVE);
                    f = Fit {
                        alpha,
                        m,
                        h_f,
                        sse: s,
                    };
                    lambda = (lambda * 0.3).max(1e-12);
                    improved = rel > 1e-14;
                    break;
                }
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    f
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs()
    }

    /// Loading `P = c h²` to `h_max`, a hold, then unloading along `P =
    /// α (h − h_f)^m` to zero and on (no contact), with `sink` = 0.
    fn power_curve(alpha: f64, m: f64, h_f: f64, h_max: f64) -> (Vec<f64>, Vec<f64>) {
        let pmax = alpha * (h_max - h_f).powf(m);
        let (mut d, mut l) = (Vec::new(), Vec::new());
        for i in 0..=50 {
            let hh = h_max * i as f64 / 50.0;
            d.push(hh);
            l.push(pmax * (hh / h_max).powi(2));
        }
        for _ in 0..5 {
            d.push(h_max);
            l.push(pmax);
        }
        // Equal depth steps, one landing on h_f.
        let dh = (h_max - h_f) / 60.0;
        for i in 1..=80 {
            let hh = h_max - dh * i as f64;
            d.push(hh);
            l.push(if hh > h_f {
                alpha * (hh - h_f).powf(m)
            } else {
                0.0
            });
        }
        (d, l)
    }

    #[test]
    fn exact_power_law_unloading_is_recovered() {
        let (alpha, m, h_f, h_max) = (3.0e12, 1.4, 2.0e-7, 4.5e-7);
        let (d, l) = power_curve(alpha, m, h_f, h_max);
        let (a, r0) = (5.0e-7, 3.0e-6);
        let r = analyse(
            Series {
                depth: &d,
                load: &l,
                sink: None,
            },
            Options {
                r0,
                contact_half_width: a,
                fit_lower: 0.4,
                fit_upper: 1.0,
            },
        )
        .unwrap();
        let pmax = alpha * (h_max - h_f).powf(m);
        let s = m * alpha * (h_max - h_f).powf(m - 1.0);
        assert!(rel(r.fit_m, m) < 1e-7, "{r:?}");
        assert!(rel(r.fit_alpha, alpha) < 1e-5, "{r:?}");
        assert!(rel(r.fit_h_f, h_f) < 1e-7, "{r:?}");
        assert!(rel(r.stiffness, s) < 1e-7, "{r:?}");
        assert!(r.fit_rms < 1e-9);
        assert_eq!(r.unload_load, pmax);
        assert_eq!(r.max_load, pmax);
        assert_eq!(r.max_depth, h_max);
        assert_eq!(r.hardness, pmax / (2.0 * a));
        assert!(rel(r.reduced_modulus, 2.0 * s * (r0 / a).acosh() / PI) < 1e-7);
        // Unloading reaches zero at h_f exactly (sink = 0 here).
        assert!(rel(r.residual_depth, h_f) < 1e-12, "{r:?}");
        // The window starts at the last point of the hold (index 55); points
        // below 40 % of P_max are outside it.
        let inside = (55..d.len())
            .filter(|&i| l[i] >= 0.4 * pmax && l[i] <= pmax)
            .count();
        assert_eq!(r.fit_points, inside);
    }

    #[test]
    fn linear_unloading_gives_its_slope() {
        // A flat punch unloads linearly (m = 1).
        let (alpha, h_f, h_max) = (2.0e9, 1.0e-7, 3.0e-7);
        let (d, l) = power_curve(alpha, 1.0, h_f, h_max);
        let r = analyse(
            Series {
                depth: &d,
                load: &l,
                sink: None,
            },
            Options {
                r0: 1e-5,
                contact_half_width: 1e-6,
                ..Default::default()
            },
        )
        .unwrap();
        assert!(rel(r.stiffness, alpha) < 1e-6, "{r:?}");
        assert!((r.fit_m - 1.0).abs() < 1e-6, "{r:?}");
    }

    /// The 2D elastic wedge on a half-space, depths relative to the surface
    /// at r0: `P = E* a tan β`, `h = (2 tan β/π)(a arccosh(r0/a) + r0
    /// arcsin(a/r0))`; unloading retraces loading. Returns depth and load.
    pub(super) fn elastic_wedge(
        e_star: f64,
        beta: f64,
        r0: f64,
        a_max: f64,
    ) -> (Vec<f64>, Vec<f64>) {
        let tb = beta.tan();
        let hh = |a: f64| 2.0 * tb / PI * (a * (r0 / a).acosh() + r0 * (a / r0).asin());
        let (mut d, mut l) = (vec![0.0], vec![0.0]);
        for i in 1..=200 {
            let a = a_max * i as f64 / 200.0;
            d.push(hh(a));
            l.push(e_star * a * tb);
        }
        for i in (0..200).rev() {
            let a = a_max * i as f64 / 200.0;
            d.push(if a > 0.0 { hh(a) } else { 0.0 });
            l.push(e_star * a * tb);
        }
        (d, l)
    }

    #[test]
    fn elastic_wedge_half_space_gives_back_the_plane_strain_modulus() {
        // The compliance relation itself, on the exact 2D wedge curve: the
        // only approximation is the power law over the window.
        let e_star = 70e9 / (1.0 - 0.33f64 * 0.33);
        let beta = 25f64.to_radians();
        for (r0_over_a, lo, bound) in [(5.0, 0.5, 0.01), (10.0, 0.5, 0.01), (5.0, 0.2, 0.03)] {
            let a = 3e-7;
            let r0 = r0_over_a * a;
            let (d, l) = elastic_wedge(e_star, beta, r0, a);
            let r = analyse(
                Series {
                    depth: &d,
                    load: &l,
                    sink: None,
                },
                Options {
                    r0,
                    contact_half_width: a,
                    fit_lower: lo,
                    fit_upper: 1.0,
                },
            )
            .unwrap();
            let err = rel(r.reduced_modulus, e_star);
            println!(
                "r0/a {r0_over_a}, window from {lo}: E_r/E* - 1 = {:+.3} %, m = {:.3}",
                100.0 * (r.reduced_modulus / e_star - 1.0),
                r.fit_m
            );
            assert!(
                err < bound,
                "r0/a {r0_over_a}, window from {lo}: E_r {} vs E* {e_star}: {:.3} %",
                r.reduced_modulus,
                100.0 * err
            );
            // The exact slope dP/dh at a: π E* / (2 arccosh(r0/a)).
            let s = PI * e_star / (2.0 * (r0 / a).acosh());
            assert!(rel(r.stiffness, s) < bound);
            // The elastic wedge leaves no impression.
            assert!(r.residual_depth.abs() < 1e-3 * r.max_depth, "{r:?}");
            assert!(r.fit_m > 1.0 && r.fit_m < 2.0, "{r:?}");
        }
    }

    #[test]
    fn sink_is_subtracted_from_the_depth() {
        let e_star = 1e9;
        let (a, r0) = (1.0, 5.0);
        let (h_rel, l) = elastic_wedge(e_star, 0.3, r0, a);
        // The reference point sinks by 30 % of the relative depth plus a
        // constant: the relative depth is what the fit sees.
        let sink: Vec<f64> = h_rel.iter().map(|h| 0.3 * h + 0.01).collect();
        let depth: Vec<f64> = h_rel.iter().zip(&sink).map(|(h, s)| h + s).collect();
        let opts = Options {
            r0,
            contact_half_width: a,
            ..Default::default()
        };
        let plain = analyse(
            Series {
                depth: &h_rel,
                load: &l,
                sink: None,
            },
            opts,
        )
        .unwrap();
        let sunk = analyse(
            Series {
                depth: &depth,
                load: &l,
                sink: Some(&sink),
            },
            opts,
        )
        .unwrap();
        assert!(rel(sunk.stiffness, plain.stiffness) < 1e-9);
        assert!(rel(sunk.reduced_modulus, plain.reduced_modulus) < 1e-9);
        // The residual depth is absolute: where the load returns to zero.
        assert!((sunk.residual_depth - 0.01).abs() < 1e-12, "{sunk:?}");
    }

    #[test]
    fn noisy_unloading_stays_close() {
        // Deterministic ±0.5 % load noise on a known power law.
        let (alpha, m, h_f, h_max) = (1.0e12, 1.5, 1.0e-7, 4.0e-7);
        let (d, mut l) = power_curve(alpha, m, h_f, h_max);
        let mut x = 12345u64;
        for v in l.iter_mut() {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let u = (x >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            *v *= 1.0 + 0.01 * u;
        }
        let r = analyse(
            Series {
                depth: &d,
                load: &l,
                sink: None,
            },
            Options {
                r0: 1e-5,
                contact_half_width: 1e-6,
                ..Default::default()
            },
        )
        .unwrap();
        let s = m * alpha * (h_max - h_f).powf(m - 1.0);
        assert!(rel(r.stiffness, s) < 0.03, "{r:?} vs S = {s}");
        assert!(r.fit_rms < 0.005);
    }

    #[test]
    fn arguments_are_checked_by_name_and_bound() {
        let (d, l) = power_curve(1.0, 1.5, 0.1, 1.0);
        let ok = Options {
            r0: 10.0,
            contact_half_width: 1.0,
            ..Default::default()
        };
        let s = |depth: &'static [f64], load: &'static [f64]| Series {
            depth,
            load,
            sink: None,
        };
        let d: &'static [f64] = Box::leak(d.into_boxed_slice());
        let l: &'static [f64] = Box::leak(l.into_boxed_slice());
        let msg = |r: Result<Analysis>| r.unwrap_err().msg;
        assert!(msg(analyse(s(d, &l[1..]), ok)).contains("load has"));
        assert!(msg(analyse(s(&d[..3], &l[..3]), ok)).contains("n = 3 must be >= 4"));
        let mut bad = d.to_vec();
        bad[7] = f64::NAN;
        let bad: &'static [f64] = Box::leak(bad.into_boxed_slice());
        assert!(msg(analyse(s(bad, l), ok)).contains("depth[7] = NaN must be finite"));
        let with = |o: Options| msg(analyse(s(d, l), o));
        assert!(with(Options { r0: 1.0, ..ok })
            .contains("r0 = 1 must be finite and > contact_half_width = 1"));
        assert!(with(Options {
            contact_half_width: 0.0,
            ..ok
        })
        .contains("contact_half_width = 0 must be finite and > 0"));
        assert!(with(Options {
            fit_lower: 0.0,
            ..ok
        })
        .contains("fit_lower = 0 must lie in (0, 1)"));
        assert!(with(Options {
            fit_upper: 0.4,
            ..ok
        })
        .contains("fit_upper = 0.4 must lie in (fit_lower = 0.5, 1]"));
        assert!(with(Options {
            fit_lower: 0.999,
            fit_upper: 1.0,
            ..ok
        })
        .contains("at least 3 are needed"));
        let sink = [0.0; 3];
        assert!(msg(analyse(
            Series {
                depth: d,
                load: l,
                sink: Some(&sink)
            },
            ok
        ))
        .contains("sink has 3 values"));
        let zeros = vec![0.0; d.len()];
        let zeros: &'static [f64] = Box::leak(zeros.into_boxed_slice());
        assert!(msg(analyse(s(d, zeros), ok)).contains("must be > 0"));
    }
}
