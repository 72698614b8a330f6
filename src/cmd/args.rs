//! From arguments to library values: each shared argument group converts itself
//! (`ModelArgs::load`, `ProblemArgs::build`, `OutputArgs::settings`, …), naming the flag in its
//! errors. Nothing here computes or writes.

use super::flags::{spec_error, spec_flag};
use crate::cli::*;
use anyhow::{bail, Context, Result};
use gpu_amcs::engine::backend::BackendChoice;
use gpu_amcs::engine::{Evaluator, Problem};
use gpu_amcs::kinematics::RobotModel;
use gpu_amcs::mc::{IntervalKind, RunSettings};
use gpu_amcs::memory::{self, Estimate, MemoryBudget};
use gpu_amcs::points::WorkspaceBox;
use gpu_amcs::simulate::{Experiment, Factors, SweepDirection};
use gpu_amcs::spec::{
    self, GeneratedPoints, ModelSource, PointsSource, ProblemSpec, ReferenceSource, SpecField,
};
use std::path::Path;

/// Bytes kept per test point: the configuration in degrees and radians, the reference
/// position and the problem's bookkeeping, with room to spare.
pub const BYTES_PER_POINT: u64 = 256;

/// Bytes kept per draw: its value, and as much again for the growth of the value vector.
pub const BYTES_PER_DRAW: u64 = 16;

impl From<BackendArg> for BackendChoice {
    fn from(b: BackendArg) -> Self {
        match b {
            BackendArg::Auto => BackendChoice::Auto,
            BackendArg::Gpu => BackendChoice::Gpu,
            BackendArg::Cpu => BackendChoice::Cpu,
        }
    }
}

impl From<IntervalArg> for IntervalKind {
    fn from(i: IntervalArg) -> Self {
        match i {
            IntervalArg::Shortest => IntervalKind::Shortest,
            IntervalArg::Symmetric => IntervalKind::Symmetric,
        }
    }
}

impl ModelArgs {
    /// The model file, or the preset when none is given.
    pub fn load(&self) -> Result<RobotModel> {
        load_model(self.model.as_deref(), &self.preset)
    }
}

/// A model file, or the preset `name` when there is none. A robot description (URDF `.urdf`/
/// `.xml`, DH table `.csv`, UR calibration `.yaml`/`.yml`) is imported on the fly, with the
/// same proof as `import` (a `.toml` is always read as a model file: write a DH table in TOML
/// through `import` first).
pub fn load_model(file: Option<&Path>, name: &str) -> Result<RobotModel> {
    Ok(ModelSource::file_or_preset(file, name).load()?)
}

impl BoxArgs {
    /// The workspace box for `model`: each of centre and size as given, else the robot's
    /// default ([`WorkspaceBox::for_robot`]).
    pub fn workspace(&self, model: &RobotModel) -> Result<WorkspaceBox> {
        Ok(self.generated(0, 0)?.workspace(model))
    }

    /// Checks the given flags' shapes (three numbers each).
    pub fn check(&self) -> Result<()> {
        self.generated(0, 0).map(|_| ())
    }

    /// `count` points generated with `seed` in this box.
    pub fn generated(&self, count: usize, seed: u64) -> Result<GeneratedPoints> {
        Ok(GeneratedPoints {
            count,
            seed,
            box_center: three(self.box_center.as_deref(), SpecField::BoxCenter)?,
            box_size: three(self.box_size.as_deref(), SpecField::BoxSize)?,
        })
    }
}

/// A flag of three numbers x,y,z (mm), when given.
fn three(v: Option<&[f64]>, field: SpecField) -> Result<Option<[f64; 3]>> {
    match v {
        None => Ok(None),
        Some([x, y, z]) => Ok(Some([*x, *y, *z])),
        Some(v) => bail!(
            "{} needs three numbers x,y,z (mm), got {}",
            spec_flag(field),
            v.len()
        ),
    }
}

impl BackendArgs {
    /// The backend and adapter; an adapter name needs a backend that can use it, and with
    /// `auto` it asks for that GPU (an error when none matches, not a silent CPU fallback).
    pub fn choice(&self) -> Result<(BackendChoice, Option<&str>)> {
        spec::backend_choice(self.backend.into(), self.adapter.as_deref()).map_err(spec_error)
    }

    /// Builds the evaluator; the notes say what was chosen and why.
    pub fn evaluator(&self, problem: Problem) -> Result<(Box<dyn Evaluator>, Vec<String>)> {
        spec::make_evaluator(
            gpu_amcs::backends(),
            problem,
            self.backend.into(),
            self.adapter.as_deref(),
        )
        .map_err(spec_error)
    }
}

impl MemoryArgs {
    /// The memory budget: `--memory-limit`, or a share of the available memory.
    pub fn budget(&self) -> Result<MemoryBudget> {
        let limit = self
            .memory_limit
            .as_deref()
            .map(memory::parse_size)
            .transpose()
            .context("--memory-limit")?;
        Ok(MemoryBudget::new(limit))
    }

    /// Checks `estimate` against the budget.
    pub fn check(&self, estimate: &Estimate) -> Result<()> {
        Ok(self.budget()?.check(estimate)?)
    }
}

/// Most threads `--threads` accepts: results do not depend on the count, and more threads than
/// cores only cost memory and start-up time.
pub const MAX_THREADS: usize = 4096;

/// `--threads` is 1 to [`MAX_THREADS`].
fn check_threads(threads: Option<usize>) -> Result<()> {
    match threads {
        Some(0) => bail!("--threads must be at least 1"),
        Some(t) if t > MAX_THREADS => bail!("--threads must be at most {MAX_THREADS}, got {t}"),
        _ => Ok(()),
    }
}

/// A rayon pool of `threads` threads (all cores when `None`) to run the work in; failing to
/// start it is an error naming `--threads`.
pub fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    check_threads(threads)?;
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build()
        .map_err(|e| {
            anyhow::anyhow!(
                "--threads {}: cannot start the threads ({e}); use fewer",
                threads.map_or_else(|| "(all cores)".to_string(), |t| t.to_string())
            )
        })
}

/// The problem a run analyses and a label of its reference.
pub struct Built {
    /// Model, points, reference and seed.
    pub problem: Problem,
    /// "calibrated model" or "nominal model (NAME)".
    pub reference: String,
}

impl ProblemArgs {
    /// The library's description of the problem these flags give (the box's shape checked).
    pub fn spec(&self) -> Result<ProblemSpec> {
        let points = match &self.points_file {
            Some(f) => PointsSource::File(f.clone()),
            None => {
                PointsSource::Generate(self.workspace.generated(self.points, self.points_seed)?)
            }
        };
        let reference = match self.reference {
            ReferenceArg::Calibrated => ReferenceSource::Calibrated,
            // Without --nominal: the preset (--preset, default tx60).
            ReferenceArg::Nominal => ReferenceSource::Nominal(Some(ModelSource::file_or_preset(
                self.nominal.as_deref(),
                &self.model.preset,
            ))),
        };
        Ok(ProblemSpec {
            model: ModelSource::file_or_preset(self.model.model.as_deref(), &self.model.preset),
            points,
            reference,
            seed: self.seed,
            backend: self.backend.backend.into(),
            adapter: self.backend.adapter.clone(),
        })
    }

    /// Checks the flags that need no file: `--nominal` only with `--reference nominal`, the
    /// box, the number of points, the backend and adapter, `--threads`.
    pub fn check(&self) -> Result<()> {
        if self.nominal.is_some() && self.reference != ReferenceArg::Nominal {
            bail!("--nominal is used only with --reference nominal");
        }
        self.spec()?.check().map_err(spec_error)?;
        check_threads(self.threads)
    }

    /// Bytes for the test points (their number is known before reading a points file only
    /// when they are generated; a points file is bounded by its size).
    pub fn points_estimate(&self, e: Estimate) -> Estimate {
        match self.points_file {
            Some(_) => e,
            None => e.plus(&[self.points as u64, BYTES_PER_POINT]),
        }
    }

    /// The files this problem reads, with their flags.
    pub fn inputs(&self) -> Vec<(&'static str, &Path)> {
        [
            ("--model", self.model.model.as_deref()),
            ("--points-file", self.points_file.as_deref()),
            ("--nominal", self.nominal.as_deref()),
        ]
        .into_iter()
        .filter_map(|(f, p)| p.map(|p| (f, p)))
        .collect()
    }

    /// Reads the model and points and builds the problem ([`ProblemSpec::build_problem`]).
    pub fn build(&self) -> Result<Built> {
        self.check()?;
        let b = self.spec()?.build_problem().map_err(spec_error)?;
        Ok(Built {
            problem: b.problem,
            reference: b.reference,
        })
    }
}

impl OutputArgs {
    /// The drivers' reporting settings.
    pub fn settings(&self) -> RunSettings {
        RunSettings {
            coverage_probability: self.coverage,
            interval: self.interval.into(),
            thresholds: self.thresholds.clone(),
            per_point: self.per_point,
        }
    }
}

/// A simulation or study setting error with the flag that sets it added.
pub fn simulate_setting(e: gpu_amcs::simulate::SimulateError) -> anyhow::Error {
    use gpu_amcs::simulate::SimulateError;
    match e {
        SimulateError::Setting { field, message } => {
            let flag = match field {
                "runs" => "--runs",
                "range" => "--range",
                "step" => "--step",
                "speed" => "--speed",
                "point counts" => "--points",
                "MCS draws" => "--mcs-draws",
                "tolerances" => "--deltas",
                "factors" => "--factors",
                _ => return anyhow::anyhow!("{field}: {message}"),
            };
            anyhow::anyhow!("{field} ({flag}): {message}")
        }
        other => other.into(),
    }
}

/// Bytes per simulated sweep point: the point itself, its CSV line as text and while it is
/// built, and the identification's work on it.
pub const BYTES_PER_SWEEP_POINT: u64 = 512;

impl FactorArgs {
    /// The experiment (the virtual robot) and the factor levels, checked.
    pub fn experiment(&self) -> Result<(Experiment, Factors)> {
        let f = self.factors();
        f.check().map_err(simulate_setting)?;
        let mut nominal = self.model.load()?;
        let exp = match &self.truth {
            None => Experiment::for_robot(nominal, self.robot_seed),
            Some(p) => {
                let truth = RobotModel::from_file(p).context("--truth")?;
                if truth.fixed != nominal.fixed {
                    bail!(
                        "--truth {}: its fixed d/β pattern differs from the nominal model's ({})",
                        p.display(),
                        nominal.name
                    );
                }
                nominal.tool = truth.tool;
                Experiment::with_truth(nominal, truth)
            }
        };
        Ok((exp, f))
    }

    /// The files these flags read (`--truth`, `--model`), which no output may overwrite.
    pub fn inputs(&self) -> Vec<(&'static str, &Path)> {
        [
            ("--truth", self.truth.as_deref()),
            ("--model", self.model.model.as_deref()),
        ]
        .into_iter()
        .filter_map(|(f, p)| p.map(|p| (f, p)))
        .collect()
    }

    /// The factor levels.
    pub fn factors(&self) -> Factors {
        Factors {
            runs: self.runs,
            range_fraction: self.range / 100.0,
            step_deg: self.step,
            speed_fraction: self.speed / 100.0,
            direction: match self.start {
                StartArg::NegToPos => SweepDirection::NegToPos,
                StartArg::PosToNeg => SweepDirection::PosToNeg,
            },
        }
    }

    /// What the sweeps of all runs keep, before any is simulated (the TX60's sweep plan).
    pub fn sweep_estimate(&self, e: Estimate) -> Estimate {
        sweeps_estimate(e, &self.factors())
    }
}

/// Adds the memory of the sweeps of `f`'s runs on the TX60 sweep plan to `e`.
pub fn sweeps_estimate(e: Estimate, f: &Factors) -> Estimate {
    let plan = Experiment::tx60(0).plan_for(f);
    let per_run = (1..=6).fold(0u64, |acc, j| acc.saturating_add(plan.sweep_len(j)));
    e.plus(&[f.runs as u64, per_run, BYTES_PER_SWEEP_POINT])
}
