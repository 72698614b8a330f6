//! Robot identification by the circle-point (axis measurement) method (METHOD.md §2, paper §1.3).
//!
//! Flow: [`read_sweeps`] (CSV → [`SweepData`]) → [`identify`] → one [`Identification`] per run:
//! the identified [`RobotModel`] plus an [`IdentifyReport`] ([`render_identify_report`] formats
//! it). Per run and joint: the sweep is checked ([`check_sweep`]), a circle is fitted
//! ([`circle::fit_circle`], by [`CircleFitMethod`]) giving the joint's axis line in the base frame;
//! consecutive axes give the MDH parameters ([`mdh`]) and the J6 sweep the tool point. The
//! conventions for what point measurements cannot separate are documented in [`mdh`]. By default
//! ([`IdentifyOptions::default`]) two further steps use the commanded angles and the design:
//! a prior that keeps poorly determined quantities near the nominal geometry ([`NominalPrior`],
//! [`circle::AxisPrior`]) and a whole-chain least-squares refinement over all sweep points
//! ([`refine`]); both can be switched off to get the plain circle-point result.
//! [`validate()`] compares a model's predictions with measured positions.
//!
//! Held-out RMS error on simulated TX60s (perturbed by 0.3 mm / 0.03°, tool (30, −20, 80) mm,
//! σ = 10 µm, 2° steps; `cargo bench --bench identify_range`, 20 robots; nominal model 0.87 mm):
//!
//! | range | point cloud | commanded angles | default (commanded + prior + refinement) |
//! |-------|-------------|------------------|------------------------------------------|
//! | 10 %  | 5.18 mm     | 2.81 mm          | 0.45 mm                                  |
//! | 25 %  | 0.50 mm     | 0.29 mm          | 0.19 mm                                  |
//! | 50 %  | 0.096 mm    | 0.066 mm         | 0.044 mm                                 |
//! | 75 %  | 0.040 mm    | 0.027 mm         | 0.020 mm                                 |
//! | 100 % | 0.018 mm    | 0.015 mm         | 0.012 mm                                 |
//!
//! Why short arcs are hard whatever the circle model: a rigid tilt of the circle about the arc's
//! tangent moves the points only by the sagitta, so the axis tilt is fixed by `σ/(r(1−cos Δ/2))`
//! and the resulting position error `~ 8σ/(Δ²√N)` does not depend on the radius. The
//! commanded angles pin the radius and the centre along the chord (so they beat the point cloud
//! at every range), but not that tilt; the nominal prior bounds it.
//!
//! The identified model copies the nominal model's name (suffixed), joint limits and structure
//! (`fixed`, except where [`mdh::PARALLEL_THRESHOLD_DEG`] switches a pair to the `β` form). Its
//! uncertainty is `Uncertainty::Independent([0.0; 30])`: one run says nothing about the spread;
//! statistics over repeated runs ([`parameter_statistics`]) or a simulation supply it.
//!
//! ```
//! use gpu_amcs::identify::{identify, IdentifyOptions};
//! use gpu_amcs::kinematics::tx60;
//! use gpu_amcs::simulate::{simulate_sweeps, SweepPlan};
//! let mut truth = tx60();
//! truth.tool = [30.0, -20.0, 80.0];
//! let data = simulate_sweeps(&truth, &SweepPlan::default(), 0.0, 1, 1);
//! let ids = identify(&data, &tx60(), &IdentifyOptions::default()).unwrap();
//! assert!((ids[0].model.tool[0] - 30.0).abs() < 1e-6);
//! println!("{}", gpu_amcs::identify::render_identify_report(&ids[0].report));
//! ```

pub mod circle;
pub mod lines;
pub mod mdh;
pub mod refine;
pub mod sweeps;
pub mod validate;

pub use circle::{fit_circle, AxisPrior, CircleFit, CircleFitError, CircleFitMethod, MIN_ARC_DEG};
pub use lines::{common_normal, CommonNormal, Line, LineRelation};
pub use mdh::PARALLEL_THRESHOLD_DEG;
pub use sweeps::{parse_sweeps, read_sweeps, write_sweeps, Sweep, SweepData, SweepPoint, SweepRun};
pub use validate::{
    accuracy, parse_measurements, read_measurements, render_validation, validate,
    write_measurements, AccuracyStats, Measurement, Validation,
};

use crate::kinematics::{
    param_index, FixedParam, ParamKind, RobotModel, Uncertainty, JOINTS, N_PARAMS,
};
use nalgebra::Vector3;
use std::fmt::Write as _;

/// A non-swept joint may differ from the sweep's home pose by at most this much (degrees).
pub const HOME_TOLERANCE_DEG: f64 = 1e-6;

/// Errors reading sweep or measurement data and identifying a model. Every variant about a sweep
/// names the joint (and the run, when the file has a `run` column).
#[derive(Debug, thiserror::Error)]
pub enum IdentifyError {
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The path given.
        path: String,
        /// The OS error.
        source: std::io::Error,
    },
    /// A malformed CSV row: wrong number of fields, a field that is not a (finite) number, a
    /// joint number outside 1–6. Fix the named line.
    #[error("{origin}: line {line}: {message}")]
    Csv {
        /// The file.
        origin: String,
        /// 1-based line number.
        line: u64,
        /// What is wrong.
        message: String,
    },
    /// The header lacks a required column.
    #[error("{origin}: missing column '{column}' (the header must have {expected})")]
    MissingColumn {
        /// The file.
        origin: String,
        /// The missing column.
        column: &'static str,
        /// All required columns.
        expected: String,
    },
    /// The file has a header but no data rows.
    #[error("{origin}: no data rows")]
    Empty {
        /// The file.
        origin: String,
    },
    /// A run has no sweep of a joint.
    #[error("joint {joint}{run}: no sweep of this joint (every joint 1–6 needs one)")]
    MissingJoint {
        /// 1-based joint.
        joint: usize,
        /// " (run X)" or "".
        run: String,
    },
    /// A non-swept joint differs from the sweep's home pose (two joints moving).
    #[error("joint {joint} sweep{run}: line {line}: joint {other} moved too (q{other} = {value} deg, the sweep's home is {home} deg); only the swept joint may move")]
    OtherJointMoved {
        /// The swept joint.
        joint: usize,
        /// " (run X)" or "".
        run: String,
        /// The line of the offending row.
        line: u64,
        /// The other joint that moved.
        other: usize,
        /// Its value in that row.
        value: f64,
        /// Its value in the sweep's first row.
        home: f64,
    },
    /// The circle fit of a joint failed (too few points, collinear, arc too short, radius too
    /// small).
    #[error("joint {joint} sweep{run}: {source}")]
    Fit {
        /// The swept joint.
        joint: usize,
        /// " (run X)" or "".
        run: String,
        /// Why the fit failed.
        source: CircleFitError,
    },
    /// The measured axes cannot be turned into this joint's parameters.
    #[error("joint {joint}: {message}")]
    Geometry {
        /// 1-based joint.
        joint: usize,
        /// What is wrong.
        message: String,
    },
    /// Nothing to evaluate.
    #[error("{0}")]
    NoData(String),
}

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
    /// Angle between this joint's axis and the next, degrees (`None` for J6).
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
pub fn check_sweep(sweep: &Sweep, run: Option<&str>) -> Result<[f64; JOINTS], IdentifyError> {
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
            source: CircleFitError::TooFewPoints {
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

/// Identifies the model of one run.
pub fn identify_run(
    run: &SweepRun,
    nominal: &RobotModel,
    options: &IdentifyOptions,
) -> Result<Identification, IdentifyError> {
    let label = run.label();
    let mut fits = Vec::with_capacity(JOINTS);
    let mut axes = Vec::with_capacity(JOINTS);
    for j in 1..=JOINTS {
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
        let prior = options.nominal_prior.map(|pr| {
            let (r, _) = mdh::frame(&nominal.params, j - 1, &home.map(f64::to_radians));
            circle::AxisPrior {
                direction: r * Vector3::z(),
                sigma_rad: pr.angle_sigma_deg.to_radians(),
            }
        });
        let fit = fit_circle(&pts, &qs, options.method, prior.as_ref()).map_err(|source| {
            IdentifyError::Fit {
                joint: j,
                run: label.clone(),
                source,
            }
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
    let axes: [mdh::MeasuredAxis; JOINTS] = std::array::from_fn(|i| axes[i]);
    let tool_points: Vec<([f64; JOINTS], Vector3<f64>)> = run
        .sweep(JOINTS)
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
                &nominal.params,
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
        name: format!("{} (identified{label})", nominal.name),
        params: chain.params,
        fixed: chain.fixed,
        limits_deg: nominal.limits_deg,
        tool: chain.tool,
        uncertainty: Uncertainty::Independent([0.0; N_PARAMS]),
    };
    let to_file = |p: &[f64; N_PARAMS], j: usize| -> [f64; 5] {
        std::array::from_fn(|k| p[j * 5 + k] / ParamKind::ALL[k].to_internal())
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
    Ok(Identification {
        model,
        report: IdentifyReport {
            run: run.run.clone(),
            method: options.method,
            joints,
            tool_mm: chain.tool,
            nominal_tool_mm: nominal.tool,
            j1_tilt_deg: j1.angle.to_degrees(),
            j1_offset_mm: j1.distance,
        },
    })
}

/// Relative ridge added to the diagonal of a sample covariance: with R runs of ~24 free
/// parameters the covariance is singular when R is at most the number of free parameters, and the
/// ridge gives it a Cholesky factor (draws stay within 10⁻³ σ of the sample covariance's subspace).
pub const COVARIANCE_RIDGE: f64 = 1e-6;

/// Sample covariance (n − 1) of the parameters of `models`, row-major 30×30, internal units.
pub fn sample_covariance(models: &[RobotModel]) -> Vec<f64> {
    let n = models.len() as f64;
    let mut mean = [0.0; N_PARAMS];
    for m in models {
        for (s, v) in mean.iter_mut().zip(&m.params) {
            *s += v / n;
        }
    }
    let mut c = vec![0.0; N_PARAMS * N_PARAMS];
    for m in models {
        for i in 0..N_PARAMS {
            let di = m.params[i] - mean[i];
            for k in 0..N_PARAMS {
                c[i * N_PARAMS + k] += di * (m.params[k] - mean[k]) / (n - 1.0);
            }
        }
    }
    c
}

/// [`parameter_statistics`] with the full sample covariance instead of independent σ: rows and
/// columns of fixed parameters are zero and the diagonal carries the [`COVARIANCE_RIDGE`].
pub fn correlated_statistics(models: &[RobotModel]) -> Option<RobotModel> {
    let mut m = parameter_statistics(models)?;
    let sig = m.uncertainty.sigmas();
    let mut cov = sample_covariance(models);
    for i in 0..N_PARAMS {
        for k in 0..N_PARAMS {
            if sig[i] == 0.0 || sig[k] == 0.0 {
                cov[i * N_PARAMS + k] = 0.0;
            }
        }
        cov[i * N_PARAMS + i] *= 1.0 + COVARIANCE_RIDGE;
    }
    m.uncertainty = Uncertainty::Covariance(cov);
    Some(m)
}

/// Mean parameters and their sample standard deviations over the models of repeated runs
/// (`n − 1` divisor): a model whose uncertainty is `Independent(σ)`. The first model supplies the
/// structure, limits and name; `None` for fewer than two models or differing structures.
pub fn parameter_statistics(models: &[RobotModel]) -> Option<RobotModel> {
    let first = models.first()?;
    if models.len() < 2 || models.iter().any(|m| m.fixed != first.fixed) {
        return None;
    }
    let n = models.len() as f64;
    let mut mean = [0.0; N_PARAMS];
    let mut tool = [0.0; 3];
    for m in models {
        for (s, v) in mean.iter_mut().zip(&m.params) {
            *s += v / n;
        }
        for (s, v) in tool.iter_mut().zip(&m.tool) {
            *s += v / n;
        }
    }
    let mut sigma = [0.0; N_PARAMS];
    for (i, s) in sigma.iter_mut().enumerate() {
        let var = models
            .iter()
            .map(|m| (m.params[i] - mean[i]).powi(2))
            .sum::<f64>()
            / (n - 1.0);
        *s = var.sqrt();
    }
    // A fixed parameter has no spread by definition.
    for (j, f) in first.fixed.iter().enumerate() {
        let k = match f {
            FixedParam::D => ParamKind::D,
            FixedParam::Beta => ParamKind::Beta,
        };
        sigma[param_index(j, k)] = 0.0;
    }
    Some(RobotModel {
        name: format!("{} (mean of {} runs)", first.name, models.len()),
        params: mean,
        fixed: first.fixed,
        limits_deg: first.limits_deg,
        tool,
        uncertainty: Uncertainty::Independent(sigma),
    })
}

/// Formats the per-joint table of an identification for the terminal.
pub fn render_identify_report(report: &IdentifyReport) -> String {
    let mut s = String::new();
    let run = sweeps::run_label(report.run.as_deref());
    let _ = writeln!(
        s,
        "Identification{run}, {} circle fit",
        report.method.name()
    );
    let _ = writeln!(
        s,
        "{:>3} {:>6} {:>9} {:>11} {:>10} {:>10} {:>10}",
        "J", "points", "arc deg", "radius mm", "rms mm", "max mm", "axis∠ deg"
    );
    for j in &report.joints {
        let angle = j
            .axis_angle_deg
            .map(|a| format!("{a:.4}"))
            .unwrap_or_else(|| "-".into());
        let _ = writeln!(
            s,
            "{:>3} {:>6} {:>9.2} {:>11.4} {:>10.5} {:>10.5} {:>10}",
            j.joint,
            j.points,
            j.arc_span_deg,
            j.radius_mm,
            j.rms_residual_mm,
            j.max_residual_mm,
            angle
        );
    }
    let _ = writeln!(
        s,
        "\nParameters: identified (identified − nominal); mm and deg; [fixed] = held fixed"
    );
    let _ = writeln!(
        s,
        "{:>3} {:>24} {:>24} {:>24} {:>24} {:>24}",
        "J", "theta", "d", "a", "alpha", "beta"
    );
    for j in &report.joints {
        let mut row = format!("{:>3}", j.joint);
        for (k, kind) in ParamKind::ALL.iter().enumerate() {
            let fixed = matches!(
                (j.fixed, kind),
                (FixedParam::D, ParamKind::D) | (FixedParam::Beta, ParamKind::Beta)
            ) || j.joint == JOINTS;
            let cell = if fixed {
                format!("{:.4} [fixed]", j.identified[k])
            } else {
                format!(
                    "{:.4} ({:+.4})",
                    j.identified[k],
                    j.identified[k] - j.nominal[k]
                )
            };
            let _ = write!(row, " {cell:>24}");
        }
        let _ = writeln!(s, "{row}");
    }
    let t = report.tool_mm;
    let n = report.nominal_tool_mm;
    let _ = writeln!(
        s,
        "\nTool point (flange frame): ({:.4}, {:.4}, {:.4}) mm, nominal ({:.4}, {:.4}, {:.4}) mm",
        t[0], t[1], t[2], n[0], n[1], n[2]
    );
    let _ = writeln!(
        s,
        "J6: theta, d, a, alpha kept nominal; the tool point absorbs the rest."
    );
    let _ = writeln!(
        s,
        "J1 measured axis vs base z: tilt {:.4} deg, offset {:.4} mm (the model takes base z as J1's axis)",
        report.j1_tilt_deg, report.j1_offset_mm
    );
    s
}
