//! The AMCS and MCS jobs: the problem and the driver's options → the run report. An MCS run
//! whose values would not fit the memory is summarised chunk by chunk instead
//! ([`SummaryMode::Auto`], `summary.rs`). Both keep their notes in the report (its text prints
//! them) and tell only what loading the model chose.

use super::{counted, Analysed, JobError, MemoryCheck, Setup, Shard, BYTES_PER_DRAW};
use crate::engine::Backends;
use crate::mc::summary::Summary;
use crate::mc::{self, AmcsOptions, McError, McResult, McsOptions, RunSettings};
use crate::memory::{Bytes, Estimate};
use crate::report::{self, RunReport};
use crate::spec::ProblemSpec;

/// What an [`AmcsJob`] or [`McsJob`] gives.
#[derive(Clone, Debug)]
pub struct RunOutcome {
    /// The report (text, JSON, CSV, SVG, HTML).
    pub report: RunReport,
    /// The problem as analysed, for the report page's model rows.
    pub analysed: Analysed,
    /// The summary of a summarised MCS run (what `merge` reads), none when the values were kept.
    pub summary: Option<Summary>,
}

/// An adaptive Monte Carlo run (GUM S1 §7.9): the main job.
///
/// # Examples
///
/// ```
/// use gpu_amcs_core::engine::{BackendChoice, CpuOnly};
/// use gpu_amcs_core::job::AmcsJob;
/// use gpu_amcs_core::mc::Tolerance;
/// use gpu_amcs_core::spec::{GeneratedPoints, PointsSource, ProblemSpec};
///
/// let mut job = AmcsJob::new(ProblemSpec {
///     points: PointsSource::Generate(GeneratedPoints { count: 4, ..Default::default() }),
///     backend: BackendChoice::Cpu,
///     ..ProblemSpec::default()
/// });
/// job.options.tolerance = Tolerance::Delta(0.05);
/// job.options.batch_size = 2000;
/// let outcome = job.run(&CpuOnly).unwrap();
/// assert!(outcome.report.result.converged);
/// assert_eq!(outcome.report.notes, Vec::<String>::new());
/// ```
#[derive(Clone, Debug)]
pub struct AmcsJob {
    /// Problem, frame, memory and progress.
    pub setup: Setup,
    /// The driver's options (`gpu-amcs amcs`'s defaults: δ = 0.01 mm, batches of 10⁴, at most
    /// 10⁷ draws).
    pub options: AmcsOptions,
}

impl AmcsJob {
    /// The run of `problem` with the defaults.
    pub fn new(problem: ProblemSpec) -> AmcsJob {
        AmcsJob {
            setup: Setup::new(problem),
            options: AmcsOptions::default(),
        }
    }

    /// What the run keeps at `m` test points: up to the cap's values, the points and, with
    /// per-point output, a batch of per-point errors in the driver's buffer and the evaluator's.
    pub fn memory_estimate(&self, m: u64) -> Estimate {
        let o = &self.options;
        kept(
            Estimate::new(
                format!("AMCS with up to {} draws", o.max_draws),
                "lower the draw cap or the batch, use fewer points or no per-point output, \
                 or raise the memory limit",
            ),
            o.max_draws,
            o.batch_size,
            o.settings.per_point,
            m,
        )
    }

    /// Checks the options, the spec and the memory of the points known before reading a file.
    ///
    /// # Errors
    ///
    /// [`JobError::Run`] naming a driver setting, [`JobError::Spec`],
    /// [`JobError::Memory`] ([`MemoryCheck::Amcs`]).
    pub fn check(&self) -> Result<(), JobError> {
        self.options.check()?;
        self.setup
            .check(MemoryCheck::Amcs, &|m| self.memory_estimate(m))
    }

    /// Builds the problem, opens the evaluator and runs; the progress is counted in draws
    /// under "AMCS" (the total is the cap).
    ///
    /// # Errors
    ///
    /// Those of [`Self::check`], the memory again once a points file is read, the evaluator's
    /// and the driver's.
    pub fn run(&self, backends: &dyn Backends) -> Result<RunOutcome, JobError> {
        self.check()?;
        let opts = &self.options;
        kept_run(
            &self.setup,
            (MemoryCheck::Amcs, &|m| self.memory_estimate(m)),
            backends,
            "AMCS",
            &|ev, progress| mc::run_amcs(ev, opts, Some(progress)),
        )
    }
}

/// How an [`McsJob`] keeps its draws.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SummaryMode {
    /// Keep every value when they fit the memory, else summarise them chunk by chunk (a note
    /// says so).
    Auto,
    /// Keep every value; a run whose values do not fit is refused ([`MemoryCheck::Mcs`]).
    Never,
    /// Summarise the draws of [`McsJob::shard`] (for `merge`).
    Always,
}

/// A Monte Carlo run with a fixed number of draws.
///
/// # Examples
///
/// ```
/// use gpu_amcs_core::engine::{BackendChoice, CpuOnly};
/// use gpu_amcs_core::job::{McsJob, Shard, SummaryMode};
/// use gpu_amcs_core::spec::{GeneratedPoints, PointsSource, ProblemSpec};
///
/// let mut job = McsJob::new(ProblemSpec {
///     points: PointsSource::Generate(GeneratedPoints { count: 4, ..Default::default() }),
///     backend: BackendChoice::Cpu,
///     ..ProblemSpec::default()
/// });
/// job.draws = 4000;
/// let kept = job.run(&CpuOnly).unwrap();
/// assert_eq!(kept.report.result.sorted_values.len(), 4000);
///
/// // The first of two shards, summarised: its summary is what `merge` reads.
/// job.summary = SummaryMode::Always;
/// job.shard = Shard::new(0, 2).unwrap();
/// let half = job.run(&CpuOnly).unwrap();
/// let summary = half.summary.unwrap();
/// assert_eq!((summary.provenance.first, summary.provenance.end), (0, 2000));
/// ```
#[derive(Clone, Debug)]
pub struct McsJob {
    /// Problem, frame, memory and progress.
    pub setup: Setup,
    /// Draws (`gpu-amcs mcs`'s default: 10⁶).
    pub draws: u64,
    /// Coverage, interval, thresholds, per-point output.
    pub settings: RunSettings,
    /// Whether the values are kept or summarised.
    pub summary: SummaryMode,
    /// The draws a summarised run evaluates ([`SummaryMode::Always`]); the whole run otherwise.
    pub shard: Shard,
}

impl McsJob {
    /// The run of `problem` with the defaults, summarised when its values would not fit.
    pub fn new(problem: ProblemSpec) -> McsJob {
        McsJob {
            setup: Setup::new(problem),
            draws: McsOptions::default().draws,
            settings: RunSettings::default(),
            summary: SummaryMode::Auto,
            shard: Shard::WHOLE,
        }
    }

    /// Draws per evaluation chunk of a run of `draws` draws (results do not depend on it).
    pub fn chunk(draws: u64) -> u64 {
        100_000.min(draws.max(1))
    }

    /// The driver's options.
    pub fn options(&self) -> McsOptions {
        McsOptions {
            draws: self.draws,
            chunk: Self::chunk(self.draws),
            settings: self.settings.clone(),
        }
    }

    /// What the run keeps at `m` test points when it keeps its values: every value, the points
    /// and, with per-point output, a chunk of per-point errors in the driver's buffer and the
    /// evaluator's.
    pub fn memory_estimate(&self, m: u64) -> Estimate {
        kept(
            Estimate::new(
                format!("MCS with {} draws", self.draws),
                "use fewer draws (or AMCS), fewer points or no per-point output, or raise the \
                 memory limit",
            ),
            self.draws,
            Self::chunk(self.draws),
            self.settings.per_point,
            m,
        )
    }

    /// Runs: keeps the values, or summarises them ([`Self::summary`]); the progress is counted
    /// in draws under "MCS", "MCS (summary)" or "MCS shard".
    ///
    /// # Errors
    ///
    /// [`JobError::Run`] naming a driver setting, [`JobError::Spec`], [`JobError::Memory`]
    /// ([`MemoryCheck::Mcs`] or [`MemoryCheck::McsSummary`]), [`JobError::Setting`]
    /// ([`super::JobSetting::Shard`]) for more shards than draws, [`JobError::Summary`], and the
    /// evaluator's errors.
    pub fn run(&self, backends: &dyn Backends) -> Result<RunOutcome, JobError> {
        match self.summary {
            SummaryMode::Always => {
                return super::summary::run(self, backends, "MCS shard", Vec::new())
            }
            SummaryMode::Never => {}
            SummaryMode::Auto => {
                self.settings.check()?;
                let known = self.setup.problem.known_points().unwrap_or(0) as u64;
                let values = self.memory_estimate(known);
                let budget = &self.setup.memory;
                if budget.check(&values).is_err() {
                    let needed = match values.bytes {
                        Some(b) => Bytes(b).to_string(),
                        None => "more than 2^64 bytes".to_string(),
                    };
                    let note = format!(
                        "summary mode: keeping the values of {} draws would need {needed}, more \
                         than the memory limit of {} ({}); the draws were summarised chunk by \
                         chunk instead",
                        self.draws,
                        Bytes(budget.limit),
                        budget.source
                    );
                    return super::summary::run(self, backends, "MCS (summary)", vec![note]);
                }
            }
        }
        let opts = self.options();
        opts.settings.check()?;
        self.setup
            .check(MemoryCheck::Mcs, &|m| self.memory_estimate(m))?;
        kept_run(
            &self.setup,
            (MemoryCheck::Mcs, &|m| self.memory_estimate(m)),
            backends,
            "MCS",
            &|ev, progress| mc::run_mcs(ev, &opts, Some(progress)),
        )
    }
}

/// `e` with `draws` values, `m` test points and, with `per_point`, `batch` × m per-point errors
/// in the driver's buffer and as many in the evaluator's.
fn kept(e: Estimate, draws: u64, batch: u64, per_point: bool, m: u64) -> Estimate {
    let e = e
        .plus(&[draws, BYTES_PER_DRAW])
        .plus(&[m, super::BYTES_PER_POINT]);
    if per_point {
        e.plus(&[batch, m, 2 * 8])
    } else {
        e
    }
}

/// The driver of a run that keeps its values.
type Drive<'a> = &'a (dyn Fn(&mut dyn crate::engine::Evaluator, mc::Progress) -> Result<McResult, McError>
         + Sync);

/// Builds the problem (checking `memory` once its points are known), opens the evaluator and
/// runs `drive` under `label`; the report's notes: the model's, then the evaluator's.
fn kept_run(
    setup: &Setup,
    (check, estimate): (MemoryCheck, &dyn Fn(u64) -> Estimate),
    backends: &dyn Backends,
    label: &'static str,
    drive: Drive<'_>,
) -> Result<RunOutcome, JobError> {
    let built = setup.build(check, estimate)?;
    let analysed = Analysed::of(&built.problem);
    let seed = built.problem.seed;
    let model_notes = report::model_notes(&built.problem.model);
    let (mut ev, notes) = setup.evaluator(backends, built.problem)?;
    let progress = counted(&setup.progress, label);
    let result = drive(ev.as_mut(), &progress)?;
    Ok(RunOutcome {
        report: RunReport {
            model: analysed.model.name.clone(),
            points: analysed.points,
            reference: built.reference,
            seed,
            notes: [model_notes, notes].concat(),
            result,
        },
        analysed,
        summary: None,
    })
}

/// The run report of a summary, with its note after `notes` (a summarised run's, and
/// `merge`'s of its shards).
pub fn summary_report(s: &Summary, mut notes: Vec<String>) -> RunReport {
    let p = &s.provenance;
    notes.push(s.note());
    RunReport {
        model: p.model.clone(),
        points: p.points,
        reference: p.reference.clone(),
        seed: p.seed,
        notes,
        result: s.to_result(),
    }
}
