//! The particle loops are compiled for several instruction sets and one is
//! chosen at run time (`gimlet::kernel::isa`). They must give the same bits:
//! every scheme, weight function and material law is run on a small impact
//! scene under each level this CPU has, and the particle states compared.

use gimlet::kernel::isa::{self, Isa};
use gimlet::kernel::{FaceBc, Scheme};
use gimlet::material::Material;
use gimlet::shape::ShapeKind;
use gimlet_validate::scenes::flip_run;
use gimlet_validate::solver::{Domain, Fill, Solver};

/// A block falling onto a fixed floor and a second, stiffer one beside it
/// (two materials of the same law), 30 steps; the final particle fields.
fn run(scheme: Scheme, shape: ShapeKind, neo: bool) -> Vec<Vec<f64>> {
    let h = 1.0 / 32.0;
    let dom = Domain::new([0.0, 0.0], [1.0, 1.0], h);
    let mut cfg = flip_run(ShapeKind::UGimp, Scheme::Musl);
    cfg.scheme = scheme;
    cfg.shape = shape;
    cfg.gravity = [0.0, -9.8];
    cfg.bc = [FaceBc::Fixed; 4];
    let mut s = Solver::new(dom, cfg).unwrap();
    let mats: Vec<Material> = [1.0e4, 3.0e4]
        .iter()
        .map(|&e| {
            if neo {
                Material::NeoHookean {
                    e,
                    nu: 0.3,
                    rho: 1.0,
                }
            } else {
                Material::LinearElastic {
                    e,
                    nu: 0.3,
                    rho: 1.0,
                }
            }
        })
        .collect();
    let m0 = s.add_material(mats[0]).unwrap();
    let m1 = s.add_material(mats[1]).unwrap();
    // An odd particle count (the last block of the loops is partial).
    s.fill_rect(&Fill {
        velocity: [0.5, -2.0],
        ..Fill::new([0.2, 2.0 * h, 0.45, 0.4], 2, m0)
    })
    .unwrap();
    s.fill_rect(&Fill {
        velocity: [-0.5, -1.0],
        first_id: 100_000,
        ..Fill::new([0.5, 2.0 * h, 0.5 + 3.0 * h, 0.3 + h], 3, m1)
    })
    .unwrap();
    let dt = 0.3 * h / mats[1].p_wave_speed(1.0);
    for _ in 0..30 {
        s.step(dt).unwrap();
    }
    let p = s.particles();
    vec![
        p.x.to_vec(),
        p.y.to_vec(),
        p.vx.to_vec(),
        p.vy.to_vec(),
        p.fxx.to_vec(),
        p.fxy.to_vec(),
        p.fyx.to_vec(),
        p.fyy.to_vec(),
        p.sxx.to_vec(),
        p.syy.to_vec(),
        p.sxy.to_vec(),
        p.szz.to_vec(),
        p.lpx.to_vec(),
        p.lpy.to_vec(),
    ]
}

#[test]
fn every_instruction_set_gives_the_same_bits() {
    let best = isa::detected();
    let levels: Vec<Isa> = [Isa::Base, Isa::Avx2, Isa::Avx512]
        .into_iter()
        .filter(|&l| l <= best)
        .collect();
    eprintln!("levels on this CPU: {levels:?}");
    let mut compared = 0;
    for scheme in [Scheme::Usl, Scheme::Musl, Scheme::Usf] {
        for shape in [ShapeKind::UGimp, ShapeKind::CpGimp, ShapeKind::Mpm] {
            for neo in [true, false] {
                let mut reference: Option<Vec<Vec<f64>>> = None;
                for &l in &levels {
                    isa::set_cap(l);
                    assert_eq!(isa::active(), l);
                    let r = run(scheme, shape, neo);
                    assert!(r[0].len() > 100 && r[0].len() % 8 != 0);
                    match &reference {
                        None => reference = Some(r),
                        Some(r0) => {
                            for (k, (a, b)) in r0.iter().zip(&r).enumerate() {
                                let same = a.iter().zip(b).all(|(u, v)| u.to_bits() == v.to_bits());
                                assert!(
                                    same,
                                    "{scheme:?} {shape:?} neo={neo}: field {k} differs under {l:?}"
                                );
                            }
                            compared += 1;
                        }
                    }
                }
            }
        }
    }
    isa::set_cap(Isa::Avx512);
    eprintln!("{compared} comparisons");
}
