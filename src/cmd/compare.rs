//! `compare`: MCS against AMCS at several tolerances, the paper's Table 2 for one model.

use super::args::{thread_pool, BYTES_PER_DRAW};
use super::flags::Driver;
use super::outputs::Outputs;
use super::progress::Progress;
use super::reports::{problem_rows, write_reports};
use super::Run;
use crate::cmd::args::{DeltasArgs, ProblemArgs};
use crate::cmd::reports::ReportFlags;
use anyhow::Result;
use clap::Args;
use gpu_amcs::job::{Analysed, McsJob};
use gpu_amcs::mc::{self, AmcsOptions, McsOptions, RunSettings, Tolerance};
use gpu_amcs::memory::Estimate;
use gpu_amcs::report::{self, Comparison};
use std::path::PathBuf;

/// The draw cap of each AMCS run of the comparison.
const AMCS_CAP: u64 = 100_000_000;

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
        let base = RunSettings {
            coverage_probability: a.coverage,
            ..RunSettings::default()
        };
        let amcs_opts: Vec<AmcsOptions> = a
            .deltas
            .deltas
            .iter()
            .map(|&d| AmcsOptions {
                tolerance: Tolerance::Delta(d),
                batch_size: a.batch,
                max_draws: AMCS_CAP,
                settings: base.clone(),
            })
            .collect();
        for o in &amcs_opts {
            o.check().map_err(|e| Driver::Compare.error(e))?;
        }
        a.problem.check()?;
        // The MCS values are kept while each AMCS run grows up to its cap.
        let e = Estimate::new(
            format!(
                "MCS with {} draws and AMCS with up to {AMCS_CAP} draws",
                a.draws
            ),
            "use fewer --draws or --points, or raise --memory-limit",
        )
        .plus(&[a.draws, BYTES_PER_DRAW])
        .plus(&[AMCS_CAP, BYTES_PER_DRAW]);
        a.problem.memory.check(&a.problem.points_estimate(e))?;
        let pool = thread_pool(a.problem.threads)?;
        let (c, rows) = pool.install(|| -> Result<(Comparison, Vec<(String, String)>)> {
            let problem = a.problem.build()?;
            let (model, m, seed) = (problem.model.name.clone(), problem.n_points(), problem.seed);
            let rows = problem_rows(&a.problem, &Analysed::of(&problem));
            let model_notes = report::model_notes(&problem.model);
            let (mut ev, notes) = a.problem.backend.evaluator(problem)?;
            let notes = [model_notes, notes].concat();
            let bar = Progress::new(a.reports.quiet, "MCS", "draws");
            let cb = |done: u64, total: u64| bar.update(done, total);
            let mcs = mc::run_mcs(
                ev.as_mut(),
                &McsOptions {
                    draws: a.draws,
                    chunk: McsJob::chunk(a.draws),
                    settings: base.clone(),
                },
                Some(&cb),
            )
            .map_err(|e| Driver::Compare.error(e))?;
            let mut amcs = Vec::new();
            for (d, o) in a.deltas.deltas.iter().zip(&amcs_opts) {
                bar.set_label(format!("AMCS δ={d}"));
                bar.restart(true);
                let r = mc::run_amcs(ev.as_mut(), o, Some(&cb))
                    .map_err(|e| Driver::Compare.error(e))?;
                let mre = report::max_relative_error(&r, &mcs);
                amcs.push((*d, r, mre));
            }
            bar.finish();
            let c = Comparison {
                model,
                points: m,
                seed,
                mcs,
                amcs,
                notes,
            };
            Ok((c, rows))
        })?;
        outputs.stage_file("--markdown", report::markdown::render_comparison(&c))?;
        // -q silences the progress bar only: the table is the comparison's result.
        let print = ReportFlags {
            quiet: false,
            ..a.reports.clone()
        };
        write_reports(outputs, &c, &print, &rows)
    }
}
