//! A mergeable summary of a Monte Carlo run (`docs/METHOD.md §4`): what the reports need,
//! without keeping the values, so that a run can be split into shards of the one draw stream
//! (draw k is a pure function of the seed and k) and the shards merged.
//!
//! Exact parts: count, min, max, the central moment sums (merged with the pairwise update of
//! Chan et al. for M2 and Pébay 2008 for M3 and M4), the counts below each threshold (so
//! R(l_c) and its Wilson interval are those of the single run), the optional per-point counts,
//! and the moments of the 20 equal groups the batch-means standard errors use. Quantiles and
//! the coverage interval come from a fine histogram of fixed bin width h = [`BIN_WIDTH`] stored
//! sparsely (only occupied bins, so memory grows with the occupied range of w, not the draws).
//! A rank's value is read as its bin's centre (the exact min and max at the ends), within h/2
//! of the value: the symmetric interval's ends are within h/2 of the sorted-values ends; the
//! shortest interval is chosen among the same ranks with widths off by at most h, so its true
//! width is within 2h of the shortest, and its ends are within h/2 of the sorted-values ends
//! whenever it picks the same ranks (tested within h on 3·10^5 and 10^6 draws).

mod fnv;
mod mcs;
mod moments;
mod provenance;
mod sensitivity_shard;

pub(crate) use fnv::Fnv;
pub use mcs::{merge, summarize, Summary};
pub use moments::MomentSums;
pub use provenance::Provenance;
pub(crate) use provenance::{in_range_order, provenance_fields};
pub use sensitivity_shard::{merge_sensitivity, SensitivityMergeError, SensitivityShard};

use super::result::McError;

/// Width h of a histogram bin, mm: bin `b` holds `b·h ≤ w < (b + 1)·h`.
pub const BIN_WIDTH: f64 = 1e-6;

/// Bytes one occupied histogram bin is budgeted at: a B-tree entry (two u64) and its share of
/// the node (up to eleven entries a node, at least half full, plus the node header).
pub const BYTES_PER_BIN: u64 = 64;

/// Number of groups of the batch-means standard errors of M1–M4 (as in an MCS run).
pub const GROUPS: u64 = 20;

/// Representative values kept for the PDF and CDF curves of a summary's report.
pub const CURVE_VALUES: usize = 10_000;

/// Errors of building, reading and merging summaries.
#[derive(Debug, thiserror::Error)]
pub enum SummaryError {
    /// The driver failed (a setting, the evaluator, a non-finite value).
    #[error(transparent)]
    Mc(#[from] McError),
    /// A file is not a summary.
    #[error("{file}: not a summary: {message}")]
    Corrupt {
        /// The file.
        file: String,
        /// What is wrong.
        message: String,
    },
    /// A summary's field differs from the first summary's.
    #[error("{file}: field `{field}` is {found}, but {first_file} has {expected}")]
    Mismatch {
        /// The file.
        file: String,
        /// The field.
        field: &'static str,
        /// Its value there.
        found: String,
        /// The first file.
        first_file: String,
        /// Its value in the first file.
        expected: String,
    },
    /// The ranges (of draws, or of a map's reached cells) overlap or leave a gap.
    #[error("{file}: {unit} [{first}, {end}) {problem}")]
    Range {
        /// The file.
        file: String,
        /// What the range counts: "draws" or "reached cells".
        unit: &'static str,
        /// First draw (or cell) of that file.
        first: u64,
        /// End of that file's range.
        end: u64,
        /// "overlap …" or "leave … missing".
        problem: String,
    },
    /// No summaries were given.
    #[error("no summaries to merge")]
    Empty,
    /// The histogram outgrew the bins it was allowed.
    #[error(
        "the histogram of w needs more than {max_bins} occupied bins of width {BIN_WIDTH:e} mm \
         (w spreads over {min} … {max} mm), more than the memory left for it"
    )]
    Histogram {
        /// Bins allowed.
        max_bins: u64,
        /// Smallest w so far, mm.
        min: f64,
        /// Largest w so far, mm.
        max: f64,
    },
}
