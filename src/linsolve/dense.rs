//! Dense Cholesky factorisation `A = L Lᵀ` of a small symmetric positive
//! definite matrix, and the two triangular solves.
//!
//! This is the path for the small active sets of the contact LCP: every rank
//! runs it redundantly on its replicated copy of the matrix, so the result is
//! bitwise the same on any number of ranks and needs no communication.
//!
//! Storage is row-major `m × m` (only the lower triangle is read and
//! written). The factorisation is the row-oriented (Cholesky–Banachiewicz)
//! form: entry `L[i][j]` is `A[i][j]` minus the dot product of the first `j`
//! entries of rows `i` and `j` of `L`, two contiguous rows, so the inner loop
//! is a unit-stride dot product. The back substitution runs by columns of
//! `Lᵀ`, i.e. by rows of `L`, so it is unit-stride too. Cost: `m³/3`
//! multiply-adds for the factorisation, `m²` per solve.

/// A pivot that shows the matrix is not (numerically) positive definite.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NotPositiveDefinite {
    /// Row of the dense system (`0..m`) where the factorisation stopped.
    pub row: usize,
    /// The pivot `A[k][k] - Σ L[k][j]²` found there.
    pub pivot: f64,
    /// The original diagonal entry `A[k][k]`.
    pub diagonal: f64,
}

/// A pivot is accepted when it exceeds this multiple of the original diagonal
/// entry: below it the row is, to working precision, a combination of the
/// previous rows (the rounding error of the pivot itself is about
/// `m · ε · A[k][k]`, so a smaller pivot carries no correct digit).
pub const PIVOT_REL_TOL: f64 = 4.0 * f64::EPSILON;

/// Factors the `m × m` row-major matrix in `a` in place: on success the lower
/// triangle holds `L` with `A = L Lᵀ` (the strict upper triangle is left as
/// it was and never read), and `inv_diag[k] = 1 / L[k][k]`.
///
/// Fails, leaving `a` partly overwritten, when a pivot is not above
/// [`PIVOT_REL_TOL`] times its diagonal entry (or is not finite).
pub fn cholesky_factor(
    a: &mut [f64],
    m: usize,
    inv_diag: &mut [f64],
) -> Result<(), NotPositiveDefinite> {
    assert!(a.len() >= m * m && inv_diag.len() >= m);
    for i in 0..m {
        let (done, rest) = a.split_at_mut(i * m);
        let row_i = &mut rest[..m];
        for j in 0..i {
            let row_j = &done[j * m..j * m + j];
            let s = row_i[j] - dot(&row_i[..j], row_j);
            row_i[j] = s * inv_diag[j];
        }
        let diagonal = row_i[i];
        let pivot = diagonal - dot(&row_i[..i], &row_i[..i]);
        if !(pivot > PIVOT_REL_TOL * diagonal) || !pivot.is_finite() {
            return Err(NotPositiveDefinite {
                row: i,
                pivot,
                diagonal,
            });
        }
        let l = pivot.sqrt();
        row_i[i] = l;
        inv_diag[i] = 1.0 / l;
    }
    Ok(())
}

/// Solves `L Lᵀ x = b` in place (`b` in, `x` out) with the factor written by
/// [`cholesky_factor`].
pub fn cholesky_solve(l: &[f64], m: usize, inv_diag: &[f64], b: &mut [f64]) {
    assert!(l.len() >= m * m && inv_diag.len() >= m && b.len() >= m);
    // L y = b, by rows.
    for i in 0..m {
        let s = b[i] - dot(&l[i * m..i * m + i], &b[..i]);
        b[i] = s * inv_diag[i];
    }
    // Lᵀ x = y: x_i is final once the rows below have been eliminated; then
    // row i of L (column i of Lᵀ) updates the entries above.
    for i in (0..m).rev() {
        let xi = b[i] * inv_diag[i];
        b[i] = xi;
        let row = &l[i * m..i * m + i];
        for (bk, &lik) in b[..i].iter_mut().zip(row) {
            *bk -= lik * xi;
        }
    }
}

/// Unit-stride dot product with four independent accumulators (lets the
/// compiler keep several multiply-adds in flight without reassociating a
/// single sum).
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

    /// A = B Bᵀ + I with B the 5×5 matrix of small integers below, b = A x*
    /// for x* = (1, -2, 3, -4, 5); everything is exact in binary, so the
    /// solve must return x* to a few ulps (cond(A) ≈ 150 here).
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
        let mut inv = vec![0.0; m];
        let mut f = a.clone();
        cholesky_factor(&mut f, m, &mut inv).expect("SPD");
        // L Lᵀ reproduces A (lower triangle) to rounding.
        for i in 0..m {
            for j in 0..=i {
                let s: f64 = (0..=j).map(|k| f[i * m + k] * f[j * m + k]).sum();
                assert!(
                    (s - a[i * m + j]).abs() <= 1e-13 * a[i * m + i],
                    "LLᵀ[{i}][{j}]"
                );
            }
        }
        cholesky_solve(&f, m, &inv, &mut b);
        for (k, (&x, &e)) in b.iter().zip(&xs).enumerate() {
            assert!((x - e).abs() <= 1e-13, "x[{k}] = {x}, exact {e}");
        }
    }

    /// The 1D Laplacian tridiag(-1, 2, -1) of size m has the closed-form
    /// inverse (A⁻¹)_{ij} = min(i,j)(m+1-max(i,j))/(m+1) (1-based): the
    /// solve of A x = e_k must return that column, to cond(A)·ε ≈ 4m²/π²·ε.
    #[test]
    fn cholesky_inverts_the_1d_laplacian() {
        let m = 40;
        let mut a = vec![0.0; m * m];
        for i in 0..m {
            a[i * m + i] = 2.0;
            if i > 0 {
                a[i * m + i - 1] = -1.0;
                a[(i - 1) * m + i] = -1.0;
            }
        }
        let mut inv = vec![0.0; m];
        cholesky_factor(&mut a, m, &mut inv).expect("SPD");
        let np1 = (m + 1) as f64;
        for k in [0, 7, m / 2, m - 1] {
            let mut b = vec![0.0; m];
            b[k] = 1.0;
            cholesky_solve(&a, m, &inv, &mut b);
            for (i, &x) in b.iter().enumerate() {
                let (ii, kk) = ((i + 1) as f64, (k + 1) as f64);
                let exact = ii.min(kk) * (np1 - ii.max(kk)) / np1;
                assert!(
                    (x - exact).abs() <= 1e-12 * np1,
                    "A⁻¹[{i}][{k}] = {x}, exact {exact}"
                );
            }
        }
    }

    /// [[1, 2], [2, 1]] has eigenvalues 3 and -1: the second pivot is
    /// 1 - 4 = -3 and the factorisation must stop there.
    #[test]
    fn cholesky_rejects_an_indefinite_matrix() {
        let mut a = vec![1.0, 2.0, 2.0, 1.0];
        let mut inv = vec![0.0; 2];
        let e = cholesky_factor(&mut a, 2, &mut inv).unwrap_err();
        assert_eq!(e.row, 1);
        assert_eq!(e.pivot, -3.0);
        assert_eq!(e.diagonal, 1.0);
    }

    /// A singular PSD matrix (two equal rows) has a zero pivot, up to
    /// rounding: rejected by the relative pivot test, not divided by.
    #[test]
    fn cholesky_rejects_a_singular_matrix() {
        let third = 1.0 / 3.0;
        let mut a = vec![third, third, third, third];
        let mut inv = vec![0.0; 2];
        let e = cholesky_factor(&mut a, 2, &mut inv).unwrap_err();
        assert_eq!(e.row, 1);
        assert!(e.pivot.abs() <= PIVOT_REL_TOL * third);
    }
}
