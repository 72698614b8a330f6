//! `mcs`: classic Monte Carlo with a fixed number of draws.

use super::analysis::{run_and_report, Plan};
use super::{Flags, Run};
use crate::cli::{OutputArgs, ProblemArgs};
use anyhow::Result;
use clap::Args;
use gpu_amcs::mc::{self, McsOptions};
use std::path::PathBuf;

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
    /// Evaluate only shard K of N (K from 0): draws [K·n/N, (K+1)·n/N) of the run's one
    /// stream. Without it, with --summary-out, read from SLURM_ARRAY_TASK_ID and
    /// SLURM_ARRAY_TASK_COUNT when set.
    #[arg(long, value_name = "K/N", requires = "summary_out")]
    pub shard: Option<String>,
    /// Write a mergeable summary of the draws (JSON) for `gpu-amcs merge`; the values are not
    /// kept and the reports come from the summary.
    #[arg(long, value_name = "FILE")]
    pub summary_out: Option<PathBuf>,
}

/// Draws per evaluation chunk of an MCS run of `draws` draws.
pub fn chunk(draws: u64) -> u64 {
    100_000.min(draws.max(1))
}

impl Run for McsArgs {
    fn run(self) -> Result<()> {
        if let Some(out) = &self.summary_out {
            let shard = super::merge::Shard::from_flag_or_env(self.shard.as_deref())?;
            let chunk = chunk(self.draws);
            return super::merge::run_shard(
                &self.problem,
                &self.output,
                self.draws,
                chunk,
                shard,
                out,
            );
        }
        let opts = McsOptions {
            draws: self.draws,
            chunk: chunk(self.draws),
            settings: self.output.settings(),
        };
        opts.settings.check().map_err(|e| Flags::RUN.error(e))?;
        let plan = Plan {
            label: "MCS",
            capped: false,
            what: format!("MCS with {} draws", self.draws),
            draws: self.draws,
            batch: opts.chunk,
            advice: "use fewer --draws (or AMCS), fewer --points or no --per-point, \
                     or raise --memory-limit",
        };
        run_and_report(&self.problem, &self.output, plan, Flags::RUN, |ev, cb| {
            mc::run_mcs(ev, &opts, Some(cb))
        })?;
        Ok(())
    }
}
