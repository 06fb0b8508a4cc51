//! Global diagnostics of a particle set and surface loads on particles:
//! pure functions shared by the single-patch solver and the distributed
//! simulation (which sums them over patches and ranks).

use crate::kernel::Side;
use crate::material::{MatParams, Stress, Tensor2};
use crate::particles::Particles;

/// Kinetic energy, strain energy, momentum x and y, and mass of the owned
/// particles of a set (copies that couple levels are skipped), in that order
/// (extensive quantities are per the plane-strain thickness).
pub fn sums(p: &Particles, mats: &[MatParams]) -> [f64; 5] {
    let mut out = [0.0; 5];
    for i in 0..p.len() {
        if p.copy[i] != crate::particles::OWNED {
            continue;
        }
        let m = p.mass[i];
        out[0] += 0.5 * m * (p.vx[i] * p.vx[i] + p.vy[i] * p.vy[i]);
        let s = Stress {
            xx: p.sxx[i],
            yy: p.syy[i],
            xy: p.sxy[i],
            zz: p.szz[i],
        };
        let f = Tensor2 {
            xx: p.fxx[i],
            xy: p.fxy[i],
            yx: p.fyx[i],
            yy: p.fyy[i],
        };
        out[1] += mats[p.material[i] as usize].strain_energy(&s, &f, p.vol0[i]);
        out[2] += m * p.vx[i];
        out[3] += m * p.vy[i];
        out[4] += m;
    }
    out
}

/// Checks the arguments of a traction load: a finite segment `[lo, hi]` on
/// the line `at` with `lo < hi`, and a finite traction.
pub fn check_traction(at: f64, lo: f64, hi: f64, t: [f64; 2]) -> crate::error::Result<()> {
    if !(at.is_finite() && lo.is_finite() && hi.is_finite() && lo < hi) {
        return Err(crate::error::Error::arg(format!(
            "segment [lo, hi] = [{lo}, {hi}] on the line {at} must be finite with lo < hi"
        )));
    }
    if !(t[0].is_finite() && t[1].is_finite()) {
        return Err(crate::error::Error::arg(format!(
            "traction ({}, {}) must be finite",
            t[0], t[1]
        )));
    }
    Ok(())
}

/// Puts a traction on the particles whose face on `side` lies on the line
/// `at` (`x = at` for left/right, `y = at` for bottom/top, within `tol`) and
/// overlaps the segment `[lo, hi]` along the line: each gets `fext +=
/// traction × overlap × thickness` (scaled by the load ramp at every step).
/// Returns the number of particles loaded. Arguments are checked by callers.
#[allow(clippy::too_many_arguments)]
pub fn apply_traction(
    p: &mut Particles,
    side: Side,
    at: f64,
    lo: f64,
    hi: f64,
    traction: [f64; 2],
    thickness: f64,
    tol: f64,
) -> usize {
    let mut count = 0;
    for k in 0..p.len() {
        let (face, c, half) = match side {
            Side::Left => (p.x[k] - p.lpx[k], p.y[k], p.lpy[k]),
            Side::Right => (p.x[k] + p.lpx[k], p.y[k], p.lpy[k]),
            Side::Bottom => (p.y[k] - p.lpy[k], p.x[k], p.lpx[k]),
            Side::Top => (p.y[k] + p.lpy[k], p.x[k], p.lpx[k]),
        };
        if (face - at).abs() > tol {
            continue;
        }
        let overlap = (c + half).min(hi) - (c - half).max(lo);
        if overlap <= 0.0 {
            continue;
        }
        p.fext_x[k] += traction[0] * overlap * thickness;
        p.fext_y[k] += traction[1] * overlap * thickness;
        count += 1;
    }
    count
}
