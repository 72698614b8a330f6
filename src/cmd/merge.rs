//! `merge`: the report of a run from the summaries of its shards (`mcs --shard K/N
//! --summary-out FILE`; sensitivity and map shards too), and the shard run itself: draws
//! `[K·n/N, (K+1)·n/N)` of the one stream, summarised without keeping the values.

use super::analysis::outputs;
use super::args::{thread_pool, MemoryArgs, BYTES_PER_POINT};
use super::flags::{sensitivity_error, Driver};
use super::outputs::Outputs;
use super::progress::Progress;
use super::reports::{problem_rows, write_reports};
use super::Run;
use crate::cmd::args::{OutputArgs, ProblemArgs};
use crate::cmd::reports::ReportFlags;
use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use gpu_amcs::map::shard::{self as map_shard, MapShard};
use gpu_amcs::mc::sensitivity::{SensitivityOptions, SensitivityResult};
use gpu_amcs::mc::summary::{
    self, Provenance, SensitivityShard, Summary, SummaryError, BYTES_PER_BIN,
};
use gpu_amcs::mc::{min_draws, McError, Setting};
use gpu_amcs::memory::{Bytes, Estimate};
use gpu_amcs::report::{Report, RunReport};
use std::path::{Path, PathBuf};

/// Largest summary file read, bytes (a summary holds at most one entry per occupied bin).
const MAX_SUMMARY_BYTES: u64 = 1 << 30;

/// Merge options.
#[derive(Args, Debug, Clone)]
#[command(
    mut_arg("json", |a| a.help("Write the JSON report here")),
    mut_arg("csv", |a| a.help("Write CSV reports (summary, reliability, PDF, CDF) into this directory")),
    mut_arg("svg", |a| a.help("Write SVG plots into this directory")),
    mut_arg("quiet", |a| a.help("No text report on stdout"))
)]
pub struct MergeArgs {
    /// Summaries written by `mcs --summary-out` (or `sensitivity`, `map`), together covering
    /// every draw (a map: every reached cell) of one run once.
    #[arg(required = true, value_name = "FILE")]
    pub files: Vec<PathBuf>,
    #[command(flatten)]
    pub reports: ReportFlags,
    #[command(flatten)]
    pub memory: MemoryArgs,
}

impl Run for MergeArgs {
    fn run(self) -> Result<()> {
        // Sized from the files' lengths before any is read: every shard is kept once parsed,
        // and the largest passes through its text, its checksum-verified copy and its parse.
        let sizes = self
            .files
            .iter()
            .map(|f| file_len(f))
            .collect::<Result<Vec<_>>>()?;
        self.memory.check(&merge_estimate(&sizes, 1))?;
        let texts = Texts::open(&self.files)?;
        let kind = texts.kind.clone();
        if kind.is_none() {
            // Run summaries keep a B-tree entry for each histogram bin, written in as few as
            // six characters (`"7":1,`).
            self.memory
                .check(&merge_estimate(&sizes, BYTES_PER_BIN.div_ceil(6)))?;
        }
        let files: Vec<String> = self.files.iter().map(|f| f.display().to_string()).collect();
        let rows = vec![("shard summaries".to_string(), files.join(", "))];
        let mut outputs = Outputs::new(self.files.iter().map(|f| ("FILE", f.as_path())));
        let flags = &self.reports;
        if kind.as_deref() == Some(MapShard::KIND) {
            // A map's files depend on its layers, known once its shards are read.
            let named = texts.parse(|t, f| Ok(MapShard::from_json(t, f)?))?;
            let result = map_shard::merge(&named).map_err(merge_error)?;
            flags.declare(&mut outputs, &result.layout())?;
            return write_reports(outputs, &result, flags, &rows);
        }
        if kind.as_deref() == Some(SensitivityShard::KIND) {
            flags.declare(&mut outputs, &SensitivityResult::planned_layout())?;
            let named = texts.parse(|t, f| Ok(SensitivityShard::from_json(t, f)?))?;
            let result = summary::merge_sensitivity(&named).map_err(|e| match e {
                summary::SensitivityMergeError::Shards(e) => merge_error(e),
                e => e.into(),
            })?;
            return write_reports(outputs, &result, flags, &rows);
        }
        flags.declare(&mut outputs, &RunReport::planned_layout())?;
        let named = texts.parse(|t, f| Ok(Summary::from_json(t, f)?))?;
        let merged = summary::merge(&named).map_err(merge_error)?;
        let rep = report_of(&merged, Vec::new());
        write_reports(outputs, &rep, flags, &rows)
    }
}

/// What merging files of `sizes` bytes keeps at most: every file once parsed (`per_byte` bytes
/// a byte of its text: 1 for map and sensitivity shards, whose draws are 16 or about 20
/// characters of text and 8 bytes parsed) and, while the largest is read, its text, its
/// checksum-verified copy and its parse at once.
fn merge_estimate(sizes: &[u64], per_byte: u64) -> Estimate {
    let total = sizes.iter().try_fold(0u64, |a, &s| a.checked_add(s));
    let largest = sizes.iter().copied().max().unwrap_or(0);
    Estimate::new(
        format!(
            "merging {} file(s) of {}",
            sizes.len(),
            total.map_or("more than 2^64 bytes".to_string(), |t| Bytes(t).to_string())
        ),
        "merge on a machine with more memory, or raise --memory-limit",
    )
    .plus(&[total.unwrap_or(u64::MAX), per_byte])
    .plus(&[largest, 3])
}

/// The `kind` field of a shard file (absent in a run summary).
#[derive(serde::Deserialize)]
struct Kind {
    kind: Option<String>,
}

/// What a file of `kind` holds, in words.
fn kind_words(kind: Option<&str>) -> String {
    match kind {
        None => "an mcs summary".to_string(),
        Some(k) if k == SensitivityShard::KIND => "a sensitivity shard".to_string(),
        Some(k) if k == MapShard::KIND => "a map shard".to_string(),
        Some(k) => format!("of kind {k:?}"),
    }
}

/// The kind a file's `text` tells: `None` when it is not JSON of that form (its own reader
/// refuses it, naming it), `Some(None)` for a run summary.
fn kind_of(text: &str) -> Option<Option<String>> {
    serde_json::from_str::<Kind>(text).ok().map(|k| k.kind)
}

/// The files to merge, read one at a time so that only one file's text is held at once: the
/// first file's text and kind, then each other file checked to be of the same kind.
struct Texts<'a> {
    /// The files, in the order given.
    files: &'a [PathBuf],
    /// The first file's text, until it is parsed.
    first: Option<String>,
    /// The first file's kind (`None` for a run summary or a file that is not JSON).
    kind: Option<String>,
}

impl<'a> Texts<'a> {
    /// Reads the first of `files` (at least one: clap requires it).
    fn open(files: &'a [PathBuf]) -> Result<Texts<'a>> {
        let first = match files.first() {
            Some(f) => read_text(f)?,
            None => bail!("no files to merge"),
        };
        let kind = kind_of(&first).flatten();
        Ok(Texts {
            files,
            first: Some(first),
            kind,
        })
    }

    /// Each file parsed by `parse(text, name)` and named, every file's text dropped once it is
    /// parsed; a file that tells another kind than the first is refused before it is parsed.
    fn parse<T>(mut self, parse: impl Fn(&str, &str) -> Result<T>) -> Result<Vec<(String, T)>> {
        let mut out = Vec::with_capacity(self.files.len());
        for (i, f) in self.files.iter().enumerate() {
            let name = f.display().to_string();
            let text = match self.first.take() {
                Some(t) if i == 0 => t,
                _ => {
                    let t = read_text(f)?;
                    if let Some(k) = kind_of(&t).filter(|k| *k != self.kind) {
                        bail!(
                            "{name}: {}, but {} is {}; merge the files of one run",
                            kind_words(k.as_deref()),
                            self.files[0].display(),
                            kind_words(self.kind.as_deref())
                        );
                    }
                    t
                }
            };
            let parsed = parse(&text, &name)?;
            drop(text);
            out.push((name, parsed));
        }
        Ok(out)
    }
}

/// The length of one shard file, naming it in every error; longer than [`MAX_SUMMARY_BYTES`]
/// is refused.
fn file_len(path: &Path) -> Result<u64> {
    let shown = path.display().to_string();
    let len = std::fs::metadata(path)
        .with_context(|| format!("{shown}: cannot read"))?
        .len();
    if len > MAX_SUMMARY_BYTES {
        bail!("{shown}: not a summary: {len} bytes, more than {MAX_SUMMARY_BYTES}");
    }
    Ok(len)
}

/// Reads one shard file, naming it in every error.
fn read_text(path: &Path) -> Result<String> {
    let shown = path.display().to_string();
    file_len(path)?;
    std::fs::read_to_string(path).with_context(|| format!("{shown}: cannot read"))
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
    /// The whole run.
    pub const WHOLE: Shard = Shard { k: 0, n: 1 };

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

    /// The shard from `--shard K/N`; else from a Slurm array task (`SLURM_ARRAY_TASK_ID` less
    /// `SLURM_ARRAY_TASK_MIN`, over `SLURM_ARRAY_TASK_STEP`, of `SLURM_ARRAY_TASK_COUNT`); else
    /// from a Kubernetes Indexed Job (`JOB_COMPLETION_INDEX` of `--shards N`); else the whole
    /// run. `env` reads a variable. Half a scheduler's variables, both schedulers' at once, or
    /// values that disagree are an error naming the variable.
    pub fn from_flags_or_env(
        flag: Option<&str>,
        shards: Option<u64>,
        env: impl Fn(&str) -> Option<String>,
    ) -> Result<Shard> {
        if let Some(text) = flag {
            return Shard::parse(text, "--shard");
        }
        let num = |name: &str| -> Result<Option<u64>> {
            env(name)
                .map(|v| {
                    v.trim()
                        .parse::<u64>()
                        .map_err(|_| anyhow!("{name}: expected a whole number, got {v:?}"))
                })
                .transpose()
        };
        let slurm = (num("SLURM_ARRAY_TASK_ID")?, num("SLURM_ARRAY_TASK_COUNT")?);
        match (slurm, num("JOB_COMPLETION_INDEX")?) {
            ((Some(_), _) | (_, Some(_)), Some(_)) => bail!(
                "JOB_COMPLETION_INDEX: set together with SLURM_ARRAY_TASK_*; give --shard K/N \
                 to say which shard this is"
            ),
            ((None, None), None) => match shards {
                Some(n) => bail!(
                    "--shards {n}: JOB_COMPLETION_INDEX is not set (--shards is for a Kubernetes \
                     Indexed Job; elsewhere give --shard K/N)"
                ),
                None => Ok(Shard::WHOLE),
            },
            ((None, None), Some(i)) => match shards {
                Some(n) => Shard::new(i, n, "JOB_COMPLETION_INDEX"),
                None => bail!(
                    "JOB_COMPLETION_INDEX: set ({i}), but --shards N (the Job's completions) \
                     is not given"
                ),
            },
            ((Some(_), None), None) => {
                bail!("SLURM_ARRAY_TASK_COUNT: not set, but SLURM_ARRAY_TASK_ID is")
            }
            ((None, Some(_)), None) => {
                bail!("SLURM_ARRAY_TASK_ID: not set, but SLURM_ARRAY_TASK_COUNT is")
            }
            ((Some(id), Some(count)), None) => {
                let min = num("SLURM_ARRAY_TASK_MIN")?.unwrap_or(0);
                let step = num("SLURM_ARRAY_TASK_STEP")?.unwrap_or(1);
                if step == 0 {
                    bail!("SLURM_ARRAY_TASK_STEP: must be at least 1, got 0");
                }
                let off = id.checked_sub(min).ok_or_else(|| {
                    anyhow!("SLURM_ARRAY_TASK_ID: {id} is below SLURM_ARRAY_TASK_MIN {min}")
                })?;
                if off % step != 0 {
                    bail!(
                        "SLURM_ARRAY_TASK_ID: {id} is not SLURM_ARRAY_TASK_MIN {min} plus a \
                         multiple of SLURM_ARRAY_TASK_STEP {step}"
                    );
                }
                if let Some(max) = num("SLURM_ARRAY_TASK_MAX")? {
                    let held = max.checked_sub(min).map(|d| d / step + 1);
                    if held != Some(count) {
                        bail!(
                            "SLURM_ARRAY_TASK_COUNT: {count} tasks, but the array \
                             {min}-{max}:{step} is not that many evenly spaced tasks; submit a \
                             range (--array=0-{})",
                            count.saturating_sub(1)
                        );
                    }
                }
                if let Some(n) = shards.filter(|&n| n != count) {
                    bail!("--shards {n}: SLURM_ARRAY_TASK_COUNT is {count}");
                }
                Shard::new(off / step, count, "SLURM_ARRAY_TASK_ID")
            }
        }
    }

    /// Draws `[K·draws/N, (K+1)·draws/N)`.
    pub fn range(&self, draws: u64) -> (u64, u64) {
        let at = |k: u64| (u128::from(k) * u128::from(draws) / u128::from(self.n)) as u64;
        (at(self.k), at(self.k + 1))
    }
}

/// Histogram bins a summary reserves up front: w of the TX60 spreads over ~0.25 mm, so about
/// 2.5·10^5 bins of 10^-6 mm are occupied at 10^6 draws (crates/core/src/mc/summary/); the bins beyond
/// this reserve are bounded while the run goes, by the memory the limit leaves.
const RESERVED_BINS: u64 = 1 << 16;

/// Draws per chunk of a summary of `draws` draws, `per_draw` bytes of buffers each (None: not
/// known yet): up to 2^20, for fewer round trips to a GPU (a 10^9-draw run in chunks of 10^5
/// made 10^4 of them), halved while one chunk's buffers would take more than an eighth of the
/// memory `limit`, and never below `floor` (the exact run's chunk).
fn summary_chunk(floor: u64, draws: u64, per_draw: Option<u64>, limit: u64) -> u64 {
    let Some(bytes) = per_draw else {
        return floor;
    };
    let mut chunk = (1u64 << 20).min(draws);
    while chunk > floor && chunk.saturating_mul(bytes) > limit / 8 {
        chunk /= 2;
    }
    chunk.max(floor.min(draws)).max(1)
}

/// Runs shard `shard` of an MCS run of `draws` draws in chunks of `chunk` (`sizes`) without
/// keeping the values, and writes its summary to `summary_out` when given, with the reports
/// of the other outputs (from the summary, after `notes`).
pub fn run_summary(
    problem: &ProblemArgs,
    output: &OutputArgs,
    (draws, chunk): (u64, u64),
    shard: Shard,
    summary_out: Option<&Path>,
    notes: Vec<String>,
) -> Result<()> {
    let settings = output.settings();
    settings.check().map_err(|e| Driver::Run.error(e))?;
    let min = min_draws(settings.coverage_probability);
    if draws < min {
        return Err(Driver::Run.error(McError::Setting {
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
    outputs.file("--summary-out", summary_out)?;
    let (first, end) = shard.range(draws);
    let generated = match problem.points_file {
        Some(_) => 0,
        None => problem.points as u64,
    };
    let chunk = summary_chunk(
        chunk,
        end - first,
        match (output.per_point, problem.points_file.is_some()) {
            (false, _) => Some(8),
            (true, false) => Some(8 + 16 * generated),
            // A points file's count is known only once read.
            (true, true) => None,
        },
        problem.memory.budget()?.limit,
    );
    let fixed = |m: u64| {
        let e = Estimate::new(
            format!("a summary of {} draws in chunks of {chunk}", end - first),
            "use fewer --points or no --per-point, or raise --memory-limit",
        )
        .plus(&[chunk, 8])
        .plus(&[m, BYTES_PER_POINT]);
        if output.per_point {
            e.plus(&[chunk, m, 2 * 8])
        } else {
            e
        }
    };
    let estimate = |m: u64| fixed(m).plus(&[(end - first).min(RESERVED_BINS), BYTES_PER_BIN]);
    problem.memory.check(&estimate(generated))?;
    let pool = thread_pool(problem.threads)?;
    let (s, notes, rows) = pool.install(|| -> Result<(Summary, Vec<String>, _)> {
        let mut built = problem.build()?;
        // The robot base frame analyses the model without its placement's spread: so does the
        // provenance (its model hash), so shards of the two frames never merge.
        built.problem = crate::cmd::args::frame_problem(built.problem, problem.frame);
        let m = built.problem.n_points() as u64;
        problem.memory.check(&estimate(m))?;
        let max_bins = problem.memory.budget()?.room_left(&fixed(m)) / BYTES_PER_BIN;
        let prov = Provenance::new(&built.problem, &built.reference, draws, first, end);
        let rows = problem_rows(problem, &built.problem);
        let model = gpu_amcs::report::model_notes(&built.problem.model);
        let (mut ev, more) = problem
            .backend
            .frame_evaluator(built.problem, problem.frame)?;
        let label = if summary_out.is_some() {
            "MCS shard"
        } else {
            "MCS (summary)"
        };
        let bar = Progress::new(output.reports.quiet, label, "draws");
        let s = summary::summarize(
            ev.as_mut(),
            first,
            end,
            chunk,
            max_bins,
            &settings,
            prov,
            Some(&|done, total| bar.update(done, total)),
        );
        bar.finish();
        Ok((
            s.map_err(summary_error)?,
            [notes, model, more].concat(),
            rows,
        ))
    })?;
    outputs.stage_file("--summary-out", s.to_json())?;
    write_reports(outputs, &report_of(&s, notes), &output.reports, &rows)
}

/// Evaluates the shard of a sensitivity analysis that `--shard` or the scheduler's variables
/// name (chunks `[K·C/N, (K+1)·C/N)` of the C evaluation chunks of base samples) and writes its
/// outputs to `summary_out`.
pub fn run_sensitivity_shard(
    problem: &ProblemArgs,
    opts: &SensitivityOptions,
    flag: Option<&str>,
    summary_out: &Path,
) -> Result<()> {
    let shard = Shard::from_flags_or_env(flag, None, |v| std::env::var(v).ok())?;
    // Whole evaluation chunks, so every model call sees the rows of the one-run call (the
    // evaluators round alike only for the same rows at the same place in a call).
    let (n, chunk) = (opts.draws as u64, opts.chunk as u64);
    let chunks = n.div_ceil(chunk);
    if shard.n > chunks {
        bail!(
            "--shard: {} shards of {chunks} chunks of {chunk} base samples leave some empty",
            shard.n
        );
    }
    let mut outputs = Outputs::new(problem.inputs());
    outputs.file("--summary-out", Some(summary_out))?;
    let (c0, c1) = shard.range(chunks);
    let (first, end) = (c0 * chunk, (c1 * chunk).min(n));
    let pool = thread_pool(problem.threads)?;
    let s = pool.install(|| -> Result<SensitivityShard> {
        let built = problem.build()?;
        // The frame decides the inputs, and so the provenance's model hash: shards of the two
        // frames never merge.
        let pb = crate::cmd::args::frame_problem(built.problem.clone(), problem.frame);
        let prov = Provenance::new(&pb, &built.reference, n, first, end);
        let (mut ev, _) = problem
            .backend
            .frame_evaluator(built.problem.clone(), problem.frame)?;
        SensitivityShard::run(&pb, ev.as_mut(), opts, prov).map_err(sensitivity_error)
    })?;
    outputs.stage_file("--summary-out", s.to_json())?;
    outputs.commit()?;
    Ok(())
}

/// A merge error for the command line: a model hash that differs says what makes it differ
/// (the hash alone named no cause the user could act on).
fn merge_error(e: SummaryError) -> anyhow::Error {
    match e {
        SummaryError::Mismatch {
            file,
            field: "model_hash",
            found,
            first_file,
            expected,
        } => anyhow!(
            "{file}: the model as drawn differs from {first_file}'s (field `model_hash` {found}, there {expected}): the shards come from other model files, or from one model with another --frame (base leaves the placement out) or --no-discrepancy; merge the shards of one run"
        ),
        e => e.into(),
    }
}

/// A summary error for the command line: settings name their flag, a histogram that
/// outgrew the memory says which flag raises it.
fn summary_error(e: SummaryError) -> anyhow::Error {
    match e {
        SummaryError::Mc(e) => Driver::Run.error(e),
        e @ SummaryError::Histogram { .. } => anyhow!("{e}; raise --memory-limit"),
        e => e.into(),
    }
}

#[cfg(test)]
mod tests;
