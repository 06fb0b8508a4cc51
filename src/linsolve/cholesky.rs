//! Envelope (profile, "skyline") Cholesky factorisation `B = L Lᵀ` of a
//! symmetric positive definite matrix, and the two triangular solves.
//!
//! Row `i` of `L` is stored from its first non-zero column `first[i]` of `B`
//! to the diagonal, contiguously: the factor's non-zeros stay inside that
//! envelope (the classical profile property), so nothing outside it is ever
//! stored or touched. With `first[i] = 0` for every row this is the plain
//! dense Cholesky; for the contact matrices, whose rows couple only
//! particles that share grid nodes, the envelope after a reverse
//! Cuthill–McKee ordering (`ordering.rs`) is a narrow band, and the cost
//! drops from `m³/3` to about `m·b²/2` multiply-adds (`b` the band width).
//!
//! The factorisation is row-oriented (Cholesky–Banachiewicz): entry
//! `L[i][j]` is `B[i][j]` minus the dot product of rows `i` and `j` of `L`
//! over their common envelope, two contiguous slices, so the inner loop is
//! a unit-stride dot product. The back substitution runs by rows of `L`
//! too. Every rank that calls this with the same input gets bitwise the same
//! output: the redundant direct path needs no communication.

/// A pivot that shows the matrix is not (numerically) positive definite.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NotPositiveDefinite {
    /// Row (`0..m`, in the factor's ordering) where the factorisation stopped.
    pub row: usize,
    /// The pivot `B[k][k] - Σ L[k][j]²` found there.
    pub pivot: f64,
    /// The original diagonal entry `B[k][k]`.
    pub diagonal: f64,
}

/// A pivot is accepted when it exceeds this multiple of the original diagonal
/// entry: below it the row is, to working precision, a combination of the
/// previous rows (the rounding error of the pivot itself is a few `ε·B[k][k]`,
/// so a smaller pivot carries no correct digit).
pub const PIVOT_REL_TOL: f64 = 4.0 * f64::EPSILON;

/// An envelope Cholesky factor; reusable (its buffers grow, never shrink).
#[derive(Clone, Debug, Default)]
pub struct ProfileCholesky {
    m: usize,
    /// First stored column of each row.
    first: Vec<usize>,
    /// Start of each row in `vals` (`m + 1` entries).
    off: Vec<usize>,
    /// The rows, each from `first[i]` to the diagonal.
    vals: Vec<f64>,
    /// `1 / L[i][i]`.
    inv_diag: Vec<f64>,
}

impl ProfileCholesky {
    /// An empty factor.
    pub fn new() -> ProfileCholesky {
        ProfileCholesky::default()
    }

    /// Sets the shape for an `m × m` matrix whose row `i` has its first
    /// non-zero (lower triangle) in column `first[i] ≤ i`, and zeroes the
    /// envelope. Then fill it with [`set`](Self::set) and call
    /// [`factor`](Self::factor).
    pub fn reset(&mut self, first: &[usize]) {
        let m = first.len();
        self.m = m;
        self.first.clear();
        self.first.extend_from_slice(first);
        self.off.clear();
        self.off.push(0);
        let mut total = 0usize;
        for (i, &f) in first.iter().enumerate() {
            assert!(
                f <= i,
                "envelope: first[{i}] = {f} lies right of the diagonal"
            );
            total += i - f + 1;
            self.off.push(total);
        }
        self.vals.clear();
        self.vals.resize(total, 0.0);
        self.inv_diag.clear();
        self.inv_diag.resize(m, 0.0);
    }

    /// Number of stored entries (the envelope's size).
    pub fn envelope(&self) -> usize {
        self.vals.len()
    }

    /// Multiply-adds of the factorisation: `Σ_i Σ_{j ∈ env(i)} |env(i) ∩ env(j)|`,
    /// bounded here by `Σ_i len(i)² / 2`.
    pub fn flops_estimate(first: &[usize]) -> f64 {
        first
            .iter()
            .enumerate()
            .map(|(i, &f)| {
                let l = (i - f + 1) as f64;
                0.5 * l * l
            })
            .sum()
    }

    /// Sets `B[i][j]` (`j ≤ i`, inside the envelope).
    #[inline]
    pub fn set(&mut self, i: usize, j: usize, v: f64) {
        debug_assert!(j <= i && j >= self.first[i]);
        self.vals[self.off[i] + (j - self.first[i])] = v;
    }

    /// Factors in place. Fails, leaving the factor unusable, when a pivot is
    /// not above [`PIVOT_REL_TOL`] times its diagonal entry (or is not
    /// finite).
    pub fn factor(&mut self) -> Result<(), NotPositiveDefinite> {
        for i in 0..self.m {
            let fi = self.first[i];
            let (done, rest) = self.vals.split_at_mut(self.off[i]);
            let row_i = &mut rest[..i - fi + 1];
            for j in fi..i {
                let fj = self.first[j];
                let k0 = fi.max(fj);
                let row_j = &done[self.off[j]..self.off[j + 1]];
                let s = row_i[j - fi] - dot(&row_i[k0 - fi..j - fi], &row_j[k0 - fj..j - fj]);
                row_i[j - fi] = s * self.inv_diag[j];
            }
            let diagonal = row_i[i - fi];
            let head = &row_i[..i - fi];
            let pivot = diagonal - dot(head, head);
            if pivot.is_nan() || pivot <= PIVOT_REL_TOL * diagonal || pivot.is_infinite() {
                return Err(NotPositiveDefinite {
                    row: i,
                    pivot,
                    diagonal,
                });
            }
            let l = pivot.sqrt();
            row_i[i - fi] = l;
            self.inv_diag[i] = 1.0 / l;
        }
        Ok(())
    }

    /// Solves `L Lᵀ x = b` in place (`b` in, `x` out).
    pub fn solve(&self, b: &mut [f64]) {
        let m = self.m;
        assert!(b.len() >= m);
        // L y = b, by rows.
        for i in 0..m {
            let fi = self.first[i];
            let row = &self.vals[self.off[i]..self.off[i + 1] - 1];
            let s = b[i] - dot(row, &b[fi..i]);
            b[i] = s * self.inv_diag[i];
        }
        // Lᵀ x = y: x_i is final once the rows below have been eliminated;
        // then row i of L updates the entries of its envelope.
        for i in (0..m).rev() {
            let fi = self.first[i];
            let xi = b[i] * self.inv_diag[i];
            b[i] = xi;
            let row = &self.vals[self.off[i]..self.off[i + 1] - 1];
            for (bk, &lik) in b[fi..i].iter_mut().zip(row) {
                *bk -= lik * xi;
            }
        }
    }
}

/// Unit-stride dot product with four independent accumulators (lets the
/// compiler keep several multiply-adds in flight without reassociating a
/// single sum; the result depends only on the inputs, not on the caller).
#[inline]
fn dot(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len().min(y.len());
    let (x, y) = (&x[..n], &y[..n]);
    let mut acc = [0.0f64; 4];
    let chunks = n / 4;
    for c in 0..chunks {
        let k = 4 * c;
        acc[0] += x[k] * y[k];
        acc[1] += x[k + 1] * y[k + 1];
        acc[2] += x[k + 2] * y[k + 2];
        acc[3] += x[k + 3] * y[k + 3];
    }
    let mut s = (acc[0] + acc[2]) + (acc[1] + acc[3]);
    for k in 4 * chunks..n {
        s += x[k] * y[k];
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Loads a dense row-major matrix with a full (dense) envelope.
    fn dense_factor(a: &[f64], m: usize) -> ProfileCholesky {
        let mut c = ProfileCholesky::new();
        c.reset(&vec![0; m]);
        for i in 0..m {
            for j in 0..=i {
                c.set(i, j, a[i * m + j]);
            }
        }
        c
    }

    /// A = B Bᵀ + I with B the 5×5 matrix of small integers below, b = A x*
    /// for x* = (1, -2, 3, -4, 5); the solve must return x* to a few ulps
    /// (cond(A) ≈ 150 here).
    #[test]
    fn cholesky_solves_a_known_spd_system() {
        let bm = [
            [2.0, 1.0, 0.0, 0.0, 1.0],
            [0.0, 3.0, 1.0, 0.0, 0.0],
            [1.0, 0.0, 2.0, 1.0, 0.0],
            [0.0, 1.0, 0.0, 4.0, 1.0],
            [1.0, 0.0, 0.0, 1.0, 2.0],
        ];
        let m = 5;
        let mut a = vec![0.0; m * m];
        for i in 0..m {
            for j in 0..m {
                let s: f64 = (0..m).map(|k| bm[i][k] * bm[j][k]).sum();
                a[i * m + j] = s + if i == j { 1.0 } else { 0.0 };
            }
        }
        let xs = [1.0, -2.0, 3.0, -4.0, 5.0];
        let mut b: Vec<f64> = (0..m)
            .map(|i| (0..m).map(|j| a[i * m + j] * xs[j]).sum())
            .collect();
        let mut c = dense_factor(&a, m);
        c.factor().expect("SPD");
        // L Lᵀ reproduces A (lower triangle) to rounding.
        let l = |i: usize, j: usize| c.vals[c.off[i] + j];
        for i in 0..m {
            for j in 0..=i {
                let s: f64 = (0..=j).map(|k| l(i, k) * l(j, k)).sum();
                assert!(
                    (s - a[i * m + j]).abs() <= 1e-13 * a[i * m + i],
                    "LLᵀ[{i}][{j}]"
                );
            }
        }
        c.solve(&mut b);
        for (k, (&x, &e)) in b.iter().zip(&xs).enumerate() {
            assert!((x - e).abs() <= 1e-13, "x[{k}] = {x}, exact {e}");
        }
    }

    /// The 1D Laplacian tridiag(-1, 2, -1) of size m has the closed-form
    /// inverse (A⁻¹)_{ij} = min(i,j)(m+1-max(i,j))/(m+1) (1-based): the
    /// solve of A x = e_k must return that column, to cond(A)·ε ≈ 4m²/π²·ε.
    /// Stored as a band (envelope of width 2) and as a dense envelope: the
    /// two factorisations do the same arithmetic on the non-zeros and agree
    /// bitwise.
    #[test]
    fn cholesky_inverts_the_1d_laplacian_in_band_and_dense_storage() {
        let m = 40;
        let mut band = ProfileCholesky::new();
        let first: Vec<usize> = (0..m).map(|i: usize| i.saturating_sub(1)).collect();
        band.reset(&first);
        let mut dense = ProfileCholesky::new();
        dense.reset(&vec![0; m]);
        for i in 0..m {
            for c in [&mut band, &mut dense] {
                c.set(i, i, 2.0);
                if i > 0 {
                    c.set(i, i - 1, -1.0);
                }
            }
        }
        assert_eq!(band.envelope(), 2 * m - 1);
        assert_eq!(dense.envelope(), m * (m + 1) / 2);
        band.factor().expect("SPD");
        dense.factor().expect("SPD");
        let np1 = (m + 1) as f64;
        for k in [0, 7, m / 2, m - 1] {
            let mut b = vec![0.0; m];
            b[k] = 1.0;
            let mut bd = b.clone();
            band.solve(&mut b);
            dense.solve(&mut bd);
            for (i, &x) in b.iter().enumerate() {
                let (ii, kk) = ((i + 1) as f64, (k + 1) as f64);
                let exact = ii.min(kk) * (np1 - ii.max(kk)) / np1;
                assert!(
                    (x - exact).abs() <= 1e-12 * np1,
                    "A⁻¹[{i}][{k}] = {x}, exact {exact}"
                );
                assert_eq!(x.to_bits(), bd[i].to_bits(), "band and dense differ at {i}");
            }
        }
    }

    /// An arrow-shaped envelope (rows starting at different columns) checked
    /// against the dense factorisation of the same matrix: the envelope holds
    /// all of the factor's fill.
    #[test]
    fn cholesky_with_a_ragged_envelope_matches_dense() {
        let m = 12;
        let mut a = vec![0.0; m * m];
        let first = [0, 0, 1, 1, 0, 3, 5, 2, 7, 7, 4, 9];
        for i in 0..m {
            a[i * m + i] = 10.0 + i as f64;
            for j in first[i]..i {
                let v = ((i * 7 + j * 3) % 5) as f64 * 0.3 - 0.6;
                a[i * m + j] = v;
                a[j * m + i] = v;
            }
        }
        let mut p = ProfileCholesky::new();
        p.reset(&first);
        for i in 0..m {
            for j in first[i]..=i {
                p.set(i, j, a[i * m + j]);
            }
        }
        p.factor().expect("diagonally dominant");
        let mut d = dense_factor(&a, m);
        d.factor().expect("diagonally dominant");
        let xs: Vec<f64> = (0..m).map(|i| (i as f64 - 4.0) * 0.5).collect();
        let mut b: Vec<f64> = (0..m)
            .map(|i| (0..m).map(|j| a[i * m + j] * xs[j]).sum())
            .collect();
        let mut bd = b.clone();
        p.solve(&mut b);
        d.solve(&mut bd);
        for i in 0..m {
            assert!((b[i] - xs[i]).abs() <= 1e-14 * 4.0, "x[{i}] = {}", b[i]);
            assert!((b[i] - bd[i]).abs() <= 1e-15 * 4.0);
        }
    }

    /// [[1, 2], [2, 1]] has eigenvalues 3 and -1: the second pivot is
    /// 1 - 4 = -3 and the factorisation must stop there.
    #[test]
    fn cholesky_rejects_an_indefinite_matrix() {
        let mut c = dense_factor(&[1.0, 2.0, 2.0, 1.0], 2);
        let e = c.factor().unwrap_err();
        assert_eq!(e.row, 1);
        assert_eq!(e.pivot, -3.0);
        assert_eq!(e.diagonal, 1.0);
    }

    /// A singular PSD matrix (two equal rows) has a zero pivot, up to
    /// rounding: rejected by the relative pivot test, not divided by.
    #[test]
    fn cholesky_rejects_a_singular_matrix() {
        let third = 1.0 / 3.0;
        let mut c = dense_factor(&[third, third, third, third], 2);
        let e = c.factor().unwrap_err();
        assert_eq!(e.row, 1);
        assert!(e.pivot.abs() <= PIVOT_REL_TOL * third);
    }
}
