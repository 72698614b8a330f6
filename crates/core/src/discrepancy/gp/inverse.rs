//! `K⁻¹` from the Cholesky factor of a kernel matrix: the process's most expensive step (every
//! step of the hyperparameter search, and the posterior over up to [`super::MAX_TRAINING`]
//! poses).
//!
//! Column k of `K⁻¹ = L⁻ᵀ L⁻¹` is `L⁻ᵀ (L⁻¹ e_k)`. The forward solve starts at row k (the rows
//! above stay zero) and, `K⁻¹` being symmetric, the backward solve stops at row k: the lower
//! triangle costs `2n³/3` multiply-adds instead of the `2n³` of solving every column in full,
//! and the upper triangle is its mirror. Columns are solved in parallel blocks; each entry's
//! arithmetic does not depend on the number of threads.

use nalgebra::{Cholesky, DMatrix, Dyn};
use rayon::prelude::*;

/// Columns per parallel task.
const BLOCK: usize = 16;

/// `a · b` over four running sums (which the compiler keeps in vector registers).
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut acc = [0.0f64; 4];
    let (a4, b4) = (a.chunks_exact(4), b.chunks_exact(4));
    let tail: f64 = a4
        .remainder()
        .iter()
        .zip(b4.remainder())
        .map(|(x, y)| x * y)
        .sum();
    for (x, y) in a4.zip(b4) {
        for k in 0..4 {
            acc[k] += x[k] * y[k];
        }
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

/// `K⁻¹` of the matrix whose Cholesky factorisation is `chol`.
pub(super) fn par_inverse(chol: &Cholesky<f64, Dyn>) -> DMatrix<f64> {
    let l = chol.l_dirty();
    let n = l.nrows();
    let ls = l.as_slice();
    let column = |m: usize| &ls[m * n..(m + 1) * n];
    let mut out = DMatrix::zeros(n, n);
    out.as_mut_slice()
        .par_chunks_mut(n * BLOCK)
        .enumerate()
        .for_each(|(b, cols)| {
            for (c, col) in cols.chunks_mut(n).enumerate() {
                let k = b * BLOCK + c;
                // forward: L y = e_k, rows k.. (column form)
                col[k] = 1.0;
                for m in k..n {
                    let lm = column(m);
                    let ym = col[m] / lm[m];
                    col[m] = ym;
                    for (y, &v) in col[m + 1..].iter_mut().zip(&lm[m + 1..]) {
                        *y -= v * ym;
                    }
                }
                // backward: Lᵀ x = y, rows n−1 down to k (dot form over L's column i)
                for i in (k..n).rev() {
                    let li = column(i);
                    let (head, tail) = col.split_at_mut(i + 1);
                    let dot = dot(&li[i + 1..], tail);
                    head[i] = (head[i] - dot) / li[i];
                }
            }
        });
    // the upper triangle is the lower's mirror
    for k in 0..n {
        for i in k + 1..n {
            out[(k, i)] = out[(i, k)];
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The inverse equals nalgebra's within rounding (the same solves, the zeros of `e_k` and
    /// the upper triangle skipped), is exactly symmetric, and times `K` gives the identity.
    #[test]
    fn equals_nalgebra_within_rounding() {
        for n in [1, 5, 16, 17, 100, 301] {
            let a = DMatrix::from_fn(n, n, |i, j| ((i * 7 + j * 3) % 11) as f64 / 11.0 - 0.5);
            let k = &a * a.transpose() + DMatrix::identity(n, n) * 0.1;
            let chol = k.clone().cholesky().unwrap();
            let want = chol.inverse();
            let got = par_inverse(&chol);
            let scale = want.amax();
            // backward-stable triangular solves: entries agree to a few n·ε of the largest
            let tol = 8.0 * n as f64 * f64::EPSILON * scale;
            let diff = (&got - &want).amax();
            assert!(diff <= tol, "n = {n}: {diff:e} > {tol:e}");
            assert_eq!(got, got.transpose(), "n = {n}: not symmetric");
            let residual = (&got * &k - DMatrix::identity(n, n)).amax();
            assert!(residual < 1e-8, "n = {n}: K⁻¹K − I = {residual:e}");
        }
    }
}
