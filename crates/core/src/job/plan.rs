//! The plan job: the nominal robot, the task and the tracker → the poses to measure and the
//! reliability they are predicted to give at the task points ([`crate::plan`]).

use super::{Analysed, JobError, JobSetting, MemoryCheck, Setup};
use crate::engine::{Backends, Frame};
use crate::kinematics::Joints;
use crate::memory::Estimate;
use crate::plan::{
    self, Plan, PlanError, PlanField, PlanOptions, TrackerSite, Workcell, DEFAULT_THRESHOLDS_MM,
};
use crate::progress::{Notice, ProgressHook};
use crate::spec::{PointsSource, ProblemSpec, ReferenceSource};

/// Most draws of a plan's prediction.
pub const MAX_PREDICTION_DRAWS: usize = 100_000_000;

/// Where the reliability is wanted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PlanTask {
    /// The problem's test points.
    #[default]
    Points,
    /// The ISO 9283 test poses P1–P5 (tool pointing down) instead.
    Iso9283,
}

/// What a [`PlanJob`] gives.
#[derive(Clone, Debug)]
pub struct PlanOutcome {
    /// The design, its figures and the prediction.
    pub plan: Plan,
    /// What the job chose (the backend), as it told them.
    pub notes: Vec<String>,
    /// The prediction's problem (the planned model at the task points), for the report page.
    pub analysed: Analysed,
}

/// A calibration plan: `poses` of `candidates` configurations for the task, and the engine's
/// prediction of the reliability the calibration gives there. The problem's frame and
/// reference do not apply, and other than the measurement frame and the calibrated reference
/// they are refused: a plan predicts the planned calibration's error against its own model, in
/// the measurement frame the calibration identifies the placement in.
///
/// # Examples
///
/// ```
/// use gpu_amcs_core::engine::{BackendChoice, CpuOnly};
/// use gpu_amcs_core::job::PlanJob;
/// use gpu_amcs_core::spec::{GeneratedPoints, PointsSource, ProblemSpec};
///
/// let mut job = PlanJob::new(ProblemSpec {
///     points: PointsSource::Generate(GeneratedPoints { count: 5, ..Default::default() }),
///     backend: BackendChoice::Cpu,
///     ..ProblemSpec::default()
/// });
/// job.poses = 10;
/// job.candidates = 200;
/// job.draws = 1000;
/// let outcome = job.run(&CpuOnly).unwrap();
/// assert_eq!(outcome.plan.design_deg.len(), 10);
/// assert!(outcome.plan.prediction.is_some());
/// ```
#[derive(Clone, Debug)]
pub struct PlanJob {
    /// The nominal robot and the task points, the seed, the backend; memory and progress
    /// (the plan's steps under their own labels, then "plan prediction" in draws).
    pub setup: Setup,
    /// The task points or the ISO 9283 test poses.
    pub task: PlanTask,
    /// Poses to measure.
    pub poses: usize,
    /// Candidate configurations to choose from.
    pub candidates: usize,
    /// Tracker noise per coordinate, mm (1σ).
    pub sigma_mm: f64,
    /// Where the tracker stands and what it sees; none: every candidate is visible.
    pub tracker: Option<TrackerSite>,
    /// Thresholds L of the predicted reliability, mm.
    pub thresholds: Vec<f64>,
    /// The target on the flange, mm; none: [`PlanOptions::default_target`].
    pub target: Option<[f64; 3]>,
    /// The floor, keep-out boxes and self-collision.
    pub workcell: Workcell,
    /// Draws of the prediction, 100 to [`MAX_PREDICTION_DRAWS`].
    pub draws: usize,
    /// The side every joint arrives at each pose from ([`PlanOptions::approach`]); none: from
    /// the previous pose.
    pub approach: Option<crate::plan::Approach>,
}

impl PlanJob {
    /// The plan for `problem` with `gpu-amcs plan`'s defaults: 30 poses of 2000 candidates,
    /// σ = 0.01 mm, no tracker site, the plan's default thresholds, 10⁵ draws.
    pub fn new(problem: ProblemSpec) -> PlanJob {
        PlanJob {
            setup: Setup::new(problem),
            task: PlanTask::Points,
            poses: 30,
            candidates: 2000,
            sigma_mm: 0.01,
            tracker: None,
            thresholds: DEFAULT_THRESHOLDS_MM.to_vec(),
            target: None,
            workcell: Workcell::default(),
            draws: 100_000,
            approach: None,
        }
    }

    /// The planner's options for `target` (the steps told to the job's hook).
    fn options(&self, target: [f64; 3]) -> PlanOptions {
        PlanOptions {
            poses: self.poses,
            candidates: self.candidates,
            sigma_mm: self.sigma_mm,
            tracker: self.tracker.clone(),
            thresholds: self.thresholds.clone(),
            target_mm: target,
            seed: self.setup.problem.seed,
            workcell: self.workcell.clone(),
            approach: self.approach,
            progress: self.setup.progress.clone(),
            ..PlanOptions::default()
        }
    }

    /// Checks what a plan does not use (a nominal reference, the base frame), the spec, the
    /// prediction's draws, the tracker's site and the workcell's figures.
    ///
    /// # Errors
    ///
    /// [`JobError::Setting`] ([`JobSetting::Reference`], [`JobSetting::Frame`]);
    /// [`JobError::Spec`]; [`JobError::Plan`] ([`PlanField::Search`]) for draws out of range,
    /// and the site's ([`TrackerSite::check`]) and the workcell's ([`Workcell::check`]).
    pub fn check(&self) -> Result<(), JobError> {
        if let ReferenceSource::Nominal(_) = self.setup.problem.reference {
            return Err(JobError::Setting {
                setting: JobSetting::Reference,
                message: "a plan predicts the planned calibration's error against its own model \
                          (the calibrated reference); a nominal reference does not apply"
                    .into(),
            });
        }
        if self.setup.frame != Frame::Measurement {
            return Err(JobError::Setting {
                setting: JobSetting::Frame,
                message: "a plan predicts in the measurement frame, with the placement the \
                          calibration identifies; the base frame does not apply"
                    .into(),
            });
        }
        self.setup.problem.check()?;
        if !(100..=MAX_PREDICTION_DRAWS).contains(&self.draws) {
            return Err(PlanError::Setting {
                field: PlanField::Search,
                message: format!(
                    "the prediction's draws must be 100 … {MAX_PREDICTION_DRAWS}, got {}",
                    self.draws
                ),
            }
            .into());
        }
        if let Some(t) = &self.tracker {
            t.check()?;
        }
        self.workcell.check()?;
        Ok(())
    }

    /// Plans, then predicts.
    ///
    /// # Errors
    ///
    /// Those of [`Self::check`]; [`JobError::Setting`] ([`JobSetting::Task`]) when the ISO
    /// 9283 poses cannot be placed; [`JobError::Plan`] for a task the robot cannot reach in its
    /// workcell (given points only: generated ones are a stand-in), a setting the planner
    /// refuses, candidates that do not identify the model; [`JobError::Memory`]
    /// ([`MemoryCheck::PlanSearch`], [`MemoryCheck::PlanPrediction`]) before either exists.
    pub fn run(&self, backends: &dyn Backends) -> Result<PlanOutcome, JobError> {
        self.check()?;
        let built = self.setup.built()?;
        let model = plan::model_to_plan(&built.problem);
        let task: Vec<Joints> = match self.task {
            PlanTask::Iso9283 => {
                let rpy = crate::map::tool_down_rpy_deg(&model);
                let cube = crate::iso9283::test_cube(&model, Some(rpy)).map_err(|e| {
                    JobError::Setting {
                        setting: JobSetting::Task,
                        message: e.0,
                    }
                })?;
                cube.poses_q_deg.to_vec()
            }
            PlanTask::Points => built
                .problem
                .points
                .iter()
                .map(|q| q.map(f64::to_degrees))
                .collect(),
        };
        let target = self
            .target
            .unwrap_or_else(|| PlanOptions::default_target(&model));
        let generated = matches!(self.setup.problem.points, PointsSource::Generate(_));
        if self.task == PlanTask::Iso9283 || !generated {
            // A task the robot cannot reach above the floor and outside the boxes cannot be
            // planned for; generated points are a stand-in and are not checked.
            let mut arm = model.clone();
            arm.tool = target;
            plan::workcell::check_task(&arm, &task, &self.workcell)?;
        }
        let opts = self.options(target);
        // The candidates' matrices and the prediction's draws, sized before either exists.
        let what = format!(
            "a plan from {} candidates at {} task points",
            opts.candidates,
            task.len()
        );
        let search = plan::plan_estimate(
            &model,
            task.len(),
            &opts,
            Estimate::new(
                what.clone(),
                "use fewer candidates, or raise the memory limit",
            ),
        );
        self.setup.fits(MemoryCheck::PlanSearch, &search)?;
        let prediction = plan::prediction_estimate(
            task.len(),
            self.draws,
            plan::plan_estimate(
                &model,
                task.len(),
                &opts,
                Estimate::new(
                    format!("{what} and a prediction of {} draws", self.draws),
                    "use fewer draws, or raise the memory limit",
                ),
            ),
        );
        self.setup.fits(MemoryCheck::PlanPrediction, &prediction)?;
        let mut p = plan::plan(&model, &task, &opts)?;
        let seed = self.setup.problem.seed;
        let problem = plan::prediction_problem(&p, &task, seed)?;
        let analysed = Analysed::of(&problem);
        let (mut ev, notes) = crate::spec::make_evaluator(
            backends,
            problem,
            self.setup.problem.backend,
            self.setup.problem.adapter.as_deref(),
        )?;
        for n in &notes {
            self.setup.progress.notice(Notice::Note(n));
        }
        let progress = self.setup.progress.clone();
        let draws = ProgressHook::new(move |_: &str, done, total| {
            progress.report("plan prediction", done, total)
        });
        p.prediction = Some(plan::predict_with_progress(
            ev.as_mut(),
            self.draws,
            &self.thresholds,
            &draws,
        )?);
        Ok(PlanOutcome {
            plan: p,
            notes,
            analysed,
        })
    }
}
