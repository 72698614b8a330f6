//! The tail job: the problem and the thresholds → Pr[w ≥ L] and β at each, by subset
//! simulation or crude Monte Carlo ([`crate::mc::tail`]).

use super::{counted, Analysed, JobError, MemoryCheck, Setup};
use crate::engine::Backends;
use crate::mc::tail::{run_tail, TailOptions, TailResult};
use crate::memory::Estimate;
use crate::spec::ProblemSpec;

/// Evaluations of w a tail job makes at most unless told otherwise (`gpu-amcs tail`'s default).
pub const DEFAULT_MAX_EVALUATIONS: u64 = 5_000_000;

/// What a [`TailJob`] gives.
#[derive(Clone, Debug)]
pub struct TailOutcome {
    /// The estimates and their report.
    pub result: TailResult,
    /// What the job chose (the backend, the frame), as it told them.
    pub notes: Vec<String>,
    /// The problem as analysed, for the report page's model rows.
    pub analysed: Analysed,
}

/// Tail probabilities `P_f = Pr[w ≥ L]` down to 10⁻⁹.
///
/// # Examples
///
/// ```
/// use gpu_amcs_core::engine::{BackendChoice, CpuOnly};
/// use gpu_amcs_core::job::TailJob;
/// use gpu_amcs_core::spec::{GeneratedPoints, PointsSource, ProblemSpec};
///
/// let mut job = TailJob::new(ProblemSpec {
///     points: PointsSource::Generate(GeneratedPoints { count: 3, ..Default::default() }),
///     backend: BackendChoice::Cpu,
///     ..ProblemSpec::default()
/// });
/// job.options.thresholds = vec![0.3];
/// job.options.samples_per_level = 200;
/// job.options.target_cov = 0.5;
/// let outcome = job.run(&CpuOnly).unwrap();
/// let p = outcome.result.estimates[0].p_f;
/// assert!(p > 0.0 && p < 1.0);
/// ```
#[derive(Clone, Debug)]
pub struct TailJob {
    /// Problem, frame, memory and progress.
    pub setup: Setup,
    /// The estimator's options (`gpu-amcs tail`'s defaults; the thresholds have none).
    pub options: TailOptions,
}

impl TailJob {
    /// The analysis of `problem` with the defaults (at most [`DEFAULT_MAX_EVALUATIONS`]) and no
    /// thresholds yet.
    pub fn new(problem: ProblemSpec) -> TailJob {
        TailJob {
            setup: Setup::new(problem),
            options: TailOptions {
                max_evaluations: DEFAULT_MAX_EVALUATIONS,
                ..TailOptions::default()
            },
        }
    }

    /// What the analysis keeps at `m` test points.
    pub fn memory_estimate(&self, m: u64) -> Estimate {
        Setup::with_points(
            self.options
                .memory_estimate("use fewer samples per level, or raise the memory limit"),
            m,
        )
    }

    /// Checks the options, the spec and the memory of the points known before reading a file.
    ///
    /// # Errors
    ///
    /// [`JobError::Tail`] naming a setting, [`JobError::Spec`], [`JobError::Memory`]
    /// ([`MemoryCheck::Tail`]).
    pub fn check(&self) -> Result<(), JobError> {
        self.options.check()?;
        self.setup
            .check(MemoryCheck::Tail, &|m| self.memory_estimate(m))
    }

    /// Runs the estimator; the progress is counted in evaluations of w under "tail" (the total
    /// is the cap).
    ///
    /// # Errors
    ///
    /// Those of [`Self::check`], the memory again once a points file is read, the evaluator's
    /// and the estimator's.
    pub fn run(&self, backends: &dyn Backends) -> Result<TailOutcome, JobError> {
        self.check()?;
        let built = self
            .setup
            .build(MemoryCheck::Tail, &|m| self.memory_estimate(m))?;
        let analysed = Analysed::of(&built.problem);
        let (mut ev, notes) = self.setup.evaluator_told(backends, built.problem.clone())?;
        let problem = built.problem.in_frame(self.setup.frame);
        let progress = counted(&self.setup.progress, "tail");
        let result = run_tail(ev.as_mut(), &problem, &self.options, Some(&progress))?;
        Ok(TailOutcome {
            result,
            notes,
            analysed,
        })
    }
}
