//! `mcs`: classic Monte Carlo with a fixed number of draws (the library's `McsJob`). A run
//! whose values would not fit the memory limit runs in summary mode: the values are summarised
//! chunk by chunk, never all kept.

use super::analysis::{outputs, run_and_report};
use super::flags::Driver;
use super::merge::summary_shard;
use super::progress::Bars;
use super::Run;
use crate::cmd::args::{OutputArgs, ProblemArgs};
use anyhow::Result;
use clap::Args;
use gpu_amcs::job::{McsJob, Shard, SummaryMode};
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

impl Run for McsArgs {
    fn run(self) -> Result<()> {
        let settings = self.output.settings();
        settings.check().map_err(|e| Driver::Run.error(e))?;
        let shard = summary_shard(
            self.summary_out.is_some(),
            self.shard.as_deref(),
            self.shards,
        )?;
        self.problem.check()?;
        let mut outputs = outputs(&self.problem, &self.output)?;
        outputs.file("--summary-out", self.summary_out.as_deref())?;
        let bars = Bars::new(self.output.reports.quiet, |label| match label {
            "MCS shard" => ("MCS shard", "draws", false),
            "MCS (summary)" => ("MCS (summary)", "draws", false),
            _ => ("MCS", "draws", false),
        });
        let job = McsJob {
            setup: self.problem.setup(&bars)?,
            draws: self.draws,
            settings,
            summary: match shard {
                Some(_) => SummaryMode::Always,
                None => SummaryMode::Auto,
            },
            shard: shard.unwrap_or(Shard::WHOLE),
        };
        run_and_report(&self.problem, &self.output, outputs, &bars, || {
            job.run(gpu_amcs::backends())
        })?;
        Ok(())
    }
}
