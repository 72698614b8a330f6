//! The lack of fit of a finished whole-chain fit (docs/METHOD.md §18): each point's residual,
//! whitening and leverage handed to [`crate::discrepancy::LackOfFit`], which splits noise from
//! what the model does not explain, fits the compensation over the configurations, builds the
//! model's discrepancy term and runs the leave-one-out self-check.

use super::{ChainOptions, Fitted, NoiseReport, Observation};
use crate::discrepancy::{Configurations, FittedPoint, LackOfFit};
use crate::identify::chain_fit::{local_jacobian, position_residuals};
use nalgebra::{DMatrix, Matrix3};

/// The lack of fit of `run` with `linearised` = `(JᵀWJ + prior)⁻¹` over its free inputs
/// (whitened units; the placement's rotation as [`local_jacobian`] takes it) and the noise
/// check `noise`; without `self_check`, no leave-one-out self-check (an intermediate fit).
/// `extra` inputs fitted to the same data before `run` (the joint errors' coefficients and
/// gaps the angles were corrected by) shrink the residuals too: their leverage, spread evenly
/// over the observations (`extra / 3n` on each whitened coordinate), is added to each point's.
///
/// With several targets measured at each pose only the model's own target (the first) enters:
/// the discrepancy term and the compensation are the model target's, and a left-out
/// measurement must not keep its twins at the same pose in the fit of the self-check.
pub(super) fn lack_of_fit(
    run: &Fitted,
    linearised: &DMatrix<f64>,
    noise: &NoiseReport,
    opts: &ChainOptions,
    self_check: bool,
    extra: usize,
) -> LackOfFit {
    let mut points = fitted_points(run, &run.obs, linearised);
    if extra > 0 {
        let each = extra as f64 / (3 * run.obs.len()) as f64;
        for p in &mut points {
            p.leverage += Matrix3::identity() * each;
        }
    }
    let q_rad: Vec<Vec<f64>> = run
        .obs
        .iter()
        .filter(|o| o.target == 0)
        .map(|o| o.q.to_vec())
        .collect();
    let groups = model_target_ranges(&run.obs, &opts.held_out.ranges(run.obs.len()));
    let configurations = Configurations {
        q_rad: &q_rad,
        to_base: run.state.rotation().transpose(),
        groups: &groups,
    };
    LackOfFit::estimate_with(
        &points,
        opts.compensate.then_some(configurations),
        opts.noise.is_stated(),
        // σ from repeated measurements was estimated: the F test against the pure error
        opts.noise
            .pure_error_p_value(noise.chi2, noise.dof)
            .or(noise.p_value),
        opts.seed,
        self_check,
    )
}

/// The model target's points of `obs` (observations of `run`'s poses, one for one, perhaps at
/// other angles) at `run`'s state: residual, `run`'s whitening and leverage.
fn fitted_points(run: &Fitted, obs: &[Observation], linearised: &DMatrix<f64>) -> Vec<FittedPoint> {
    let j = local_jacobian(&run.obs, &run.state, &run.free);
    let plain = position_residuals(obs, &run.state);
    (run.obs.iter().zip(&plain).enumerate())
        .filter(|(_, (o, _))| o.target == 0)
        .map(|(i, (o, r))| {
            let ji = j.rows(3 * i, 3);
            let h = ji * linearised * ji.transpose();
            FittedPoint {
                // measured minus predicted (the compensation adds its mean to the prediction)
                residual_mm: [-r[0], -r[1], -r[2]],
                whiten: o.whiten,
                leverage: Matrix3::from_fn(|a, b| 0.5 * (h[(a, b)] + h[(b, a)])),
            }
        })
        .collect()
}

/// The discrepancy term of `run`'s fitted state at `obs`: its poses, one for one, at other
/// angles (the prediction that does not know the backlash's sides), with `run`'s whitening and
/// leverage, no compensation; the noise `stated` or not. `None` with too few points for a term.
pub(super) fn term_at(
    run: &Fitted,
    linearised: &DMatrix<f64>,
    obs: &[Observation],
    stated: bool,
    seed: u64,
) -> Option<crate::discrepancy::Discrepancy> {
    let points = fitted_points(run, obs, linearised);
    LackOfFit::estimate_with(&points, None, stated, None, seed, false).term
}

/// `ranges` of observation indices as ranges of the model target's points (those with
/// `target == 0`, numbered in order); ranges left without such a point are dropped.
fn model_target_ranges(
    obs: &[Observation],
    ranges: &[std::ops::Range<usize>],
) -> Vec<std::ops::Range<usize>> {
    let mut before = Vec::with_capacity(obs.len() + 1);
    let mut count = 0;
    for o in obs {
        before.push(count);
        count += usize::from(o.target == 0);
    }
    before.push(count);
    ranges
        .iter()
        .map(|r| before[r.start.min(obs.len())]..before[r.end.min(obs.len())])
        .filter(|r| !r.is_empty())
        .collect()
}
