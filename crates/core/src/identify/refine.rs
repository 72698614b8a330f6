//! Whole-chain least-squares refinement of a circle-point identification.
//!
//! The circle-point method uses each sweep only for its axis line; the radius, height and phase
//! of every circle (where the target is relative to that axis, which the rest of the chain
//! predicts) and the fact that every sweep passes the same home-pose target are thrown away.
//! This step keeps the circle-point result as the start and minimises
//! `Σ_k ‖P(params, q_k) − p_k‖²` over all points of all sweeps of the run, at the commanded
//! angles, by Levenberg–Marquardt over the identifiable parameters: θ, a, α of joints 1 to
//! n − 1, `d` where β is fixed, β where `d` is fixed, and the tool point (the last joint's
//! parameters stay nominal, J1's axis stays base z, as in [`super::mdh`]). It is the
//! maximum-likelihood estimate for isotropic tracker noise given the same data and conventions.

use super::lm::levenberg_marquardt;
use super::sweeps::SweepRun;
use crate::kinematics::{param_index, position, FixedParam, Joints, ParamKind, Params};

/// The parameters the refinement adjusts: `(joint (0-based), kind)` in storage order.
fn refined(fixed: &[FixedParam]) -> Vec<(usize, ParamKind)> {
    fixed
        .iter()
        .enumerate()
        .take(fixed.len().saturating_sub(1))
        .flat_map(|(j, f)| {
            ParamKind::ALL
                .into_iter()
                .filter(move |&kind| kind != f.kind())
                .map(move |kind| (j, kind))
        })
        .collect()
}

/// Indices (into the `5n` parameters, one [`FixedParam`] per joint in `fixed`) of the parameters
/// the refinement adjusts.
pub fn refined_params(fixed: &[FixedParam]) -> Vec<usize> {
    refined(fixed)
        .into_iter()
        .map(|(j, kind)| param_index(j, kind))
        .collect()
}

/// `P(params, q_k) − p_k` for every point, x, y, z in turn. A function of its own (not inlined
/// into the solver) so that the forward kinematics is inlined here and the sines and cosines of the
/// parameters, the same for every point, are computed once per call.
#[inline(never)]
fn point_residuals(params: &[f64], tool: &[f64; 3], points: &[(Joints, [f64; 3])]) -> Vec<f64> {
    let mut r = Vec::with_capacity(3 * points.len());
    for (q, p) in points {
        let x = position(params, tool, q);
        r.extend_from_slice(&[x[0] - p[0], x[1] - p[1], x[2] - p[2]]);
    }
    r
}

/// Refines `params` and `tool` against every point of `run`; returns the refined pair and the
/// RMS point residual (mm) after refinement.
///
/// With `prior = Some((nominal, length_sigma_mm, angle_sigma_rad))` every refined parameter is
/// also pulled towards its nominal value with that σ (pseudo-observations weighted by the tracker
/// noise estimated from the unregularised fit, as in [`super::circle::AxisPrior`]): on short arcs
/// the data leave some combinations almost free and the nominal geometry is then the better guess.
pub fn refine_chain(
    run: &SweepRun,
    params: &[f64],
    fixed: &[FixedParam],
    tool: &[f64; 3],
    prior: Option<(&[f64], f64, f64)>,
) -> (Params, [f64; 3], f64) {
    let kinds = refined(fixed);
    let free = refined_params(fixed);
    let points: Vec<(Joints, [f64; 3])> = run
        .sweeps
        .iter()
        .flat_map(|s| s.points.iter())
        .map(|p| (p.q_deg.map(f64::to_radians), p.position_mm))
        .collect();
    type State = (Params, [f64; 3]);
    let residuals = |s: &State| point_residuals(&s.0, &s.1, &points);
    let apply = |s: &State, d: &[f64]| -> State {
        let mut n = *s;
        for (k, &i) in free.iter().enumerate() {
            n.0[i] += d[k];
        }
        for k in 0..3 {
            n.1[k] += d[free.len() + k];
        }
        n
    };
    let mut steps: Vec<f64> = kinds
        .iter()
        .map(|&(_, kind)| if kind.is_angle() { 1e-8 } else { 1e-5 })
        .collect();
    steps.extend_from_slice(&[1e-5; 3]);
    let mut s = levenberg_marquardt(
        (Params::from_slice(params), *tool),
        &steps,
        apply,
        residuals,
    );
    if let Some((nominal, length_sigma, angle_sigma)) = prior {
        let r = residuals(&s);
        let dof = r.len().saturating_sub(steps.len()).max(1) as f64;
        let noise = (r.iter().map(|v| v * v).sum::<f64>() / dof).sqrt();
        let weights: Vec<f64> = kinds
            .iter()
            .map(|&(_, kind)| {
                let sigma = if kind.is_angle() {
                    angle_sigma
                } else {
                    length_sigma
                };
                noise / sigma
            })
            .collect();
        let regularised = |st: &State| -> Vec<f64> {
            let mut r = residuals(st);
            for (k, &i) in free.iter().enumerate() {
                r.push(weights[k] * (st.0[i] - nominal[i]));
            }
            r
        };
        if weights.iter().all(|w| w.is_finite()) {
            s = levenberg_marquardt(
                (Params::from_slice(params), *tool),
                &steps,
                apply,
                regularised,
            );
        }
    }
    let r = residuals(&s);
    let rms = (r.iter().map(|v| v * v).sum::<f64>() / (r.len().max(3) / 3) as f64).sqrt();
    (s.0, s.1, rms)
}
