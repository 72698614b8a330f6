//! Backlash in the fit beyond geometry (docs/METHOD.md §19.5): each joint stands half its gap
//! from the commanded angle on the side it arrived from, the sides those the data give (a pose
//! file's `s1..sn`) or else taken from the order of the poses. When the gaps predict new poses better, a model that keeps its joint errors keeps the
//! gaps too ([`super::ExtendedFit::backlash`]): the geometry is fitted to the angles corrected by
//! the known sides, and the analyses draw the side at each task point.

use super::select::{Linearised, TermSelection};
use super::{
    fit_over, jacobian, loo_rms, moved, residuals, ExtendedModel, Fitted, Inputs, PER_JOINT,
    PRIOR_RAD,
};
use crate::identify::chain_fit::Observation;
use crate::kinematics::{Backlash, Joints};
use nalgebra::DVector;
use serde::Serialize;

/// What a backlash per joint adds, the approach directions taken from the poses' order.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BacklashCheck {
    /// Leave-one-out RMS (3-D) with compliance, harmonics and backlash, mm.
    pub loo_rms_mm: f64,
    /// Whether it predicts better than compliance and harmonics alone (the same margin).
    pub predicts_better: bool,
    /// Whether it predicts better than the geometry alone (the same margin): with
    /// [`Self::predicts_better`], a reason to keep the joint errors, which the gaps ride with,
    /// even where compliance and harmonics alone gain nothing (a robot whose hysteresis is
    /// most of what the geometry leaves).
    pub beats_geometry: bool,
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

/// What a fit with a gap per joint adds to its inputs: the direction each joint arrived from
/// at each observation, the gaps' coefficient indices (`PER_JOINT·n + j`) and the prior σ of
/// every coefficient, the gaps' ([`PRIOR_RAD`]) after the others'.
pub(super) struct Gaps {
    /// Per observation, the approach directions ([`approach_directions`]).
    pub dirs: Vec<Joints>,
    /// The gaps' coefficient indices.
    pub indices: Vec<usize>,
    /// Prior σ per coefficient index, the gaps' included.
    pub sigma: Vec<f64>,
}

impl Gaps {
    /// The gaps of `run`'s `n` joints with the other coefficients' prior σ `sigma`; `None`
    /// when no joint arrived from both sides or `3·poses < 2·(free + n)` (`free` the other
    /// free inputs: the data cannot support them).
    pub(super) fn of(run: &Fitted, n: usize, free: usize, sigma: &[f64]) -> Option<Gaps> {
        let q: Vec<Joints> = run.obs.iter().map(|o| o.q).collect();
        let given: Vec<Option<Joints>> = run.obs.iter().map(|o| o.sides).collect();
        let dirs = approach_directions(&q, &given);
        let both =
            (0..n).any(|j| dirs.iter().any(|d| d[j] > 0.0) && dirs.iter().any(|d| d[j] < 0.0));
        if !both || 3 * run.obs.len() < 2 * (free + n) {
            return None;
        }
        Some(Gaps {
            dirs,
            indices: (0..n).map(|j| PER_JOINT * n + j).collect(),
            sigma: sigma
                .iter()
                .copied()
                .chain((0..n).map(|_| PRIOR_RAD))
                .collect(),
        })
    }

    /// The terms the data need ([`super::select`]) judged in the fit with every candidate
    /// `extras` of `all` and these gaps, the gaps always kept, and that fit; `None` when it
    /// cannot be evaluated.
    pub(super) fn select(
        &self,
        run: &Fitted,
        fitted: &ExtendedModel,
        all: &Inputs<'_>,
        extras: &[usize],
    ) -> Option<(Vec<usize>, TermSelection, GapFit)> {
        let gaps = self;
        let geo = all.geo;
        let n = gaps.indices.len();
        let free: Vec<usize> = all.free[..geo]
            .iter()
            .chain(&gaps.indices)
            .chain(extras)
            .copied()
            .collect();
        let x = gaps.inputs(all, &free);
        // One Gauss–Newton step from `fitted` (converged without the gaps) with the gaps at zero:
        // the coefficients and gaps turn the joints by 1e-4–1e-3 rad, so the model is linear in
        // them to Δ²·L ≈ 4e-4 mm, and the step is the fit to that; the residuals at it follow
        // linearly, as the selection takes them anyway.
        let start = gaps.start(fitted);
        let (jac, r0) = jacobian(&run.obs, &start, &x);
        let r0 = DVector::from_column_slice(&r0);
        let jt = jac.transpose();
        let normal = (&jt * &jac).cholesky()?;
        let delta = normal.solve(&(&jt * &r0));
        let step: Vec<f64> = delta.iter().map(|v| -v).collect();
        let m = moved(&start, &free, geo, &step);
        let r = r0 - &jac * &delta;
        let (kept, selection) = Linearised {
            obs: &run.obs,
            jac: &jac,
            r: r.as_slice(),
            geo: geo + n,
            extras,
            beta: &m.beta,
        }
        .select(n)?;
        let rows = 3 * run.obs.len();
        let dof = rows.saturating_sub(free.len()).max(1) as f64;
        let noise = (r.rows(0, rows).norm_squared() / dof).sqrt();
        // The covariance with the observations whitened at this fit's own noise when smaller (as
        // the backlash fit is fitted), back in the first units (÷ s²): in the first units the
        // priors weigh more against the data than they do at the data's noise, and a weakly seen
        // coefficient's σ comes out too small.
        let covariance = if noise > 0.0 && noise < 1.0 {
            let obs = jac.rows(0, rows);
            let prior = jac.rows(rows, jac.nrows() - rows);
            let info = obs.transpose() * obs / (noise * noise) + prior.transpose() * prior;
            info.cholesky()?.inverse() / (noise * noise)
        } else {
            normal.inverse()
        };
        Some((
            kept,
            selection,
            GapFit {
                model: m,
                noise,
                covariance,
            },
        ))
    }

    /// The inputs of `all` with the free inputs `free` (the gaps' indices among them) and the
    /// gaps' directions and prior σ.
    pub(super) fn inputs<'a>(&'a self, all: &Inputs<'a>, free: &'a [usize]) -> Inputs<'a> {
        Inputs {
            free,
            sigma: &self.sigma,
            dirs: Some(&self.dirs),
            ..*all
        }
    }

    /// `fitted` with the gaps appended at zero: where a fit with them starts.
    pub(super) fn start(&self, fitted: &ExtendedModel) -> ExtendedModel {
        let mut m = fitted.clone();
        m.beta.extend(std::iter::repeat_n(0.0, self.indices.len()));
        m
    }
}

/// A fit with every candidate term and the gaps (the one the terms were chosen in): its model
/// and its noise in the units its observations are whitened in ([`noise_scale`]).
pub(super) struct GapFit {
    /// The geometry, every candidate's coefficient and the gaps.
    pub model: ExtendedModel,
    /// Its noise, whitened units.
    pub noise: f64,
    /// The covariance of its free inputs (the geometry's, the gaps', then every candidate's),
    /// whitened units.
    pub covariance: nalgebra::DMatrix<f64>,
}

impl GapFit {
    /// [`Self::covariance`] without the gaps' rows and columns: the geometry's `geo` inputs,
    /// then the `extras` candidates', as the fit without the gaps orders them.
    pub(super) fn without_gaps(&self, geo: usize, extras: usize) -> nalgebra::DMatrix<f64> {
        let n = self.covariance.nrows() - geo - extras;
        let keep: Vec<usize> = (0..geo).chain(geo + n..geo + n + extras).collect();
        self.covariance.select_rows(&keep).select_columns(&keep)
    }
}

/// The fit of [`super::check`] with a backlash per joint added ([`BacklashCheck`]), from the fit
/// the terms were chosen in (`prefit`: its dropped terms set to zero) when there is one; `None`
/// when no joint arrived from both sides or the data cannot support it.
pub(super) fn backlash_check(
    run: &Fitted,
    fitted: &ExtendedModel,
    all: &Inputs<'_>,
    sigma: &[f64],
    (loo_geometric, loo_extended): (f64, f64),
    prefit: Option<&GapFit>,
) -> Option<BacklashCheck> {
    let n = fitted.links.joints();
    let gaps = Gaps::of(run, n, all.free.len(), sigma)?;
    let free: Vec<usize> = all.free.iter().chain(&gaps.indices).copied().collect();
    let given = run.obs.iter().any(|o| o.sides.is_some());
    let x = gaps.inputs(all, &free);
    // The observations are whitened with the geometric fit's noise, which holds the lack of fit
    // the joint errors and the gaps explain: against it the priors hold weakly seen gaps (a
    // wrist joint's) towards zero, by more than their σ (simulated TX60s: 78 % of the gaps
    // within 1.96σ, all short). Fitted with the observations whitened at the fit's own noise
    // `s` (in those units; of the fit the terms were chosen in, else of this one) when that is
    // smaller, the priors weigh what they were meant to; the σ go back to the first units
    // (÷ s), which the caller scales to the data's noise.
    let (m, s) = match prefit {
        Some(p) => {
            let mut m = p.model.clone();
            for (i, b) in m.beta.iter_mut().enumerate().take(PER_JOINT * n) {
                if !all.free[all.geo..].contains(&i) {
                    *b = 0.0;
                }
            }
            (m, p.noise)
        }
        None => {
            let m = fit_over(&run.obs, gaps.start(fitted), &x);
            let s = noise_scale(&run.obs, &m, &x);
            (m, s)
        }
    };
    let rescaled: Vec<Observation>;
    let (obs, m, s) = if s > 0.0 && s < 1.0 {
        rescaled = run
            .obs
            .iter()
            .map(|o| Observation {
                whiten: o.whiten / s,
                ..*o
            })
            .collect();
        let m = fit_over(&rescaled, m, &x);
        (&rescaled[..], m, s)
    } else if prefit.is_some() {
        (&run.obs[..], fit_over(&run.obs, m, &x), 1.0)
    } else {
        (&run.obs[..], m, 1.0)
    };
    let (loo, cov) = loo_rms(obs, &m, &x)?;
    let first = free.len() - n;
    let margin = 1.0 - crate::discrepancy::gp::required_gain(run.obs.len());
    Some(BacklashCheck {
        loo_rms_mm: loo,
        predicts_better: loo < margin * loo_extended,
        beats_geometry: loo < margin * loo_geometric,
        gap_deg: (0..n)
            .map(|j| {
                [
                    m.beta[PER_JOINT * n + j].to_degrees(),
                    (cov[(first + j, first + j)].max(0.0).sqrt() / s).to_degrees(),
                ]
            })
            .collect(),
        sides_given: given,
        residual_rms_mm: None,
        model: m,
    })
}

/// The fit's noise in the units its observations are whitened in: `√(Σ r² / (3N − p))` of
/// their whitened residuals (the priors' rows left out), `p` the free inputs; 0 without degrees
/// of freedom.
pub(super) fn noise_scale(obs: &[Observation], m: &ExtendedModel, x: &Inputs<'_>) -> f64 {
    let r = residuals(obs, m, x);
    let dof = (3 * obs.len()).saturating_sub(x.free.len());
    if dof == 0 {
        return 0.0;
    }
    (r[..3 * obs.len()].iter().map(|v| v * v).sum::<f64>() / dof as f64).sqrt()
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
