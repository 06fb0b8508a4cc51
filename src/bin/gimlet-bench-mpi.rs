//! Parallel benchmark on the comparison scene (a 0.5 × 0.5 Neo-Hookean
//! block, E = 1e4, ν = 0.3, ρ = 1, dropped at v = (0, −1) under gravity onto
//! a fixed floor in a unit box, 4 particles per cell, Δt = 0.3 Δx / c), run
//! through the distributed `Simulation` on however many ranks it is started
//! with. Prints particle-steps per second, the split of rank time into
//! compute, nodal-sum exchange and migration, and bytes sent per rank per
//! step (medians over `--runs`).
//!
//! ```text
//! mpiexec -n 2 gimlet-bench-mpi [--cells 512] [--steps 100] [--runs 3] [--patches 2x1]
//! ```

use gimlet::comm::Comm;
use gimlet::kernel::{FaceBc, Scheme};
use gimlet::material::Material;
use gimlet::sim::Simulation;
use std::time::Instant;

struct Args {
    cells: i64,
    steps: u64,
    runs: usize,
    patches: [i64; 2],
    scheme: Scheme,
}

fn parse() -> Result<Args, String> {
    let mut a = Args {
        cells: 512,
        steps: 100,
        runs: 3,
        patches: [0, 0],
        scheme: Scheme::Usl,
    };
    let v: Vec<String> = std::env::args().skip(1).collect();
    let mut i = 0;
    while i < v.len() {
        let val = v.get(i + 1).ok_or(format!("{} needs a value", v[i]))?;
        match v[i].as_str() {
            "--cells" => a.cells = val.parse().map_err(|e| format!("--cells: {e}"))?,
            "--steps" => a.steps = val.parse().map_err(|e| format!("--steps: {e}"))?,
            "--runs" => a.runs = val.parse().map_err(|e| format!("--runs: {e}"))?,
            "--patches" => {
                let p: Vec<i64> = val.split('x').filter_map(|s| s.parse().ok()).collect();
                if p.len() != 2 || p[0] < 1 || p[1] < 1 {
                    return Err("--patches takes PXxPY, e.g. 2x1".into());
                }
                a.patches = [p[0], p[1]];
            }
            "--scheme" => {
                a.scheme = match val.as_str() {
                    "usl" => Scheme::Usl,
                    "musl" => Scheme::Musl,
                    "usf" => Scheme::Usf,
                    _ => return Err("--scheme takes usl, musl or usf".into()),
                }
            }
            o => return Err(format!("unknown option {o}")),
        }
        i += 2;
    }
    Ok(a)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    v[v.len() / 2]
}

/// One run: returns (wall seconds of the stepping, particles, rank-max
/// compute, exchange, migrate seconds, rank-max bytes sent per step).
fn run(comm_world: &Comm, a: &Args) -> Result<(f64, u64, [f64; 3], f64), gimlet::error::Error> {
    let _ = comm_world;
    let comm = Comm::world()?;
    let nranks = comm.size() as i64;
    let h = 1.0 / a.cells as f64;
    let mut s = Simulation::new(comm, 0.0, 0.0, 1.0, 1.0, h)?;
    let p = if a.patches[0] > 0 {
        a.patches
    } else {
        [nranks, 1]
    };
    s.hier
        .set_patch_size(0, (a.cells + p[0] - 1) / p[0], (a.cells + p[1] - 1) / p[1])?;
    let (e, nu, rho) = (1e4, 0.3, 1.0);
    let m = s.add_material(Material::NeoHookean { e, nu, rho })? as i32;
    let mut run = s.run;
    run.bc = [FaceBc::Fixed; 4];
    run.gravity = [0.0, -9.8];
    run.scheme = a.scheme;
    run.cfl = 1.0;
    s.set_run(run)?;
    let y0 = 5.0 * h;
    s.fill_rectangle([0.25, y0, 0.75, y0 + 0.5], 2, m, rho, 0.0, -1.0)?;
    let lam = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
    let mu = e / (2.0 * (1.0 + nu));
    let c = ((lam + 2.0 * mu) / rho).sqrt();
    let dt = 0.3 * h / c;
    s.step(dt)?; // start-up: balancing, first grids
    let before = s.levels[0].stats;
    s.comm.barrier()?;
    let t0 = Instant::now();
    for _ in 0..a.steps {
        s.step(dt)?;
    }
    s.comm.barrier()?;
    let wall = t0.elapsed().as_secs_f64();
    let st = s.levels[0].stats;
    let mut split = [
        st.compute - before.compute,
        st.exchange - before.exchange,
        st.migrate - before.migrate,
    ];
    s.comm.max_f64(&mut split)?;
    let mut bytes = [(st.bytes_sent - before.bytes_sent) as f64 / a.steps as f64];
    s.comm.max_f64(&mut bytes)?;
    let (_, n) = s.counts()?;
    Ok((wall, n, split, bytes[0]))
}

fn main() {
    // SAFETY: the binary initialises MPI once and finalises it at the end.
    unsafe { mpi_sys::MPI_Init(std::ptr::null_mut(), std::ptr::null_mut()) };
    let code = {
        let world = Comm::world().expect("MPI_COMM_WORLD");
        match parse() {
            Err(e) => {
                if world.rank() == 0 {
                    eprintln!("gimlet-bench-mpi: {e}");
                }
                2
            }
            Ok(a) => {
                let mut walls = Vec::new();
                let mut splits = Vec::new();
                let mut bytes = 0.0;
                let mut n = 0;
                let mut ok = true;
                for _ in 0..a.runs {
                    match run(&world, &a) {
                        Ok((w, np, sp, b)) => {
                            walls.push(w);
                            splits.push(sp);
                            bytes = b;
                            n = np;
                        }
                        Err(e) => {
                            eprintln!("gimlet-bench-mpi: {e}");
                            ok = false;
                            break;
                        }
                    }
                }
                if ok && world.rank() == 0 {
                    let w = median(walls.clone());
                    let comp = median(splits.iter().map(|s| s[0]).collect());
                    let exch = median(splits.iter().map(|s| s[1]).collect());
                    let migr = median(splits.iter().map(|s| s[2]).collect());
                    println!(
                        "{{\"ranks\": {}, \"cells\": {}, \"particles\": {}, \"steps\": {}, \"wall_s\": {:.4}, \"particle_steps_per_s\": {:.4e}, \"compute_s\": {:.4}, \"exchange_s\": {:.4}, \"migrate_s\": {:.4}, \"bytes_sent_per_rank_per_step\": {:.0}}}",
                        world.size(),
                        a.cells,
                        n,
                        a.steps,
                        w,
                        n as f64 * a.steps as f64 / w,
                        comp,
                        exch,
                        migr,
                        bytes
                    );
                }
                if ok {
                    0
                } else {
                    1
                }
            }
        }
    };
    // SAFETY: every communicator was freed when its Comm dropped.
    unsafe { mpi_sys::MPI_Finalize() };
    std::process::exit(code);
}
