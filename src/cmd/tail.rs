//! `tail`: the probability that w reaches a threshold, down to 1e-9, by subset simulation.

use super::args::thread_pool;
use super::flags::{job_error, tail_error};
use super::outputs::Outputs;
use super::progress::Bars;
use super::reports::{problem_rows, write_reports};
use super::Run;
use crate::cmd::args::ProblemArgs;
use crate::cmd::reports::ReportFlags;
use anyhow::Result;
use clap::{Args, ValueEnum};
use gpu_amcs::job::TailJob;
use gpu_amcs::mc::tail::{TailMethod, TailOptions, TailResult};

/// Estimator of the tail probability.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum MethodArg {
    /// Subset simulation in the standard-normal space of the draws.
    Subset,
    /// Crude Monte Carlo on the run's draws (for comparison; needs ~100/P_f draws).
    Mc,
}

/// `tail` options.
#[derive(Args, Debug, Clone)]
#[command(
    mut_arg("json", |a| a.help("Write the result as JSON to FILE")),
    mut_arg("csv", |a| a.help("Write tail.csv into DIR")),
    mut_arg("svg", |a| a.help("Write tail.svg (P_f against L on a log axis) into DIR"))
)]
pub struct TailArgs {
    #[command(flatten)]
    pub problem: ProblemArgs,
    /// Thresholds L (mm): P_f = Pr[w ≥ L] at each.
    #[arg(
        long,
        required = true,
        value_delimiter = ',',
        value_name = "MM,...",
        allow_hyphen_values = true
    )]
    pub threshold: Vec<f64>,
    /// Target coefficient of variation of every estimate, in (0, 1).
    #[arg(
        long,
        default_value_t = 0.1,
        value_name = "C",
        allow_hyphen_values = true
    )]
    pub cov: f64,
    /// Estimator.
    #[arg(long, value_enum, default_value_t = MethodArg::Subset)]
    pub method: MethodArg,
    /// Cap on evaluations of w; reaching it ends the run with the estimates so far, marked as
    /// not reaching the target.
    #[arg(long, default_value_t = gpu_amcs::job::DEFAULT_MAX_EVALUATIONS, value_name = "N")]
    pub max_evaluations: u64,
    /// Subset simulation: samples per level of the pilot run.
    #[arg(long, default_value_t = 1000, value_name = "N")]
    pub samples_per_level: usize,
    /// Subset simulation: level probability p0, in (0, 0.5].
    #[arg(
        long,
        default_value_t = 0.1,
        value_name = "P",
        allow_hyphen_values = true
    )]
    pub p0: f64,
    #[command(flatten)]
    pub reports: ReportFlags,
}

impl Run for TailArgs {
    fn run(self) -> Result<()> {
        let a = self;
        let options = TailOptions {
            method: match a.method {
                MethodArg::Subset => TailMethod::Subset,
                MethodArg::Mc => TailMethod::MonteCarlo,
            },
            thresholds: a.threshold.clone(),
            target_cov: a.cov,
            max_evaluations: a.max_evaluations,
            samples_per_level: a.samples_per_level,
            p0: a.p0,
            ..TailOptions::default()
        };
        options.check().map_err(tail_error)?;
        a.problem.check()?;
        let mut outputs = Outputs::new(a.problem.inputs());
        a.reports
            .declare(&mut outputs, &TailResult::planned_layout())?;
        let bars = Bars::new(a.reports.quiet, |_| ("tail", "evaluations", true));
        let job = TailJob {
            setup: a.problem.setup(&bars)?,
            options,
        };
        job.check().map_err(job_error)?;
        let pool = thread_pool(a.problem.threads)?;
        let outcome = pool.install(|| job.run(gpu_amcs::backends()));
        bars.finish();
        let outcome = outcome.map_err(job_error)?;
        let rows = problem_rows(&a.problem, &outcome.analysed);
        write_reports(outputs, &outcome.result, &a.reports, &rows)
    }
}
