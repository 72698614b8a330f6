//! The comparison job: one MCS run and one AMCS run per tolerance δ on the same evaluator, each
//! AMCS run's moments measured against the MCS run's (the paper's Table 2 for one model).

use super::{counted, Analysed, JobError, MemoryCheck, Setup, BYTES_PER_DRAW};
use crate::engine::Backends;
use crate::mc::{self, AmcsOptions, McsOptions, RunSettings, Tolerance};
use crate::memory::Estimate;
use crate::report::{self, Comparison};
use crate::spec::ProblemSpec;

/// The draw cap of each AMCS run of a comparison: each is to converge.
pub const COMPARE_AMCS_CAP: u64 = 100_000_000;

/// What a [`CompareJob`] gives.
#[derive(Clone, Debug)]
pub struct CompareOutcome {
    /// The MCS run, the AMCS runs with their maximum relative errors, and the notes (the
    /// model's, then the evaluator's).
    pub comparison: Comparison,
    /// The problem as analysed, for the report page's model rows.
    pub analysed: Analysed,
}

/// MCS against AMCS at several tolerances: the MCS run first, then one AMCS run per δ, each
/// capped at [`COMPARE_AMCS_CAP`] draws; each AMCS run's maximum relative error of the moments
/// M1–M4 is against the MCS run's ([`report::max_relative_error`]). The runs use the same
/// evaluator and the same draws (the stream of the problem's seed), as independent [`McsJob`]
/// and [`AmcsJob`] runs would, in the job's frame (the measurement frame draws a model's
/// uncertain placement).
///
/// [`McsJob`]: super::McsJob
/// [`AmcsJob`]: super::AmcsJob
///
/// # Examples
///
/// ```
/// use gpu_amcs_core::engine::{BackendChoice, CpuOnly};
/// use gpu_amcs_core::job::CompareJob;
/// use gpu_amcs_core::spec::{GeneratedPoints, PointsSource, ProblemSpec};
///
/// let mut job = CompareJob::new(ProblemSpec {
///     points: PointsSource::Generate(GeneratedPoints { count: 5, ..Default::default() }),
///     backend: BackendChoice::Cpu,
///     ..ProblemSpec::default()
/// });
/// job.draws = 20_000;
/// job.deltas = vec![0.05];
/// job.batch_size = 2000;
/// let c = job.run(&CpuOnly).unwrap().comparison;
/// assert_eq!((c.points, c.mcs.draws), (5, 20_000));
/// let (delta, amcs, mre) = &c.amcs[0];
/// assert_eq!(*delta, 0.05);
/// assert!(amcs.converged && mre.is_finite());
/// ```
#[derive(Clone, Debug)]
pub struct CompareJob {
    /// Problem, memory and progress ("MCS", then "AMCS δ=…" for each δ, in draws).
    pub setup: Setup,
    /// Draws of the MCS run (`gpu-amcs compare`'s default: 10⁶).
    pub draws: u64,
    /// The AMCS runs' tolerances δ, mm, in the order they run.
    pub deltas: Vec<f64>,
    /// The AMCS runs' batch size H.
    pub batch_size: u64,
    /// Coverage probability p of every run.
    pub coverage_probability: f64,
}

impl CompareJob {
    /// The comparison of `problem` with `gpu-amcs compare`'s defaults: 10⁶ MCS draws, δ = 0.01
    /// and 0.02 mm, batches of 10⁴, p = 0.95.
    pub fn new(problem: ProblemSpec) -> CompareJob {
        CompareJob {
            setup: Setup::new(problem),
            draws: McsOptions::default().draws,
            deltas: vec![0.01, 0.02],
            batch_size: AmcsOptions::default().batch_size,
            coverage_probability: RunSettings::default().coverage_probability,
        }
    }

    /// The runs' settings: the coverage probability, the rest the defaults (a comparison is
    /// of the moments).
    fn settings(&self) -> RunSettings {
        RunSettings {
            coverage_probability: self.coverage_probability,
            ..RunSettings::default()
        }
    }

    /// The MCS run's options.
    pub fn mcs_options(&self) -> McsOptions {
        McsOptions {
            draws: self.draws,
            chunk: super::McsJob::chunk(self.draws),
            settings: self.settings(),
        }
    }

    /// The AMCS runs' options, one per δ.
    pub fn amcs_options(&self) -> Vec<AmcsOptions> {
        self.deltas
            .iter()
            .map(|&d| AmcsOptions {
                tolerance: Tolerance::Delta(d),
                batch_size: self.batch_size,
                max_draws: COMPARE_AMCS_CAP,
                settings: self.settings(),
            })
            .collect()
    }

    /// What the comparison keeps at `m` test points: the MCS values while an AMCS run grows up
    /// to its cap, and the points.
    pub fn memory_estimate(&self, m: u64) -> Estimate {
        Setup::with_points(
            Estimate::new(
                format!(
                    "MCS with {} draws and AMCS with up to {COMPARE_AMCS_CAP} draws",
                    self.draws
                ),
                "use fewer draws or points, or raise the memory limit",
            )
            .plus(&[self.draws, BYTES_PER_DRAW])
            .plus(&[COMPARE_AMCS_CAP, BYTES_PER_DRAW]),
            m,
        )
    }

    /// Checks every run's options, the spec and the memory of the points known before reading
    /// a file.
    ///
    /// # Errors
    ///
    /// [`JobError::Run`] naming a driver setting (the AMCS runs' first), [`JobError::Spec`],
    /// [`JobError::Memory`] ([`MemoryCheck::Compare`]).
    pub fn check(&self) -> Result<(), JobError> {
        for o in self.amcs_options() {
            o.check()?;
        }
        self.mcs_options().check()?;
        self.setup
            .check(MemoryCheck::Compare, &|m| self.memory_estimate(m))
    }

    /// Builds the problem, opens the evaluator, runs MCS, then AMCS at each δ.
    ///
    /// # Errors
    ///
    /// Those of [`Self::check`], the memory again once a points file is read, the evaluator's
    /// and the drivers'.
    pub fn run(&self, backends: &dyn Backends) -> Result<CompareOutcome, JobError> {
        self.check()?;
        let built = self
            .setup
            .build(MemoryCheck::Compare, &|m| self.memory_estimate(m))?;
        let analysed = Analysed::of(&built.problem);
        let seed = built.problem.seed;
        let model_notes = report::model_notes(&built.problem.model);
        let (mut ev, notes) = self.setup.evaluator(backends, built.problem)?;
        let hook = &self.setup.progress;
        let mcs = mc::run_mcs(
            ev.as_mut(),
            &self.mcs_options(),
            Some(&counted(hook, "MCS")),
        )?;
        let mut amcs = Vec::new();
        for (d, o) in self.deltas.iter().zip(self.amcs_options()) {
            let label = format!("AMCS δ={d}");
            let progress = |done, total| hook.report(&label, done, total);
            let r = mc::run_amcs(ev.as_mut(), &o, Some(&progress))?;
            let mre = report::max_relative_error(&r, &mcs);
            amcs.push((*d, r, mre));
        }
        Ok(CompareOutcome {
            comparison: Comparison {
                model: analysed.model.name.clone(),
                points: analysed.points,
                seed,
                mcs,
                amcs,
                notes: [model_notes, notes].concat(),
            },
            analysed,
        })
    }
}
