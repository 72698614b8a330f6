//! Matrix times a block of lane vectors, the product the samplers form once per draw (`L z` of
//! a Cholesky factor, a shift `A δβ`).
//!
//! Four rows are summed at a time: their sums do not depend on each other, so the processor
//! adds them side by side instead of waiting on one row's additions in turn, which is what a
//! row-by-row loop does. Each row is still summed over its columns in column order from `+0`,
//! so a row's result has the bits of the plain sum `Σ_c m_rc x_c`; entries that are exactly zero
//! (a factor's upper triangle) add `±0`, which leaves a nonzero sum as it is.

/// `out(r, y_r)` with `y_r[l] = Σ_c m[r·cols + c] · x[c][l]` summed over `c = 0, 1, …` in
/// order, for every row `r` of the row-major `m` (`m.len() / cols` rows). With `lower` the
/// matrix is lower triangular (zero above its diagonal) and row `r`'s sum stops after column
/// `r` plus at most the three columns its group of four rows needs (zeros).
///
/// # Panics
///
/// When `x` holds fewer than `cols` vectors (or, with `lower`, fewer than the rows).
#[inline(always)]
pub(crate) fn rows_times_lanes<const L: usize>(
    m: &[f64],
    cols: usize,
    lower: bool,
    x: &[[f64; L]],
    mut out: impl FnMut(usize, &[f64; L]),
) {
    if cols == 0 {
        return;
    }
    let rows = m.len() / cols;
    let mut r0 = 0;
    while r0 + 4 <= rows {
        let end = if lower { (r0 + 4).min(cols) } else { cols };
        let row: [&[f64]; 4] = std::array::from_fn(|k| &m[(r0 + k) * cols..][..end]);
        let x = &x[..end];
        let mut acc = [[0.0; L]; 4];
        for (c, xc) in x.iter().enumerate() {
            for k in 0..4 {
                let v = row[k][c];
                for l in 0..L {
                    acc[k][l] += v * xc[l];
                }
            }
        }
        for (k, a) in acc.iter().enumerate() {
            out(r0 + k, a);
        }
        r0 += 4;
    }
    for r in r0..rows {
        let end = if lower { (r + 1).min(cols) } else { cols };
        let mut acc = [0.0; L];
        for (v, xc) in m[r * cols..][..end].iter().zip(&x[..end]) {
            for l in 0..L {
                acc[l] += v * xc[l];
            }
        }
        out(r, &acc);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every row equals the plain sum in column order, to the bit, for full and lower
    /// triangular matrices of 1 to 13 rows (groups of four and the rows left over).
    #[test]
    fn rows_equal_their_plain_sums() {
        let mut s = 0x1234_5678u64;
        let mut next = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((s >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        for n in 1..=13 {
            for lower in [false, true] {
                let cols = if lower { n } else { n + 2 };
                let m: Vec<f64> = (0..n * cols)
                    .map(|i| {
                        if lower && i % cols > i / cols {
                            0.0
                        } else {
                            next()
                        }
                    })
                    .collect();
                let x: Vec<[f64; 3]> = (0..cols).map(|_| [next(), next(), next()]).collect();
                let mut seen = vec![false; n];
                rows_times_lanes(&m, cols, lower, &x, |r, y| {
                    seen[r] = true;
                    for l in 0..3 {
                        let last = if lower { r + 1 } else { cols };
                        let plain = (0..last).fold(0.0, |a, c| a + m[r * cols + c] * x[c][l]);
                        assert_eq!(y[l].to_bits(), plain.to_bits(), "n {n} row {r} lane {l}");
                    }
                });
                assert!(seen.iter().all(|&s| s), "every row given ({n} rows)");
            }
        }
    }
}
