//! Each closed form against a relation it must satisfy.

use super::*;

const E: f64 = 70e9;
const NU: f64 = 0.3;

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// Composite 8-point Gauss–Legendre of `f` over `[a, b]` in `n` pieces.
fn gauss(f: &dyn Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    const X: [f64; 4] = [
        0.183_434_642_495_649_8,
        0.525_532_409_916_329,
        0.796_666_477_413_626_7,
        0.960_289_856_497_536_3,
    ];
    const W: [f64; 4] = [
        0.362_683_783_378_362,
        0.313_706_645_877_887_3,
        0.222_381_034_453_374_5,
        0.101_228_536_290_376_3,
    ];
    let h = (b - a) / n as f64;
    let mut s = 0.0;
    for k in 0..n {
        let (m, hh) = (a + (k as f64 + 0.5) * h, 0.5 * h);
        for j in 0..4 {
            s += W[j] * hh * (f(m - hh * X[j]) + f(m + hh * X[j]));
        }
    }
    s
}

#[test]
fn lame_sphere_satisfies_equilibrium_hooke_and_its_boundaries() {
    let s = LameSphere {
        a: 1.0,
        b: 2.0,
        p: 1e8,
        e: E,
        nu: NU,
    };
    // Lamé: σ_θθ(a) = 5p/7 for a = 1, b = 2.
    assert!(rel(s.at(1.0).2, 5.0 / 7.0 * s.p) < 1e-14);
    assert!(rel(s.at(1.0).1, -s.p) < 1e-14 && s.at(2.0).1.abs() < 1e-6);
    let (lam, mu) = (
        E * NU / ((1.0 + NU) * (1.0 - 2.0 * NU)),
        E / (2.0 * (1.0 + NU)),
    );
    let d = 1e-5;
    for k in 1..20 {
        let r = 1.0 + k as f64 / 20.0;
        let (u, srr, stt) = s.at(r);
        let (um, sm, _) = s.at(r - d);
        let (up, sp, _) = s.at(r + d);
        // dσ_RR/dR + 2(σ_RR − σ_tt)/R = 0.
        let res = (sp - sm) / (2.0 * d) + 2.0 * (srr - stt) / r;
        assert!(res.abs() < 1e-6 * s.p, "R={r}: {res}");
        // Hooke on ε_RR = du/dR, ε_tt = u/R.
        let (err, ett) = ((up - um) / (2.0 * d), u / r);
        let tr = err + 2.0 * ett;
        assert!(
            (lam * tr + 2.0 * mu * err - srr).abs() < 1e-6 * s.p,
            "R={r}"
        );
        assert!(
            (lam * tr + 2.0 * mu * ett - stt).abs() < 1e-6 * s.p,
            "R={r}"
        );
    }
    // In cylindrical components: the axisymmetric equilibrium equations
    // ∂σ_rr/∂r + ∂σ_rz/∂z + (σ_rr − σ_θθ)/r = 0, ∂σ_rz/∂r + ∂σ_zz/∂z +
    // σ_rz/r = 0, and the traction −p n on the inner surface.
    for k in 0..12 {
        let phi = 0.1 + 1.3 * k as f64 / 12.0;
        for big_r in [1.2, 1.5, 1.9] {
            let (r, z) = (big_r * phi.sin(), big_r * phi.cos());
            let f = s.at_cylindrical(r, z);
            let fr = |dr: f64, dz: f64| s.at_cylindrical(r + dr, z + dz);
            let drr = (fr(d, 0.0).s_rr - fr(-d, 0.0).s_rr) / (2.0 * d);
            let drz_z = (fr(0.0, d).s_rz - fr(0.0, -d).s_rz) / (2.0 * d);
            let drz_r = (fr(d, 0.0).s_rz - fr(-d, 0.0).s_rz) / (2.0 * d);
            let dzz = (fr(0.0, d).s_zz - fr(0.0, -d).s_zz) / (2.0 * d);
            let e1 = drr + drz_z + (f.s_rr - f.s_tt) / r;
            let e2 = drz_r + dzz + f.s_rz / r;
            assert!(e1.abs() < 1e-5 * s.p && e2.abs() < 1e-5 * s.p, "{e1} {e2}");
            // Hoop strain u_r / r and Hooke for σ_θθ.
            let fz = |dz: f64| s.at_cylindrical(r, z + dz);
            let fx = |dr: f64| s.at_cylindrical(r + dr, z);
            let err = (fx(d).u_r - fx(-d).u_r) / (2.0 * d);
            let ezz = (fz(d).u_z - fz(-d).u_z) / (2.0 * d);
            let ett = f.u_r / r;
            let tr = err + ezz + ett;
            assert!(((lam * tr + 2.0 * mu * ett) - f.s_tt).abs() < 1e-6 * s.p);
        }
        let (r, z) = (phi.sin(), phi.cos());
        let f = s.at_cylindrical(r, z);
        let (tr, tz) = (f.s_rr * r + f.s_rz * z, f.s_rz * r + f.s_zz * z);
        assert!((tr + s.p * r).abs() < 1e-6 && (tz + s.p * z).abs() < 1e-6);
    }
}

#[test]
fn lame_cylinder_satisfies_equilibrium_hooke_and_its_boundaries() {
    let (lam, mu) = (
        E * NU / ((1.0 + NU) * (1.0 - 2.0 * NU)),
        E / (2.0 * (1.0 + NU)),
    );
    for ends in [
        CylinderEnds::PlaneStrain,
        CylinderEnds::Open,
        CylinderEnds::Closed,
    ] {
        let c = LameCylinder {
            a: 1.0,
            b: 2.0,
            p: 1e8,
            e: E,
            nu: NU,
            ends,
        };
        // Lamé: σ_θθ(a) = 5p/3 (any ends).
        assert!(rel(c.at(1.0, 0.0).s_tt, 5.0 / 3.0 * c.p) < 1e-14);
        assert!(rel(c.at(1.0, 0.0).s_rr, -c.p) < 1e-14 && c.at(2.0, 0.0).s_rr.abs() < 1e-6);
        let sz = c.at(1.5, 0.0).s_zz;
        match ends {
            CylinderEnds::PlaneStrain => assert!(rel(sz, 2.0 * NU * c.p / 3.0) < 1e-12),
            CylinderEnds::Open => assert!(sz.abs() < 1e-6),
            // The caps' load p π a² over the wall's area π (b² − a²).
            CylinderEnds::Closed => assert!(rel(sz, c.p / 3.0) < 1e-12),
        }
        let d = 1e-5;
        for k in 1..20 {
            let r = 1.0 + k as f64 / 20.0;
            let f = c.at(r, 0.3);
            let (m, p) = (c.at(r - d, 0.3), c.at(r + d, 0.3));
            let res = (p.s_rr - m.s_rr) / (2.0 * d) + (f.s_rr - f.s_tt) / r;
            assert!(res.abs() < 1e-6 * c.p, "{res}");
            let (err, ett, ezz) = ((p.u_r - m.u_r) / (2.0 * d), f.u_r / r, c.axial_strain());
            let tr = err + ett + ezz;
            for (got, want) in [
                (lam * tr + 2.0 * mu * err, f.s_rr),
                (lam * tr + 2.0 * mu * ett, f.s_tt),
                (lam * tr + 2.0 * mu * ezz, f.s_zz),
            ] {
                assert!((got - want).abs() < 1e-6 * c.p, "{ends:?}: {got} vs {want}");
            }
        }
    }
    // The sphere and the cylinder differ by a factor 7/3 in the inner hoop
    // stress: a test that dropped the hoop term could not pass both.
    let s = LameSphere {
        a: 1.0,
        b: 2.0,
        p: 1.0,
        e: E,
        nu: NU,
    };
    let c = LameCylinder {
        a: 1.0,
        b: 2.0,
        p: 1.0,
        e: E,
        nu: NU,
        ends: CylinderEnds::PlaneStrain,
    };
    assert!(rel(c.at(1.0, 0.0).s_tt / s.at(1.0).2, 7.0 / 3.0) < 1e-14);
}

#[test]
fn sneddon_cone_load_pressure_stiffness_and_surface() {
    let c = SneddonCone {
        e_star: E / (1.0 - NU * NU),
        half_angle: 70.3f64.to_radians(),
    };
    let h = 2e-7;
    let a = c.contact_radius(h);
    let p = c.load(h);
    // ∫ p 2πr dr = P, with r = a / cosh u (p = E*/(2 tan ψ) u there).
    let total = gauss(
        &|u: f64| {
            c.pressure(h, a / u.cosh()) * 2.0 * PI * (a / u.cosh()) * a * u.sinh()
                / (u.cosh() * u.cosh())
        },
        1e-12,
        40.0,
        400,
    );
    assert!(rel(total, p) < 1e-10, "{total} vs {p}");
    // Mean pressure E*/(2 tan ψ).
    assert!(rel(p / (PI * a * a), c.e_star / (2.0 * c.half_angle.tan())) < 1e-14);
    // dP/dh = 2 E* a.
    let d = 1e-6 * h;
    let s = (c.load(h + d) - c.load(h - d)) / (2.0 * d);
    assert!(rel(s, 2.0 * c.e_star * a) < 1e-9);
    // The surface: continuous at the contact edge, where it has sunk by
    // u_z(a) = h − h_c; the point-load far field P/(π E* r).
    let inside = h - a / c.half_angle.tan();
    assert!(rel(c.surface_deflection(h, a), inside) < 1e-12);
    assert!(rel(c.surface_deflection(h, a * (1.0 + 1e-9)), inside) < 1e-6);
    assert!(rel(h - c.surface_deflection(h, a), c.contact_depth(h)) < 1e-12);
    let far = 300.0 * a;
    assert!(rel(c.surface_deflection(h, far), p / (PI * c.e_star * far)) < 1e-4);
}

#[test]
fn hertz_load_pressure_stiffness_and_surface() {
    let s = Hertz {
        e_star: E / (1.0 - NU * NU),
        radius: 1e-5,
    };
    let h = 0.01 * s.radius;
    let (a, p, p0) = (s.contact_radius(h), s.load(h), s.peak_pressure(h));
    assert!(rel(p0, 3.0 * p / (2.0 * PI * a * a)) < 1e-14);
    assert!(rel(s.depth_at_load(p), h) < 1e-14);
    // ∫ p 2πr dr = P, r = a sin θ.
    let total = gauss(
        &|t: f64| s.pressure(h, a * t.sin()) * 2.0 * PI * a * t.sin() * a * t.cos(),
        0.0,
        PI / 2.0,
        50,
    );
    assert!(rel(total, p) < 1e-12, "{total} vs {p}");
    let d = 1e-6 * h;
    assert!(
        rel(
            (s.load(h + d) - s.load(h - d)) / (2.0 * d),
            2.0 * s.e_star * a
        ) < 1e-9
    );
    // Surface: continuous at a (a²/(2R) both sides) and P/(π E* r) far out.
    assert!(rel(s.surface_deflection(h, a), a * a / (2.0 * s.radius)) < 1e-12);
    assert!(
        rel(
            s.surface_deflection(h, a * (1.0 + 1e-9)),
            a * a / (2.0 * s.radius)
        ) < 1e-6
    );
    let far = 300.0 * a;
    assert!(rel(s.surface_deflection(h, far), p / (PI * s.e_star * far)) < 1e-4);
}

#[test]
fn exact_sphere_tends_to_hertz_and_shares_the_punch_stiffness() {
    let e = ExactSphere {
        e_star: E / (1.0 - NU * NU),
        radius: 1e-5,
    };
    let hz = Hertz {
        e_star: e.e_star,
        radius: e.radius,
    };
    for x in [0.02, 0.05, 0.1] {
        let a = x * e.radius;
        // The leading corrections of the series in the notes.
        let dh = e.depth(a) / (a * a / e.radius) - 1.0;
        let dp = e.load(a) / (4.0 / 3.0 * e.e_star * a.powi(3) / e.radius) - 1.0;
        assert!(rel(dh, x * x / 3.0) < 0.05, "x={x}: {dh}");
        assert!(rel(dp, 0.4 * x * x) < 0.05, "x={x}: {dp}");
        // At the same contact radius the paraboloid is the limit.
        let hh = hz.depth_at_load(hz.load(a * a / e.radius));
        assert!(rel(hh, a * a / e.radius) < 1e-13);
        // dP/dh = (dP/da)/(dh/da) = 2 E* a for the exact sphere too.
        let d = 1e-6 * a;
        let s = (e.load(a + d) - e.load(a - d)) / (e.depth(a + d) - e.depth(a - d));
        assert!(rel(s, 2.0 * e.e_star * a) < 1e-7, "x={x}: {s}");
    }
}

#[test]
fn flat_punch_load_pressure_and_surface() {
    let f = FlatPunch {
        e_star: E / (1.0 - NU * NU),
        radius: 1e-6,
    };
    let h = 1e-8;
    let a = f.radius;
    // ∫ p 2πr dr = P, r = a sin θ (the edge singularity cancels).
    let total = gauss(
        &|t: f64| f.pressure(h, a * t.sin()) * 2.0 * PI * a * t.sin() * a * t.cos(),
        0.0,
        PI / 2.0,
        50,
    );
    assert!(rel(total, f.load(h)) < 1e-12);
    let d = 1e-3 * h;
    assert!(
        rel(
            (f.load(h + d) - f.load(h - d)) / (2.0 * d),
            2.0 * f.e_star * a
        ) < 1e-12
    );
    assert!(rel(f.surface_deflection(h, a * (1.0 + 1e-12)), h) < 1e-5);
    let far = 300.0 * a;
    assert!(
        rel(
            f.surface_deflection(h, far),
            f.load(h) / (PI * f.e_star * far)
        ) < 1e-5
    );
}
