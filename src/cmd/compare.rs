//! `compare`: MCS against AMCS at several tolerances, the paper's Table 2 for one model (the
//! library's `CompareJob`).

use super::args::thread_pool;
use super::flags::{job_error, Driver};
use super::outputs::Outputs;
use super::progress::Bars;
use super::reports::{problem_rows, write_reports};
use super::Run;
use crate::cmd::args::{DeltasArgs, ProblemArgs};
use crate::cmd::reports::ReportFlags;
use anyhow::Result;
use clap::Args;
use gpu_amcs::job::{CompareJob, JobError};
use gpu_amcs::report::{self, Comparison};
use std::path::PathBuf;

/// Comparison options.
#[derive(Args, Debug, Clone)]
#[command(
    mut_arg("json", |a| a.help("Write the comparison as JSON to FILE")),
    mut_arg("csv", |a| a.help("Write comparison.csv (the table) into DIR")),
    mut_arg("svg", |a| a.help("Write pdf.svg and reliability.svg (MCS and AMCS overlaid) into DIR")),
    mut_arg("quiet", |a| a.help("No progress bar"))
)]
pub struct CompareArgs {
    #[command(flatten)]
    pub problem: ProblemArgs,
    /// Number of MCS draws.
    #[arg(long, default_value_t = 1_000_000, value_name = "N")]
    pub draws: u64,
    #[command(flatten)]
    pub deltas: DeltasArgs,
    /// AMCS batch size H.
    #[arg(long, default_value_t = 10_000, value_name = "H")]
    pub batch: u64,
    /// Coverage probability p.
    #[arg(
        long,
        default_value_t = 0.95,
        value_name = "P",
        allow_hyphen_values = true
    )]
    pub coverage: f64,
    #[command(flatten)]
    pub reports: ReportFlags,
    /// Write the comparison as a Markdown table to FILE.
    #[arg(long, value_name = "FILE")]
    pub markdown: Option<PathBuf>,
}

impl Run for CompareArgs {
    fn run(self) -> Result<()> {
        let a = self;
        let mut outputs = Outputs::new(a.problem.inputs());
        a.reports
            .declare(&mut outputs, &Comparison::planned_layout())?;
        outputs.file("--markdown", a.markdown.as_deref())?;
        a.problem.check()?;
        // MCS under one bar, then each AMCS run under its own ("AMCS δ=…"), its total the cap.
        let bars = Bars::new(a.reports.quiet, |label| (label, "draws", label != "MCS"));
        let job = CompareJob {
            setup: a.problem.setup(&bars)?,
            draws: a.draws,
            deltas: a.deltas.deltas.clone(),
            batch_size: a.batch,
            coverage_probability: a.coverage,
        };
        job.check().map_err(compare_error)?;
        let pool = thread_pool(a.problem.threads)?;
        let outcome = pool.install(|| job.run(gpu_amcs::backends()));
        bars.finish();
        let outcome = outcome.map_err(compare_error)?;
        let rows = problem_rows(&a.problem, &outcome.analysed);
        let c = outcome.comparison;
        outputs.stage_file("--markdown", report::markdown::render_comparison(&c))?;
        // -q silences the progress bar only: the table is the comparison's result.
        let print = ReportFlags {
            quiet: false,
            ..a.reports.clone()
        };
        write_reports(outputs, &c, &print, &rows)
    }
}

/// A comparison's error: the drivers' settings with `compare`'s flags, the rest as any job's.
fn compare_error(e: JobError) -> anyhow::Error {
    match e {
        JobError::Run(e) => Driver::Compare.error(e),
        e => job_error(e),
    }
}
