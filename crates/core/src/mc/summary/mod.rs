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

pub mod checksum;
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

/// The backend of merged parts, each `[backend, adapter, driver]`: the common one when every
/// part ran on the same backend and adapter, otherwise "mixed: cpu (2 shards), gpu (1)" with the
/// distinct adapters and drivers joined by "; ". Never empty when `parts` is not.
pub fn merged_backend<'a>(parts: impl IntoIterator<Item = &'a [String; 3]>) -> [String; 3] {
    let parts: Vec<&[String; 3]> = parts.into_iter().collect();
    let Some(first) = parts.first() else {
        return Default::default();
    };
    if parts.iter().all(|p| p[..2] == first[..2]) {
        return (*first).clone();
    }
    let distinct = |i: usize| -> Vec<(&str, usize)> {
        let mut seen: Vec<(&str, usize)> = Vec::new();
        for p in &parts {
            match seen.iter_mut().find(|(name, _)| *name == p[i]) {
                Some((_, n)) => *n += 1,
                None => seen.push((&p[i], 1)),
            }
        }
        seen
    };
    let backends: Vec<String> = distinct(0)
        .iter()
        .enumerate()
        .map(|(k, (name, n))| match (k, n) {
            (0, 1) => format!("{name} (1 shard)"),
            (0, n) => format!("{name} ({n} shards)"),
            (_, n) => format!("{name} ({n})"),
        })
        .collect();
    let join = |i: usize| {
        distinct(i)
            .iter()
            .map(|(name, _)| *name)
            .collect::<Vec<_>>()
            .join("; ")
    };
    [format!("mixed: {}", backends.join(", ")), join(1), join(2)]
}

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

#[cfg(test)]
mod tests {
    use super::merged_backend;

    fn b(x: &str, a: &str) -> [String; 3] {
        [x.into(), a.into(), "d".into()]
    }

    #[test]
    fn mixed_backends_are_reported_as_such() {
        let same = [b("cpu", "rayon"), b("cpu", "rayon")];
        assert_eq!(merged_backend(&same), b("cpu", "rayon"));
        let mixed = [b("cpu", "rayon"), b("gpu", "H100"), b("cpu", "rayon")];
        let m = merged_backend(&mixed);
        assert_eq!(m[0], "mixed: cpu (2 shards), gpu (1)");
        assert_eq!(m[1], "rayon; H100");
        assert_eq!(m[2], "d");
        let one = [b("gpu", "a"), b("cpu", "r")];
        assert_eq!(merged_backend(&one)[0], "mixed: gpu (1 shard), cpu (1)");
        assert_eq!(
            merged_backend(&[] as &[[String; 3]]),
            <[String; 3]>::default()
        );
    }
}
