//! The factors of a simulated calibration experiment (`FactorArgs`: runs, range, step, speed,
//! sweep direction, the virtual robot) and the memory its sweeps keep.

use super::ModelArgs;
use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use gpu_amcs::kinematics::RobotModel;
use gpu_amcs::memory::Estimate;
use gpu_amcs::simulate::{Experiment, Factors, SweepDirection};
use std::path::{Path, PathBuf};

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

/// Bytes per simulated sweep point: the point itself, its CSV line as text and while it is
/// built, and the identification's work on it.
pub const BYTES_PER_SWEEP_POINT: u64 = 512;

impl FactorArgs {
    /// The experiment (the virtual robot) and the factor levels, checked.
    pub fn experiment(&self) -> Result<(Experiment, Factors)> {
        let f = self.factors();
        f.check().map_err(crate::cmd::flags::simulate_error)?;
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
