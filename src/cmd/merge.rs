//! `merge`: the report of a run from the summaries of its shards (`mcs --shard K/N
//! --summary-out FILE`), and the shard run itself: draws `[K·n/N, (K+1)·n/N)` of the one
//! stream, summarised without keeping the values.

use super::analysis::{outputs, write_reports};
use super::args::{thread_pool, BYTES_PER_POINT};
use super::html;
use super::outputs::{Outputs, CSV_NAMES, SVG_NAMES};
use super::progress::Progress;
use super::{Flags, Run};
use crate::cli::{HtmlArgs, OutputArgs, ProblemArgs};
use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use gpu_amcs::mc::summary::{self, Provenance, Summary};
use gpu_amcs::mc::{min_draws, McError, Setting};
use gpu_amcs::memory::Estimate;
use gpu_amcs::report::RunReport;
use std::path::{Path, PathBuf};

/// Largest summary file read, bytes (a summary holds at most one entry per occupied bin).
const MAX_SUMMARY_BYTES: u64 = 1 << 30;

/// Histogram bins a shard is sized for: one a draw, up to a 2 mm spread of w at 10^-6 mm a bin.
const HISTOGRAM_BINS: u64 = 2_000_000;

/// Bytes of one occupied histogram bin (a map entry and its share of the tree).
const BYTES_PER_BIN: u64 = 64;

/// Merge options.
#[derive(Args, Debug, Clone)]
pub struct MergeArgs {
    /// Summaries written by `mcs --summary-out`, together covering every draw of one run once.
    #[arg(required = true, value_name = "FILE")]
    pub files: Vec<PathBuf>,
    /// Write the JSON report here.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Write CSV reports (summary, reliability, PDF, CDF) into this directory.
    #[arg(long, value_name = "DIR")]
    pub csv: Option<PathBuf>,
    /// Write SVG plots into this directory.
    #[arg(long, value_name = "DIR")]
    pub svg: Option<PathBuf>,
    #[command(flatten)]
    pub html: HtmlArgs,
    /// No text report on stdout.
    #[arg(long, short)]
    pub quiet: bool,
}

impl Run for MergeArgs {
    fn run(self) -> Result<()> {
        let mut outputs = Outputs::new(self.files.iter().map(|f| ("FILE", f.as_path())));
        outputs.file("--json", self.json.as_deref())?;
        outputs.dir("--csv", self.csv.as_deref(), CSV_NAMES)?;
        outputs.dir("--svg", self.svg.as_deref(), SVG_NAMES)?;
        self.html.declare(&mut outputs, html::RUN_NAMES)?;
        let named = self
            .files
            .iter()
            .map(|f| read_summary(f).map(|s| (f.display().to_string(), s)))
            .collect::<Result<Vec<_>>>()?;
        let merged = summary::merge(&named)?;
        let rep = report_of(&merged, Vec::new());
        let shards: Vec<String> = named.iter().map(|(n, _)| n.clone()).collect();
        let rows = vec![("shard summaries".to_string(), shards.join(", "))];
        write_reports(outputs, &rep, &rows, self.quiet)
    }
}

/// Reads one summary file, naming it in every error.
fn read_summary(path: &Path) -> Result<Summary> {
    let shown = path.display().to_string();
    let len = std::fs::metadata(path)
        .with_context(|| format!("{shown}: cannot read"))?
        .len();
    if len > MAX_SUMMARY_BYTES {
        bail!("{shown}: not a summary: {len} bytes, more than {MAX_SUMMARY_BYTES}");
    }
    let text = std::fs::read_to_string(path).with_context(|| format!("{shown}: cannot read"))?;
    Ok(Summary::from_json(&text, &shown)?)
}

/// The run report of a summary, with its note after `notes`.
fn report_of(s: &Summary, mut notes: Vec<String>) -> RunReport {
    let p = &s.provenance;
    notes.push(s.note());
    RunReport {
        model: p.model.clone(),
        points: p.points,
        reference: p.reference.clone(),
        seed: p.seed,
        notes,
        result: s.to_result(),
    }
}

/// Shard K of N (0-based K).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// This shard.
    pub k: u64,
    /// Number of shards.
    pub n: u64,
}

impl Shard {
    /// Parses `K/N` (`source` names where it came from in errors).
    pub fn parse(text: &str, source: &str) -> Result<Shard> {
        let (k, n) = text
            .split_once('/')
            .ok_or_else(|| anyhow!("{source}: expected K/N (e.g. 0/4), got {text:?}"))?;
        let num = |s: &str| {
            s.trim()
                .parse::<u64>()
                .map_err(|_| anyhow!("{source}: expected K/N with whole numbers, got {text:?}"))
        };
        Shard::new(num(k)?, num(n)?, source)
    }

    fn new(k: u64, n: u64, source: &str) -> Result<Shard> {
        if n == 0 || k >= n {
            bail!("{source}: shard {k} of {n}: need 0 ≤ K < N");
        }
        Ok(Shard { k, n })
    }

    /// The shard from `--shard`, else from a Slurm array task (`SLURM_ARRAY_TASK_ID` less
    /// `SLURM_ARRAY_TASK_MIN`, of `SLURM_ARRAY_TASK_COUNT`), else the whole run.
    pub fn from_flag_or_env(flag: Option<&str>) -> Result<Shard> {
        if let Some(text) = flag {
            return Shard::parse(text, "--shard");
        }
        let var = |name: &str| -> Result<Option<u64>> {
            match std::env::var(name) {
                Err(_) => Ok(None),
                Ok(v) => v
                    .trim()
                    .parse()
                    .map(Some)
                    .map_err(|_| anyhow!("{name}: expected a whole number, got {v:?}")),
            }
        };
        match (var("SLURM_ARRAY_TASK_ID")?, var("SLURM_ARRAY_TASK_COUNT")?) {
            (Some(id), Some(count)) => {
                let min = var("SLURM_ARRAY_TASK_MIN")?.unwrap_or(0);
                let k = id.checked_sub(min).ok_or_else(|| {
                    anyhow!("SLURM_ARRAY_TASK_ID: {id} is below SLURM_ARRAY_TASK_MIN {min}")
                })?;
                Shard::new(k, count, "SLURM_ARRAY_TASK_ID/SLURM_ARRAY_TASK_COUNT")
            }
            _ => Ok(Shard { k: 0, n: 1 }),
        }
    }

    /// Draws `[K·draws/N, (K+1)·draws/N)`.
    pub fn range(&self, draws: u64) -> (u64, u64) {
        let at = |k: u64| (u128::from(k) * u128::from(draws) / u128::from(self.n)) as u64;
        (at(self.k), at(self.k + 1))
    }
}

/// Runs shard `shard` of an MCS run of `draws` draws in chunks of `chunk` and writes its
/// summary to `summary_out` (with the shard's own reports from the other outputs).
pub fn run_shard(
    problem: &ProblemArgs,
    output: &OutputArgs,
    draws: u64,
    chunk: u64,
    shard: Shard,
    summary_out: &Path,
) -> Result<()> {
    let settings = output.settings();
    settings.check().map_err(|e| Flags::RUN.error(e))?;
    let min = min_draws(settings.coverage_probability);
    if draws < min {
        return Err(Flags::RUN.error(McError::Setting {
            field: Setting::Draws,
            message: format!("must be at least 100/(1 − p) = {min}, got {draws}"),
        }));
    }
    if shard.n > draws {
        bail!(
            "--shard: {} shards of {draws} draws leave some empty",
            shard.n
        );
    }
    problem.check()?;
    let mut outputs = outputs(problem, output)?;
    outputs.file("--summary-out", Some(summary_out))?;
    let (first, end) = shard.range(draws);
    let estimate = |m: u64| {
        let e = Estimate::new(
            format!("a summary of {} draws in chunks of {chunk}", end - first),
            "use fewer --points or no --per-point, or raise --memory-limit",
        )
        .plus(&[chunk, 8])
        .plus(&[m, BYTES_PER_POINT])
        .plus(&[(end - first).min(HISTOGRAM_BINS), BYTES_PER_BIN]);
        if output.per_point {
            e.plus(&[chunk, m, 2 * 8])
        } else {
            e
        }
    };
    let generated = match problem.points_file {
        Some(_) => 0,
        None => problem.points as u64,
    };
    problem.memory.check(&estimate(generated))?;
    let pool = thread_pool(problem.threads)?;
    let (s, notes, rows) = pool.install(|| -> Result<(Summary, Vec<String>, _)> {
        let built = problem.build()?;
        problem
            .memory
            .check(&estimate(built.problem.n_points() as u64))?;
        let prov = Provenance::new(&built.problem, &built.reference, draws, first, end);
        let rows = html::problem_rows(problem, &built.problem);
        let (mut ev, notes) = problem.backend.evaluator(built.problem)?;
        let bar = Progress::new(output.quiet, "MCS shard", "draws");
        let s = summary::summarize(
            ev.as_mut(),
            first,
            end,
            chunk,
            &settings,
            prov,
            Some(&|done, total| bar.update(done, total)),
        );
        bar.finish();
        Ok((s?, notes, rows))
    })?;
    outputs.stage_file("--summary-out", s.to_json())?;
    write_reports(outputs, &report_of(&s, notes), &rows, output.quiet)
}
