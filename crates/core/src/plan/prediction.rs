//! The engine's Monte Carlo of a planned model at the task points: the prediction a plan reports
//! beside its linearised figures.

use super::geometry::quantile;
use super::{setting, Plan, PlanError, PlanField, Prediction};
use crate::engine::{Evaluator, Problem, Reference};
use crate::kinematics::Joints;
use crate::mc::stats::Reliability;
use crate::progress::ProgressHook;
use rayon::prelude::*;

/// Draws per evaluation call of the prediction.
const PREDICTION_CHUNK: usize = 1 << 16;

/// Adds to `e` the bytes [`predict`] keeps for `draws` draws at `points` task points: every
/// draw's w, and a chunk's per-point errors in its buffer and the evaluator's.
pub fn prediction_estimate(
    points: usize,
    draws: usize,
    e: crate::memory::Estimate,
) -> crate::memory::Estimate {
    e.plus(&[draws as u64, 8])
        .plus(&[PREDICTION_CHUNK.min(draws) as u64, points as u64, 2 * 8])
}

/// The engine's Monte Carlo of the planned model ([`Plan::model`]) at the task points:
/// `draws` draws on `ev` (an evaluator of that model's problem), R(L) at `thresholds`.
///
/// # Errors
///
/// [`PlanError::Engine`] when the evaluator fails; [`PlanError::Setting`] for no draws.
pub fn predict(
    ev: &mut dyn Evaluator,
    draws: usize,
    thresholds: &[f64],
) -> Result<Prediction, PlanError> {
    predict_with_progress(ev, draws, thresholds, &ProgressHook::none())
}

/// [`predict`], telling `progress` the draws done of `draws` chunk by chunk.
///
/// # Errors
///
/// As [`predict`].
pub fn predict_with_progress(
    ev: &mut dyn Evaluator,
    draws: usize,
    thresholds: &[f64],
    progress: &ProgressHook,
) -> Result<Prediction, PlanError> {
    if draws < 100 {
        return Err(setting(
            PlanField::Search,
            format!("the prediction needs at least 100 draws, got {draws}"),
        ));
    }
    let m = ev.n_points();
    let mut w = vec![0.0; draws];
    // Per-point errors chunk by chunk (one chunk's m errors a draw kept at a time).
    let chunk = PREDICTION_CHUNK.min(draws);
    let mut e = vec![0.0; chunk * m];
    let mut below = vec![0u64; m * thresholds.len()];
    let mut first = 0;
    while first < draws {
        progress.report("draws", first as u64, draws as u64);
        let n = chunk.min(draws - first);
        ev.evaluate(
            first as u64,
            &mut w[first..first + n],
            Some(&mut e[..n * m]),
        )?;
        for row in e[..n * m].chunks(m) {
            for (j, x) in row.iter().enumerate() {
                for (t, l) in thresholds.iter().enumerate() {
                    below[j * thresholds.len() + t] += u64::from(x < l);
                }
            }
        }
        first += n;
    }
    progress.report("draws", draws as u64, draws as u64);
    w.par_sort_unstable_by(f64::total_cmp);
    let per_point = (0..m)
        .map(|j| {
            thresholds
                .iter()
                .enumerate()
                .map(|(t, &l)| {
                    Reliability::from_count(l, below[j * thresholds.len() + t], draws as u64)
                })
                .collect()
        })
        .collect();
    Ok(Prediction {
        draws,
        reliability: thresholds
            .iter()
            .map(|&t| Reliability::from_sorted(t, &w))
            .collect(),
        q95_mm: quantile(&w, 0.95),
        mean_mm: w.iter().sum::<f64>() / draws as f64,
        per_point,
        backend: ev.info(),
    })
}

/// The model to plan from, as an analysis of `problem` takes it: its discrepancy term (an
/// identified model of the robot carries one) stays when the problem draws it, and is left out
/// when the analysis was asked to leave it out.
pub fn model_to_plan(problem: &Problem) -> crate::kinematics::RobotModel {
    let mut model = problem.model.clone();
    if problem.discrepancy.is_none() {
        model.discrepancy = None;
    }
    model
}

/// The problem [`predict`] evaluates: the planned model at the task points.
///
/// # Errors
///
/// [`PlanError::Problem`] when the problem cannot be built.
pub fn prediction_problem(plan: &Plan, task: &[Joints], seed: u64) -> Result<Problem, PlanError> {
    Problem::new(plan.model(), task, &Reference::Calibrated, seed).map_err(|e| match e {
        // The design's covariance scales with σ²: a σ so large that the planned model's
        // uncertainty is beyond what a model holds is the noise's fault, not the model's.
        crate::engine::ProblemError::Model { field, message, .. } => PlanError::Setting {
            field: super::PlanField::Sigma,
            message: format!(
                "{} mm gives the planned model an uncertainty beyond what a model holds ({field}: {message}): state a smaller σ, or plan more poses",
                crate::number::fmt_plain(plan.sigma_mm)
            ),
        },
        e => e.into(),
    })
}
