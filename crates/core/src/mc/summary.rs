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

use super::result::{McError, McResult, Method, Progress, RunSettings, Setting};
use super::sensitivity::{
    self, Design, Outputs, SensitivityError, SensitivityOptions, SensitivityResult,
};
use super::stats::{CoverageInterval, IntervalKind, Moments, Reliability};
use crate::engine::{BackendInfo, Evaluator, Problem};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Width h of a histogram bin, mm: bin `b` holds `b·h ≤ w < (b + 1)·h`.
pub const BIN_WIDTH: f64 = 1e-6;

/// The histogram bin of `w` (non-negative).
fn bin_of(w: f64) -> u64 {
    (w / BIN_WIDTH) as u64
}

/// Bytes one occupied histogram bin is budgeted at: a B-tree entry (two u64) and its share of
/// the node (up to eleven entries a node, at least half full, plus the node header).
pub const BYTES_PER_BIN: u64 = 64;

/// Number of groups of the batch-means standard errors of M1–M4 (as in an MCS run).
pub const GROUPS: u64 = 20;

/// Representative values kept for the PDF and CDF curves of a summary's report.
pub const CURVE_VALUES: usize = 10_000;

/// Where a summary comes from: a merge accepts only summaries whose provenance agrees apart
/// from the draw range.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Provenance {
    /// Version of the tool that wrote the summary.
    pub version: String,
    /// Model name.
    pub model: String,
    /// FNV-1a hash of the model's TOML text, hex.
    pub model_hash: String,
    /// What the errors are measured from (e.g. "calibrated model").
    pub reference: String,
    /// Number of test points.
    pub points: usize,
    /// FNV-1a hash of the test points and their reference positions, hex.
    pub points_hash: String,
    /// Seed of the parameter draws.
    pub seed: u64,
    /// Draws of the whole run.
    pub draws: u64,
    /// First draw of this summary.
    pub first: u64,
    /// One past the last draw of this summary.
    pub end: u64,
}

impl Provenance {
    /// The provenance of draws `[first, end)` of a run of `draws` draws of `problem`, whose
    /// errors are measured from `reference` (a label for the reports).
    pub fn new(problem: &Problem, reference: &str, draws: u64, first: u64, end: u64) -> Provenance {
        let mut h = Fnv::new();
        for q in &problem.points {
            q.iter().for_each(|x| h.write(&x.to_le_bytes()));
        }
        for r in &problem.reference {
            r.iter().for_each(|x| h.write(&x.to_le_bytes()));
        }
        let mut mh = Fnv::new();
        mh.write(problem.model.to_toml().as_bytes());
        Provenance {
            version: env!("CARGO_PKG_VERSION").to_string(),
            model: problem.model.name.clone(),
            model_hash: mh.hex(),
            reference: reference.to_string(),
            points: problem.n_points(),
            points_hash: h.hex(),
            seed: problem.seed,
            draws,
            first,
            end,
        }
    }
}

/// 64-bit FNV-1a: the fingerprints of a provenance.
pub(crate) struct Fnv(u64);

impl Fnv {
    pub(crate) fn new() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
    pub(crate) fn write(&mut self, bytes: &[u8]) {
        for b in bytes {
            self.0 = (self.0 ^ u64::from(*b)).wrapping_mul(0x0100_0000_01b3);
        }
    }
    /// The hash as 16 hex digits.
    pub(crate) fn hex(&self) -> String {
        format!("{:016x}", self.0)
    }
}

/// Count, mean and the central moment sums `M_k = Σ (x − mean)^k`, k = 2…4.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MomentSums {
    /// Number of values.
    pub n: u64,
    /// Mean.
    pub mean: f64,
    /// Σ (x − mean)².
    pub m2: f64,
    /// Σ (x − mean)³.
    pub m3: f64,
    /// Σ (x − mean)⁴.
    pub m4: f64,
}

impl MomentSums {
    /// The sums of `v` (two passes, so no cancellation).
    pub fn of(v: &[f64]) -> MomentSums {
        if v.is_empty() {
            return MomentSums::default();
        }
        let mean = match v.first().filter(|&&x| v.iter().all(|&y| y == x)) {
            Some(&x) => x,
            None => v.iter().sum::<f64>() / v.len() as f64,
        };
        let (mut m2, mut m3, mut m4) = (0.0, 0.0, 0.0);
        for x in v {
            let d = x - mean;
            let d2 = d * d;
            m2 += d2;
            m3 += d2 * d;
            m4 += d2 * d2;
        }
        MomentSums {
            n: v.len() as u64,
            mean,
            m2,
            m3,
            m4,
        }
    }

    /// The sums of the union of both sets (Chan et al. for M2, Pébay 2008 for M3 and M4).
    pub fn merge(&self, b: &MomentSums) -> MomentSums {
        let a = self;
        if a.n == 0 {
            return *b;
        }
        if b.n == 0 {
            return *a;
        }
        let (na, nb) = (a.n as f64, b.n as f64);
        let n = na + nb;
        let d = b.mean - a.mean;
        let d_n = d / n;
        let mean = if d == 0.0 { a.mean } else { a.mean + d_n * nb };
        let m2 = a.m2 + b.m2 + d * d_n * na * nb;
        let m3 =
            a.m3 + b.m3 + d * d_n * d_n * na * nb * (na - nb) + 3.0 * d_n * (na * b.m2 - nb * a.m2);
        let m4 = a.m4
            + b.m4
            + d * d_n * d_n * d_n * na * nb * (na * na - na * nb + nb * nb)
            + 6.0 * d_n * d_n * (na * na * b.m2 + nb * nb * a.m2)
            + 4.0 * d_n * (na * b.m3 - nb * a.m3);
        MomentSums {
            n: a.n + b.n,
            mean,
            m2,
            m3,
            m4,
        }
    }

    /// M1–M4 as [`Moments::of`] defines them (skewness and kurtosis undefined at zero spread).
    pub fn moments(&self) -> Moments {
        let n = self.n as f64;
        let (m2, m3, m4) = (self.m2 / n, self.m3 / n, self.m4 / n);
        let defined = |x: f64| (m2 > 0.0 && m2.is_finite() && x.is_finite()).then_some(x);
        Moments {
            mean: self.mean,
            variance: self.m2 / (n - 1.0),
            skewness: defined(m3 / m2.powf(1.5)),
            kurtosis: defined(m4 / (m2 * m2)),
        }
    }
}

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

/// Serde's view of [`IntervalKind`] for reading summaries.
#[derive(Serialize, Deserialize)]
#[serde(remote = "IntervalKind", rename_all = "lowercase")]
enum IntervalKindDef {
    Shortest,
    Symmetric,
}

/// The mergeable summary of draws `[first, end)` of a run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// Where the draws come from.
    pub provenance: Provenance,
    /// Coverage probability p.
    pub coverage_probability: f64,
    /// `"shortest"` or `"symmetric"`.
    #[serde(with = "IntervalKindDef")]
    pub interval: IntervalKind,
    /// Thresholds l_c, mm.
    pub thresholds: Vec<f64>,
    /// Whether per-point counts are kept.
    pub per_point: bool,
    /// Backend that evaluated the draws: backend, adapter, driver.
    pub backend: [String; 3],
    /// Evaluation chunks.
    pub chunks: u64,
    /// Draws per chunk.
    pub chunk: u64,
    /// Wall time of the evaluations, seconds (summed over merged summaries).
    pub seconds: f64,
    /// Smallest w, mm.
    pub min: f64,
    /// Largest w, mm.
    pub max: f64,
    /// Moment sums of all draws.
    pub sums: MomentSums,
    /// Moment sums of the parts of the [`GROUPS`] equal groups of the whole run this summary
    /// holds (group g: draws `[g·L, (g + 1)·L)`, L = ⌊draws/GROUPS⌋).
    pub groups: Vec<MomentSums>,
    /// Draws with w < l_c, per threshold.
    pub below: Vec<u64>,
    /// Draws with e_j < l_t at `[j · thresholds + t]`, with per-point counts.
    pub per_point_below: Vec<u64>,
    /// Occupied histogram bins: bin index → draws.
    pub bins: BTreeMap<u64, u64>,
}

impl Summary {
    fn empty(settings: &RunSettings, provenance: Provenance, m: usize, info: BackendInfo) -> Self {
        let t = settings.thresholds.len();
        Summary {
            provenance,
            coverage_probability: settings.coverage_probability,
            interval: settings.interval,
            thresholds: settings.thresholds.clone(),
            per_point: settings.per_point,
            backend: [info.backend, info.adapter, info.driver],
            chunks: 0,
            chunk: 0,
            seconds: 0.0,
            min: f64::INFINITY,
            max: f64::NEG_INFINITY,
            sums: MomentSums::default(),
            groups: vec![MomentSums::default(); GROUPS as usize],
            below: vec![0; t],
            per_point_below: vec![0; if settings.per_point { m * t } else { 0 }],
            bins: BTreeMap::new(),
        }
    }

    /// Adds draws `first..first + w.len()` (finite, non-negative).
    fn add(&mut self, first: u64, w: &[f64]) {
        self.sums = self.sums.merge(&MomentSums::of(w));
        let len = self.provenance.draws / GROUPS;
        if len > 0 {
            let mut k = first;
            while k < first + w.len() as u64 && k < len * GROUPS {
                let g = k / len;
                let stop = ((g + 1) * len).min(first + w.len() as u64);
                let part = &w[(k - first) as usize..(stop - first) as usize];
                self.groups[g as usize] = self.groups[g as usize].merge(&MomentSums::of(part));
                k = stop;
            }
        }
        for &v in w {
            self.min = self.min.min(v);
            self.max = self.max.max(v);
            *self.bins.entry(bin_of(v)).or_insert(0) += 1;
            for (c, l) in self.below.iter_mut().zip(&self.thresholds) {
                *c += u64::from(v < *l);
            }
        }
    }

    /// The summary as JSON.
    pub fn to_json(&self) -> String {
        // Plain data with finite floats: serialising cannot fail.
        serde_json::to_string(self).unwrap_or_default() + "\n"
    }

    /// Reads a summary written by [`Summary::to_json`]; `file` names it in errors.
    pub fn from_json(text: &str, file: &str) -> Result<Summary, SummaryError> {
        let corrupt = |message: String| SummaryError::Corrupt {
            file: file.to_string(),
            message,
        };
        let s: Summary = serde_json::from_str(text).map_err(|e| corrupt(e.to_string()))?;
        let p = &s.provenance;
        let t = s.thresholds.len();
        let binned: u64 = s.bins.values().sum();
        let checks = [
            (p.first < p.end && p.end <= p.draws, "provenance draw range"),
            (s.sums.n == p.end - p.first, "sums.n"),
            (binned == s.sums.n, "bins"),
            (s.groups.len() == GROUPS as usize, "groups"),
            (s.below.len() == t && t > 0, "below"),
            (s.below.iter().all(|&c| c <= s.sums.n), "below"),
            (
                s.per_point_below.len() == if s.per_point { p.points * t } else { 0 },
                "per_point_below",
            ),
            (
                s.min.is_finite() && s.max.is_finite() && s.min <= s.max && s.min >= 0.0,
                "min/max",
            ),
            (
                s.bins.first_key_value().map(|(&b, _)| b) == Some(bin_of(s.min))
                    && s.bins.last_key_value().map(|(&b, _)| b) == Some(bin_of(s.max)),
                "bins",
            ),
            (
                s.sums.mean.is_finite() && s.sums.m2 >= 0.0 && s.sums.m4 >= 0.0,
                "sums",
            ),
            (
                s.coverage_probability > 0.0 && s.coverage_probability < 1.0,
                "coverage_probability",
            ),
        ];
        if let Some((_, field)) = checks.iter().find(|(ok, _)| !ok) {
            return Err(corrupt(format!("field `{field}` is inconsistent")));
        }
        Ok(s)
    }

    /// Merges two summaries of the same run (the caller checks provenance and ranges).
    fn absorb(&mut self, b: &Summary) {
        self.sums = self.sums.merge(&b.sums);
        for (g, h) in self.groups.iter_mut().zip(&b.groups) {
            *g = g.merge(h);
        }
        self.min = self.min.min(b.min);
        self.max = self.max.max(b.max);
        self.chunks += b.chunks;
        self.seconds += b.seconds;
        for (c, d) in self.below.iter_mut().zip(&b.below) {
            *c += d;
        }
        for (c, d) in self.per_point_below.iter_mut().zip(&b.per_point_below) {
            *c += d;
        }
        for (k, c) in &b.bins {
            *self.bins.entry(*k).or_insert(0) += c;
        }
        self.provenance.first = self.provenance.first.min(b.provenance.first);
        self.provenance.end = self.provenance.end.max(b.provenance.end);
    }

    /// The value of each rank's bin: its centre, kept within [min, max].
    fn bin_value(&self, bin: u64) -> f64 {
        ((bin as f64 + 0.5) * BIN_WIDTH).clamp(self.min, self.max)
    }

    /// Bins in order with the rank of their last value (1-based, cumulative).
    fn cumulative(&self) -> Vec<(u64, u64)> {
        let mut cum = 0;
        self.bins
            .iter()
            .map(|(&b, &c)| {
                cum += c;
                (b, cum)
            })
            .collect()
    }

    /// The value of rank `k` (1-based): exact min and max at the ends, else the centre of its
    /// bin (within h/2 of the value).
    fn rank_value(&self, cum: &[(u64, u64)], k: u64) -> f64 {
        if k <= 1 {
            return self.min;
        }
        if k >= self.sums.n {
            return self.max;
        }
        let i = cum.partition_point(|&(_, c)| c < k);
        self.bin_value(cum[i].0)
    }

    /// The coverage interval of GUM S1 §7.7 (as [`coverage_interval`] picks its ranks) from
    /// the histogram: each end within h/2 of the sorted-values end of the same rank (see the
    /// module documentation for the shortest interval's bound).
    ///
    /// [`coverage_interval`]: super::stats::coverage_interval
    pub fn coverage_interval(&self) -> CoverageInterval {
        let m = self.sums.n;
        let p = self.coverage_probability;
        let q = ((p * m as f64 + 0.5).floor() as u64).clamp(1, m.saturating_sub(1).max(1));
        let cum = self.cumulative();
        if m < 2 {
            return CoverageInterval {
                low: self.min,
                high: self.min,
            };
        }
        let r = match self.interval {
            IntervalKind::Symmetric => (m - q).div_ceil(2).max(1),
            IntervalKind::Shortest => {
                let (mut best, mut width) = (1, f64::INFINITY);
                let mut consider = |r: u64| {
                    let w = self.rank_value(&cum, r + q) - self.rank_value(&cum, r);
                    if w < width {
                        width = w;
                        best = r;
                    }
                };
                consider(1);
                // Between the exact ends the width is constant while both ranks stay in their
                // bins: visit the first r of each such stretch.
                let (mut r, last) = (2, m - q - 1);
                while r <= last {
                    consider(r);
                    let i = cum.partition_point(|&(_, c)| c < r);
                    let j = cum.partition_point(|&(_, c)| c < r + q);
                    r = (cum[i].1 + 1).min(cum[j].1 + 1 - q);
                }
                if m - q >= 2 {
                    consider(m - q);
                }
                best
            }
        };
        CoverageInterval {
            low: self.rank_value(&cum, r),
            high: self.rank_value(&cum, r + q),
        }
    }

    /// [`CURVE_VALUES`] values at evenly spaced ranks, ascending: stand-ins for the sorted
    /// values in the PDF and CDF curves (CDF within 1/[`CURVE_VALUES`] and h).
    pub fn curve_values(&self) -> Vec<f64> {
        let cum = self.cumulative();
        let n = self.sums.n;
        let k = (CURVE_VALUES as u64).min(n);
        (0..k)
            .map(|i| self.rank_value(&cum, 1 + (i * (n - 1)) / (k - 1).max(1)))
            .collect()
    }

    /// The report of a complete summary (draws `[0, draws)`): every exact part as a single
    /// run gives it, the coverage interval from the histogram, and the PDF and CDF curves from
    /// [`Summary::curve_values`].
    pub fn to_result(&self) -> McResult {
        let n = self.sums.n;
        let moments = self.sums.moments();
        let reliability = self
            .below
            .iter()
            .zip(&self.thresholds)
            .map(|(&c, &l)| Reliability::from_count(l, c, n))
            .collect();
        let t = self.thresholds.len();
        let per_point_reliability = self.per_point.then(|| {
            self.per_point_below
                .chunks(t)
                .map(|c| {
                    c.iter()
                        .zip(&self.thresholds)
                        .map(|(&k, &l)| Reliability::from_count(l, k, n))
                        .collect()
                })
                .collect()
        });
        McResult {
            method: Method::Mcs,
            settings: RunSettings {
                coverage_probability: self.coverage_probability,
                interval: self.interval,
                thresholds: self.thresholds.clone(),
                per_point: self.per_point,
            },
            draws: n,
            batches: self.chunks as usize,
            batch_size: self.chunk,
            converged: true,
            numerical_tolerance: None,
            ndig: None,
            estimate: moments.mean,
            std_uncertainty: moments.std_dev(),
            coverage_interval: self.coverage_interval(),
            moments,
            moment_standard_errors: self.moment_standard_errors(),
            min: self.min,
            max: self.max,
            reliability,
            per_point_reliability,
            trace: Vec::new(),
            backend: BackendInfo {
                backend: self.backend[0].clone(),
                adapter: self.backend[1].clone(),
                driver: self.backend[2].clone(),
            },
            seconds: self.seconds,
            sorted_values: self.curve_values(),
        }
    }

    /// The batch-means standard errors of M1–M4 over the [`GROUPS`] groups, as an MCS run
    /// computes them (NaN, "not available", for a part of a run or when a group has fewer
    /// than 2 draws).
    pub fn moment_standard_errors(&self) -> [f64; 4] {
        let g = GROUPS as f64;
        let p = &self.provenance;
        let complete = p.first == 0 && p.end == p.draws;
        if !complete || p.draws / GROUPS < 2 || self.groups.iter().any(|s| s.n < 2) {
            return [f64::NAN; 4];
        }
        let per: Vec<[f64; 4]> = self.groups.iter().map(|s| s.moments().as_array()).collect();
        std::array::from_fn(|k| {
            let mean = per.iter().map(|p| p[k]).sum::<f64>() / g;
            let var = per.iter().map(|p| (p[k] - mean).powi(2)).sum::<f64>() / (g - 1.0);
            (var / g).sqrt()
        })
    }

    /// The note a report from this summary carries.
    pub fn note(&self) -> String {
        let p = &self.provenance;
        let part = if p.first == 0 && p.end == p.draws {
            ""
        } else {
            "; a part of the run, so the standard errors of M1–M4 (batch means over the whole \
             run) are not available"
        };
        format!(
            "summary of draws [{}, {}): coverage interval from a histogram of bin width \
             h = {BIN_WIDTH:e} mm (symmetric: each end within h/2 of the sorted values'; shortest: \
             width within 2h of the shortest, ends may move where widths tie within h); PDF and CDF \
             curves from {} histogram quantiles; moments, R(l_c) and min/max exact{part}",
            p.first,
            p.end,
            self.curve_values_len()
        )
    }

    fn curve_values_len(&self) -> u64 {
        (CURVE_VALUES as u64).min(self.sums.n)
    }
}

/// Evaluates draws `[first, end)` on `ev` in chunks of `chunk` and summarises them without
/// keeping the values (memory: one chunk and the occupied bins, at most `max_bins` of them, else
/// [`SummaryError::Histogram`]). `provenance` gives the run; its range is set to `[first, end)`.
#[allow(clippy::too_many_arguments)]
pub fn summarize(
    ev: &mut dyn Evaluator,
    first: u64,
    end: u64,
    chunk: u64,
    max_bins: u64,
    settings: &RunSettings,
    mut provenance: Provenance,
    progress: Option<Progress>,
) -> Result<Summary, SummaryError> {
    settings.check()?;
    if chunk == 0 {
        return Err(McError::Setting {
            field: Setting::Chunk,
            message: "must be positive".into(),
        }
        .into());
    }
    if first >= end || end > provenance.draws {
        return Err(McError::Setting {
            field: Setting::Draws,
            message: format!(
                "the draw range [{first}, {end}) must be non-empty and within the {} draws",
                provenance.draws
            ),
        }
        .into());
    }
    let start = std::time::Instant::now();
    provenance.first = first;
    provenance.end = end;
    let m = ev.n_points();
    let mut s = Summary::empty(settings, provenance, m, ev.info());
    s.chunk = chunk;
    let mut w = Vec::new();
    let mut pp = Vec::new();
    let t = settings.thresholds.len();
    let mut k = first;
    while k < end {
        let n = chunk.min(end - k) as usize;
        w.resize(n, 0.0);
        if settings.per_point {
            pp.resize(n * m, 0.0);
            ev.evaluate(k, &mut w, Some(&mut pp))
                .map_err(McError::from)?;
            for row in pp.chunks(m) {
                for (j, e) in row.iter().enumerate() {
                    for (ti, l) in settings.thresholds.iter().enumerate() {
                        s.per_point_below[j * t + ti] += u64::from(*e < *l);
                    }
                }
            }
        } else {
            ev.evaluate(k, &mut w, None).map_err(McError::from)?;
        }
        if let Some((i, v)) = w
            .iter()
            .enumerate()
            .find(|(_, v)| !v.is_finite() || **v < 0.0)
        {
            return Err(McError::NonFinite {
                draw: k + i as u64,
                value: *v,
            }
            .into());
        }
        s.add(k, &w);
        if s.bins.len() as u64 > max_bins {
            return Err(SummaryError::Histogram {
                max_bins,
                min: s.min,
                max: s.max,
            });
        }
        s.chunks += 1;
        k += n as u64;
        if let Some(cb) = progress {
            cb(k - first, end - first);
        }
    }
    s.seconds = start.elapsed().as_secs_f64();
    Ok(s)
}

/// Merges named summaries of one run: they must agree on provenance (apart from the range) and
/// settings, and their ranges must cover `[0, draws)` exactly once. The result does not depend
/// on the order given (summaries are merged in draw order).
pub fn merge(named: &[(String, Summary)]) -> Result<Summary, SummaryError> {
    let order = in_draw_order(named, |s| &s.provenance, settings_of)?;
    let mut out = order[0].1.clone();
    for (_, s) in &order[1..] {
        out.absorb(s);
    }
    Ok(out)
}

/// The settings a summary's merge partners must share, by field.
fn settings_of(s: &Summary) -> Vec<(&'static str, String)> {
    vec![
        ("coverage_probability", s.coverage_probability.to_string()),
        ("interval", format!("{:?}", s.interval)),
        (
            "thresholds",
            format!("{:?}, per_point {}", s.thresholds, s.per_point),
        ),
    ]
}

/// `named` in draw order, after checking that they are parts of one run: provenance (apart
/// from the range) and `settings` agree with the first's, and the ranges tile `[0, draws)`.
fn in_draw_order<T>(
    named: &[(String, T)],
    provenance: impl Fn(&T) -> &Provenance,
    settings: impl Fn(&T) -> Vec<(&'static str, String)>,
) -> Result<Vec<(&str, &T)>, SummaryError> {
    in_range_order(
        named,
        "draws",
        |s| {
            let p = provenance(s);
            (p.first, p.end, p.draws)
        },
        |s| {
            let mut v = provenance_fields(provenance(s));
            v.extend(settings(s));
            v
        },
    )
}

/// The fields of a provenance that every part of one run shares, by name (all but the range).
pub(crate) fn provenance_fields(p: &Provenance) -> Vec<(&'static str, String)> {
    vec![
        ("version", p.version.clone()),
        ("model", p.model.clone()),
        ("model_hash", p.model_hash.clone()),
        ("reference", p.reference.clone()),
        ("points", p.points.to_string()),
        ("points_hash", p.points_hash.clone()),
        ("seed", p.seed.to_string()),
        ("draws", p.draws.to_string()),
    ]
}

/// `named` in the order of their ranges, after checking that they are parts of one run:
/// `fields` agree with the first's, and the ranges (`range` gives first, end and the total, in
/// `unit`s) tile `[0, total)`.
pub(crate) fn in_range_order<'a, T>(
    named: &'a [(String, T)],
    unit: &'static str,
    range: impl Fn(&T) -> (u64, u64, u64),
    fields: impl Fn(&T) -> Vec<(&'static str, String)>,
) -> Result<Vec<(&'a str, &'a T)>, SummaryError> {
    let mut order: Vec<(&str, &T)> = named.iter().map(|(f, s)| (f.as_str(), s)).collect();
    order.sort_by_key(|(_, s)| {
        let (a, b, _) = range(s);
        (a, b)
    });
    let Some(&(first_file, first)) = order.first() else {
        return Err(SummaryError::Empty);
    };
    let expected = fields(first);
    let mut covered = 0;
    for &(file, s) in &order {
        let mismatch = expected.iter().zip(fields(s)).find(|(x, y)| x.1 != y.1);
        if let Some(((field, want), (_, found))) = mismatch {
            return Err(SummaryError::Mismatch {
                file: file.to_string(),
                field,
                found,
                first_file: first_file.to_string(),
                expected: want.clone(),
            });
        }
        let (a, b, _) = range(s);
        if a != covered {
            let problem = if a < covered {
                format!("overlap {unit} before {covered} of another summary")
            } else {
                format!("leave {unit} [{covered}, {a}) missing")
            };
            return Err(SummaryError::Range {
                file: file.to_string(),
                unit,
                first: a,
                end: b,
                problem,
            });
        }
        covered = b;
    }
    let (_, _, total) = range(first);
    if covered != total {
        let (file, s) = order[order.len() - 1];
        let (a, b, _) = range(s);
        return Err(SummaryError::Range {
            file: file.to_string(),
            unit,
            first: a,
            end: b,
            problem: format!("leave {unit} [{covered}, {total}) missing"),
        });
    }
    Ok(order)
}

/// A shard of a sensitivity analysis (`docs/METHOD.md §11`): the model outputs of base samples
/// `[first, end)` (the provenance's range; its `draws` are the base samples N). The bootstrap
/// resamples base samples from the whole range, so shards keep their outputs (8 bytes ×
/// (2 + S) a base sample) and the merge analyses them together, exactly as one run would.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SensitivityShard {
    /// Always [`SensitivityShard::KIND`]: tells a sensitivity shard from a run summary.
    pub kind: String,
    /// Where the base samples come from.
    pub provenance: Provenance,
    /// Bootstrap resamples of the analysis.
    pub bootstrap: usize,
    /// Seed of the bootstrap resampling.
    pub bootstrap_seed: u64,
    /// Thresholds of the exceedance indicators, mm.
    pub thresholds: Vec<f64>,
    /// The inputs.
    pub design: Design,
    /// Backend that evaluated the outputs: backend, adapter, driver.
    pub backend: [String; 3],
    /// The outputs of the shard's base samples, written as the bits of each f64 (a JSON
    /// number need not read back to the same f64; the bits do, so the merge is exact).
    #[serde(with = "output_bits")]
    pub outputs: Outputs,
}

/// [`Outputs`] as the IEEE-754 bits of its values.
mod output_bits {
    use super::Outputs;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    #[derive(Serialize, Deserialize)]
    struct Bits {
        a: Vec<u64>,
        b: Vec<u64>,
        sets: Vec<Vec<u64>>,
    }

    fn to_bits(v: &[f64]) -> Vec<u64> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    fn from_bits(v: Vec<u64>) -> Vec<f64> {
        v.into_iter().map(f64::from_bits).collect()
    }

    pub fn serialize<S: Serializer>(o: &Outputs, s: S) -> Result<S::Ok, S::Error> {
        Bits {
            a: to_bits(&o.a),
            b: to_bits(&o.b),
            sets: o.sets.iter().map(|v| to_bits(v)).collect(),
        }
        .serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Outputs, D::Error> {
        let b = Bits::deserialize(d)?;
        Ok(Outputs {
            a: from_bits(b.a),
            b: from_bits(b.b),
            sets: b.sets.into_iter().map(from_bits).collect(),
        })
    }
}

impl SensitivityShard {
    /// The `kind` of a sensitivity shard.
    pub const KIND: &'static str = "sensitivity shard";

    /// Evaluates base samples `[provenance.first, provenance.end)` of the analysis of
    /// `problem` with `opts` (`opts.draws` the provenance's draws).
    pub fn run(
        problem: &Problem,
        ev: &mut dyn Evaluator,
        opts: &SensitivityOptions,
        provenance: Provenance,
    ) -> Result<SensitivityShard, SensitivityError> {
        let range = provenance.first as usize..provenance.end as usize;
        let (outputs, design) = sensitivity::run_outputs(problem, ev, opts, range)?;
        let info = ev.info();
        Ok(SensitivityShard {
            kind: Self::KIND.to_string(),
            provenance,
            bootstrap: opts.bootstrap,
            bootstrap_seed: opts.bootstrap_seed,
            thresholds: opts.thresholds.clone(),
            design,
            backend: [info.backend, info.adapter, info.driver],
            outputs,
        })
    }

    /// The shard as JSON (`kind` first, so a reader can tell it from a summary).
    pub fn to_json(&self) -> String {
        // Plain data with finite floats: serialising cannot fail.
        serde_json::to_string(self).unwrap_or_default() + "\n"
    }

    /// Reads a shard written by [`SensitivityShard::to_json`]; `file` names it in errors.
    pub fn from_json(text: &str, file: &str) -> Result<SensitivityShard, SummaryError> {
        let corrupt = |message: String| SummaryError::Corrupt {
            file: file.to_string(),
            message,
        };
        let s: SensitivityShard = serde_json::from_str(text).map_err(|e| corrupt(e.to_string()))?;
        let p = &s.provenance;
        let n = (p.end - p.first) as usize;
        let o = &s.outputs;
        let checks = [
            (s.kind == Self::KIND, "kind"),
            (p.first < p.end && p.end <= p.draws, "provenance draw range"),
            (o.a.len() == n && o.b.len() == n, "outputs"),
            (o.sets.iter().all(|v| v.len() == n), "outputs"),
            (
                o.a.iter()
                    .chain(&o.b)
                    .chain(o.sets.iter().flatten())
                    .all(|v| v.is_finite()),
                "outputs",
            ),
        ];
        if let Some((_, field)) = checks.iter().find(|(ok, _)| !ok) {
            return Err(corrupt(format!("field `{field}` is inconsistent")));
        }
        Ok(s)
    }
}

/// Errors of merging sensitivity shards: the shards' own, or the analysis's.
#[derive(Debug, thiserror::Error)]
pub enum SensitivityMergeError {
    /// The shards do not make one analysis.
    #[error(transparent)]
    Shards(#[from] SummaryError),
    /// The analysis of the merged outputs failed.
    #[error(transparent)]
    Analysis(#[from] SensitivityError),
}

/// The analysis of named sensitivity shards that together hold every base sample of one run
/// once (checked as [`merge`] checks summaries): the same result as one run, to the bit.
pub fn merge_sensitivity(
    named: &[(String, SensitivityShard)],
) -> Result<SensitivityResult, SensitivityMergeError> {
    let order = in_draw_order(
        named,
        |s| &s.provenance,
        |s| {
            vec![
                ("bootstrap", s.bootstrap.to_string()),
                ("bootstrap_seed", s.bootstrap_seed.to_string()),
                ("thresholds", format!("{:?}", s.thresholds)),
                ("design", format!("{:?}", s.design)),
                (
                    "outputs",
                    format!("{} pick-freeze sets", s.outputs.sets.len()),
                ),
            ]
        },
    )?;
    let first = order[0].1;
    let mut out = Outputs {
        sets: vec![Vec::new(); first.outputs.sets.len()],
        ..Outputs::default()
    };
    for (_, s) in &order {
        out.a.extend_from_slice(&s.outputs.a);
        out.b.extend_from_slice(&s.outputs.b);
        for (all, part) in out.sets.iter_mut().zip(&s.outputs.sets) {
            all.extend_from_slice(part);
        }
    }
    let p = &first.provenance;
    let opts = SensitivityOptions {
        draws: p.draws as usize,
        bootstrap: first.bootstrap,
        bootstrap_seed: first.bootstrap_seed,
        thresholds: first.thresholds.clone(),
        ..SensitivityOptions::default()
    };
    let [backend, adapter, driver] = first.backend.clone();
    let info = BackendInfo {
        backend,
        adapter,
        driver,
    };
    let model = (p.model.clone(), p.points, p.seed);
    Ok(first.design.result(model, info, &out, &opts)?)
}
