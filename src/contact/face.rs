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
fn hats(xi: f64, base: i64) -> [f64; 3] {
    let u = xi - base as f64;
    [
        (1.0 - u.abs()).max(0.0),
        (1.0 - (u - 1.0).abs()).max(0.0),
        (1.0 - (u - 2.0).abs()).max(0.0),
    ]
}

/// The face integrals `T_ip` of a particle at `(x, y)` with half-lengths
/// `(lx, ly)` against a contact normal `n` (unit, from the indenter into the
/// body), on a level with node 0 at `origin` and cell size `h`, with the
/// weight function `shape` (its averages along the faces; for plain MPM the
/// face reduces to its centre point).
pub fn face_weights(
    shape: ShapeKind,
    origin: [f64; 2],
    h: f64,
    c: [f64; 2],
    half: [f64; 2],
    n: [f64; 2],
) -> FaceWeights {
    let xi = (c[0] - origin[0]) / h;
    let yi = (c[1] - origin[1]) / h;
    let wx = weights_1d(shape, xi, half[0] / h);
    let wy = weights_1d(shape, yi, half[1] / h);
    let (ax, ay) = (n[0].abs(), n[1].abs());
    let mut t = [0.0; 9];
    // Face in y: at y - sign(n_y) ly, length 2 lx.
    if ay > 0.0 {
        let yf = yi - n[1].signum() * half[1] / h;
        let hy = hats(yf, wy.base);
        let s = ay * 2.0 * half[0];
        for b in 0..3 {
            for a in 0..3 {
                t[a + 3 * b] += s * wx.w[a] * hy[b];
            }
        }
    }
    // Face in x: at x - sign(n_x) lx, length 2 ly.
    if ax > 0.0 {
        let xf = xi - n[0].signum() * half[0] / h;
        let hx = hats(xf, wx.base);
        let s = ax * 2.0 * half[1];
        for b in 0..3 {
            for a in 0..3 {
                t[a + 3 * b] += s * hx[a] * wy.w[b];
            }
        }
    }
    FaceWeights {
        base: [wx.base, wy.base],
        t,
        len: 2.0 * half[0] * ay + 2.0 * half[1] * ax,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let f = face_weights(ShapeKind::UGimp, [0.0, 0.0], h, c, half, n);
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
}
