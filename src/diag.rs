//! Global diagnostics of a particle set and surface loads on particles:
//! pure functions shared by the single-patch solver and the distributed
//! simulation (which sums them over patches and ranks).

use crate::kernel::Side;
use crate::material::{MatParams, Stress, Tensor2};
use crate::mode::{Mode, PlaneStrain};
use crate::particles::{LoadKind, Particles};

/// Kinetic energy, strain energy, momentum x and y, and mass of the owned
/// particles of a set (copies that couple levels are skipped), in that order
/// (extensive quantities are per the plane-strain thickness).
pub fn sums(p: &Particles, mats: &[MatParams]) -> [f64; 5] {
    sums_in::<PlaneStrain>(p, mats)
}

/// [`sums`] in the mode `G`: in axisymmetry per radian, the strain energy
/// with the hoop terms ([`MatParams::strain_energy_in`]).
pub fn sums_in<G: Mode>(p: &Particles, mats: &[MatParams]) -> [f64; 5] {
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
        out[1] += if G::AXISYMMETRIC {
            mats[p.material[i] as usize].strain_energy_in::<G>(&s, &f, p.fzz[i], p.vol0[i])
        } else {
            mats[p.material[i] as usize].strain_energy(&s, &f, p.vol0[i])
        };
        out[2] += m * p.vx[i];
        out[3] += m * p.vy[i];
        out[4] += m;
    }
    out
}

/// The centres of particle `i`'s loaded faces in y and in x (the particle
/// centre where that face carries no load), moved with the particle's
/// deformation gradient: `x + F (0, ty lpy0)` and `x + F (tx lpx0, 0)`.
/// The work of a surface load is its force times the displacement of this
/// point.
pub fn load_points(p: &Particles, i: usize) -> [[f64; 2]; 2] {
    let (ty, tx) = crate::particles::load_faces_of(p.load_faces[i]);
    let (dy, dx) = (ty as f64 * p.lpy0[i], tx as f64 * p.lpx0[i]);
    [
        [p.x[i] + p.fxy[i] * dy, p.y[i] + p.fyy[i] * dy],
        [p.x[i] + p.fxx[i] * dx, p.y[i] + p.fyx[i] * dx],
    ]
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

/// The particle faces a traction is put on: those on `side` lying on the
/// line `at` (`x = at` for left/right, `y = at` for bottom/top) and
/// overlapping the segment `[lo, hi]` along the line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaceLine {
    /// The side of the particles whose faces are loaded.
    pub side: Side,
    /// The line's coordinate.
    pub at: f64,
    /// The segment's start along the line.
    pub lo: f64,
    /// The segment's end along the line.
    pub hi: f64,
}

/// Puts a traction on the particles whose face lies on `line` (within
/// `tol`): each gets `traction × overlap × thickness` added to the
/// reference force of that face (scaled by the load ramp at every step, and
/// spread over the nodes by the face integral of their shape functions: see
/// [`crate::kernel`]). Returns the number of particles loaded. A particle
/// carries loads on at most one face in y (top or bottom) and one in x
/// (left or right): loading the top face of a particle whose bottom face is
/// loaded (a layer one particle thick loaded from both sides) is rejected,
/// and then no particle is loaded. The other arguments are checked by
/// callers (see [`check_traction`]).
pub fn apply_traction(
    p: &mut Particles,
    line: &FaceLine,
    traction: [f64; 2],
    thickness: f64,
    tol: f64,
) -> crate::error::Result<usize> {
    let FaceLine { side, at, lo, hi } = *line;
    let hits = traction_targets(p, side, at, lo, hi, tol, LoadKind::Dead)?;
    load_faces(p, side, &hits, traction, thickness, LoadKind::Dead);
    Ok(hits.len())
}

/// The face sign a side sets (+1 top/right, −1 bottom/left) and whether it
/// is a face in y.
fn face_of(side: Side) -> (i32, bool) {
    match side {
        Side::Left => (-1, false),
        Side::Right => (1, false),
        Side::Bottom => (-1, true),
        Side::Top => (1, true),
    }
}

/// The particles [`apply_traction`] would load with a traction of `kind`,
/// with the overlap of their face with `[lo, hi]`, or its error; changes
/// nothing. A particle carries loads of one kind: a particle already loaded
/// by a traction of the other kind is an error.
pub fn traction_targets(
    p: &Particles,
    side: Side,
    at: f64,
    lo: f64,
    hi: f64,
    tol: f64,
    kind: LoadKind,
) -> crate::error::Result<Vec<(usize, f64)>> {
    use crate::particles::{load_faces_of, load_kind_of};
    let (sign, in_y) = face_of(side);
    let mut hits: Vec<(usize, f64)> = Vec::new();
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
        let (ty, tx) = load_faces_of(p.load_faces[k]);
        if p.load_faces[k] != 0.0 && load_kind_of(p.load_faces[k]) != kind {
            let name = |k: LoadKind| match k {
                LoadKind::Dead => "dead (gimlet_apply_traction)",
                LoadKind::FollowArea => "follower GIMLET_FOLLOW_AREA",
                LoadKind::FollowFace => "follower GIMLET_FOLLOW_FACE",
            };
            return Err(crate::error::Error::arg(format!(
                "particle id {} already carries a {} traction: a particle's loads are all of one kind, this one is {}",
                p.id[k],
                name(load_kind_of(p.load_faces[k])),
                name(kind)
            )));
        }
        let held = if in_y { ty } else { tx };
        if held == -sign {
            let name = |s: i32| match (in_y, s) {
                (true, 1) => "top",
                (true, _) => "bottom",
                (false, 1) => "right",
                (false, _) => "left",
            };
            return Err(crate::error::Error::arg(format!(
                "particle id {} already carries a traction on its {} face: a particle can carry loads on one face in y and one in x, not on {} and {} (use more particles through the thickness of the layer)",
                p.id[k],
                name(held),
                name(held),
                name(sign)
            )));
        }
        hits.push((k, overlap));
    }
    Ok(hits)
}

/// Adds `traction × overlap × thickness` to the `side` face load of each
/// particle `(k, overlap)` of `hits` (from [`traction_targets`] with the
/// same `kind`), and marks the particle's loads as of `kind`.
pub fn load_faces(
    p: &mut Particles,
    side: Side,
    hits: &[(usize, f64)],
    traction: [f64; 2],
    thickness: f64,
    kind: LoadKind,
) {
    use crate::particles::{load_faces_code, load_faces_of};
    let (sign, in_y) = face_of(side);
    for &(k, overlap) in hits {
        let (fx, fy) = (
            traction[0] * overlap * thickness,
            traction[1] * overlap * thickness,
        );
        let (ty, tx) = load_faces_of(p.load_faces[k]);
        if in_y {
            p.fext_x[k] += fx;
            p.fext_y[k] += fy;
            p.load_faces[k] = load_faces_code(sign, tx, kind);
        } else {
            p.fside_x[k] += fx;
            p.fside_y[k] += fy;
            p.load_faces[k] = load_faces_code(ty, sign, kind);
        }
    }
}
