//! Command-line definitions (clap). Parsing only: the work is done in `commands.rs` through the
//! library. `gpu-amcs` with no subcommand runs AMCS on the built-in TX60.

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

/// Subcommands.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Adaptive Monte Carlo (the default when no subcommand is given).
    #[command(allow_negative_numbers = true)]
    Amcs(AmcsArgs),
    /// Classic Monte Carlo with a fixed number of draws.
    #[command(allow_negative_numbers = true)]
    Mcs(McsArgs),
    /// MCS against AMCS at two tolerances: the paper's Table 2 for one model.
    #[command(allow_negative_numbers = true)]
    Compare(CompareArgs),
    /// Print a built-in model as a model file (TOML) to start from.
    Model(ModelArgs),
    /// Generate test points and write them as CSV (q1..q6 in degrees).
    #[command(allow_negative_numbers = true)]
    Points(PointsArgs),
    /// Forward kinematics: tool positions (mm) of the configurations in a CSV.
    Fk(FkArgs),
    /// Convert a URDF, DH table (CSV/TOML) or UR calibration file (YAML) to a model file,
    /// proving the conversion.
    Import(ImportArgs),
    /// Write a model as URDF and/or as a UR calibration file.
    Export(ExportArgs),
    /// Identify the MDH parameters from laser-tracker sweeps (circle point method).
    Identify(IdentifyArgs),
    /// Positioning accuracy of a model against measured positions.
    Validate(ValidateArgs),
    /// Simulate calibration sweeps of a virtual robot measured by a laser tracker (CSV).
    #[command(allow_negative_numbers = true)]
    Simulate(SimulateArgs),
    /// Repeated simulated calibrations → model file with mean, σ and full covariance.
    #[command(allow_negative_numbers = true)]
    Calibrate(CalibrateArgs),
    /// The paper's factor study: Tables 1–2 and Figs. 4–9 on a virtual TX60.
    #[command(allow_negative_numbers = true)]
    Study(StudyArgs),
}

/// Sweep direction (start position).
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum StartArg {
    /// From each joint's negative end to its positive end (the paper's baseline).
    NegToPos,
    /// From the positive end to the negative end.
    PosToNeg,
}

/// The virtual robot and the five calibration factors.
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
    /// Seed of the simulated true robot (the nominal TX60 with 0.3 mm / 0.03° class errors).
    #[arg(long, default_value_t = 2025, value_name = "SEED")]
    pub robot_seed: u64,
    /// The true robot as a model file instead (same structure as the TX60; its tool is the target).
    #[arg(long, value_name = "FILE")]
    pub truth: Option<PathBuf>,
    /// Seed of the measurement noise (run r uses a seed derived from it and r).
    #[arg(long, default_value_t = 1, value_name = "SEED")]
    pub seed: u64,
}

/// `simulate` options.
#[derive(Args, Debug, Clone)]
pub struct SimulateArgs {
    #[command(flatten)]
    pub factors: FactorArgs,
    /// Write the sweeps CSV to FILE (default: stdout).
    #[arg(long, short, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Also write the true robot's model file.
    #[arg(long, value_name = "FILE")]
    pub truth_out: Option<PathBuf>,
}

/// `calibrate` options.
#[derive(Args, Debug, Clone)]
pub struct CalibrateArgs {
    #[command(flatten)]
    pub factors: FactorArgs,
    /// Write the calibrated model (mean, σ, full covariance) to FILE.
    #[arg(long, short, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Write independent σ only (no covariance table).
    #[arg(long)]
    pub independent: bool,
    /// Random test points for the accuracy check before/after calibration.
    #[arg(long, default_value_t = 50, value_name = "N")]
    pub accuracy_points: usize,
}

/// `study` options.
#[derive(Args, Debug, Clone)]
pub struct StudyArgs {
    /// Output directory (tables, figures, STUDY.md, study.json).
    #[arg(long, short, default_value = "study-out", value_name = "DIR")]
    pub out: PathBuf,
    /// Reduced study (2–3 levels per factor, 10 runs, MCS 10^5): about a minute.
    #[arg(long)]
    pub quick: bool,
    /// Factors to vary (default: all).
    #[arg(long, value_delimiter = ',', value_name = "NAME,...")]
    pub factors: Option<Vec<String>>,
    /// Calibration runs at the baseline (default 20, --quick 10).
    #[arg(long, value_name = "R")]
    pub runs: Option<usize>,
    /// MCS draws (default 10^6, --quick 10^5).
    #[arg(long, value_name = "N")]
    pub mcs_draws: Option<u64>,
    /// Numbers of test points.
    #[arg(long, value_delimiter = ',', default_values_t = [10usize, 50], value_name = "N,...")]
    pub points: Vec<usize>,
    /// AMCS tolerances δ (mm).
    #[arg(long, value_delimiter = ',', default_values_t = [0.01, 0.02], value_name = "MM,...", allow_hyphen_values = true)]
    pub deltas: Vec<f64>,
    /// Seed of the simulated true robot.
    #[arg(long, default_value_t = 2025, value_name = "SEED")]
    pub robot_seed: u64,
    /// Seed of the calibration runs.
    #[arg(long, default_value_t = 1, value_name = "SEED")]
    pub seed: u64,
    /// Evaluation backend.
    #[arg(long, value_enum, default_value_t = BackendArg::Auto)]
    pub backend: BackendArg,
    /// GPU adapter to use (case-insensitive part of its name).
    #[arg(long, value_name = "NAME")]
    pub adapter: Option<String>,
    /// No progress bar and no summary on stdout.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Circle model of the identification.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum FitArg {
    /// Circle through the points with each point's angle known from the commanded joint angle.
    Commanded,
    /// Plain point-cloud circle fit (plane, algebraic circle, geometric refinement).
    PointCloud,
}

/// `identify` options.
#[derive(Args, Debug, Clone)]
pub struct IdentifyArgs {
    /// Sweeps CSV: joint,q1..q6,x,y,z (optionally a run column); degrees and mm.
    #[arg(value_name = "SWEEPS.csv")]
    pub sweeps: PathBuf,
    /// Write the identified model (TOML) to FILE.
    #[arg(long, short, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Nominal model giving the structure and conventions (default: the preset).
    #[arg(long, value_name = "FILE")]
    pub nominal: Option<PathBuf>,
    /// Built-in nominal model used when --nominal is not given.
    #[arg(long, default_value = "tx60", value_name = "NAME")]
    pub preset: String,
    /// Circle model.
    #[arg(long, value_enum, default_value_t = FitArg::Commanded)]
    pub fit: FitArg,
    /// Use the data alone: no prior towards the nominal geometry.
    #[arg(long)]
    pub no_prior: bool,
    /// Skip the least-squares refinement over all sweep points.
    #[arg(long)]
    pub no_refine: bool,
    /// With several runs, write the full sample covariance of the parameters instead of
    /// independent σ.
    #[arg(long)]
    pub covariance: bool,
    /// Fail (exit 2, no model file) when a result looks implausible: a fit RMS residual above
    /// 0.05 mm, a parameter more than 5 mm / 2° from nominal, a J1 axis away from base z.
    #[arg(long)]
    pub strict: bool,
    /// Print every run's per-joint fit and parameter tables instead of a summary.
    #[arg(long, short, conflicts_with = "quiet")]
    pub verbose: bool,
    /// Print only warnings and errors.
    #[arg(long, short)]
    pub quiet: bool,
}

/// `validate` options.
#[derive(Args, Debug, Clone)]
pub struct ValidateArgs {
    /// Measured positions: q1..q6,x,y,z (degrees, mm).
    #[arg(value_name = "MEASURED.csv")]
    pub measured: PathBuf,
    /// Model to check (TOML).
    #[arg(long, value_name = "FILE")]
    pub model: PathBuf,
    /// Also check a nominal model (FILE, or the preset when no file is given) and report the
    /// improvement.
    #[arg(long, value_name = "FILE", num_args = 0..=1)]
    pub nominal: Option<Option<PathBuf>>,
    /// Built-in nominal model for a bare --nominal.
    #[arg(long, default_value = "tx60", value_name = "NAME")]
    pub preset: String,
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

/// Model, test points, reference, seed and backend.
#[derive(Args, Debug, Clone)]
pub struct ProblemArgs {
    /// Model file (TOML, mm and degrees); default: the built-in preset.
    #[arg(long, value_name = "FILE")]
    pub model: Option<PathBuf>,
    /// Built-in model used when --model is not given.
    #[arg(long, default_value = "tx60", value_name = "NAME")]
    pub preset: String,
    /// Number of generated test points (ignored with --points-file).
    #[arg(long, default_value_t = 50, value_name = "N")]
    pub points: usize,
    /// Test points from a CSV (header q1..q6, degrees).
    #[arg(long, value_name = "CSV")]
    pub points_file: Option<PathBuf>,
    /// Seed of the generated test points.
    #[arg(long, default_value_t = 1, value_name = "SEED")]
    pub points_seed: u64,
    /// Workspace box centre for generated points, mm: x,y,z.
    #[arg(long, value_delimiter = ',', default_values_t = [250.0, 0.0, 200.0], value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub box_center: Vec<f64>,
    /// Workspace box edge lengths for generated points, mm: x,y,z.
    #[arg(long, value_delimiter = ',', default_values_t = [900.0, 1200.0, 800.0], value_name = "X,Y,Z")]
    pub box_size: Vec<f64>,
    /// Seed of the parameter draws.
    #[arg(long, default_value_t = 2025, value_name = "SEED")]
    pub seed: u64,
    /// Reference positions the errors are measured from.
    #[arg(long, value_enum, default_value_t = ReferenceArg::Calibrated)]
    pub reference: ReferenceArg,
    /// Nominal model for --reference nominal (default: the preset).
    #[arg(long, value_name = "FILE")]
    pub nominal: Option<PathBuf>,
    /// Evaluation backend.
    #[arg(long, value_enum, default_value_t = BackendArg::Auto)]
    pub backend: BackendArg,
    /// GPU adapter to use (case-insensitive part of its name).
    #[arg(long, value_name = "NAME")]
    pub adapter: Option<String>,
    /// CPU threads (default: all cores). Results do not depend on it.
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
}

/// Reporting options.
#[derive(Args, Debug, Clone)]
pub struct OutputArgs {
    /// Thresholds l_c (mm) for the reliability R(l_c).
    #[arg(long, value_delimiter = ',', default_values_t = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8], value_name = "MM,...", allow_hyphen_values = true)]
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
    /// Write the report as JSON to FILE.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Write CSV files (CDF, PDF, reliability, convergence trace) into DIR.
    #[arg(long, value_name = "DIR")]
    pub csv: Option<PathBuf>,
    /// Write SVG plots (PDF, reliability curve, convergence) into DIR.
    #[arg(long, value_name = "DIR")]
    pub svg: Option<PathBuf>,
    /// No progress bar and no table on stdout.
    #[arg(long, short)]
    pub quiet: bool,
}

/// AMCS options.
#[derive(Args, Debug, Clone)]
pub struct AmcsArgs {
    #[command(flatten)]
    pub problem: ProblemArgs,
    #[command(flatten)]
    pub output: OutputArgs,
    /// Numerical tolerance δ in mm (GUM S1 §7.9.4).
    #[arg(
        long,
        default_value_t = 0.01,
        value_name = "MM",
        conflicts_with = "ndig"
    )]
    pub delta: f64,
    /// Derive δ from u(w) and this many significant digits (GUM S1 §7.9.2) instead of --delta.
    #[arg(long, value_name = "N")]
    pub ndig: Option<u32>,
    /// Batch size H.
    #[arg(long, default_value_t = 10_000, value_name = "H")]
    pub batch: u64,
    /// Cap on the total number of draws; reaching it ends the run as not converged.
    #[arg(long, default_value_t = 10_000_000, value_name = "N")]
    pub max_draws: u64,
}

/// MCS options.
#[derive(Args, Debug, Clone)]
pub struct McsArgs {
    #[command(flatten)]
    pub problem: ProblemArgs,
    #[command(flatten)]
    pub output: OutputArgs,
    /// Number of draws.
    #[arg(long, default_value_t = 1_000_000, value_name = "N")]
    pub draws: u64,
}

/// Comparison options.
#[derive(Args, Debug, Clone)]
pub struct CompareArgs {
    #[command(flatten)]
    pub problem: ProblemArgs,
    /// Number of MCS draws.
    #[arg(long, default_value_t = 1_000_000, value_name = "N")]
    pub draws: u64,
    /// AMCS tolerances δ (mm).
    #[arg(long, value_delimiter = ',', default_values_t = [0.01, 0.02], value_name = "MM,...", allow_hyphen_values = true)]
    pub deltas: Vec<f64>,
    /// AMCS batch size H.
    #[arg(long, default_value_t = 10_000, value_name = "H")]
    pub batch: u64,
    /// Coverage probability p.
    #[arg(
        long,
        default_value_t = 0.95,
        value_name = "P",
        allow_hyphen_values = true
    )]
    pub coverage: f64,
    /// Write the comparison as JSON to FILE.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Write the comparison as a Markdown table to FILE.
    #[arg(long, value_name = "FILE")]
    pub markdown: Option<PathBuf>,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
}

/// `model` options.
#[derive(Args, Debug, Clone)]
pub struct ModelArgs {
    /// Built-in model to print.
    #[arg(long, default_value = "tx60", value_name = "NAME")]
    pub preset: String,
    /// Write to FILE instead of stdout.
    #[arg(long, short, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// List the built-in models instead.
    #[arg(long, conflicts_with = "out")]
    pub list: bool,
}

/// `points` options.
#[derive(Args, Debug, Clone)]
pub struct PointsArgs {
    /// Number of test points.
    #[arg(value_name = "N")]
    pub n: usize,
    /// Model file (default: the preset).
    #[arg(long, value_name = "FILE")]
    pub model: Option<PathBuf>,
    /// Built-in model used when --model is not given.
    #[arg(long, default_value = "tx60", value_name = "NAME")]
    pub preset: String,
    /// Seed.
    #[arg(long, default_value_t = 1, value_name = "SEED")]
    pub points_seed: u64,
    /// Workspace box centre, mm: x,y,z.
    #[arg(long, value_delimiter = ',', default_values_t = [250.0, 0.0, 200.0], value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub box_center: Vec<f64>,
    /// Workspace box edge lengths, mm: x,y,z.
    #[arg(long, value_delimiter = ',', default_values_t = [900.0, 1200.0, 800.0], value_name = "X,Y,Z")]
    pub box_size: Vec<f64>,
    /// Write to FILE instead of stdout.
    #[arg(long, short, value_name = "FILE")]
    pub out: Option<PathBuf>,
}

/// `fk` options.
#[derive(Args, Debug, Clone)]
pub struct FkArgs {
    /// Configurations (header q1..q6, degrees).
    #[arg(long, value_name = "CSV")]
    pub points_file: PathBuf,
    /// Model file (default: the preset).
    #[arg(long, value_name = "FILE")]
    pub model: Option<PathBuf>,
    /// Built-in model used when --model is not given.
    #[arg(long, default_value = "tx60", value_name = "NAME")]
    pub preset: String,
}

/// `import` options.
#[derive(Args, Debug, Clone)]
pub struct ImportArgs {
    /// Robot description: .urdf/.xml (URDF), .csv/.toml (standard or modified DH table),
    /// .yaml/.yml (UR calibration).
    #[arg(value_name = "FILE")]
    pub source: PathBuf,
    /// Model file to write (TOML).
    #[arg(long, short, value_name = "FILE")]
    pub out: PathBuf,
    /// URDF: base link of the chain (default: the root link).
    #[arg(long, value_name = "LINK")]
    pub base: Option<String>,
    /// URDF: tip link of the chain; its origin becomes the tool point (default: the single leaf).
    #[arg(long, value_name = "LINK")]
    pub tip: Option<String>,
    /// Model name (default: the robot's name in the file, else the file name).
    #[arg(long, value_name = "NAME")]
    pub name: Option<String>,
}

/// `export` options.
#[derive(Args, Debug, Clone)]
#[command(group(clap::ArgGroup::new("target").required(true).multiple(true).args(["urdf", "ur_calibration"])))]
pub struct ExportArgs {
    /// Model file (default: the preset).
    #[arg(long, value_name = "FILE")]
    pub model: Option<PathBuf>,
    /// Built-in model used when --model is not given.
    #[arg(long, default_value = "tx60", value_name = "NAME")]
    pub preset: String,
    /// Write the model as URDF to FILE.
    #[arg(long, value_name = "FILE")]
    pub urdf: Option<PathBuf>,
    /// Write the model as a UR calibration file (YAML) to FILE.
    #[arg(long, value_name = "FILE")]
    pub ur_calibration: Option<PathBuf>,
    /// Robot name in the URDF (default: the model's name).
    #[arg(long, value_name = "NAME")]
    pub name: Option<String>,
}
