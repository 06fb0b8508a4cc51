//! J2 plasticity driven at one material point by prescribed velocity
//! gradients, against closed forms (plain `cargo test`, no grid).
//!
//! Material: E = 70 GPa, ν = 0.3 (aluminium-like), σ_y = 100 MPa; linear
//! hardening h = 5 GPa where a test needs a hardening slope, h = 0 (perfect
//! plasticity) for the limit loads; the power law σ_0 = 100 MPa, n = 0.1,
//! ε_0 = σ_0/E for the consistency test. μ = E/(2(1+ν)), λ = Eν/((1+ν)(1−2ν)),
//! K = λ + 2μ/3.
//!
//! Closed forms (derivations in the tests' comments), all exact for the
//! discrete update on these proportional paths (no spin: the Jaumann
//! update adds `C:D Δt` exactly; radial return with linear hardening is
//! exact on a radial path), so the bounds are round-off:
//! * pure shear `D_xy = γ̇/2`, no spin: `τ = μγ` up to `τ_y = σ_y/√3`
//!   (`γ_y = σ_y/(√3 μ)`), then `dτ/dγ = μh/(h + 3μ)`, `ε_p = √3 (τ − τ_y)/h`;
//! * plane-strain uniaxial strain (only `D_yy`): `σ_xx = σ_zz = λε`,
//!   `σ_yy = (λ+2μ)ε`, so `σ_xx/σ_yy = ν/(1−ν)` and `q = |σ_yy − σ_xx| =
//!   2μ|ε|`: first yield at `|ε| = σ_y/(2μ) = σ_y(1+ν)/E`, where
//!   `|σ_yy| = σ_y (1−ν)/(1−2ν)`; after it `q = σ_y + 2μh/(3μ+h) (|ε| −
//!   ε_y)` and the mean stress stays `Kε`;
//! * plane-strain compression with `σ_xx = 0`: elastic `σ_yy = E/(1−ν²) ε`,
//!   `σ_zz = νσ_yy`, `q = |σ_yy| √(1 − ν + ν²)`: first yield at
//!   `|σ_yy| = σ_y/√(1−ν+ν²)`; with perfect plasticity `σ_zz → σ_yy/2` and
//!   `|σ_yy| → 2σ_y/√3` (the plane-strain limit).

use gimlet::material::j2::{pressure_mean, von_mises, Hardening};
use gimlet::material::{rotate_stress, MatParams, Material, Stress, Tensor2};

const E: f64 = 70e9;
const NU: f64 = 0.3;
const RHO: f64 = 2700.0;
const SY: f64 = 100e6;
const H: f64 = 5e9;

fn j2(hardening: Hardening) -> Material {
    Material::J2 {
        e: E,
        nu: NU,
        rho: RHO,
        hardening,
    }
}

fn linear(h: f64) -> Material {
    j2(Hardening::Linear { sigma_y: SY, h })
}

fn power() -> Hardening {
    Hardening::Power {
        sigma_0: SY,
        n: 0.1,
        eps_0: SY / E,
    }
}

/// One material point: the law, its stress and equivalent plastic strain.
#[derive(Clone, Copy)]
struct Point {
    p: MatParams,
    s: Stress,
    ep: f64,
}

impl Point {
    fn new(m: Material) -> Point {
        m.validate().unwrap();
        Point {
            p: m.params(),
            s: Stress::default(),
            ep: 0.0,
        }
    }
    /// One step under the velocity gradient `l`; true when it yielded.
    fn step(&mut self, l: &Tensor2, dt: f64) -> bool {
        let ep0 = self.ep;
        self.s = self
            .p
            .update_stress(self.s, l, dt, &Tensor2::IDENTITY, &mut self.ep);
        self.ep > ep0
    }
    fn q(&self) -> f64 {
        von_mises(&self.s)
    }
    fn flow(&self) -> f64 {
        self.p.hardening.unwrap().flow_stress(self.ep)
    }
}

fn lg(xx: f64, xy: f64, yx: f64, yy: f64) -> Tensor2 {
    Tensor2 { xx, xy, yx, yy }
}

fn mu() -> f64 {
    E / (2.0 * (1.0 + NU))
}
fn lambda() -> f64 {
    E * NU / ((1.0 + NU) * (1.0 - 2.0 * NU))
}

/// Pure shear (`D_xy` only, no spin): yield at `τ = σ_y/√3`, then the
/// hardening slope `dτ/dγ = μh/(h+3μ)`. Derivation: `q = √3 τ`; while
/// yielding `q = σ_y + h ε_p` gives `dε_p = √3 dτ / h`; the plastic shear
/// strain is `dγ_p = 3/2 · 2 · (s_xy/q) dε_p = √3 dε_p = 3 dτ/h`, and
/// `dτ = μ (dγ − dγ_p)`.
#[test]
fn pure_shear_yields_at_sigma_y_over_sqrt3_and_hardens_with_the_closed_form_slope() {
    let mu = mu();
    let tau_y = SY / 3f64.sqrt();
    let gamma_y = tau_y / mu;
    for h in [H, 0.0] {
        let mut pt = Point::new(linear(h));
        let dgam = gamma_y / 37.0; // yield falls inside a step
        let dt = 1e-3;
        let l = lg(0.0, 0.5 * dgam / dt, 0.5 * dgam / dt, 0.0);
        let slope = mu * h / (h + 3.0 * mu);
        let (mut first, mut worst) = (None, 0.0f64);
        for k in 1..=400 {
            let yielded = pt.step(&l, dt);
            let g = k as f64 * dgam;
            let tau = if g <= gamma_y {
                mu * g
            } else {
                tau_y + slope * (g - gamma_y)
            };
            worst = worst.max((pt.s.xy - tau).abs() / tau_y);
            assert_eq!((pt.s.xx, pt.s.yy, pt.s.zz), (0.0, 0.0, 0.0));
            if yielded && first.is_none() {
                first = Some(k);
                assert!(g > gamma_y && g - dgam <= gamma_y, "step {k}");
            }
            if h > 0.0 && g > gamma_y {
                let ep = 3f64.sqrt() * (pt.s.xy - tau_y) / h;
                assert!((pt.ep - ep).abs() <= 1e-12 * ep, "{} vs {ep}", pt.ep);
            }
        }
        println!(
            "pure shear, h = {h:e}: first yield at step {:?} (gamma_y = {gamma_y:.4e}, step {dgam:.3e}), tau at gamma = {:.1} gamma_y: {:.6e} (closed form slope {slope:.6e}); max |tau - closed form| / tau_y = {worst:.2e}",
            first.unwrap(),
            400.0 / 37.0,
            pt.s.xy
        );
        assert!(worst <= 1e-12, "worst = {worst:e}");
    }
}

/// Simple shear (`L_xy` only: stretching and spin): the stress rotates with
/// the spin, so `σ_xx, σ_yy` are `O(γ τ)` and the shear stress at first
/// yield is `σ_y/√3` up to `O(γ_y²)` (~1e-6 here); `q = σ_y` there to
/// round-off.
#[test]
fn simple_shear_yields_at_sigma_y_over_sqrt3_up_to_the_rotation() {
    let mu = mu();
    let tau_y = SY / 3f64.sqrt();
    let gamma_y = tau_y / mu;
    let mut pt = Point::new(linear(0.0));
    let dgam = gamma_y / 50.0;
    let dt = 1.0;
    let l = lg(0.0, dgam / dt, 0.0, 0.0);
    let mut k = 0;
    while !pt.step(&l, dt) {
        k += 1;
        assert!(k < 100);
    }
    let rel = (pt.s.xy - tau_y).abs() / tau_y;
    let cons = (pt.q() - SY).abs() / SY;
    println!("simple shear: first yield at gamma = {:.4e} (gamma_y = {gamma_y:.4e}), sigma_xy / tau_y - 1 = {rel:.2e}, q / sigma_y - 1 = {cons:.1e}", (k + 1) as f64 * dgam);
    assert!(rel < 1e-5, "rel = {rel:e}");
    assert!(cons < 1e-14, "cons = {cons:e}");
}

/// Plane-strain uniaxial strain (only `D_yy`, compression): elastic
/// `σ_xx = σ_zz = ν/(1−ν) σ_yy`; first yield at `σ_xx − σ_yy = σ_y`,
/// `|ε| = σ_y/(2μ)`, `|σ_yy| = σ_y(1−ν)/(1−2ν)`; then `q = σ_y +
/// 2μh/(3μ+h)(|ε| − ε_y)`, mean stress `Kε`. (With `n = 3/2 s/q`, `n_yy =
/// −1` in compression: `dq = 3μ(2/3 d|ε| − dε_p)`, `dq = h dε_p`.)
#[test]
fn plane_strain_uniaxial_strain_first_yield_and_hardening() {
    let (mu, la) = (mu(), lambda());
    let k_bulk = la + 2.0 * mu / 3.0;
    let eps_y = SY / (2.0 * mu);
    let syy_y = SY * (1.0 - NU) / (1.0 - 2.0 * NU);
    let mut pt = Point::new(linear(H));
    let de = eps_y / 23.5; // yield falls inside a step
    let dt = 1.0;
    let l = lg(0.0, 0.0, 0.0, -de / dt);
    let slope = 2.0 * mu * H / (3.0 * mu + H);
    let mut worst = 0.0f64;
    let mut onset = None;
    for k in 1..=200 {
        let yielded = pt.step(&l, dt);
        let e = k as f64 * de; // |ε|
        if e <= eps_y {
            assert!(!yielded);
            let r = pt.s.xx / pt.s.yy;
            assert!((r - NU / (1.0 - NU)).abs() < 1e-14, "{r}");
            assert_eq!(pt.s.xx, pt.s.zz);
        } else if onset.is_none() {
            assert!(yielded && e - de <= eps_y);
            onset = Some(k);
        }
        let q = if e <= eps_y {
            2.0 * mu * e
        } else {
            SY + slope * (e - eps_y)
        };
        let m = -k_bulk * e;
        let (syy, sxx) = (m - 2.0 * q / 3.0, m + q / 3.0);
        worst = worst
            .max((pt.s.yy - syy).abs() / SY)
            .max((pt.s.xx - sxx).abs() / SY)
            .max((pt.s.zz - sxx).abs() / SY);
    }
    println!(
        "plane-strain uniaxial strain: exact onset |eps_yy| = sigma_y/(2 mu) = {eps_y:.6e}, sigma_yy = -sigma_y (1-nu)/(1-2nu) = {:.6e}; yielded first at step {:?} of {de:.3e}; max |sigma - closed form| / sigma_y = {worst:.2e}",
        -syy_y,
        onset.unwrap()
    );
    assert!(worst < 1e-12, "worst = {worst:e}");
}

/// One step of `D_yy = dyy` with `D_xx` solved so that `σ_xx = 0` after
/// the step (secant iteration on the law itself, to |σ_xx| ≤ 1e-12 σ_y).
fn step_free_lateral(pt: &mut Point, dyy: f64, guess: f64) -> f64 {
    let sxx = |dxx: f64| {
        let mut t = *pt;
        t.step(&lg(dxx, 0.0, 0.0, dyy), 1.0);
        t.s.xx
    };
    let (mut a, mut b) = (guess, guess * (1.0 + 1e-3) + 1e-18);
    let (mut fa, mut fb) = (sxx(a), sxx(b));
    for _ in 0..60 {
        if fb.abs() <= 1e-12 * SY {
            break;
        }
        let c = b - fb * (b - a) / (fb - fa);
        (a, fa) = (b, fb);
        b = c;
        fb = sxx(b);
    }
    assert!(fb.abs() <= 1e-12 * SY, "sigma_xx = {fb}");
    pt.step(&lg(b, 0.0, 0.0, dyy), 1.0);
    b
}

/// Plane-strain compression, lateral face free (`σ_xx = 0`), perfect
/// plasticity: elastic `σ_yy = E/(1−ν²) ε`, `σ_zz = νσ_yy`; first yield at
/// `|σ_yy| = σ_y/√(1−ν+ν²)`; then `|σ_yy|` rises to the limit `2σ_y/√3`
/// as `σ_zz → σ_yy/2`.
#[test]
fn plane_strain_compression_tends_to_two_over_sqrt3_sigma_y() {
    let mut pt = Point::new(linear(0.0));
    let onset = SY / (1.0 - NU + NU * NU).sqrt();
    let limit = 2.0 * SY / 3f64.sqrt();
    let eps1 = onset * (1.0 - NU * NU) / E;
    let de = eps1 / 40.0;
    let ratio = -lambda() / (lambda() + 2.0 * mu());
    let mut dxx = ratio * -de;
    let (mut eps, mut first) = (0.0, None);
    let mut lateral = 0.0;
    let steps = (0.05 / de).ceil() as usize; // to 5 % compression
    for k in 1..=steps {
        let ep0 = pt.ep;
        dxx = step_free_lateral(&mut pt, -de, dxx);
        lateral += dxx;
        eps += de;
        if pt.ep == ep0 {
            let syy = -E / (1.0 - NU * NU) * eps;
            assert!((pt.s.yy - syy).abs() < 1e-11 * SY, "{} vs {syy}", pt.s.yy);
            assert!((pt.s.zz - NU * pt.s.yy).abs() < 1e-11 * SY);
        } else if first.is_none() {
            first = Some((k, pt.s.yy));
            assert!(eps > eps1 && eps - de <= eps1 * (1.0 + 1e-12));
        }
        assert!((pt.q() - SY).abs() < 1e-12 * SY || pt.ep == 0.0 || pt.ep == ep0);
    }
    let rel = (pt.s.yy.abs() - limit).abs() / limit;
    println!(
        "plane-strain compression, sigma_xx = 0: first yield at |sigma_yy| = sigma_y/sqrt(1-nu+nu^2) = {onset:.6e} (step {:?}); at {:.1} % strain ({steps} steps, eps_p = {:.4}, lateral strain {:.4}): |sigma_yy| = {:.8e}, limit 2 sigma_y/sqrt(3) = {limit:.8e}, relative difference {rel:.2e}, sigma_zz/sigma_yy = {:.8}",
        first.unwrap(),
        100.0 * eps,
        pt.ep,
        lateral,
        pt.s.yy.abs(),
        pt.s.zz / pt.s.yy
    );
    assert!(pt.s.xx.abs() <= 1e-12 * SY);
    assert!(rel < 1e-9, "rel = {rel:e}");
    assert!((pt.s.zz / pt.s.yy - 0.5).abs() < 1e-9);
}

/// Load, unload to zero, reload, then reverse, in pure shear with linear
/// hardening: unloading follows the elastic slope μ with ε_p frozen;
/// reloading yields again at the flow stress reached (τ₁), and reverse
/// loading yields at −τ₁ (isotropic hardening: no Bauschinger effect).
#[test]
fn load_unload_reload_is_elastic_and_yields_at_the_previous_flow_stress() {
    let mu = mu();
    let tau_y = SY / 3f64.sqrt();
    let gamma_y = tau_y / mu;
    let dgam = gamma_y / 41.0;
    let dt = 1.0;
    let shear = |r: f64| lg(0.0, 0.5 * r * dgam / dt, 0.5 * r * dgam / dt, 0.0);
    let mut pt = Point::new(linear(H));
    for _ in 0..600 {
        pt.step(&shear(1.0), dt);
    }
    let (tau1, ep1) = (pt.s.xy, pt.ep);
    assert!(tau1 > 1.5 * tau_y);
    // Unload to (about) zero stress: elastic, slope μ exactly.
    let n_un = (tau1 / (mu * dgam)).floor() as usize;
    for k in 1..=n_un {
        assert!(!pt.step(&shear(-1.0), dt));
        let expect = tau1 - mu * k as f64 * dgam;
        assert!((pt.s.xy - expect).abs() < 1e-12 * tau1);
        assert_eq!(pt.ep, ep1);
    }
    // Reload: elastic up to τ₁, yielding in the step that crosses it.
    let mut k = 0;
    let before = loop {
        let prev = pt.s.xy;
        k += 1;
        if pt.step(&shear(1.0), dt) {
            break prev;
        }
        assert!(k < 10 * n_un);
    };
    let crossed = before + mu * dgam;
    println!(
        "reload: yields in the step from tau = {before:.8e} (trial {crossed:.8e}), previous flow stress tau_1 = {tau1:.8e}"
    );
    assert!(before <= tau1 * (1.0 + 1e-12) && crossed > tau1);
    // Reverse: elastic down to −τ₂ (τ₂ the flow stress now), then yields.
    let tau2 = pt.flow() / 3f64.sqrt();
    let ep2 = pt.ep;
    let before = loop {
        let prev = pt.s.xy;
        if pt.step(&shear(-1.0), dt) {
            break prev;
        }
        assert_eq!(pt.ep, ep2);
    };
    let crossed = before - mu * dgam;
    println!(
        "reverse: yields in the step from tau = {before:.8e} (trial {crossed:.8e}), current flow stress -tau_2 = {:.8e} (a Bauschinger effect would yield earlier)",
        -tau2
    );
    assert!(before >= -tau2 * (1.0 + 1e-12) && crossed < -tau2);
    assert!((pt.q() - pt.flow()).abs() < 1e-12 * pt.flow());
}

/// A yielded point spun rigidly (spin only) for three full turns: the
/// components rotate by the update's angle (`4 atan(ω Δt/4)` per step,
/// Hughes–Winget), the invariants (q, mean stress, σ_zz) and ε_p stay.
#[test]
fn rigid_rotation_of_a_yielded_point_keeps_its_invariants() {
    for hard in [Hardening::Linear { sigma_y: SY, h: H }, power()] {
        let mut pt = Point::new(j2(hard));
        let r = SY / E / 10.0;
        let l = lg(r, 0.2 * r, 0.2 * r, -0.3 * r);
        let mut n = 0;
        while pt.ep < 0.01 {
            pt.step(&l, 1.0);
            n += 1;
        }
        let (s0, q0, m0, ep0) = (pt.s, pt.q(), pressure_mean(&pt.s), pt.ep);
        assert!((q0 - pt.flow()).abs() < 1e-12 * q0, "{n} loading steps");
        let turns = 3.0;
        let nsteps = 400;
        let w = 0.05; // angle rate
        let dt = turns * 2.0 * std::f64::consts::PI / (w * nsteps as f64);
        let spin = lg(0.0, -w, w, 0.0);
        let mut worst = [0.0f64; 4];
        for k in 1..=nsteps {
            pt.step(&spin, dt);
            worst[0] = worst[0].max((pt.q() - q0).abs() / q0);
            worst[1] = worst[1].max((pressure_mean(&pt.s) - m0).abs() / q0);
            worst[2] = worst[2].max((pt.s.zz - s0.zz).abs() / q0);
            worst[3] = worst[3].max((pt.ep - ep0).abs() / ep0);
            let theta = k as f64 * 4.0 * (0.25 * w * dt).atan();
            let rs = rotate_stress(s0, theta);
            let d = [pt.s.xx - rs.xx, pt.s.yy - rs.yy, pt.s.xy - rs.xy]
                .iter()
                .fold(0.0f64, |a, b| a.max(b.abs()));
            assert!(d < 1e-11 * q0, "step {k}: {d:e}");
        }
        println!(
            "{hard:?}: 3 turns in {nsteps} steps of {:.3} rad; max relative change: q {:.1e}, mean stress {:.1e}, sigma_zz {:.1e}, eps_p {:.1e}",
            4.0 * (0.25 * w * dt).atan(),
            worst[0],
            worst[1],
            worst[2],
            worst[3]
        );
        assert!(worst.iter().all(|&v| v < 1e-12), "{worst:?}");
        // A rotated state, not the original.
        assert!((pt.s.xy - s0.xy).abs() > 0.0 || (pt.s.xx - s0.xx).abs() > 0.0);
    }
}

/// While yielding, the returned stress is on the yield surface,
/// `q = σ_y(ε_p)`, to round-off at every step, for both hardening laws, on
/// a path that mixes stretching, shear, spin and changes direction. (The
/// round-off of `q` computed from the components is that of the largest
/// component: the bound is relative to `max(σ_y, |σ_m|)`.)
#[test]
fn stress_stays_on_the_yield_surface_while_yielding() {
    for hard in [
        Hardening::Linear { sigma_y: SY, h: H },
        Hardening::Linear {
            sigma_y: SY,
            h: 0.0,
        },
        power(),
    ] {
        let mut pt = Point::new(j2(hard));
        let r = SY / E / 7.0;
        let (mut plastic, mut worst, mut pmax) = (0, 0.0f64, 0.0f64);
        for k in 0..4000 {
            let t = k as f64 / 4000.0 * 6.0;
            let l = lg(
                r * (1.0 + t).cos(),
                r * (0.3 + 0.7 * (2.0 * t).sin()),
                r * (0.1 - 0.5 * t.cos()),
                -r * ((1.0 + t).cos() + 0.2 * (3.0 * t).sin()),
            );
            let yielded = pt.step(&l, 1.0);
            let scale = pt.flow().max(pressure_mean(&pt.s).abs());
            let excess = (pt.q() - pt.flow()) / scale;
            if yielded {
                plastic += 1;
                worst = worst.max(excess.abs());
            }
            assert!(excess <= 1e-14, "step {k}: {excess:e}");
            pmax = pmax.max(pressure_mean(&pt.s).abs() / pt.flow());
        }
        println!(
            "{hard:?}: {plastic} yielding steps of 4000, eps_p = {:.4}, max |mean stress| / sigma_y = {pmax:.2}, max |q - sigma_y(eps_p)| / max(sigma_y, |mean stress|) = {worst:.2e}",
            pt.ep
        );
        assert!(plastic > 1000);
        assert!(worst < 1e-14, "worst = {worst:e}");
    }
}

/// The power-law return's scalar equation converges to round-off for
/// extreme valid parameters: `n` from 0 to 0.999, `ε_0` from 1e-12 to 1,
/// current `ε_p` from 0 to 10, trial overstress from 1e-10 to 1e3 times
/// the flow stress. Converged: the root is bracketed within a few units in
/// the last place (`g(Δ(1−ε)) ≥ 0 ≥ g(Δ(1+ε))`, `ε = 16 ulp`) or the
/// residual is at the round-off of `q*`.
#[test]
fn power_law_return_converges_for_extreme_parameters() {
    let mu3 = 3.0 * mu();
    let (mut cases, mut max_it, mut it_sum) = (0, 0, 0u64);
    for n in [0.0, 1e-6, 0.01, 0.1, 0.5, 0.9, 0.999] {
        for eps_0 in [1e-12, 1e-8, 1e-4, 1e-2, 1.0] {
            for ep in [0.0, 1e-9, 1e-3, 0.3, 10.0] {
                for over in [1e-10, 1e-4, 0.1, 3.0, 1e3] {
                    let h = Hardening::Power {
                        sigma_0: SY,
                        n,
                        eps_0,
                    };
                    let sy = h.flow_stress(ep);
                    let q = sy * (1.0 + over);
                    let inc = h.increment(q, mu3, ep, sy);
                    let x = inc.deps;
                    let g = |x: f64| q - mu3 * x - h.flow_stress(ep + x);
                    let tol = 16.0 * f64::EPSILON;
                    let bracketed = g(x * (1.0 - tol)) >= 0.0 && g(x * (1.0 + tol)) <= 0.0;
                    let small = g(x).abs() <= 8.0 * f64::EPSILON * q;
                    assert!(
                        x > 0.0 && x.is_finite() && (bracketed || small),
                        "n {n}, eps_0 {eps_0}, eps_p {ep}, over {over}: x = {x:e}, g = {:e}, {} iterations",
                        g(x),
                        inc.iterations
                    );
                    max_it = max_it.max(inc.iterations);
                    it_sum += inc.iterations as u64;
                    cases += 1;
                }
            }
        }
    }
    println!(
        "power-law return: {cases} cases converged, mean {:.1} iterations, at most {max_it}",
        it_sum as f64 / cases as f64
    );
    assert!(max_it <= 100, "max_it = {max_it}");
    // The aluminium of issue 14 (σ_0 = 100 MPa, n = 0.1, ε_0 = σ_0/E) at
    // the overstresses of explicit steps: one or two powers.
    let h = power();
    let (mut max_it, mut it_sum, mut cases) = (0, 0, 0);
    for ep in [0.0, 1e-4, 1e-2, 0.1, 0.5] {
        for over in [1e-8, 1e-6, 1e-4, 1e-2] {
            let sy = h.flow_stress(ep);
            let inc = h.increment(sy * (1.0 + over), mu3, ep, sy);
            max_it = max_it.max(inc.iterations);
            it_sum += inc.iterations;
            cases += 1;
        }
    }
    println!(
        "power-law return, aluminium: mean {:.1} iterations, at most {max_it}",
        it_sum as f64 / cases as f64
    );
    assert!(max_it <= 6, "max_it = {max_it}");
}
