//! Single-core speed benchmark of the single-level solver on the comparison
//! scene the peer codes run (`make bench` runs them beside it): a unit square of
//! `cells × cells` cells, a 0.5 × 0.5 Neo-Hookean block (E = 1e4, ν = 0.3,
//! ρ = 1) starting 5 cells above the floor at v = (0, −1), gravity
//! (0, −9.8), `ppc` particles per cell, Δt = 0.3 Δx / c with c the P-wave
//! speed, f64, fixed faces.
//!
//! ```text
//! gimlet-bench [--cells 512] [--ppc 4] [--steps 200] [--warmup 10]
//!              [--scheme usl|musl|usf[,...]] [--shape ugimp|cpgimp|mpm[,...]]
//!              [--transfer flip|apic[,...]]
//!              [--runs 3] [--sort N] [--no-fuse] [--bc bottom|all]
//!              [--dump FILE] [--isa baseline|avx2|avx512]
//!              [--material neo-hookean|linear|j2|j2-power|j2-elastic]
//!              [--shear RATE]
//! ```
//!
//! For each configuration (every scheme × shape × transfer listed) it builds the scene
//! `runs` times, takes `warmup` untimed steps, then times `steps` steps, and
//! prints the median particle-steps per second (per second of this thread's
//! CPU time, which other processes on a shared machine do not inflate, and
//! per wall-clock second), the time split by phase
//! (P2G, grid update, G2P with the stress update, fused G2P+P2G passes,
//! sorting) of the median run, and one JSON line. `--dump` writes the final
//! particle state of the last run (ids, positions, velocities, F, stress as
//! little-endian f64) so that two builds can be compared bit for bit.
//! `--isa` caps the instruction set of the particle loops (default: the
//! best this CPU has; see `gimlet::kernel::isa`), to time them side by side.
//! `--material` swaps the block's law (same E, ν, ρ; default Neo-Hookean,
//! the peers' law): `linear` is the hypo-elastic Jaumann law; `j2` is J2
//! plasticity on it with linear hardening (σ_y = 20 = E/500, h = E/100:
//! the impact on the floor, about ρ c v = 116, yields the lower part of the
//! block), `j2-power` the same with power-law hardening (σ_0 = 20, n = 0.1,
//! ε_0 = σ_0/E), and `j2-elastic` J2 with a yield stress never reached (the
//! cost of the elastic trial and the yield check alone). The J2 runs print
//! the share of particles that have yielded. The falling block does not
//! deform (it reaches the floor after ~2000 steps at 512 cells), so a law
//! that yields needs `--shear RATE`: the block starts with the isochoric
//! velocity field `v = (0, −1) + RATE (x − 0.5, −(y − y_c))` about its
//! centre, which at 100/s yields every J2 particle within the warm-up and
//! keeps them flowing (compare the laws on that scene).

use gimlet::kernel::isa::{self, Isa};
use gimlet::kernel::{thread_cpu_seconds, FaceBc, PhaseTimes, Scheme, Transfer};
use gimlet::material::{neo_hookean_stress, Hardening, Material, Tensor2};
use gimlet::shape::ShapeKind;
use gimlet_validate::scenes::flip_run;
use gimlet_validate::solver::{Domain, Fill, Solver};
use std::io::Write;
use std::process::ExitCode;
use std::time::Instant;

struct Args {
    cells: i64,
    ppc: u32,
    steps: u64,
    warmup: u64,
    schemes: Vec<Scheme>,
    shapes: Vec<ShapeKind>,
    transfers: Vec<Transfer>,
    runs: usize,
    sort: Option<u64>,
    fuse: bool,
    all_fixed: bool,
    dump: Option<String>,
    isa: Isa,
    material: Material,
    shear: f64,
}

fn usage() -> String {
    "usage: gimlet-bench [--cells 512] [--ppc 4] [--steps 200] [--warmup 10] \
     [--scheme usl|musl|usf[,...]] [--shape ugimp|cpgimp|mpm[,...]] \
     [--transfer flip|apic[,...]] [--runs 3] \
     [--sort N] [--no-fuse] [--bc bottom|all] [--dump FILE] [--isa baseline|avx2|avx512] \
     [--material neo-hookean|linear|j2|j2-power|j2-elastic] [--shear RATE]"
        .to_string()
}

fn parse_args() -> Result<Args, String> {
    let mut a = Args {
        cells: 512,
        ppc: 4,
        steps: 200,
        warmup: 10,
        schemes: vec![Scheme::Usl],
        shapes: vec![ShapeKind::UGimp],
        transfers: vec![Transfer::Flip],
        runs: 3,
        sort: None,
        fuse: true,
        all_fixed: true,
        dump: None,
        isa: Isa::Avx512,
        material: MAT,
        shear: 0.0,
    };
    let argv: Vec<String> = std::env::args().skip(1).collect();
    let mut i = 0;
    while i < argv.len() {
        let key = argv[i].as_str();
        let flag_only = matches!(key, "--no-fuse" | "-h" | "--help");
        let val = if flag_only {
            ""
        } else {
            i += 1;
            argv.get(i)
                .map(String::as_str)
                .ok_or_else(|| format!("{key} needs a value; {}", usage()))?
        };
        let num = |v: &str| -> Result<u64, String> {
            v.parse::<u64>()
                .map_err(|_| format!("{key} = {v} must be a non-negative integer"))
        };
        match key {
            "--cells" => a.cells = num(val)? as i64,
            "--ppc" => a.ppc = num(val)? as u32,
            "--steps" => a.steps = num(val)?,
            "--warmup" => a.warmup = num(val)?,
            "--runs" => a.runs = num(val)? as usize,
            "--sort" => a.sort = Some(num(val)?),
            "--no-fuse" => a.fuse = false,
            "--dump" => a.dump = Some(val.to_string()),
            "--isa" => {
                a.isa = match val {
                    "baseline" => Isa::Base,
                    "avx2" => Isa::Avx2,
                    "avx512" => Isa::Avx512,
                    _ => return Err(format!("--isa = {val} must be baseline, avx2 or avx512")),
                }
            }
            "--shear" => {
                a.shear = val
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite() && *v >= 0.0)
                    .ok_or_else(|| format!("--shear = {val} must be a finite rate >= 0"))?
            }
            "--material" => {
                a.material = match val {
                    "neo-hookean" => MAT,
                    "linear" => LINEAR,
                    "j2" => j2(Hardening::Linear {
                        sigma_y: 20.0,
                        h: 100.0,
                    }),
                    "j2-power" => j2(Hardening::Power {
                        sigma_0: 20.0,
                        n: 0.1,
                        eps_0: 20.0 / 1.0e4,
                    }),
                    "j2-elastic" => j2(Hardening::Linear {
                        sigma_y: 1.0e12,
                        h: 0.0,
                    }),
                    _ => {
                        return Err(format!(
                    "--material = {val} must be neo-hookean, linear, j2, j2-power or j2-elastic"
                ))
                    }
                }
            }
            "--bc" => {
                a.all_fixed = match val {
                    "all" => true,
                    "bottom" => false,
                    _ => return Err(format!("--bc = {val} must be bottom or all")),
                }
            }
            "--scheme" => {
                a.schemes = val
                    .split(',')
                    .map(|s| match s {
                        "usl" => Ok(Scheme::Usl),
                        "musl" => Ok(Scheme::Musl),
                        "usf" => Ok(Scheme::Usf),
                        _ => Err(format!("--scheme {s} must be usl, musl or usf")),
                    })
                    .collect::<Result<_, _>>()?
            }
            "--shape" => {
                a.shapes = val
                    .split(',')
                    .map(|s| match s {
                        "ugimp" => Ok(ShapeKind::UGimp),
                        "cpgimp" => Ok(ShapeKind::CpGimp),
                        "mpm" => Ok(ShapeKind::Mpm),
                        _ => Err(format!("--shape {s} must be ugimp, cpgimp or mpm")),
                    })
                    .collect::<Result<_, _>>()?
            }
            "--transfer" => {
                a.transfers = val
                    .split(',')
                    .map(|s| match s {
                        "flip" => Ok(Transfer::Flip),
                        "apic" => Ok(Transfer::Apic),
                        _ => Err(format!("--transfer {s} must be flip or apic")),
                    })
                    .collect::<Result<_, _>>()?
            }
            "-h" | "--help" => return Err(usage()),
            _ => return Err(format!("unknown argument {key}; {}", usage())),
        }
        i += 1;
    }
    let side = (a.ppc as f64).sqrt().round() as u32;
    if side * side != a.ppc || !(1..=16).contains(&side) {
        return Err(format!(
            "--ppc = {} must be a square n² with 1 <= n <= 16",
            a.ppc
        ));
    }
    if a.cells < 16 || a.cells > 1 << 14 {
        return Err(format!("--cells = {} must lie in [16, 16384]", a.cells));
    }
    if a.runs == 0 || a.steps == 0 {
        return Err("--runs and --steps must be >= 1".to_string());
    }
    Ok(a)
}

const MAT: Material = Material::NeoHookean {
    e: 1.0e4,
    nu: 0.3,
    rho: 1.0,
};

/// The hypo-elastic law with the same constants.
const LINEAR: Material = Material::LinearElastic {
    e: 1.0e4,
    nu: 0.3,
    rho: 1.0,
};

/// J2 plasticity with the same elastic constants.
fn j2(hardening: Hardening) -> Material {
    Material::J2 {
        e: 1.0e4,
        nu: 0.3,
        rho: 1.0,
        hardening,
    }
}

/// A configuration: scheme, weights, transfer.
type Config = (Scheme, ShapeKind, Transfer);

/// The comparison scene with the given configuration.
fn scene(a: &Args, (scheme, shape, transfer): Config) -> Result<(Solver, f64), String> {
    let h = 1.0 / a.cells as f64;
    let dom = Domain::new([0.0, 0.0], [1.0, 1.0], h);
    let mut cfg = flip_run(ShapeKind::UGimp, Scheme::Musl);
    cfg.scheme = scheme;
    cfg.shape = shape;
    cfg.transfer = transfer;
    cfg.gravity = [0.0, -9.8];
    cfg.cfl = 1.0;
    cfg.bc = if a.all_fixed {
        [FaceBc::Fixed; 4]
    } else {
        [FaceBc::Free, FaceBc::Free, FaceBc::Fixed, FaceBc::Free]
    };
    let mut s = Solver::new(dom, cfg).map_err(|e| e.msg)?;
    let m = s.add_material(a.material).map_err(|e| e.msg)?;
    let side = (a.ppc as f64).sqrt().round() as u32;
    let y0 = 5.0 * h;
    s.fill_rect(&Fill {
        velocity: [0.0, -1.0],
        ..Fill::new([0.25, y0, 0.75, y0 + 0.5], side, m)
    })
    .map_err(|e| e.msg)?;
    if a.shear > 0.0 {
        let yc = y0 + 0.25;
        let p = s.particles_mut();
        for i in 0..p.len() {
            p.vx[i] = a.shear * (p.x[i] - 0.5);
            p.vy[i] = -1.0 - a.shear * (p.y[i] - yc);
        }
    }
    s.set_sort_interval(a.sort);
    s.set_fused_passes(a.fuse);
    let dt = 0.3 * h / a.material.p_wave_speed(1.0);
    Ok((s, dt))
}

struct RunResult {
    /// Wall time of the timed steps.
    wall: f64,
    /// CPU time of this thread over the timed steps.
    seconds: f64,
    times: PhaseTimes,
}

fn one_run(a: &Args, cfg: Config) -> Result<(RunResult, Solver), String> {
    let (mut s, dt) = scene(a, cfg)?;
    for _ in 0..a.warmup {
        s.step(dt).map_err(|e| e.msg)?;
    }
    s.set_phase_timing(true);
    let t0 = Instant::now();
    let c0 = thread_cpu_seconds();
    for _ in 0..a.steps {
        s.step(dt).map_err(|e| e.msg)?;
    }
    let seconds = thread_cpu_seconds() - c0;
    let wall = t0.elapsed().as_secs_f64();
    let times = s.phase_times().unwrap_or_default();
    Ok((
        RunResult {
            wall,
            seconds,
            times,
        },
        s,
    ))
}

/// Time of the stress update alone over the particles of `s` (F update by
/// a small velocity gradient, the stress, and the wave speed), per
/// particle: the arithmetic share of the stress in the G2P pass. The
/// Neo-Hookean stress from F; the other laws through
/// [`gimlet::material::MatParams::update_stress`] from the particles'
/// stresses (and plastic strains).
fn stress_only_seconds_per_particle(s: &Solver, mat: &Material) -> f64 {
    if !matches!(mat, Material::NeoHookean { .. }) {
        return hypo_stress_only_seconds_per_particle(s, mat);
    }
    let p = s.particles();
    let n = p.len();
    let mp = MAT.params();
    let (mut fxx, mut fxy, mut fyx, mut fyy) =
        (p.fxx.clone(), p.fxy.clone(), p.fyx.clone(), p.fyy.clone());
    let (mut sxx, mut syy, mut sxy, mut szz) =
        (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let reps = 5;
    let t0 = thread_cpu_seconds();
    let mut cmin = f64::INFINITY;
    for r in 0..reps {
        let l = std::hint::black_box(1e-6 * (r as f64 + 1.0));
        for k in 0..n {
            let f = Tensor2 {
                xx: fxx[k] * (1.0 + l),
                xy: fxy[k] + l * fyy[k],
                yx: fyx[k],
                yy: fyy[k] * (1.0 - l),
            };
            let st = neo_hookean_stress(mp.lambda, mp.mu, &f);
            cmin = cmin.min(mp.p_wave_speed(f.det()));
            fxx[k] = f.xx;
            fxy[k] = f.xy;
            fyx[k] = f.yx;
            fyy[k] = f.yy;
            sxx[k] = st.xx;
            syy[k] = st.yy;
            sxy[k] = st.xy;
            szz[k] = st.zz;
        }
    }
    let t = thread_cpu_seconds() - t0;
    std::hint::black_box((&sxx, &syy, &sxy, &szz, cmin));
    t / (reps * n) as f64
}

/// [`stress_only_seconds_per_particle`] for the rate laws.
fn hypo_stress_only_seconds_per_particle(s: &Solver, mat: &Material) -> f64 {
    let p = s.particles();
    let n = p.len();
    let mp = mat.params();
    let (mut sxx, mut syy, mut sxy, mut szz, mut ep) = (
        p.sxx.clone(),
        p.syy.clone(),
        p.sxy.clone(),
        p.szz.clone(),
        p.eps_p.clone(),
    );
    let reps = 5;
    let t0 = thread_cpu_seconds();
    let mut cmin = f64::INFINITY;
    for r in 0..reps {
        let g = std::hint::black_box(1e-3 * (r as f64 + 1.0));
        let l = Tensor2 {
            xx: g,
            xy: 0.5 * g,
            yx: 0.2 * g,
            yy: -g,
        };
        for k in 0..n {
            let st = gimlet::material::Stress {
                xx: sxx[k],
                yy: syy[k],
                xy: sxy[k],
                zz: szz[k],
            };
            let st = mp.update_stress(st, &l, 1.0, &Tensor2::IDENTITY, &mut ep[k]);
            cmin = cmin.min(mp.p_wave_speed(1.0 + g));
            sxx[k] = st.xx;
            syy[k] = st.yy;
            sxy[k] = st.xy;
            szz[k] = st.zz;
        }
    }
    let t = thread_cpu_seconds() - t0;
    std::hint::black_box((&sxx, &syy, &sxy, &szz, &ep, cmin));
    t / (reps * n) as f64
}

fn dump(path: &str, s: &Solver) -> std::io::Result<()> {
    let p = s.particles();
    let mut out = Vec::with_capacity(p.len() * 8 * 13);
    // In id order, so that sorted and unsorted runs compare.
    let mut order: Vec<usize> = (0..p.len()).collect();
    order.sort_by_key(|&k| p.id[k]);
    for k in order {
        out.extend_from_slice(&(p.id[k] as f64).to_le_bytes());
        for v in [
            p.x[k], p.y[k], p.vx[k], p.vy[k], p.fxx[k], p.fxy[k], p.fyx[k], p.fyy[k], p.sxx[k],
            p.syy[k], p.sxy[k], p.szz[k],
        ] {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    std::fs::File::create(path)?.write_all(&out)
}

fn name_scheme(s: Scheme) -> &'static str {
    match s {
        Scheme::Usl => "usl",
        Scheme::Musl => "musl",
        Scheme::Usf => "usf",
    }
}

fn name_transfer(t: Transfer) -> &'static str {
    match t {
        Transfer::Flip => "flip",
        Transfer::Apic => "apic",
        Transfer::Xpic => "xpic",
    }
}

fn name_shape(s: ShapeKind) -> &'static str {
    match s {
        ShapeKind::Mpm => "mpm",
        ShapeKind::UGimp => "ugimp",
        ShapeKind::CpGimp => "cpgimp",
    }
}

fn run(a: &Args) -> Result<(), String> {
    isa::set_cap(a.isa);
    let configs = a.schemes.iter().flat_map(|&sc| {
        a.shapes
            .iter()
            .flat_map(move |&sh| a.transfers.iter().map(move |&tr| (sc, sh, tr)))
    });
    for cfg in configs {
        let (scheme, shape, transfer) = cfg;
        {
            let mut results = Vec::new();
            let mut last = None;
            for _ in 0..a.runs {
                let (r, s) = one_run(a, cfg)?;
                results.push(r);
                last = Some(s);
            }
            let s = last.expect("runs >= 1");
            let np = s.particles().len();
            results.sort_by(|x, y| x.seconds.total_cmp(&y.seconds));
            let med = &results[results.len() / 2];
            let rate = |r: &RunResult| np as f64 * a.steps as f64 / r.seconds;
            let rates: Vec<f64> = results.iter().map(rate).collect();
            let mut walls: Vec<f64> = results
                .iter()
                .map(|r| np as f64 * a.steps as f64 / r.wall)
                .collect();
            walls.sort_by(f64::total_cmp);
            let wall_rate = walls[walls.len() / 2];
            let t = med.times;
            let per = |v: f64| 1e9 * v / (np as f64 * a.steps as f64);
            let stress_ns = 1e9 * stress_only_seconds_per_particle(&s, &a.material);
            let yielded = s.particles().eps_p.iter().filter(|&&e| e > 0.0).count();
            let ymin = s.particles().y.iter().fold(f64::INFINITY, |m, &v| m.min(v));
            let finite = s
                .particles()
                .x
                .iter()
                .chain(&s.particles().y)
                .all(|v| v.is_finite());
            println!(
                "{} / {} / {} ({}): {} particles, {} steps, median {:.3} M particle-steps/s per CPU second, {:.3} M per wall second (runs, CPU: {})",
                name_shape(shape),
                name_scheme(scheme),
                name_transfer(transfer),
                isa::active().name(),
                np,
                a.steps,
                rate(med) / 1e6,
                wall_rate / 1e6,
                rates
                    .iter()
                    .map(|r| format!("{:.3}", r / 1e6))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
            println!(
                "  ns per particle-step: p2g {:.1}, grid {:.1}, g2p+stress {:.1}, fused middle {:.1}, fused last {:.1}, sort {:.1}, total {:.1} (stress alone ~{:.1})",
                per(t.p2g),
                per(t.grid),
                per(t.g2p),
                per(t.mid),
                per(t.fused),
                per(t.sort),
                per(med.seconds),
                stress_ns
            );
            if matches!(a.material, Material::J2 { .. }) {
                println!(
                    "  J2: {yielded} of {np} particles ({:.1} %) have yielded",
                    100.0 * yielded as f64 / np as f64
                );
            }
            println!(
                "{{\"impl\":\"gimlet\",\"shape\":\"{}\",\"scheme\":\"{}\",\"transfer\":\"{}\",\"isa\":\"{}\",\"fp\":\"f64\",\"threads\":1,\"n_grid\":{},\"ppc\":{},\"particles\":{},\"steps\":{},\"runs\":{},\"sort\":{},\"fused\":{},\"cpu_s\":{:.4},\"pstep_per_s\":{:.0},\"pstep_per_wall_s\":{:.0},\"p2g_s\":{:.4},\"grid_s\":{:.4},\"g2p_s\":{:.4},\"mid_s\":{:.4},\"fused_s\":{:.4},\"sort_s\":{:.4},\"stress_ns_per_particle\":{:.2},\"finite\":{},\"ymin\":{}}}",
                name_shape(shape),
                name_scheme(scheme),
                name_transfer(transfer),
                isa::active().name(),
                a.cells,
                a.ppc,
                np,
                a.steps,
                a.runs,
                a.sort.map_or("null".to_string(), |v| v.to_string()),
                a.fuse,
                med.seconds,
                rate(med),
                wall_rate,
                t.p2g,
                t.grid,
                t.g2p,
                t.mid,
                t.fused,
                t.sort,
                stress_ns,
                finite,
                ymin
            );
            if let Some(path) = &a.dump {
                dump(path, &s).map_err(|e| format!("cannot write {path}: {e}"))?;
            }
        }
    }
    Ok(())
}

fn main() -> ExitCode {
    let a = match parse_args() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::from(2);
        }
    };
    match run(&a) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("gimlet-bench: {e}");
            ExitCode::FAILURE
        }
    }
}
