//! The argument groups several subcommands share (`ModelArgs`, `BoxArgs`, `BackendArgs`,
//! `MemoryArgs`, `ProblemArgs`, `OutputArgs`, `FactorArgs`, `DeltasArgs`) and their conversion
//! to library values (`ModelArgs::load`, `ProblemArgs::build`, `OutputArgs::settings`, …),
//! naming the flag in their errors. Nothing here computes or writes.
//!
//! The factors of a simulated experiment (`FactorArgs`) are in `factors`.

mod factors;

pub use factors::{sweeps_estimate, FactorArgs};

use super::flags::{spec_error, spec_flag};
use super::reports::ReportFlags;
use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use gpu_amcs::engine::backend::BackendChoice;
use gpu_amcs::job::Setup;
use gpu_amcs::kinematics::RobotModel;
use gpu_amcs::mc::{IntervalKind, RunSettings};
use gpu_amcs::memory::{self, Estimate, MemoryBudget};
use gpu_amcs::points::WorkspaceBox;
use gpu_amcs::spec::{
    self, GeneratedPoints, ModelSource, PointsSource, ProblemSpec, ReferenceSource, SpecField,
};
use std::path::Path;
use std::path::PathBuf;

/// Where the errors are measured from.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReferenceArg {
    /// The position the calibrated model itself predicts (what the calibration's spread leaves).
    Calibrated,
    /// The nominal (design) model's position (adds the uncalibrated systematic error).
    Nominal,
}

/// Evaluation backend.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum BackendArg {
    /// A real GPU when one is present, otherwise the CPU.
    Auto,
    /// Any wgpu adapter (Vulkan/Metal/DX12), software ones such as lavapipe included.
    Gpu,
    /// The rayon CPU reference path.
    Cpu,
}

/// Coverage interval choice.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum IntervalArg {
    /// Shortest interval (GUM S1 §7.7.2).
    Shortest,
    /// Probabilistically symmetric interval (GUM S1 §7.7.1).
    Symmetric,
}

/// The model: a file or a built-in preset.
#[derive(Args, Debug, Clone)]
pub struct ModelArgs {
    /// Model file (TOML, mm and degrees) or a robot description imported on the fly (.urdf,
    /// DH table .csv, UR calibration .yaml); default: the built-in preset.
    #[arg(long, value_name = "FILE")]
    pub model: Option<PathBuf>,
    /// Built-in model used when --model is not given.
    #[arg(long, default_value = "tx60", value_name = "NAME")]
    pub preset: String,
    /// Tip link of a URDF given with --model (default: a link named tool0, else flange, else
    /// the deepest leaf of the longest revolute chain; a note says which).
    #[arg(long, value_name = "LINK")]
    pub tip: Option<String>,
}

/// The workspace box of generated test points.
#[derive(Args, Debug, Clone)]
pub struct BoxArgs {
    /// Workspace box centre for generated points, mm: x,y,z [default: from the robot's reach;
    /// 250,0,200 for the TX60].
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "X,Y,Z",
        allow_hyphen_values = true
    )]
    pub box_center: Option<Vec<f64>>,
    /// Workspace box edge lengths for generated points, mm: x,y,z [default: from the robot's
    /// reach; 900,1200,800 for the TX60].
    #[arg(long, value_delimiter = ',', value_name = "X,Y,Z")]
    pub box_size: Option<Vec<f64>>,
}

/// Evaluation backend and GPU adapter.
#[derive(Args, Debug, Clone)]
pub struct BackendArgs {
    /// Evaluation backend.
    #[arg(long, value_enum, default_value_t = BackendArg::Auto)]
    pub backend: BackendArg,
    /// GPU adapter to use (case-insensitive part of its name); needs --backend gpu or auto.
    #[arg(long, value_name = "NAME")]
    pub adapter: Option<String>,
}

/// The memory a run may plan to use.
#[derive(Args, Debug, Clone)]
pub struct MemoryArgs {
    /// Refuse runs estimated to need more memory than SIZE (e.g. 500M, 2G; mcs summarises its
    /// draws instead of keeping them); default: 80 % of the available memory.
    #[arg(long, value_name = "SIZE")]
    pub memory_limit: Option<String>,
}

/// The frame of the targets.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameArg {
    /// The measurement (tracker, cell) frame the model's placement was identified in.
    Measurement,
    /// The robot's own base frame.
    Base,
}

impl From<FrameArg> for gpu_amcs::engine::Frame {
    fn from(f: FrameArg) -> Self {
        match f {
            FrameArg::Measurement => gpu_amcs::engine::Frame::Measurement,
            FrameArg::Base => gpu_amcs::engine::Frame::Base,
        }
    }
}

/// Model, test points, reference, seed and backend.
#[derive(Args, Debug, Clone)]
pub struct ProblemArgs {
    #[command(flatten)]
    pub model: ModelArgs,
    /// Number of generated test points (ignored with --points-file).
    #[arg(long, default_value_t = 50, value_name = "N")]
    pub points: usize,
    /// Test points from a CSV (header q1..qn, one column per joint of the model; degrees).
    #[arg(long, value_name = "CSV")]
    pub points_file: Option<PathBuf>,
    /// Seed of the generated test points.
    #[arg(long, default_value_t = 1, value_name = "SEED")]
    pub points_seed: u64,
    #[command(flatten)]
    pub workspace: BoxArgs,
    /// Seed of the parameter draws.
    #[arg(long, default_value_t = 2025, value_name = "SEED")]
    pub seed: u64,
    /// Leave out the model's discrepancy term (what the geometric model does not explain,
    /// found by identify): the reliability then covers the parameters' uncertainty alone.
    #[arg(long)]
    pub no_discrepancy: bool,
    /// Payload at the task, kg, for a model with joint compliance (identify
    /// --beyond-geometry): its torques bend the joints; default: the model's own (the payload
    /// during calibration).
    #[arg(long, value_name = "KG")]
    pub payload_kg: Option<f64>,
    /// Standard uncertainty of --payload-kg, kg (drawn with every draw).
    #[arg(long, value_name = "KG", requires = "payload_kg")]
    pub payload_sigma_kg: Option<f64>,
    /// Centre of mass of --payload-kg in the flange frame, mm [default: the model's].
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "X,Y,Z",
        allow_hyphen_values = true,
        requires = "payload_kg"
    )]
    pub payload_com: Option<Vec<f64>>,
    /// Reference positions the errors are measured from.
    #[arg(long, value_enum, default_value_t = ReferenceArg::Calibrated)]
    pub reference: ReferenceArg,
    /// Nominal model for --reference nominal (default: the preset the model is; a model that is
    /// no preset needs it).
    #[arg(long, value_name = "FILE")]
    pub nominal: Option<PathBuf>,
    /// Frame of the targets: `measurement` draws a model's uncertain base placement too (a
    /// model identified from tracker data carries one), `base` leaves it out (the robot's own
    /// frame).
    #[arg(long, value_enum, default_value_t = FrameArg::Measurement)]
    pub frame: FrameArg,
    #[command(flatten)]
    pub backend: BackendArgs,
    /// CPU threads (default: all cores). Results do not depend on it.
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    #[command(flatten)]
    pub memory: MemoryArgs,
}

/// The AMCS tolerances of a comparison.
#[derive(Args, Debug, Clone)]
pub struct DeltasArgs {
    /// AMCS tolerances δ (mm).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "0.01,0.02",
        value_name = "MM,...",
        allow_hyphen_values = true
    )]
    pub deltas: Vec<f64>,
}

/// Reporting options of a run: its settings and where its reports go.
#[derive(Args, Debug, Clone)]
pub struct OutputArgs {
    /// Thresholds l_c (mm) for the reliability R(l_c).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = DEFAULT_THRESHOLDS.as_str(),
        value_name = "MM,...",
        allow_hyphen_values = true
    )]
    pub thresholds: Vec<f64>,
    /// Coverage probability p.
    #[arg(
        long,
        default_value_t = 0.95,
        value_name = "P",
        allow_hyphen_values = true
    )]
    pub coverage: f64,
    /// Coverage interval: shortest or probabilistically symmetric.
    #[arg(long, value_enum, default_value_t = IntervalArg::Shortest)]
    pub interval: IntervalArg,
    /// Also report the single-point reliabilities R_j (paper eq. 14).
    #[arg(long)]
    pub per_point: bool,
    #[command(flatten)]
    pub reports: ReportFlags,
}

pub use gpu_amcs::job::{BYTES_PER_DRAW, BYTES_PER_POINT};

/// The library's default thresholds (`gpu_amcs::mc::DEFAULT_THRESHOLDS_MM`) as the one
/// comma-separated value `--thresholds` takes, for the flags' defaults and help.
pub static DEFAULT_THRESHOLDS: std::sync::LazyLock<String> =
    std::sync::LazyLock::new(|| comma_list(&gpu_amcs::mc::DEFAULT_THRESHOLDS_MM));

/// Numbers as one comma-separated flag value (`0.1,0.2`).
pub fn comma_list(v: &[f64]) -> String {
    v.iter().map(f64::to_string).collect::<Vec<_>>().join(",")
}

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
    /// Where the model comes from: the file (a description imported with `--tip` when given),
    /// or the preset.
    pub fn source(&self) -> Result<ModelSource> {
        match (&self.model, &self.tip) {
            (_, None) => Ok(ModelSource::file_or_preset(
                self.model.as_deref(),
                &self.preset,
            )),
            (Some(p), Some(tip)) if gpu_amcs::spec::is_description(p) => {
                Ok(ModelSource::Description {
                    path: p.clone(),
                    tip: tip.clone(),
                })
            }
            (_, Some(_)) => bail!(
                "--tip names the tip link of a robot description given with --model (.urdf, .xml)"
            ),
        }
    }

    /// The model file, or the preset when none is given; what an import chose (the tip link)
    /// is printed as a note.
    pub fn load(&self) -> Result<RobotModel> {
        let source = self.source()?;
        let (model, notes) = source
            .load_noted()
            .map_err(|e| spec_error(gpu_amcs::spec::SpecError::new(source.field(), e)))?;
        print_model_notes(self.model.as_deref(), &notes);
        Ok(model)
    }
}

/// Prints what loading the model `file` chose on the user's behalf.
fn print_model_notes(file: Option<&Path>, notes: &[String]) {
    if let Some(f) = file {
        for n in notes {
            eprintln!("note: --model {}: {n}", f.display());
        }
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

/// The three finite numbers a flag of the form `A,B,C` was given; `what` names them
/// ("x, y, z mm").
pub fn three_values(flag: &str, what: &str, v: &[f64]) -> Result<[f64; 3]> {
    match v {
        [a, b, c] if v.iter().all(|x| x.is_finite()) => Ok([*a, *b, *c]),
        [_, _, _] => bail!("{flag}: {what} must be finite numbers"),
        _ => bail!("{flag} needs three numbers ({what}), got {}", v.len()),
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
}

/// The default budget of this process, measured at its first use.
static DEFAULT_BUDGET: std::sync::OnceLock<MemoryBudget> = std::sync::OnceLock::new();

/// The room the kernel enforces for this process ([`memory::hard_room`]), measured at its
/// first use.
static HARD_ROOM: std::sync::OnceLock<Option<MemoryBudget>> = std::sync::OnceLock::new();

impl MemoryArgs {
    /// The memory budget: `--memory-limit`, or a share of the available memory.
    pub fn budget(&self) -> Result<MemoryBudget> {
        let limit = self
            .memory_limit
            .as_deref()
            .map(memory::parse_size)
            .transpose()
            .context("--memory-limit")?;
        Ok(match limit {
            // The hard rooms measured once, as the default is.
            Some(l) => MemoryBudget::given(l, *HARD_ROOM.get_or_init(memory::hard_room)),
            // Measured once: the address space left shrinks as worker threads reserve their
            // stacks and allocator arenas, and the decisions of one run (summary mode or not,
            // then the check before the run) must use the same limit.
            None => *DEFAULT_BUDGET.get_or_init(|| MemoryBudget::new(None)),
        })
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
    // Threads that start while the address space runs out can abort the process (glibc cannot
    // register a new thread's destructors): refuse a pool whose stacks alone would take more
    // than half of the address-space limit before starting any.
    if let (Some(n), Some(limit)) = (threads, gpu_amcs_core::memory::address_space_limit()) {
        let stacks = n as u64 * THREAD_STACK_BYTES;
        if stacks > limit / 2 {
            bail!(
                "--threads {n}: {n} threads reserve about {} MiB of stack address space, more than half of the address-space limit ({} MiB); use fewer",
                stacks >> 20,
                limit >> 20
            );
        }
    }
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

/// Address space a pool thread reserves for its stack (Rust's default 2 MiB and a guard page).
const THREAD_STACK_BYTES: u64 = (2 << 20) + (4 << 10);

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
            // Without --nominal: the preset the model is (--preset, or a model file by its
            // name), else the library refuses (naming --nominal).
            ReferenceArg::Nominal => ReferenceSource::Nominal(
                self.nominal
                    .as_deref()
                    .map(|p| ModelSource::File(p.to_path_buf())),
            ),
        };
        Ok(ProblemSpec {
            model: self.model.source()?,
            points,
            reference,
            seed: self.seed,
            backend: self.backend.backend.into(),
            adapter: self.backend.adapter.clone(),
            discrepancy: !self.no_discrepancy,
            payload: match self.payload_kg {
                None => None,
                Some(mass_kg) => Some(gpu_amcs::spec::PayloadSpec {
                    mass_kg,
                    sigma_kg: self.payload_sigma_kg.unwrap_or(0.0),
                    com_mm: match self.payload_com.as_deref() {
                        None => None,
                        Some([x, y, z]) => Some([*x, *y, *z]),
                        Some(v) => bail!(
                            "--payload-com needs 3 numbers X,Y,Z (mm), found {}",
                            v.len()
                        ),
                    },
                }),
            },
            // Sides at given points come from the points file's s1..sn columns.
            sides: None,
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

    /// The job setup of these flags: the spec, the frame, the memory budget, and `bars` told
    /// the progress and notices.
    pub fn setup(&self, bars: &std::sync::Arc<super::progress::Bars>) -> Result<Setup> {
        Ok(Setup {
            problem: self.spec()?,
            frame: self.frame.into(),
            memory: self.memory.budget()?,
            progress: bars.hook(self.model.model.as_deref()),
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
