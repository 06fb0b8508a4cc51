//! prototype (exploration)
use gimlet::kernel::{FaceBc, Ramp, Scheme, Side};
use gimlet::material::Material;
use gimlet::shape::ShapeKind;
use gimlet::solver::{Solver, SolverConfig};

fn run(shape: ShapeKind, trac: f64, nramp: usize, nhold: usize, scheme: Scheme, flip: f64, cf: f64) {
    let h = 2e-6;
    let (l, w) = (60e-6, 40e-6);
    let mat = Material::LinearElastic { e: 170e9, nu: 0.18, rho: 2330.0 };
    let c = mat.p_wave_speed(1.0);
    let dt = cf * h / c;
    let mut cfg = SolverConfig::new([0.0, -10e-6], [120e-6, 60e-6], h);
    cfg.shape = shape; cfg.scheme = scheme; cfg.flip = flip;
    cfg.bc[Side::Left as usize] = FaceBc::Roller;
    cfg.ramp = Ramp { t_ramp: nramp as f64 * dt };
    let mut s = Solver::new(cfg).unwrap();
    s.add_material(mat).unwrap();
    s.fill_rect(0.0, 0.0, l, w, 2, 0, 0.0, 0.0, 0).unwrap();
    s.apply_traction(Side::Right, l, -1.0, 1.0, [trac, 0.0]).unwrap();
    let np = s.particles().len();
    let mut work = 0.0;
    let mut cell: Vec<i64> = s.particles().x.iter().map(|&x| (x / h).floor() as i64).collect();
    let mut cross = vec![0u32; np];
    let (mut rms_max, mut gap_max, mut ke_hold, mut mean_dev_max, mut mean_acc, mut nacc) = (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0.0, 0.0);
    let mut status = String::from("ok");
    let mut xold = vec![0.0; np];
    for step in 0..(nramp + nhold) {
        let lf = cfg.ramp.factor(s.time());
        xold.copy_from_slice(&s.particles().x);
        if let Err(e) = s.step(dt) { status = format!("failed at step {step}: {:?}", e.status); break; }
        let p = s.particles();
        for i in 0..np { work += p.fext_x[i] * lf * (p.x[i] - xold[i]); let cnew = (p.x[i] / h).floor() as i64; if cnew != cell[i] { cross[i] += 1; cell[i] = cnew; } }
        let lf1 = cfg.ramp.factor(s.time());
        let (mut n, mut sum, mut sq) = (0.0, 0.0, 0.0);
        for i in 0..np {
            if p.x0[i] > 0.1 * l && p.x0[i] < 0.9 * l {
                let pn = p.sxx[i] * p.fyy[i];
                n += 1.0; sum += pn; sq += pn * pn;
            }
        }
        let mean = sum / n; let rms = (sq / n - mean * mean).max(0.0).sqrt();
        if step >= nramp / 10 { rms_max = rms_max.max(rms / (lf1 * trac)); }
        for i in 0..np - 1 { if p.y0[i] == p.y0[i+1] { gap_max = gap_max.max(p.x[i+1] - p.x[i]); } }
        if step >= nramp { ke_hold = ke_hold.max(s.kinetic_energy()); mean_dev_max = mean_dev_max.max((mean / trac - 1.0).abs()); mean_acc += mean; nacc += 1.0; }
    }
    let p = s.particles();
    let xend = (0..np).map(|i| p.x[i] + p.lpx[i]).fold(0.0f64, f64::max);
    let en = s.kinetic_energy() + s.strain_energy();
    println!("{shape:?} {scheme:?} flip {flip} P {trac:e}: {status}; end strain {:.3}; crossings max {} mean {:.1}; rms_max {:.4}; gap_max/h {:.3}; hold: mean dev max {:.4}, avg mean/P {:.4}, KEmax/W {:.2e}; (KE+SE-W)/W {:.3e}",
        (xend - l) / l, cross.iter().max().unwrap(), cross.iter().sum::<u32>() as f64 / np as f64, rms_max, gap_max / h, mean_dev_max, mean_acc / nacc / trac, ke_hold / work, (en - work) / work);
}

#[test]
fn explore() {
    let args: Vec<f64> = std::env::var("TARGS").unwrap().split(',').map(|v| v.parse().unwrap()).collect();
    let shape = [ShapeKind::Mpm, ShapeKind::UGimp, ShapeKind::CpGimp][args[0] as usize];
    let scheme = [Scheme::Usf, Scheme::Usl, Scheme::Musl][args[1] as usize];
    run(shape, args[2], args[3] as usize, args[4] as usize, scheme, args[5], args[6]);
}
