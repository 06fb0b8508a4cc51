//! Tests of the axisymmetric laws and the mode's kinematics: closed forms
//! of homogeneous axisymmetric states, a 3D evaluation of the hyperelastic
//! stress, a reference integration of J2 on a non-proportional path,
//! objectivity, and bitwise equality of the plane-strain path.

use super::*;
use crate::material::j2::{von_mises, Hardening};
use crate::material::{
    rotate_stress, AnyLaw, Constitutive, J2Law, LinearElasticLaw, Material, NeoHookeanLaw,
};
use crate::mode::{Axisymmetric, PlaneStrain};
use nalgebra::Matrix3;

const E: f64 = 70e9;
const NU: f64 = 0.3;
const RHO: f64 = 2700.0;
const SY: f64 = 100e6;

fn lin() -> MatParams {
    Material::LinearElastic {
        e: E,
        nu: NU,
        rho: RHO,
    }
    .params()
}

fn nh() -> MatParams {
    Material::NeoHookean {
        e: E,
        nu: NU,
        rho: RHO,
    }
    .params()
}

fn j2(hardening: Hardening) -> MatParams {
    Material::J2 {
        e: E,
        nu: NU,
        rho: RHO,
        hardening,
    }
    .params()
}

fn j2_linear(h: f64) -> MatParams {
    j2(Hardening::Linear { sigma_y: SY, h })
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-300)
}

struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn sym(&mut self) -> f64 {
        2.0 * self.next() - 1.0
    }
}

fn bits(s: &Stress) -> [u64; 4] {
    [
        s.xx.to_bits(),
        s.yy.to_bits(),
        s.xy.to_bits(),
        s.zz.to_bits(),
    ]
}

#[test]
fn plane_strain_through_the_mode_is_the_plane_update_bit_for_bit() {
    fn check<M: Constitutive>(p: &MatParams, r: &mut Lcg) {
        for _ in 0..200 {
            let s = Stress {
                xx: 2e8 * r.sym(),
                yy: 2e8 * r.sym(),
                xy: 1e8 * r.sym(),
                zz: 2e8 * r.sym(),
            };
            let l = Tensor2 {
                xx: r.sym(),
                xy: r.sym(),
                yx: r.sym(),
                yy: r.sym(),
            };
            let f = Tensor2 {
                xx: 1.0 + 0.1 * r.sym(),
                xy: 0.1 * r.sym(),
                yx: 0.1 * r.sym(),
                yy: 1.0 + 0.1 * r.sym(),
            };
            // A hoop that plane strain must ignore.
            let hoop = Hoop {
                rate: r.sym(),
                f: 1.0 + 0.2 * r.sym(),
            };
            let dt = 1e-3 * r.next();
            let ep0 = 0.01 * r.next();
            let (mut e1, mut e2) = (ep0, ep0);
            let a = M::update(p, s, &l, dt, &f, &mut e1);
            let b = M::update_in::<PlaneStrain>(p, s, &l, hoop, dt, &f, &mut e2);
            assert_eq!(bits(&a), bits(&b), "{:?}", p.kind);
            assert_eq!(e1.to_bits(), e2.to_bits());
            // The mixed-law dispatch gives the specific law's bits in
            // axisymmetry too.
            let (mut e3, mut e4) = (ep0, ep0);
            let c = M::update_in::<Axisymmetric>(p, s, &l, hoop, dt, &f, &mut e3);
            let d = AnyLaw::update_in::<Axisymmetric>(p, s, &l, hoop, dt, &f, &mut e4);
            assert_eq!(bits(&c), bits(&d), "{:?}", p.kind);
            assert_eq!(e3.to_bits(), e4.to_bits());
            // The energy too.
            let w1 = p.strain_energy(&s, &f, 2.0);
            let w2 = p.strain_energy_in::<PlaneStrain>(&s, &f, hoop.f, 2.0);
            assert_eq!(w1.to_bits(), w2.to_bits());
        }
    }
    let mut r = Lcg(3);
    check::<LinearElasticLaw>(&lin(), &mut r);
    check::<NeoHookeanLaw>(&nh(), &mut r);
    check::<J2Law>(&j2_linear(5e9), &mut r);
    check::<AnyLaw>(&j2_linear(0.0), &mut r);
    check::<AnyLaw>(&lin(), &mut r);
    check::<AnyLaw>(&nh(), &mut r);
}

#[test]
fn linear_elastic_under_constant_rates_is_hooke_with_the_hoop_rate() {
    // D = diag(a, b) in the r–z plane, L_θθ = c, no spin: the Jaumann
    // update adds C:D Δt exactly.
    let p = lin();
    let (a, b, c) = (1.0e-3, -0.4e-3, 0.7e-3);
    let l = Tensor2 {
        xx: a,
        xy: 0.0,
        yx: 0.0,
        yy: b,
    };
    let (dt, n) = (0.1, 500);
    let mut s = Stress::default();
    for _ in 0..n {
        s = LinearElasticLaw::update_in::<Axisymmetric>(
            &p,
            s,
            &l,
            Hoop { rate: c, f: 1.0 },
            dt,
            &Tensor2::IDENTITY,
            &mut 0.0,
        );
    }
    let t = dt * n as f64;
    let tr = (a + b + c) * t;
    let (lam, mu) = (p.lambda, p.mu);
    assert!(rel(s.xx, lam * tr + 2.0 * mu * a * t) < 1e-12, "{s:?}");
    assert!(rel(s.yy, lam * tr + 2.0 * mu * b * t) < 1e-12, "{s:?}");
    assert!(rel(s.zz, lam * tr + 2.0 * mu * c * t) < 1e-12, "{s:?}");
    assert!(s.xy.abs() < 1e-12 * s.xx.abs());
    // Plane strain's fourth component is ν(σ_xx + σ_yy) with D_zz = 0; the
    // hoop rate makes the difference 2μ c t + λ c t (in both the others).
    let mut ps = Stress::default();
    for _ in 0..n {
        ps = p.update_stress(ps, &l, dt, &Tensor2::IDENTITY, &mut 0.0);
    }
    assert!(rel(s.zz - ps.zz, (lam + 2.0 * mu) * c * t) < 1e-10);
    assert!(rel(s.xx - ps.xx, lam * c * t) < 1e-10);
}

/// The homogeneous expansion `r = R (1 + ε̇ t)`, `z = Z (1 + ε̇ t)` at a
/// material point, driven as the kernel would drive it: the rates of each
/// step taken at its start, `L = ε̇ / (1 + ε̇ t_n)` on all three normal
/// components (the hoop one is `v_r / r`), `F ← (I + Δt L) F`, `F_θθ`
/// by [`advance_hoop`]. Returns the stress, `F_rr` and `F_θθ` for each law.
fn expand(p: &MatParams, rate: f64, n: usize, dt: f64) -> (Stress, f64, f64, f64) {
    let mut s = Stress::default();
    let (mut f, mut ftt, mut ep) = (Tensor2::IDENTITY, 1.0, 0.0);
    for k in 0..n {
        let t = k as f64 * dt;
        let lr = rate / (1.0 + rate * t);
        let l = Tensor2 {
            xx: lr,
            xy: 0.0,
            yx: 0.0,
            yy: lr,
        };
        f = Tensor2 {
            xx: f.xx + dt * (l.xx * f.xx + l.xy * f.yx),
            xy: f.xy + dt * (l.xx * f.xy + l.xy * f.yy),
            yx: f.yx + dt * (l.yx * f.xx + l.yy * f.yx),
            yy: f.yy + dt * (l.yx * f.xy + l.yy * f.yy),
        };
        ftt = advance_hoop(ftt, lr, dt);
        s = p.update_stress_axi(s, &l, Hoop { rate: lr, f: ftt }, dt, &f, &mut ep);
    }
    (s, f.xx, ftt, ep)
}

#[test]
fn homogeneous_expansion_at_a_material_point_against_closed_forms() {
    let (rate, n) = (1.0, 1000);
    let eps = 0.01;
    let dt = eps / (rate * n as f64);
    let k_bulk = E / (3.0 * (1.0 - 2.0 * NU));
    // Kinematics: F_rr = F_θθ = 1 + ε (r/R), exact for the explicit update.
    let (s, frr, ftt, _) = expand(&nh(), rate, n, dt);
    assert!(rel(frr, 1.0 + eps) < 1e-13 && rel(ftt, 1.0 + eps) < 1e-13);
    // Neo-Hookean: σ = (μ/J)(λ_s² − 1) + λ ln J / J on all three normal
    // components, J = λ_s³ — at the F the update produced.
    let p = nh();
    let j = frr * frr * ftt;
    let want = p.mu / j * (frr * frr - 1.0) + p.lambda * j.ln() / j;
    for c in [s.xx, s.yy, s.zz] {
        assert!(rel(c, want) < 1e-12, "{s:?} vs {want}");
    }
    assert_eq!(s.xy, 0.0);
    // Hypo-elastic: σ = 3K Σ Δt L_n on each normal component, the
    // left-point sum of ∫ ε̇/(1+ε̇t) dt, which tends to 3K ln(1+ε) at first
    // order in Δt.
    let sum: f64 = (0..n)
        .map(|k| dt * rate / (1.0 + rate * k as f64 * dt))
        .sum();
    let (s, _, _, _) = expand(&lin(), rate, n, dt);
    for c in [s.xx, s.yy, s.zz] {
        assert!(rel(c, 3.0 * k_bulk * sum) < 1e-11, "{s:?}");
    }
    let err_n = rel(s.zz, 3.0 * k_bulk * (1.0 + eps).ln());
    let (s2, _, _, _) = expand(&lin(), rate, 2 * n, 0.5 * dt);
    let err_2n = rel(s2.zz, 3.0 * k_bulk * (1.0 + eps).ln());
    assert!(err_n < 1e-5, "{err_n}");
    assert!(
        err_n / err_2n > 1.9 && err_n / err_2n < 2.1,
        "{err_n} {err_2n}"
    );
    // J2 under a pure expansion never yields: the elastic law's bits.
    let (sj, _, _, ep) = expand(&j2_linear(0.0), rate, n, dt);
    assert_eq!(bits(&sj), bits(&s));
    assert_eq!(ep, 0.0);
}

#[test]
fn neo_hookean_axi_is_the_3d_law_and_objective() {
    let p = nh();
    let mut r = Lcg(11);
    for _ in 0..200 {
        let f = Tensor2 {
            xx: 1.0 + 0.2 * r.sym(),
            xy: 0.2 * r.sym(),
            yx: 0.2 * r.sym(),
            yy: 1.0 + 0.2 * r.sym(),
        };
        let ftt = 1.0 + 0.2 * r.sym();
        let s = neo_hookean_stress_axi(p.lambda, p.mu, &f, ftt);
        // The 3D law on the block-diagonal F.
        let f3 = Matrix3::new(f.xx, f.xy, 0.0, f.yx, f.yy, 0.0, 0.0, 0.0, ftt);
        let j = f3.determinant();
        let b = f3 * f3.transpose();
        let sig =
            (b - Matrix3::identity()) * (p.mu / j) + Matrix3::identity() * (p.lambda * j.ln() / j);
        let scale = p.mu;
        for (got, want) in [
            (s.xx, sig[(0, 0)]),
            (s.yy, sig[(1, 1)]),
            (s.xy, sig[(0, 1)]),
            (s.zz, sig[(2, 2)]),
        ] {
            assert!((got - want).abs() < 1e-13 * scale, "{got} vs {want}");
        }
        assert_eq!(sig[(0, 2)], 0.0);
        // A rotation in the r–z plane rotates the in-plane stress and
        // leaves σ_θθ.
        let th = 3.0 * r.sym();
        let (sn, c) = th.sin_cos();
        let fr = Tensor2 {
            xx: c * f.xx - sn * f.yx,
            xy: c * f.xy - sn * f.yy,
            yx: sn * f.xx + c * f.yx,
            yy: sn * f.xy + c * f.yy,
        };
        let sr = neo_hookean_stress_axi(p.lambda, p.mu, &fr, ftt);
        let want = rotate_stress(s, th);
        for (a, b) in [
            (sr.xx, want.xx),
            (sr.yy, want.yy),
            (sr.xy, want.xy),
            (sr.zz, want.zz),
        ] {
            assert!((a - b).abs() < 1e-9 * scale, "{a} vs {b}");
        }
    }
}

#[test]
fn rigid_rotation_in_the_meridian_plane_keeps_the_hoop_stress() {
    // Pure spin, no hoop rate: a prestress with σ_θθ turns by 90° in the
    // r–z plane, σ_θθ stays (linear elastic, and J2 below yield).
    let s0 = Stress {
        xx: 3.0e7,
        yy: 1.0e7,
        xy: 0.5e7,
        zz: -2.0e7,
    };
    let n = 2000;
    let dt = 1e-3;
    let w = std::f64::consts::FRAC_PI_2 / (n as f64 * dt);
    let l = Tensor2 {
        xx: 0.0,
        xy: -w,
        yx: w,
        yy: 0.0,
    };
    for p in [lin(), j2_linear(1e9)] {
        let mut s = s0;
        let mut ep = 0.0;
        for _ in 0..n {
            s = p.update_stress_axi(s, &l, Hoop::NONE, dt, &Tensor2::IDENTITY, &mut ep);
        }
        let scale = 3.0e7;
        assert!((s.xx - s0.yy).abs() < 1e-6 * scale, "{s:?}");
        assert!((s.yy - s0.xx).abs() < 1e-6 * scale, "{s:?}");
        assert!((s.xy + s0.xy).abs() < 1e-6 * scale, "{s:?}");
        assert_eq!(s.zz, s0.zz);
        assert_eq!(ep, 0.0);
    }
}

#[test]
fn j2_under_axisymmetric_isochoric_extension_matches_the_closed_form() {
    // D = ε̇ diag(−1/2, 1) in the r–z plane, L_θθ = −ε̇/2: the uniaxial
    // isochoric stretch along the axis, which plane strain cannot
    // represent. Deviator s = 2μ e until q = 3μ ε reaches σ_y (ε_y =
    // σ_y/(3μ)); then q = σ_y + 3μh/(3μ+h) (ε − ε_y), ε_p = (3μ ε −
    // σ_y)/(3μ + h); the mean stress stays 0; σ_zz = 2q/3, σ_rr = σ_θθ =
    // −q/3. Exact for the radial return on this radial path.
    for h in [0.0, 5e9] {
        let p = j2_linear(h);
        let mu3 = 3.0 * p.mu;
        let rate = 1.0;
        let (dt, n) = (2e-5, 1000); // to ε = 0.02, ~20 ε_y
        let l = Tensor2 {
            xx: -0.5 * rate,
            xy: 0.0,
            yx: 0.0,
            yy: rate,
        };
        let hoop = Hoop {
            rate: -0.5 * rate,
            f: 1.0,
        };
        let (mut s, mut ep) = (Stress::default(), 0.0);
        let eps_y = SY / mu3;
        for k in 1..=n {
            s = J2Law::update_axi(&p, s, &l, hoop, dt, &Tensor2::IDENTITY, &mut ep);
            let eps = rate * dt * k as f64;
            let (q, epw) = if eps <= eps_y {
                (mu3 * eps, 0.0)
            } else {
                (
                    SY + mu3 * h / (mu3 + h) * (eps - eps_y),
                    (mu3 * eps - SY) / (mu3 + h),
                )
            };
            let tol = 1e-10 * SY;
            assert!(
                (von_mises(&s) - q).abs() < tol,
                "h={h} step {k}: {s:?} q={q}"
            );
            assert!((s.yy - 2.0 * q / 3.0).abs() < tol, "h={h} step {k}: {s:?}");
            assert!((s.xx + q / 3.0).abs() < tol && (s.zz + q / 3.0).abs() < tol);
            assert!((ep - epw).abs() < 1e-10 * (eps_y + epw), "{ep} vs {epw}");
        }
        // Plane strain with the same in-plane rates holds D_zz = 0 instead
        // of the hoop rate: a different state (σ_zz ≠ σ_rr).
        let (mut ps, mut pep) = (Stress::default(), 0.0);
        for _ in 0..n {
            ps = J2Law::update(&p, ps, &l, dt, &Tensor2::IDENTITY, &mut pep);
        }
        assert!((ps.zz - ps.xx).abs() > 0.2 * SY, "{ps:?}");
    }
}

/// An independent integration of 3D J2 with the Jaumann rate: full 3×3
/// tensors, the exact rotation `exp(W Δt)` of the step, the elastic
/// increment `C:D Δt`, and a radial return whose power-law equation is
/// solved by bisection.
fn reference_j2(
    p: &MatParams,
    path: &dyn Fn(f64) -> (Tensor2, f64),
    t_end: f64,
    n: usize,
) -> (Matrix3<f64>, f64) {
    let hard = p.hardening.unwrap();
    let (lam, mu) = (p.lambda, p.mu);
    let dt = t_end / n as f64;
    let mut s = Matrix3::<f64>::zeros();
    let mut ep = 0.0;
    for k in 0..n {
        let (l, ltt) = path((k as f64 + 0.5) * dt);
        let l3 = Matrix3::new(l.xx, l.xy, 0.0, l.yx, l.yy, 0.0, 0.0, 0.0, ltt);
        let d = (l3 + l3.transpose()) * 0.5;
        let w = 0.5 * (l.yx - l.xy) * dt;
        let (sn, c) = w.sin_cos();
        let q = Matrix3::new(c, -sn, 0.0, sn, c, 0.0, 0.0, 0.0, 1.0);
        s = q * s * q.transpose();
        s += (Matrix3::identity() * (lam * d.trace()) + d * (2.0 * mu)) * dt;
        let pm = s.trace() / 3.0;
        let dev = s - Matrix3::identity() * pm;
        let qt = (1.5 * dev.component_mul(&dev).sum()).sqrt();
        let sy = hard.flow_stress(ep);
        if qt > sy {
            let g = |x: f64| qt - 3.0 * mu * x - hard.flow_stress(ep + x);
            let (mut lo, mut hi) = (0.0, (qt - sy) / (3.0 * mu));
            for _ in 0..200 {
                let m = 0.5 * (lo + hi);
                if g(m) > 0.0 {
                    lo = m;
                } else {
                    hi = m;
                }
            }
            let x = 0.5 * (lo + hi);
            ep += x;
            s = Matrix3::identity() * pm + dev * (1.0 - 3.0 * mu * x / qt);
        }
    }
    (s, ep)
}

#[test]
fn j2_on_a_non_proportional_axisymmetric_path_converges_to_a_reference_integration() {
    // Stretch, shear, spin and a hoop rate that changes sign, about 10 ε_y
    // in all, with power-law hardening.
    let p = j2(Hardening::Power {
        sigma_0: SY,
        n: 0.1,
        eps_0: SY / E,
    });
    let path = |t: f64| {
        (
            Tensor2 {
                xx: 0.010 * (2.0 * t).cos(),
                xy: 0.006 * (3.0 * t).sin(),
                yx: -0.004,
                yy: -0.012,
            },
            0.008 * t.sin() - 0.004,
        )
    };
    let t_end = 1.5;
    let (sref, epref) = reference_j2(&p, &path, t_end, 60_000);
    let run = |n: usize| {
        let dt = t_end / n as f64;
        let (mut s, mut ep) = (Stress::default(), 0.0);
        for k in 0..n {
            let (l, ltt) = path((k as f64 + 0.5) * dt);
            let hoop = Hoop { rate: ltt, f: 1.0 };
            s = J2Law::update_in::<Axisymmetric>(&p, s, &l, hoop, dt, &l, &mut ep);
        }
        let err = [
            s.xx - sref[(0, 0)],
            s.yy - sref[(1, 1)],
            s.xy - sref[(0, 1)],
            s.zz - sref[(2, 2)],
        ]
        .iter()
        .fold(0.0f64, |a, &b| a.max(b.abs()));
        (err / SY, (ep - epref).abs() / epref)
    };
    let (e1, p1) = run(150);
    let (e2, p2) = run(300);
    let (e3, p3) = run(600);
    println!("J2 axi vs reference: stress error / σ_y {e1:.2e} {e2:.2e} {e3:.2e}, ε_p {p1:.2e} {p2:.2e} {p3:.2e}");
    assert!(epref > 5.0 * SY / E, "the path must flow: ε_p = {epref}");
    assert!(e3 < 2e-3 && p3 < 2e-3, "{e3} {p3}");
    // First order (or better) in the step.
    assert!(e1 / e2 > 1.7 && e2 / e3 > 1.7, "{e1} {e2} {e3}");
}

#[test]
fn kinematics_of_the_modes() {
    let mut r = Lcg(21);
    for _ in 0..200 {
        let l = Tensor2 {
            xx: r.sym(),
            xy: r.sym(),
            yx: r.sym(),
            yy: r.sym(),
        };
        let (ltt, dt, dbar) = (r.sym(), r.next(), r.sym());
        // Plane strain: the kernel's own expressions, bit for bit.
        let dxy = 0.5 * (l.xy + l.yx);
        let kernel_inc2 = dt * dt * (l.xx * l.xx + l.yy * l.yy + 2.0 * dxy * dxy);
        assert_eq!(
            strain_increment2::<PlaneStrain>(&l, ltt, dt).to_bits(),
            kernel_inc2.to_bits()
        );
        let mut kl = l;
        let c = 0.5 * (dbar - (kl.xx + kl.yy));
        kl.xx += c;
        kl.yy += c;
        let (mut pl, mut ptt) = (l, ltt);
        replace_dilatation::<PlaneStrain>(&mut pl, &mut ptt, dbar);
        assert_eq!(pl, kl);
        assert_eq!(ptt, ltt);
        assert_eq!(
            jacobian::<PlaneStrain>(&l, ltt).to_bits(),
            l.det().to_bits()
        );
        // Axisymmetry: the hoop enters.
        assert!(
            (strain_increment2::<Axisymmetric>(&l, ltt, dt) - kernel_inc2 - dt * dt * ltt * ltt)
                .abs()
                < 1e-14
        );
        assert_eq!(jacobian::<Axisymmetric>(&l, ltt), l.det() * ltt);
        assert_eq!(dilatation::<Axisymmetric>(&l, ltt), l.xx + l.yy + ltt);
        let (mut al, mut att) = (l, ltt);
        replace_dilatation::<Axisymmetric>(&mut al, &mut att, dbar);
        assert!((dilatation::<Axisymmetric>(&al, att) - dbar).abs() < 1e-14);
        let m0 = dilatation::<Axisymmetric>(&l, ltt) / 3.0;
        let m1 = dbar / 3.0;
        for (a, b) in [
            (l.xx - m0, al.xx - m1),
            (l.yy - m0, al.yy - m1),
            (ltt - m0, att - m1),
        ] {
            assert!((a - b).abs() < 1e-14, "the deviator is kept");
        }
        assert_eq!((al.xy, al.yx), (l.xy, l.yx));
    }
    // The hoop stretch of a radial motion at constant velocity, r = R + v t
    // (L_θθ = v / r_n at each step's start), is r/R to round-off.
    let (big_r, v, dt) = (0.3, 0.7, 1e-3);
    let mut ftt = 1.0;
    for k in 0..1000 {
        let rn = big_r + v * dt * k as f64;
        ftt = advance_hoop(ftt, v / rn, dt);
    }
    assert!(rel(ftt, (big_r + v * 1.0) / big_r) < 1e-13, "{ftt}");
    // The midpoint form at a constant rate: ((1 + kL)/(1 − kL))^n → e^{Lt}
    // at second order.
    let err = |n: usize| {
        let (rate, t) = (2.0, 0.5);
        let dt = t / n as f64;
        let mut f = 1.0;
        for _ in 0..n {
            f = advance_hoop_midpoint(f, rate, dt);
        }
        rel(f, (rate * t).exp())
    };
    let (a, b) = (err(100), err(200));
    assert!(a < 1e-4 && a / b > 3.9 && a / b < 4.1, "{a} {b}");
}

#[test]
fn axisymmetric_energies_are_consistent_with_the_stresses() {
    // Neo-Hookean: dW/dt = J V0 σ:D (the stress power, with σ_θθ L_θθ) on
    // a general path F(t) = F0 + t Ḟ, F_θθ(t) = f0 + t ḟ.
    let p = nh();
    let vol0 = 1.7;
    let (f0, fd) = (
        Tensor2 {
            xx: 1.05,
            xy: 0.08,
            yx: -0.03,
            yy: 0.93,
        },
        Tensor2 {
            xx: 0.2,
            xy: -0.1,
            yx: 0.3,
            yy: 0.15,
        },
    );
    let (t0, td) = (1.08, -0.25);
    let at = |t: f64| {
        let f = Tensor2 {
            xx: f0.xx + t * fd.xx,
            xy: f0.xy + t * fd.xy,
            yx: f0.yx + t * fd.yx,
            yy: f0.yy + t * fd.yy,
        };
        (f, t0 + t * td)
    };
    let w = |t: f64| {
        let (f, ftt) = at(t);
        p.strain_energy_in::<Axisymmetric>(&Stress::default(), &f, ftt, vol0)
    };
    let h = 1e-5;
    let dw = (w(h) - w(-h)) / (2.0 * h);
    let (f, ftt) = at(0.0);
    let s = neo_hookean_stress_axi(p.lambda, p.mu, &f, ftt);
    // L = Ḟ F⁻¹, L_θθ = ḟ / F_θθ.
    let j2d = f.det();
    let inv = Tensor2 {
        xx: f.yy / j2d,
        xy: -f.xy / j2d,
        yx: -f.yx / j2d,
        yy: f.xx / j2d,
    };
    let l = Tensor2 {
        xx: fd.xx * inv.xx + fd.xy * inv.yx,
        xy: fd.xx * inv.xy + fd.xy * inv.yy,
        yx: fd.yx * inv.xx + fd.yy * inv.yx,
        yy: fd.yx * inv.xy + fd.yy * inv.yy,
    };
    let power = jacobian::<Axisymmetric>(&f, ftt)
        * vol0
        * (s.xx * l.xx + s.yy * l.yy + s.xy * (l.xy + l.yx) + s.zz * td / ftt);
    assert!(rel(dw, power) < 1e-7, "{dw} vs {power}");
    // Linear elastic: a homogeneous expansion's stress 3Kε (all three
    // normal components) stores σ²/(2K) per unit current volume.
    let p = lin();
    let k_bulk = E / (3.0 * (1.0 - 2.0 * NU));
    let eps = 1e-3;
    let sig = 3.0 * k_bulk * eps;
    let s = Stress {
        xx: sig,
        yy: sig,
        xy: 0.0,
        zz: sig,
    };
    let f = Tensor2 {
        xx: 1.0 + eps,
        xy: 0.0,
        yx: 0.0,
        yy: 1.0 + eps,
    };
    let got = p.strain_energy_in::<Axisymmetric>(&s, &f, 1.0 + eps, vol0);
    let want = sig * sig / (2.0 * k_bulk) * (1.0 + eps).powi(3) * vol0;
    assert!(rel(got, want) < 1e-12, "{got} vs {want}");
}
