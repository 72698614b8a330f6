//! Identification from tracker data as measured (docs/METHOD.md §2.4): pose data, or sweeps, in
//! any measurement frame, each run through the whole-chain fit of [`super::chain`] so that every
//! identified model carries the covariance its own data produced.
//!
//! * **Poses** go straight to the whole-chain fit, which starts from a rigid alignment of the
//!   nominal chain to the data.
//! * **Sweeps** in a measurement frame first get a placement from the measured J1 and J2 axes
//!   ([`placement_from_axes`]): the frame in which J1 is the z axis, with the nominal model's θ1
//!   and d1 conventions; the circle-point method then runs in that frame as for base-frame data,
//!   and its result starts the whole-chain fit over all sweep points with the placement free.
//! * With the placement known (base-frame data) the circle-point result starts the same fit with
//!   the placement held at the identity.

use super::chain::{
    chain_model, identify_chain, nominal_state, ChainOptions, ChainReport, HeldOut, MeasuredPoint,
    Placement,
};
use super::chain_fit::{ChainState, OtherTargets};
use super::circle::CircleFitMethod;
use super::identifiability::check_something_free;
use super::lines::{common_normal, Line};
use super::noise::chi2_upper_tail;
use super::pipeline::{identify_run, Identification, IdentifyOptions, IdentifyReport};
use super::poses::{PoseData, TrackerData};
use super::repeats::{fit_input, FitInput};
use super::sweeps::{SweepData, SweepRun};
use super::{mdh, IdentifyError, IdentifyWarning};
use crate::kinematics::{param_index, Block, ParamKind, RobotModel};
use crate::progress::ProgressHook;
use nalgebra::{DMatrix, DVector, Matrix3, Rotation3, Vector3};

/// An identification report for data without circle fits (poses): the whole-chain report and
/// the target, nothing per joint.
fn pose_report(
    run: Option<String>,
    nominal: &RobotModel,
    chain: ChainReport,
    tool: [f64; 3],
) -> IdentifyReport {
    let warnings = chain_warnings(run.as_deref(), &chain);
    IdentifyReport {
        run,
        method: CircleFitMethod::CommandedAngles,
        joints: Vec::new(),
        tool_mm: tool,
        nominal_tool_mm: nominal.tool,
        j1_tilt_deg: 0.0,
        j1_offset_mm: 0.0,
        warnings,
        chain: Some(chain),
    }
}

/// Identifies one model per run of pose data. Poses measured more than once enter as their
/// means, weighted by the noise (σ/√k), and their scatter is the noise when none is stated
/// ([`super::repeats`]); the report says so. Several runs whose joint parameters disagree beyond
/// their uncertainty are flagged ([`disagreeing_runs`]).
///
/// # Errors
///
/// [`IdentifyError::NoData`] for no runs, and the errors of [`identify_chain`].
pub fn identify_poses(
    data: &PoseData,
    nominal: &RobotModel,
    options: &IdentifyOptions,
    chain: &ChainOptions,
) -> Result<Vec<Identification>, IdentifyError> {
    if data.runs.is_empty() {
        return Err(IdentifyError::NoData("no poses to identify from".into()));
    }
    check_targets(data)?;
    let (runs, drift) = super::drift::correct(data)?;
    let chain = &per_run_options(chain, data.runs.len());
    let count = data.runs.len();
    let fits = runs
        .iter()
        .zip(&drift)
        .enumerate()
        .map(|(k, (r, drift))| {
            let label = super::sweeps::run_label(r.run.as_deref());
            let input = fit_input(r, &chain.noise);
            let opts = ChainOptions {
                noise: input.noise,
                progress: run_progress(&chain.progress, k, count),
                ..chain.clone()
            };
            let mut result =
                identify_chain(&input.points, nominal, None, options.nominal_prior, &opts)?;
            note_repeats(&mut result.report, &input);
            result.report.targets = data.targets.clone();
            result.report.drift = drift.clone();
            let model = chain_model(
                nominal,
                &result,
                format!("{} (identified{label})", nominal.name),
            );
            Ok((model, result))
        })
        .collect::<Result<Vec<_>, IdentifyError>>()?;
    let disagree = disagreeing_runs(
        &data
            .runs
            .iter()
            .zip(&fits)
            .map(|(r, (_, f))| (r.run.clone(), f.state, f.covariance.as_slice()))
            .collect::<Vec<_>>(),
    );
    Ok(data
        .runs
        .iter()
        .zip(fits)
        .enumerate()
        .map(|(i, (r, (model, result)))| {
            let mut report = pose_report(r.run.clone(), nominal, result.report, model.tool);
            if i == 0 {
                report
                    .warnings
                    .extend(disagree.iter().map(|m| IdentifyWarning::Chain {
                        run: String::new(),
                        message: m.clone(),
                    }));
            }
            Identification { model, report }
        })
        .collect())
}

/// Refuses runs that leave out one of several targets: every run's fit estimates every
/// target's offset, and the first target is the model's tool.
///
/// # Errors
///
/// [`IdentifyError::NoData`] naming the run and the target it lacks.
fn check_targets(data: &PoseData) -> Result<(), IdentifyError> {
    for r in &data.runs {
        for (t, label) in data.targets.iter().enumerate() {
            if !r.points.iter().any(|p| p.target as usize == t) {
                return Err(IdentifyError::NoData(format!(
                    "target '{label}' has no rows{}: with several targets every run must measure each ({}; the first, '{}', is the model's tool)",
                    super::sweeps::run_label(r.run.as_deref()),
                    data.targets.join(", "),
                    data.targets[0]
                )));
            }
        }
    }
    Ok(())
}

/// The report of a fit of repeated poses: where the noise came from, its test (an F test of the
/// means' χ² against the pure error, which was estimated), and the warnings of the comparison
/// with a stated σ.
fn note_repeats(report: &mut ChainReport, input: &FitInput) {
    if let Some(source) = &input.source {
        report.noise.source = source.clone();
    }
    if let Some(p) = input
        .noise
        .pure_error_p_value(report.noise.chi2, report.noise.dof)
    {
        report.noise.p_value = Some(p);
        report.lack_of_fit.summary.push_str(&format!(
            " The noise is the pure error of the repeated measurements ({}); the test is the F test of the pose means' residuals against it.",
            report.noise.source
        ));
    }
    report.warnings.extend(input.warnings.iter().cloned());
}

/// Runs whose joint (MDH) parameters disagree beyond their uncertainty: for each pair, `χ² =
/// dᵀ (C_a + C_b)⁺ d` over the parameters both identified, against χ² with the rank's degrees
/// of freedom at 1 % over the number of pairs (Bonferroni). `runs` holds each run's label, state
/// and row-major covariance over [`ChainState::space`]. One line per pair that disagrees.
pub fn disagreeing_runs(runs: &[(Option<String>, ChainState, &[f64])]) -> Vec<String> {
    let pairs = runs.len() * runs.len().saturating_sub(1) / 2;
    let mut out = Vec::new();
    for (a, (la, sa, ca)) in runs.iter().enumerate() {
        for (lb, sb, cb) in &runs[a + 1..] {
            let space = sa.space();
            let n = space.len();
            if ca.len() != n * n || cb.len() != n * n || sb.space().len() != n {
                continue;
            }
            let idx: Vec<usize> = (0..n)
                .filter(|&i| space.locate(i).0 == Block::Joints)
                .filter(|&i| ca[i * n + i] > 0.0 && cb[i * n + i] > 0.0)
                .collect();
            let m = idx.len();
            if m == 0 {
                continue;
            }
            let s = DMatrix::from_fn(m, m, |r, c| {
                let (i, j) = (idx[r], idx[c]);
                ca[i * n + j] + cb[i * n + j]
            });
            let d = DVector::from_fn(m, |r, _| sa.get(idx[r]) - sb.get(idx[r]));
            let eig = s.symmetric_eigen();
            let top = eig.eigenvalues.iter().fold(0.0f64, |t, v| t.max(*v));
            let (mut chi2, mut rank) = (0.0, 0);
            for (k, l) in eig.eigenvalues.iter().enumerate() {
                if *l > 1e-12 * top && top > 0.0 {
                    chi2 += eig.eigenvectors.column(k).dot(&d).powi(2) / l;
                    rank += 1;
                }
            }
            if rank == 0 {
                continue;
            }
            let p = chi2_upper_tail(chi2, rank);
            if p < 0.01 / pairs.max(1) as f64 {
                let name = |l: &Option<String>| l.clone().unwrap_or_else(|| "(unnamed)".into());
                out.push(format!(
                    "runs {} and {} disagree beyond their uncertainty (joint parameters: χ² = {chi2:.1} for {rank} degrees of freedom, p = {p:.1e}): their mean model averages different robots, set-ups or regions of the workspace; identify them separately or find what changed",
                    name(la),
                    name(lb)
                ));
            }
        }
    }
    out
}

/// Identifies tracker data of either kind: poses through [`identify_poses`], sweeps through
/// [`identify_sweeps_chain`], or with `circle_only` through the plain circle-point pipeline
/// ([`super::identify`]; base-frame sweeps only, no covariance of its own).
///
/// # Errors
///
/// [`IdentifyError::NoData`] for `circle_only` with poses or with the placement to identify, or
/// for a `chain.fix` that holds every parameter the whole-chain fit would identify
/// ([`check_something_free`]); the errors of the pipelines.
pub fn identify_data(
    data: &TrackerData,
    nominal: &RobotModel,
    options: &IdentifyOptions,
    chain: &ChainOptions,
    circle_only: bool,
) -> Result<Vec<Identification>, IdentifyError> {
    if !circle_only {
        check_something_free(nominal, chain.placement, &chain.fix)?;
    }
    match data {
        TrackerData::Sweeps(d) if circle_only => {
            if chain.placement == Placement::Identify {
                return Err(IdentifyError::NoData(
                    "the plain circle-point result needs sweeps in the robot base frame (the placement known)".into(),
                ));
            }
            super::identify(d, nominal, options)
        }
        TrackerData::Sweeps(d) => identify_sweeps_chain(d, nominal, options, chain),
        TrackerData::Poses(_) if circle_only => Err(IdentifyError::NoData(
            "the plain circle-point method needs sweeps; these are poses".into(),
        )),
        TrackerData::Poses(p) => identify_poses(p, nominal, options, chain),
    }
}

/// The chain report's warnings as identification warnings.
fn chain_warnings(run: Option<&str>, chain: &ChainReport) -> Vec<IdentifyWarning> {
    chain
        .warnings
        .iter()
        .map(|m| IdentifyWarning::Chain {
            run: super::sweeps::run_label(run),
            message: m.clone(),
        })
        .collect()
}

/// The arcs each sweep is cut into for the check beyond geometry ([`HeldOut`]): with each
/// sweep point alone the check kept joint errors that predicted poses across the workspace worse
/// than the geometry (simulated TX60s at size 1: 0.258 against 0.176 mm); leaving out a third of
/// a sweep at a time keeps them only where they predict those poses better (docs/METHOD.md
/// §19.6 has the measured table for one to four arcs).
pub const SWEEP_ARCS: usize = 3;

/// The points of every sweep of a run as whole-chain measurements.
fn sweep_points(run: &SweepRun) -> Vec<MeasuredPoint> {
    run.sweeps
        .iter()
        .flat_map(|s| s.points.iter())
        .map(|p| MeasuredPoint {
            q_deg: p.q_deg,
            position_mm: p.position_mm,
            sigma_mm: None,
            payload_kg: 0.0,
            line: p.line,
            target: 0,
            sides: None,
        })
        .collect()
}

/// The placement (measurement frame ← base) implied by the measured J1 and J2 axes: J1's axis is
/// the base z axis, the base origin lies `d1` (nominal) below the foot of the J1–J2 common normal
/// and the normal's direction at J2's sweep home pose fixes the rotation about z (the nominal
/// θ1). Returns `[x, y, z, roll, pitch, yaw]` (mm, radians).
///
/// # Errors
///
/// [`IdentifyError::JointCount`] when the points do not have one angle per joint of `nominal`,
/// [`IdentifyError::MissingJoint`] when the run has no J1 or J2 sweep, [`IdentifyError::Fit`]
/// when a circle fit fails, [`IdentifyError::Geometry`] when the two axes are parallel.
pub fn placement_from_axes(
    run: &SweepRun,
    nominal: &RobotModel,
    method: CircleFitMethod,
) -> Result<[f64; 6], IdentifyError> {
    super::pipeline::check_joint_count(run, nominal)?;
    let mut lines = Vec::new();
    let mut homes = Vec::new();
    for j in 1..=2 {
        let (_, home, fit) = super::pipeline::fit_sweep(run, j, method, |_| None)?;
        lines.push(Line {
            point: fit.center,
            dir: fit.normal,
        });
        homes.push(home);
    }
    let nominal_line = |j: usize, home: &crate::kinematics::Joints| {
        let (r, t) = mdh::frame(&nominal.params, j, &home.map(f64::to_radians));
        Line {
            point: t,
            dir: r * Vector3::z(),
        }
    };
    let (n1, n2) = (nominal_line(0, &homes[1]), nominal_line(1, &homes[1]));
    let frame_of = |l1: &Line, l2: &Line| -> Option<(Matrix3<f64>, Vector3<f64>)> {
        let cn = common_normal(l1, l2);
        let n = l1.dir.cross(&l2.dir);
        if n.norm() < 1e-6 {
            return None;
        }
        let z = l1.dir.normalize();
        let x = n.normalize();
        Some((Matrix3::from_columns(&[x, z.cross(&x), z]), cn.foot1))
    };
    let parallel = || IdentifyError::Geometry {
        joint: 1,
        message: "the J1 and J2 axes are parallel: the placement cannot be found from them".into(),
    };
    let (mn, cn) = frame_of(&n1, &n2).ok_or_else(parallel)?;
    let (mm, cm) = frame_of(&lines[0], &lines[1]).ok_or_else(parallel)?;
    let r = mm * mn.transpose();
    let t = cm - r * cn;
    let (roll, pitch, yaw) = Rotation3::from_matrix(&r).euler_angles();
    Ok([t.x, t.y, t.z, roll, pitch, yaw])
}

/// A run with every point moved from the measurement frame into the base frame of `placement`.
fn into_base_frame(run: &SweepRun, placement: &[f64; 6]) -> SweepRun {
    let r = *Rotation3::from_euler_angles(placement[3], placement[4], placement[5]).matrix();
    let t = Vector3::new(placement[0], placement[1], placement[2]);
    let mut out = run.clone();
    for s in &mut out.sweeps {
        for p in &mut s.points {
            let v = r.transpose() * (Vector3::from(p.position_mm) - t);
            p.position_mm = [v.x, v.y, v.z];
        }
    }
    out
}

/// Identifies one model per run of sweep data with the whole-chain fit and its covariance: the
/// circle-point method (in the frame of [`placement_from_axes`] when the placement is
/// identified), then [`identify_chain`] over all points of the run from its result.
///
/// # Errors
///
/// [`IdentifyError::NoData`] for no runs, and the errors of [`placement_from_axes`],
/// [`identify_run`] and [`identify_chain`].
pub fn identify_sweeps_chain(
    data: &SweepData,
    nominal: &RobotModel,
    options: &IdentifyOptions,
    chain: &ChainOptions,
) -> Result<Vec<Identification>, IdentifyError> {
    if data.runs.is_empty() {
        return Err(IdentifyError::NoData("no sweeps to identify from".into()));
    }
    let chain = &per_run_options(chain, data.runs.len());
    let count = data.runs.len();
    data.runs
        .iter()
        .enumerate()
        .map(|(k, run)| {
            let lengths: Vec<usize> = run.sweeps.iter().map(|s| s.points.len()).collect();
            let chain = &ChainOptions {
                progress: run_progress(&chain.progress, k, count),
                held_out: HeldOut::sweep_arcs(&lengths, SWEEP_ARCS),
                ..chain.clone()
            };
            chain.progress.report("circle fits", 0, 1);
            let placement = match chain.placement {
                Placement::Identify => placement_from_axes(run, nominal, options.method)?,
                Placement::Known => [0.0; 6],
            };
            let local = into_base_frame(run, &placement);
            let mut base_nominal = nominal.clone();
            base_nominal.base = None;
            let circle = identify_run(&local, &base_nominal, options)?;
            let mut start = ChainState {
                params: circle.model.params,
                tool: circle.model.tool,
                base: placement,
                others: OtherTargets::NONE,
            };
            if chain.placement == Placement::Identify {
                let s = nominal_state(nominal);
                for kind in [ParamKind::Theta, ParamKind::D] {
                    let i = param_index(0, kind);
                    start.params[i] = s.params[i];
                }
            }
            let result = identify_chain(
                &sweep_points(run),
                nominal,
                Some(start),
                options.nominal_prior,
                chain,
            )?;
            let model = chain_model(nominal, &result, circle.model.name.clone());
            let mut report = circle.report;
            report.tool_mm = model.tool;
            // The circle fits already warn per joint about residuals and parameters far from
            // nominal; the chain adds what only it sees.
            let mut chain_report = result.report.clone();
            chain_report.warnings.retain(|w| {
                !w.starts_with("the RMS residual") && !w.contains("moved further from nominal")
            });
            report
                .warnings
                .extend(chain_warnings(run.run.as_deref(), &chain_report));
            report.chain = Some(result.report);
            Ok(Identification { model, report })
        })
        .collect()
}

/// The progress hook of run `k` (from 0) of `count`: the run's steps as a share of all runs'.
fn run_progress(hook: &ProgressHook, k: usize, count: usize) -> ProgressHook {
    if count > 1 {
        hook.part(k as u64, count as u64, format!("run {}/{count}: ", k + 1))
    } else {
        hook.clone()
    }
}

/// The whole-chain options of one of `runs` runs: several runs give their mean model, which no
/// run's compensation or joint errors describe, so they are fitted without either; a check
/// beyond geometry asked for still runs and is reported per run (the mean model of several
/// runs carries the geometry's statistics alone, and a run's geometry fitted beside joint
/// errors would not be the geometry that predicts best without them).
fn per_run_options(chain: &ChainOptions, runs: usize) -> ChainOptions {
    use super::JointErrorFit;
    ChainOptions {
        compensate: chain.compensate && runs == 1,
        beyond_geometry: match chain.beyond_geometry {
            JointErrorFit::Auto if runs > 1 => JointErrorFit::Off,
            JointErrorFit::On | JointErrorFit::Keep if runs > 1 => JointErrorFit::Check,
            mode => mode,
        },
        ..chain.clone()
    }
}
