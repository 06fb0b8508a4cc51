//! Tests of the r-weighted weights: the defining integrals by quadrature,
//! the identities of the module notes, the axis, the limits.

use super::*;
use crate::shape::{weights_1d, GimpShape, ShapeKind};

/// Small deterministic generator (no external crates): uniform in [0, 1).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn hat(s: f64) -> f64 {
    (1.0 - s.abs()).max(0.0)
}

fn dhat(s: f64) -> f64 {
    if s.abs() >= 1.0 {
        0.0
    } else if s > 0.0 {
        -1.0
    } else {
        1.0
    }
}

/// The defining integrals of node `i` for a particle at `xi` with
/// half-length `l` (already clamped) on a grid whose node 0 is at radius
/// `rho0`, by 3-point Gauss–Legendre on the pieces between integers (the
/// integrands are piecewise polynomials of degree <= 2 with kinks at the
/// nodes, so this is exact to round-off). Returns (S, G, T, w).
fn quadrature(xi: f64, l: f64, rho0: f64, i: i64) -> (f64, f64, f64, f64) {
    let (lo, hi) = (xi - l, xi + l);
    let mut cuts = vec![lo];
    let mut k = lo.floor() + 1.0;
    while k < hi {
        cuts.push(k);
        k += 1.0;
    }
    cuts.push(hi);
    let gp = [-(0.6f64).sqrt(), 0.0, (0.6f64).sqrt()];
    let gw = [5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0];
    let (mut is, mut ig, mut it, mut vol) = (0.0, 0.0, 0.0, 0.0);
    for c in cuts.windows(2) {
        let (a, b) = (c[0], c[1]);
        let (mid, half) = (0.5 * (a + b), 0.5 * (b - a));
        for q in 0..3 {
            let x = mid + half * gp[q];
            let wq = gw[q] * half;
            let r = rho0 + x;
            let n = hat(x - i as f64);
            is += wq * n * r;
            ig += wq * dhat(x - i as f64) * r;
            it += wq * n;
            vol += wq * r;
        }
    }
    (is / vol, ig / vol, it / vol, it / (2.0 * l))
}

/// Weights of node `node` (zero outside the stencil).
fn at(w: &AxiWeights1D, node: i64) -> (f64, f64, f64, f64) {
    let k = node - w.base;
    if (0..3).contains(&k) {
        let k = k as usize;
        (w.s[k], w.g[k], w.t[k], w.w[k])
    } else {
        (0.0, 0.0, 0.0, 0.0)
    }
}

/// Particles to probe: (xi, li, rho0), with the particle's radius
/// `rho0 + xi >= li` (the clamp inactive) unless `clamped`.
fn probes(clamped: bool) -> Vec<(f64, f64, f64)> {
    let mut r = Lcg(2024);
    let mut v = Vec::new();
    let sizes = [0.5, 0.25, 0.125, 1.0 / 6.0, 0.01];
    for &li in &sizes {
        // First columns on a grid whose node 0 is the axis: every position
        // from the domain touching the axis to three cells out, and the
        // stencil switches and nodes exactly.
        for k in 0..=24 {
            let xi = li + (3.0 - li) * k as f64 / 24.0;
            v.push((xi, li, 0.0));
        }
        for k in 1..4 {
            v.push((k as f64, li, 0.0));
            v.push((k as f64 - 0.5, li, 0.0));
        }
        for _ in 0..60 {
            // Random positions and grid origins: node 0 at the axis, to
            // the right of it at a non-integer radius, or in a ghost layer
            // left of it.
            let rho0 = match (r.next() * 3.0) as u32 {
                0 => 0.0,
                1 => 10.0 * r.next(),
                _ => -3.0,
            };
            let rho = li + 6.0 * r.next();
            v.push((rho - rho0, li, rho0));
        }
        if clamped {
            // Closer to the axis than the half-length.
            for k in 1..8 {
                let rho = li * k as f64 / 8.0;
                v.push((rho, li, 0.0));
            }
        }
    }
    v
}

#[test]
fn closed_forms_match_quadrature_of_the_defining_integrals() {
    let mut worst: f64 = 0.0;
    for (xi, li, rho0) in probes(true) {
        let w = AxiGimpShape::eval(xi, li, rho0);
        let rho = rho0 + xi;
        let l = li.min(0.5).min(rho);
        for node in w.base - 2..w.base + 5 {
            let (s, g, t, pw) = at(&w, node);
            let (qs, qg, qt, qw) = quadrature(xi, l, rho0, node);
            for (name, c, q) in [("S", s, qs), ("G", g, qg), ("T", t, qt), ("w", pw, qw)] {
                let err = (c - q).abs() / q.abs().max(1.0);
                worst = worst.max(err);
                assert!(
                    err < 1e-12,
                    "{name} xi={xi} li={li} rho0={rho0} node={node}: {c} vs {q}"
                );
            }
        }
    }
    println!("largest difference from quadrature: {worst:.2e}");
}

#[test]
fn identities_hold_in_every_column_including_the_first() {
    for (xi, li, rho0) in probes(true) {
        let w = AxiGimpShape::eval(xi, li, rho0);
        let rho = rho0 + xi;
        let l = li.min(0.5).min(rho);
        let (mut ss, mut sg, mut sgr, mut str_, mut swr, mut ssr) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        for k in 0..3 {
            let ri = rho0 + (w.base + k as i64) as f64;
            ss += w.s[k];
            sg += w.g[k];
            sgr += w.g[k] * ri;
            str_ += w.t[k] * ri;
            swr += w.w[k] * ri;
            ssr += w.s[k] * ri;
            assert!(w.s[k] >= 0.0 && w.t[k] >= 0.0 && w.w[k] >= 0.0);
        }
        let tol = 1e-13 * (1.0 + rho.abs() + rho0.abs());
        let ctx = format!("xi={xi} li={li} rho0={rho0}");
        assert!((ss - 1.0).abs() < 1e-14, "sum S = {ss}: {ctx}");
        assert!(sg.abs() < 1e-13, "sum G = {sg}: {ctx}");
        assert!((sgr - 1.0).abs() < tol, "sum G r = {sgr}: {ctx}");
        assert!((str_ - 1.0).abs() < tol, "sum T r = {str_}: {ctx}");
        assert!((swr - rho).abs() < tol, "sum w r = {swr}: {ctx}");
        // The r-weighted centroid, not the centre.
        let centroid = rho + l * l / (3.0 * rho);
        assert!(
            (ssr - centroid).abs() < tol,
            "sum S r = {ssr} vs {centroid}: {ctx}"
        );
    }
}

#[test]
fn affine_velocity_fields_give_exact_strain_rates_in_2d() {
    // v_r = a + b r + c z, v_z = d + e r + f z in cell units on a grid
    // whose node 0 is the axis; the exact particle averages are L_rr = b,
    // L_rz = c, L_zr = e, L_zz = f and L_θθ = (a + b r_p + c z_p)/r_p. The
    // homogeneous expansion is a = 0, b = f, c = e = 0 (L_θθ = b).
    let mut rng = Lcg(99);
    let (a, b, c, d, e, f) = (0.3, 1.7, -0.4, 0.9, 0.25, -1.1);
    for kind in [ShapeKind::Mpm, ShapeKind::UGimp, ShapeKind::CpGimp] {
        for _ in 0..400 {
            let lix = [0.25, 0.125, 0.5, 0.1][(rng.next() * 4.0) as usize];
            let liy = [0.25, 0.125, 0.5][(rng.next() * 3.0) as usize];
            // Half of them in the first column.
            let rp = if rng.next() < 0.5 {
                lix + (1.0 - lix) * rng.next()
            } else {
                lix + 8.0 * rng.next()
            };
            let zp = 8.0 * rng.next();
            let w = axi_weights_2d(kind, rp, zp, lix, liy, 0.0);
            let mut l = [0.0; 5];
            for bb in 0..3 {
                for aa in 0..3 {
                    let k = aa + 3 * bb;
                    let (ri, zi) = ((w.br + aa as i64) as f64, (w.bz + bb as i64) as f64);
                    let vr = a + b * ri + c * zi;
                    let vz = d + e * ri + f * zi;
                    l[0] += vr * w.gr[k];
                    l[1] += vr * w.gz[k];
                    l[2] += vz * w.gr[k];
                    l[3] += vz * w.gz[k];
                    l[4] += vr * w.t[k];
                }
            }
            let exact = [b, c, e, f, (a + b * rp + c * zp) / rp];
            for (k, (&got, &want)) in l.iter().zip(&exact).enumerate() {
                assert!(
                    (got - want).abs() < 1e-12 * (1.0 + want.abs()) * (1.0 + zp),
                    "{kind:?} component {k}: {got} vs {want} at r={rp} z={zp} lx={lix}"
                );
            }
        }
    }
}

#[test]
fn nodes_at_negative_radius_get_nothing_and_the_axis_node_its_mass() {
    for &li in &[0.5, 0.25, 0.125, 0.01] {
        for k in 0..=20 {
            // Every particle of the first half cell, the domain touching
            // the axis included.
            let rho = li + (0.5 - li) * k as f64 / 20.0;
            let rho = if rho >= 0.5 { 0.4999999 } else { rho };
            for w in [
                AxiGimpShape::eval(rho, li, 0.0),
                AxiMpmShape::eval(rho, li, 0.0),
            ] {
                assert_eq!(w.base, -1, "rho={rho}");
                assert_eq!((w.s[0], w.g[0], w.t[0], w.w[0]), (0.0, 0.0, 0.0, 0.0));
                assert!(w.s[1] > 0.0, "the axis node's mass weight, rho={rho}");
            }
        }
    }
    // The first particle of a 2x2 fill (r_p = lp = h/4): S of the axis node
    // is ∫_0^{1/2} (1 − ξ) ξ dξ / ∫_0^{1/2} ξ dξ = 2/3, its T is
    // w/ρ_p = (3/4)/(1/4) = 3.
    let w = AxiGimpShape::eval(0.25, 0.25, 0.0);
    assert!((w.s[1] - 2.0 / 3.0).abs() < 1e-15 && (w.t[1] - 3.0).abs() < 1e-15);
}

#[test]
fn particles_nearer_the_axis_than_their_size_see_a_clamped_domain() {
    // r_p < lp: the domain is [0, 2 r_p]; the weights are those of a
    // particle of half-length r_p, finite down to the smallest normal
    // radius, and keep the identities.
    for &li in &[0.5, 0.25] {
        for rho in [0.2, 0.1, 1e-3, 1e-9, 1e-100, f64::MIN_POSITIVE] {
            // T = w/ρ_p: the round-off of w (~1e-16) grows by 1/ρ_p.
            let tol = 1e-15 / rho.min(1.0);
            let w = AxiGimpShape::eval(rho, li, 0.0);
            let v = AxiGimpShape::eval(rho, rho, 0.0);
            assert_eq!(w, v, "rho={rho}");
            let (mut ss, mut sgr, mut str_) = (0.0, 0.0, 0.0);
            for k in 0..3 {
                assert!(w.s[k].is_finite() && w.g[k].is_finite() && w.t[k].is_finite());
                // Positive; below the round-off of the node distances
                // (r_p < ~1e-16 h: 1 + ρ_p rounds to 1) the node at −h
                // may see the particle on the axis and get −ρ_p/3.
                assert!(w.s[k] >= if rho > 1e-15 { 0.0 } else { -rho }, "rho={rho}");
                let ri = (w.base + k as i64) as f64;
                ss += w.s[k];
                sgr += w.g[k] * ri;
                // The axis node (ri = 0) carries the 1/ρ_p of T; the others
                // stay bounded.
                str_ += w.t[k] * ri;
                if ri != 0.0 {
                    assert!(w.t[k] <= 1.0 + tol, "rho={rho}: T={}", w.t[k]);
                }
            }
            assert!((ss - 1.0).abs() < 1e-14, "rho={rho}: {ss}");
            assert!((sgr - 1.0).abs() < tol, "rho={rho}: {sgr}");
            assert!((str_ - 1.0).abs() < tol, "rho={rho}: {str_}");
            // The hoop force of the axis node, V T ∝ r_p T = w, is bounded.
            assert!(w.t[1] * rho <= 1.0 + 1e-15);
        }
    }
}

#[test]
fn the_gradient_is_not_the_derivative_of_the_weight() {
    // dS/dξ_p = G − m/ρ_p² with m = (S − w) ρ_p: a central difference of
    // S against that, away from the region boundaries.
    let h = 1e-6;
    let mut largest_gap: f64 = 0.0;
    for &li in &[0.25, 0.125, 0.4] {
        for k in 0..200 {
            let xi = li + 0.013 + 2.5 * k as f64 / 200.0;
            let w = AxiGimpShape::eval(xi, li, 0.0);
            let (wm, wp) = (
                AxiGimpShape::eval(xi - h, li, 0.0),
                AxiGimpShape::eval(xi + h, li, 0.0),
            );
            for node in w.base..w.base + 3 {
                let (s, g, _, pw) = at(&w, node);
                let ds = (at(&wp, node).0 - at(&wm, node).0) / (2.0 * h);
                let m = (s - pw) * xi;
                let predicted = g - m / (xi * xi);
                assert!(
                    (ds - predicted).abs() < 1e-6,
                    "xi={xi} li={li} node={node}: dS={ds} vs {predicted}"
                );
                largest_gap = largest_gap.max((ds - g).abs());
            }
        }
    }
    // In the first column the two differ by order one: the first particle
    // of a 2×2 fill has m = −l²/3 on the axis node, |m|/ρ² = 1/3.
    assert!(largest_gap > 0.3, "{largest_gap}");
}

#[test]
fn weights_are_continuous_and_the_gradient_too() {
    let eps = 1e-11;
    for &li in &[0.25, 0.125, 0.5] {
        let mut pts: Vec<f64> = vec![];
        for k in 1..5 {
            pts.push(k as f64);
            pts.push(k as f64 + 0.5);
        }
        for d in [li, 1.0 - li, 1.0 + li] {
            pts.push(2.0 + d);
            pts.push(2.0 - d);
        }
        for &x in &pts {
            let (a, b) = (
                AxiGimpShape::eval(x - eps, li, 0.0),
                AxiGimpShape::eval(x + eps, li, 0.0),
            );
            for node in -1..7 {
                let (sa, ga, ta, _) = at(&a, node);
                let (sb, gb, tb, _) = at(&b, node);
                assert!((sa - sb).abs() < 1e-9, "S li={li} x={x} node={node}");
                assert!(
                    (ga - gb).abs() < 1e-9,
                    "G li={li} x={x} node={node}: {ga} vs {gb}"
                );
                assert!((ta - tb).abs() < 1e-9, "T li={li} x={x} node={node}");
            }
        }
    }
}

#[test]
fn far_from_the_axis_the_weights_tend_to_the_plane_ones() {
    let mut r = Lcg(5);
    for &li in &[0.5, 0.25, 0.125] {
        for &big in &[10.0, 1e3, 1e6] {
            let mut worst_s: f64 = 0.0;
            for _ in 0..200 {
                let xi = big + 3.0 * r.next();
                let a = AxiGimpShape::eval(xi, li, 0.0);
                let p = GimpShape::eval(xi, li);
                assert_eq!(a.base, p.base);
                assert_eq!(a.w, p.w, "the plane weights are GimpShape's, bit for bit");
                for k in 0..3 {
                    // The bounds of the module notes: |m| <= l²/3, |n| <= l/2.
                    let ds = (a.s[k] - p.w[k]).abs();
                    let dg = (a.g[k] - p.g[k]).abs();
                    assert!(ds <= li * li / (3.0 * xi) * (1.0 + 1e-12) + 1e-15);
                    assert!(dg <= li / (2.0 * xi) * (1.0 + 1e-12) + 1e-15);
                    assert!((a.t[k] - p.w[k] / xi).abs() <= 1e-15 * a.t[k].abs());
                    worst_s = worst_s.max(ds);
                }
            }
            // ... and the difference is of that order (the correction is
            // there, not zero).
            assert!(worst_s > 0.05 * li * li / (3.0 * (big + 3.0)), "{worst_s}");
        }
    }
}

#[test]
fn point_particles_tend_to_the_r_weighted_mpm_weights() {
    let mut r = Lcg(17);
    for _ in 0..500 {
        let xi = 1e-3 + 6.0 * r.next();
        let m = AxiMpmShape::eval(xi, 0.25, 0.0);
        // MPM: the hat at the particle, its slope, the hat over the radius.
        let base = m.base;
        for k in 0..3 {
            let node = base + k as i64;
            let d = xi - node as f64;
            assert!((m.s[k] - hat(d)).abs() < 1e-15);
            assert_eq!(m.w[k], m.s[k]);
            assert!((m.t[k] - hat(d) / xi).abs() < 1e-15 * (1.0 + 1.0 / xi));
        }
        let (mut sgr, mut str_) = (0.0, 0.0);
        for k in 0..3 {
            let ri = (base + k as i64) as f64;
            sgr += m.g[k] * ri;
            str_ += m.t[k] * ri;
        }
        assert!((sgr - 1.0).abs() < 1e-13 && (str_ - 1.0).abs() < 1e-13);
        // GIMP with l -> 0: the MPM weights (away from the nodes, where
        // the MPM gradient jumps).
        let frac = xi - xi.floor();
        if frac > 1e-6 && frac < 1.0 - 1e-6 {
            for l in [1e-8, 0.0] {
                let g = AxiGimpShape::eval(xi, l, 0.0);
                assert_eq!(g.base, m.base);
                for k in 0..3 {
                    assert!((g.s[k] - m.s[k]).abs() < 1e-7, "xi={xi} l={l}");
                    assert!((g.g[k] - m.g[k]).abs() < 1e-7, "xi={xi} l={l}");
                    assert!(
                        (g.t[k] - m.t[k]).abs() < 1e-7 * (1.0 + m.t[k]),
                        "xi={xi} l={l}"
                    );
                }
            }
        }
    }
}

#[test]
fn one_dimensional_and_two_dimensional_forms_agree_with_the_plane_ones_along_z() {
    // The z factors are the plane weights: S summed over r is the plane z
    // weight, G_z summed over r is the plane z slope.
    let (xi, yi, lx, ly) = (0.6, 3.3, 0.25, 0.125);
    let w = axi_weights_2d(ShapeKind::UGimp, xi, yi, lx, ly, 0.0);
    let pz = weights_1d(ShapeKind::UGimp, yi, ly);
    for b in 0..3 {
        let s: f64 = (0..3).map(|a| w.s[a + 3 * b]).sum();
        let g: f64 = (0..3).map(|a| w.gz[a + 3 * b]).sum();
        assert!((s - pz.w[b]).abs() < 1e-15 && (g - pz.g[b]).abs() < 1e-15);
    }
}
