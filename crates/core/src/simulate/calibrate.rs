//! Repeated calibration experiments on a virtual robot (paper §2.2 and §3.2): simulate the
//! circle-point sweeps of one factor setting R times, identify each run, and take the parameter
//! statistics — mean, σ and the full covariance — that AMCS needs.
//!
//! An [`Experiment`] is the fixed part: the nominal (design) model, the true robot, the tracker
//! ([`TrackerModel`]), the robot's non-geometric errors ([`RobotErrorModel`]), the measurement
//! plan (home pose, measuring ranges) and the identification options. [`Factors`] is the part the
//! paper varies. Run `r` of a calibration draws from its own generator seeded by
//! [`run_seed`]`(seed, r)`, so the runs can be simulated and identified in parallel (rayon) and
//! the result does not depend on the thread count. A measured point is
//!
//! `tracker(FK(truth, q_cmd + e_joint) + scatter)`
//!
//! with `e_joint` the moving joint's backlash and settling error and `scatter` the pose
//! repeatability and residual vibration ([`RobotErrorModel`]), then the tracker's radial and
//! transverse noise ([`TrackerModel::measure`]).
//!
//! The full covariance of R runs of ~20 free parameters is singular when R is at most the number
//! of free parameters; the correlated model adds a ridge of [`crate::identify::COVARIANCE_RIDGE`] × its own
//! diagonal so it has a Cholesky factor (the draws stay within 10⁻³ σ of the sample covariance's
//! subspace).

use super::factors::{Factors, RobotErrorModel, SimulateError};
use super::nongeometric::{true_position, NonGeometric, NonGeometricError, NonGeometricSizes};
use super::robot::{perturbed_model, ParameterErrors};
use super::sweep::SweepPlan;
use super::tracker::TrackerModel;
use crate::identify::{
    correlated_statistics, identify_run, parameter_statistics, validate, IdentifyOptions,
    Measurement, Sweep, SweepData, SweepPoint, SweepRun, Validation,
};
use crate::kinematics::{tx60, Joints, RobotModel};
use crate::points::{self, WorkspaceBox};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

/// The tracker target in the flange frame of the simulated TX60 (and of any robot of
/// [`Experiment::for_robot`]), mm (off-axis, so the last joint's circle — J6's — has a radius of
/// √(30² + 20²) ≈ 36 mm).
pub const DESIGN_TOOL_MM: [f64; 3] = [30.0, -20.0, 80.0];

/// The fixed part of a calibration experiment.
#[derive(Clone, Debug)]
pub struct Experiment {
    /// Design model (structure, conventions, prior), with the design tool point.
    pub nominal: RobotModel,
    /// The robot as it really is.
    pub truth: RobotModel,
    /// The laser tracker.
    pub tracker: TrackerModel,
    /// Repeatability, dynamics and backlash of the robot.
    pub robot: RobotErrorModel,
    /// Home pose and measuring ranges (its fraction and step are replaced by the factors; fitted
    /// to the nominal model's joint count and limits by [`SweepPlan::within`]).
    pub plan: SweepPlan,
    /// Identification options.
    pub identify: IdentifyOptions,
    /// Where the robot base stands in the tracker's frame; `None`: the sweeps are recorded in
    /// the base frame (the factor study's setting). With a placement the tracker stands at the
    /// measurement frame's origin and every point is reported in that frame.
    pub placement: Option<crate::kinematics::BaseTransform>,
    /// The true robot's non-geometric errors (compliance under gravity and payload, gear
    /// harmonics: [`super::nongeometric`]); `None`: a purely geometric robot.
    pub nongeometric: Option<NonGeometric>,
}

impl Experiment {
    /// A TX60 whose true geometry is the nominal one perturbed by [`ParameterErrors::default`]
    /// (0.3 mm / 0.03° class) from `robot_seed`, tool [`DESIGN_TOOL_MM`], the AT960 and the TX60
    /// error model.
    pub fn tx60(robot_seed: u64) -> Self {
        Self::for_robot(tx60(), robot_seed)
    }

    /// The same experiment on any robot: `nominal` with the design tracker target, and a true
    /// robot perturbed from it by the same error classes, seeded by `robot_seed`.
    pub fn for_robot(mut nominal: RobotModel, robot_seed: u64) -> Self {
        nominal.tool = DESIGN_TOOL_MM;
        let mut rng = ChaCha8Rng::seed_from_u64(robot_seed);
        let truth = perturbed_model(
            &nominal,
            &ParameterErrors::default(),
            DESIGN_TOOL_MM,
            &mut rng,
        );
        Self::with_truth(nominal, truth)
    }

    /// An experiment on a given true robot (its structure must match `nominal`'s): the AT960,
    /// the TX60's error model ([`RobotErrorModel::for_joints`] of the robot's joint count) and
    /// the paper's plan (fitted to the robot by [`Experiment::plan_for`]).
    pub fn with_truth(nominal: RobotModel, truth: RobotModel) -> Self {
        let robot = RobotErrorModel::for_joints(nominal.joints());
        Experiment {
            nominal,
            truth,
            tracker: TrackerModel::default(),
            robot,
            plan: SweepPlan::default(),
            identify: IdentifyOptions::default(),
            placement: None,
            nongeometric: None,
        }
    }

    /// Gives the true robot non-geometric errors of `sizes`, drawn from `seed`
    /// ([`NonGeometric::draw`]; sizes of a purely geometric robot remove them).
    ///
    /// # Errors
    ///
    /// [`NonGeometricError`] for a size out of range ([`NonGeometricSizes::check`]).
    pub fn set_nongeometric(
        &mut self,
        sizes: &NonGeometricSizes,
        seed: u64,
    ) -> Result<(), NonGeometricError> {
        sizes.check()?;
        self.nongeometric = NonGeometric::draw(&self.truth, sizes, seed);
        Ok(())
    }

    /// The sweep plan of a factor setting: [`Self::plan`] fitted into the nominal model's joint
    /// limits (and so resized to its joint count) with the factors' fraction and step.
    pub fn plan_for(&self, f: &Factors) -> SweepPlan {
        SweepPlan {
            range_fraction: f.range_fraction,
            step_deg: f.step_deg,
            ..self.plan.within(&self.nominal.limits_deg)
        }
    }

    /// One simulated calibration run (one sweep per joint of the nominal model, six for the TX60)
    /// from generator `rng`.
    pub fn sweep_run(&self, f: &Factors, label: Option<String>, rng: &mut ChaCha8Rng) -> SweepRun {
        let plan = self.plan_for(f);
        let tracker = match &self.placement {
            None => self.tracker,
            Some(b) => TrackerModel {
                position_mm: super::poses::tracker_in_base_frame(b),
                ..self.tracker
            },
        };
        let place = |p: [f64; 3]| match &self.placement {
            None => p,
            Some(b) => b.apply(p),
        };
        let dir = f.direction.sign();
        let sweeps = (1..=plan.joints())
            .map(|j| {
                let mut configs = plan.sweep_configurations(j);
                if dir < 0.0 {
                    configs.reverse();
                }
                let points = configs
                    .into_iter()
                    .map(|q_deg| {
                        let mut q_act = q_deg;
                        q_act[j - 1] += self.robot.joint_error_deg(
                            &self.nominal,
                            j - 1,
                            &q_deg,
                            dir,
                            f.speed_fraction,
                            rng,
                        );
                        let p = true_position(
                            &self.truth,
                            self.nongeometric.as_ref(),
                            &q_act.map(f64::to_radians),
                        );
                        let s = self.robot.point_scatter_mm(f.speed_fraction, rng);
                        let p = [p[0] + s[0], p[1] + s[1], p[2] + s[2]];
                        SweepPoint {
                            q_deg,
                            position_mm: place(tracker.measure(p, rng)),
                            line: 0,
                        }
                    })
                    .collect();
                Sweep { joint: j, points }
            })
            .collect();
        SweepRun { run: label, sweeps }
    }

    /// All `f.runs` runs of a calibration from `seed`, labelled "1", "2", …, line numbers as
    /// written by [`crate::identify::write_sweeps`].
    pub fn sweeps(&self, f: &Factors, seed: u64) -> SweepData {
        let runs: Vec<SweepRun> = (0..f.runs)
            .into_par_iter()
            .map(|r| {
                let mut rng = ChaCha8Rng::seed_from_u64(run_seed(seed, r as u64));
                self.sweep_run(f, Some((r + 1).to_string()), &mut rng)
            })
            .collect();
        let mut data = SweepData { runs };
        let mut line = 2;
        for r in &mut data.runs {
            for s in &mut r.sweeps {
                for p in &mut s.points {
                    p.line = line;
                    line += 1;
                }
            }
        }
        data
    }

    /// Whether the robot can be calibrated from sweeps: not with backlash, which the sweeps do
    /// not simulate (along an arc every point arrives from the same side, so the gap is one
    /// more offset of the joint; pose runs simulate it).
    ///
    /// # Errors
    ///
    /// [`SimulateError::Other`] for a robot with backlash.
    pub fn check_sweeps(&self) -> Result<(), SimulateError> {
        if self
            .nongeometric
            .as_ref()
            .is_some_and(NonGeometric::has_backlash)
        {
            return Err(SimulateError::Other(
                "backlash is simulated in pose runs only: along a sweep's arc every point arrives from the same side, so its gap is one more offset of the joint".into(),
            ));
        }
        Ok(())
    }

    /// Positions of `truth` at `configs` (degrees, one angle per joint) as the tracker measures
    /// them (static poses: repeatability scatter and tracker noise), lines numbered as written.
    /// A robot with backlash ([`NonGeometric::has_backlash`]) visits them in their order: each
    /// joint arrives from the side it moved from the configuration before (none at the first),
    /// stands half its gap beyond the commanded angle on that side, and each measurement records
    /// its sides, as `simulate_poses_sided` records them (without backlash: none, and the same
    /// bits as before backlash existed).
    pub fn measure(&self, configs: &[Joints], rng: &mut ChaCha8Rng) -> Vec<Measurement> {
        let lash = self.nongeometric.as_ref().filter(|e| e.has_backlash());
        let sides = lash.map(|_| crate::identify::chain::approach_directions(configs, &[]));
        configs
            .iter()
            .enumerate()
            .map(|(k, q)| {
                let rad = q.map(f64::to_radians);
                let sides = sides.as_ref().map(|s| s[k]);
                let p = match (lash, &sides) {
                    (Some(e), Some(s)) => {
                        let at = e.sided_angles(&self.truth, &rad, s);
                        crate::kinematics::position(&self.truth.params, &self.truth.tool, &at)
                    }
                    _ => true_position(&self.truth, self.nongeometric.as_ref(), &rad),
                };
                let s = self.robot.point_scatter_mm(0.0, rng);
                Measurement {
                    payload_kg: None,
                    q_deg: *q,
                    position_mm: self
                        .tracker
                        .measure([p[0] + s[0], p[1] + s[1], p[2] + s[2]], rng),
                    line: k as u64 + 2,
                    target: None,
                    on_base: false,
                    sides,
                }
            })
            .collect()
    }
}

/// Seed of run `run` of a calibration seeded `seed` (SplitMix64 of both), so runs are
/// independent and reproducible in any order.
pub fn run_seed(seed: u64, run: u64) -> u64 {
    splitmix(splitmix(seed) ^ run.wrapping_mul(0x9E37_79B9_7F4A_7C15))
}

/// SplitMix64 finaliser.
pub fn splitmix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The statistics of a repeated calibration.
#[derive(Clone, Debug)]
pub struct Calibration {
    /// The factor setting.
    pub factors: Factors,
    /// The model identified from each run.
    pub runs: Vec<RobotModel>,
    /// Mean parameters with independent σ (the paper's assumption).
    pub independent: RobotModel,
    /// Mean parameters with the full sample covariance (plus the ridge).
    pub correlated: RobotModel,
    /// Wall time of simulation and identification, seconds.
    pub seconds: f64,
}

/// Runs `f.runs` simulated calibrations from `seed` (in parallel) and returns their statistics.
///
/// # Errors
///
/// [`SimulateError::Setting`] for a factor out of range ([`Factors::check`]),
/// [`SimulateError::Identify`] naming the run whose identification failed, and
/// [`SimulateError::Other`] when the runs identified models of different structure or the
/// covariance statistics fail.
///
/// # Examples
///
/// Two runs on a virtual TX60 measured without noise, sweeping in 5° steps: the calibrated
/// model predicts the true robot's positions to the micrometre, where the nominal model misses
/// them by tenths of a millimetre.
///
/// ```
/// use gpu_amcs_core::points::WorkspaceBox;
/// use gpu_amcs_core::simulate::{
///     accuracy_check, calibrate, Experiment, Factors, RobotErrorModel, SimulateError,
///     TrackerModel,
/// };
///
/// let mut exp = Experiment::tx60(7);
/// exp.tracker = TrackerModel::perfect();
/// exp.robot = RobotErrorModel::none();
/// let f = Factors {
///     runs: 2,
///     step_deg: 5.0,
///     ..Factors::default()
/// };
/// let c = calibrate(&exp, &f, 1)?;
/// assert_eq!(c.runs.len(), 2);
/// assert!(c.independent.name.contains("calibrated (2 runs"));
///
/// let v = accuracy_check(&exp, &c.independent, 5, &WorkspaceBox::default(), 3)?;
/// assert!(v.model.max_mm < 1e-3, "{:?}", v.model);
/// assert!(v.nominal.unwrap().1.mean_mm > 0.1);
///
/// // One run gives no statistics.
/// let one = Factors { runs: 1, ..f };
/// assert!(matches!(calibrate(&exp, &one, 1), Err(SimulateError::Setting { .. })));
/// # Ok::<(), SimulateError>(())
/// ```
pub fn calibrate(exp: &Experiment, f: &Factors, seed: u64) -> Result<Calibration, SimulateError> {
    calibrate_with_progress(exp, f, seed, &crate::progress::ProgressHook::none())
}

/// [`calibrate`], telling `progress` each run identified (label `calibration runs`, the runs
/// done of `f.runs`; the results do not depend on it).
///
/// # Errors
///
/// As [`calibrate`].
pub fn calibrate_with_progress(
    exp: &Experiment,
    f: &Factors,
    seed: u64,
    progress: &crate::progress::ProgressHook,
) -> Result<Calibration, SimulateError> {
    f.check()?;
    exp.check_sweeps()?;
    let t0 = std::time::Instant::now();
    let runs: Vec<RobotModel> = each_run(f.runs, progress, |r| {
        let mut rng = ChaCha8Rng::seed_from_u64(run_seed(seed, r as u64));
        let run = exp.sweep_run(f, Some((r + 1).to_string()), &mut rng);
        identify_run(&run, &exp.nominal, &exp.identify)
            .map(|id| id.model)
            .map_err(|cause| SimulateError::Identify { run: r + 1, cause })
    })?;
    let mut independent = parameter_statistics(&runs).ok_or_else(|| {
        SimulateError::Other("the runs identified models of different structure".into())
    })?;
    independent.name = format!(
        "{} calibrated ({} runs, range {} %, step {}°, speed {} %, {})",
        exp.nominal.name,
        f.runs,
        f.range_fraction * 100.0,
        f.step_deg,
        f.speed_fraction * 100.0,
        f.direction.label()
    );
    let mut correlated = correlated_statistics(&runs).ok_or_else(|| {
        SimulateError::Other("the runs identified models of different structure".into())
    })?;
    correlated.name = independent.name.clone();
    Ok(Calibration {
        factors: *f,
        runs,
        independent,
        correlated,
        seconds: t0.elapsed().as_secs_f64(),
    })
}

/// `run(r)` for the runs `r` in `0..runs`, in parallel, each reported to `progress` as it
/// finishes ("calibration runs", k of `runs`); the results in run order, so that the error
/// returned is the first failing run's, whatever thread finished first.
pub(crate) fn each_run<T: Send>(
    runs: usize,
    progress: &crate::progress::ProgressHook,
    run: impl Fn(usize) -> Result<T, SimulateError> + Sync,
) -> Result<Vec<T>, SimulateError> {
    use std::sync::atomic::{AtomicU64, Ordering};
    let finished = AtomicU64::new(0);
    progress.report("calibration runs", 0, runs as u64);
    (0..runs)
        .into_par_iter()
        .map(|r| {
            let out = run(r);
            let k = finished.fetch_add(1, Ordering::Relaxed) + 1;
            progress.report("calibration runs", k, runs as u64);
            out
        })
        .collect::<Vec<_>>()
        .into_iter()
        .collect()
}

/// The measurements of `n` random test configurations whose target lies in `bx`, on the true
/// robot of `exp`, for `seed` (the same for every model checked with that seed).
///
/// # Errors
///
/// [`SimulateError::Other`] when no `n` test configurations can be generated in `bx`.
pub(crate) fn test_measurements(
    exp: &Experiment,
    n: usize,
    bx: &WorkspaceBox,
    seed: u64,
) -> Result<Vec<Measurement>, SimulateError> {
    let configs = points::generate(&exp.nominal, n, bx, seed)
        .map_err(|e| SimulateError::Other(format!("test points: {e}")))?;
    let mut rng = ChaCha8Rng::seed_from_u64(splitmix(seed ^ 0xACC));
    Ok(exp.measure(&configs, &mut rng))
}

/// Accuracy before and after calibration (the paper's 22.9 % experiment): `n` random test
/// configurations whose target lies in `bx`, measured on the true robot, against the calibrated
/// model and the nominal model.
///
/// # Errors
///
/// [`SimulateError::Other`] when no `n` test configurations can be generated in `bx` or the
/// validation fails.
pub fn accuracy_check(
    exp: &Experiment,
    calibrated: &RobotModel,
    n: usize,
    bx: &WorkspaceBox,
    seed: u64,
) -> Result<Validation, SimulateError> {
    let m = test_measurements(exp, n, bx, seed)?;
    let mut nominal = exp.nominal.clone();
    nominal.name = format!("{} (nominal)", exp.nominal.name);
    validate(calibrated, &m, Some(&nominal)).map_err(|e| SimulateError::Other(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn perfect_measurement_recovers_the_truth_and_runs_are_reproducible() {
        let mut exp = Experiment::tx60(7);
        exp.tracker = TrackerModel::perfect();
        exp.robot = RobotErrorModel::none();
        let f = Factors {
            runs: 2,
            ..Factors::default()
        };
        let c = calibrate(&exp, &f, 1).unwrap();
        let v = accuracy_check(&exp, &c.independent, 20, &WorkspaceBox::default(), 3).unwrap();
        assert!(v.model.max_mm < 1e-3, "{:?}", v.model);
        assert!(v.nominal.unwrap().1.mean_mm > 0.1);
        // noisy: same seed, same statistics
        let exp = Experiment::tx60(7);
        let a = calibrate(&exp, &f, 5).unwrap();
        let b = calibrate(&exp, &f, 5).unwrap();
        assert_eq!(a.independent.params, b.independent.params);
        assert_eq!(a.independent.uncertainty, b.independent.uncertainty);
    }
}
