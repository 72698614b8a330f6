//! The identification pipeline of one run: check each sweep, fit its circle, turn the axes into
//! the MDH chain, optionally refine it over all points (see the module docs of
//! [`crate::identify`]).

use super::circle::{self, fit_circle, CircleFitError, CircleFitMethod};
use super::lines::{common_normal, Line};
use super::quality::{quality_warnings, IdentifyWarning, QualityLimits};
use super::sweeps::{self, Sweep, SweepData, SweepRun};
use super::{mdh, refine, IdentifyError};
use crate::kinematics::{
    param_index, FixedParam, Joints, ParamKind, Params, RobotModel, Uncertainty,
};
use nalgebra::Vector3;

/// A non-swept joint may differ from the sweep's home pose by at most this much (degrees).
pub const HOME_TOLERANCE_DEG: f64 = 1e-6;

/// Default σ of the nominal-geometry prior on angles (axis directions, θ, α, β), degrees: a
/// generous bound on how far a real robot is from its design (the simulated robots' parameters
/// are within 0.03°, their axes within ~0.06°).
pub const NOMINAL_ANGLE_SIGMA_DEG: f64 = 0.1;
/// Default σ of the nominal-geometry prior on lengths (d, a), mm.
pub const NOMINAL_LENGTH_SIGMA_MM: f64 = 1.0;

/// Prior knowledge that the robot is close to its nominal geometry, used where the data leave a
/// quantity almost free (short arcs): see [`circle::AxisPrior`] and [`refine::refine_chain`].
/// The data are weighted by the tracker noise estimated from the fit itself, so with long arcs or
/// noise-free data the prior has no effect.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NominalPrior {
    /// σ of angles (axis tilt, θ, α, β), degrees.
    pub angle_sigma_deg: f64,
    /// σ of lengths (d, a), mm.
    pub length_sigma_mm: f64,
}

impl Default for NominalPrior {
    fn default() -> Self {
        NominalPrior {
            angle_sigma_deg: NOMINAL_ANGLE_SIGMA_DEG,
            length_sigma_mm: NOMINAL_LENGTH_SIGMA_MM,
        }
    }
}

/// Options of [`identify`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IdentifyOptions {
    /// Circle model (default: [`CircleFitMethod::CommandedAngles`]).
    pub method: CircleFitMethod,
    /// Prior towards the nominal geometry: each fitted axis direction towards the nominal
    /// model's axis at the sweep's home pose ([`circle::AxisPrior`]) and, in the refinement, each
    /// parameter towards its nominal value. `None` uses the data alone. Default:
    /// `Some(NominalPrior::default())`.
    pub nominal_prior: Option<NominalPrior>,
    /// Refine the circle-point result by least squares over all sweep points ([`refine`]).
    /// Default: `true`.
    pub refine: bool,
}

impl Default for IdentifyOptions {
    fn default() -> Self {
        IdentifyOptions {
            method: CircleFitMethod::CommandedAngles,
            nominal_prior: Some(NominalPrior::default()),
            refine: true,
        }
    }
}

/// What identification found for one joint.
#[derive(Clone, Debug, PartialEq)]
pub struct JointReport {
    /// 1-based joint.
    pub joint: usize,
    /// Points in the sweep.
    pub points: usize,
    /// Span of the commanded angles, degrees.
    pub arc_span_deg: f64,
    /// Fitted circle radius, mm.
    pub radius_mm: f64,
    /// RMS of the per-point fit residuals, mm.
    pub rms_residual_mm: f64,
    /// Largest per-point fit residual, mm.
    pub max_residual_mm: f64,
    /// Per-point fit residuals, mm, in sweep order.
    pub residuals_mm: Vec<f64>,
    /// The fitted axis in the base frame, at the sweep's home pose.
    pub axis: Line,
    /// Identified `[θ, d, a, α, β]`, mm and degrees.
    pub identified: [f64; 5],
    /// Nominal `[θ, d, a, α, β]`, mm and degrees.
    pub nominal: [f64; 5],
    /// Which of d / β is fixed in the identified model.
    pub fixed: FixedParam,
    /// Angle between this joint's axis and the next, degrees (`None` for the last joint).
    pub axis_angle_deg: Option<f64>,
}

/// The report of one identification run.
#[derive(Clone, Debug, PartialEq)]
pub struct IdentifyReport {
    /// Run label, if the data had a `run` column.
    pub run: Option<String>,
    /// Circle model used.
    pub method: CircleFitMethod,
    /// One entry per joint, J1 first.
    pub joints: Vec<JointReport>,
    /// Identified tool point in the flange frame, mm.
    pub tool_mm: [f64; 3],
    /// Nominal tool point, mm.
    pub nominal_tool_mm: [f64; 3],
    /// Angle of the measured J1 axis from the base +z axis, degrees (the model uses base z).
    pub j1_tilt_deg: f64,
    /// Distance of the measured J1 axis from the base z axis, mm (the model uses base z).
    pub j1_offset_mm: f64,
    /// What looks implausible, under the default [`QualityLimits`] ([`quality_warnings`]).
    pub warnings: Vec<IdentifyWarning>,
    /// The whole-chain fit with its covariance and identifiability, when the run went through
    /// it ([`super::measured`]); `None` for the plain circle-point pipeline.
    pub chain: Option<super::chain::ChainReport>,
}

/// An identified model and its report.
#[derive(Clone, Debug, PartialEq)]
pub struct Identification {
    /// The identified model.
    pub model: RobotModel,
    /// How it was found.
    pub report: IdentifyReport,
}

/// Checks one sweep: enough points and only the swept joint moving. Returns its home pose
/// (degrees; the swept joint's entry is its first commanded value).
///
/// # Errors
///
/// [`IdentifyError::MissingJoint`] for a sweep without points, [`IdentifyError::Fit`] (with
/// [`CircleFitError::TooFewPoints`]) for fewer than [`circle::MIN_POINTS`] points, and
/// [`IdentifyError::OtherJointMoved`] when a joint other than the swept one leaves the home pose by
/// more than [`HOME_TOLERANCE_DEG`].
pub fn check_sweep(sweep: &Sweep, run: Option<&str>) -> Result<Joints, IdentifyError> {
    let label = sweeps::run_label(run);
    let Some(first) = sweep.points.first() else {
        return Err(IdentifyError::MissingJoint {
            joint: sweep.joint,
            run: label,
        });
    };
    if sweep.points.len() < circle::MIN_POINTS {
        return Err(IdentifyError::Fit {
            joint: sweep.joint,
            run: label,
            cause: CircleFitError::TooFewPoints {
                points: sweep.points.len(),
            },
        });
    }
    let home = first.q_deg;
    for p in &sweep.points {
        for (k, (&q, &h)) in p.q_deg.iter().zip(&home).enumerate() {
            if k + 1 != sweep.joint && (q - h).abs() > HOME_TOLERANCE_DEG {
                return Err(IdentifyError::OtherJointMoved {
                    joint: sweep.joint,
                    run: label,
                    line: p.line,
                    other: k + 1,
                    value: q,
                    home: h,
                });
            }
        }
    }
    Ok(home)
}

/// Identifies one model per run of `data` (see the module docs). `nominal` gives the structure,
/// the sign conventions, the fixed parameters and the joint limits.
///
/// # Errors
///
/// [`IdentifyError::NoData`] when `data` has no run; otherwise the first run's error of
/// [`identify_run`].
///
/// # Examples
///
/// Identifies a simulated TX60 (true tool point (30, −20, 80) mm, tracker noise 10 µm) from
/// one run of circle-point sweeps, starting from the nominal model:
///
/// ```
/// use gpu_amcs_core::identify::{identify, IdentifyOptions};
/// use gpu_amcs_core::kinematics::tx60;
/// use gpu_amcs_core::simulate::{simulate_sweeps, SweepPlan};
///
/// let mut truth = tx60();
/// truth.tool = [30.0, -20.0, 80.0];
/// let data = simulate_sweeps(&truth, &SweepPlan::default(), 0.01, 1, 1);
/// let ids = identify(&data, &tx60(), &IdentifyOptions::default())?;
/// assert_eq!(ids.len(), 1);
/// let tool = ids[0].model.tool;
/// assert!((0..3).all(|k| (tool[k] - truth.tool[k]).abs() < 0.1), "{tool:?}");
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn identify(
    data: &SweepData,
    nominal: &RobotModel,
    options: &IdentifyOptions,
) -> Result<Vec<Identification>, IdentifyError> {
    if data.runs.is_empty() {
        return Err(IdentifyError::NoData("no sweeps to identify from".into()));
    }
    data.runs
        .iter()
        .map(|r| identify_run(r, nominal, options))
        .collect()
}

/// Checks joint `j`'s sweep of `run` ([`check_sweep`]) and fits its circle with the prior
/// `prior(home)`; returns the sweep, its home pose (degrees) and the fit.
///
/// # Errors
///
/// [`IdentifyError::MissingJoint`] when the run has no sweep of `j`, the errors of
/// [`check_sweep`], and [`IdentifyError::Fit`] naming the joint and run.
pub(crate) fn fit_sweep(
    run: &SweepRun,
    j: usize,
    method: CircleFitMethod,
    prior: impl Fn(&Joints) -> Option<circle::AxisPrior>,
) -> Result<(&Sweep, Joints, circle::CircleFit), IdentifyError> {
    let label = run.label();
    let sweep = run.sweep(j).ok_or_else(|| IdentifyError::MissingJoint {
        joint: j,
        run: label.clone(),
    })?;
    let home = check_sweep(sweep, run.run.as_deref())?;
    let pts: Vec<Vector3<f64>> = sweep
        .points
        .iter()
        .map(|p| Vector3::from(p.position_mm))
        .collect();
    let qs: Vec<f64> = sweep
        .points
        .iter()
        .map(|p| p.q_deg[j - 1].to_radians())
        .collect();
    let fit = fit_circle(&pts, &qs, method, prior(&home).as_ref()).map_err(|cause| {
        IdentifyError::Fit {
            joint: j,
            run: label,
            cause,
        }
    })?;
    Ok((sweep, home, fit))
}

/// Identifies the model of one run.
///
/// # Errors
///
/// [`IdentifyError::JointCount`] when the sweeps' points do not have one angle per joint of
/// `nominal`, [`IdentifyError::MissingJoint`] when a joint has no sweep, the errors of
/// [`check_sweep`] for a bad sweep, [`IdentifyError::Fit`] when a circle fit fails (naming the
/// joint and run), and [`IdentifyError::Geometry`] when the fitted axes cannot be turned into a
/// joint's parameters.
pub fn identify_run(
    run: &SweepRun,
    nominal: &RobotModel,
    options: &IdentifyOptions,
) -> Result<Identification, IdentifyError> {
    let label = run.label();
    let n = nominal.joints();
    check_joint_count(run, nominal)?;
    let mut fits = Vec::with_capacity(n);
    let mut axes = Vec::with_capacity(n);
    for j in 1..=n {
        let (sweep, home, fit) = fit_sweep(run, j, options.method, |home| {
            options.nominal_prior.map(|pr| {
                let (r, _) = mdh::frame(&nominal.params, j - 1, &home.map(f64::to_radians));
                circle::AxisPrior {
                    direction: r * Vector3::z(),
                    sigma_rad: pr.angle_sigma_deg.to_radians(),
                }
            })
        })?;
        axes.push(mdh::MeasuredAxis {
            line: Line {
                point: fit.center,
                dir: fit.normal,
            },
            home_deg: home,
        });
        fits.push((sweep.points.len(), fit));
    }
    let tool_points: Vec<(Joints, Vector3<f64>)> = run
        .sweep(n)
        .map(|s| {
            s.points
                .iter()
                .map(|p| (p.q_deg, Vector3::from(p.position_mm)))
                .collect()
        })
        .unwrap_or_default();
    let mut chain = mdh::axes_to_chain(nominal, &axes, &tool_points)?;
    if options.refine {
        let prior = options.nominal_prior.map(|p| {
            (
                &nominal.params[..],
                p.length_sigma_mm,
                p.angle_sigma_deg.to_radians(),
            )
        });
        let (params, tool, _) =
            refine::refine_chain(run, &chain.params, &chain.fixed, &chain.tool, prior);
        chain.params = params;
        chain.tool = tool;
    }

    let base_z = Line {
        point: Vector3::zeros(),
        dir: Vector3::z(),
    };
    let j1 = common_normal(&base_z, &axes[0].line);
    let model = RobotModel {
        joint_errors: None,
        links: nominal.links,
        discrepancy: None,
        name: format!("{} (identified{label})", nominal.name),
        params: chain.params,
        fixed: chain.fixed,
        limits_deg: nominal.limits_deg,
        tool: chain.tool,
        tool_sigma: [0.0; 3],
        uncertainty: Uncertainty::Independent(Params::filled(nominal.layout().n_params(), 0.0)),
        // The chain is expressed in the measurements' frame with J1 along its z, the nominal
        // model's base frame; the nominal's placement in its description's frame (e.g. the
        // KUKA KR 6's Rx(180°)) carries over, so `fk` and `export` of the result match it.
        base: nominal.base,
    };
    let to_file = |p: &[f64], j: usize| -> [f64; 5] {
        ParamKind::ALL.map(|kind| p[param_index(j, kind)] / kind.to_internal())
    };
    let joints = fits
        .into_iter()
        .enumerate()
        .map(|(j, (points, fit))| JointReport {
            joint: j + 1,
            points,
            arc_span_deg: fit.arc_span_deg,
            radius_mm: fit.radius,
            rms_residual_mm: fit.rms_residual,
            max_residual_mm: fit.max_residual,
            residuals_mm: fit.residuals,
            axis: axes[j].line,
            identified: to_file(&chain.params, j),
            nominal: to_file(&nominal.params, j),
            fixed: chain.fixed[j],
            axis_angle_deg: chain.axis_angles_deg.get(j).copied(),
        })
        .collect();
    let mut report = IdentifyReport {
        run: run.run.clone(),
        method: options.method,
        joints,
        tool_mm: chain.tool,
        nominal_tool_mm: nominal.tool,
        j1_tilt_deg: j1.angle.to_degrees(),
        j1_offset_mm: j1.distance,
        warnings: Vec::new(),
        chain: None,
    };
    report.warnings = quality_warnings(&report, &QualityLimits::default());
    Ok(Identification { model, report })
}

/// Checks that every point of `run` has one commanded angle per joint of `nominal`.
///
/// # Errors
///
/// [`IdentifyError::JointCount`] naming the first point's line, sweep and both counts.
pub(crate) fn check_joint_count(run: &SweepRun, nominal: &RobotModel) -> Result<(), IdentifyError> {
    let n = nominal.joints();
    for s in &run.sweeps {
        if let Some(p) = s.points.iter().find(|p| p.q_deg.len() != n) {
            return Err(IdentifyError::JointCount(format!(
                "line {} (joint {} sweep{}): {} joint angles, the nominal model {} has {} joints",
                p.line,
                s.joint,
                run.label(),
                p.q_deg.len(),
                nominal.name,
                n
            )));
        }
    }
    Ok(())
}
