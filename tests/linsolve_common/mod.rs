//! Test problems for the contact LCP (shared by the linsolve test programs):
//! a 1D obstacle problem, a contact-like strip (particles in a row on a GIMP
//! grid, `K = Tᵀ M⁻¹ T + regularisation`), and random banded SPD matrices.
#![allow(dead_code)]

use gimlet::linsolve::SymCsr;
use gimlet::shape::{weights_2d, ShapeKind};

/// SplitMix64, seeded: reproducible problems on every rank.
pub struct Rng(pub u64);
impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [-1, 1).
    pub fn sym(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }
}

/// The 1D obstacle problem: `A = s·tridiag(-1, 2 + ε, -1)`, `r = Aψ - f`
/// with a parabolic obstacle `ψ` and a downward load `f`. cond(A) ≈ 4/ε.
pub fn obstacle(n: usize, eps: f64) -> (SymCsr, Vec<f64>) {
    let s = 250.0;
    let mut t = Vec::new();
    for i in 0..n {
        t.push((i, i, s * (2.0 + eps)));
        if i > 0 {
            t.push((i, i - 1, -s));
            t.push((i - 1, i, -s));
        }
    }
    let a = SymCsr::from_triplets(n, &t);
    let psi: Vec<f64> = (0..n)
        .map(|i| {
            let ti = (i + 1) as f64 / (n + 1) as f64;
            0.4 - 3.0 * (ti - 0.5) * (ti - 0.5)
        })
        .collect();
    let mut ax = vec![0.0; n];
    matvec(&a, &psi, &mut ax);
    let r = ax.iter().map(|v| v + 0.5).collect();
    (a, r)
}

/// A contact-like matrix: `n` particles in one row (`ppc` per cell, at the
/// same height), uGIMP weights on a unit grid, `T_iq` = weight of node `i`
/// at particle `q` times the face length `1/ppc`, lumped nodal masses `M_i`
/// varying by ±30 %, `K = Tᵀ M⁻¹ T + reg·max(diag)·I`. Particles of one row
/// touch only `n/ppc + 3` node columns, so `Tᵀ M⁻¹ T` is singular for
/// `ppc ≥ 2` and `reg` sets the conditioning, as in the contact assembly.
pub fn contact_strip(n: usize, ppc: usize, reg: f64, seed: u64) -> SymCsr {
    contact_patch(n, 1, ppc, reg, seed)
}

/// [`contact_strip`] with `rows` rows of `n / rows` particles each (a 2D
/// block of contact particles: the worst case for the envelope of the
/// direct solver, whose band then grows like the row length).
pub fn contact_patch(n: usize, rows: usize, ppc: usize, reg: f64, seed: u64) -> SymCsr {
    let mut rng = Rng(seed);
    let per_row = n.div_ceil(rows);
    let li = 0.5 / ppc as f64;
    let seg = 1.0 / ppc as f64;
    let ncols = per_row / ppc + 8;
    let nrows = rows / ppc + 12;
    let mass: Vec<f64> = (0..ncols * nrows).map(|_| 1.0 + 0.3 * rng.sym()).collect();
    // Per particle: (node id, value) of its non-zero weights.
    let mut tq: Vec<Vec<(usize, f64)>> = Vec::with_capacity(n);
    for q in 0..n {
        let (row, col) = (q / per_row, q % per_row);
        let xi = 2.0 + (col as f64 + 0.5) / ppc as f64;
        let yi = 2.0 + (row as f64 + 0.5) / ppc as f64;
        let w = weights_2d(ShapeKind::UGimp, xi, yi, li, li);
        let mut entries = Vec::new();
        for b in 0..3 {
            for a in 0..3 {
                let v = w.w[a + 3 * b];
                if v != 0.0 {
                    let ix = (w.bx + a as i64) as usize;
                    let iy = (w.by + b as i64) as usize;
                    entries.push((iy * ncols + ix, v * seg));
                }
            }
        }
        tq.push(entries);
    }
    // Particles sharing a node: within 3 cells in x and y.
    let reach = 3 * ppc;
    let mut t = Vec::new();
    for q in 0..n {
        let (rq, cq) = (q / per_row, q % per_row);
        for rp in rq.saturating_sub(reach)..(rq + reach + 1).min(rows) {
            for cp in cq.saturating_sub(reach)..(cq + reach + 1).min(per_row) {
                let p = rp * per_row + cp;
                if p >= n {
                    continue;
                }
                let mut s = 0.0;
                for &(i, a) in &tq[q] {
                    for &(j, b) in &tq[p] {
                        if i == j {
                            s += a * b / mass[i];
                        }
                    }
                }
                if s != 0.0 {
                    t.push((q, p, s));
                }
            }
        }
    }
    let mut a = SymCsr::from_triplets(n, &t);
    let dmax = (0..n).map(|i| diag(&a, i)).fold(0.0f64, f64::max);
    for i in 0..n {
        for k in a.row_ptr[i]..a.row_ptr[i + 1] {
            if a.cols[k] as usize == i {
                a.vals[k] += reg * dmax;
            }
        }
    }
    a
}

/// The right-hand side of an indenter pressed into the strip: `r_q < 0`
/// (penetration) under a cylinder of half-width `n/3` in the middle, `> 0`
/// outside, scaled like the matrix.
pub fn indenter_rhs(a: &SymCsr) -> Vec<f64> {
    let n = a.n;
    let c = n as f64 / 2.0;
    let rad = n as f64 / 3.0;
    let d0 = diag(a, n / 2);
    (0..n)
        .map(|q| {
            let u = (q as f64 + 0.5 - c) / rad;
            d0 * (0.6 * u * u - 0.3 + 0.05 * (0.37 * q as f64).sin())
        })
        .collect()
}

/// A random banded SPD matrix `BᵀB/w + δ·I` (B with half-bandwidth `w`) and
/// `r` uniform in [-1, 1).
pub fn random_banded(n: usize, w: usize, delta: f64, seed: u64) -> (SymCsr, Vec<f64>) {
    let mut rng = Rng(seed);
    let mut b = vec![vec![0.0; 2 * w + 1]; n];
    for row in b.iter_mut() {
        for v in row.iter_mut() {
            *v = rng.sym();
        }
    }
    // B[k][j] for |k - j| <= w stored at b[k][j + w - k].
    let bv = |k: usize, j: usize| -> f64 {
        if k.abs_diff(j) <= w {
            b[k][j + w - k]
        } else {
            0.0
        }
    };
    let mut t = Vec::new();
    for i in 0..n {
        for j in i.saturating_sub(2 * w)..(i + 2 * w + 1).min(n) {
            let lo = i.max(j).saturating_sub(w);
            let hi = (i.min(j) + w + 1).min(n);
            let mut s = 0.0;
            for k in lo..hi {
                s += bv(k, i) * bv(k, j);
            }
            s /= w as f64;
            if i == j {
                s += delta;
            }
            if s != 0.0 {
                t.push((i, j, s));
            }
        }
    }
    let r = (0..n).map(|_| rng.sym()).collect();
    (SymCsr::from_triplets(n, &t), r)
}

/// `y = A x`.
pub fn matvec(a: &SymCsr, x: &[f64], y: &mut [f64]) {
    for (i, yi) in y.iter_mut().enumerate().take(a.n) {
        let mut s = 0.0;
        for k in a.row_ptr[i]..a.row_ptr[i + 1] {
            s += a.vals[k] * x[a.cols[k] as usize];
        }
        *yi = s;
    }
}

/// `A_ii`.
pub fn diag(a: &SymCsr, i: usize) -> f64 {
    (a.row_ptr[i]..a.row_ptr[i + 1])
        .find(|&k| a.cols[k] as usize == i)
        .map_or(0.0, |k| a.vals[k])
}

/// Non-zeros per row (mean).
pub fn nnz_per_row(a: &SymCsr) -> f64 {
    a.cols.len() as f64 / a.n.max(1) as f64
}

/// `max_i |x_i - y_i| / max_i |y_i|`.
pub fn rel_diff(x: &[f64], y: &[f64]) -> f64 {
    let ymax = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let d = x
        .iter()
        .zip(y)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    if ymax == 0.0 {
        d
    } else {
        d / ymax
    }
}

/// The same matrix with its unknowns renumbered by a seeded random
/// permutation (`new = perm[old]`): the contact assembly may number the
/// particles in any order.
pub fn scrambled(a: &SymCsr, seed: u64) -> SymCsr {
    let n = a.n;
    let mut rng = Rng(seed);
    let mut perm: Vec<usize> = (0..n).collect();
    for i in (1..n).rev() {
        let j = (rng.next_u64() % (i as u64 + 1)) as usize;
        perm.swap(i, j);
    }
    let mut t = Vec::with_capacity(a.cols.len());
    for i in 0..n {
        for k in a.row_ptr[i]..a.row_ptr[i + 1] {
            t.push((perm[i], perm[a.cols[k] as usize], a.vals[k]));
        }
    }
    SymCsr::from_triplets(n, &t)
}
