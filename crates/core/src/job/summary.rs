//! An MCS run summarised chunk by chunk ([`super::SummaryMode`]): the values are never all
//! kept, the report comes from the summary, and a shard's summary merges with the others'.

use super::run::summary_report;
use super::{Analysed, JobError, McsJob, MemoryCheck, RunOutcome, BYTES_PER_POINT};
use crate::engine::Backends;
use crate::mc::summary::{self, Provenance, BYTES_PER_BIN};
use crate::mc::{min_draws, McError, Setting};
use crate::memory::Estimate;

/// Histogram bins a summary reserves up front: w of the TX60 spreads over ~0.25 mm, so about
/// 2.5·10^5 bins of 10^-6 mm are occupied at 10^6 draws (`mc/summary/`); the bins beyond this
/// reserve are bounded while the run goes, by the memory the limit leaves.
const RESERVED_BINS: u64 = 1 << 16;

/// Draws per chunk of a summary of `draws` draws, `per_draw` bytes of buffers each (None: not
/// known yet): up to 2^20, for fewer round trips to a GPU (a 10^9-draw run in chunks of 10^5
/// made 10^4 of them), halved while one chunk's buffers would take more than an eighth of the
/// memory `limit`, and never below `floor` (the kept run's chunk).
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

/// Runs the draws of `job.shard` in chunks without keeping the values, under `label`; the
/// report's notes: `notes`, the model's, the evaluator's, then the summary's.
pub(super) fn run(
    job: &McsJob,
    backends: &dyn Backends,
    label: &'static str,
    notes: Vec<String>,
) -> Result<RunOutcome, JobError> {
    let (settings, draws, setup) = (&job.settings, job.draws, &job.setup);
    settings.check()?;
    let min = min_draws(settings.coverage_probability);
    if draws < min {
        return Err(McError::Setting {
            field: Setting::Draws,
            message: format!("must be at least 100/(1 − p) = {min}, got {draws}"),
        }
        .into());
    }
    job.shard.check(draws, &format!("{draws} draws"))?;
    let (first, end) = job.shard.range(draws);
    let known = setup.problem.known_points().map(|m| m as u64);
    let chunk = summary_chunk(
        McsJob::chunk(draws),
        end - first,
        match (settings.per_point, known) {
            (false, _) => Some(8),
            (true, Some(m)) => Some(8 + 16 * m),
            // A points file's count is known only once read.
            (true, None) => None,
        },
        setup.memory.limit,
    );
    let fixed = |m: u64| {
        let e = Estimate::new(
            format!("a summary of {} draws in chunks of {chunk}", end - first),
            "use fewer points or no per-point output, or raise the memory limit",
        )
        .plus(&[chunk, 8])
        .plus(&[m, BYTES_PER_POINT]);
        if settings.per_point {
            e.plus(&[chunk, m, 2 * 8])
        } else {
            e
        }
    };
    let estimate = |m: u64| fixed(m).plus(&[(end - first).min(RESERVED_BINS), BYTES_PER_BIN]);
    setup.check(MemoryCheck::McsSummary, &estimate)?;
    let mut built = setup.build(MemoryCheck::McsSummary, &estimate)?;
    // The robot base frame analyses the model without its placement's spread: so does the
    // provenance (its model hash), so shards of the two frames never merge.
    built.problem = built.problem.in_frame(setup.frame);
    let m = built.problem.n_points() as u64;
    let max_bins = setup.memory.room_left(&fixed(m)) / BYTES_PER_BIN;
    let prov = Provenance::new(&built.problem, &built.reference, draws, first, end);
    let analysed = Analysed::of(&built.problem);
    let model = crate::report::model_notes(&built.problem.model);
    let (mut ev, more) = setup.evaluator(backends, built.problem)?;
    let progress = super::counted(&setup.progress, label);
    let s = summary::summarize(
        ev.as_mut(),
        first,
        end,
        chunk,
        max_bins,
        settings,
        prov,
        Some(&progress),
    )?;
    Ok(RunOutcome {
        report: summary_report(&s, [notes, model, more].concat()),
        analysed,
        summary: Some(s),
    })
}

#[cfg(test)]
mod tests {
    use super::summary_chunk;

    #[test]
    fn a_summary_chunk_shrinks_to_fit_the_memory_but_not_below_the_kept_runs() {
        // Plenty of memory: 2^20 draws a chunk.
        assert_eq!(
            summary_chunk(100_000, 10_000_000, Some(8), 1 << 40),
            1 << 20
        );
        // 8 MiB / 8 = 1 MiB for a chunk's buffers of 16 bytes a draw: 2^16 draws, but never
        // fewer than the kept run's 10^5.
        assert_eq!(
            summary_chunk(100_000, 10_000_000, Some(16), 8 << 20),
            100_000
        );
        assert_eq!(summary_chunk(1000, 10_000_000, Some(16), 8 << 20), 1 << 16);
        // A points file's per-point buffers are unknown: the kept run's chunk.
        assert_eq!(summary_chunk(100_000, 10_000_000, None, 1 << 40), 100_000);
        // Never more than the draws.
        assert_eq!(summary_chunk(500, 500, Some(8), 1 << 40), 500);
    }
}
