//! `mcs`: classic Monte Carlo with a fixed number of draws.

use super::analysis::{run_and_report, Plan};
use super::{Flags, Run};
use crate::cli::{OutputArgs, ProblemArgs};
use anyhow::Result;
use clap::Args;
use gpu_amcs::mc::{self, McsOptions};

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

/// Draws per evaluation chunk of an MCS run of `draws` draws.
pub fn chunk(draws: u64) -> u64 {
    100_000.min(draws.max(1))
}

impl Run for McsArgs {
    fn run(self) -> Result<()> {
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
