//! `mcs`: classic Monte Carlo with a fixed number of draws. A run whose values would not fit
//! the memory limit runs in summary mode (`super::merge::run_summary`): the values are
//! summarised chunk by chunk, never all kept.

use super::analysis::{run_and_report, Plan};
use super::flags::Driver;
use super::merge::{run_summary, Shard};
use super::Run;
use crate::cmd::args::{OutputArgs, ProblemArgs};
use anyhow::Result;
use clap::Args;
use gpu_amcs::mc::{self, McsOptions};
use gpu_amcs::memory::Bytes;
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
    /// stream. Without it, with --summary-out, K and N come from SLURM_ARRAY_TASK_ID and
    /// SLURM_ARRAY_TASK_COUNT, or from JOB_COMPLETION_INDEX and --shards, when set.
    #[arg(long, value_name = "K/N", requires = "summary_out")]
    pub shard: Option<String>,
    /// Number of shards N of a Kubernetes Indexed Job (its completions): this shard is
    /// JOB_COMPLETION_INDEX of N.
    #[arg(
        long,
        value_name = "N",
        requires = "summary_out",
        conflicts_with = "shard"
    )]
    pub shards: Option<u64>,
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
        let chunk = chunk(self.draws);
        if let Some(out) = &self.summary_out {
            let shard = Shard::from_flags_or_env(self.shard.as_deref(), self.shards, |v| {
                std::env::var(v).ok()
            })?;
            return run_summary(
                &self.problem,
                &self.output,
                (self.draws, chunk),
                shard,
                Some(out),
                Vec::new(),
            );
        }
        let opts = McsOptions {
            draws: self.draws,
            chunk,
            settings: self.output.settings(),
        };
        opts.settings.check().map_err(|e| Driver::Run.error(e))?;
        let plan = Plan {
            label: "MCS",
            capped: false,
            what: format!("MCS with {} draws", self.draws),
            draws: self.draws,
            batch: opts.chunk,
            advice: "use fewer --draws (or AMCS), fewer --points or no --per-point, \
                     or raise --memory-limit",
        };
        // Kept values that would not fit the limit: summary mode (with a points file the
        // points are counted once read, by the summary's own estimate).
        let generated = match self.problem.points_file {
            Some(_) => 0,
            None => self.problem.points as u64,
        };
        let budget = self.problem.memory.budget()?;
        let values = plan.estimate(&self.output, generated);
        if budget.check(&values).is_err() {
            let needed = match values.bytes {
                Some(b) => Bytes(b).to_string(),
                None => "more than 2^64 bytes".to_string(),
            };
            let note = format!(
                "summary mode: keeping the values of {} draws would need {needed}, more than \
                 the memory limit of {} ({}); the draws were summarised chunk by chunk instead",
                self.draws,
                Bytes(budget.limit),
                budget.source
            );
            return run_summary(
                &self.problem,
                &self.output,
                (self.draws, chunk),
                Shard::WHOLE,
                None,
                vec![note],
            );
        }
        run_and_report(&self.problem, &self.output, plan, Driver::Run, |ev, cb| {
            mc::run_mcs(ev, &opts, Some(cb))
        })?;
        Ok(())
    }
}
