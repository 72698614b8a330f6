//! Statistics over the models of repeated identification runs: mean parameters and tool point
//! with their run-to-run σ ([`parameter_statistics`]) or full sample covariance
//! ([`correlated_statistics`]).
//!
//! The tool point (tracker target) is identified in every run, so it has a run-to-run spread
//! too: its σ goes into [`RobotModel::tool_sigma`], and the full covariance becomes
//! `(5n + 3)²` (the `5n` parameters, then the tool's x, y, z; 33 × 33 for six joints) when the
//! tool varies between the runs.

use super::{Identification, IdentifyError};
use crate::kinematics::{param_index, Block, Covariance, Inputs, Params, RobotModel, Uncertainty};

/// Relative ridge added to the diagonal of a sample covariance: with R runs of ~24 free
/// parameters the covariance is singular when R is at most the number of free parameters, and the
/// ridge gives it a Cholesky factor (draws stay within 10⁻³ σ of the sample covariance's subspace).
pub const COVARIANCE_RIDGE: f64 = 1e-6;

/// The values of a model's [`RobotModel::robot_inputs`]: its `5n` parameters, then the tool's
/// x, y, z.
fn inputs(m: &RobotModel) -> Inputs {
    let space = m.robot_inputs();
    Inputs::from_fn(space.len(), |i| match space.locate(i) {
        (Block::Tool, k) => m.tool[k],
        _ => m.params[i],
    })
}

/// Sample covariance (n − 1) of the parameters and tool coordinates of `models` (all with the
/// first model's joint count), row-major `(5n + 3)²` (the `5n` parameters, then the tool's x, y,
/// z; 33 × 33 for six joints), internal units; empty for no models.
pub fn sample_covariance(models: &[RobotModel]) -> Vec<f64> {
    let Some(first) = models.first() else {
        return Vec::new();
    };
    let nu = first.robot_inputs().len();
    let n = models.len() as f64;
    let mut mean = vec![0.0; nu];
    for m in models {
        for (s, v) in mean.iter_mut().zip(&inputs(m)) {
            *s += v / n;
        }
    }
    let mut c = vec![0.0; nu * nu];
    for m in models {
        let x = inputs(m);
        for i in 0..nu {
            let di = x[i] - mean[i];
            for k in 0..nu {
                c[i * nu + k] += di * (x[k] - mean[k]) / (n - 1.0);
            }
        }
    }
    c
}

/// [`parameter_statistics`] with the full sample covariance instead of independent σ: rows and
/// columns of fixed parameters (and of a tool coordinate without spread) are zero and the
/// diagonal carries the [`COVARIANCE_RIDGE`]. The matrix is `(5n + 3)²` (33 × 33 for six joints)
/// when the tool varies between the runs, else the parameters' `5n × 5n` block (30 × 30; the tool
/// then has σ 0).
pub fn correlated_statistics(models: &[RobotModel]) -> Option<RobotModel> {
    let mut m = parameter_statistics(models)?;
    let robot = m.robot_inputs();
    let nu = robot.len();
    let sig = m.input_sigmas();
    let full = sample_covariance(models);
    let space = if m.tool_uncertain() {
        robot
    } else {
        robot.without(Block::Tool)
    };
    let n = space.len();
    let mut cov = vec![0.0; n * n];
    for i in 0..n {
        for k in 0..n {
            if sig[i] != 0.0 && sig[k] != 0.0 {
                cov[i * n + k] = full[i * nu + k];
            }
        }
        cov[i * n + i] *= 1.0 + COVARIANCE_RIDGE;
    }
    m.set_covariance(Covariance::new(space, cov)?);
    Some(m)
}

/// Mean parameters and tool point and their sample standard deviations over the models of
/// repeated runs (`n − 1` divisor): a model whose uncertainty is `Independent(σ)` and whose
/// `tool_sigma` is the tool's run-to-run σ. The first model supplies the structure, limits and
/// name; `None` for fewer than two models or differing structures (joint counts included).
pub fn parameter_statistics(models: &[RobotModel]) -> Option<RobotModel> {
    let first = models.first()?;
    if models.len() < 2
        || models
            .iter()
            .any(|m| m.fixed != first.fixed || m.params.len() != first.params.len())
    {
        return None;
    }
    let np = first.params.len();
    let n = models.len() as f64;
    let nu = first.robot_inputs().len();
    let mut mean = vec![0.0; nu];
    for m in models {
        for (s, v) in mean.iter_mut().zip(&inputs(m)) {
            *s += v / n;
        }
    }
    let mut sigma = vec![0.0; nu];
    for (i, s) in sigma.iter_mut().enumerate() {
        let var = models
            .iter()
            .map(|m| (inputs(m)[i] - mean[i]).powi(2))
            .sum::<f64>()
            / (n - 1.0);
        *s = var.sqrt();
    }
    // A fixed parameter has no spread by definition.
    for (j, f) in first.fixed.iter().enumerate() {
        sigma[param_index(j, f.kind())] = 0.0;
    }
    Some(RobotModel {
        joint_errors: None,
        links: first.links,
        discrepancy: None,
        name: format!("{} (mean of {} runs)", first.name, models.len()),
        params: Params::from_slice(&mean[..np]),
        fixed: first.fixed,
        limits_deg: first.limits_deg,
        tool: std::array::from_fn(|k| mean[np + k]),
        tool_sigma: std::array::from_fn(|k| sigma[np + k]),
        uncertainty: Uncertainty::Independent(Params::from_slice(&sigma[..np])),
        base: first.base,
    })
}

/// What the runs' checks beyond geometry found, for the note of their mean model (which holds
/// the geometry alone); `None` when no run was checked.
fn checks_per_run(runs: &[Identification]) -> Option<String> {
    let checks: Vec<_> = runs
        .iter()
        .filter_map(|i| i.report.chain.as_ref()?.beyond_geometry.as_ref())
        .collect();
    if checks.is_empty() {
        return None;
    }
    let better = checks.iter().filter(|c| c.predicts_better).count();
    let range = |f: fn(&&super::chain::BeyondGeometry) -> f64| {
        let (lo, hi) = checks
            .iter()
            .map(f)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(v), b.max(v))
            });
        if hi - lo < 5e-5 {
            format!("{lo:.4}")
        } else {
            format!("{lo:.4}–{hi:.4}")
        }
    };
    Some(format!(
        "; beyond geometry, checked per run: joint compliance and gear harmonics predict better in {better} of the {} runs checked (leave-one-out RMS {} mm against {} mm for the geometry alone), but the mean model of several runs holds the geometry alone: identify one run to keep them",
        checks.len(),
        range(|c| c.loo_rms_extended_mm),
        range(|c| c.loo_rms_geometric_mm),
    ))
}

/// The model file of an identification: one run's model with the nominal model's uncertainty
/// (one run says nothing about the spread), or the mean of several runs with their run-to-run σ
/// (or, with `covariance`, their full covariance). Its name says what it was identified from
/// (`source`, e.g. the sweeps file). The note says which of these it is, for the user.
///
/// # Errors
/// [`IdentifyError::NoData`] for no runs, or runs whose models differ in structure.
pub fn identified_model(
    ids: &[Identification],
    nominal: &RobotModel,
    covariance: bool,
    source: &str,
) -> Result<(RobotModel, String), IdentifyError> {
    let (mut model, note) = match ids {
        [] => return Err(IdentifyError::NoData("no identified runs".into())),
        [one] if one.report.chain.is_some() => {
            let how = one
                .report
                .chain
                .as_ref()
                .map(|c| match c.covariance_from {
                    super::UncertaintyMethod::Linearised => "s²(JᵀWJ)⁻¹".to_string(),
                    super::UncertaintyMethod::MonteCarlo { draws } => {
                        format!("the spread of {draws} Monte Carlo re-identifications")
                    }
                })
                .unwrap_or_default();
            (
                one.model.clone(),
                format!(
                    "one run: the model file holds the covariance its own data produced ({how}, {} × {})",
                    one.model.uncertainty.dim(),
                    one.model.uncertainty.dim()
                ),
            )
        }
        [one] => {
            let mut m = one.model.clone();
            m.uncertainty = nominal.uncertainty.clone();
            (
                m,
                "note: one run says nothing about the spread: the model file keeps the nominal \
                 model's uncertainty; give several runs (a `run` column) to estimate it"
                    .to_string(),
            )
        }
        many => {
            let models: Vec<RobotModel> = many.iter().map(|i| i.model.clone()).collect();
            let (stats, what) = if covariance {
                (correlated_statistics(&models), "full covariance")
            } else {
                (parameter_statistics(&models), "σ")
            };
            let stats = stats
                .ok_or_else(|| IdentifyError::NoData("parameter statistics of the runs".into()))?;
            let mut stats = stats;
            let mut note = format!(
                "{} runs: the model file holds the mean parameters and their run-to-run {what}",
                many.len()
            );
            if let Some(cmp) = compare_with_single_run(many, &stats) {
                note.push_str(&cmp);
            }
            // What the runs' fits leave unexplained, pooled: the mean model keeps it.
            let terms: Vec<&crate::discrepancy::Discrepancy> = many
                .iter()
                .filter_map(|i| i.model.discrepancy.as_ref())
                .collect();
            stats.discrepancy = crate::discrepancy::Discrepancy::pooled(&terms);
            if let Some(d) = stats.discrepancy.as_ref().filter(|d| d.drawn()) {
                note.push_str(&format!(
                    "; its discrepancy term pools the residuals of {} of the {} runs (robot's RMS {:.4} mm)",
                    terms.len(),
                    many.len(),
                    d.robot_rms_mm()
                ));
            }
            if let Some(check) = checks_per_run(many) {
                note.push_str(&check);
            }
            // Placements identified per run: their mean (the tracker is taken not to move).
            let bases: Vec<_> = many.iter().filter_map(|i| i.model.base).collect();
            if many.iter().any(|i| {
                i.report
                    .chain
                    .as_ref()
                    .is_some_and(|c| c.frame == super::Placement::Identify)
            }) && bases.len() == many.len()
            {
                let n = bases.len() as f64;
                let mut b = bases[0];
                for k in 0..3 {
                    b.xyz[k] = bases.iter().map(|x| x.xyz[k]).sum::<f64>() / n;
                    b.rpy[k] = bases.iter().map(|x| x.rpy[k]).sum::<f64>() / n;
                }
                stats.base = Some(b);
            }
            (stats, note)
        }
    };
    model.name = format!("{} (identified from {source})", nominal.name);
    Ok((model, note))
}

/// "; run-to-run σ / single-run σ: median 1.02 over 23 parameters" when the runs carry
/// single-run covariances.
fn compare_with_single_run(runs: &[Identification], stats: &RobotModel) -> Option<String> {
    let spread = stats.input_sigmas();
    let mut ratios = Vec::new();
    for i in 0..spread.len() {
        let single: Vec<f64> = runs
            .iter()
            .filter_map(|r| match &r.model.uncertainty {
                Uncertainty::Covariance(_) if r.report.chain.is_some() => {
                    Some(r.model.uncertainty.entry(i, i).max(0.0).sqrt())
                }
                _ => None,
            })
            .collect();
        if single.len() != runs.len() || spread[i] == 0.0 {
            continue;
        }
        let mean = single.iter().sum::<f64>() / single.len() as f64;
        if mean > 0.0 {
            ratios.push(spread[i] / mean);
        }
    }
    if ratios.is_empty() {
        return None;
    }
    ratios.sort_by(f64::total_cmp);
    Some(format!(
        "; run-to-run σ / single-run σ: median {:.2} (range {:.2}–{:.2}) over {} inputs",
        ratios[ratios.len() / 2],
        ratios[0],
        ratios[ratios.len() - 1],
        ratios.len()
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::tx60;

    /// Three runs whose tool differs: the tool's mean and σ are those of the three values
    /// (closed form), the covariance is 33 × 33 (six joints) with the tool's variance on its
    /// diagonal, and
    /// the model passes its own checks.
    #[test]
    fn tool_spread_over_runs() {
        let runs: Vec<RobotModel> = [-1.0, 0.0, 2.0]
            .iter()
            .map(|&t| {
                let mut m = tx60();
                m.tool = [100.0 + 0.003 * t, 5.0, -0.002 * t];
                m.params[2] += 1e-3 * t;
                m
            })
            .collect();
        let m = parameter_statistics(&runs).unwrap();
        // values −1, 0, 2: mean 1/3, sample variance ((4/3)² + (1/3)² + (5/3)²)/2 = 7/3
        let s = (7.0f64 / 3.0).sqrt();
        assert!((m.tool[0] - (100.0 + 0.001)).abs() < 1e-12);
        assert!((m.tool_sigma[0] - 0.003 * s).abs() < 1e-12);
        assert_eq!(m.tool_sigma[1], 0.0);
        assert!((m.tool_sigma[2] - 0.002 * s).abs() < 1e-12);
        m.check().unwrap();
        let c = correlated_statistics(&runs).unwrap();
        let six = crate::kinematics::Layout::SIX;
        assert!(c.uncertainty.covers(Block::Tool));
        assert_eq!(c.uncertainty.dim(), six.robot().len());
        let (x, z) = (30, 32);
        let ridge = 1.0 + COVARIANCE_RIDGE;
        assert!((c.uncertainty.entry(x, x) - (0.003 * s).powi(2) * ridge).abs() < 1e-15);
        // tool x and z are perfectly anti-correlated, as are tool x and a1
        assert!((c.uncertainty.entry(x, z) + 0.003 * 0.002 * s * s).abs() < 1e-15);
        assert!(c.uncertainty.entry(x, 2) > 0.0);
        assert!((c.tool_sigma[0] - (0.003 * s) * ridge.sqrt()).abs() < 1e-15);
        let back = RobotModel::from_toml(&c.to_toml(), "x").unwrap();
        assert_eq!(back.uncertainty.dim(), six.robot().len());
        assert!((back.tool_sigma[2] - c.tool_sigma[2]).abs() < 1e-15);
        // runs with one tool keep the 30 × 30 matrix and no tool spread
        let same: Vec<RobotModel> = runs
            .iter()
            .map(|r| RobotModel {
                tool: [1.0, 2.0, 3.0],
                ..r.clone()
            })
            .collect();
        let c = correlated_statistics(&same).unwrap();
        assert_eq!(c.uncertainty.dim(), six.n_params());
        assert!(!c.tool_uncertain());
    }
}
