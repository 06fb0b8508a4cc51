//! The contact boundary of a particle and the integrals of the node shape
//! functions over it: `T_ip = ∫_{∂Ω_p} S_i ds` of the paper's eqs. 10–11.
//!
//! A GIMP particle is an axis-aligned rectangle (centre `(x, y)`,
//! half-lengths `(lx, ly)`). Against an indenter whose contact normal `n`
//! points from the indenter into the body, the part of the rectangle's
//! boundary that faces the indenter is its face in y whose outward normal
//! is `−sign(n_y) e_y` (the top face under an indenter above it) and its
//! face in x whose outward normal is `−sign(n_x) e_x`. A uniform pressure
//! `P` along `n` on that boundary, measured per unit area of the indenter
//! surface it covers, loads each face in proportion to its projection on
//! the indenter surface, `|n_y|` for the face in y and `|n_x|` for the face
//! in x:
//!
//! ```text
//! T_ip = |n_y| ∫_{face y} S_i ds + |n_x| ∫_{face x} S_i ds,
//! ℓ_p  = Σ_i T_ip = 2 lx |n_y| + 2 ly |n_x|,
//! ```
//!
//! so that the nodal contact force is `F_i = Σ_p T_ip P_p n_p t` (`t` the
//! plane-strain thickness) and the particle's contact force is `P_p ℓ_p n_p
//! t`: `ℓ_p` is the length of indenter surface the particle covers (its
//! contact-face length). On a face, `S_i` factorises: along the face, the
//! average of the hat function over the particle's extent (the GIMP weight
//! of that axis); across it, the hat function at the face's coordinate.
//! These are the same face integrals that carry surface tractions in the
//! particle loops (see `crate::kernel`).
//!
//! **Where the indenter ends.** A face counts only over its part within the
//! indenter's extent along it (its bounding box), so `ℓ_p` stays the
//! length of indenter surface covered when a particle straddles the edge
//! of a flat punch: its face integrals and its contact-face length are
//! those of the covered part (see [`face_weights`]). Loading the whole
//! face instead widens the punch by up to half a particle and makes the
//! particle drag the material beyond the edge down with the punch: on a
//! perfectly plastic body the flat-punch load came out too high by about
//! 1.3 h/a (+15 % with cells a/8), an error of first order in h.

use crate::shape::{weights_1d, ShapeKind};

/// The face integrals of one particle on its 3×3 node stencil.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaceWeights {
    /// First stencil node (level indices) in x and y.
    pub base: [i64; 2],
    /// `T` of node `(base[0] + a, base[1] + b)` at index `a + 3 b`, in
    /// length units (`Σ t = len`).
    pub t: [f64; 9],
    /// The contact-face length `ℓ = 2 lx |n_y| + 2 ly |n_x|`.
    pub len: f64,
}

/// Values of the hat functions of the nodes `base .. base + 3` at `xi`
/// (cell units from the level's node 0).
pub(super) fn hats(xi: f64, base: i64) -> [f64; 3] {
    let u = xi - base as f64;
    [
        (1.0 - u.abs()).max(0.0),
        (1.0 - (u - 1.0).abs()).max(0.0),
        (1.0 - (u - 2.0).abs()).max(0.0),
    ]
}

/// `∫ hat` over `(−∞, u]` for the unit hat `max(0, 1 − |s|)`.
fn hat_primitive(u: f64) -> f64 {
    if u <= -1.0 {
        0.0
    } else if u <= 0.0 {
        0.5 * (1.0 + u) * (1.0 + u)
    } else if u < 1.0 {
        1.0 - 0.5 * (1.0 - u) * (1.0 - u)
    } else {
        1.0
    }
}

/// The weights along a face of its part `[u0, u1]` (cell units from node
/// 0, `u0 ≤ u1`) on the nodes `base .. base + 3`: the averages of the hat
/// functions over the part (the GIMP weights of a particle that were that
/// part), or for plain MPM their values at its midpoint.
pub(super) fn part_weights(shape: ShapeKind, u0: f64, u1: f64, base: i64) -> [f64; 3] {
    let mid = 0.5 * (u0 + u1);
    if shape == ShapeKind::Mpm || u1 - u0 <= 1e-12 * (1.0 + mid.abs()) {
        return hats(mid, base);
    }
    let inv = 1.0 / (u1 - u0);
    let mut w = [0.0; 3];
    for (k, wk) in w.iter_mut().enumerate() {
        let i = (base + k as i64) as f64;
        *wk = (hat_primitive(u1 - i) - hat_primitive(u0 - i)) * inv;
    }
    w
}

/// The face integrals `T_ip` of a particle at `(x, y)` with half-lengths
/// `(lx, ly)` against a contact normal `n` (unit, from the indenter into the
/// body), on a level with node 0 at `origin` and cell size `h`, with the
/// weight function `shape` (its averages along the faces; for plain MPM the
/// face reduces to its centre point).
///
/// `span = [xlo, ylo, xhi, yhi]` is the indenter's extent (its bounding
/// box): each face counts only over the part of it that lies within the
/// indenter's extent along the face (`[xlo, xhi]` for the face in y,
/// `[ylo, yhi]` for the face in x). A particle straddling the edge of a
/// flat punch thus carries the pressure on the part of its face under the
/// punch, not on the whole face (which would widen the punch by up to half
/// a particle and drag the material beyond its edge down with it). When no
/// face that the normal loads overlaps the extent at all (a particle off a
/// corner, predicted to reach it within the step), the whole faces count.
/// Faces inside the extent give exactly the unclipped integrals.
pub fn face_weights(
    shape: ShapeKind,
    origin: [f64; 2],
    h: f64,
    c: [f64; 2],
    half: [f64; 2],
    n: [f64; 2],
    span: [f64; 4],
) -> FaceWeights {
    let xi = (c[0] - origin[0]) / h;
    let yi = (c[1] - origin[1]) / h;
    let wx = weights_1d(shape, xi, half[0] / h);
    let wy = weights_1d(shape, yi, half[1] / h);
    let (ax, ay) = (n[0].abs(), n[1].abs());
    // The covered part of each face, along it: `None` when it is the whole
    // face; the length (0 when nothing is covered) and the weights along it
    // otherwise.
    let part = |lo: f64, hi: f64, s_lo: f64, s_hi: f64, o: f64, base: i64| {
        if lo >= s_lo && hi <= s_hi {
            return None;
        }
        let (u0, u1) = (lo.max(s_lo), hi.min(s_hi));
        if u1 > u0 {
            Some((
                u1 - u0,
                part_weights(shape, (u0 - o) / h, (u1 - o) / h, base),
            ))
        } else {
            Some((0.0, [0.0; 3]))
        }
    };
    let mut along_x = part(
        c[0] - half[0],
        c[0] + half[0],
        span[0],
        span[2],
        origin[0],
        wx.base,
    );
    let mut along_y = part(
        c[1] - half[1],
        c[1] + half[1],
        span[1],
        span[3],
        origin[1],
        wy.base,
    );
    let covered =
        |p: &Option<(f64, [f64; 3])>, a: f64| a > 0.0 && !matches!(p, Some((l, _)) if *l <= 0.0);
    if !covered(&along_x, ay) && !covered(&along_y, ax) {
        along_x = None;
        along_y = None;
    }
    // (Unclipped faces keep the expressions, hence the bits, of the
    // integrals without an extent.)
    let (sx, len_x, wxf) = match along_x {
        None => (ay * 2.0 * half[0], 2.0 * half[0], wx.w),
        Some((l, w)) => (ay * l, l, w),
    };
    let (sy, len_y, wyf) = match along_y {
        None => (ax * 2.0 * half[1], 2.0 * half[1], wy.w),
        Some((l, w)) => (ax * l, l, w),
    };
    let mut t = [0.0; 9];
    // Face in y: at y - sign(n_y) ly, along x.
    if ay > 0.0 {
        let yf = yi - n[1].signum() * half[1] / h;
        let hy = hats(yf, wy.base);
        let s = sx;
        for b in 0..3 {
            for a in 0..3 {
                t[a + 3 * b] += s * wxf[a] * hy[b];
            }
        }
    }
    // Face in x: at x - sign(n_x) lx, along y.
    if ax > 0.0 {
        let xf = xi - n[0].signum() * half[0] / h;
        let hx = hats(xf, wx.base);
        let s = sy;
        for b in 0..3 {
            for a in 0..3 {
                t[a + 3 * b] += s * hx[a] * wyf[b];
            }
        }
    }
    FaceWeights {
        base: [wx.base, wy.base],
        t,
        len: len_x * ay + len_y * ax,
    }
}

/// How far (along the normal `n`, toward the indenter) the point where a
/// particle's gap is measured lies from the point of its rectangle nearest
/// the indenter, for a plane indenter surface of normal `n` (`half` the
/// half-lengths `lx, ly`):
///
/// - `mode` 0: 0, the nearest point (no point of the domain may enter the
///   indenter);
/// - `mode` 1: the mean distance over the loaded faces, weighted as the
///   face integrals weight them (`2 lx |ny|` the face in y, `2 ly |nx|`
///   the face in x), so that the gap and the face velocity that changes it
///   (`Σ T_ip v_i / ℓ_p`) are the same average:
///   `|nx| |ny| (lx² + ly²) / (lx |ny| + ly |nx|)`;
/// - `mode` 2: the middle of the face in y, `lx |nx|`.
///
/// Zero for an axis normal (the face lies along the indenter's surface).
/// The contact phase measures the gap at the nearest point when the
/// rectangle is nearest to a sharp vertex of the indenter from outside
/// (`Gap::vertex`): a punch's corner or a wedge's apex has no surface for
/// the faces to lie along.
pub fn gap_offset(mode: u8, n: [f64; 2], half: [f64; 2]) -> f64 {
    let (ax, ay) = (n[0].abs(), n[1].abs());
    let [lx, ly] = half;
    match mode {
        1 => {
            let l = lx * ay + ly * ax;
            if l > 0.0 {
                ax * ay * (lx * lx + ly * ly) / l
            } else {
                0.0
            }
        }
        2 => lx * ax,
        _ => 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const UNBOUNDED: [f64; 4] = [
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::INFINITY,
    ];

    /// `∫ S_i` over a segment by midpoint quadrature of the bilinear hats.
    fn quad(i: i64, j: i64, h: f64, p0: [f64; 2], p1: [f64; 2]) -> f64 {
        let n = 20000;
        let len = ((p1[0] - p0[0]).powi(2) + (p1[1] - p0[1]).powi(2)).sqrt();
        (0..n)
            .map(|k| {
                let s = (k as f64 + 0.5) / n as f64;
                let x = p0[0] + s * (p1[0] - p0[0]);
                let y = p0[1] + s * (p1[1] - p0[1]);
                let hx = (1.0 - (x / h - i as f64).abs()).max(0.0);
                let hy = (1.0 - (y / h - j as f64).abs()).max(0.0);
                hx * hy
            })
            .sum::<f64>()
            * len
            / n as f64
    }

    #[test]
    fn face_integrals_match_quadrature_and_sum_to_the_face_length() {
        let h = 0.5;
        let c = [1.37, 2.11];
        let half = [0.125, 0.1];
        let th = 0.7f64;
        // Indenter above and to the left: n points down and to the right.
        let n = [th.sin(), -th.cos()];
        let f = face_weights(ShapeKind::UGimp, [0.0, 0.0], h, c, half, n, UNBOUNDED);
        let mut sum = 0.0;
        for b in 0..3 {
            for a in 0..3 {
                let (i, j) = (f.base[0] + a as i64, f.base[1] + b as i64);
                let want = n[1].abs()
                    * quad(
                        i,
                        j,
                        h,
                        [c[0] - half[0], c[1] + half[1]],
                        [c[0] + half[0], c[1] + half[1]],
                    )
                    + n[0].abs()
                        * quad(
                            i,
                            j,
                            h,
                            [c[0] - half[0], c[1] - half[1]],
                            [c[0] - half[0], c[1] + half[1]],
                        );
                let got = f.t[a + 3 * b];
                assert!((got - want).abs() < 1e-8, "node ({i},{j}): {got} vs {want}");
                sum += got;
            }
        }
        let len = 2.0 * half[0] * n[1].abs() + 2.0 * half[1] * n[0].abs();
        assert!((f.len - len).abs() < 1e-15);
        assert!((sum - len).abs() < 1e-14, "{sum} vs {len}");
    }

    #[test]
    fn a_face_counts_only_where_the_indenter_extends() {
        let h = 0.5;
        let half = [0.125, 0.1];
        let n = [0.0, -1.0];
        // A punch ending at x = 1.3 over the top face [1.245, 1.495] of a
        // particle: only [1.245, 1.3] carries pressure.
        let span = [-2.0, 1.0, 1.3, 4.0];
        let c = [1.37, 2.11];
        let f = face_weights(ShapeKind::UGimp, [0.0, 0.0], h, c, half, n, span);
        let top = c[1] + half[1];
        let (x0, x1) = (c[0] - half[0], 1.3);
        assert!((f.len - (x1 - x0)).abs() < 1e-15, "{}", f.len);
        let mut sum = 0.0;
        for b in 0..3 {
            for a in 0..3 {
                let (i, j) = (f.base[0] + a as i64, f.base[1] + b as i64);
                let want = quad(i, j, h, [x0, top], [x1, top]);
                let got = f.t[a + 3 * b];
                assert!((got - want).abs() < 1e-8, "node ({i},{j}): {got} vs {want}");
                sum += got;
            }
        }
        assert!((sum - f.len).abs() < 1e-14);
        // Plain MPM: the covered part's midpoint.
        let m = face_weights(ShapeKind::Mpm, [0.0, 0.0], h, c, half, n, span);
        let mid = 0.5 * (x0 + x1) / h;
        let hx = hats(mid, m.base[0]);
        let hy = hats(top / h, m.base[1]);
        for (b, wy) in hy.iter().enumerate() {
            for (a, wx) in hx.iter().enumerate() {
                let want = (x1 - x0) * wx * wy;
                assert!((m.t[a + 3 * b] - want).abs() < 1e-15);
            }
        }
        // Inside the extent: bitwise the integrals without one.
        let inside = [0.0, 1.0, 3.0, 4.0];
        assert_eq!(
            face_weights(
                ShapeKind::UGimp,
                [0.0, 0.0],
                h,
                c,
                half,
                [0.6, -0.8],
                inside
            ),
            face_weights(
                ShapeKind::UGimp,
                [0.0, 0.0],
                h,
                c,
                half,
                [0.6, -0.8],
                UNBOUNDED
            )
        );
        // Beside the punch, touching its side: the face in y lies beyond the
        // extent and drops out, the face in x counts over its covered part.
        let side = face_weights(
            ShapeKind::UGimp,
            [0.0, 0.0],
            h,
            [1.425, 1.05],
            half,
            [0.6, -0.8],
            span,
        );
        assert!(
            (side.len - 0.6 * (1.15 - 1.0)).abs() < 1e-15,
            "{}",
            side.len
        );
        // Off the corner, no face covered: the whole faces count.
        let off = face_weights(ShapeKind::UGimp, [0.0, 0.0], h, [1.5, 0.8], half, n, span);
        assert_eq!(off.len, 2.0 * half[0]);
    }

    #[test]
    fn flat_contact_loads_only_the_top_face() {
        // A particle whose top face lies on the node row j = 4: the whole
        // face integral goes to that row, split along x as the GIMP weights.
        let h = 1.0;
        let f = face_weights(
            ShapeKind::UGimp,
            [0.0, 0.0],
            h,
            [2.25, 3.75],
            [0.25, 0.25],
            [0.0, -1.0],
            UNBOUNDED,
        );
        assert_eq!(f.base, [1, 3]);
        assert_eq!(f.len, 0.5);
        // row b = 1 (node row 4) holds everything: x-weights of a particle
        // spanning [2, 2.5]: node 2 gets 0.75, node 3 0.25 (times 0.5).
        let row: Vec<f64> = (0..3).map(|a| f.t[a + 3]).collect();
        assert!((row[0] - 0.0).abs() < 1e-15);
        assert!((row[1] - 0.375).abs() < 1e-15);
        assert!((row[2] - 0.125).abs() < 1e-15);
        for a in 0..3 {
            assert_eq!(f.t[a], 0.0);
            assert_eq!(f.t[a + 6], 0.0);
        }
    }

    #[test]
    fn gap_offset_is_the_face_mean_distance_to_a_plane() {
        // A flank of normal n (from the indenter into the body) and a
        // rectangle touching it at its nearest corner: the mean signed
        // distance over the loaded faces, weighted by their projections
        // (2 lx |ny| for the face in y, 2 ly |nx| for the face in x), by
        // quadrature, against the closed form.
        for &(deg, lx, ly) in &[
            (25.0f64, 1.0, 1.0),
            (25.0, 0.5, 1.5),
            (60.0, 1.0, 0.25),
            (0.0, 1.0, 1.0),
        ] {
            let b = deg.to_radians();
            let n = [b.sin(), -b.cos()];
            // Corner nearest the plane: (-lx, +ly) relative to the centre;
            // the plane through it: n . (p - corner) = 0.
            let corner = [-lx, ly];
            let dist = |p: [f64; 2]| n[0] * (p[0] - corner[0]) + n[1] * (p[1] - corner[1]);
            let m = 2000;
            let (mut top, mut side) = (0.0, 0.0);
            for k in 0..m {
                let s = (k as f64 + 0.5) / m as f64;
                top += dist([-lx + 2.0 * lx * s, ly]) / m as f64;
                side += dist([-lx, -ly + 2.0 * ly * s]) / m as f64;
            }
            let (wt, ws) = (2.0 * lx * n[1].abs(), 2.0 * ly * n[0].abs());
            let mean = (wt * top + ws * side) / (wt + ws);
            let got = gap_offset(1, n, [lx, ly]);
            assert!(
                (got - mean).abs() < 1e-9 * (lx + ly),
                "{deg} deg: {got} vs {mean}"
            );
            assert!((gap_offset(2, n, [lx, ly]) - top).abs() < 1e-9 * (lx + ly));
            assert_eq!(gap_offset(0, n, [lx, ly]), 0.0);
        }
        // An axis normal: the face is parallel to the indenter surface.
        assert_eq!(gap_offset(1, [0.0, -1.0], [1.0, 2.0]), 0.0);
        assert_eq!(gap_offset(2, [0.0, -1.0], [1.0, 2.0]), 0.0);
    }
}
