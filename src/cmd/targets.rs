//! `targets`: corrected targets of a task for a controller running the nominal kinematics.

use super::args::load_model;
use super::Run;
use anyhow::{Context, Result};
use clap::Args;
use gpu_amcs::identify::targets::corrected_targets;
use gpu_amcs::kinematics::RobotModel;
use gpu_amcs::points;
use std::path::PathBuf;

/// `targets` options.
#[derive(Args, Debug, Clone)]
pub struct TargetsArgs {
    /// Task configurations: the joint angles the controller takes for each task pose (header
    /// q1..qn, degrees).
    #[arg(long, value_name = "CSV")]
    pub points_file: PathBuf,
    /// The calibrated model (TOML, as `identify` writes it; its compensation is applied).
    #[arg(long, value_name = "FILE")]
    pub model: PathBuf,
    /// The kinematics the controller runs (model file or description); default: the preset.
    #[arg(long, value_name = "FILE")]
    pub nominal: Option<PathBuf>,
    /// Built-in nominal model when --nominal is not given.
    #[arg(long, default_value = "tx60", value_name = "NAME")]
    pub preset: String,
}

impl Run for TargetsArgs {
    fn run(self) -> Result<()> {
        let model = RobotModel::from_file(&self.model)?;
        let nominal = load_model(self.nominal.as_deref(), &self.preset).context("--nominal")?;
        let configs: Vec<Vec<f64>> = points::read_csv(&self.points_file, model.joints())
            .context("--points-file")?
            .iter()
            .map(|q| q.to_vec())
            .collect();
        let out = corrected_targets(&model, &nominal, &configs).map_err(|e| match e {
            gpu_amcs::identify::IdentifyError::OutsideLimits { line, message } => anyhow::anyhow!(
                "--points-file: {}: configuration {line}: {message}",
                self.points_file.display()
            ),
            e => anyhow::anyhow!("{e}"),
        })?;
        let errors: Vec<f64> = out.targets.iter().map(|t| t.error_mm()).collect();
        let mean = errors.iter().sum::<f64>() / errors.len() as f64;
        let max = errors.iter().fold(0.0f64, |a, &b| a.max(b));
        eprintln!(
            "{} task poses: uncorrected, {} misses the nominal targets by {mean:.4} mm on average, {max:.4} mm at most; {}",
            out.targets.len(),
            model.name,
            if out.compensated {
                "its compensation is included"
            } else {
                "it has no compensation (geometric model alone)"
            }
        );
        if let Some(t) = out.nominal_tool_replaced {
            eprintln!(
                "note: {}'s tool point ({:.3}, {:.3}, {:.3}) mm is another target than the model's; the model's tool is used for both",
                nominal.name, t[0], t[1], t[2]
            );
        }
        crate::cmd::stdout::print(&out.to_csv())?;
        Ok(())
    }
}
