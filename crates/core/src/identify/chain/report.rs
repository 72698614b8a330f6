//! What a whole-chain identification reports ([`ChainReport`], with its parameter rows, noise
//! check and Monte Carlo check) and returns ([`ChainResult`]), and how the report is assembled
//! from a finished fit.

use super::covariance::{correlation, residual_norms, standard_deviations, FreeCovariance};
use super::model::reported_space;
use super::monte_carlo::monte_carlo_check;
use super::undetermined::{prior_sigma, with_held_inputs};
use super::warnings::run_warnings;
use super::{ChainOptions, Fitted, MeasuredPoint, Placement, UncertaintyMethod};
use crate::identify::chain_fit::{default_free, ChainState, Prior};
use crate::identify::identifiability::Identifiability;
use crate::kinematics::RobotModel;
use nalgebra::DMatrix;
use serde::Serialize;

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
    /// `identified`, `fixed: convention`, `not identifiable: nominal, prior σ` (the data do not
    /// determine it; it keeps its prior uncertainty), `fixed: by request`.
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
    /// Every input: identified or fixed, with σ; with several targets per pose, the other
    /// targets' offsets last (`target2_x`, …; the model file keeps only the first target).
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
    /// Noise against lack of fit, the discrepancy term and the leave-one-out self-check.
    pub lack_of_fit: crate::discrepancy::LackOfFit,
    /// The check beyond geometry (joint compliance and gear harmonics), when asked for.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub beyond_geometry: Option<super::BeyondGeometry>,
    /// When the check beyond geometry runs ([`super::JointErrorFit`]).
    pub joint_error_fit: super::JointErrorFit,
    /// Problems found (one line each, with what to measure instead).
    pub warnings: Vec<String>,
    /// The labels of the targets measured at each pose, when the data named them (the first is
    /// the model's tool, the others' offsets are the `target2_…` rows of `parameters`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub targets: Vec<String>,
    /// What the base reference reflectors showed, when the data had some.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub drift: Option<crate::identify::drift::DriftReport>,
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
    /// The discrepancy term the identified model carries (`None`: no lack of fit found, or too
    /// few points).
    pub discrepancy: Option<crate::discrepancy::Discrepancy>,
    /// The report.
    pub report: ChainReport,
    /// The model with compliance and harmonics of the check beyond geometry, when asked for.
    pub extended: Option<super::ExtendedModel>,
    /// The joint errors the identified model carries: those of the check beyond geometry when
    /// they predict new poses better ([`super::BeyondGeometry::kept`]).
    pub joint_errors: Option<crate::kinematics::JointErrors>,
}

/// The covariance the model keeps: over the free inputs, then those the data leave
/// undetermined with their prior σ ([`with_held_inputs`]).
pub(super) struct Kept {
    /// The inputs, free ones first (indices into the fit inputs).
    pub inputs: Vec<usize>,
    /// Their covariance, internal units.
    pub matrix: DMatrix<f64>,
}

impl Kept {
    /// The covariance of `run`'s free inputs (`cov`'s choice) with `held` (inputs the data do not
    /// determine, at `nominal`'s values) added at their prior σ; `prior` is the fit's.
    pub fn new(
        run: &Fitted,
        held: &[usize],
        nominal: &RobotModel,
        cov: &FreeCovariance,
        prior: Option<&Prior>,
    ) -> Kept {
        let mut inputs = run.free.clone();
        if held.is_empty() {
            // exactly symmetric, as a model file must be (a Cholesky inverse is so only to
            // rounding, which an ill-conditioned fit makes visible)
            let c = cov.chosen();
            return Kept {
                inputs,
                matrix: (c + c.transpose()) * 0.5,
            };
        }
        let sigma: Vec<f64> = held
            .iter()
            .map(|&i| prior_sigma(nominal, run.space, i))
            .collect();
        let matrix = with_held_inputs(
            &run.obs,
            &run.state,
            &run.free,
            held,
            &sigma,
            cov.chosen(),
            prior,
        );
        inputs.extend_from_slice(held);
        Kept { inputs, matrix }
    }

    /// The standard uncertainty of fit input `i` (internal units), `None` when not kept.
    fn sigma(&self, i: usize) -> Option<f64> {
        let k = self.inputs.iter().position(|&x| x == i)?;
        Some(self.matrix[(k, k)].max(0.0).sqrt())
    }
}

/// What a finished fit was checked for: the noise, identifiability and lack of fit.
pub(super) struct Checks {
    /// The noise check.
    pub noise: NoiseReport,
    /// Rank, conditioning, null directions.
    pub identifiability: Identifiability,
    /// Noise against lack of fit.
    pub lack_of_fit: crate::discrepancy::LackOfFit,
}

/// The report of the finished fit `run` of `points` against `nominal`: the parameter rows, the
/// Monte Carlo check, the correlations of the covariance `cov` holds, the residuals and the
/// warnings.
pub(super) fn build_report(
    run: &Fitted,
    points: &[MeasuredPoint],
    nominal: &RobotModel,
    opts: &ChainOptions,
    checks: Checks,
    cov: &FreeCovariance,
    kept: &Kept,
) -> ChainReport {
    let Checks {
        noise,
        mut identifiability,
        lack_of_fit,
    } = checks;
    let p = run.free.len();
    let mc_sigma: Option<Vec<f64>> = cov.monte_carlo.as_ref().map(|c| standard_deviations(c, p));
    let monte_carlo = mc_sigma.as_ref().map(|mc| {
        let lin_sigma = standard_deviations(&cov.linearised, p);
        monte_carlo_check(mc, &lin_sigma, opts.uncertainty)
    });
    let chosen = cov.chosen();
    let parameters = parameter_rows(
        run,
        nominal,
        opts.placement,
        &identifiability,
        kept,
        mc_sigma.as_deref(),
    );
    let correlation = correlation(chosen, p);
    let (norms, rms, max) = residual_norms(&run.obs, &run.state);
    let warnings = run_warnings(
        &identifiability,
        &noise,
        &lack_of_fit,
        &parameters,
        rms,
        opts.placement,
    );
    identifiability.correlated.truncate(50);
    ChainReport {
        frame: opts.placement,
        points: run.obs.len(),
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
        lack_of_fit,
        beyond_geometry: None,
        joint_error_fit: opts.beyond_geometry,
        warnings,
        targets: Vec::new(),
        drift: None,
    }
}

/// The report rows of the inputs a model of `placement` keeps (report units): identified, with
/// σ from the covariance the model keeps (and from the Monte Carlo σ `mc_sigma` when
/// computed), or held and why (the prior σ for an input the data do not determine).
fn parameter_rows(
    run: &Fitted,
    nominal: &RobotModel,
    placement: Placement,
    identifiability: &Identifiability,
    kept: &Kept,
    mc_sigma: Option<&[f64]>,
) -> Vec<ParameterRow> {
    let space = run.space;
    let conventional = {
        let all = default_free(&nominal.fixed, placement == Placement::Identify);
        move |i: usize| !all.contains(&i)
    };
    let shown = reported_space(space, placement).len();
    (0..shown)
        .map(|i| {
            let f = space.from_internal(i);
            let k = run.free.iter().position(|&x| x == i);
            let status = if k.is_some() {
                "identified".to_string()
            } else if identifiability.fixed_by_user.contains(&space.name(i)) {
                "fixed: by request".to_string()
            } else if identifiability
                .null_directions
                .iter()
                .any(|n| n.fixed == space.name(i))
            {
                "not identifiable: nominal, prior σ".to_string()
            } else if conventional(i) {
                "fixed: convention".to_string()
            } else {
                "fixed".to_string()
            };
            ParameterRow {
                name: space.name(i),
                nominal: run.nominal.get(i) * f,
                value: run.state.get(i) * f,
                sigma: kept.sigma(i).unwrap_or(0.0) * f,
                sigma_monte_carlo: k.and_then(|k| mc_sigma.map(|m| m[k] * f)),
                unit: space.quantity(i).file_unit(),
                status,
            }
        })
        // Several targets per pose: the other targets' offsets (flange frame), which the
        // model file does not keep, after the model's inputs.
        .chain(run.state.other_inputs().map(|i| {
            ParameterRow {
                name: run.state.input_name(i),
                nominal: run.nominal.get(i),
                value: run.state.get(i),
                sigma: kept.sigma(i).unwrap_or(0.0),
                sigma_monte_carlo: run
                    .free
                    .iter()
                    .position(|&x| x == i)
                    .and_then(|k| mc_sigma.map(|m| m[k])),
                unit: "mm",
                status: if run.free.contains(&i) {
                    "identified".to_string()
                } else {
                    "not identifiable: first estimate".to_string()
                },
            }
        }))
        .collect()
}
