//! `amcs` (and the default run): adaptive Monte Carlo, GUM S1 §7.9.

use super::analysis::{outputs, run_and_report};
use super::flags::{job_error, Driver};
use super::progress::Bars;
use super::Run;
use crate::cmd::args::{OutputArgs, ProblemArgs};
use anyhow::Result;
use clap::Args;
use gpu_amcs::job::AmcsJob;
use gpu_amcs::mc::{AmcsOptions, Tolerance};

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

impl AmcsArgs {
    /// The driver's options.
    pub fn options(&self) -> AmcsOptions {
        AmcsOptions {
            tolerance: match self.ndig {
                Some(n) => Tolerance::Ndig(n),
                None => Tolerance::Delta(self.delta),
            },
            batch_size: self.batch,
            max_draws: self.max_draws,
            settings: self.output.settings(),
        }
    }
}

impl Run for AmcsArgs {
    fn run(self) -> Result<()> {
        let options = self.options();
        options.check().map_err(|e| Driver::Run.error(e))?;
        self.problem.check()?;
        let outputs = outputs(&self.problem, &self.output)?;
        let bars = Bars::new(self.output.reports.quiet, |_| ("AMCS", "draws", true));
        let job = AmcsJob {
            setup: self.problem.setup(&bars)?,
            options,
        };
        job.check().map_err(job_error)?;
        let rep = run_and_report(&self.problem, &self.output, outputs, &bars, || {
            job.run(gpu_amcs::backends())
        })?;
        if !rep.result.converged {
            eprintln!(
                "warning: AMCS did not converge within --max-draws {}; the results use all draws made",
                self.max_draws
            );
        }
        Ok(())
    }
}
