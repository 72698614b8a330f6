//! What the fit beyond geometry leaves undetermined ([`super::BeyondGeometry`]'s
//! `undetermined`): coefficients held by their prior, or not separated from another input.

use super::{CONFOUNDED, PRIOR_HELD};
use crate::kinematics::JointErrors;
use nalgebra::DMatrix;

/// The coefficients among `free` (the first `geo` geometric inputs of `space`, then
/// coefficients) that the posterior covariance `cov` shows undetermined ([`BeyondGeometry`]'s
/// `undetermined`); `sigma` the coefficients' prior σ.
pub(super) fn undetermined(
    free: &[usize],
    geo: usize,
    space: crate::kinematics::InputSpace,
    cov: &DMatrix<f64>,
    sigma: &[f64],
) -> Vec<String> {
    let name = |k: usize| {
        if k < geo {
            crate::identify::chain_fit::fit_input_name(space, free[k])
        } else {
            JointErrors::coefficient_name(free[k])
        }
    };
    let sd = |k: usize| cov[(k, k)].max(0.0).sqrt();
    (geo..free.len())
        .filter_map(|k| {
            let ratio = sd(k) / sigma[free[k]];
            if ratio > PRIOR_HELD {
                return Some(format!(
                    "{}: held by its prior (σ {:.0} % of the prior's)",
                    name(k),
                    100.0 * ratio
                ));
            }
            let (other, rho) = (0..free.len())
                .filter(|&o| o != k && sd(o) > 0.0)
                .map(|o| (o, cov[(k, o)] / (sd(k) * sd(o))))
                .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))?;
            (rho.abs() > CONFOUNDED).then(|| {
                format!(
                    "{}: not separated from {} (correlation {rho:+.2})",
                    name(k),
                    name(other)
                )
            })
        })
        .collect()
}
