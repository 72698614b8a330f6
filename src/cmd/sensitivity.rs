//! `sensitivity`: first-order and total Sobol indices of w per parameter, joint and kind (the
//! library's `SensitivityJob`), or one shard's model outputs for `merge`.

use super::args::thread_pool;
use super::flags::{job_error, sensitivity_error};
use super::merge::summary_shard;
use super::outputs::Outputs;
use super::progress::Bars;
use super::reports::{problem_rows, write_reports};
use super::Run;
use crate::cmd::args::ProblemArgs;
use crate::cmd::reports::ReportFlags;
use anyhow::Result;
use clap::Args;
use gpu_amcs::job::SensitivityJob;
use gpu_amcs::mc::sensitivity::{SensitivityOptions, SensitivityResult};
use std::path::PathBuf;

/// `sensitivity` options.
#[derive(Args, Debug, Clone)]
#[command(
    mut_arg("json", |a| a.help("Write the indices as JSON to FILE")),
    mut_arg("csv", |a| a.help("Write indices.csv into DIR")),
    mut_arg("svg", |a| a.help("Write indices.svg and groups.svg (bar charts of the indices of w) into DIR")),
    mut_arg("quiet", |a| a.help("No table on stdout"))
)]
pub struct SensitivityArgs {
    #[command(flatten)]
    pub problem: ProblemArgs,
    /// Base samples N (a power of 2); the run evaluates w N·(D + 2 + G) times (D free
    /// parameters, G groups that are not single parameters).
    #[arg(long, default_value_t = 1 << 13, value_name = "N")]
    pub draws: usize,
    /// Bootstrap resamples for the 95 % confidence intervals.
    #[arg(long, default_value_t = 300, value_name = "B")]
    pub bootstrap: usize,
    /// Seed of the bootstrap resampling.
    #[arg(long, default_value_t = 1, value_name = "SEED")]
    pub bootstrap_seed: u64,
    /// Also the indices of the failure indicator 1[w ≥ l_c] at these thresholds (mm).
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "MM,...",
        allow_hyphen_values = true
    )]
    pub thresholds: Vec<f64>,
    #[command(flatten)]
    pub reports: ReportFlags,
    /// Evaluate only shard K of N (K from 0): base samples [K·N_b/N, (K+1)·N_b/N). Without it,
    /// with --summary-out, K and N come from SLURM_ARRAY_TASK_ID and SLURM_ARRAY_TASK_COUNT
    /// when set.
    #[arg(long, value_name = "K/N", requires = "summary_out")]
    pub shard: Option<String>,
    /// Write the shard's model outputs (JSON) for `gpu-amcs merge`, which computes the indices.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["json", "csv", "svg", "html"])]
    pub summary_out: Option<PathBuf>,
}

impl Run for SensitivityArgs {
    fn run(self) -> Result<()> {
        let a = self;
        let options = SensitivityOptions {
            draws: a.draws,
            bootstrap: a.bootstrap,
            bootstrap_seed: a.bootstrap_seed,
            thresholds: a.thresholds.clone(),
            ..SensitivityOptions::default()
        };
        options.check().map_err(sensitivity_error)?;
        a.problem.check()?;
        let mut outputs = Outputs::new(a.problem.inputs());
        match &a.summary_out {
            Some(out) => outputs.file("--summary-out", Some(out))?,
            None => a
                .reports
                .declare(&mut outputs, &SensitivityResult::planned_layout())?,
        }
        let bars = Bars::new(a.reports.quiet, |_| ("sensitivity", "draws", false));
        let job = SensitivityJob {
            setup: a.problem.setup(&bars)?,
            options,
        };
        job.check().map_err(job_error)?;
        let shard = summary_shard(a.summary_out.is_some(), a.shard.as_deref(), None)?;
        let pool = thread_pool(a.problem.threads)?;
        if let Some(shard) = shard {
            let s = pool
                .install(|| job.run_shard(gpu_amcs::backends(), shard))
                .map_err(job_error)?;
            outputs.stage_file("--summary-out", s.to_json())?;
            outputs.commit()?;
            return Ok(());
        }
        let outcome = pool
            .install(|| job.run(gpu_amcs::backends()))
            .map_err(job_error)?;
        let rows = problem_rows(&a.problem, &outcome.analysed);
        write_reports(outputs, &outcome.result, &a.reports, &rows)
    }
}
