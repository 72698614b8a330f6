//! Repeated calibrations of a robot with joint errors beyond geometry (docs/METHOD.md §19): every
//! run identified twice from the same sweeps, by the whole-chain fit with the geometry alone and
//! with the check beyond geometry of a chosen [`JointErrorFit`] mode (joint compliance under
//! gravity, gear harmonics), and the accuracy of both at test poses of the true robot.
//!
//! The runs' mean model carries joint errors only when the runs' models do: with
//! [`JointErrorFit::Auto`] or [`JointErrorFit::On`] the runs decide together — when most of them
//! keep the joint errors, the others are identified again keeping them
//! ([`JointErrorFit::Keep`]) so that every run's model enters the mean with the same structure;
//! otherwise every run's model is its geometric one. The mean model's joint errors are the
//! runs' mean coefficients with their run-to-run covariance (as its geometry has); they are
//! drawn independently of the geometry (no `geometry_shift`: the runs' correlation between
//! geometry and coefficients is not carried). Robots with backlash are calibrated from pose
//! runs, the sides from the poses' order; the mean model carries the runs' mean gaps when every
//! run kept gaps ([`mean_joint_errors`]).

use super::calibrate::{each_run, run_seed, test_measurements, Calibration, Experiment};
use super::factors::{Factors, SimulateError};
pub use super::full_report::{render_full_accuracy, render_full_calibration};
use crate::identify::chain::BeyondGeometry;
use crate::identify::{
    correlated_statistics, identify_data, parameter_statistics, validate, AccuracyStats,
    ChainOptions, JointErrorFit, NoiseModel, Placement, PoseData, PosePoint, PoseRun, SweepData,
    TrackerData, COVARIANCE_RIDGE,
};
use crate::kinematics::{JointErrors, RobotModel};
use crate::points::WorkspaceBox;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

/// What each run of a [`FullCalibration`] measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RunData {
    /// The circle-point sweeps of the factor setting (one joint moving at a time).
    Sweeps,
    /// This many static poses at random configurations within the joint limits (the factors'
    /// range, step, speed and start do not apply).
    Poses(usize),
}

impl RunData {
    /// In words, for reports.
    pub fn describe(self) -> String {
        match self {
            RunData::Sweeps => "circle-point sweeps".into(),
            RunData::Poses(n) => format!("{n} random poses"),
        }
    }
}

/// One run's poses: `n` random configurations within the nominal model's limits, measured as
/// [`Experiment::measure`] measures them (static: the robot's repeatability scatter and the
/// tracker's noise; a robot with backlash visits them in their order and each pose records its
/// sides), at the payload the true robot carries.
fn pose_run(exp: &Experiment, n: usize, label: String, rng: &mut ChaCha8Rng) -> PoseData {
    let configs = super::random_configurations(&exp.nominal.limits_deg, n, rng);
    let payload_kg = exp.nongeometric.as_ref().map_or(0.0, |g| g.payload_kg);
    let points = exp
        .measure(&configs, rng)
        .into_iter()
        .map(|m| PosePoint {
            q_deg: m.q_deg,
            position_mm: m.position_mm,
            sigma_mm: None,
            payload_kg,
            line: m.line,
            target: 0,
            sides: m.sides,
        })
        .collect();
    PoseData {
        runs: vec![PoseRun {
            run: Some(label),
            points,
        }],
        targets: Vec::new(),
        references: Vec::new(),
        reference_labels: Vec::new(),
    }
}

/// One run of a [`FullCalibration`].
#[derive(Clone, Debug)]
pub struct FullRun {
    /// The run's model identified with the geometry alone.
    pub geometric: RobotModel,
    /// The run's model as it enters the full mean model (its joint errors when the mean carries
    /// them, else its geometric model).
    pub full: RobotModel,
    /// The check beyond geometry of the run's identification with the mode asked for (`None`
    /// when it did not run).
    pub check: Option<BeyondGeometry>,
    /// Whether the run's identification with the mode asked for kept the joint errors (before
    /// the runs decided together).
    pub kept_by_mode: bool,
}

/// A repeated calibration identified with the geometry alone and with joint errors.
#[derive(Clone, Debug)]
pub struct FullCalibration {
    /// The mode the runs were identified with beside the geometric identification.
    pub mode: JointErrorFit,
    /// What each run measured.
    pub data: RunData,
    /// Statistics of the runs' geometric models.
    pub geometric: Calibration,
    /// Statistics of the runs' full models; the mean models carry the mean joint errors when
    /// [`Self::carries_joint_errors`].
    pub full: Calibration,
    /// Every run.
    pub runs: Vec<FullRun>,
    /// Whether the full mean model carries joint errors.
    pub carries_joint_errors: bool,
}

impl FullCalibration {
    /// Runs whose identification with the mode kept the joint errors.
    pub fn kept_by_mode(&self) -> usize {
        self.runs.iter().filter(|r| r.kept_by_mode).count()
    }
}

/// The whole-chain options of run `r` identified with `mode`: the noise estimated from the
/// residuals (as `identify` does without a stated noise), no compensation (the mean model of
/// several runs keeps none), linearised covariance.
fn chain_options(exp: &Experiment, mode: JointErrorFit, seed: u64) -> ChainOptions {
    ChainOptions {
        placement: if exp.placement.is_some() {
            Placement::Identify
        } else {
            Placement::Known
        },
        noise: NoiseModel::FromResiduals,
        seed,
        compensate: false,
        beyond_geometry: mode,
        ..ChainOptions::default()
    }
}

/// Identifies one run's sweeps with `mode`.
fn identify_one(
    exp: &Experiment,
    data: &TrackerData,
    mode: JointErrorFit,
    seed: u64,
    run: usize,
) -> Result<(RobotModel, Option<BeyondGeometry>), SimulateError> {
    let opts = chain_options(exp, mode, seed);
    let mut ids = identify_data(data, &exp.nominal, &exp.identify, &opts, false)
        .map_err(|cause| SimulateError::Identify { run, cause })?;
    let id = ids
        .pop()
        .ok_or_else(|| SimulateError::Other(format!("calibration run {run}: no identification")))?;
    let check = id
        .report
        .chain
        .as_ref()
        .and_then(|c| c.beyond_geometry.clone());
    Ok((id.model, check))
}

/// Runs `f.runs` simulated calibrations of `exp` from `seed` measuring `what` (with
/// [`RunData::Sweeps`] the sweeps of [`super::calibrate()`]'s runs), each identified by the
/// whole-chain fit with the geometry alone and with `mode`, and returns both statistics (module
/// docs).
///
/// # Errors
///
/// As [`super::calibrate()`]; [`SimulateError::Identify`] too when a run's poses are too few to
/// identify the model.
pub fn calibrate_full(
    exp: &Experiment,
    f: &Factors,
    seed: u64,
    what: RunData,
    mode: JointErrorFit,
    progress: &crate::progress::ProgressHook,
) -> Result<FullCalibration, SimulateError> {
    f.check()?;
    if what == RunData::Sweeps {
        exp.check_sweeps()?;
    }
    let t0 = std::time::Instant::now();
    let fitted: Vec<(TrackerData, FullRun)> = each_run(f.runs, progress, |r| {
        let s = run_seed(seed, r as u64);
        let mut rng = ChaCha8Rng::seed_from_u64(s);
        let label = (r + 1).to_string();
        let data = match what {
            RunData::Sweeps => TrackerData::Sweeps(SweepData {
                runs: vec![exp.sweep_run(f, Some(label), &mut rng)],
            }),
            RunData::Poses(n) => TrackerData::Poses(pose_run(exp, n, label, &mut rng)),
        };
        let (geometric, _) = identify_one(exp, &data, JointErrorFit::Off, s, r + 1)?;
        let (full, check) = identify_one(exp, &data, mode, s, r + 1)?;
        let kept_by_mode = full.joint_errors.is_some();
        Ok((
            data,
            FullRun {
                geometric,
                full,
                check,
                kept_by_mode,
            },
        ))
    })?;
    let kept = fitted.iter().filter(|(_, r)| r.kept_by_mode).count();
    let carries = 2 * kept > f.runs;
    let runs: Vec<FullRun> = fitted
        .into_par_iter()
        .enumerate()
        .map(|(r, (data, mut run))| {
            if carries && !run.kept_by_mode {
                let s = run_seed(seed, r as u64);
                run.full = identify_one(exp, &data, JointErrorFit::Keep, s, r + 1)?.0;
            } else if !carries {
                run.full = run.geometric.clone();
            }
            Ok(run)
        })
        .collect::<Result<_, SimulateError>>()?;
    let geometric: Vec<RobotModel> = runs.iter().map(|r| r.geometric.clone()).collect();
    let full: Vec<RobotModel> = runs.iter().map(|r| r.full.clone()).collect();
    let seconds = t0.elapsed().as_secs_f64();
    let geometric = statistics(exp, f, what, &geometric, "geometric", seconds)?;
    let mut full = statistics(exp, f, what, &full, "joint errors", seconds)?;
    if carries {
        let models: Vec<RobotModel> = runs.iter().map(|r| r.full.clone()).collect();
        let errors = |correlated: bool, m: &RobotModel| {
            mean_joint_errors(&models, m.tool, correlated).ok_or_else(|| {
                SimulateError::Other(
                    "the runs identified joint errors of different structure".into(),
                )
            })
        };
        full.independent.joint_errors = Some(errors(false, &full.independent)?);
        full.correlated.joint_errors = Some(errors(true, &full.correlated)?);
    }
    Ok(FullCalibration {
        mode,
        data: what,
        geometric,
        full,
        runs,
        carries_joint_errors: carries,
    })
}

/// The [`Calibration`] of `models` (their independent and correlated statistics), named as
/// [`super::calibrate()`] names its model, with `kind` the identification.
fn statistics(
    exp: &Experiment,
    f: &Factors,
    what: RunData,
    models: &[RobotModel],
    kind: &str,
    seconds: f64,
) -> Result<Calibration, SimulateError> {
    let structure =
        || SimulateError::Other("the runs identified models of different structure".into());
    let mut independent = parameter_statistics(models).ok_or_else(structure)?;
    independent.name = match what {
        RunData::Sweeps => format!(
            "{} calibrated, {kind} ({} runs, range {} %, step {}°, speed {} %, {})",
            exp.nominal.name,
            f.runs,
            f.range_fraction * 100.0,
            f.step_deg,
            f.speed_fraction * 100.0,
            f.direction.label()
        ),
        RunData::Poses(n) => format!(
            "{} calibrated, {kind} ({} runs of {n} random poses)",
            exp.nominal.name, f.runs
        ),
    };
    let mut correlated = correlated_statistics(models).ok_or_else(structure)?;
    correlated.name = independent.name.clone();
    Ok(Calibration {
        factors: *f,
        runs: models.to_vec(),
        independent,
        correlated,
        seconds,
    })
}

/// The mean joint errors of `models` (each carrying joint errors of the same joint count and
/// link masses): the mean coefficients; for a coefficient with run-to-run spread its sample
/// variance (`correlated`: the full sample covariance of those coefficients, with
/// [`COVARIANCE_RIDGE`] on the diagonal), for one without spread that some run kept free (a
/// compliance the data did not determine, held at 0 with its prior) the largest σ a run gave it;
/// the payload during calibration the runs', its centre of mass at the mean model's `tool`. No
/// `geometry_shift`. `None` for no models or differing structures.
pub fn mean_joint_errors(
    models: &[RobotModel],
    tool: [f64; 3],
    correlated: bool,
) -> Option<JointErrors> {
    let errors: Vec<&JointErrors> = models
        .iter()
        .map(|m| m.joint_errors.as_ref())
        .collect::<Option<_>>()?;
    let first = *errors.first()?;
    let nc = first.coefficients.len();
    if errors
        .iter()
        .any(|e| e.coefficients.len() != nc || e.links != first.links)
    {
        return None;
    }
    let n = errors.len() as f64;
    let mean: Vec<f64> = (0..nc)
        .map(|i| errors.iter().map(|e| e.coefficients[i]).sum::<f64>() / n)
        .collect();
    let cov = |i: usize, k: usize| {
        if errors.len() < 2 {
            return 0.0;
        }
        errors
            .iter()
            .map(|e| (e.coefficients[i] - mean[i]) * (e.coefficients[k] - mean[k]))
            .sum::<f64>()
            / (n - 1.0)
    };
    let spread: Vec<bool> = (0..nc).map(|i| cov(i, i) > 0.0).collect();
    let free: Vec<usize> = (0..nc)
        .filter(|&i| spread[i] || errors.iter().any(|e| e.free.contains(&i)))
        .collect();
    let p = free.len();
    let mut covariance = vec![0.0; p * p];
    for (a, &i) in free.iter().enumerate() {
        if !spread[i] {
            covariance[a * p + a] = errors
                .iter()
                .map(|e| e.sigma(i))
                .fold(0.0, f64::max)
                .powi(2);
            continue;
        }
        for (b, &k) in free.iter().enumerate() {
            if a == b {
                covariance[a * p + a] = cov(i, i) * (1.0 + COVARIANCE_RIDGE);
            } else if correlated && spread[k] {
                covariance[a * p + b] = cov(i, k);
            }
        }
    }
    let payload = crate::kinematics::Payload {
        com_mm: tool,
        sigma_kg: 0.0,
        ..first.calibration_payload
    };
    Some(JointErrors {
        coefficients: mean,
        links: first.links,
        calibration_payload: payload,
        payload,
        free,
        covariance,
        shift_space: first.shift_space,
        shift: Vec::new(),
        backlash: mean_backlash(&errors),
    })
}

/// The mean backlash of the runs' joint errors `errors`, when every run kept gaps for the same
/// joints: per joint the mean gap, its σ the larger of the runs' sample standard deviation and
/// the largest σ a run gave it (a single run's σ is honest, simulated TX60s: 96 % of gaps within
/// 1.96σ; a spread from few runs can fall far below it). No term for unknown
/// sides: like the geometry, the mean model holds the runs' spread and no discrepancy term, so
/// it draws the sides at points whose sides are not given. `None` when some run kept none.
fn mean_backlash(errors: &[&JointErrors]) -> Option<crate::kinematics::Backlash> {
    let lashes: Vec<&crate::kinematics::Backlash> = errors
        .iter()
        .map(|e| e.backlash.as_ref())
        .collect::<Option<_>>()?;
    let n = lashes.first()?.gap_rad.len();
    if lashes.iter().any(|b| b.gap_rad.len() != n) {
        return None;
    }
    let runs = lashes.len() as f64;
    let gap_rad: Vec<f64> = (0..n)
        .map(|j| lashes.iter().map(|b| b.gap_rad[j]).sum::<f64>() / runs)
        .collect();
    let sigma_rad = (0..n)
        .map(|j| {
            let spread = if lashes.len() < 2 {
                0.0
            } else {
                (lashes
                    .iter()
                    .map(|b| (b.gap_rad[j] - gap_rad[j]).powi(2))
                    .sum::<f64>()
                    / (runs - 1.0))
                    .sqrt()
            };
            lashes.iter().map(|b| b.sigma_rad[j]).fold(spread, f64::max)
        })
        .collect();
    Some(crate::kinematics::Backlash {
        gap_rad,
        sigma_rad,
        sides_unknown: None,
    })
}

/// Accuracy at test poses of one model.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct RunAccuracy {
    /// The geometric model's errors.
    pub geometric: AccuracyStats,
    /// The full model's errors.
    pub full: AccuracyStats,
}

/// Before calibration, after the geometric one and with the full model, at the same test poses
/// of the true robot ([`accuracy_full`]).
#[derive(Clone, Debug, serde::Serialize)]
pub struct FullAccuracy {
    /// The nominal model's errors (before calibration).
    pub nominal: AccuracyStats,
    /// The mean models' errors.
    pub mean: RunAccuracy,
    /// Each run's own models' errors.
    pub runs: Vec<RunAccuracy>,
}

impl FullAccuracy {
    /// The share of the error before calibration (mean) the geometric mean model leaves.
    pub fn geometric_share(&self) -> f64 {
        self.mean.geometric.mean_mm / self.nominal.mean_mm
    }

    /// The share of the geometric mean model's error (mean) the full mean model leaves.
    pub fn full_share(&self) -> f64 {
        self.mean.full.mean_mm / self.mean.geometric.mean_mm
    }
}

/// The accuracy of `cal`'s mean models (independent σ) and of every run's own models at `n`
/// random test configurations in `bx` of the true robot, measured as
/// [`super::accuracy_check`] measures them for the same `seed` (so its figures for the same
/// model are these).
///
/// # Errors
///
/// [`SimulateError::Other`] when no `n` test configurations can be generated in `bx` or a
/// validation fails.
pub fn accuracy_full(
    exp: &Experiment,
    cal: &FullCalibration,
    n: usize,
    bx: &WorkspaceBox,
    seed: u64,
) -> Result<FullAccuracy, SimulateError> {
    let m = test_measurements(exp, n, bx, seed)?;
    let other = |e: crate::identify::IdentifyError| SimulateError::Other(e.to_string());
    let errors = |model: &RobotModel| validate(model, &m, None).map(|v| v.model);
    let mean = validate(&cal.full.independent, &m, Some(&exp.nominal)).map_err(other)?;
    let nominal = mean
        .nominal
        .map(|n| n.1)
        .ok_or_else(|| SimulateError::Other("no nominal errors".into()))?;
    let runs = cal
        .runs
        .iter()
        .map(|r| {
            Ok(RunAccuracy {
                geometric: errors(&r.geometric)?,
                full: errors(&r.full)?,
            })
        })
        .collect::<Result<_, _>>()
        .map_err(other)?;
    Ok(FullAccuracy {
        nominal,
        mean: RunAccuracy {
            geometric: errors(&cal.geometric.independent).map_err(other)?,
            full: mean.model,
        },
        runs,
    })
}
