//! `sensitivity`: first-order and total Sobol indices of w per parameter, joint and kind.

use super::args::{frame_problem, thread_pool};
use super::flags::sensitivity_error;
use super::outputs::Outputs;
use super::reports::{problem_rows, write_reports};
use super::Run;
use crate::cmd::args::ProblemArgs;
use crate::cmd::reports::ReportFlags;
use anyhow::Result;
use clap::Args;
use gpu_amcs::mc::sensitivity::{run_sensitivity, SensitivityOptions, SensitivityResult};
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
        let opts = SensitivityOptions {
            draws: a.draws,
            bootstrap: a.bootstrap,
            bootstrap_seed: a.bootstrap_seed,
            thresholds: a.thresholds.clone(),
            ..SensitivityOptions::default()
        };
        opts.check().map_err(sensitivity_error)?;
        a.problem.check()?;
        let mut outputs = Outputs::new(a.problem.inputs());
        a.reports
            .declare(&mut outputs, &SensitivityResult::planned_layout())?;
        let estimate = a
            .problem
            .points_estimate(opts.memory_estimate("use fewer --draws, or raise --memory-limit"));
        a.problem.memory.check(&estimate)?;
        if let Some(out) = &a.summary_out {
            return super::merge::run_sensitivity_shard(&a.problem, &opts, a.shard.as_deref(), out);
        }
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
                if let Some(line) = announce(ev.as_mut(), &problem, &opts) {
                    eprintln!("{line}");
                }
            }
            Ok((
                run_sensitivity(&problem, ev.as_mut(), &opts).map_err(sensitivity_error)?,
                rows,
            ))
        })?;
        write_reports(outputs, &result, &a.reports, &rows)
    }
}

/// Rows timed for the up-front estimate of a sensitivity run.
const PILOT_ROWS: usize = 2048;

/// The "estimated ~N s" line of a run expected to take more than
/// [`ANNOUNCE_S`](super::progress::ANNOUNCE_S): a pilot evaluation of [`PILOT_ROWS`] rows times
/// the rows of the run (N base samples × (2 + free parameters + 8 groups) pick-freeze matrices),
/// plus a quarter for the bootstrap analysis (its share at 2^20 in `benches/sensitivity.rs`).
fn announce(
    ev: &mut dyn gpu_amcs::engine::Evaluator,
    problem: &gpu_amcs::engine::Problem,
    opts: &SensitivityOptions,
) -> Option<String> {
    let offsets = vec![0.0; PILOT_ROWS * ev.offset_width()];
    let mut w = vec![0.0; PILOT_ROWS];
    let t = std::time::Instant::now();
    ev.evaluate_offsets(&offsets, &mut w, None).ok()?;
    let per_row = t.elapsed().as_secs_f64() / PILOT_ROWS as f64;
    let free = problem
        .model
        .param_sigmas()
        .iter()
        .filter(|s| **s > 0.0)
        .count();
    let rows = opts.draws as f64 * (2 + free + 8) as f64;
    let seconds = 1.25 * per_row * rows;
    (seconds > super::progress::ANNOUNCE_S).then(|| {
        format!(
            "sensitivity: estimated ~{seconds:.0} s for N = {} base samples ({} pick-freeze matrices)",
            opts.draws,
            2 + free + 8
        )
    })
}
