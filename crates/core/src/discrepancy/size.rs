//! How well the residuals determine the term's size, and the per-draw factors that carry that
//! uncertainty into every analysis (docs/METHOD.md §18.3).
//!
//! The term's radii are the standardised residual norms `r_i`, scaled for the robot by how much
//! of their mean square `ms = mean(r_i²)` is not measurement noise. From 60 poses that mean
//! square is itself uncertain (its relative standard error is about `√(Var r²/n)/ms`, 10–20 %
//! for Gaussian residuals, more for heavy-tailed ones), and with it the robot's share: a robot
//! whose lack of fit the residuals underestimate gets a term too small at *every* task point
//! of a draw at once, which no per-point draw can make up for. So each draw `k` of an analysis
//! takes its own mean square `ms_k` from the posterior of `ms` given the residuals, a Bayesian
//! bootstrap (Rubin 1981: Dirichlet(1, …, 1) weights on the residuals; no Gaussian assumption,
//! heavy tails widen it by themselves), and scales the norms of that draw by
//!
//! ```text
//! g_k = √(max(0, ms_k/ms − f))        f = the noise's part of ms (0 when the noise is unknown)
//! ```
//!
//! for the robot, and `√(ms_k/ms)` for what a new measurement shows (noise kept). At `ms_k = ms`
//! this is the point estimate `√share`; where the residuals are close to the stated noise, some
//! draws carry a small term and most none. The factors are [`SIZE_DRAWS`] evenly spaced
//! quantiles of the posterior, so a run picks one per draw with 8 bits of its Philox block.

use crate::normal::normal_quantile;
use rand::{Rng, SeedableRng};

/// Quantiles of the size's posterior a run draws from (one per draw, from the top 8 bits of a
/// Philox word: the GPU indexes them the same way).
pub const SIZE_DRAWS: usize = 256;

/// Residuals up to which the posterior is the exact Bayesian bootstrap (above, its normal limit,
/// which the central limit theorem makes exact to well under the quantiles' spacing).
const EXACT_UP_TO: usize = 2048;

/// Bootstrap replicates behind the quantiles: 2048, fewer for many residuals (at most 2²¹
/// weights in all, a few milliseconds), never fewer than 1024.
fn replicates(n: usize) -> usize {
    ((1usize << 21) / n.max(1)).clamp(1024, 2048)
}

/// [`SIZE_DRAWS`] quantiles, ascending, of `ms_k / ms` under the posterior of the mean square
/// of `norms` (a Bayesian bootstrap; its normal limit above 2048 norms). Deterministic:
/// the same norms give the same factors. Empty norms or a zero mean square give all ones.
pub fn mean_square_ratios(norms: &[f64]) -> Vec<f64> {
    let n = norms.len();
    // In ascending order, so that the factors do not depend on the order the norms come in.
    let mut squares: Vec<f64> = norms.iter().map(|r| r * r).collect();
    squares.sort_by(f64::total_cmp);
    let ms = squares.iter().sum::<f64>() / n.max(1) as f64;
    if n < 2 || !(ms > 0.0 && ms.is_finite()) {
        return vec![1.0; SIZE_DRAWS];
    }
    if n > EXACT_UP_TO {
        // Var of the Dirichlet-weighted mean: Σ(x_i − x̄)² / (n(n + 1)).
        let var = squares.iter().map(|x| (x - ms).powi(2)).sum::<f64>() / (n * (n + 1)) as f64;
        let sd = var.sqrt() / ms;
        return (0..SIZE_DRAWS)
            .map(|k| (1.0 + sd * normal_quantile((k as f64 + 0.5) / SIZE_DRAWS as f64)).max(0.0))
            .collect();
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x5123_D15C ^ n as u64);
    let reps = replicates(n);
    let mut ratios: Vec<f64> = (0..reps)
        .map(|_| {
            let (mut weighted, mut total) = (0.0, 0.0);
            for x in &squares {
                let w = -(1.0 - rng.random::<f64>()).ln();
                weighted += w * x;
                total += w;
            }
            weighted / total / ms
        })
        .collect();
    ratios.sort_by(f64::total_cmp);
    (0..SIZE_DRAWS)
        .map(|k| ratios[(2 * k + 1) * reps / (2 * SIZE_DRAWS)])
        .collect()
}

/// The per-draw factors `g_k = √(max(0, ratio_k − f))` for a noise part `f` of the mean square.
pub fn factors(ratios: &[f64], noise_part: f64) -> Vec<f64> {
    ratios
        .iter()
        .map(|r| (r - noise_part).max(0.0).sqrt())
        .collect()
}
