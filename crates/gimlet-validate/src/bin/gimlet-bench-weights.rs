//! Micro-benchmark of the 1D weight functions as the kernel evaluates them:
//! blocks of 8 particles, one lane loop per block whose body is the scalar
//! weight function, results stored as structure-of-arrays (as
//! `kernel::block` does). It compares the plane weights
//! (`GimpShape`, `MpmShape`: weight and slope per node) with the
//! r-weighted ones of the axisymmetric mode (`AxiGimpShape`,
//! `AxiMpmShape`: weight, gradient and hoop weight per node).
//!
//! ```text
//! gimlet-bench-weights [--shape gimp|axi-gimp|mpm|axi-mpm|all] [--particles 65536]
//!                      [--passes 200] [--runs 7] [--isa baseline|best]
//! ```
//!
//! `--isa best` runs the loops compiled for AVX-512, else AVX2, whichever
//! the CPU has (as the kernel's dispatch does), `baseline` the SSE2 build.
//! With `--shape all` it times the four in turn, `runs` times interleaved,
//! and prints the median nanoseconds per particle (one axis) of this
//! thread's CPU time and the ratios axi/plane. With one shape it runs that
//! alone (for `valgrind --tool=callgrind`: the instructions per evaluation
//! are the difference of two runs with different `--passes`, divided by
//! the difference of their evaluations).

use gimlet::kernel::thread_cpu_seconds;
use gimlet::shape::{AxiGimpShape, AxiMpmShape, AxiShape1D, GimpShape, MpmShape, Shape1D};
use std::hint::black_box;
use std::process::ExitCode;

const LANES: usize = 8;

/// Stored results of one block: three arrays of three nodes, and the
/// first nodes.
#[derive(Clone, Copy)]
#[repr(align(64))]
struct Out {
    a: [[f64; LANES]; 3],
    b: [[f64; LANES]; 3],
    c: [[f64; LANES]; 3],
    base: [f64; LANES],
}

/// One block of plane weights, written as `kernel::block` writes its lane
/// loop (positions from a grid origin and `1/h`, SoA stores).
#[inline(always)]
fn plane_block<S: Shape1D>(x: &[f64; LANES], l: &[f64; LANES], out: &mut Out) {
    let (o, inv_h) = (0.0, 1.0);
    for k in 0..LANES {
        let xi = (x[k] - o) * inv_h;
        let w = S::eval_f(xi, l[k] * inv_h);
        out.base[k] = w.base;
        for a in 0..3 {
            out.a[a][k] = w.w[a];
            out.b[a][k] = w.g[a];
        }
    }
}

/// One block of r-weighted weights (weight, gradient, hoop weight).
#[inline(always)]
fn axi_block<S: AxiShape1D>(x: &[f64; LANES], l: &[f64; LANES], out: &mut Out) {
    let (o, inv_h, rho0) = (0.0, 1.0, 0.0);
    for k in 0..LANES {
        let xi = (x[k] - o) * inv_h;
        let w = S::eval_f(xi, l[k] * inv_h, rho0);
        out.base[k] = w.base;
        for a in 0..3 {
            out.a[a][k] = w.s[a];
            out.b[a][k] = w.g[a];
            out.c[a][k] = w.t[a];
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Which {
    Gimp,
    AxiGimp,
    Mpm,
    AxiMpm,
}

/// `n` passes over the particles, block by block, with the block function
/// `f`; returns a checksum of the stores.
#[inline(always)]
fn passes_with(
    f: impl Fn(&[f64; LANES], &[f64; LANES], &mut Out),
    xi: &[f64],
    li: &[f64],
    n: usize,
) -> f64 {
    let mut out = Out {
        a: [[0.0; LANES]; 3],
        b: [[0.0; LANES]; 3],
        c: [[0.0; LANES]; 3],
        base: [0.0; LANES],
    };
    let mut acc = 0.0;
    for _ in 0..n {
        for (x, l) in black_box(xi)
            .chunks_exact(LANES)
            .zip(black_box(li).chunks_exact(LANES))
        {
            let (x, l): (&[f64; LANES], &[f64; LANES]) =
                (x.try_into().unwrap(), l.try_into().unwrap());
            f(x, l, &mut out);
            let o = black_box(&out);
            acc += o.a[1][0] + o.b[2][LANES - 1] + o.c[0][2] + o.base[3];
        }
    }
    acc
}

macro_rules! passes_fn {
    ($name:ident $(, $feat:literal)?) => {
        $(#[target_feature(enable = $feat)])?
        #[allow(unused_unsafe)]
        unsafe fn $name(which: Which, xi: &[f64], li: &[f64], n: usize) -> f64 {
            match which {
                Which::Gimp => passes_with(plane_block::<GimpShape>, xi, li, n),
                Which::AxiGimp => passes_with(axi_block::<AxiGimpShape>, xi, li, n),
                Which::Mpm => passes_with(plane_block::<MpmShape>, xi, li, n),
                Which::AxiMpm => passes_with(axi_block::<AxiMpmShape>, xi, li, n),
            }
        }
    };
}

passes_fn!(passes_baseline);
#[cfg(target_arch = "x86_64")]
passes_fn!(
    passes_avx512,
    "avx512f,avx512dq,avx512vl,avx2,fma,bmi1,bmi2,lzcnt,popcnt"
);

#[cfg(target_arch = "x86_64")]
passes_fn!(passes_avx2, "avx2,fma,bmi1,bmi2,lzcnt,popcnt");

fn run(which: Which, xi: &[f64], li: &[f64], n: usize, best: bool) -> f64 {
    #[cfg(target_arch = "x86_64")]
    if best
        && std::arch::is_x86_feature_detected!("avx512f")
        && std::arch::is_x86_feature_detected!("avx512dq")
        && std::arch::is_x86_feature_detected!("avx512vl")
        && std::arch::is_x86_feature_detected!("avx2")
        && std::arch::is_x86_feature_detected!("fma")
    {
        // SAFETY: the features were detected above (the bit-manipulation
        // ones come with them on every AVX-512 CPU; the kernel's dispatch
        // relies on the same).
        return unsafe { passes_avx512(which, xi, li, n) };
    }
    #[cfg(target_arch = "x86_64")]
    if best
        && std::arch::is_x86_feature_detected!("avx2")
        && std::arch::is_x86_feature_detected!("fma")
    {
        // SAFETY: as above, for AVX2 (what valgrind's CPU offers).
        return unsafe { passes_avx2(which, xi, li, n) };
    }
    let _ = best;
    // SAFETY: no features required.
    unsafe { passes_baseline(which, xi, li, n) }
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    v[v.len() / 2]
}

fn main() -> ExitCode {
    let mut shape = "all".to_string();
    let (mut np, mut npass, mut runs, mut best) = (65536usize, 200usize, 7usize, true);
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut i = 0;
    while i < args.len() {
        let v = args.get(i + 1).cloned().unwrap_or_default();
        match args[i].as_str() {
            "--shape" => shape = v,
            "--particles" => np = v.parse().unwrap_or(0),
            "--passes" => npass = v.parse().unwrap_or(0),
            "--runs" => runs = v.parse().unwrap_or(0),
            "--isa" => best = v != "baseline",
            _ => {
                eprintln!("unknown argument {}", args[i]);
                return ExitCode::FAILURE;
            }
        }
        i += 2;
    }
    if np < LANES || npass == 0 || runs == 0 {
        eprintln!("--particles must be >= 8, --passes and --runs >= 1");
        return ExitCode::FAILURE;
    }
    // Particles spread over 200 cells from the axis (the first columns
    // included), quarter-cell half-lengths with a few smaller ones.
    let mut s = 12345u64;
    let mut rnd = || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    let li: Vec<f64> = (0..np)
        .map(|_| if rnd() < 0.8 { 0.25 } else { 0.125 })
        .collect();
    let xi: Vec<f64> = li.iter().map(|&l| l + 200.0 * rnd()).collect();
    let all = [Which::Gimp, Which::AxiGimp, Which::Mpm, Which::AxiMpm];
    let chosen: Vec<Which> = match shape.as_str() {
        "all" => all.to_vec(),
        "gimp" => vec![Which::Gimp],
        "axi-gimp" => vec![Which::AxiGimp],
        "mpm" => vec![Which::Mpm],
        "axi-mpm" => vec![Which::AxiMpm],
        _ => {
            eprintln!("--shape must be gimp, axi-gimp, mpm, axi-mpm or all");
            return ExitCode::FAILURE;
        }
    };
    if chosen.len() == 1 {
        let acc = run(chosen[0], &xi, &li, npass, best);
        println!(
            "{:?}: {} evaluations (checksum {acc:.6e})",
            chosen[0],
            npass * (np / LANES) * LANES
        );
        return ExitCode::SUCCESS;
    }
    let mut t = vec![Vec::new(); chosen.len()];
    for _ in 0..runs {
        for (k, &w) in chosen.iter().enumerate() {
            let t0 = thread_cpu_seconds();
            black_box(run(w, &xi, &li, npass, best));
            t[k].push(thread_cpu_seconds() - t0);
        }
    }
    let evals = (npass * (np / LANES) * LANES) as f64;
    let ns: Vec<f64> = t.iter_mut().map(|v| median(v) / evals * 1e9).collect();
    println!(
        "isa {}: median of {runs} interleaved runs, ns per particle-axis evaluation (thread CPU time)",
        if best { "best" } else { "baseline" }
    );
    for (k, w) in chosen.iter().enumerate() {
        println!("  {:<8} {:.3} ns", format!("{w:?}"), ns[k]);
    }
    println!(
        "  ratio AxiGimp/Gimp {:.3}, AxiMpm/Mpm {:.3}",
        ns[1] / ns[0],
        ns[3] / ns[2]
    );
    ExitCode::SUCCESS
}
