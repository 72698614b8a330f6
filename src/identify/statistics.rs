//! Statistics over the models of repeated identification runs: mean parameters with their
//! run-to-run σ ([`parameter_statistics`]) or full sample covariance ([`correlated_statistics`]).

use crate::kinematics::{param_index, RobotModel, Uncertainty, N_PARAMS};

/// Relative ridge added to the diagonal of a sample covariance: with R runs of ~24 free
/// parameters the covariance is singular when R is at most the number of free parameters, and the
/// ridge gives it a Cholesky factor (draws stay within 10⁻³ σ of the sample covariance's subspace).
pub const COVARIANCE_RIDGE: f64 = 1e-6;

/// Sample covariance (n − 1) of the parameters of `models`, row-major 30×30, internal units.
pub fn sample_covariance(models: &[RobotModel]) -> Vec<f64> {
    let n = models.len() as f64;
    let mut mean = [0.0; N_PARAMS];
    for m in models {
        for (s, v) in mean.iter_mut().zip(&m.params) {
            *s += v / n;
        }
    }
    let mut c = vec![0.0; N_PARAMS * N_PARAMS];
    for m in models {
        for i in 0..N_PARAMS {
            let di = m.params[i] - mean[i];
            for k in 0..N_PARAMS {
                c[i * N_PARAMS + k] += di * (m.params[k] - mean[k]) / (n - 1.0);
            }
        }
    }
    c
}

/// [`parameter_statistics`] with the full sample covariance instead of independent σ: rows and
/// columns of fixed parameters are zero and the diagonal carries the [`COVARIANCE_RIDGE`].
pub fn correlated_statistics(models: &[RobotModel]) -> Option<RobotModel> {
    let mut m = parameter_statistics(models)?;
    let sig = m.uncertainty.sigmas();
    let mut cov = sample_covariance(models);
    for i in 0..N_PARAMS {
        for k in 0..N_PARAMS {
            if sig[i] == 0.0 || sig[k] == 0.0 {
                cov[i * N_PARAMS + k] = 0.0;
            }
        }
        cov[i * N_PARAMS + i] *= 1.0 + COVARIANCE_RIDGE;
    }
    m.uncertainty = Uncertainty::Covariance(cov);
    Some(m)
}

/// Mean parameters and their sample standard deviations over the models of repeated runs
/// (`n − 1` divisor): a model whose uncertainty is `Independent(σ)`. The first model supplies the
/// structure, limits and name; `None` for fewer than two models or differing structures.
pub fn parameter_statistics(models: &[RobotModel]) -> Option<RobotModel> {
    let first = models.first()?;
    if models.len() < 2 || models.iter().any(|m| m.fixed != first.fixed) {
        return None;
    }
    let n = models.len() as f64;
    let mut mean = [0.0; N_PARAMS];
    let mut tool = [0.0; 3];
    for m in models {
        for (s, v) in mean.iter_mut().zip(&m.params) {
            *s += v / n;
        }
        for (s, v) in tool.iter_mut().zip(&m.tool) {
            *s += v / n;
        }
    }
    let mut sigma = [0.0; N_PARAMS];
    for (i, s) in sigma.iter_mut().enumerate() {
        let var = models
            .iter()
            .map(|m| (m.params[i] - mean[i]).powi(2))
            .sum::<f64>()
            / (n - 1.0);
        *s = var.sqrt();
    }
    // A fixed parameter has no spread by definition.
    for (j, f) in first.fixed.iter().enumerate() {
        sigma[param_index(j, f.kind())] = 0.0;
    }
    Some(RobotModel {
        name: format!("{} (mean of {} runs)", first.name, models.len()),
        params: mean,
        fixed: first.fixed,
        limits_deg: first.limits_deg,
        tool,
        uncertainty: Uncertainty::Independent(sigma),
    })
}
