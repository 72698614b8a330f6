//! `tail`: the probability that w reaches a threshold, down to 1e-9, by subset simulation.

use super::args::{frame_problem, thread_pool};
use super::flags::tail_error;
use super::outputs::Outputs;
use super::progress::Progress;
use super::reports::{problem_rows, write_reports};
use super::Run;
use crate::cmd::args::ProblemArgs;
use crate::cmd::reports::ReportFlags;
use anyhow::Result;
use clap::{Args, ValueEnum};
use gpu_amcs::mc::tail::{run_tail, TailMethod, TailOptions, TailResult};

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
    #[arg(long, default_value_t = 5_000_000, value_name = "N")]
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
        let opts = TailOptions {
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
        opts.check().map_err(tail_error)?;
        a.problem.check()?;
        let mut outputs = Outputs::new(a.problem.inputs());
        a.reports
            .declare(&mut outputs, &TailResult::planned_layout())?;
        a.problem.memory.check(&a.problem.points_estimate(
            opts.memory_estimate("use fewer --samples-per-level, or raise --memory-limit"),
        ))?;
        let pool = thread_pool(a.problem.threads)?;
        let (result, rows) = pool.install(|| -> Result<_> {
            let built = a.problem.build()?;
            let rows = problem_rows(&a.problem, &built.problem);
            let (mut ev, notes) = a
                .problem
                .backend
                .frame_evaluator(built.problem.clone(), a.problem.frame)?;
            let problem = frame_problem(built.problem, a.problem.frame);
            if !a.reports.quiet {
                for n in &notes {
                    eprintln!("note: {n}");
                }
            }
            let bar = Progress::new(a.reports.quiet, "tail", "evaluations").capped();
            let r = run_tail(
                ev.as_mut(),
                &problem,
                &opts,
                Some(&|done, total| bar.update(done, total)),
            )
            .map_err(tail_error);
            bar.finish();
            Ok((r?, rows))
        })?;
        write_reports(outputs, &result, &a.reports, &rows)
    }
}
