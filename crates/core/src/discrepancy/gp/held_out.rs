//! What a fitted process leaves at poses it did not see: cross-validation with refitted
//! hyperparameters for few poses, the closed-form leave-one-out for many.

use super::{fit, GpError, GpFit, CROSS_VALIDATION_LIMIT, FOLDS};
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};

/// Held-out figures of a process: per pose, what it leaves of each set of values and its
/// predictive σ there.
#[derive(Clone, Debug)]
pub struct HeldOut {
    /// Per set of values, per pose: the value minus the held-out prediction, mm.
    pub residuals: Vec<Vec<Vector3<f64>>>,
    /// Per pose, the predictive σ per coordinate of the process that did not see it, mm.
    pub sigmas: Vec<f64>,
    /// How: `"5-fold cross-validation"` or `"leave-one-out"`.
    pub method: &'static str,
}

/// What a process fitted to `targets` over `configs` leaves of each of `values` at poses it did
/// not see: [`FOLDS`]-fold cross-validation with refitted hyperparameters up to
/// [`CROSS_VALIDATION_LIMIT`] poses, else the closed-form leave-one-out of `full` (the process
/// fitted to all poses).
///
/// # Errors
///
/// A fold's fit failing ([`fit`]).
pub fn held_out(
    full: &GpFit,
    configs: &[Vec<f64>],
    targets: &[Vector3<f64>],
    values: &[&[Vector3<f64>]],
    seed: u64,
) -> Result<HeldOut, GpError> {
    let n = configs.len();
    if n > CROSS_VALIDATION_LIMIT {
        return Ok(HeldOut {
            residuals: values.iter().map(|v| full.loo(v)).collect(),
            sigmas: full.loo_sigmas(),
            method: "leave-one-out",
        });
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0xF01D_5EED);
    let mut order: Vec<usize> = (0..n).collect();
    for a in 0..n {
        let b = rng.random_range(a..n);
        order.swap(a, b);
    }
    let mut residuals: Vec<Vec<Vector3<f64>>> = values.iter().map(|v| v.to_vec()).collect();
    let mut sigmas = vec![0.0; n];
    for f in 0..FOLDS {
        let held: Vec<usize> = order[f * n / FOLDS..(f + 1) * n / FOLDS].to_vec();
        let mut is_held = vec![false; n];
        held.iter().for_each(|&i| is_held[i] = true);
        let train: Vec<usize> = (0..n).filter(|&i| !is_held[i]).collect();
        let pick = |v: &[Vector3<f64>]| train.iter().map(|&i| v[i]).collect::<Vec<_>>();
        let part = fit(
            &train
                .iter()
                .map(|&i| configs[i].clone())
                .collect::<Vec<_>>(),
            &pick(targets),
            seed.wrapping_add(f as u64 + 1),
        )?;
        for (k, v) in values.iter().enumerate() {
            let known = pick(v);
            for &i in &held {
                residuals[k][i] = v[i] - part.mean_of_values(&known, &configs[i]);
            }
        }
        for &i in &held {
            sigmas[i] = part.predictive_sigma(&configs[i]);
        }
    }
    Ok(HeldOut {
        residuals,
        sigmas,
        method: "5-fold cross-validation",
    })
}
