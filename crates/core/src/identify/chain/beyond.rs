//! Beyond geometry (issue 33, first step): would joint compliance under gravity and gear
//! harmonics predict the robot better than its geometry alone?
//!
//! The extended model lets each joint stand at `q_i + Δθ_i(q)` when commanded to `q_i`, with
//!
//! * gear harmonics `h_i = a_i1 sin q_i + b_i1 cos q_i + a_i2 sin 2q_i + b_i2 cos 2q_i`;
//! * joint compliance `k_i · τ_i(q + h)`, `τ_i` the gravity torque about joint i's axis of the
//!   links beyond it ([`crate::kinematics::gravity`]: the default link masses, gravity along −z of
//!   the robot's base frame, no payload);
//!
//! and fits `k_i, a_i1, b_i1, a_i2, b_i2` together with the geometry's free inputs by
//! Levenberg–Marquardt from the geometric solution, with a zero-mean prior on each so that a
//! joint that moved little does not give wild coefficients: σ [`PRIOR_RAD`] on each harmonic
//! coefficient and on the compliance's deflection at the joint's RMS torque over the poses
//! (`σ_k = PRIOR_RAD / τ_rms,i`, which does not depend on the assumed masses' scale). Compliance is fitted only for joints whose torque varies over the poses
//! (a vertical first axis carries none).
//!
//! Per joint the data then choose the terms ([`select`], by Akaike's criterion: a compliance,
//! the harmonic orders 1..m) unless the orders are set, and the model is fitted again with those alone.
//!
//! Both models are judged by their leave-one-out prediction error, `W⁻¹ (I − H_ii)⁻¹ W r_i` per
//! point (exact for a linear model, the linearisation at the solution otherwise; `H_ii` the
//! point's leverage block): the RMS a new pose would show. The check reports both.

use super::Fitted;
use crate::identify::chain_fit::{ChainState, Observation, Prior};
use crate::identify::lm::levenberg_marquardt;
use crate::kinematics::gravity::{gravity_torques, LinkMasses};
use crate::kinematics::joint_errors::PointTerms;
use crate::kinematics::{Backlash, JointErrors, Joints, Payload, RobotModel};
mod backlash;
mod held_out;
mod kept_errors;
pub(crate) use kept_errors::most_common_payload;
mod select;
mod separated;

pub(crate) use backlash::approach_directions;
use backlash::backlash_check;
pub use backlash::{BacklashCheck, ResidualRms};
pub use held_out::HeldOut;
use nalgebra::{DMatrix, Vector3};
use select::loo_linear;
pub use select::{Term, TermScore, TermSelection};
use separated::undetermined;
use serde::Serialize;

/// Coefficients per joint: `k, a1, b1, a2, b2`.
const PER_JOINT: usize = 5;

/// σ of the zero-mean prior on a harmonic coefficient and on a joint's compliance deflection at
/// its RMS torque, rad (0.05°; a 60 kg-class arm has harmonics of 0.002–0.01° and deflections of
/// 0.01°, the public data sets' arms 0.02–0.1°).
pub const PRIOR_RAD: f64 = 0.05 * std::f64::consts::PI / 180.0;

/// A joint's compliance is fitted when the RMS of its gravity torque over the poses is at least
/// this share of the largest joint's.
const TORQUE_SHARE: f64 = 0.01;

/// The check's report.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BeyondGeometry {
    /// Coefficients fitted beyond the geometry.
    pub parameters: usize,
    /// What the leave-out RMS values leave out at a time: "each point", or the arcs of each
    /// sweep ([`crate::identify::HeldOut`]).
    pub left_out: String,
    /// Leave-one-out RMS (3-D) of the geometric model, mm.
    pub loo_rms_geometric_mm: f64,
    /// Leave-one-out RMS (3-D) with compliance and harmonics, mm.
    pub loo_rms_extended_mm: f64,
    /// Whether the extended model predicts new poses better by the compensation's margin
    /// ([`crate::discrepancy::gp::required_gain`]).
    pub predicts_better: bool,
    /// Whether the identified model carries the joint errors (it does when they predict better;
    /// the geometry is then fitted again to the corrected joint angles).
    pub kept: bool,
    /// Per joint: the fitted compliance and its standard uncertainty, µrad/(N·m) (`None`: not
    /// fitted, the joint's torque does not vary).
    pub compliance_urad_per_nm: Vec<Option<[f64; 2]>>,
    /// Per joint: amplitudes of the first and second harmonic, degrees.
    pub harmonic_amplitudes_deg: Vec<[f64; 2]>,
    /// The link masses the torques assume, kg.
    pub link_mass_kg: Vec<f64>,
    /// The payloads the poses were measured with, kg, ascending (the data's `payload_kg`
    /// column; `[0]` without it). Two or more let the fit tell compliance from what merely
    /// follows the joint angles (a harmonic of the same shape as a link's torque).
    pub calibration_payloads_kg: Vec<f64>,
    /// RMS over the poses of the fitted joint deflections, degrees, per joint.
    pub deflection_rms_deg: Vec<f64>,
    /// The coefficients these data do not determine, one line each: held by their prior (a
    /// posterior σ above [`PRIOR_HELD`] of the prior's), or not separated from another input
    /// (a correlation beyond ±[`CONFOUNDED`]: a harmonic of a joint that hardly moved against
    /// its offset, a first harmonic of q1 against the placement).
    pub undetermined: Vec<String>,
    /// Which terms the model has per joint, and the leave-one-out figures that chose them.
    pub selection: TermSelection,
    /// The backlash check, when asked for and the poses' order gives the joints both
    /// directions.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub backlash: Option<BacklashCheck>,
    /// The data record approach sides (`s1..sn`) but the backlash check was not asked for.
    pub sides_unchecked: bool,
}

/// A coefficient whose posterior σ exceeds this share of its prior's is held by the prior.
pub const PRIOR_HELD: f64 = 0.7;

/// A coefficient correlated beyond this with another free input is not separated from it.
pub const CONFOUNDED: f64 = 0.95;

impl BeyondGeometry {
    /// Whether a model that keeps joint errors when they predict better keeps them: they do
    /// ([`Self::predicts_better`]), or with them the backlash gaps do, against the geometry
    /// alone too ([`BacklashCheck::beats_geometry`]).
    pub fn worth_keeping(&self) -> bool {
        self.predicts_better || self.gaps_carry()
    }

    /// Whether the backlash gaps predict better than both the joint errors and the geometry
    /// alone.
    fn gaps_carry(&self) -> bool {
        self.backlash
            .as_ref()
            .is_some_and(|b| b.predicts_better && b.beats_geometry)
    }

    /// One paragraph for the report.
    pub fn sentence(&self) -> String {
        let change = 100.0 * (self.loo_rms_extended_mm / self.loo_rms_geometric_mm - 1.0);
        let left_out = match self.left_out.as_str() {
            "each point" => String::new(),
            groups => format!(" ({groups} left out in turn)"),
        };
        format!(
            "Beyond geometry: with joint compliance under gravity and gear harmonics ({} more coefficients) the leave-one-out RMS{left_out} is {:.4} mm against {:.4} mm for the geometry alone ({change:+.0} %): {}.",
            self.parameters,
            self.loo_rms_extended_mm,
            self.loo_rms_geometric_mm,
            match (self.predicts_better, self.kept) {
                (true, true) => "the robot shows errors of these kinds, and the model carries them (geometry fitted again to the corrected joint angles; every analysis draws them)",
                (false, true) if self.gaps_carry() => "no gain from these terms alone, but with the backlash gaps below the model predicts better than the geometry alone, so it carries them with the gaps (geometry fitted again to the corrected joint angles; every analysis draws them)",
                (true, false) => "the robot shows errors of these kinds, but the model carries the geometry alone (a check only; several runs' mean model holds no joint errors: identify one run to keep them)",
                (false, true) => "no gain worth the coefficients, but the model carries them as asked (geometry fitted again to the corrected joint angles; every analysis draws them)",
                _ => "no gain worth the coefficients; the model carries the geometry alone",
            }
        )
    }
}

/// The geometry and the coefficients beyond it.
#[derive(Clone, Debug, PartialEq)]
pub struct ExtendedModel {
    /// The geometric inputs.
    pub state: ChainState,
    /// `k, a1, b1, a2, b2` per joint.
    pub beta: Vec<f64>,
    /// The link masses and centres of mass of the torques.
    pub links: LinkMasses,
}

impl ExtendedModel {
    /// The joint deflections at the commanded angles `q` (rad): the formula of
    /// [`JointErrors::deflections_with`] (torques at the commanded angles, no payload).
    pub fn deflections(&self, q: &[f64]) -> Joints {
        self.deflections_at(q, 0.0)
    }

    /// [`Self::deflections`] with a payload of `payload_kg` at the target (the tool point).
    pub fn deflections_at(&self, q: &[f64], payload_kg: f64) -> Joints {
        let t = point_terms(&self.state.params, &self.links, &self.state.tool, q);
        JointErrors::deflections_with(&self.beta, payload_kg, &t, q.len())
    }

    /// The target's position in the measurement frame at the commanded angles `q` (rad), mm.
    pub fn predict(&self, q: &[f64]) -> [f64; 3] {
        let d = self.deflections(q);
        let actual = Joints::from_fn(q.len(), |i| q[i] + d[i]);
        self.state.predict(&actual)
    }
}

/// The per-point quantities of [`JointErrors::point_terms`], a payload's centre of mass at
/// `com_mm` (flange frame: the target).
fn point_terms(params: &[f64], links: &LinkMasses, com_mm: &[f64; 3], q: &[f64]) -> PointTerms {
    let at = Payload {
        com_mm: *com_mm,
        ..Payload::NONE
    };
    let e = JointErrors {
        coefficients: Vec::new(),
        links: *links,
        calibration_payload: at,
        payload: at,
        free: Vec::new(),
        covariance: Vec::new(),
        shift_space: crate::kinematics::InputSpace::parameters(q.len()),
        shift: Vec::new(),
        backlash: None,
    };
    e.point_terms(params, q)
}

/// The free inputs of a fit: `free` (geometric first, `geo` of them, then coefficients), the
/// geometry's prior and σ of each coefficient's prior.
#[derive(Clone, Copy)]
struct Inputs<'a> {
    free: &'a [usize],
    geo: usize,
    prior: Option<&'a Prior>,
    sigma: &'a [f64],
    /// Per observation, the quantities its deflections are linear in ([`PointTerms`]), at the
    /// geometric solution: the torques move with the geometry by its relative change (~1e-3),
    /// a change of ~1e-7 rad in a deflection of 1e-4 rad, so the fit takes them once.
    terms: &'a [PointTerms],
    /// Per observation, the direction each joint arrived from (−1, 0, +1), when the fit has a
    /// backlash per joint (coefficients `PER_JOINT·n + j`: the gap, the joint standing half of
    /// it from its commanded angle on the side it came from).
    dirs: Option<&'a [Joints]>,
    /// What the leave-out RMS leaves out at a time: runs of consecutive observations (an arc
    /// of a sweep), or, when empty, each observation alone.
    held_out: &'a [std::ops::Range<usize>],
}

/// Whitened residuals of `m` at `obs`, then the prior rows of the free inputs.
fn residuals(obs: &[Observation], m: &ExtendedModel, x: &Inputs<'_>) -> Vec<f64> {
    let (free, geo, prior) = (x.free, x.geo, x.prior);
    let mut out = Vec::with_capacity(3 * obs.len() + free.len());
    let n = m.links.joints();
    let at = m.state.predictor();
    for (k, (o, t)) in obs.iter().zip(x.terms).enumerate() {
        let mut d = JointErrors::deflections_with(&m.beta, o.payload_kg, t, n);
        if let Some(dirs) = x.dirs {
            for j in 0..n {
                d[j] += 0.5 * m.beta[PER_JOINT * n + j] * dirs[k][j];
            }
        }
        let p = at.predict_target(&Joints::from_fn(n, |i| o.q[i] + d[i]), o.target as usize);
        let e = o.whiten * Vector3::new(p[0] - o.p[0], p[1] - o.p[1], p[2] - o.p[2]);
        out.extend_from_slice(&[e.x, e.y, e.z]);
    }
    for (k, &i) in free.iter().enumerate() {
        if k < geo {
            if let Some(p) = prior.filter(|p| p.sigma_of(i) > 0.0) {
                out.push((m.state.get(i) - p.centre.get(i)) / p.sigma_of(i));
            }
        } else {
            out.push(m.beta[i] / x.sigma[i]);
        }
    }
    out
}

/// Finite-difference step of free input `k` (geometric inputs first, `geo` of them).
fn step(state: &ChainState, free: &[usize], geo: usize, k: usize) -> f64 {
    if k >= geo {
        if free[k] >= PER_JOINT * state.layout().joints() {
            1e-8
        } else if free[k].is_multiple_of(PER_JOINT) {
            1e-9
        } else {
            1e-8
        }
    } else if state.is_angle(free[k]) {
        1e-8
    } else {
        1e-5
    }
}

/// `m` moved by `d` over the free inputs.
fn moved(m: &ExtendedModel, free: &[usize], geo: usize, d: &[f64]) -> ExtendedModel {
    let mut n = m.clone();
    for (k, (&i, v)) in free.iter().zip(d).enumerate() {
        if k < geo {
            n.state.set(i, m.state.get(i) + v);
        } else {
            n.beta[i] += v;
        }
    }
    n
}

/// The Jacobian of [`residuals`] over the free inputs of `x` at `m`, and the residuals.
fn jacobian(obs: &[Observation], m: &ExtendedModel, x: &Inputs<'_>) -> (DMatrix<f64>, Vec<f64>) {
    use rayon::prelude::*;
    let (free, geo) = (x.free, x.geo);
    let r0 = residuals(obs, m, x);
    let cols: Vec<Vec<f64>> = (0..free.len())
        .into_par_iter()
        .map(|k| {
            let h = step(&m.state, free, geo, k);
            let mut d = vec![0.0; free.len()];
            d[k] = h;
            let a = residuals(obs, &moved(m, free, geo, &d), x);
            d[k] = -h;
            let b = residuals(obs, &moved(m, free, geo, &d), x);
            a.iter().zip(&b).map(|(x, y)| (x - y) / (2.0 * h)).collect()
        })
        .collect();
    (
        DMatrix::from_fn(r0.len(), free.len(), |r, c| cols[c][r]),
        r0,
    )
}

/// The leave-one-out RMS (3-D, mm) of `m` fitted over the inputs `x` (prior rows as in
/// [`residuals`]), and the covariance of the free inputs.
fn loo_rms(obs: &[Observation], m: &ExtendedModel, x: &Inputs<'_>) -> Option<(f64, DMatrix<f64>)> {
    let (jac, r0) = jacobian(obs, m, x);
    if !x.held_out.is_empty() {
        let cov = (jac.transpose() * &jac).try_inverse()?;
        let j = jac.rows(0, 3 * obs.len());
        let rms = held_out::leave_group_out_rms(obs, &j, &cov, &r0, x.held_out)?;
        return Some((rms, cov));
    }
    loo_linear(obs, &jac, &r0)
}

/// The free inputs `geometric` followed by the coefficients `coefficients`.
fn with_coefficients(geometric: &[usize], coefficients: &[usize]) -> Vec<usize> {
    geometric.iter().chain(coefficients).copied().collect()
}

/// `start` fitted to `obs` by Levenberg–Marquardt over the free inputs of `x`.
fn fit_over(obs: &[Observation], start: ExtendedModel, x: &Inputs<'_>) -> ExtendedModel {
    let steps: Vec<f64> = (0..x.free.len())
        .map(|k| step(&start.state, x.free, x.geo, k))
        .collect();
    levenberg_marquardt(
        start,
        &steps,
        |m, d| moved(m, x.free, x.geo, d),
        |m| residuals(obs, m, x),
    )
}

/// Fits the extended model to `run`'s observations from its geometric solution and compares
/// the leave-one-out RMS of both. `None` when the data cannot support it (fewer equations than
/// twice the coefficients, or a singular information matrix).
pub(super) fn check(
    run: &Fitted,
    nominal: &RobotModel,
    prior: Option<&Prior>,
    with_backlash: bool,
    held_out: &[std::ops::Range<usize>],
    orders: Option<&[u8]>,
) -> Option<ExtendedFit> {
    let n = run.state.layout().joints();
    let links = LinkMasses::of(nominal);
    let geometric = ExtendedModel {
        state: run.state,
        beta: vec![0.0; PER_JOINT * n],
        links,
    };
    // Joints whose torque varies over the poses.
    let torques: Vec<Joints> = run
        .obs
        .iter()
        .map(|o| {
            gravity_torques(
                &run.state.params,
                &run.state.tool,
                &links,
                o.payload_kg,
                &o.q,
            )
        })
        .collect();
    let rms_tau: Vec<f64> = (0..n)
        .map(|i| {
            (torques.iter().map(|t| t[i] * t[i]).sum::<f64>() / torques.len().max(1) as f64).sqrt()
        })
        .collect();
    let top = rms_tau.iter().copied().fold(0.0, f64::max);
    // The candidates: compliance where the torque varies, the harmonics up to the orders set
    // (both orders on every joint unless set).
    let extras: Vec<usize> = (0..PER_JOINT * n)
        .filter(|&i| match i % PER_JOINT {
            0 => rms_tau[i / PER_JOINT] >= TORQUE_SHARE * top.max(1e-12),
            k => orders.is_none_or(|o| usize::from(o[i / PER_JOINT]) >= k.div_ceil(2)),
        })
        .collect();
    if 3 * run.obs.len() < 2 * (run.free.len() + extras.len()) {
        return None;
    }
    let geo = run.free.len();
    let sigma: Vec<f64> = (0..PER_JOINT * n)
        .map(|i| {
            if i.is_multiple_of(PER_JOINT) {
                PRIOR_RAD / rms_tau[i / PER_JOINT].max(1e-12)
            } else {
                PRIOR_RAD
            }
        })
        .collect();
    let terms: Vec<PointTerms> = run
        .obs
        .iter()
        .map(|o| point_terms(&run.state.params, &links, &run.state.tool, &o.q))
        .collect();
    let plain = Inputs {
        free: &run.free,
        geo,
        prior,
        sigma: &sigma,
        terms: &terms,
        dirs: None,
        held_out,
    };
    let (loo_geometric, _) = loo_rms(&run.obs, &geometric, &plain)?;
    let free = with_coefficients(&run.free, &extras);
    let all = Inputs {
        free: &free,
        ..plain
    };
    let fitted = fit_over(&run.obs, geometric, &all);
    let (jac, r0) = jacobian(&run.obs, &fitted, &all);
    let (loo_all, cov) = loo_linear(&run.obs, &jac, &r0)?;
    // Per joint the terms the data need (unless the orders are set): the model keeps the fit
    // with those alone, and the covariance of the fit with every candidate (docs/METHOD.md §19:
    // a dropped coefficient stays at 0 with the spread the data left it, and the kept ones keep
    // theirs, not the narrower one given that the dropped are exactly 0: the selection looked
    // at these data, and the spread a model that holds the truth has is what stays honest).
    let mut gap_fit = None;
    let (fitted, selection, loo_extended, sel_free) = match orders {
        Some(_) => (
            fitted,
            select::TermSelection::fixed(&extras, n, loo_all),
            loo_all,
            free.clone(),
        ),
        None => {
            let lin = select::Linearised {
                obs: &run.obs,
                jac: &jac,
                r: &r0,
                geo,
                extras: &extras,
                beta: &fitted.beta,
            };
            // With the backlash checked on poses, the terms are chosen with the gaps in the
            // fit: without them the hysteresis is part of the residual variance against which
            // a term's χ² is judged, true terms go, and the gaps then absorb what they leave
            // (simulated TX60s with every term: gaps within 1.96σ 78 % of the time so, 97 %
            // with every term fitted).
            let gapped = if with_backlash && held_out.is_empty() {
                backlash::Gaps::of(run, n, free.len(), &sigma)
            } else {
                None
            };
            let with_gaps = gapped
                .as_ref()
                .and_then(|g| g.select(run, &fitted, &all, &extras));
            let (kept, mut selection) = match with_gaps {
                Some((kept, selection, fit)) => {
                    gap_fit = Some(fit);
                    (kept, selection)
                }
                None => lin.select(n)?,
            };
            selection.with_gaps = gap_fit.is_some();
            if kept.len() == extras.len() {
                (fitted, selection, loo_all, free.clone())
            } else {
                let sel_free = with_coefficients(&run.free, &kept);
                let x = Inputs {
                    free: &sel_free,
                    ..plain
                };
                let mut start = fitted.clone();
                for &i in extras.iter().filter(|i| !kept.contains(i)) {
                    start.beta[i] = 0.0;
                }
                let m = fit_over(&run.obs, start, &x);
                let (loo, _) = loo_rms(&run.obs, &m, &x)?;
                (m, selection, loo, sel_free)
            }
        }
    };
    let deflections: Vec<Joints> = run.obs.iter().map(|o| fitted.deflections(&o.q)).collect();
    let backlash = if with_backlash {
        let kept = Inputs {
            free: &sel_free,
            ..plain
        };
        backlash_check(
            run,
            &fitted,
            &kept,
            &sigma,
            (loo_geometric, loo_extended),
            gap_fit.as_ref(),
        )
    } else {
        None
    };
    // A model that keeps the gaps keeps the covariance of the fit with every candidate and the
    // gaps (the gaps' rows left out, at that fit's own noise): without them the coefficients'
    // σ are those of a model whose residuals hold the hysteresis (simulated TX60s with
    // backlash: 90.6 % of the coefficients within 1.96σ so, RMS z 1.13; 93.3 % and 1.06 so).
    let cov = match (&backlash, &gap_fit) {
        (Some(b), Some(g)) if b.predicts_better && held_out.is_empty() => {
            g.without_gaps(geo, extras.len())
        }
        _ => cov,
    };
    // The coefficients' σ: of the fit with every candidate (what the model keeps), by their
    // positions among its free inputs (after the geometry's, whose indices are of another space).
    let sigma_of = |i: usize| {
        free[geo..]
            .iter()
            .position(|&f| f == i)
            .map(|k| cov[(geo + k, geo + k)].max(0.0).sqrt())
    };
    let report = BeyondGeometry {
        backlash,
        sides_unchecked: !with_backlash && run.obs.iter().any(|o| o.sides.is_some()),
        parameters: sel_free.len() - geo,
        selection,
        left_out: held_out::describe(held_out),
        loo_rms_geometric_mm: loo_geometric,
        loo_rms_extended_mm: loo_extended,
        predicts_better: loo_extended
            < (1.0 - crate::discrepancy::gp::required_gain(run.obs.len())) * loo_geometric,
        kept: false,
        compliance_urad_per_nm: (0..n)
            .map(|j| {
                let i = PER_JOINT * j;
                sigma_of(i).map(|s| [fitted.beta[i] * 1e6, s * 1e6])
            })
            .collect(),
        harmonic_amplitudes_deg: (0..n)
            .map(|j| {
                let b = &fitted.beta[PER_JOINT * j..PER_JOINT * (j + 1)];
                [b[1].hypot(b[2]).to_degrees(), b[3].hypot(b[4]).to_degrees()]
            })
            .collect(),
        link_mass_kg: links.mass_kg.to_vec(),
        calibration_payloads_kg: {
            let mut m: Vec<f64> = run.obs.iter().map(|o| o.payload_kg).collect();
            m.sort_by(f64::total_cmp);
            m.dedup();
            m
        },
        deflection_rms_deg: (0..n)
            .map(|j| {
                (deflections.iter().map(|d| d[j] * d[j]).sum::<f64>()
                    / deflections.len().max(1) as f64)
                    .sqrt()
                    .to_degrees()
            })
            .collect(),
        undetermined: undetermined(&free, geo, run.space, &cov, &sigma),
    };
    let (model, backlash) = backlash::kept(report.backlash.as_ref(), held_out, fitted, n);
    Some(ExtendedFit {
        report,
        model,
        free,
        geo,
        covariance: cov,
        backlash,
    })
}

/// The extended fit of [`check`]: its report, the model with the terms selected, and the
/// covariance of the fit with every candidate term (a dropped coefficient at 0 keeps its spread).
#[derive(Clone, Debug)]
pub struct ExtendedFit {
    /// The comparison with the geometry alone.
    pub report: BeyondGeometry,
    /// The geometry and the coefficients (0 where a term was dropped).
    pub model: ExtendedModel,
    /// The free inputs of the fit with every candidate term: `geo` geometric ones (indices of the fit's input space), then
    /// coefficients (indices of `k, a1, b1, a2, b2` per joint).
    free: Vec<usize>,
    geo: usize,
    /// Their covariance (internal units), with the noise the fit was whitened with.
    covariance: DMatrix<f64>,
    /// The gaps, when the backlash check found that they predict better (with the noise the fit
    /// was whitened with); `model` is then the fit with them.
    pub backlash: Option<Backlash>,
}
