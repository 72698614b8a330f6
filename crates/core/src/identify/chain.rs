//! One run's whole-chain identification with its uncertainty (docs/METHOD.md §2.4–2.7): the
//! weighted least-squares fit of [`super::chain_fit`], the identifiability analysis of
//! [`super::identifiability`], the covariance `s²(JᵀWJ)⁻¹` at the solution, its χ² check
//! against a stated noise, and optionally a Monte Carlo re-identification that checks the
//! linearisation (GUM Supplement 2 style).

use super::chain_fit::{
    default_free, fit, initial_state, jacobian, position_residuals, residuals, ChainState,
    Observation, Prior,
};
use super::identifiability::{
    advice, analyse, fix_null_directions, Identifiability, CONDITION_LIMIT,
};
use super::noise::{chi2_upper_tail, NoiseModel};
use super::pipeline::NominalPrior;
use super::IdentifyError;
use crate::kinematics::{Block, InputSpace, Joints, RobotModel, Uncertainty};
use nalgebra::{DMatrix, Matrix3, Vector3};
use rand::SeedableRng;
use serde::Serialize;

/// Whether the measurement frame → base placement is identified or known.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Placement {
    /// The data are in any frame (tracker, cell, world); the placement is identified.
    Identify,
    /// The data are in the robot's base frame (J1 along z); the placement is not fitted.
    Known,
}

/// How the parameters' covariance is obtained.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum UncertaintyMethod {
    /// `s²(JᵀWJ)⁻¹` at the solution (the default).
    Linearised,
    /// The sample covariance of `draws` re-identifications of synthetic data drawn around the
    /// fit with the same noise; the linearised one is reported beside it.
    MonteCarlo {
        /// Number of synthetic data sets (K).
        draws: usize,
    },
}

/// Options of the whole-chain identification.
#[derive(Clone, Debug, PartialEq)]
pub struct ChainOptions {
    /// Identify the placement or take the data as base-frame data.
    pub placement: Placement,
    /// Inputs the user fixes at their nominal values, by name (`d2`, `tool_z`, `base_yaw`, …).
    pub fix: Vec<String>,
    /// The measurement noise.
    pub noise: NoiseModel,
    /// Covariance method.
    pub uncertainty: UncertaintyMethod,
    /// Seed of the Monte Carlo re-identification.
    pub seed: u64,
}

impl Default for ChainOptions {
    fn default() -> Self {
        ChainOptions {
            placement: Placement::Identify,
            fix: Vec::new(),
            noise: NoiseModel::FromResiduals,
            uncertainty: UncertaintyMethod::Linearised,
            seed: 1,
        }
    }
}

/// A measured point as the whole-chain fit takes it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeasuredPoint {
    /// Commanded joint angles, degrees, one per joint.
    pub q_deg: Joints,
    /// Measured target position, mm, in the data's frame.
    pub position_mm: [f64; 3],
    /// Stated standard uncertainty per coordinate, mm, if the data have it.
    pub sigma_mm: Option<[f64; 3]>,
    /// The line of the data file.
    pub line: u64,
}

/// One identified quantity in the report (report units: mm and degrees).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ParameterRow {
    /// Name (`theta2`, `tool_x`, `base_yaw`, …).
    pub name: String,
    /// Nominal (start) value.
    pub nominal: f64,
    /// Identified value.
    pub value: f64,
    /// Standard uncertainty (0 for a fixed input).
    pub sigma: f64,
    /// Monte Carlo standard uncertainty, when computed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sigma_monte_carlo: Option<f64>,
    /// `"mm"` or `"deg"`.
    pub unit: &'static str,
    /// `identified`, `fixed: convention`, `fixed: not identifiable`, `fixed: by request`.
    pub status: String,
}

/// The noise check of a fit.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct NoiseReport {
    /// Where σ came from.
    pub source: String,
    /// The estimated σ per coordinate (from the residuals), mm; `None` for stated noise.
    pub sigma_mm: Option<f64>,
    /// χ² of the whitened residuals (stated noise).
    pub chi2: f64,
    /// Degrees of freedom 3n − p.
    pub dof: usize,
    /// `Pr[χ²_dof > chi2]` (stated noise); `None` when σ was estimated from the residuals.
    pub p_value: Option<f64>,
}

/// The Monte Carlo check of the linearised covariance.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MonteCarloCheck {
    /// Synthetic data sets re-identified.
    pub draws: usize,
    /// Smallest, median and largest ratio σ_MC / σ_linearised over the identified inputs.
    pub ratio_min: f64,
    /// Median ratio.
    pub ratio_median: f64,
    /// Largest ratio.
    pub ratio_max: f64,
}

/// What the whole-chain identification found.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ChainReport {
    /// The frame of the data and of the identified model.
    pub frame: Placement,
    /// Points used.
    pub points: usize,
    /// RMS of the 3-D point residuals, mm.
    pub rms_residual_mm: f64,
    /// Largest 3-D point residual, mm.
    pub max_residual_mm: f64,
    /// 3-D residual of each point, mm, in data order.
    pub residuals_mm: Vec<f64>,
    /// Line of each point in the data file.
    pub lines: Vec<u64>,
    /// Every input: identified or fixed, with σ.
    pub parameters: Vec<ParameterRow>,
    /// The noise and its check.
    pub noise: NoiseReport,
    /// Rank, condition, observability, null directions, correlations.
    pub identifiability: Identifiability,
    /// Correlation matrix of the identified inputs (row-major, in the order of the
    /// `identified` rows of `parameters`).
    pub correlation: Vec<f64>,
    /// The Monte Carlo check, when asked for.
    pub monte_carlo: Option<MonteCarloCheck>,
    /// The method whose covariance the model file holds.
    pub covariance_from: UncertaintyMethod,
    /// Problems found (one line each, with what to measure instead).
    pub warnings: Vec<String>,
}

/// The result: values, covariance over all fit inputs ([`ChainState::space`]; internal units,
/// zero rows for fixed inputs) and the report.
#[derive(Clone, Debug)]
pub struct ChainResult {
    /// The identified values.
    pub state: ChainState,
    /// Row-major covariance of the [`ChainState::space`] (39 × 39 for six joints), internal units
    /// (mm, rad).
    pub covariance: Vec<f64>,
    /// The report.
    pub report: ChainReport,
}

/// The nominal model's values as a chain state (placement: its `base`, or the identity).
pub fn nominal_state(nominal: &RobotModel) -> ChainState {
    let base = nominal
        .base
        .map(|b| [b.xyz[0], b.xyz[1], b.xyz[2], b.rpy[0], b.rpy[1], b.rpy[2]])
        .unwrap_or([0.0; 6]);
    ChainState {
        params: nominal.params,
        tool: nominal.tool,
        base,
    }
}

/// The prior of [`NominalPrior`] on the MDH parameters (not on the target or the placement).
fn nominal_prior(nominal: &ChainState, p: &NominalPrior) -> Prior {
    let space = nominal.space();
    let sigma = (0..space.len())
        .map(|i| match space.locate(i) {
            (Block::Joints, _) if space.is_angle(i) => p.angle_sigma_deg.to_radians(),
            (Block::Joints, _) => p.length_sigma_mm,
            _ => 0.0,
        })
        .collect();
    Prior {
        centre: *nominal,
        sigma,
    }
}

/// Builds the observations of `points` under `noise` (unit weights for noise from residuals).
///
/// # Errors
///
/// [`IdentifyError::NoData`] when the noise model needs per-point σ and a point has none.
pub fn observations(
    points: &[MeasuredPoint],
    noise: &NoiseModel,
) -> Result<Vec<Observation>, IdentifyError> {
    points
        .iter()
        .map(|p| {
            let whiten = noise.whiten(&p.position_mm, p.sigma_mm).ok_or_else(|| {
                IdentifyError::NoData(format!(
                    "line {}: no sx, sy, sz for this point while the noise is taken from the data's columns",
                    p.line
                ))
            })?;
            Ok(Observation {
                q: p.q_deg.map(f64::to_radians),
                p: p.position_mm,
                whiten,
            })
        })
        .collect()
}

/// Identifies the whole chain from `points`. `start` is the starting state (for sweeps: the
/// circle-point result and the placement from the J1/J2 axes), `None` to start from the nominal
/// model with a rigid alignment to the data. The placement is held at `start`'s (identity for
/// [`Placement::Known`]) unless identified.
///
/// # Errors
///
/// [`IdentifyError::NoData`] for no points or a name in `fix` that is not an input,
/// [`IdentifyError::JointCount`] when a point does not have one angle per joint of `nominal` (or
/// `start` has another number of parameters), and [`IdentifyError::NoData`] when σ is to be
/// estimated and there are no degrees of freedom left.
pub fn identify_chain(
    points: &[MeasuredPoint],
    nominal: &RobotModel,
    start: Option<ChainState>,
    prior: Option<NominalPrior>,
    opts: &ChainOptions,
) -> Result<ChainResult, IdentifyError> {
    if points.is_empty() {
        return Err(IdentifyError::NoData("no measured points".into()));
    }
    let lay = nominal.layout();
    let space = lay.measured();
    if let Some(p) = points.iter().find(|p| p.q_deg.len() != lay.joints()) {
        return Err(IdentifyError::JointCount(format!(
            "line {}: {} joint angles, the nominal model {} has {} joints",
            p.line,
            p.q_deg.len(),
            nominal.name,
            lay.joints()
        )));
    }
    if let Some(s) = start.filter(|s| s.params.len() != lay.n_params()) {
        return Err(IdentifyError::JointCount(format!(
            "the start has {} parameters, the nominal model {} has {}",
            s.params.len(),
            nominal.name,
            lay.n_params()
        )));
    }
    let mut nominal_s = nominal_state(nominal);
    if opts.placement == Placement::Known {
        nominal_s.base = [0.0; 6];
    }
    let mut obs = observations(points, &opts.noise)?;
    let mut free = default_free(&nominal.fixed, opts.placement == Placement::Identify);
    let mut state = match (start, opts.placement) {
        (Some(s), _) => s,
        (None, Placement::Identify) => initial_state(&obs, &nominal.params, &nominal.tool),
        (None, Placement::Known) => ChainState {
            base: [0.0; 6],
            tool: super::chain_fit::initial_tool(&obs, &nominal.params).unwrap_or(nominal.tool),
            ..nominal_s
        },
    };
    if opts.placement == Placement::Known {
        state.base = [0.0; 6];
    }
    let mut fixed_by_user = Vec::new();
    for name in &opts.fix {
        let i = space.find(&name.trim().to_ascii_lowercase()).ok_or_else(|| {
            IdentifyError::NoData(format!(
                "cannot fix '{name}': not a parameter name (theta1…beta{}, tool_x…tool_z, base_x…base_yaw)",
                lay.joints()
            ))
        })?;
        if space.locate(i).0 == Block::Placement && opts.placement == Placement::Known {
            return Err(IdentifyError::NoData(format!(
                "cannot fix '{name}': the placement is not identified for base-frame data"
            )));
        }
        free.retain(|&k| k != i);
        state.set(i, nominal_s.get(i));
        fixed_by_user.push(space.name(i));
    }
    // Directions the data cannot determine, found at the start and fixed at nominal.
    let mut nulls = fix_null_directions(&obs, &mut state, &nominal_s, &mut free);
    state = fit(&obs, &state, &free, None);
    let again = fix_null_directions(&obs, &mut state, &nominal_s, &mut free);
    if !again.is_empty() {
        nulls.extend(again);
        state = fit(&obs, &state, &free, None);
    }
    let dof = (3 * obs.len()).saturating_sub(free.len());
    let mut estimated_sigma = None;
    if !opts.noise.is_stated() {
        if dof == 0 {
            let fixed: Vec<&str> = nulls.iter().map(|n| n.fixed.as_str()).collect();
            return Err(IdentifyError::NoData(format!(
                "{} points give {} equations: {} quantities are identifiable at most{}, and no degrees of freedom are left to estimate the noise; measure 30–60 poses spread over the joint ranges, or state the tracker's σ",
                obs.len(),
                3 * obs.len(),
                free.len(),
                if fixed.is_empty() {
                    String::new()
                } else {
                    format!(" (rank deficient: {} not identifiable)", fixed.join(", "))
                }
            )));
        }
        let r = residuals(&obs, &state);
        let s = (r.iter().map(|v| v * v).sum::<f64>() / dof as f64).sqrt();
        // Noise-free data: any tiny σ keeps the covariance finite and honest (≈ 0).
        let s = s.max(1e-12);
        estimated_sigma = Some(s);
        for o in &mut obs {
            o.whiten = Matrix3::identity() / s;
        }
    }
    let prior = prior.map(|p| nominal_prior(&nominal_s, &p));
    if prior.is_some() {
        state = fit(&obs, &state, &free, prior.as_ref());
    }
    // Covariance over the free inputs: (JᵀWJ + prior)⁻¹ in whitened units.
    let j = jacobian(&obs, &state, &free);
    let mut a = j.transpose() * &j;
    if let Some(p) = &prior {
        for (k, &i) in free.iter().enumerate() {
            if p.sigma[i] > 0.0 {
                a[(k, k)] += 1.0 / (p.sigma[i] * p.sigma[i]);
            }
        }
    }
    let cov_free = invert_spd(&a);
    let r = residuals(&obs, &state);
    let chi2 = r.iter().map(|v| v * v).sum::<f64>();
    let noise = NoiseReport {
        source: opts.noise.describe(),
        sigma_mm: estimated_sigma,
        chi2,
        dof,
        p_value: opts.noise.is_stated().then(|| chi2_upper_tail(chi2, dof)),
    };
    let mut identifiability = analyse(&obs, &state, &free, &cov_free, nulls, fixed_by_user);
    let monte_carlo_cov = match opts.uncertainty {
        UncertaintyMethod::Linearised => None,
        UncertaintyMethod::MonteCarlo { draws } => Some(monte_carlo_covariance(
            &obs,
            &state,
            &free,
            prior.as_ref(),
            draws,
            opts.seed,
        )),
    };
    let lin_sigma: Vec<f64> = (0..free.len())
        .map(|k| cov_free[(k, k)].max(0.0).sqrt())
        .collect();
    let mc_sigma: Option<Vec<f64>> = monte_carlo_cov
        .as_ref()
        .map(|c| (0..free.len()).map(|k| c[(k, k)].max(0.0).sqrt()).collect());
    let monte_carlo = mc_sigma.as_ref().map(|mc| {
        let mut ratios: Vec<f64> = mc
            .iter()
            .zip(&lin_sigma)
            .filter(|(_, l)| **l > 0.0)
            .map(|(m, l)| m / l)
            .collect();
        ratios.sort_by(f64::total_cmp);
        let n = ratios.len();
        MonteCarloCheck {
            draws: match opts.uncertainty {
                UncertaintyMethod::MonteCarlo { draws } => draws,
                UncertaintyMethod::Linearised => 0,
            },
            ratio_min: ratios.first().copied().unwrap_or(f64::NAN),
            ratio_median: if n == 0 { f64::NAN } else { ratios[n / 2] },
            ratio_max: ratios.last().copied().unwrap_or(f64::NAN),
        }
    });
    let chosen = monte_carlo_cov.as_ref().unwrap_or(&cov_free);
    let nf = space.len();
    let mut covariance = vec![0.0; nf * nf];
    for (a_k, &ia) in free.iter().enumerate() {
        for (b_k, &ib) in free.iter().enumerate() {
            covariance[ia * nf + ib] = chosen[(a_k, b_k)];
        }
    }
    // Report rows.
    let conventional = {
        let all = default_free(&nominal.fixed, opts.placement == Placement::Identify);
        move |i: usize| !all.contains(&i)
    };
    let shown = reported_space(space, opts.placement).len();
    let parameters: Vec<ParameterRow> = (0..shown)
        .map(|i| {
            let f = space.from_internal(i);
            let k = free.iter().position(|&x| x == i);
            let status = if k.is_some() {
                "identified".to_string()
            } else if identifiability.fixed_by_user.contains(&space.name(i)) {
                "fixed: by request".to_string()
            } else if identifiability
                .null_directions
                .iter()
                .any(|n| n.fixed == space.name(i))
            {
                "fixed: not identifiable".to_string()
            } else if conventional(i) {
                "fixed: convention".to_string()
            } else {
                "fixed".to_string()
            };
            ParameterRow {
                name: space.name(i),
                nominal: nominal_s.get(i) * f,
                value: state.get(i) * f,
                sigma: k.map_or(0.0, |k| chosen[(k, k)].max(0.0).sqrt() * f),
                sigma_monte_carlo: k.and_then(|k| mc_sigma.as_ref().map(|m| m[k] * f)),
                unit: space.quantity(i).file_unit(),
                status,
            }
        })
        .collect();
    let p = free.len();
    let mut correlation = vec![0.0; p * p];
    for a_k in 0..p {
        for b_k in 0..p {
            let d = (chosen[(a_k, a_k)] * chosen[(b_k, b_k)]).sqrt();
            correlation[a_k * p + b_k] = if d > 0.0 { chosen[(a_k, b_k)] / d } else { 0.0 };
        }
    }
    let plain = position_residuals(&obs, &state);
    let norms: Vec<f64> = plain
        .iter()
        .map(|e| (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt())
        .collect();
    let rms = (norms.iter().map(|v| v * v).sum::<f64>() / norms.len() as f64).sqrt();
    let max = norms.iter().fold(0.0f64, |m, v| m.max(*v));
    let mut warnings = chain_warnings(&identifiability, &noise, &parameters);
    if rms > super::MAX_RMS_RESIDUAL_MM {
        warnings.insert(
            0,
            format!(
                "the RMS residual {rms:.4} mm is far above tracker noise ({} mm allowed): {}",
                super::MAX_RMS_RESIDUAL_MM,
                match opts.placement {
                    Placement::Known => "are the data really in the robot base frame, with the nominal model's structure?",
                    Placement::Identify => "check the nominal model's structure, the target and the data",
                }
            ),
        );
    }
    identifiability.correlated.truncate(50);
    Ok(ChainResult {
        state,
        covariance,
        report: ChainReport {
            frame: opts.placement,
            points: obs.len(),
            rms_residual_mm: rms,
            max_residual_mm: max,
            residuals_mm: norms,
            lines: points.iter().map(|p| p.line).collect(),
            parameters,
            noise,
            identifiability,
            correlation,
            monte_carlo,
            covariance_from: opts.uncertainty,
            warnings,
        },
    })
}

/// The warnings of a chain fit: directions the data leave free, ill-conditioning, residuals
/// inconsistent with the stated noise, parameters far from nominal.
fn chain_warnings(a: &Identifiability, noise: &NoiseReport, rows: &[ParameterRow]) -> Vec<String> {
    let mut w = Vec::new();
    if !a.null_directions.is_empty() {
        let fixed: Vec<&str> = a.null_directions.iter().map(|n| n.fixed.as_str()).collect();
        let first = &a.null_directions[0].combination;
        w.push(format!(
            "rank deficient: the data do not determine {} combination(s) of the parameters (first: {first}); fixed at nominal: {}; {}",
            a.null_directions.len(),
            fixed.join(", "),
            advice(first, a)
        ));
    }
    if a.condition_number > CONDITION_LIMIT {
        w.push(format!(
            "ill-conditioned: condition number {:.3e} is above {CONDITION_LIMIT}; the data barely determine {}; {}",
            a.condition_number,
            a.weakest,
            advice(&a.weakest, a)
        ));
    }
    if let Some(p) = noise.p_value {
        let ratio = (noise.chi2 / noise.dof.max(1) as f64).sqrt();
        if p < 1e-3 {
            w.push(format!(
                "the residuals are {ratio:.2}× the stated noise (χ² = {:.1} for {} degrees of freedom, p = {p:.1e}): the model or the stated σ is wrong; the covariance assumes the stated σ and is too small",
                noise.chi2, noise.dof
            ));
        } else if p > 1.0 - 1e-3 {
            w.push(format!(
                "the residuals are only {ratio:.2}× the stated noise (χ² = {:.1} for {} degrees of freedom): the stated σ looks too large, so the covariance is too wide",
                noise.chi2, noise.dof
            ));
        }
    }
    let far: Vec<String> = rows
        .iter()
        .filter(|r| r.status == "identified")
        .filter(|r| !r.name.starts_with("base_") && !r.name.starts_with("tool_"))
        .filter(|r| {
            let limit = if r.unit == "deg" {
                super::MAX_ANGLE_CHANGE_DEG
            } else {
                super::MAX_LENGTH_CHANGE_MM
            };
            (r.value - r.nominal).abs() > limit
        })
        .map(|r| format!("{} {:+.3} {}", r.name, r.value - r.nominal, r.unit))
        .collect();
    if !far.is_empty() {
        w.push(format!(
            "{} parameter(s) moved further from nominal than a calibration corrects ({} mm / {}°): {}; check the nominal model, the data's units and the warnings above",
            far.len(),
            super::MAX_LENGTH_CHANGE_MM,
            super::MAX_ANGLE_CHANGE_DEG,
            far.join(", ")
        ));
    }
    w
}

/// The inverse of a symmetric positive (semi)definite matrix: Cholesky, or the pseudo-inverse by
/// eigen-decomposition when it is singular to working precision.
fn invert_spd(a: &DMatrix<f64>) -> DMatrix<f64> {
    if let Some(ch) = a.clone().cholesky() {
        return ch.inverse();
    }
    let eig = a.clone().symmetric_eigen();
    let max = eig.eigenvalues.iter().fold(0.0f64, |m, v| m.max(*v));
    let mut inv = DMatrix::zeros(a.nrows(), a.ncols());
    for k in 0..eig.eigenvalues.len() {
        let l = eig.eigenvalues[k];
        if l > 1e-12 * max {
            let v = eig.eigenvectors.column(k);
            inv += v * v.transpose() / l;
        }
    }
    inv
}

/// The sample covariance (over `free`) of `draws` re-identifications of synthetic data: the fit's
/// predictions plus noise drawn from each point's stated (or estimated) noise.
fn monte_carlo_covariance(
    obs: &[Observation],
    state: &ChainState,
    free: &[usize],
    prior: Option<&Prior>,
    draws: usize,
    seed: u64,
) -> DMatrix<f64> {
    use rayon::prelude::*;
    let predicted: Vec<[f64; 3]> = obs.iter().map(|o| state.predict(&o.q)).collect();
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
                        q: o.q,
                        p: [p[0] + e.x, p[1] + e.y, p[2] + e.z],
                        whiten: o.whiten,
                    }
                })
                .collect();
            let s = fit(&synthetic, state, free, prior);
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

/// The identified model of a chain result: `nominal`'s structure and limits with the identified
/// parameters, target and (for [`Placement::Identify`]) placement, and the covariance as the
/// model file's `[covariance]`: `(5n + 9)²` with the placement (the last six rows x, y, z, roll,
/// pitch, yaw; 39 × 39, rows 34–39, for six joints), `(5n + 3)²` (33 × 33) without.
pub fn chain_model(nominal: &RobotModel, result: &ChainResult, name: String) -> RobotModel {
    state_model(
        nominal,
        &result.state,
        &result.covariance,
        result.report.frame,
        name,
    )
}

/// The fit inputs a model of `frame` keeps: all of them when the placement was identified, else
/// the robot's (the placement was known).
fn reported_space(fit: InputSpace, frame: Placement) -> InputSpace {
    match frame {
        Placement::Identify => fit,
        Placement::Known => fit.without(Block::Placement),
    }
}

/// The model of chain state `s` with `covariance` (row-major over [`ChainState::space`], internal units,
/// zero rows for inputs held fixed) in `frame`: what [`chain_model`] makes of an identification,
/// and what a calibration plan predicts before any data exist. `s` has `nominal`'s joint count.
pub fn state_model(
    nominal: &RobotModel,
    s: &ChainState,
    covariance: &[f64],
    frame: Placement,
    name: String,
) -> RobotModel {
    let fit = s.space();
    debug_assert_eq!(s.layout(), nominal.layout());
    let kept = reported_space(fit, frame);
    let cov = crate::kinematics::Covariance::new(fit, covariance.to_vec())
        .expect("a covariance of the fit inputs")
        .restricted(kept);
    let mut model = RobotModel {
        name,
        params: s.params,
        fixed: nominal.fixed,
        limits_deg: nominal.limits_deg,
        tool: s.tool,
        // Set from the covariance's tool block below.
        tool_sigma: [0.0; 3],
        uncertainty: Uncertainty::Independent(nominal.param_sigmas()),
        base: match frame {
            Placement::Identify => Some(crate::kinematics::BaseTransform {
                xyz: [s.base[0], s.base[1], s.base[2]],
                rpy: [s.base[3], s.base[4], s.base[5]],
            }),
            Placement::Known => nominal.base,
        },
    };
    model.set_covariance(cov);
    model
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::tx60;
    use rand::{Rng, SeedableRng};

    /// A TX60 with every free parameter off by tenths of a mm / hundredths of a degree, target
    /// (30, −20, 80) mm, placed 2.6 m from the tracker and turned.
    fn truth() -> ChainState {
        let nominal = tx60();
        let mut t = ChainState {
            params: nominal.params,
            tool: [30.0, -20.0, 80.0],
            base: [2600.0, 500.0, -200.0, 0.03, -0.05, 2.3],
        };
        let six = crate::kinematics::Layout::SIX;
        for (k, i) in default_free(&nominal.fixed, true).into_iter().enumerate() {
            if i < six.n_params() {
                let size = if six.measured().is_angle(i) {
                    5e-4
                } else {
                    0.3
                };
                t.set(i, t.get(i) + size * [1.0, -0.6, 0.8, -1.0, 0.5][k % 5]);
            }
        }
        t
    }

    fn points(t: &ChainState, n: usize, sigma: f64, seed: u64) -> Vec<MeasuredPoint> {
        let m = tx60();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        (0..n)
            .map(|k| {
                let q_deg = Joints::from_fn(m.joints(), |j| {
                    let (lo, hi) = m.limits_deg[j];
                    rng.random_range(lo.max(-170.0)..hi.min(170.0))
                });
                let p = t.predict(&q_deg.map(f64::to_radians));
                let position_mm = p.map(|v| v + sigma * crate::sampling::standard_normal(&mut rng));
                MeasuredPoint {
                    q_deg,
                    position_mm,
                    sigma_mm: None,
                    line: k as u64 + 2,
                }
            })
            .collect()
    }

    #[test]
    fn noise_free_poses_in_a_tracker_frame_are_reproduced() {
        let t = truth();
        let data = points(&t, 60, 0.0, 1);
        let r = identify_chain(&data, &tx60(), None, None, &ChainOptions::default()).unwrap();
        assert_eq!(r.report.identifiability.parameters, 27);
        assert!(r.report.identifiability.null_directions.is_empty());
        for p in points(&t, 20, 0.0, 99) {
            let got = r.state.predict(&p.q_deg.map(f64::to_radians));
            for k in 0..3 {
                assert!(
                    (got[k] - p.position_mm[k]).abs() < 1e-6,
                    "{got:?} {:?}",
                    p.position_mm
                );
            }
        }
        eprintln!(
            "KAPPA {} sv {:?}",
            r.report.identifiability.condition_number, r.report.identifiability.singular_values
        );
    }

    #[test]
    fn frozen_wrist_is_named() {
        let t = truth();
        let mut data = points(&t, 60, 0.01, 2);
        for p in &mut data {
            p.q_deg[3] = 10.0;
            p.q_deg[4] = 40.0;
            p.q_deg[5] = -20.0;
            p.position_mm = t.predict(&p.q_deg.map(f64::to_radians));
        }
        let r = identify_chain(&data, &tx60(), None, None, &ChainOptions::default()).unwrap();
        let a = &r.report.identifiability;
        assert!(!a.null_directions.is_empty(), "{a:?}");
        assert!(
            r.report
                .warnings
                .iter()
                .any(|w| w.contains("rank deficient") && w.contains("barely moved")),
            "{:?}",
            r.report.warnings
        );
    }
}

#[cfg(test)]
mod target_tests {
    use super::*;
    use crate::kinematics::tx60;

    /// A target on the J6 axis leaves its phase invisible: flagged, with the advice to move it.
    #[test]
    fn target_on_the_j6_axis_is_flagged() {
        let m = tx60();
        let s = ChainState {
            params: m.params,
            tool: [0.0, 0.0, 80.0],
            base: [2000.0, 0.0, 0.0, 0.0, 0.0, 1.0],
        };
        let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(4);
        use rand::Rng;
        let configs: Vec<Joints> = (0..60)
            .map(|_| {
                Joints::from_fn(m.joints(), |j| {
                    rng.random_range(m.limits_deg[j].0..m.limits_deg[j].1)
                })
            })
            .collect();
        let pts: Vec<MeasuredPoint> = configs
            .into_iter()
            .enumerate()
            .map(|(k, q)| MeasuredPoint {
                q_deg: q,
                position_mm: s.predict(&q.map(f64::to_radians)),
                sigma_mm: None,
                line: k as u64,
            })
            .collect();
        let r = identify_chain(&pts, &m, None, None, &ChainOptions::default()).unwrap();
        let w = r.report.warnings.join("\n");
        assert!(w.contains("away from the J6 axis"), "{w}");
    }
}
