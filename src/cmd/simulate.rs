//! `simulate`: calibration sweeps of a virtual robot measured by a laser tracker.

use super::outputs::Outputs;
use super::Run;
use crate::cmd::args::{FactorArgs, MemoryArgs};
use anyhow::{Context, Result};
use clap::Args;
use gpu_amcs::memory::Estimate;
use std::path::PathBuf;

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
    #[command(flatten)]
    pub memory: MemoryArgs,
}

impl Run for SimulateArgs {
    fn run(self) -> Result<()> {
        let a = self;
        let mut outputs = Outputs::new(a.factors.inputs());
        outputs.file("--out", a.out.as_deref())?;
        outputs.file("--truth-out", a.truth_out.as_deref())?;
        let (exp, f) = a.factors.experiment()?;
        a.memory.check(&a.factors.sweep_estimate(Estimate::new(
            format!("{} runs of sweeps at a {}° step", f.runs, f.step_deg),
            "use fewer --runs or a larger --step, or raise --memory-limit",
        )))?;
        let data = exp.sweeps(&f, a.factors.seed);
        let mut buf = Vec::new();
        gpu_amcs::identify::write_sweeps(&data, &mut buf)?;
        let text = String::from_utf8(buf).context("sweep CSV")?;
        let lines = text.lines().count() - 1;
        outputs.stage_file("--truth-out", exp.truth.to_toml())?;
        match &a.out {
            Some(o) => {
                outputs.stage_file("--out", text)?;
                outputs.commit()?;
                eprintln!(
                    "wrote {} runs × 6 sweeps ({lines} points) to {}",
                    f.runs,
                    o.display()
                );
            }
            None => {
                outputs.commit()?;
                crate::cmd::stdout::print(&text)?;
            }
        }
        Ok(())
    }
}
