//! The mergeable summary of the draws of an MCS run ([`Summary`]): built from draw ranges by
//! [`summarize`], merged by [`merge`], reported by [`Summary::to_result`] (see the module docs of
//! `crate::mc::summary` for what is exact and what comes from the histogram).

mod tally;

use super::moments::MomentSums;
use super::provenance::{in_draw_order, Provenance};
use super::{SummaryError, BIN_WIDTH, CURVE_VALUES, GROUPS};
use crate::engine::{BackendInfo, Evaluator};
use crate::mc::result::{McError, McResult, Method, Progress, RunSettings, Setting};
use crate::mc::stats::{CoverageInterval, IntervalKind, Reliability};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use tally::{BinTally, PIECE};

/// The histogram bin of `w` (non-negative).
fn bin_of(w: f64) -> u64 {
    (w / BIN_WIDTH) as u64
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

    /// Adds draws `first..first + w.len()` (finite, non-negative), their histogram counts to
    /// `tally`. The work is split into pieces of at most [`PIECE`] draws that never straddle a
    /// group boundary, done in parallel and combined in draw order: the same bits with any
    /// number of threads.
    fn add(&mut self, first: u64, w: &[f64], tally: &mut BinTally) {
        if w.is_empty() {
            return;
        }
        let end = first + w.len() as u64;
        let len = self.provenance.draws / GROUPS;
        let grouped_end = len * GROUPS;
        let mut parts = Vec::with_capacity(w.len() / PIECE + GROUPS as usize + 1);
        let mut k = first;
        while k < end {
            let mut stop = (k + PIECE as u64).min(end);
            if k < grouped_end {
                stop = stop.min((k / len + 1) * len);
            }
            parts.push((k, stop));
            k = stop;
        }
        let thresholds = &self.thresholds;
        let stats: Vec<(MomentSums, f64, f64, Vec<u64>)> = parts
            .par_iter()
            .map(|&(a, b)| {
                let v = &w[(a - first) as usize..(b - first) as usize];
                let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
                for &x in v {
                    lo = lo.min(x);
                    hi = hi.max(x);
                }
                let below = thresholds
                    .iter()
                    .map(|l| v.iter().filter(|&&x| x < *l).count() as u64)
                    .collect();
                (MomentSums::of(v), lo, hi, below)
            })
            .collect();
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for (&(a, _), (sums, l, h, below)) in parts.iter().zip(&stats) {
            if a < grouped_end {
                let g = (a / len) as usize;
                self.groups[g] = self.groups[g].merge(sums);
            }
            self.sums = self.sums.merge(sums);
            lo = lo.min(*l);
            hi = hi.max(*h);
            for (c, d) in self.below.iter_mut().zip(below) {
                *c += d;
            }
        }
        self.min = self.min.min(lo);
        self.max = self.max.max(hi);
        tally.add(w, (lo, hi), &mut self.bins);
    }

    /// The summary as JSON.
    pub fn to_json(&self) -> String {
        // Plain data with finite floats: serialising cannot fail.
        super::checksum::seal(&serde_json::to_string(self).unwrap_or_default())
    }

    /// Reads a summary written by [`Summary::to_json`]; `file` names it in errors.
    ///
    /// # Errors
    ///
    /// [`SummaryError::Corrupt`] when `text` is not the JSON of a summary, or its fields are
    /// inconsistent (draw range, counts, bins, groups, min/max, moment sums, coverage probability);
    /// the message names the field.
    pub fn from_json(text: &str, file: &str) -> Result<Summary, SummaryError> {
        let corrupt = |message: String| SummaryError::Corrupt {
            file: file.to_string(),
            message,
        };
        let text = super::checksum::verify(text, file)?;
        let s: Summary = serde_json::from_str(&text).map_err(|e| corrupt(e.to_string()))?;
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
    /// [`coverage_interval`]: crate::mc::stats::coverage_interval
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
///
/// # Errors
///
/// [`SummaryError::Mc`] for settings out of range ([`RunSettings::check`]), a chunk of 0, an empty
/// draw range or one beyond the provenance's draws, a failing evaluator, or a draw whose `w` is not
/// finite or negative; [`SummaryError::Histogram`] when the histogram needs more than `max_bins`
/// bins.
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
    check_request(settings, first, end, chunk, provenance.draws)?;
    let start = std::time::Instant::now();
    provenance.first = first;
    provenance.end = end;
    let m = ev.n_points();
    let mut s = Summary::empty(settings, provenance, m, ev.info());
    s.chunk = chunk;
    let mut w = Vec::new();
    let mut pp = Vec::new();
    let mut tally = BinTally::new(max_bins);
    let mut k = first;
    while k < end {
        let n = chunk.min(end - k) as usize;
        w.resize(n, 0.0);
        evaluate_chunk(ev, k, &mut w, &mut pp, m, settings, &mut s.per_point_below)?;
        s.add(k, &w, &mut tally);
        if tally.occupied(&s.bins) > max_bins {
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
    tally.flush(&mut s.bins);
    s.seconds = start.elapsed().as_secs_f64();
    Ok(s)
}

/// Checks the request of [`summarize`]: the settings, a positive chunk and a non-empty draw
/// range `[first, end)` within the run's `draws`.
fn check_request(
    settings: &RunSettings,
    first: u64,
    end: u64,
    chunk: u64,
    draws: u64,
) -> Result<(), SummaryError> {
    settings.check()?;
    if chunk == 0 {
        return Err(McError::Setting {
            field: Setting::Chunk,
            message: "must be positive".into(),
        }
        .into());
    }
    if first >= end || end > draws {
        return Err(McError::Setting {
            field: Setting::Draws,
            message: format!(
                "the draw range [{first}, {end}) must be non-empty and within the {draws} draws"
            ),
        }
        .into());
    }
    Ok(())
}

/// Evaluates draws `[k, k + w.len())` of `ev` (`m` test points) into `w`, adding their
/// per-point counts below each threshold to `per_point_below` when `settings` keeps them
/// (`pp` holds the per-point errors).
///
/// # Errors
///
/// [`SummaryError::Mc`] for a failing evaluator or a draw whose `w` is not finite or negative.
fn evaluate_chunk(
    ev: &mut dyn Evaluator,
    k: u64,
    w: &mut [f64],
    pp: &mut Vec<f64>,
    m: usize,
    settings: &RunSettings,
    per_point_below: &mut [u64],
) -> Result<(), SummaryError> {
    let n = w.len();
    let t = settings.thresholds.len();
    if settings.per_point {
        pp.resize(n * m, 0.0);
        ev.evaluate(k, w, Some(pp.as_mut_slice()))
            .map_err(McError::from)?;
        for row in pp.chunks(m) {
            for (j, e) in row.iter().enumerate() {
                for (ti, l) in settings.thresholds.iter().enumerate() {
                    per_point_below[j * t + ti] += u64::from(*e < *l);
                }
            }
        }
    } else {
        ev.evaluate(k, w, None).map_err(McError::from)?;
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
    Ok(())
}

/// Merges named summaries of one run: they must agree on provenance (apart from the range) and
/// settings, and their ranges must cover `[0, draws)` exactly once. The result does not depend
/// on the order given (summaries are merged in draw order).
///
/// # Errors
///
/// [`SummaryError::Empty`] for no summaries, [`SummaryError::Mismatch`] naming the first field (of
/// the provenance or the settings) on which a summary differs from the first, and
/// [`SummaryError::Range`] when the draw ranges overlap or leave draws of `[0, draws)` missing.
pub fn merge(named: &[(String, Summary)]) -> Result<Summary, SummaryError> {
    let order = in_draw_order(named, |s| &s.provenance, settings_of)?;
    let mut out = order[0].1.clone();
    for (_, s) in &order[1..] {
        out.absorb(s);
    }
    out.backend = super::merged_backend(order.iter().map(|(_, s)| &s.backend));
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
