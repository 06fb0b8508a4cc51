//! The face integrals of a contact particle in the axisymmetric mode (x is
//! the radius r, y the axis z): the r-weighted counterparts of
//! [`super::face::face_weights`].
//!
//! Per radian, a pressure `P` on the part of a particle's boundary that
//! faces the indenter loads node `i` with `P n ∫ S_i r ds`. The contact
//! problem (eq. 11, [`super::system`]) keeps its form with
//!
//! ```text
//! T_ip = |n_y| ∫_{face y} N_i r dr + |n_x| r_f ∫_{face x} N_i dz,
//! ℓ_p  = Σ_i T_ip = |n_y| (r_1² − r_0²)/2 + |n_x| r_f 2 l_y,
//! ```
//!
//! (`[r_0, r_1]` the face in y, `r_f` the radius of the face in x) and a
//! thickness of 1: `ℓ_p` is the area per radian of indenter surface the
//! particle covers, `P ℓ_p n_p` its contact force per radian, and the face
//! velocity `Σ_i T_ip v_i / ℓ_p` the r-weighted mean over the face. Along
//! the face in y the weights are the exact integrals of the hat functions
//! times r (two-point Gauss on each cell's part, exact for the quadratic
//! integrand); plain MPM takes the hats at the face's midpoint, as in plane
//! strain. The clipping to the indenter's extent is that of the plane
//! faces.

use super::face::{hats, part_weights, FaceWeights};
use crate::shape::{weights_1d, ShapeKind};

/// `(∫ N_a ρ dξ for the nodes base .. base + 3, ∫ ρ dξ)` over `[u0, u1]`
/// (cells from node 0; `ρ = ρ0 + ξ` the radius in cells): two-point Gauss on
/// each cell's part, where the integrand is quadratic.
fn r_weighted_part(u0: f64, u1: f64, base: i64, rho0: f64) -> ([f64; 3], f64) {
    let g = 0.5 / 3f64.sqrt();
    let mut w = [0.0; 3];
    let mut a0 = u0;
    while a0 < u1 {
        let b = (a0.floor() + 1.0).min(u1);
        let (m, d) = (0.5 * (a0 + b), b - a0);
        for xg in [m - g * d, m + g * d] {
            let hs = hats(xg, base);
            let rho = rho0 + xg;
            for a in 0..3 {
                w[a] += 0.5 * d * hs[a] * rho;
            }
        }
        a0 = b;
    }
    (w, 0.5 * (u1 - u0) * (2.0 * rho0 + u0 + u1))
}

/// The r-weighted face integrals (see the module notes) of a particle at
/// `c` with half-lengths `half` against the contact normal `n`, on a level
/// with node 0 at `origin` and cell size `h`, clipped to the indenter's
/// extent `span = [xlo, ylo, xhi, yhi]` as [`super::face::face_weights`]
/// clips. `t` and `len` are per radian (area units).
pub fn face_weights_axi(
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
    let rho0 = origin[0] / h;
    let wx = weights_1d(shape, xi, half[0] / h);
    let wy = weights_1d(shape, yi, half[1] / h);
    let (ax, ay) = (n[0].abs(), n[1].abs());
    // The covered part of each face along it, in cells (the whole face
    // when no face the normal loads overlaps the extent at all).
    let clip = |lo: f64, hi: f64, s_lo: f64, s_hi: f64| (lo.max(s_lo), hi.min(s_hi));
    let (mut x0, mut x1) = clip(c[0] - half[0], c[0] + half[0], span[0], span[2]);
    let (mut y0, mut y1) = clip(c[1] - half[1], c[1] + half[1], span[1], span[3]);
    if !(ay > 0.0 && x1 > x0) && !(ax > 0.0 && y1 > y0) {
        (x0, x1) = (c[0] - half[0], c[0] + half[0]);
        (y0, y1) = (c[1] - half[1], c[1] + half[1]);
    }
    let mut t = [0.0; 9];
    let mut len = 0.0;
    // Face in y: at y - sign(n_y) ly, along r over [x0, x1].
    if ay > 0.0 && x1 > x0 {
        let (u0, u1) = ((x0 - origin[0]) / h, (x1 - origin[0]) / h);
        let (wr, area) = if shape == ShapeKind::Mpm {
            let area = 0.5 * (u1 - u0) * (2.0 * rho0 + u0 + u1);
            let hm = hats(0.5 * (u0 + u1), wx.base);
            ([hm[0] * area, hm[1] * area, hm[2] * area], area)
        } else {
            r_weighted_part(u0, u1, wx.base, rho0)
        };
        let hy = hats(yi - n[1].signum() * half[1] / h, wy.base);
        let s = ay * h * h;
        for b in 0..3 {
            for a in 0..3 {
                t[a + 3 * b] += s * wr[a] * hy[b];
            }
        }
        len += s * area;
    }
    // Face in x: at r_f = x - sign(n_x) lx, along z over [y0, y1].
    if ax > 0.0 && y1 > y0 {
        let xf = xi - n[0].signum() * half[0] / h;
        let rf = (rho0 + xf) * h;
        let (u0, u1) = ((y0 - origin[1]) / h, (y1 - origin[1]) / h);
        let wz = part_weights(shape, u0, u1, wy.base);
        let hx = hats(xf, wx.base);
        let s = ax * rf * (y1 - y0);
        for b in 0..3 {
            for a in 0..3 {
                t[a + 3 * b] += s * hx[a] * wz[b];
            }
        }
        len += s;
    }
    FaceWeights {
        base: [wx.base, wy.base],
        t,
        len,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The r-weighted integrals against a fine midpoint sum, and their sum
    /// (the per-radian face area) against the closed form.
    #[test]
    fn face_integrals_are_the_r_weighted_integrals_of_the_hats() {
        let h = 0.1;
        let n = [0.6, 0.8];
        for (c, half) in [
            ([0.025, 0.33], [0.025, 0.025]),
            ([0.27, 0.41], [0.05, 0.025]),
            ([0.5, 0.2], [0.0125, 0.05]),
        ] {
            let f = face_weights_axi(
                ShapeKind::UGimp,
                [0.0, 0.0],
                h,
                c,
                half,
                n,
                [-1.0, -1.0, 1.0, 1.0],
            );
            // Midpoint sums of N_i(r, z) r over the two faces.
            let m = 20000;
            let mut t = [0.0; 9];
            let (yf, xf) = (c[1] - half[1], c[0] - half[0]);
            for k in 0..m {
                let r = c[0] - half[0] + (k as f64 + 0.5) * 2.0 * half[0] / m as f64;
                let z = c[1] - half[1] + (k as f64 + 0.5) * 2.0 * half[1] / m as f64;
                for b in 0..3 {
                    for a in 0..3 {
                        let (ni, nj) =
                            ((f.base[0] + a as i64) as f64, (f.base[1] + b as i64) as f64);
                        let hat = |u: f64| (1.0 - u.abs()).max(0.0);
                        let ny = hat(r / h - ni) * hat(yf / h - nj) * r * 2.0 * half[0] / m as f64;
                        let nx = hat(xf / h - ni) * hat(z / h - nj) * xf * 2.0 * half[1] / m as f64;
                        t[a + 3 * b] += n[1] * ny + n[0] * nx;
                    }
                }
            }
            for k in 0..9 {
                assert!(
                    (f.t[k] - t[k]).abs() < 1e-8 * f.len,
                    "c {c:?}: T[{k}] {} vs {}",
                    f.t[k],
                    t[k]
                );
            }
            let area = n[1] * 2.0 * half[0] * c[0] + n[0] * xf * 2.0 * half[1];
            assert!(
                (f.len - area).abs() < 1e-14 * area,
                "c {c:?}: len {} vs {area}",
                f.len
            );
            let sum: f64 = f.t.iter().sum();
            assert!((sum - f.len).abs() < 1e-13 * area);
        }
    }
}
