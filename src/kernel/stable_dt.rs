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

/// Particles per block of the loop: the lanes of the running maxima.
const W: usize = 8;

/// `c_p + |v_p|` (see [`stable_dt_cfl1`]), of a particle of material `mp`
/// with deformation gradient `f = [fxx, fxy, fyx, fyy]` and velocity `v`.
#[inline(always)]
pub(crate) fn speed_of(mp: &MatParams, f: [f64; 4], v: [f64; 2]) -> f64 {
    let j = f[0] * f[3] - f[1] * f[2];
    mp.p_wave_speed(j) + (v[0] * v[0] + v[1] * v[1]).sqrt()
}

/// The fields the speeds are formed from, sliced to the particles.
struct Fields<'a> {
    f: [&'a [f64]; 4],
    v: [&'a [f64]; 2],
}

/// Folds the speeds of the particles `0..body` (a multiple of [`W`]) into
/// `top`, lane by lane, all with the material `mp` of law `kind`. Inlined
/// with `kind` a constant, so that the law's branch leaves the loop and the
/// lanes compile to vector instructions (as a closure called per block it
/// compiled to scalar code with the law's branch inside).
#[inline(always)]
fn fold_law(kind: MatKind, mp: &MatParams, a: &Fields, body: usize, top: &mut [f64; W]) {
    let mp = MatParams { kind, ..*mp };
    for lo in (0..body).step_by(W) {
        let at = |x: &[f64]| -> [f64; W] { *x[lo..].first_chunk::<W>().expect("a full block") };
        let (f, v) = (a.f.map(at), a.v.map(at));
        let mut s = [0.0f64; W];
        for l in 0..W {
            s[l] = speed_of(
                &mp,
                [f[0][l], f[1][l], f[2][l], f[3][l]],
                [v[0][l], v[1][l]],
            );
        }
        for l in 0..W {
            top[l] = top[l].max(s[l]);
        }
    }
}

#[inline(always)]
fn max_speed_body<I: simd::Simd4>(parts: &Particles, mats: &[MatParams]) -> f64 {
    let n = parts.len();
    let a = Fields {
        f: [
            &parts.fxx[..n],
            &parts.fxy[..n],
            &parts.fyx[..n],
            &parts.fyy[..n],
        ],
        v: [&parts.vx[..n], &parts.vy[..n]],
    };
    // Eight running maxima (independent lanes), folded at the end.
    let mut top = [0.0f64; W];
    let body = n - n % W;
    if let [mp] = mats {
        // One law for every particle: its branch leaves the loop.
        match mp.kind {
            MatKind::LinearElastic => fold_law(MatKind::LinearElastic, mp, &a, body, &mut top),
            MatKind::J2 => fold_law(MatKind::J2, mp, &a, body, &mut top),
            MatKind::NeoHookean => fold_law(MatKind::NeoHookean, mp, &a, body, &mut top),
        }
    }
    let material = &parts.material[..n];
    let from = if mats.len() == 1 { body } else { 0 };
    let mut last = 0.0f64;
    for p in from..n {
        let mp = &mats[material[p] as usize];
        let f = [a.f[0][p], a.f[1][p], a.f[2][p], a.f[3][p]];
        last = last.max(speed_of(mp, f, [a.v[0][p], a.v[1][p]]));
    }
    top.iter().fold(last, |a, &b| a.max(b))
}
