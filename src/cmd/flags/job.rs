//! Job errors ([`gpu_amcs::job::JobError`]) as the command line shows them: each setting with
//! its flag (through the mappers beside this file), each memory refusal with advice naming the
//! flags that make the run smaller.

use super::{map_error, sensitivity_error, spec_error, tail_error, Driver};
use gpu_amcs::job::{JobError, JobSetting, MemoryCheck};
use gpu_amcs::mc::summary::SummaryError;

/// The flag of a setting a job checks itself.
pub fn job_flag(s: JobSetting) -> &'static str {
    match s {
        JobSetting::Shard => "--shard",
        JobSetting::Task => "--iso9283",
        JobSetting::Reference => "--reference",
        JobSetting::Frame => "--frame",
    }
}

/// What to change when a job's memory estimate `check` does not fit, in flags.
pub fn memory_advice(check: MemoryCheck, library: &str) -> String {
    match check {
        MemoryCheck::Amcs => "lower --max-draws or --batch, use fewer --points or no --per-point, \
                              or raise --memory-limit"
            .into(),
        MemoryCheck::Mcs => "use fewer --draws (or AMCS), fewer --points or no --per-point, or \
                             raise --memory-limit"
            .into(),
        MemoryCheck::McsSummary => {
            "use fewer --points or no --per-point, or raise --memory-limit".into()
        }
        MemoryCheck::Compare => "use fewer --draws or --points, or raise --memory-limit".into(),
        MemoryCheck::Sensitivity => "use fewer --draws, or raise --memory-limit".into(),
        MemoryCheck::Tail => "use fewer --samples-per-level, or raise --memory-limit".into(),
        MemoryCheck::Map { shards: None } => library.into(),
        MemoryCheck::Map { shards: Some(k) } => format!(
            "split it into {k} or more shards (--shard K/{k} --summary-out FILE, then gpu-amcs \
             merge), or {library}"
        ),
        MemoryCheck::PlanSearch => "use fewer --candidates, or raise --memory-limit".into(),
        MemoryCheck::PlanPrediction => "use fewer --draws, or raise --memory-limit".into(),
    }
}

/// A summary error: settings name their flag, a histogram that outgrew the memory says which
/// flag raises it.
fn summary_error(e: SummaryError) -> anyhow::Error {
    match e {
        SummaryError::Mc(e) => Driver::Run.error(e),
        e @ SummaryError::Histogram { .. } => anyhow::anyhow!("{e}; raise --memory-limit"),
        e => e.into(),
    }
}

/// A job error with the flags of the setting at fault (a plan's own errors: `plan.rs`; a
/// comparison's driver settings, with `compare`'s flags: `compare.rs`).
pub fn job_error(e: JobError) -> anyhow::Error {
    match e {
        JobError::Spec(e) => spec_error(e),
        JobError::Memory { check, error } => {
            let error = error
                .clone()
                .with_advice(memory_advice(check, error.advice()));
            match check {
                MemoryCheck::Map { .. } => anyhow::Error::new(error).context("--draws, --cells"),
                _ => error.into(),
            }
        }
        JobError::Setting { setting, message } => {
            anyhow::anyhow!("{}: {message}", job_flag(setting))
        }
        JobError::Run(e) => Driver::Run.error(e),
        JobError::Summary(e) => summary_error(e),
        JobError::Sensitivity(e) => sensitivity_error(e),
        JobError::Tail(e) => tail_error(e),
        JobError::Map(e) => map_error(e),
        e @ (JobError::Reached(_) | JobError::Plan(_)) => e.into(),
    }
}
