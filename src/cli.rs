//! Command-line definitions (clap): the top-level parser, the subcommand list and the argument
//! groups several subcommands share (`ModelArgs`, `BoxArgs`, `BackendArgs`, `MemoryArgs`,
//! `ProblemArgs`, `OutputArgs`, `ReportFlags`). Each subcommand's own arguments and its run live
//! in one file under `cmd/`; turning arguments into library values is in `cmd/args.rs`, writing
//! the reports in `cmd/reports.rs`, the flag of each library setting in `cmd/flags.rs`.
//! `gpu-amcs` with no subcommand runs AMCS on the built-in TX60.

use crate::cmd::{self, amcs::AmcsArgs};
use clap::{Parser, Subcommand};

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
    /// Generate test points and write them as CSV (q1..qn in degrees, one column per joint).
    #[command(allow_negative_numbers = true)]
    Points(cmd::points::PointsArgs),
    /// Forward kinematics: tool positions (mm) of the configurations in a CSV.
    Fk(cmd::fk::FkArgs),
    /// Convert a URDF, DH table (CSV/TOML) or UR calibration file (YAML) to a model file,
    /// proving the conversion.
    Import(cmd::import::ImportArgs),
    /// Write a model as URDF and/or as a UR calibration file.
    Export(cmd::export::ExportArgs),
    /// Identify the MDH parameters, target and base placement from laser-tracker data (sweeps or
    /// poses, in any frame), with identifiability and the covariance the data produce.
    Identify(cmd::identify::IdentifyArgs),
    /// Positioning accuracy of a model against measured positions.
    Validate(cmd::validate::ValidateArgs),
    /// Corrected targets of a task: what to command a controller running the nominal
    /// kinematics so that the calibrated robot (with its compensation) reaches the intended
    /// positions (CSV).
    Targets(cmd::targets::TargetsArgs),
    /// Simulate laser-tracker data of a virtual robot (CSV): circle-point sweeps, or poses at
    /// random configurations (--poses), in the base frame or a tracker frame.
    #[command(allow_negative_numbers = true)]
    Simulate(cmd::simulate::SimulateArgs),
    /// Plan a calibration: the poses to measure for reliability at the task points, and the
    /// reliability they are predicted to give, before measuring.
    #[command(allow_negative_numbers = true)]
    Plan(cmd::plan::PlanArgs),
    /// Repeated simulated calibrations → model file with mean, σ and full covariance.
    #[command(allow_negative_numbers = true)]
    Calibrate(cmd::calibrate::CalibrateArgs),
    /// The paper's factor study: Tables 1–2 and Figs. 4–9 on a virtual TX60.
    #[command(allow_negative_numbers = true)]
    Study(cmd::study::StudyArgs),
}
