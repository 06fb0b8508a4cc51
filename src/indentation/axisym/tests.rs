//! The axisymmetric Oliver–Pharr analysis on synthetic curves from the
//! elastic closed forms, where it must be exact.

use super::*;
use crate::indentation::closed_form::{FlatPunch, Hertz, SneddonCone};

const E_STAR: f64 = 70e9 / (1.0 - 0.3 * 0.3);

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// Loading along `load(h)` from 0 to `h_max` in 200 steps, then unloading
/// along `unload(h)` back to `h_end` in 200 steps.
fn curve(
    load: &dyn Fn(f64) -> f64,
    unload: &dyn Fn(f64) -> f64,
    h_max: f64,
    h_end: f64,
) -> (Vec<f64>, Vec<f64>) {
    let (mut d, mut p) = (Vec::new(), Vec::new());
    for i in 0..=200 {
        let h = h_max * i as f64 / 200.0;
        d.push(h);
        p.push(load(h));
    }
    for i in 1..=200 {
        let h = h_max + (h_end - h_max) * i as f64 / 200.0;
        d.push(h);
        p.push(unload(h).max(0.0));
    }
    (d, p)
}

fn run(d: &[f64], p: &[f64], opts: Options) -> Analysis {
    analyse(Series { depth: d, load: p }, opts).unwrap()
}

#[test]
fn sneddon_cone_gives_back_the_modulus_and_the_contact_depth() {
    let psi = 70.3f64.to_radians();
    let cone = SneddonCone {
        e_star: E_STAR,
        half_angle: psi,
    };
    let h_max = 2e-7;
    let (d, p) = curve(&|h| cone.load(h), &|h| cone.load(h), h_max, 0.0);
    let tip = Tip::Cone { half_angle: psi };
    let a_true = cone.contact_radius(h_max);
    let r = run(
        &d,
        &p,
        Options {
            contact_radius: Some(a_true),
            ..Options::new(tip)
        },
    );
    println!(
        "Sneddon cone: m = {:.6}, E_r/E* - 1 = {:.2e}, h_c/h = {:.6}",
        r.fit_m,
        r.reduced_modulus / E_STAR - 1.0,
        r.contact_depth / h_max
    );
    assert!(
        (r.fit_m - 2.0).abs() < 1e-6 && r.fit_h_f.abs() < 1e-6 * h_max,
        "{r:?}"
    );
    assert!(rel(r.stiffness, 2.0 * E_STAR * a_true) < 1e-6);
    assert!(rel(r.reduced_modulus, E_STAR) < 1e-3, "{r:?}");
    assert!(
        rel(r.contact_depth, cone.contact_depth(h_max)) < 1e-6,
        "{r:?}"
    );
    // Mean pressure E*/(2 tan ψ); the true area is the Oliver–Pharr one.
    assert!(rel(r.hardness, E_STAR / (2.0 * psi.tan())) < 1e-5);
    assert!((r.area_ratio - 1.0).abs() < 2e-6, "{r:?}");
    assert!(rel(r.true_contact_depth, r.contact_depth) < 1e-6);
    assert!(rel(r.true_reduced_modulus, E_STAR) < 1e-5);
    // The elastic cone leaves no impression.
    assert!(r.residual_depth.abs() < 1e-3 * h_max);
    // The area function of the 70.3° cone: 24.5 h_c² (Oliver & Pharr 1992).
    assert!((tip.area(1.0) - 24.5).abs() < 0.01);
    // Oliver–Pharr's tabulated ε = 0.72: h_c = 0.64 h and E_r = (2/π)/0.64
    // E* (−0.53 %), as the module notes say.
    let r72 = run(
        &d,
        &p,
        Options {
            epsilon: Some(0.72),
            ..Options::new(tip)
        },
    );
    assert!(rel(r72.contact_depth, 0.64 * h_max) < 1e-6);
    assert!(
        rel(r72.reduced_modulus, 2.0 / PI / 0.64 * E_STAR) < 1e-5,
        "{r72:?}"
    );
    // β divides the modulus.
    let rb = run(
        &d,
        &p,
        Options {
            beta: 1.034,
            ..Options::new(tip)
        },
    );
    assert!(rel(rb.reduced_modulus * 1.034, r.reduced_modulus) < 1e-12);
}

#[test]
fn hertz_sphere_unloading_is_a_three_halves_power() {
    let hz = Hertz {
        e_star: E_STAR,
        radius: 1e-5,
    };
    let h_max = 0.01 * hz.radius;
    let (d, p) = curve(&|h| hz.load(h), &|h| hz.load(h), h_max, 0.0);
    let a_true = hz.contact_radius(h_max);
    let r = run(
        &d,
        &p,
        Options {
            contact_radius: Some(a_true),
            ..Options::new(Tip::Paraboloid { radius: hz.radius })
        },
    );
    assert!((r.fit_m - 1.5).abs() < 1e-6, "{r:?}");
    assert!(rel(r.reduced_modulus, E_STAR) < 1e-6, "{r:?}");
    assert!(rel(r.contact_depth, 0.5 * h_max) < 1e-6);
    assert!((r.area_ratio - 1.0).abs() < 1e-6);
    // Hertz's p0 = 3 P / (2π a²) = (3/2) H.
    assert!(rel(1.5 * r.hardness, hz.peak_pressure(h_max)) < 1e-6);
    // The exact cap area π(2R h_c − h_c²) is smaller by h_c/(2R): E_r
    // comes out higher by 1/√(1 − h_c/(2R)) on this (paraboloid) curve.
    let rs = run(&d, &p, Options::new(Tip::Sphere { radius: hz.radius }));
    let want = 1.0 / (1.0 - rs.contact_depth / (2.0 * hz.radius)).sqrt();
    assert!(rel(rs.reduced_modulus / E_STAR, want) < 1e-6);
    // An elastic–plastic unloading with an impression h_f: P = B (h −
    // h_f)^(3/2) is recovered with its h_f.
    let (h_f, b) = (0.3 * h_max, hz.load(1.0) * 1.8);
    let (d, p) = curve(
        &|h| hz.load(h) * 1.2,
        &|h| {
            if h > h_f {
                b * (h - h_f).powf(1.5)
            } else {
                0.0
            }
        },
        h_max,
        0.2 * h_max,
    );
    let r = run(&d, &p, Options::new(Tip::Paraboloid { radius: hz.radius }));
    assert!(
        (r.fit_m - 1.5).abs() < 1e-6 && rel(r.fit_h_f, h_f) < 1e-6,
        "{r:?}"
    );
    assert!(rel(r.stiffness, 1.5 * b * (h_max - h_f).sqrt()) < 1e-6);
    assert!(rel(r.residual_depth, h_f) < 1e-9, "{r:?}");
}

#[test]
fn flat_punch_unloads_linearly_with_the_punch_stiffness() {
    let f = FlatPunch {
        e_star: E_STAR,
        radius: 1e-6,
    };
    let h_max = 1e-8;
    let h_f = 0.4 * h_max;
    let (d, p) = curve(
        &|h| f.load(h),
        &|h| f.load(h - h_f) / (1.0 - h_f / h_max),
        h_max,
        0.0,
    );
    let r = run(&d, &p, Options::new(Tip::FlatPunch { radius: f.radius }));
    assert!((r.fit_m - 1.0).abs() < 1e-6, "{r:?}");
    let s = 2.0 * f.radius * E_STAR / (1.0 - h_f / h_max);
    assert!(rel(r.stiffness, s) < 1e-6);
    // E_r = S / (2a) for the punch's constant area π a².
    assert!(rel(r.reduced_modulus, s / (2.0 * f.radius)) < 1e-6);
    assert!(rel(r.area, PI * f.radius * f.radius) < 1e-15);
    assert!(r.true_contact_depth.is_nan());
    // h_c = h_max − P/S = h_f for the linear unloading.
    assert!(rel(r.contact_depth, h_f) < 1e-6);
}

#[test]
fn pile_up_shows_as_a_larger_true_area() {
    // The cone's elastic curve with a true contact radius 15 % larger than
    // the elastic one (a piled-up rim): the true area is 1.3225 times the
    // Oliver–Pharr area, the true hardness smaller by as much, the true
    // contact depth 15 % deeper.
    let psi = 70.3f64.to_radians();
    let cone = SneddonCone {
        e_star: E_STAR,
        half_angle: psi,
    };
    let h_max = 3e-7;
    let (d, p) = curve(&|h| cone.load(h), &|h| cone.load(h), h_max, 0.0);
    let a = 1.15 * cone.contact_radius(h_max);
    let r = run(
        &d,
        &p,
        Options {
            contact_radius: Some(a),
            ..Options::new(Tip::Cone { half_angle: psi })
        },
    );
    assert!(rel(r.area_ratio, 1.3225) < 1e-5, "{r:?}");
    assert!(rel(r.hardness / r.true_hardness, 1.3225) < 1e-5);
    assert!(rel(r.true_contact_depth / r.contact_depth, 1.15) < 1e-5);
    assert!(rel(r.reduced_modulus / r.true_reduced_modulus, 1.15) < 1e-5);
}

#[test]
fn frame_compliance_is_taken_out_of_the_depth() {
    let psi = 70.3f64.to_radians();
    let cone = SneddonCone {
        e_star: E_STAR,
        half_angle: psi,
    };
    let h_max = 2e-7;
    let (d, p) = curve(&|h| cone.load(h), &|h| cone.load(h), h_max, 0.0);
    let cf = 0.3 * h_max / cone.load(h_max);
    let d_soft: Vec<f64> = d.iter().zip(&p).map(|(h, l)| h + cf * l).collect();
    let tip = Tip::Cone { half_angle: psi };
    let plain = run(&d, &p, Options::new(tip));
    let soft = run(&d_soft, &p, Options::new(tip));
    let fixed = run(
        &d_soft,
        &p,
        Options {
            frame_compliance: cf,
            ..Options::new(tip)
        },
    );
    assert!(rel(fixed.reduced_modulus, plain.reduced_modulus) < 1e-6);
    assert!(rel(fixed.contact_depth, plain.contact_depth) < 1e-6);
    // Uncorrected, the frame's compliance is read as the sample's.
    assert!(soft.reduced_modulus < 0.8 * plain.reduced_modulus);
}

#[test]
fn series_area_function_and_its_inverse() {
    let psi = 70.3f64.to_radians();
    let cone = Tip::Cone { half_angle: psi };
    let t = psi.tan();
    let series = Tip::Series {
        c: [PI * t * t, 0.0, 0.0, 0.0, 0.0],
    };
    for hc in [1e-8, 1e-7, 3e-7] {
        assert!(rel(series.area(hc), cone.area(hc)) < 1e-15);
        assert!(rel(series.depth_of_area(cone.area(hc)), hc) < 1e-12);
        for tip in [
            cone,
            Tip::Sphere { radius: 1e-5 },
            Tip::Paraboloid { radius: 1e-5 },
        ] {
            assert!(rel(tip.depth_of_area(tip.area(hc)), hc) < 1e-12, "{tip:?}");
        }
    }
    // A rounded Berkovich-like series (C1 > 0) inverts too.
    let rounded = Tip::Series {
        c: [24.5, 1e-6, 0.0, 0.0, 0.0],
    };
    assert!(rel(rounded.depth_of_area(rounded.area(5e-8)), 5e-8) < 1e-12);
}

#[test]
fn sample_modulus_inverts_the_reduced_modulus() {
    let (e, nu, ei, nui) = (70e9, 0.33, 1141e9, 0.07);
    let er = 1.0 / ((1.0 - nu * nu) / e + (1.0 - nui * nui) / ei);
    assert!(rel(sample_modulus(er, nu, ei, nui), e) < 1e-12);
    assert!(rel(sample_modulus(E_STAR, 0.3, f64::INFINITY, 0.0), 70e9) < 1e-12);
}

#[test]
fn arguments_are_checked_by_name_and_bound() {
    let cone = SneddonCone {
        e_star: E_STAR,
        half_angle: 1.2,
    };
    let (d, p) = curve(&|h| cone.load(h), &|h| cone.load(h), 1e-7, 0.0);
    let ok = Options::new(Tip::Cone { half_angle: 1.2 });
    let msg = |dd: &[f64], pp: &[f64], o: Options| {
        analyse(
            Series {
                depth: dd,
                load: pp,
            },
            o,
        )
        .unwrap_err()
        .msg
    };
    assert!(msg(&d, &p[1..], ok).contains("load has"));
    assert!(msg(&d[..3], &p[..3], ok).contains("n = 3 must be >= 4"));
    let mut bad = p.clone();
    bad[9] = f64::INFINITY;
    assert!(msg(&d, &bad, ok).contains("load[9] = inf must be finite"));
    let with = |o: Options| msg(&d, &p, o);
    assert!(with(Options::new(Tip::Cone { half_angle: 2.0 }))
        .contains("half_angle = 2 rad must lie in (0, pi/2)"));
    assert!(with(Options::new(Tip::Sphere { radius: 0.0 }))
        .contains("sphere radius = 0 must be finite and > 0"));
    assert!(with(Options::new(Tip::Series { c: [0.0; 5] })).contains("at least one must be > 0"));
    assert!(with(Options::new(Tip::Series {
        c: [1.0, -1.0, 0.0, 0.0, 0.0]
    }))
    .contains("c[1] = -1 must be finite and >= 0"));
    assert!(with(Options {
        epsilon: Some(1.5),
        ..ok
    })
    .contains("epsilon = 1.5 must lie in (0, 1]"));
    assert!(with(Options { beta: 0.0, ..ok }).contains("beta = 0 must be finite and > 0"));
    assert!(with(Options {
        fit_lower: 1.0,
        ..ok
    })
    .contains("fit_lower = 1 must lie in (0, 1)"));
    assert!(with(Options {
        fit_upper: 0.3,
        ..ok
    })
    .contains("fit_upper = 0.3 must lie in (fit_lower = 0.4, 1]"));
    assert!(with(Options {
        frame_compliance: -1.0,
        ..ok
    })
    .contains("frame_compliance = -1 must be finite and >= 0"));
    assert!(with(Options {
        contact_radius: Some(f64::NAN),
        ..ok
    })
    .contains("contact_radius = NaN must be finite and > 0"));
    assert!(with(Options {
        fit_lower: 0.985,
        fit_upper: 0.99,
        ..ok
    })
    .contains("at least 3 are needed"));
    // A sphere too small for the contact depth.
    assert!(with(Options::new(Tip::Sphere { radius: 1e-9 }))
        .contains("must not exceed the sphere radius"));
    let zeros = vec![0.0; d.len()];
    assert!(msg(&d, &zeros, ok).contains("must be > 0"));
}
