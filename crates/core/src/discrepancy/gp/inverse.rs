//! `K⁻¹` from the Cholesky factor of a kernel matrix, its columns solved in parallel: the
//! process's most expensive step (every step of the hyperparameter search, and the posterior
//! over up to [`super::MAX_TRAINING`] poses). Each column is solved exactly as nalgebra's own
//! `Cholesky::inverse` solves it, so the result is the same to the bit on any number of threads.

use nalgebra::{Cholesky, DMatrix, Dyn};
use rayon::prelude::*;

/// Columns per parallel task (below this a matrix is solved in one piece).
const BLOCK: usize = 32;

/// `K⁻¹` of the matrix whose Cholesky factorisation is `chol`.
pub(super) fn par_inverse(chol: &Cholesky<f64, Dyn>) -> DMatrix<f64> {
    let n = chol.l_dirty().nrows();
    if n <= BLOCK {
        return chol.inverse();
    }
    let mut out = DMatrix::zeros(n, n);
    out.as_mut_slice()
        .par_chunks_mut(n * BLOCK)
        .enumerate()
        .for_each(|(b, cols)| {
            let first = b * BLOCK;
            let width = cols.len() / n;
            let mut block = DMatrix::zeros(n, width);
            for k in 0..width {
                block[(first + k, k)] = 1.0;
            }
            chol.solve_mut(&mut block);
            cols.copy_from_slice(block.as_slice());
        });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The parallel inverse is nalgebra's to the bit, for sizes around the block's.
    #[test]
    fn equals_nalgebra_to_the_bit() {
        for n in [5, 32, 33, 100, 301] {
            let a = DMatrix::from_fn(n, n, |i, j| ((i * 7 + j * 3) % 11) as f64 / 11.0 - 0.5);
            let k = &a * a.transpose() + DMatrix::identity(n, n) * 0.1;
            let chol = k.cholesky().unwrap();
            let want = chol.inverse();
            let got = par_inverse(&chol);
            assert!(
                want.iter()
                    .zip(got.iter())
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "n = {n}"
            );
        }
    }
}
