//! The Monte Carlo re-identification that checks the linearised covariance (GUM Supplement 2
//! style): synthetic data drawn around the fit with the same noise, each identified again.

use super::{MonteCarloCheck, UncertaintyMethod};
use crate::identify::chain_fit::{fit, ChainState, Observation, Prior};
use nalgebra::{DMatrix, Matrix3, Vector3};
use rand::SeedableRng;

/// The sample covariance (over `free`) of `draws` re-identifications of synthetic data: the fit's
/// predictions plus noise drawn from each point's stated (or estimated) noise. `tick(k, draws)`
/// hears every hundredth of the draws done.
pub(super) fn monte_carlo_covariance(
    obs: &[Observation],
    state: &ChainState,
    free: &[usize],
    prior: Option<&Prior>,
    draws: usize,
    seed: u64,
    tick: &(dyn Fn(u64, u64) + Sync),
) -> DMatrix<f64> {
    use rayon::prelude::*;
    use std::sync::atomic::{AtomicU64, Ordering};
    let finished = AtomicU64::new(0);
    let every = (draws as u64 / 100).max(1);
    let predicted: Vec<[f64; 3]> = obs.iter().map(|o| state.predict_observation(o)).collect();
    let inverses: Vec<Matrix3<f64>> = obs
        .iter()
        .map(|o| o.whiten.try_inverse().unwrap_or_else(Matrix3::zeros))
        .collect();
    let estimates: Vec<Vec<f64>> = (0..draws)
        .into_par_iter()
        .map(|k| {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(
                seed ^ (k as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15),
            );
            let synthetic: Vec<Observation> = obs
                .iter()
                .zip(&predicted)
                .zip(&inverses)
                .map(|((o, p), winv)| {
                    let z = Vector3::new(
                        crate::sampling::standard_normal(&mut rng),
                        crate::sampling::standard_normal(&mut rng),
                        crate::sampling::standard_normal(&mut rng),
                    );
                    let e = winv * z;
                    Observation {
                        p: [p[0] + e.x, p[1] + e.y, p[2] + e.z],
                        ..*o
                    }
                })
                .collect();
            let s = fit(&synthetic, state, free, prior);
            let k = finished.fetch_add(1, Ordering::Relaxed) + 1;
            if k.is_multiple_of(every) {
                tick(k, draws as u64);
            }
            free.iter().map(|&i| s.get(i)).collect()
        })
        .collect();
    let p = free.len();
    let n = estimates.len().max(2) as f64;
    let mean: Vec<f64> = (0..p)
        .map(|c| estimates.iter().map(|e| e[c]).sum::<f64>() / n)
        .collect();
    DMatrix::from_fn(p, p, |a, b| {
        estimates
            .iter()
            .map(|e| (e[a] - mean[a]) * (e[b] - mean[b]))
            .sum::<f64>()
            / (n - 1.0)
    })
}

/// The Monte Carlo check of the linearised covariance from the standard uncertainties of the
/// free inputs by each method (`mc`, `linearised`), `method` the Monte Carlo one: the smallest,
/// median and largest ratio σ_MC / σ_linearised over the inputs whose linearised σ is positive.
pub(super) fn monte_carlo_check(
    mc: &[f64],
    linearised: &[f64],
    method: UncertaintyMethod,
) -> MonteCarloCheck {
    let mut ratios: Vec<f64> = mc
        .iter()
        .zip(linearised)
        .filter(|(_, l)| **l > 0.0)
        .map(|(m, l)| m / l)
        .collect();
    ratios.sort_by(f64::total_cmp);
    let n = ratios.len();
    MonteCarloCheck {
        draws: match method {
            UncertaintyMethod::MonteCarlo { draws } => draws,
            UncertaintyMethod::Linearised => 0,
        },
        ratio_min: ratios.first().copied().unwrap_or(f64::NAN),
        ratio_median: if n == 0 { f64::NAN } else { ratios[n / 2] },
        ratio_max: ratios.last().copied().unwrap_or(f64::NAN),
    }
}
