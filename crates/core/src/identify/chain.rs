//! One run's whole-chain identification with its uncertainty (docs/METHOD.md §2.4–2.7): the
//! weighted least-squares fit of [`super::chain_fit`], the identifiability analysis of
//! [`super::identifiability`], the covariance `s²(JᵀWJ)⁻¹` at the solution, its χ² check
//! against a stated noise, and optionally a Monte Carlo re-identification that checks the
//! linearisation (GUM Supplement 2 style).
//!
//! One concept per file: the options and the fit's steps here; `report` (what the fit reports
//! and returns, and its assembly), `covariance` (the linearised covariance and the fit's
//! statistics), `monte_carlo` (the re-identification check), `warnings`, `model` (state and
//! covariance → model file).

mod beyond;
mod checks;
mod covariance;
mod joint_error_fit;
mod lack_of_fit;
mod model;
mod monte_carlo;
#[cfg(test)]
mod multi_target_tests;
mod report;
mod steps;
#[cfg(test)]
mod target_tests;
#[cfg(test)]
mod tests;
mod undetermined;
mod warnings;

pub(crate) use beyond::approach_directions;
pub use beyond::{
    BacklashCheck, BeyondGeometry, ExtendedModel, HeldOut, Term, TermScore, TermSelection,
    CONFOUNDED, PRIOR_HELD, PRIOR_RAD,
};
pub use joint_error_fit::{check_harmonic_orders, JointErrorFit, MAX_HARMONIC_ORDER};
pub use model::{chain_model, state_model};
pub use report::{ChainReport, ChainResult, MonteCarloCheck, NoiseReport, ParameterRow};
pub use undetermined::{
    not_identified, not_identified_note, not_identified_note_of_file, prior_sigma,
    NOT_IDENTIFIED_KEY, UNDETERMINED_PLACEMENT_SIGMA_DEG, UNDETERMINED_PLACEMENT_SIGMA_MM,
    UNDETERMINED_TOOL_SIGMA_MM,
};

use super::chain_fit::{
    default_free, fit, initial_state, residuals, ChainState, Observation, OtherTargets, Prior,
};
use super::identifiability::{analyse, fix_null_directions, NullDirection};
use super::noise::NoiseModel;
use super::pipeline::NominalPrior;
use super::IdentifyError;
use crate::kinematics::{Block, InputSpace, Joints, RobotModel};
use checks::{check_points, check_pose_count};
use covariance::{embed, linearised_covariances, noise_report, FreeCovariance};
use monte_carlo::monte_carlo_covariance;
use nalgebra::Matrix3;
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
    /// Seed of the Monte Carlo re-identification (and of the compensation's fits).
    pub seed: u64,
    /// Fit a compensation (a Gaussian process over the configuration, docs/METHOD.md §18.1)
    /// to the residuals and keep it when it predicts held-out poses better.
    pub compensate: bool,
    /// When joint compliance under gravity and gear harmonics are fitted with the geometry and
    /// kept ([`JointErrorFit`], [`BeyondGeometry`]).
    pub beyond_geometry: JointErrorFit,
    /// What the check beyond geometry leaves out at a time ([`HeldOut`]).
    pub held_out: HeldOut,
    /// Per joint, the gear harmonics fitted beyond geometry: orders 1 to this (0, 1 or 2; 0:
    /// none), and the compliance of every joint whose torque varies. `None` (the default): the
    /// data choose per joint the orders and whether the compliance is fitted, by Akaike's
    /// criterion ([`TermSelection`]).
    pub harmonic_orders: Option<Vec<u8>>,
    /// Told each step as it starts (fit, identifiability and covariance, check beyond
    /// geometry, lack of fit); none by default.
    pub progress: crate::progress::ProgressHook,
}

impl Default for ChainOptions {
    fn default() -> Self {
        ChainOptions {
            placement: Placement::Identify,
            fix: Vec::new(),
            noise: NoiseModel::FromResiduals,
            uncertainty: UncertaintyMethod::Linearised,
            seed: 1,
            compensate: true,
            beyond_geometry: JointErrorFit::Auto,
            held_out: HeldOut::Points,
            harmonic_orders: None,
            progress: Default::default(),
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
    /// The payload the robot carried at this measurement, kg (its centre of mass at the
    /// measured target); 0 without one.
    pub payload_kg: f64,
    /// The line of the data file.
    pub line: u64,
    /// Which target was measured (0: the model's tool; see [`ChainState::target`]).
    pub target: u8,
    /// The side each joint arrived from (1, −1, 0 not known), when the data say; `None`: the
    /// backlash check takes it from the points' order.
    pub sides: Option<Joints>,
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
        others: OtherTargets::NONE,
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
                payload_kg: p.payload_kg,
                target: p.target,
                sides: p.sides,
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
    // The check (when it runs) comes before the compensation: when the joint errors are kept
    // the geometry is fitted again below, and the Gaussian process over the residuals, the
    // identification's most expensive step, is left to that fit.
    let monte_carlo = matches!(opts.uncertainty, UncertaintyMethod::MonteCarlo { .. });
    let mut steps = steps::Steps::new(
        &opts.progress,
        opts.beyond_geometry != JointErrorFit::Off,
        monte_carlo,
    );
    let (first, extended, _) =
        identify_geometry(points, nominal, start, prior, opts, (None, 0), &mut steps)?;
    let keep = |e: &beyond::ExtendedFit| opts.beyond_geometry.keeps(e.report.worth_keeping());
    let Some(ext) = extended.filter(keep) else {
        steps.finish();
        return Ok(first);
    };
    steps.grow(steps::Steps::pass(false, monte_carlo) as i64);
    let geometric_only = ChainOptions {
        beyond_geometry: JointErrorFit::Off,
        ..opts.clone()
    };
    // The joint errors predict new poses better: the geometry is fitted again to the angles the
    // joints stood at (commanded plus the fitted deflections, and half the gap on the side each
    // joint arrived from when the backlash is kept), so its covariance is the geometry's given
    // the coefficients and the lack of fit is judged on what remains.
    // With the backlash kept, the prediction that does not know the sides (no half gap turned)
    // gets a discrepancy term of its own from its residuals at the second fit's geometry: it
    // holds the hysteresis, and serves test points whose sides are not given (METHOD §19.5).
    let corrected = ext.corrected(points, true);
    let centred = ext.backlash.as_ref().map(|_| ext.corrected(points, false));
    let (mut second, _, sides_unknown) = identify_geometry(
        &corrected,
        nominal,
        start,
        prior,
        &geometric_only,
        (centred.as_deref(), ext.fitted_beyond_geometry()),
        &mut steps,
    )?;
    steps.finish();
    // The coefficients' covariance is in the units the observations were whitened with: the
    // noise the geometric fit estimated (then the data's noise is what the second fit
    // estimates), or the stated noise (then the data's noise is the stated one times the lack
    // of fit the second fit still finds; the geometric fit's far larger lack of fit is what the
    // joint errors explained and must not enter).
    let scale = match (first.report.noise.sigma_mm, second.report.noise.sigma_mm) {
        (Some(a), Some(b)) if a > 0.0 => (b / a).powi(2),
        _ => second.report.lack_of_fit.covariance_scale,
    };
    let space = model::reported_space(second.state.space(), second.report.frame);
    let prior_k = crate::kinematics::gravity::compliance_prior(nominal);
    let mut errors = ext.joint_errors(second.state.space(), space, scale, prior_k);
    // A payload's centre of mass defaults to the tool point (the target the data measured); the
    // payload during calibration is the one most poses were measured with (the calibrated
    // prediction a controller makes is at that payload).
    errors.calibration_payload.com_mm = second.state.tool;
    errors.calibration_payload.mass_kg = beyond::most_common_payload(points);
    errors.payload = errors.calibration_payload;
    // The gaps' σ in the data's noise, as the coefficients' covariance.
    errors.backlash = ext.backlash.as_ref().map(|b| crate::kinematics::Backlash {
        gap_rad: b.gap_rad.clone(),
        sigma_rad: b.sigma_rad.iter().map(|s| s * scale.sqrt()).collect(),
        sides_unknown: sides_unknown.clone(),
    });
    second.joint_errors = Some(errors);
    let mut beyond = ext.report.clone();
    beyond.kept = true;
    // The report's gaps with the σ the model file holds (in the data's noise, not the check's).
    let kept_gaps = second
        .joint_errors
        .as_ref()
        .and_then(|e| e.backlash.as_ref());
    if let (Some(k), Some(b)) = (&mut beyond.backlash, kept_gaps) {
        for (g, s) in k.gap_deg.iter_mut().zip(&b.sigma_rad) {
            g[1] = s.to_degrees();
        }
    }
    let rms = |d: &crate::discrepancy::Discrepancy| d.rms_mm();
    if let (Some(k), Some(s), Some(c)) = (&mut beyond.backlash, &second.discrepancy, &sides_unknown)
    {
        k.residual_rms_mm = Some(beyond::ResidualRms {
            sided: rms(s),
            centre: rms(c),
        });
    }
    second.report.beyond_geometry = Some(beyond);
    second.extended = Some(ext.model);
    Ok(second)
}

/// The geometric identification of [`identify_chain`], the extended fit when asked for, and
/// the discrepancy term of the fitted geometry at `centred` (the points moved to other angles,
/// pose for pose) when given; `extra` inputs beyond the geometry were fitted to the data before
/// (their leverage enters the lack of fit, [`lack_of_fit::lack_of_fit`]).
fn identify_geometry(
    points: &[MeasuredPoint],
    nominal: &RobotModel,
    start: Option<ChainState>,
    prior: Option<NominalPrior>,
    opts: &ChainOptions,
    (centred, extra): (Option<&[MeasuredPoint]>, usize),
    steps: &mut steps::Steps,
) -> Result<GeometryFit, IdentifyError> {
    check_points(points, nominal, start)?;
    if let Some(o) = &opts.harmonic_orders {
        check_harmonic_orders(o, nominal.joints()).map_err(IdentifyError::HarmonicOrders)?;
    }
    steps.next("fitting the geometry");
    let (mut run, fixed_by_user) = Fitted::start(points, nominal, start, opts)?;
    check_pose_count(points, run.free.len())?;
    let nulls = run.fit_free();
    // Inputs the data leave undetermined: held at nominal, with their prior σ in the model.
    let held: Vec<usize> = nulls
        .iter()
        .filter_map(|n| run.space.find(&n.fixed))
        .collect();
    let dof = (3 * run.obs.len()).saturating_sub(run.free.len());
    let estimated_sigma = if opts.noise.is_stated() {
        None
    } else {
        Some(run.estimate_noise(&nulls, dof)?)
    };
    let prior = prior.map(|p| nominal_prior(&run.nominal, &p));
    if prior.is_some() {
        run.state = fit(&run.obs, &run.state, &run.free, prior.as_ref());
    }
    // The identifiability analysis and the lack of fit take the placement's rotation as small
    // rotations about the measurement frame's axes (the same figures however the tracker frame
    // is turned); the model keeps roll, pitch and yaw.
    steps.next("identifiability and covariance");
    let (local, linearised) =
        linearised_covariances(&run.obs, &run.state, &run.free, prior.as_ref());
    let noise = noise_report(&run.obs, &run.state, &opts.noise, estimated_sigma, dof);
    let identifiability = analyse(
        &run.obs,
        &run.state,
        &run.free,
        &local,
        nulls,
        fixed_by_user,
    );
    // The lack of fit as the χ² test tells it (the estimate below says the same): the check of
    // the joint errors runs on it.
    let p_value = opts
        .noise
        .pure_error_p_value(noise.chi2, noise.dof)
        .or(noise.p_value);
    let found = match (opts.noise.is_stated(), p_value) {
        (true, Some(p)) => Some(p < crate::discrepancy::SIGNIFICANCE),
        _ => None,
    };
    let check_runs = opts.beyond_geometry.checks(found);
    if check_runs {
        steps.next("checking beyond geometry");
    } else if opts.beyond_geometry != JointErrorFit::Off {
        steps.grow(-1);
    }
    let beyond = if check_runs {
        beyond::check(
            &run,
            nominal,
            prior.as_ref(),
            opts.beyond_geometry.explicit(),
            &opts.held_out.ranges(run.obs.len()),
            opts.harmonic_orders.as_deref(),
        )
    } else {
        None
    };
    // Joint errors to be kept: the caller fits the geometry again, and the compensation and
    // the self-check are left to that fit.
    let kept_beyond = beyond
        .as_ref()
        .is_some_and(|b| opts.beyond_geometry.keeps(b.report.worth_keeping()));
    steps.next(if opts.compensate && !kept_beyond {
        "lack of fit and compensation"
    } else {
        "lack of fit"
    });
    let lack = if kept_beyond {
        let plain = ChainOptions {
            compensate: false,
            ..opts.clone()
        };
        lack_of_fit::lack_of_fit(&run, &local, &noise, &plain, false, extra)
    } else {
        lack_of_fit::lack_of_fit(&run, &local, &noise, opts, true, extra)
    };
    // A stated noise the residuals reject: the lack of fit acts on the parameters as noise of
    // that size would, so the covariance is scaled by the residuals' mean square over the noise's.
    let scale = lack.covariance_scale;
    let linearised = linearised * scale;
    let monte_carlo = match opts.uncertainty {
        UncertaintyMethod::Linearised => None,
        UncertaintyMethod::MonteCarlo { draws } => {
            let label = format!("{draws} Monte Carlo re-identifications");
            steps.next(&label);
            let tick = |k: u64, n: u64| steps.within(&label, k, n);
            Some(
                monte_carlo_covariance(
                    &run.obs,
                    &run.state,
                    &run.free,
                    prior.as_ref(),
                    draws,
                    opts.seed,
                    &tick,
                ) * scale,
            )
        }
    };
    let cov = FreeCovariance {
        linearised,
        monte_carlo,
    };
    let kept = report::Kept::new(&run, &held, nominal, &cov, prior.as_ref());
    let covariance = embed(&kept.matrix, &kept.inputs, run.space.len());
    let discrepancy = lack.term.clone();
    let centred_term = match centred {
        Some(c) => {
            let obs = observations(c, &opts.noise)?;
            lack_of_fit::term_at(&run, &local, &obs, opts.noise.is_stated(), opts.seed)
        }
        None => None,
    };
    let checks = report::Checks {
        noise,
        identifiability,
        lack_of_fit: lack,
    };
    let mut report = report::build_report(&run, points, nominal, opts, checks, &cov, &kept);
    report.beyond_geometry = beyond.as_ref().map(|b| b.report.clone());
    Ok((
        ChainResult {
            state: run.state,
            covariance,
            discrepancy,
            report,
            extended: beyond.as_ref().map(|b| b.model.clone()),
            joint_errors: None,
        },
        beyond,
        centred_term,
    ))
}

/// What [`identify_geometry`] returns.
type GeometryFit = (
    ChainResult,
    Option<beyond::ExtendedFit>,
    Option<crate::discrepancy::Discrepancy>,
);

/// One run's fit as it goes: the observations (whitened by the noise), the nominal and the
/// current state, and the inputs still free.
struct Fitted {
    /// The fit inputs ([`InputSpace::measured`] of the nominal model's layout).
    space: InputSpace,
    /// The nominal values (placement: the identity for [`Placement::Known`]).
    nominal: ChainState,
    /// The observations.
    obs: Vec<Observation>,
    /// The current values.
    state: ChainState,
    /// The inputs the fit moves.
    free: Vec<usize>,
}

impl Fitted {
    /// The observations of `points`, the starting state (`start`, or one aligned to the data)
    /// and the free inputs, less those `opts.fix` names (returned by name).
    fn start(
        points: &[MeasuredPoint],
        nominal: &RobotModel,
        start: Option<ChainState>,
        opts: &ChainOptions,
    ) -> Result<(Fitted, Vec<String>), IdentifyError> {
        let lay = nominal.layout();
        let mut nominal_s = nominal_state(nominal);
        if opts.placement == Placement::Known {
            nominal_s.base = [0.0; 6];
        }
        let obs = observations(points, &opts.noise)?;
        let free = default_free(&nominal.fixed, opts.placement == Placement::Identify);
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
        // Several targets per pose: each other target's offset is a fit input of its own.
        let state = super::chain_fit::with_other_targets(state, &obs);
        let mut free = free;
        free.extend(state.other_inputs());
        // The other targets have no nominal: a direction the data leave free holds them at
        // their first estimate.
        nominal_s.others = state.others;
        let mut run = Fitted {
            space: lay.measured(),
            nominal: nominal_s,
            obs,
            state,
            free,
        };
        let fixed_by_user = run.fix_by_request(&opts.fix, opts.placement, lay.joints())?;
        Ok((run, fixed_by_user))
    }

    /// Holds the inputs named in `fix` at their nominal values; their names, in order.
    fn fix_by_request(
        &mut self,
        fix: &[String],
        placement: Placement,
        joints: usize,
    ) -> Result<Vec<String>, IdentifyError> {
        let space = self.space;
        let mut fixed_by_user = Vec::new();
        for name in fix {
            let i = space.find(&name.trim().to_ascii_lowercase()).ok_or_else(|| {
                IdentifyError::NoData(format!(
                    "cannot fix '{name}': not a parameter name (theta1…beta{joints}, tool_x…tool_z, base_x…base_yaw)"
                ))
            })?;
            if space.locate(i).0 == Block::Placement && placement == Placement::Known {
                return Err(IdentifyError::NoData(format!(
                    "cannot fix '{name}': the placement is not identified for base-frame data"
                )));
            }
            self.free.retain(|&k| k != i);
            self.state.set(i, self.nominal.get(i));
            fixed_by_user.push(space.name(i));
        }
        Ok(fixed_by_user)
    }

    /// Fits the free inputs without a prior; directions the data cannot determine, found at the
    /// start and again at the solution, are fixed at nominal (and returned).
    fn fit_free(&mut self) -> Vec<NullDirection> {
        let mut nulls =
            fix_null_directions(&self.obs, &mut self.state, &self.nominal, &mut self.free);
        self.state = fit(&self.obs, &self.state, &self.free, None);
        let again = fix_null_directions(&self.obs, &mut self.state, &self.nominal, &mut self.free);
        if !again.is_empty() {
            nulls.extend(again);
            self.state = fit(&self.obs, &self.state, &self.free, None);
        }
        nulls
    }

    /// σ per coordinate from the residuals over `dof` degrees of freedom (at least 1e-12), with
    /// which the observations are whitened from now on.
    ///
    /// # Errors
    ///
    /// [`IdentifyError::NoData`] when no degrees of freedom are left (naming the directions
    /// `nulls` fixed).
    fn estimate_noise(
        &mut self,
        nulls: &[NullDirection],
        dof: usize,
    ) -> Result<f64, IdentifyError> {
        let obs = &mut self.obs;
        if dof == 0 {
            let fixed: Vec<&str> = nulls.iter().map(|n| n.fixed.as_str()).collect();
            return Err(IdentifyError::NoData(format!(
                "{} points give {} equations: {} quantities are identifiable at most{}, and no degrees of freedom are left to estimate the noise; measure 30–60 poses spread over the joint ranges, or state the tracker's σ",
                obs.len(),
                3 * obs.len(),
                self.free.len(),
                if fixed.is_empty() {
                    String::new()
                } else {
                    format!(" (rank deficient: {} not identifiable)", fixed.join(", "))
                }
            )));
        }
        let r = residuals(obs, &self.state);
        let s = (r.iter().map(|v| v * v).sum::<f64>() / dof as f64).sqrt();
        // Noise-free data: any tiny σ keeps the covariance finite and honest (≈ 0).
        let s = s.max(1e-12);
        for o in obs.iter_mut() {
            o.whiten = Matrix3::identity() / s;
        }
        Ok(s)
    }
}
