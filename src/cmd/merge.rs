//! `merge`: the report of a run from the summaries of its shards (`mcs --shard K/N
//! --summary-out FILE`; sensitivity and map shards too), and the shard a run is, as the
//! command line and the schedulers name it ([`ShardFlags`]).

use super::args::MemoryArgs;
use super::outputs::Outputs;
use super::reports::write_reports;
use super::Run;
use crate::cmd::reports::ReportFlags;
use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use gpu_amcs::job::summary_report;
pub use gpu_amcs::job::Shard;
use gpu_amcs::map::shard::{self as map_shard, MapShard};
use gpu_amcs::mc::sensitivity::SensitivityResult;
use gpu_amcs::mc::summary::{self, SensitivityShard, Summary, SummaryError, BYTES_PER_BIN};
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
        let rep = summary_report(&merged, Vec::new());
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

/// A shard ([`Shard`]) as the command line names one: `--shard K/N`, or a scheduler's
/// variables.
pub trait ShardFlags: Sized {
    /// Parses `K/N` (`source` names where it came from in errors).
    fn parse(text: &str, source: &str) -> Result<Self>;

    /// The shard from `--shard K/N`; else from a Slurm array task (`SLURM_ARRAY_TASK_ID` less
    /// `SLURM_ARRAY_TASK_MIN`, over `SLURM_ARRAY_TASK_STEP`, of `SLURM_ARRAY_TASK_COUNT`); else
    /// from a Kubernetes Indexed Job (`JOB_COMPLETION_INDEX` of `--shards N`); else the whole
    /// run. `env` reads a variable. Half a scheduler's variables, both schedulers' at once, or
    /// values that disagree are an error naming the variable.
    fn from_flags_or_env(
        flag: Option<&str>,
        shards: Option<u64>,
        env: impl Fn(&str) -> Option<String>,
    ) -> Result<Self>;
}

/// The shard of a run that writes a summary (`summary_out`), from `--shard` (`flag`),
/// `--shards` or the process's environment ([`ShardFlags::from_flags_or_env`]); none for a
/// run without one.
pub fn summary_shard(
    summary_out: bool,
    flag: Option<&str>,
    shards: Option<u64>,
) -> Result<Option<Shard>> {
    summary_out
        .then(|| Shard::from_flags_or_env(flag, shards, |v| std::env::var(v).ok()))
        .transpose()
}

/// Shard `k` of `n`, or an error naming `source`.
fn shard(k: u64, n: u64, source: &str) -> Result<Shard> {
    Shard::new(k, n).ok_or_else(|| anyhow!("{source}: shard {k} of {n}: need 0 ≤ K < N"))
}

impl ShardFlags for Shard {
    fn parse(text: &str, source: &str) -> Result<Shard> {
        let (k, n) = text
            .split_once('/')
            .ok_or_else(|| anyhow!("{source}: expected K/N (e.g. 0/4), got {text:?}"))?;
        let num = |s: &str| {
            s.trim()
                .parse::<u64>()
                .map_err(|_| anyhow!("{source}: expected K/N with whole numbers, got {text:?}"))
        };
        shard(num(k)?, num(n)?, source)
    }

    fn from_flags_or_env(
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
                Some(n) => shard(i, n, "JOB_COMPLETION_INDEX"),
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
                shard(off / step, count, "SLURM_ARRAY_TASK_ID")
            }
        }
    }
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

#[cfg(test)]
mod tests;
