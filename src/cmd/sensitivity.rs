//! `sensitivity`: first-order and total Sobol indices of w per parameter, joint and kind.

use super::args::thread_pool;
use super::html;
use super::outputs::Outputs;
use super::Run;
use crate::cli::{HtmlArgs, ProblemArgs};
use anyhow::Result;
use clap::Args;
use gpu_amcs::mc::sensitivity::{
    run_sensitivity, SensitivityError, SensitivityOptions, SensitivityResult,
};
use gpu_amcs::memory::Estimate;
use gpu_amcs::report::sensitivity as report;
use std::path::PathBuf;

/// Files `--csv DIR` may write.
pub const CSV_NAMES: &[&str] = &["indices.csv"];
/// Files `--svg DIR` may write.
pub const SVG_NAMES: &[&str] = &["indices.svg", "groups.svg"];

/// `sensitivity` options.
#[derive(Args, Debug, Clone)]
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
    /// Write the indices as JSON to FILE.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Write indices.csv into DIR.
    #[arg(long, value_name = "DIR")]
    pub csv: Option<PathBuf>,
    /// Write indices.svg and groups.svg (bar charts of the indices of w) into DIR.
    #[arg(long, value_name = "DIR")]
    pub svg: Option<PathBuf>,
    #[command(flatten)]
    pub html: HtmlArgs,
    /// No table on stdout.
    #[arg(long, short)]
    pub quiet: bool,
    /// Evaluate only shard K of N (K from 0): base samples [K·N_b/N, (K+1)·N_b/N). Without it,
    /// with --summary-out, K and N come from SLURM_ARRAY_TASK_ID and SLURM_ARRAY_TASK_COUNT
    /// when set.
    #[arg(long, value_name = "K/N", requires = "summary_out")]
    pub shard: Option<String>,
    /// Write the shard's model outputs (JSON) for `gpu-amcs merge`, which computes the indices.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["json", "csv", "svg"])]
    pub summary_out: Option<PathBuf>,
}

/// A settings error with the flag that sets the field.
pub fn with_flag(e: SensitivityError) -> anyhow::Error {
    match e {
        SensitivityError::Setting { field, message } => {
            let flag = match field {
                "draws" => "--draws",
                "bootstrap" => "--bootstrap",
                "thresholds" => "--thresholds",
                _ => return anyhow::anyhow!("{field}: {message}"),
            };
            anyhow::anyhow!("{field} ({flag}): {message}")
        }
        other => other.into(),
    }
}

impl Run for SensitivityArgs {
    fn run(self) -> Result<()> {
        let a = self;
        let opts = SensitivityOptions {
            draws: a.draws,
            bootstrap: a.bootstrap,
            bootstrap_seed: a.bootstrap_seed,
            thresholds: a.thresholds.clone(),
            ..SensitivityOptions::default()
        };
        opts.check().map_err(with_flag)?;
        a.problem.check()?;
        let mut outputs = Outputs::new(a.problem.inputs());
        outputs.file("--json", a.json.as_deref())?;
        outputs.dir("--csv", a.csv.as_deref(), CSV_NAMES)?;
        outputs.dir("--svg", a.svg.as_deref(), SVG_NAMES)?;
        a.html.declare(&mut outputs, html::SENSITIVITY_NAMES)?;
        // Kept: w and every pick-freeze output (at most 2 + 30 parameters + 8 groups matrices)
        // for the bootstrap, and one chunk of offset rows and outputs.
        let matrices = 40u64;
        let estimate = a.problem.points_estimate(
            Estimate::new(
                format!("a sensitivity analysis with N = {}", a.draws),
                "use fewer --draws, or raise --memory-limit",
            )
            .plus(&[
                a.draws as u64,
                matrices,
                8 * (1 + a.thresholds.len() as u64),
            ])
            .plus(&[opts.chunk as u64, matrices, 8 * 30 + 8]),
        );
        a.problem.memory.check(&estimate)?;
        if let Some(out) = &a.summary_out {
            return super::merge::run_sensitivity_shard(&a.problem, &opts, a.shard.as_deref(), out);
        }
        let pool = thread_pool(a.problem.threads)?;
        let (result, rows) = pool.install(|| -> Result<_> {
            let built = a.problem.build()?;
            let rows = html::problem_rows(&a.problem, &built.problem);
            let problem = built.problem.clone();
            let (mut ev, notes) = a.problem.backend.evaluator(built.problem)?;
            if !a.quiet {
                for n in &notes {
                    eprintln!("note: {n}");
                }
            }
            Ok((
                run_sensitivity(&problem, ev.as_mut(), &opts).map_err(with_flag)?,
                rows,
            ))
        })?;
        write_reports(outputs, &result, &rows, a.quiet)
    }
}

/// Stages the JSON, CSV, SVG and HTML reports of `result` (`rows`: the settings shown on the
/// HTML page), writes them and prints the table.
pub fn write_reports(
    mut outputs: Outputs,
    result: &SensitivityResult,
    rows: &[(String, String)],
    quiet: bool,
) -> Result<()> {
    outputs.stage_file("--json", report::render_json(result))?;
    outputs.stage_dir(
        "--csv",
        vec![("indices.csv".to_string(), report::render_csv(result))],
    )?;
    outputs.stage_dir("--svg", report::render_svg(result))?;
    if outputs.has(html::FLAG) {
        outputs.stage_dir(html::FLAG, gpu_amcs::report::Report::html(result, rows))?;
    }
    outputs.commit()?;
    if !quiet {
        print!("{}", report::render_text(result));
    }
    Ok(())
}
