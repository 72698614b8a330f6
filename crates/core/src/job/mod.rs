//! One library call per analysis, as every front end runs it: the problem a user states and the
//! analysis's options → the memory checked → the evaluator opened → the driver run with a
//! progress hook → the report and its notes. The command line (`gpu-amcs amcs`, `mcs`,
//! `compare`, `sensitivity`, `tail`, `map`, `plan`) and Python (`gpu_amcs.amcs`, …) each fill
//! one job and call `run`; neither builds the problem, picks the backend or a memory mode, or
//! assembles a report itself. The identification's job is [`crate::identify::IdentifyJob`].
//!
//! | job | analysis | result |
//! |---|---|---|
//! | [`AmcsJob`] | adaptive Monte Carlo (the main job) | [`RunOutcome`] |
//! | [`McsJob`] | Monte Carlo with a fixed number of draws, kept or summarised | [`RunOutcome`] |
//! | [`CompareJob`] | MCS against AMCS at several tolerances (the paper's Table 2) | [`CompareOutcome`] |
//! | [`SensitivityJob`] | Sobol indices of `w` (or one shard's outputs) | [`SensitivityOutcome`] |
//! | [`TailJob`] | tail probabilities by subset simulation | [`TailOutcome`] |
//! | [`MapJob`] | the workspace reliability map (or one shard's cells) | [`MapOutcome`] |
//! | [`PlanJob`] | a calibration plan and its predicted reliability | [`PlanOutcome`] |
//!
//! Errors ([`JobError`]) name what a user changes: a driver's setting (its own enum), a field
//! of the [`ProblemSpec`] ([`SpecField`](crate::spec::SpecField)), a [`JobSetting`], or the
//! [`MemoryCheck`] that refused the run; a front end spells each its own way (a flag, a
//! keyword) and words the memory advice with its names ([`MemoryError::with_advice`]). What a
//! job chooses on the user's behalf (the backend, the frame, a summary instead of the values)
//! it tells as a [`Notice`] as it arises and keeps in its result.
//!
//! # Examples
//!
//! ```
//! use gpu_amcs_core::engine::{BackendChoice, CpuOnly};
//! use gpu_amcs_core::job::AmcsJob;
//! use gpu_amcs_core::spec::{GeneratedPoints, PointsSource, ProblemSpec};
//!
//! let mut job = AmcsJob::new(ProblemSpec {
//!     points: PointsSource::Generate(GeneratedPoints { count: 5, ..Default::default() }),
//!     backend: BackendChoice::Cpu,
//!     ..ProblemSpec::default()
//! });
//! job.options.batch_size = 2000;
//! job.options.max_draws = 20_000;
//! let outcome = job.run(&CpuOnly).unwrap();
//! assert_eq!(outcome.report.points, 5);
//! assert!(outcome.report.result.draws >= 4000);
//! ```

mod compare;
mod map;
mod plan;
mod run;
mod sensitivity;
mod summary;
mod tail;
#[cfg(test)]
mod tests;

pub use compare::{CompareJob, CompareOutcome, COMPARE_AMCS_CAP};
pub use map::{MapJob, MapOutcome, MapSettings};
pub use plan::{PlanJob, PlanOutcome, PlanTask, MAX_PREDICTION_DRAWS};
pub use run::{summary_report, AmcsJob, McsJob, RunOutcome, SummaryMode};
pub use sensitivity::{SensitivityJob, SensitivityOutcome};
pub use tail::{TailJob, TailOutcome, DEFAULT_MAX_EVALUATIONS};

use crate::engine::{Backends, Evaluator, Frame, Problem};
use crate::kinematics::RobotModel;
use crate::memory::{Estimate, MemoryBudget, MemoryError};
use crate::progress::{Notice, ProgressHook};
use crate::spec::{self, BuiltProblem, ProblemSpec, SpecError};

/// Bytes kept per test point: the configuration in degrees and radians, the reference position
/// and the problem's bookkeeping, with room to spare.
pub const BYTES_PER_POINT: u64 = 256;

/// Bytes kept per draw of a run that keeps its values: the value, and as much again for the
/// growth of the value vector.
pub const BYTES_PER_DRAW: u64 = 16;

/// The settings a job checks itself (besides its driver's, which name their own).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum JobSetting {
    /// The shard of a run: more shards than there is work to split.
    Shard,
    /// A plan's task: the ISO 9283 test poses cannot be placed for the model.
    Task,
    /// The reference: a plan predicts against its own model, never a nominal one.
    Reference,
    /// The frame of the targets: a plan predicts in the measurement frame.
    Frame,
}

/// Which memory estimate refused a job: each names what to make smaller.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MemoryCheck {
    /// An AMCS run keeping up to its draw cap: the cap, the batch, the points, per-point output.
    Amcs,
    /// An MCS run keeping its values: the draws, the points, per-point output (or AMCS).
    Mcs,
    /// An MCS run summarised chunk by chunk: the points, per-point output.
    McsSummary,
    /// A comparison: the MCS draws (kept while the AMCS runs grow up to their cap), the points.
    Compare,
    /// A sensitivity analysis: its base samples.
    Sensitivity,
    /// Tail probabilities: the samples per level.
    Tail,
    /// A map: its cells and draws; `shards` is the fewest shards that would each fit, when
    /// some would.
    Map {
        /// The fewest shards that fit.
        shards: Option<usize>,
    },
    /// A plan's search: its candidates.
    PlanSearch,
    /// A plan's prediction: its draws.
    PlanPrediction,
}

/// Why a job gave no result.
#[derive(Debug, thiserror::Error)]
pub enum JobError {
    /// The problem cannot be built; names the spec's field.
    #[error(transparent)]
    Spec(#[from] SpecError),
    /// The run would need more memory than the budget allows; the error's advice is in words
    /// (a front end puts its own, [`MemoryError::with_advice`]).
    #[error("{error}")]
    Memory {
        /// The estimate that refused it.
        check: MemoryCheck,
        /// The refusal.
        error: MemoryError,
    },
    /// A setting the job checks cannot be used; the message says why (without naming the
    /// setting, which the front end does).
    #[error("{message}")]
    Setting {
        /// The setting at fault.
        setting: JobSetting,
        /// What is wrong.
        message: String,
    },
    /// The AMCS or MCS driver refused or failed.
    #[error(transparent)]
    Run(#[from] crate::mc::McError),
    /// A summarised MCS run failed.
    #[error(transparent)]
    Summary(#[from] crate::mc::summary::SummaryError),
    /// The sensitivity analysis refused or failed.
    #[error(transparent)]
    Sensitivity(#[from] crate::mc::sensitivity::SensitivityError),
    /// The tail analysis refused or failed.
    #[error(transparent)]
    Tail(#[from] crate::mc::tail::TailError),
    /// The map refused or failed.
    #[error(transparent)]
    Map(#[from] crate::map::MapError),
    /// The map's reached configurations make no problem.
    #[error("reached configurations")]
    Reached(#[source] crate::engine::ProblemError),
    /// The plan refused or failed.
    #[error(transparent)]
    Plan(#[from] crate::plan::PlanError),
}

/// Shard `k` of `n` (from 0) of a run split over processes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// This shard.
    pub k: u64,
    /// Number of shards.
    pub n: u64,
}

impl Shard {
    /// The whole run.
    pub const WHOLE: Shard = Shard { k: 0, n: 1 };

    /// Shard `k` of `n`, when `k < n`.
    pub fn new(k: u64, n: u64) -> Option<Shard> {
        (k < n).then_some(Shard { k, n })
    }

    /// Its part `[K·items/N, (K+1)·items/N)` of `items`.
    pub fn range(&self, items: u64) -> (u64, u64) {
        let at = |k: u64| (u128::from(k) * u128::from(items) / u128::from(self.n)) as u64;
        (at(self.k), at(self.k + 1))
    }

    /// Refuses more shards than `items` (`what` they are in words: "1000 draws"): some would
    /// be empty.
    fn check(&self, items: u64, what: &str) -> Result<(), JobError> {
        if self.n > items {
            return Err(JobError::Setting {
                setting: JobSetting::Shard,
                message: format!("{} shards of {what} leave some empty", self.n),
            });
        }
        Ok(())
    }
}

/// The problem a job analysed, as its report pages describe it.
#[derive(Clone, Debug)]
pub struct Analysed {
    /// The model as analysed (without the placement's spread in the base frame, where the job
    /// reports it so).
    pub model: RobotModel,
    /// Its number of test points.
    pub points: usize,
}

impl Analysed {
    /// The model and the number of test points of `problem`.
    pub fn of(problem: &Problem) -> Analysed {
        Analysed {
            model: problem.model.clone(),
            points: problem.n_points(),
        }
    }
}

/// What every analysis on test points shares: the problem, the frame of its targets, the memory
/// it may use and who hears its progress.
#[derive(Clone, Debug)]
pub struct Setup {
    /// Model, test points, reference, seed, backend.
    pub problem: ProblemSpec,
    /// The frame of the targets: the measurement frame draws a model's uncertain placement.
    pub frame: Frame,
    /// The memory the job may plan to use.
    pub memory: MemoryBudget,
    /// Told the job's progress and [`Notice`]s.
    pub progress: ProgressHook,
}

impl Setup {
    /// `problem` in the measurement frame, within the default budget ([`MemoryBudget::new`]),
    /// heard by nobody.
    pub fn new(problem: ProblemSpec) -> Setup {
        Setup {
            problem,
            frame: Frame::Measurement,
            memory: MemoryBudget::new(None),
            progress: ProgressHook::none(),
        }
    }

    /// Checks `estimate` against the budget as `check`.
    fn fits(&self, check: MemoryCheck, estimate: &Estimate) -> Result<(), JobError> {
        self.memory
            .check(estimate)
            .map_err(|error| JobError::Memory { check, error })
    }

    /// Checks what needs no file and `estimate` of the points known before reading any
    /// (none for a points file).
    fn check(
        &self,
        check: MemoryCheck,
        estimate: &dyn Fn(u64) -> Estimate,
    ) -> Result<(), JobError> {
        self.problem.check()?;
        self.fits(
            check,
            &estimate(self.problem.known_points().unwrap_or(0) as u64),
        )
    }

    /// Builds the problem (telling what loading the model chose) and checks `estimate` of its
    /// points.
    fn build(
        &self,
        check: MemoryCheck,
        estimate: &dyn Fn(u64) -> Estimate,
    ) -> Result<BuiltProblem, JobError> {
        let built = self.built()?;
        self.fits(check, &estimate(built.problem.n_points() as u64))?;
        Ok(built)
    }

    /// Builds the problem, telling what loading the model chose.
    fn built(&self) -> Result<BuiltProblem, JobError> {
        let built = self.problem.build_problem()?;
        for n in &built.notes {
            self.progress.notice(Notice::Model(n));
        }
        Ok(built)
    }

    /// The evaluator of `problem` in the job's frame, with the notes on the choice.
    fn evaluator(
        &self,
        backends: &dyn Backends,
        problem: Problem,
    ) -> Result<(Box<dyn Evaluator>, Vec<String>), JobError> {
        Ok(spec::make_frame_evaluator(
            backends,
            problem,
            self.problem.backend,
            self.problem.adapter.as_deref(),
            self.frame,
        )?)
    }

    /// [`Self::evaluator`], each note told as it arises.
    fn evaluator_told(
        &self,
        backends: &dyn Backends,
        problem: Problem,
    ) -> Result<(Box<dyn Evaluator>, Vec<String>), JobError> {
        let (ev, notes) = self.evaluator(backends, problem)?;
        for n in &notes {
            self.progress.notice(Notice::Note(n));
        }
        Ok((ev, notes))
    }

    /// The test points' estimate: `e` and [`BYTES_PER_POINT`] for each of `m`.
    fn with_points(e: Estimate, m: u64) -> Estimate {
        e.plus(&[m, BYTES_PER_POINT])
    }
}

/// A driver's progress, told to `hook` under `label`.
fn counted<'a>(hook: &'a ProgressHook, label: &'static str) -> impl Fn(u64, u64) + Sync + 'a {
    move |done, total| hook.report(label, done, total)
}
