//! Backlash in the fit beyond geometry (docs/METHOD.md §19.5): each joint stands half its gap
//! from the commanded angle on the side it arrived from, the sides those the data give (a pose
//! file's `s1..sn`) or else taken from the order of the poses. When the gaps predict new poses better, a model that keeps its joint errors keeps the
//! gaps too ([`super::ExtendedFit::backlash`]): the geometry is fitted to the angles corrected by
//! the known sides, and the analyses draw the side at each task point.

use super::{fit_over, loo_rms, ExtendedModel, Fitted, Inputs, PER_JOINT, PRIOR_RAD};
use crate::kinematics::{Backlash, Joints};
use serde::Serialize;

/// What a backlash per joint adds, the approach directions taken from the poses' order.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BacklashCheck {
    /// Leave-one-out RMS (3-D) with compliance, harmonics and backlash, mm.
    pub loo_rms_mm: f64,
    /// Whether it predicts better than compliance and harmonics alone (the same margin).
    pub predicts_better: bool,
    /// Per joint: the gap and its standard uncertainty, degrees.
    pub gap_deg: Vec<[f64; 2]>,
    /// Whether the sides are those the data give (a pose file's `s1..sn`) rather than taken
    /// from the poses' order.
    pub sides_given: bool,
    /// When the model keeps the gaps: the RMS of its residuals with each pose's side turned
    /// and at the centre of the gaps (the norms of its two discrepancy terms), mm.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub residual_rms_mm: Option<ResidualRms>,
    /// The fit with the gaps (their coefficients after the joints' `PER_JOINT` each).
    #[serde(skip)]
    pub(super) model: ExtendedModel,
}

/// The direction each joint arrived from at each configuration of `q` (−1, 0, +1): the one
/// the data give (`given[k]`, a pose file's `s1..sn`), else from the configurations' order (the
/// first: 0; any unit of angle).
pub(crate) fn approach_directions(q: &[Joints], given: &[Option<Joints>]) -> Vec<Joints> {
    (0..q.len())
        .map(|k| {
            if let Some(s) = given.get(k).copied().flatten() {
                return s;
            }
            Joints::from_fn(q[k].len(), |j| match k {
                0 => 0.0,
                _ => {
                    let d = q[k][j] - q[k - 1][j];
                    if d.abs() < 1e-9 {
                        0.0
                    } else {
                        d.signum()
                    }
                }
            })
        })
        .collect()
}

/// The fit of [`super::check`] with a backlash per joint added ([`BacklashCheck`]); `None` when no
/// joint arrived from both sides or the data cannot support it.
pub(super) fn backlash_check(
    run: &Fitted,
    fitted: &ExtendedModel,
    all: &Inputs<'_>,
    sigma: &[f64],
    loo_extended: f64,
) -> Option<BacklashCheck> {
    let n = fitted.links.joints();
    let q: Vec<Joints> = run.obs.iter().map(|o| o.q).collect();
    let given: Vec<Option<Joints>> = run.obs.iter().map(|o| o.sides).collect();
    let dirs = approach_directions(&q, &given);
    let both = (0..n).any(|j| dirs.iter().any(|d| d[j] > 0.0) && dirs.iter().any(|d| d[j] < 0.0));
    let free: Vec<usize> = all
        .free
        .iter()
        .copied()
        .chain((0..n).map(|j| PER_JOINT * n + j))
        .collect();
    if !both || 3 * run.obs.len() < 2 * free.len() {
        return None;
    }
    let sigma: Vec<f64> = sigma
        .iter()
        .copied()
        .chain((0..n).map(|_| PRIOR_RAD))
        .collect();
    let x = Inputs {
        free: &free,
        sigma: &sigma,
        dirs: Some(&dirs),
        ..*all
    };
    let mut start = fitted.clone();
    start.beta.extend(std::iter::repeat_n(0.0, n));
    let m = fit_over(&run.obs, start, &x);
    let (loo, cov) = loo_rms(&run.obs, &m, &x)?;
    let first = free.len() - n;
    Some(BacklashCheck {
        loo_rms_mm: loo,
        predicts_better: loo
            < (1.0 - crate::discrepancy::gp::required_gain(run.obs.len())) * loo_extended,
        gap_deg: (0..n)
            .map(|j| {
                [
                    m.beta[PER_JOINT * n + j].to_degrees(),
                    cov[(first + j, first + j)].max(0.0).sqrt().to_degrees(),
                ]
            })
            .collect(),
        sides_given: given.iter().any(Option::is_some),
        residual_rms_mm: None,
        model: m,
    })
}

/// The RMS of a kept backlash's two discrepancy terms' norms, mm ([`BacklashCheck`]).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ResidualRms {
    /// Each pose's side turned (the model's own term).
    pub sided: f64,
    /// At the centre of the gaps (the term for unknown sides).
    pub centre: f64,
}

/// The model and gaps a fit keeps of `check` (used when it keeps its joint errors): gaps that
/// predict better ride with the model, with the geometry and coefficients of the fit with them
/// (of `n` joints) and their σ; otherwise `fitted` and none. Only from poses checked one at a
/// time (`held_out` empty): along a sweep's arc every point arrives from the same side, so there
/// the gap is one more offset of the joint (on the paper's simulated sweeps a forced `keep`
/// with the gaps so fitted still predicted test poses 1.15× worse than the geometry).
pub(super) fn kept(
    check: Option<&BacklashCheck>,
    held_out: &[std::ops::Range<usize>],
    fitted: ExtendedModel,
    n: usize,
) -> (ExtendedModel, Option<Backlash>) {
    match check {
        Some(b) if b.predicts_better && held_out.is_empty() => {
            let mut m = b.model.clone();
            m.beta.truncate(PER_JOINT * n);
            let g = Backlash {
                gap_rad: b.gap_deg.iter().map(|g| g[0].to_radians()).collect(),
                sigma_rad: b.gap_deg.iter().map(|g| g[1].to_radians()).collect(),
                sides_unknown: None,
            };
            (m, Some(g))
        }
        _ => (fitted, None),
    }
}
