//! The sensitivity job: the problem and the Sobol options → the indices of `w`, or one shard's
//! model outputs for `merge`.

use super::{Analysed, JobError, MemoryCheck, Setup, Shard};
use crate::engine::{Backends, Evaluator, Problem};
use crate::mc::sensitivity::{run_sensitivity, SensitivityOptions, SensitivityResult};
use crate::mc::summary::{Provenance, SensitivityShard};
use crate::memory::Estimate;
use crate::progress::Notice;
use crate::spec::ProblemSpec;

/// Rows timed for the up-front estimate of a run's time.
const PILOT_ROWS: usize = 2048;

/// What a [`SensitivityJob`] gives.
#[derive(Clone, Debug)]
pub struct SensitivityOutcome {
    /// The indices and their report.
    pub result: SensitivityResult,
    /// What the job chose (the backend, the frame), as it told them.
    pub notes: Vec<String>,
    /// The problem as analysed, for the report page's model rows.
    pub analysed: Analysed,
}

/// First-order and total Sobol indices of `w` per input, joint and kind.
///
/// # Examples
///
/// ```
/// use gpu_amcs_core::engine::{BackendChoice, CpuOnly};
/// use gpu_amcs_core::job::SensitivityJob;
/// use gpu_amcs_core::spec::{GeneratedPoints, PointsSource, ProblemSpec};
///
/// let mut job = SensitivityJob::new(ProblemSpec {
///     points: PointsSource::Generate(GeneratedPoints { count: 3, ..Default::default() }),
///     backend: BackendChoice::Cpu,
///     ..ProblemSpec::default()
/// });
/// job.options.draws = 256;
/// job.options.bootstrap = 100;
/// let outcome = job.run(&CpuOnly).unwrap();
/// assert!(!outcome.result.w().inputs.is_empty());
/// ```
#[derive(Clone, Debug)]
pub struct SensitivityJob {
    /// Problem, frame, memory and progress.
    pub setup: Setup,
    /// The analysis's options (`gpu-amcs sensitivity`'s defaults: N = 2^13, 300 resamples).
    pub options: SensitivityOptions,
}

impl SensitivityJob {
    /// The analysis of `problem` with the defaults.
    pub fn new(problem: ProblemSpec) -> SensitivityJob {
        SensitivityJob {
            setup: Setup::new(problem),
            options: SensitivityOptions::default(),
        }
    }

    /// What the analysis keeps at `m` test points.
    pub fn memory_estimate(&self, m: u64) -> Estimate {
        Setup::with_points(
            self.options
                .memory_estimate("use fewer base samples, or raise the memory limit"),
            m,
        )
    }

    /// Checks the options, the spec and the memory of the points known before reading a file.
    ///
    /// # Errors
    ///
    /// [`JobError::Sensitivity`] naming a setting, [`JobError::Spec`], [`JobError::Memory`]
    /// ([`MemoryCheck::Sensitivity`]).
    pub fn check(&self) -> Result<(), JobError> {
        self.options.check()?;
        self.setup
            .check(MemoryCheck::Sensitivity, &|m| self.memory_estimate(m))
    }

    /// Runs the analysis. With a listener of notices it first times a pilot evaluation and
    /// tells the run's expected time ([`Notice::Estimate`], labelled "sensitivity").
    ///
    /// # Errors
    ///
    /// Those of [`Self::check`], the memory again once a points file is read, the evaluator's
    /// and the analysis's.
    pub fn run(&self, backends: &dyn Backends) -> Result<SensitivityOutcome, JobError> {
        self.check()?;
        let built = self
            .setup
            .build(MemoryCheck::Sensitivity, &|m| self.memory_estimate(m))?;
        let analysed = Analysed::of(&built.problem);
        let (mut ev, notes) = self.setup.evaluator_told(backends, built.problem.clone())?;
        let problem = built.problem.in_frame(self.setup.frame);
        if self.setup.progress.hears_notices() {
            if let Some((seconds, what)) = self.pilot(ev.as_mut(), &problem) {
                self.setup.progress.notice(Notice::Estimate {
                    label: "sensitivity",
                    seconds,
                    what: &what,
                });
            }
        }
        let result = run_sensitivity(&problem, ev.as_mut(), &self.options)?;
        Ok(SensitivityOutcome {
            result,
            notes,
            analysed,
        })
    }

    /// Evaluates shard `shard` of the analysis (chunks `[K·C/N, (K+1)·C/N)` of its C
    /// evaluation chunks of base samples) for `merge`, which computes the indices.
    ///
    /// # Errors
    ///
    /// Those of [`Self::run`], and [`JobError::Setting`] ([`super::JobSetting::Shard`]) for
    /// more shards than chunks.
    pub fn run_shard(
        &self,
        backends: &dyn Backends,
        shard: Shard,
    ) -> Result<SensitivityShard, JobError> {
        self.check()?;
        // Whole evaluation chunks, so every model call sees the rows of the one-run call (the
        // evaluators round alike only for the same rows at the same place in a call).
        let (n, chunk) = (self.options.draws as u64, self.options.chunk as u64);
        let chunks = n.div_ceil(chunk);
        shard.check(chunks, &format!("{chunks} chunks of {chunk} base samples"))?;
        let (c0, c1) = shard.range(chunks);
        let (first, end) = (c0 * chunk, (c1 * chunk).min(n));
        let built = self
            .setup
            .build(MemoryCheck::Sensitivity, &|m| self.memory_estimate(m))?;
        // The frame decides the inputs, and so the provenance's model hash: shards of the two
        // frames never merge.
        let problem = built.problem.clone().in_frame(self.setup.frame);
        let prov = Provenance::new(&problem, &built.reference, n, first, end);
        let (mut ev, _) = self.setup.evaluator(backends, built.problem)?;
        Ok(SensitivityShard::run(
            &problem,
            ev.as_mut(),
            &self.options,
            prov,
        )?)
    }

    /// The expected seconds of the run and its size in words: a pilot evaluation of
    /// [`PILOT_ROWS`] rows times the rows of the run (N base samples × (2 + free inputs + 8
    /// groups) pick-freeze matrices), plus a quarter for the bootstrap analysis (its share at
    /// 2^20 in `benches/sensitivity.rs`).
    fn pilot(&self, ev: &mut dyn Evaluator, problem: &Problem) -> Option<(f64, String)> {
        let offsets = vec![0.0; PILOT_ROWS * ev.offset_width()];
        let mut w = vec![0.0; PILOT_ROWS];
        let t = std::time::Instant::now();
        ev.evaluate_offsets(&offsets, &mut w, None).ok()?;
        let per_row = t.elapsed().as_secs_f64() / PILOT_ROWS as f64;
        let free = problem
            .model
            .param_sigmas()
            .iter()
            .filter(|s| **s > 0.0)
            .count();
        let matrices = 2 + free + 8;
        let seconds = 1.25 * per_row * (self.options.draws as f64 * matrices as f64);
        Some((
            seconds,
            format!(
                "N = {} base samples ({matrices} pick-freeze matrices)",
                self.options.draws
            ),
        ))
    }
}
