//! Which parameters to calibrate better, and which calibration factor does it: Sobol indices of
//! `w` for the baseline calibration ([`crate::mc::sensitivity`]), then for the top-ranked
//! parameters the σ that every factor level of the study's own calibrations gave
//! (docs/METHOD.md §13).
//!
//! The effect of a level on the top parameters is measured, not guessed: their σ come from the
//! repeated simulated calibrations the study ran at that level. The summary per level is the
//! index-weighted variance ratio
//!
//! `r = Σ_i S_T,i (σ_i(level)/σ_i(baseline))² / Σ_i S_T,i`   over the top parameters `i`,
//!
//! the fraction of their share of `Var(w)` left at that level if each one's contribution scales
//! with its variance (exact for an additive `w`; the indices say how far from additive `w` is).
//! `r < 1` reduces them. The factor whose best level has the smallest `r` is the recommendation.

use super::runner::LevelResult;
use super::settings::Factor;
use crate::kinematics::{param_joint, param_kind};
use crate::mc::sensitivity::SensitivityResult;
use serde::Serialize;

/// How many of the top-ranked parameters the factor comparison follows.
pub const TOP_PARAMETERS: usize = 3;

/// One ranked parameter of the baseline.
#[derive(Clone, Debug, Serialize)]
pub struct RankedParameter {
    /// Name, e.g. `alpha2`.
    pub name: String,
    /// First-order index S.
    pub first_order: f64,
    /// Total index S_T.
    pub total: f64,
    /// 95 % bootstrap interval of S_T, when there is one.
    pub total_ci: Option<[f64; 2]>,
    /// σ at the baseline calibration (deg for angles, mm for lengths).
    pub sigma_baseline: f64,
}

/// One factor level's effect on the top parameters.
#[derive(Clone, Debug, Serialize)]
pub struct LevelEffect {
    /// The level's label.
    pub level: String,
    /// `σ_i(level) / σ_i(baseline)` for each top parameter, in rank order.
    pub sigma_ratios: Vec<f64>,
    /// The index-weighted variance ratio `r` (module docs).
    pub variance_ratio: f64,
}

/// One factor's levels.
#[derive(Clone, Debug, Serialize)]
pub struct FactorEffect {
    /// The factor.
    pub factor: Factor,
    /// Every level studied, in the study's order.
    pub levels: Vec<LevelEffect>,
    /// Index into `levels` of the smallest `variance_ratio`.
    pub best: usize,
}

/// The ranking section of a study.
#[derive(Clone, Debug, Serialize)]
pub struct ParameterRanking {
    /// Sobol indices of `w` at the baseline calibration (independent σ, the largest point set).
    pub sensitivity: SensitivityResult,
    /// Every free parameter, by decreasing total index.
    pub parameters: Vec<RankedParameter>,
    /// The top parameters followed (at most [`TOP_PARAMETERS`]).
    pub top: Vec<String>,
    /// Per factor studied.
    pub factors: Vec<FactorEffect>,
    /// The factor whose best level has the smallest `variance_ratio`, when that is below 1.
    pub recommended: Option<Factor>,
}

/// The index of the parameter named `name` (`alpha2`, as [`crate::kinematics::Layout::input_name`]
/// names the inputs) among the `n_params` (`5n`) parameters of the model; `None` for another
/// input (a tool coordinate).
fn param_index(name: &str, n_params: usize) -> Option<usize> {
    (0..n_params).find(|&i| format!("{}{}", param_kind(i).name(), param_joint(i) + 1) == name)
}

/// The ranking from the baseline's indices and σ (`baseline`, σ joint-major in file units as
/// [`LevelResult::sigma`]) and the study's levels.
pub fn rank(
    sensitivity: SensitivityResult,
    baseline_sigma: &[f64],
    levels: &[LevelResult],
) -> ParameterRanking {
    let parameters: Vec<RankedParameter> = sensitivity
        .w()
        .inputs
        .iter()
        .filter_map(|x| {
            let i = param_index(&x.name, baseline_sigma.len())?;
            Some(RankedParameter {
                name: x.name.clone(),
                first_order: x.first_order.value,
                total: x.total.value,
                total_ci: x.total.ci_low.zip(x.total.ci_high).map(|(a, b)| [a, b]),
                sigma_baseline: baseline_sigma[i],
            })
        })
        .collect();
    let top: Vec<&RankedParameter> = parameters
        .iter()
        .filter(|p| p.sigma_baseline > 0.0 && p.total.is_finite())
        .take(TOP_PARAMETERS)
        .collect();
    let weight: f64 = top.iter().map(|p| p.total.max(0.0)).sum();
    let factors: Vec<FactorEffect> = Factor::ALL
        .iter()
        .filter_map(|&f| {
            let effects: Vec<LevelEffect> = levels
                .iter()
                .filter(|l| l.factor == f)
                .map(|l| {
                    let ratios: Vec<f64> = top
                        .iter()
                        .map(|p| {
                            let i = param_index(&p.name, baseline_sigma.len()).unwrap_or(0);
                            l.sigma[i] / p.sigma_baseline
                        })
                        .collect();
                    let r = if weight > 0.0 {
                        top.iter()
                            .zip(&ratios)
                            .map(|(p, q)| p.total.max(0.0) * q * q)
                            .sum::<f64>()
                            / weight
                    } else {
                        f64::NAN
                    };
                    LevelEffect {
                        level: l.level.clone(),
                        sigma_ratios: ratios,
                        variance_ratio: r,
                    }
                })
                .collect();
            let best = (0..effects.len()).min_by(|&a, &b| {
                effects[a]
                    .variance_ratio
                    .total_cmp(&effects[b].variance_ratio)
            })?;
            Some(FactorEffect {
                factor: f,
                levels: effects,
                best,
            })
        })
        .collect();
    let recommended = factors
        .iter()
        .map(|f| (f.factor, f.levels[f.best].variance_ratio))
        .filter(|(_, r)| *r < 1.0)
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(f, _)| f);
    ParameterRanking {
        top: top.iter().map(|p| p.name.clone()).collect(),
        sensitivity,
        parameters,
        factors,
        recommended,
    }
}

/// The ranking as Markdown rows: one per factor level, with the σ ratios of the top parameters
/// and `r`.
pub fn rows(r: &ParameterRanking) -> (Vec<String>, Vec<Vec<String>>) {
    let mut h = vec!["factor".to_string(), "level".to_string()];
    h.extend(r.top.iter().map(|n| format!("σ({n}) / baseline")));
    h.push("r (weighted variance ratio)".into());
    let mut rows = Vec::new();
    for f in &r.factors {
        for (k, l) in f.levels.iter().enumerate() {
            let mut row = vec![
                f.factor.name().to_string(),
                if k == f.best {
                    format!("**{}**", l.level)
                } else {
                    l.level.clone()
                },
            ];
            row.extend(l.sigma_ratios.iter().map(|q| format!("{q:.3}")));
            row.push(format!("{:.3}", l.variance_ratio));
            rows.push(row);
        }
    }
    (h, rows)
}

/// The ranked parameters as rows (name, S, S_T with interval, σ at the baseline).
pub fn parameter_rows(r: &ParameterRanking) -> (Vec<String>, Vec<Vec<String>>) {
    let h = ["parameter", "S", "S_T", "S_T 95 % CI", "σ baseline"]
        .map(String::from)
        .to_vec();
    let rows = r
        .parameters
        .iter()
        .map(|p| {
            vec![
                p.name.clone(),
                format!("{:.3}", p.first_order),
                format!("{:.3}", p.total),
                p.total_ci
                    .map_or("–".into(), |[a, b]| format!("[{a:.3}, {b:.3}]")),
                format!("{:.3e}", p.sigma_baseline),
            ]
        })
        .collect();
    (h, rows)
}
