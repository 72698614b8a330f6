//! Command-line definitions (clap): the top-level parser, the subcommand list and the argument
//! groups several subcommands share (`ModelArgs`, `BoxArgs`, `BackendArgs`, `MemoryArgs`,
//! `ProblemArgs`, `OutputArgs`, `ReportFlags`). Each subcommand's own arguments and its run live
//! in one file under `cmd/`; turning arguments into library values is in `cmd/args.rs`, writing
//! the reports in `cmd/reports.rs`, the flag of each library setting in `cmd/flags.rs`.
//! `gpu-amcs` with no subcommand runs AMCS on the built-in TX60.

use crate::cmd::{self, amcs::AmcsArgs};
use clap::{Args, Parser, Subcommand, ValueEnum};
use std::path::PathBuf;

/// Positioning-accuracy reliability of a calibrated robot by adaptive Monte Carlo (GUM S1 §7.9).
#[derive(Parser, Debug)]
#[command(name = "gpu-amcs", version, about, long_about = None, args_conflicts_with_subcommands = true, allow_negative_numbers = true)]
pub struct Cli {
    /// What to do (default: AMCS on the chosen model).
    #[command(subcommand)]
    pub command: Option<Command>,
    /// AMCS options when no subcommand is given.
    #[command(flatten)]
    pub amcs: AmcsArgs,
}

impl Cli {
    /// Runs the chosen subcommand (AMCS when none is given).
    pub fn run(self) -> anyhow::Result<()> {
        match self.command {
            None => cmd::Run::run(self.amcs),
            Some(c) => c.run(),
        }
    }
}

/// Declares the subcommand enum and its dispatch from one list, so a new subcommand is its file
/// under `cmd/` (an arguments struct implementing `cmd::Run`) plus one line here.
macro_rules! subcommands {
    ($($(#[$meta:meta])* $name:ident($args:ty),)*) => {
        /// Subcommands.
        #[derive(Subcommand, Debug)]
        pub enum Command {
            $($(#[$meta])* $name($args),)*
        }

        impl Command {
            /// Runs the subcommand.
            pub fn run(self) -> anyhow::Result<()> {
                match self {
                    $(Command::$name(a) => cmd::Run::run(a),)*
                }
            }
        }
    };
}

subcommands! {
    /// Adaptive Monte Carlo (the default when no subcommand is given).
    #[command(allow_negative_numbers = true)]
    Amcs(cmd::amcs::AmcsArgs),
    /// Classic Monte Carlo with a fixed number of draws.
    #[command(allow_negative_numbers = true)]
    Mcs(cmd::mcs::McsArgs),
    /// Merge shard summaries (`mcs`, `sensitivity` or `map` with `--shard K/N --summary-out
    /// FILE`) into the run's reports.
    Merge(cmd::merge::MergeArgs),
    /// MCS against AMCS at two tolerances: the paper's Table 2 for one model.
    #[command(allow_negative_numbers = true)]
    Compare(cmd::compare::CompareArgs),
    /// Sobol sensitivity indices of w: which parameters' spread matters (first order and total).
    #[command(allow_negative_numbers = true)]
    Sensitivity(cmd::sensitivity::SensitivityArgs),
    /// Tail probability P_f = Pr[w ≥ L] and β down to 1e-9 (subset simulation).
    #[command(allow_negative_numbers = true)]
    Tail(cmd::tail::TailArgs),
    /// Workspace reliability map: R_j, e_j and the Jacobian condition per cell of a plane or grid.
    #[command(allow_negative_numbers = true)]
    Map(cmd::map::MapArgs),
    /// Print a built-in model as a model file (TOML) to start from.
    Model(cmd::model::ModelCmdArgs),
    /// Generate test points and write them as CSV (q1..q6 in degrees).
    #[command(allow_negative_numbers = true)]
    Points(cmd::points::PointsArgs),
    /// Forward kinematics: tool positions (mm) of the configurations in a CSV.
    Fk(cmd::fk::FkArgs),
    /// Convert a URDF, DH table (CSV/TOML) or UR calibration file (YAML) to a model file,
    /// proving the conversion.
    Import(cmd::import::ImportArgs),
    /// Write a model as URDF and/or as a UR calibration file.
    Export(cmd::export::ExportArgs),
    /// Identify the MDH parameters from laser-tracker sweeps (circle point method).
    Identify(cmd::identify::IdentifyArgs),
    /// Positioning accuracy of a model against measured positions.
    Validate(cmd::validate::ValidateArgs),
    /// Simulate calibration sweeps of a virtual robot measured by a laser tracker (CSV).
    #[command(allow_negative_numbers = true)]
    Simulate(cmd::simulate::SimulateArgs),
    /// Repeated simulated calibrations → model file with mean, σ and full covariance.
    #[command(allow_negative_numbers = true)]
    Calibrate(cmd::calibrate::CalibrateArgs),
    /// The paper's factor study: Tables 1–2 and Figs. 4–9 on a virtual TX60.
    #[command(allow_negative_numbers = true)]
    Study(cmd::study::StudyArgs),
}

/// Sweep direction (start position).
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum StartArg {
    /// From each joint's negative end to its positive end (the paper's baseline).
    NegToPos,
    /// From the positive end to the negative end.
    PosToNeg,
}

#[derive(Args, Debug, Clone)]
pub struct FactorArgs {
    /// Number of repeated calibration runs (at least 2).
    #[arg(long, default_value_t = 20, value_name = "R")]
    pub runs: usize,
    /// Joint range swept, percent of each joint's measuring range (0 < r ≤ 100).
    #[arg(long, default_value_t = 50.0, value_name = "PERCENT")]
    pub range: f64,
    /// Joint step, degrees.
    #[arg(long, default_value_t = 2.0, value_name = "DEG")]
    pub step: f64,
    /// Joint speed, percent of rated (0 < s ≤ 100).
    #[arg(long, default_value_t = 25.0, value_name = "PERCENT")]
    pub speed: f64,
    /// Start position: sweep direction of every joint.
    #[arg(long, value_enum, default_value_t = StartArg::NegToPos)]
    pub start: StartArg,
    /// Seed of the simulated true robot (the nominal robot with 0.3 mm / 0.03° class errors).
    #[arg(long, default_value_t = 2025, value_name = "SEED")]
    pub robot_seed: u64,
    /// The nominal robot (its design geometry): a model file or a preset.
    #[command(flatten)]
    pub model: ModelArgs,
    /// The true robot as a model file instead (same structure as the nominal robot; its tool is
    /// the target).
    #[arg(long, value_name = "FILE")]
    pub truth: Option<PathBuf>,
    /// Seed of the measurement noise (run r uses a seed derived from it and r).
    #[arg(long, default_value_t = 1, value_name = "SEED")]
    pub seed: u64,
}

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

/// Model, test points, reference, seed and backend.
#[derive(Args, Debug, Clone)]
pub struct ProblemArgs {
    #[command(flatten)]
    pub model: ModelArgs,
    /// Number of generated test points (ignored with --points-file).
    #[arg(long, default_value_t = 50, value_name = "N")]
    pub points: usize,
    /// Test points from a CSV (header q1..q6, degrees).
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
    /// Reference positions the errors are measured from.
    #[arg(long, value_enum, default_value_t = ReferenceArg::Calibrated)]
    pub reference: ReferenceArg,
    /// Nominal model for --reference nominal (default: the preset).
    #[arg(long, value_name = "FILE")]
    pub nominal: Option<PathBuf>,
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
        default_value = "0.1,0.2,0.3,0.4,0.5,0.6,0.7,0.8",
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

/// Where the reports of an analysis go: the one group of report flags every subcommand that
/// writes reports flattens (`cmd/reports.rs` declares and writes them for any
/// `gpu_amcs::report::Report`). The help texts are a run's; a subcommand whose reports are
/// other files gives its own with `#[command(mut_arg(...))]` on its arguments.
#[derive(Args, Debug, Clone, Default)]
pub struct ReportFlags {
    /// Write the report as JSON to FILE.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Write CSV files (CDF, PDF, reliability, convergence trace) into DIR.
    #[arg(long, value_name = "DIR")]
    pub csv: Option<PathBuf>,
    /// Write SVG plots (PDF, reliability curve, convergence) into DIR.
    #[arg(long, value_name = "DIR")]
    pub svg: Option<PathBuf>,
    /// Write a self-contained HTML report into DIR: index.html (summary, tables, figures, model
    /// and settings; no scripts, nothing loaded from elsewhere) and the JSON, CSV and SVG files
    /// it links to.
    #[arg(long, value_name = "DIR")]
    pub html: Option<PathBuf>,
    /// No progress bar and no table on stdout.
    #[arg(long, short)]
    pub quiet: bool,
}
