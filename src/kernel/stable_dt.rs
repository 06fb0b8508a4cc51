//! The stable time step: `min_p h / (c_p + |v_p|)` over a patch's particles
//! ([`stable_dt_cfl1`]).

use super::isa::multiversion;
use super::simd;
use crate::material::{MatKind, MatParams};
use crate::particles::Particles;

/// `min_p h / (c_p + |v_p|)` over the particles (the stable step at CFL 1),
/// with `c_p` the P-wave speed at the particle's current Jacobian. Infinite
/// without particles. Requires valid material indices.
///
/// Computed as `h / max_p (c_p + |v_p|)`, which is the same number:
/// `c_p + |v_p|` is never negative, and a correctly rounded division by a
/// non-negative number does not increase as the number grows (`NaN` speeds
/// are left out by both `min` and `max`; no particle, or only zero or `NaN`
/// speeds, give `h / 0 = ∞`). One division per call instead of one per
/// particle, and with one material the law's branch leaves the loop.
///
/// The loop runs with the best instruction set the CPU has (see
/// [`super::isa`]): the largest of a set of numbers does not depend on the order
/// it is taken in, so every build gives the same bits.
pub fn stable_dt_cfl1(parts: &Particles, mats: &[MatParams], h: f64) -> f64 {
    h / max_speed(parts, mats)
}

multiversion! {
    /// `max_p (c_p + |v_p|)` for [`stable_dt_cfl1`] (0 without particles).
    fn max_speed[][](parts: &Particles, mats: &[MatParams]) -> f64 = max_speed_body;
}

#[inline(always)]
fn max_speed_body<I: simd::Simd4>(parts: &Particles, mats: &[MatParams]) -> f64 {
    let n = parts.len();
    let (fxx, fxy, fyx, fyy) = (
        &parts.fxx[..n],
        &parts.fxy[..n],
        &parts.fyx[..n],
        &parts.fyy[..n],
    );
    let (vx, vy) = (&parts.vx[..n], &parts.vy[..n]);
    // Inlined into every loop (as a closure it stayed a call per particle).
    #[inline(always)]
    fn speed_of(mp: &MatParams, f: [f64; 4], v: [f64; 2]) -> f64 {
        let j = f[0] * f[3] - f[1] * f[2];
        mp.p_wave_speed(j) + (v[0] * v[0] + v[1] * v[1]).sqrt()
    }
    // Eight running maxima (independent lanes), folded at the end.
    const W: usize = 8;
    let mut top = [0.0f64; W];
    let mut fold = |mp: &MatParams, lo: usize| {
        for (l, t) in top.iter_mut().enumerate() {
            let p = lo + l;
            let s = speed_of(mp, [fxx[p], fxy[p], fyx[p], fyy[p]], [vx[p], vy[p]]);
            *t = t.max(s);
        }
    };
    let body = n - n % W;
    if let [mp] = mats {
        // One law for every particle: its branch leaves the loop.
        match mp.kind {
            MatKind::LinearElastic => {
                let mp = MatParams {
                    kind: MatKind::LinearElastic,
                    ..*mp
                };
                (0..body).step_by(W).for_each(|lo| fold(&mp, lo));
            }
            MatKind::J2 => {
                let mp = MatParams {
                    kind: MatKind::J2,
                    ..*mp
                };
                (0..body).step_by(W).for_each(|lo| fold(&mp, lo));
            }
            MatKind::NeoHookean => {
                let mp = MatParams {
                    kind: MatKind::NeoHookean,
                    ..*mp
                };
                (0..body).step_by(W).for_each(|lo| fold(&mp, lo));
            }
        }
    }
    let material = &parts.material[..n];
    let from = if mats.len() == 1 { body } else { 0 };
    let mut last = 0.0f64;
    for p in from..n {
        let mp = &mats[material[p] as usize];
        let s = speed_of(mp, [fxx[p], fxy[p], fyx[p], fyy[p]], [vx[p], vy[p]]);
        last = last.max(s);
    }
    top.iter().fold(last, |a, &b| a.max(b))
}
