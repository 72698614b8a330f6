//! Runs the factor study: for every factor level, a repeated calibration of the virtual TX60
//! ([`crate::simulate::calibrate()`]), the accuracy before/after calibration, then for each number
//! of test points MCS, AMCS at every δ with independent σ (the paper's assumption) and AMCS at the
//! first δ with the full covariance of the identified parameters (what the paper could not show).

use super::ranking::{rank, ParameterRanking};
use super::settings::{Factor, StudySettings};
use crate::engine::backend::Backends;
use crate::engine::{Problem, Reference};
use crate::kinematics::{param_kind, Joints, RobotModel};
use crate::mc::sensitivity::{run_sensitivity, SensitivityOptions};
use crate::mc::stats::{ecdf_grid, histogram};
use crate::mc::{
    run_amcs, run_mcs, AmcsOptions, BatchTrace, McResult, McsOptions, RunSettings, Tolerance,
};
use crate::points;
use crate::report::max_relative_error;
use crate::simulate::{accuracy_check, calibrate, Experiment, Factors, SimulateError};
use serde::Serialize;

/// Errors of the study.
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    /// A setting or a calibration failed. (Causes are `source()`s, not part of the messages, so
    /// a chain printer shows each once.)
    #[error(transparent)]
    Simulate(#[from] SimulateError),
    /// Test points could not be generated.
    #[error("test points")]
    Points(#[from] crate::points::PointsError),
    /// The problem could not be set up (e.g. a covariance without Cholesky factor).
    #[error("{context}")]
    Problem {
        /// Which level.
        context: String,
        /// Why.
        source: crate::engine::ProblemError,
    },
    /// The backend failed.
    #[error("backend")]
    Engine(#[from] crate::engine::EngineError),
    /// A Monte Carlo run failed.
    #[error(transparent)]
    Mc(#[from] crate::mc::McError),
    /// The Sobol indices of the baseline calibration failed.
    #[error(transparent)]
    Sensitivity(#[from] crate::mc::sensitivity::SensitivityError),
    /// Writing the outputs failed.
    #[error(transparent)]
    Report(#[from] crate::report::ReportError),
}

/// What one Monte Carlo run gave (the curves for the figures are kept, the draws are not).
#[derive(Clone, Debug, Serialize)]
pub struct RunSummary {
    /// `"MCS"`, `"AMCS-1"`, `"AMCS-2"`, `"AMCS-1 cov"`.
    pub label: String,
    /// δ for AMCS, mm.
    pub delta: Option<f64>,
    /// Draws made.
    pub draws: u64,
    /// Wall time, seconds.
    pub seconds: f64,
    /// AMCS stopping rule met.
    pub converged: bool,
    /// M1–M4 (mean mm, variance mm², skewness, kurtosis).
    pub moments: [f64; 4],
    /// R_c at each threshold.
    pub reliability: Vec<f64>,
    /// 95 % coverage interval of w, mm.
    pub coverage_interval: [f64; 2],
    /// Maximum relative error of M1–M4 against the MCS of the same level, %.
    pub mre_percent: Option<f64>,
    /// AMCS batch trace (convergence of the fluctuation indices).
    pub trace: Vec<BatchTrace>,
    /// PDF of w: (bin centre, density).
    #[serde(skip)]
    pub pdf: Vec<(f64, f64)>,
    /// Reliability curve: (l_c, R_c).
    #[serde(skip)]
    pub cdf: Vec<(f64, f64)>,
}

impl RunSummary {
    fn of(label: &str, delta: Option<f64>, r: &McResult, base: Option<&McResult>) -> Self {
        RunSummary {
            label: label.into(),
            delta,
            draws: r.draws,
            seconds: r.seconds,
            converged: r.converged,
            moments: r.moments.as_array(),
            reliability: r.reliability.iter().map(|x| x.r).collect(),
            coverage_interval: [r.coverage_interval.low, r.coverage_interval.high],
            mre_percent: base.map(|b| max_relative_error(r, b)),
            trace: r.trace.clone(),
            pdf: histogram(&r.sorted_values, 80),
            cdf: ecdf_grid(&r.sorted_values, 300),
        }
    }
}

/// The Monte Carlo results of one level for one number of test points.
#[derive(Clone, Debug, Serialize)]
pub struct PointsResult {
    /// Number of test points m.
    pub points: usize,
    /// MCS with independent σ.
    pub mcs: RunSummary,
    /// AMCS at each δ, independent σ.
    pub amcs: Vec<RunSummary>,
    /// AMCS at the first δ with the full covariance.
    pub amcs_covariance: RunSummary,
}

/// One factor level.
#[derive(Clone, Debug, Serialize)]
pub struct LevelResult {
    /// The factor varied.
    pub factor: Factor,
    /// The level's label.
    pub level: String,
    /// All five factors of this level.
    pub factors: Factors,
    /// Wall time of the R simulated calibrations, seconds.
    pub calibration_seconds: f64,
    /// σ of each of the `5n` parameters (file units: deg for θ, α, β; mm for d, a),
    /// joint-major (30 for the six-joint TX60).
    pub sigma: Vec<f64>,
    /// Mean |correlation| between pairs of free parameters.
    pub mean_abs_correlation: f64,
    /// Mean positioning error of the nominal model on the check points, mm.
    pub accuracy_before_mm: f64,
    /// Mean positioning error of the calibrated model on the check points, mm.
    pub accuracy_after_mm: f64,
    /// Results per number of test points.
    pub points: Vec<PointsResult>,
}

/// The whole study.
#[derive(Clone, Debug, Serialize)]
pub struct StudyResult {
    /// Settings used.
    pub settings: StudySettings,
    /// The simulated true robot's name.
    pub robot: String,
    /// Backend notes.
    pub notes: Vec<String>,
    /// One entry per level, factors in order.
    pub levels: Vec<LevelResult>,
    /// The parameters ranked by their Sobol indices at the baseline calibration, and what each
    /// factor's levels did to the top ones' σ.
    pub ranking: ParameterRanking,
    /// The robots with joint errors ([`super::beyond`]), when the settings ask for them.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub beyond_geometry: Vec<super::beyond::BeyondRow>,
    /// Total wall time, seconds.
    pub seconds: f64,
}

/// Progress callback: `(steps done, total steps, what is running)`.
pub type StudyProgress<'a> = &'a (dyn Fn(u64, u64, &str) + Sync);

fn mean_abs_correlation(m: &RobotModel) -> f64 {
    let crate::kinematics::Uncertainty::Covariance(_) = &m.uncertainty else {
        return 0.0;
    };
    let free = m.free_params();
    let (mut s, mut n) = (0.0, 0.0);
    for (a, &i) in free.iter().enumerate() {
        for &k in &free[a + 1..] {
            let r = m.uncertainty.entry(i, k)
                / (m.uncertainty.entry(i, i) * m.uncertainty.entry(k, k)).sqrt();
            s += r.abs();
            n += 1.0;
        }
    }
    if n > 0.0 {
        s / n
    } else {
        0.0
    }
}

/// Runs the study on the TX60 experiment of `settings.robot_seed`.
///
/// # Errors
///
/// As [`run_study_on`].
pub fn run_study(
    settings: &StudySettings,
    backends: &dyn Backends,
    progress: Option<StudyProgress>,
) -> Result<StudyResult, StudyError> {
    run_study_on(
        &Experiment::tx60(settings.robot_seed),
        settings,
        backends,
        progress,
    )
}

/// Runs the study on a given experiment (true robot, tracker, error model).
///
/// # Errors
///
/// [`StudyError::Simulate`] for settings out of range or a failing simulated calibration,
/// [`StudyError::Points`] when test points cannot be generated, [`StudyError::Problem`] when a
/// calibrated model and its points do not make a problem, [`StudyError::Engine`] when no evaluator
/// can be made, and [`StudyError::Mc`] or [`StudyError::Sensitivity`] when a Monte Carlo run or the
/// sensitivity analysis fails.
pub fn run_study_on(
    exp: &Experiment,
    settings: &StudySettings,
    backends: &dyn Backends,
    progress: Option<StudyProgress>,
) -> Result<StudyResult, StudyError> {
    settings.check()?;
    let t0 = std::time::Instant::now();
    let levels = settings.levels();
    for (_, _, f) in &levels {
        f.check()?;
    }
    let per_level = 1 + settings.point_counts.len() as u64 * (2 + settings.deltas.len() as u64);
    let beyond_steps = settings
        .joint_errors
        .as_ref()
        .map_or(0, |j| 2 * j.sizes.len() as u64);
    let total = levels.len() as u64 * per_level + 1 + beyond_steps;
    let mut done = 0u64;
    let tick = |done: &mut u64, msg: &str| {
        if let Some(p) = progress {
            p(*done, total, msg);
        }
        *done += 1;
    };
    // Test points: the same for every level, generated on the design model.
    let point_sets = settings
        .point_counts
        .iter()
        .map(|&m| points::generate(&exp.nominal, m, &settings.workspace, settings.points_seed))
        .collect::<Result<Vec<_>, _>>()?;
    let run_settings = RunSettings {
        thresholds: settings.thresholds.clone(),
        ..RunSettings::default()
    };
    let mut notes = Vec::new();
    let mut out = Vec::with_capacity(levels.len());
    let mut baseline = None;
    for (factor, label, f) in levels {
        let name = format!("{} {label}", factor.name());
        tick(&mut done, &format!("{name}: calibrating ({} runs)", f.runs));
        let cal = calibrate(exp, &f, settings.calibration_seed)?;
        if f == settings.baseline && baseline.is_none() {
            baseline = Some(cal.independent.clone());
        }
        let acc = accuracy_check(
            exp,
            &cal.independent,
            settings.accuracy_points,
            &settings.workspace,
            settings.points_seed + 1,
        )?;
        let sig = cal.independent.param_sigmas();
        let mut results = Vec::new();
        let amcs_options = |d: f64| AmcsOptions {
            tolerance: Tolerance::Delta(d),
            batch_size: settings.batch,
            settings: run_settings.clone(),
            ..AmcsOptions::default()
        };
        for pts in &point_sets {
            let m = pts.len();
            let problem = |model: &RobotModel| {
                Problem::new(model.clone(), pts, &Reference::Calibrated, settings.mc_seed).map_err(
                    |source| StudyError::Problem {
                        context: name.clone(),
                        source,
                    },
                )
            };
            tick(&mut done, &format!("{name}, {m} points: MCS"));
            let (mut ev, note) = backends.make_evaluator(
                problem(&cal.independent)?,
                settings.backend,
                settings.adapter.as_deref(),
            )?;
            if let Some(n) = note {
                if !notes.contains(&n) {
                    notes.push(n);
                }
            }
            let mcs = run_mcs(
                ev.as_mut(),
                &McsOptions {
                    draws: settings.mcs_draws,
                    chunk: 100_000.min(settings.mcs_draws),
                    settings: run_settings.clone(),
                },
                None,
            )?;
            let mut amcs = Vec::new();
            for (k, &d) in settings.deltas.iter().enumerate() {
                tick(&mut done, &format!("{name}, {m} points: AMCS δ={d}"));
                let r = run_amcs(ev.as_mut(), &amcs_options(d), None)?;
                amcs.push(RunSummary::of(
                    &format!("AMCS-{}", k + 1),
                    Some(d),
                    &r,
                    Some(&mcs),
                ));
            }
            tick(
                &mut done,
                &format!("{name}, {m} points: AMCS with covariance"),
            );
            let (mut ev_c, _) = backends.make_evaluator(
                problem(&cal.correlated)?,
                settings.backend,
                settings.adapter.as_deref(),
            )?;
            let d = settings.deltas[0];
            let rc = run_amcs(ev_c.as_mut(), &amcs_options(d), None)?;
            results.push(PointsResult {
                points: m,
                mcs: RunSummary::of("MCS", None, &mcs, None),
                amcs,
                amcs_covariance: RunSummary::of("AMCS-1 cov", Some(d), &rc, Some(&mcs)),
            });
        }
        out.push(LevelResult {
            factor,
            level: label,
            factors: f,
            calibration_seconds: cal.seconds,
            sigma: (0..sig.len())
                .map(|i| sig[i] / param_kind(i).to_internal())
                .collect(),
            mean_abs_correlation: mean_abs_correlation(&cal.correlated),
            accuracy_before_mm: acc.nominal.as_ref().map_or(f64::NAN, |n| n.1.mean_mm),
            accuracy_after_mm: acc.model.mean_mm,
            points: results,
        });
    }
    tick(&mut done, "baseline: Sobol indices");
    let baseline = match baseline {
        Some(m) => m,
        // No level is the baseline (e.g. only the runs factor, at other counts): calibrate it.
        None => calibrate(exp, &settings.baseline, settings.calibration_seed)?.independent,
    };
    let ranking = baseline_ranking(settings, backends, &baseline, &point_sets, &out)?;
    let beyond_geometry = match &settings.joint_errors {
        Some(js) => super::beyond::run(exp, settings, js, &mut |m: &str| tick(&mut done, m))?,
        None => Vec::new(),
    };
    if let Some(p) = progress {
        p(total, total, "done");
    }
    Ok(StudyResult {
        settings: settings.clone(),
        robot: exp.truth.name.clone(),
        notes,
        levels: out,
        ranking,
        beyond_geometry,
        seconds: t0.elapsed().as_secs_f64(),
    })
}

/// Sobol indices of `w` for the baseline calibration at the largest point set, and the
/// factor levels' effect on the top parameters ([`super::ranking`]).
fn baseline_ranking(
    settings: &StudySettings,
    backends: &dyn Backends,
    model: &RobotModel,
    point_sets: &[Vec<Joints>],
    levels: &[LevelResult],
) -> Result<ParameterRanking, StudyError> {
    let pts = point_sets
        .iter()
        .max_by_key(|p| p.len())
        .map_or(&[][..], |p| &p[..]);
    let problem = Problem::new(model.clone(), pts, &Reference::Calibrated, settings.mc_seed)
        .map_err(|source| StudyError::Problem {
            context: "baseline ranking".into(),
            source,
        })?;
    let (mut ev, _) = backends.make_evaluator(
        problem.clone(),
        settings.backend,
        settings.adapter.as_deref(),
    )?;
    let opts = SensitivityOptions {
        draws: settings.sensitivity_draws,
        ..SensitivityOptions::default()
    };
    let sens = run_sensitivity(&problem, ev.as_mut(), &opts)?;
    let sig = model.param_sigmas();
    let sigma: Vec<f64> = (0..sig.len())
        .map(|i| sig[i] / param_kind(i).to_internal())
        .collect();
    Ok(rank(sens, &sigma, levels))
}
