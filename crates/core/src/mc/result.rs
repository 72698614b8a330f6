//! The result of a Monte Carlo run and the machinery both drivers share: evaluating one batch,
//! accumulating the values and the single-point counts, and summarising at the end.

use super::stats::{
    coverage_interval, moment_standard_errors, CoverageInterval, IntervalKind, Moments, Reliability,
};
use crate::engine::{BackendInfo, EngineError, Evaluator};
use rayon::slice::ParallelSliceMut;
use serde::Serialize;

/// MCS or AMCS.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Fixed number of draws.
    Mcs,
    /// Adaptive (GUM S1 §7.9).
    Amcs,
}

/// Settings shared by both drivers.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RunSettings {
    /// Coverage probability p.
    pub coverage_probability: f64,
    /// Shortest or symmetric interval.
    pub interval: IntervalKind,
    /// Thresholds l_c (mm) at which the reliability is reported.
    pub thresholds: Vec<f64>,
    /// Also compute single-point reliabilities R_j.
    pub per_point: bool,
}

/// The thresholds `l_c` (mm) a run reports R(l_c) at when none are given: 0.1 to 0.8 mm in
/// steps of 0.1 mm (the paper's Table 2 range). Every front end takes its default from here.
pub const DEFAULT_THRESHOLDS_MM: [f64; 8] = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8];

impl Default for RunSettings {
    fn default() -> Self {
        RunSettings {
            coverage_probability: 0.95,
            interval: IntervalKind::Shortest,
            thresholds: DEFAULT_THRESHOLDS_MM.to_vec(),
            per_point: false,
        }
    }
}

impl RunSettings {
    /// Checks p and the thresholds.
    ///
    /// # Errors
    ///
    /// [`McError::Setting`] for a coverage probability outside (0, 1), no thresholds, or a
    /// threshold that is not a positive number of mm.
    pub fn check(&self) -> Result<(), McError> {
        let p = self.coverage_probability;
        if !(p > 0.0 && p < 1.0) {
            return Err(McError::Setting {
                field: Setting::CoverageProbability,
                message: format!("must lie in (0, 1), got {p}"),
            });
        }
        if self.thresholds.is_empty() {
            return Err(McError::Setting {
                field: Setting::Thresholds,
                message: "at least one is needed".into(),
            });
        }
        if let Some(t) = self
            .thresholds
            .iter()
            .find(|t| !t.is_finite() || **t <= 0.0)
        {
            return Err(McError::Setting {
                field: Setting::Thresholds,
                message: format!("each must be a positive number of mm, got {t}"),
            });
        }
        Ok(())
    }
}

/// The smallest number of draws GUM S1 §7.9.2 asks for at coverage probability `p`:
/// `⌈100/(1 − p)⌉`, where a quotient within rounding of an integer counts as that integer (so
/// p = 0.9999 gives 10^6, not 10^6 + 1). Saturates at `u64::MAX` as p approaches 1.
pub fn min_draws(p: f64) -> u64 {
    let x = 100.0 / (1.0 - p);
    let r = x.round();
    if (x - r).abs() <= 1e-9 * r.abs().max(1.0) {
        r as u64
    } else {
        x.ceil() as u64
    }
}

/// The settings a driver checks, named in its errors ([`McError::Setting`]); a front end maps
/// each to its own option name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Setting {
    /// [`RunSettings::coverage_probability`].
    CoverageProbability,
    /// [`RunSettings::thresholds`].
    Thresholds,
    /// The AMCS numerical tolerance δ.
    Tolerance,
    /// The AMCS significant digits.
    SignificantDigits,
    /// The AMCS batch size H.
    BatchSize,
    /// The AMCS draw cap.
    MaxDraws,
    /// The MCS number of draws.
    Draws,
    /// The MCS evaluation chunk.
    Chunk,
}

impl Setting {
    /// Every setting.
    pub const ALL: [Setting; 8] = [
        Self::CoverageProbability,
        Self::Thresholds,
        Self::Tolerance,
        Self::SignificantDigits,
        Self::BatchSize,
        Self::MaxDraws,
        Self::Draws,
        Self::Chunk,
    ];
}

impl std::fmt::Display for Setting {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Setting::CoverageProbability => "coverage probability",
            Setting::Thresholds => "thresholds",
            Setting::Tolerance => "numerical tolerance",
            Setting::SignificantDigits => "significant digits",
            Setting::BatchSize => "batch size",
            Setting::MaxDraws => "draw cap",
            Setting::Draws => "number of draws",
            Setting::Chunk => "chunk size",
        })
    }
}

/// Errors of the drivers.
#[derive(Debug, thiserror::Error)]
pub enum McError {
    /// A setting is out of range; names the setting.
    #[error("{field}: {message}")]
    Setting {
        /// The setting.
        field: Setting,
        /// What is wrong.
        message: String,
    },
    /// The evaluator failed.
    #[error(transparent)]
    Engine(#[from] EngineError),
    /// The evaluator produced a value that is not finite.
    #[error("draw {draw} gave a non-finite maximum point error ({value}): check the model")]
    NonFinite {
        /// Draw index.
        draw: u64,
        /// The value.
        value: f64,
    },
}

/// One AMCS batch (GUM S1 §7.9.4): its own estimates and, from h ≥ 2, the standard deviations
/// of the batch estimates about their mean (eq. 21); the rule compares `2s` with δ.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BatchTrace {
    /// Batch number h (1-based).
    pub h: usize,
    /// Draws so far (h·H).
    pub draws: u64,
    /// Mean of this batch, mm.
    pub mean: f64,
    /// Standard deviation of this batch, mm.
    pub std_uncertainty: f64,
    /// Coverage interval of this batch.
    pub low: f64,
    /// Coverage interval of this batch.
    pub high: f64,
    /// `[2s_w, 2s_u(w), 2s_wlow, 2s_whigh]` after this batch (NaN for h = 1), mm.
    pub fluctuation: [f64; 4],
    /// The numerical tolerance δ in force after this batch, mm.
    pub delta: f64,
}

/// Progress callback: `(draws done, draws planned or the cap)`.
pub type Progress<'a> = &'a (dyn Fn(u64, u64) + Sync);

/// Everything a run reports.
#[derive(Clone, Debug, Serialize)]
pub struct McResult {
    /// MCS or AMCS.
    pub method: Method,
    /// Settings used.
    pub settings: RunSettings,
    /// Total draws.
    pub draws: u64,
    /// Batches of H (AMCS) or evaluation chunks (MCS).
    pub batches: usize,
    /// Batch size H.
    pub batch_size: u64,
    /// AMCS: whether the stopping rule was met (MCS: always true).
    pub converged: bool,
    /// AMCS: final numerical tolerance δ, mm.
    pub numerical_tolerance: Option<f64>,
    /// AMCS with `--ndig`: the significant digits δ was derived from (GUM S1 §7.9.2).
    pub ndig: Option<u32>,
    /// Estimate of w (the mean), mm.
    pub estimate: f64,
    /// Standard uncertainty u(w) (sample standard deviation), mm.
    pub std_uncertainty: f64,
    /// The coverage interval of all draws.
    pub coverage_interval: CoverageInterval,
    /// M1–M4.
    pub moments: Moments,
    /// Monte Carlo standard errors of M1–M4 (batch means over 20 groups).
    pub moment_standard_errors: [f64; 4],
    /// Smallest and largest w, mm.
    pub min: f64,
    /// Largest w, mm.
    pub max: f64,
    /// `R(l_c) = Pr[w < l_c]` per threshold.
    pub reliability: Vec<Reliability>,
    /// Single-point reliabilities: `per_point_reliability[j][t]` = `Pr[e_j < l_t]`.
    pub per_point_reliability: Option<Vec<Vec<Reliability>>>,
    /// AMCS per-batch trace (empty for MCS).
    pub trace: Vec<BatchTrace>,
    /// Backend that evaluated the draws.
    pub backend: BackendInfo,
    /// Wall time of the run, seconds.
    pub seconds: f64,
    /// All w values, ascending (not serialised; for curves and plots).
    #[serde(skip)]
    pub sorted_values: Vec<f64>,
}

/// Accumulates batches.
pub(crate) struct Accumulator<'e> {
    pub eval: &'e mut dyn Evaluator,
    pub settings: RunSettings,
    pub values: Vec<f64>,
    pub counts: Vec<u64>,
    per_point_buf: Vec<f64>,
    pub batches: usize,
    start: std::time::Instant,
}

impl<'e> Accumulator<'e> {
    /// An empty accumulator of the draws of `eval` under `settings`, room for `capacity` values.
    ///
    /// # Errors
    ///
    /// [`McError::Setting`] when `settings` are out of range ([`RunSettings::check`]).
    pub fn new(
        eval: &'e mut dyn Evaluator,
        settings: RunSettings,
        capacity: u64,
    ) -> Result<Self, McError> {
        settings.check()?;
        let m = eval.n_points();
        let counts = vec![
            0;
            if settings.per_point {
                m * settings.thresholds.len()
            } else {
                0
            }
        ];
        let values = Vec::with_capacity(capacity.min(1 << 28) as usize);
        Ok(Accumulator {
            eval,
            settings,
            values,
            counts,
            per_point_buf: Vec::new(),
            batches: 0,
            start: std::time::Instant::now(),
        })
    }

    /// Evaluates draws `[len, len + n)` and appends them; returns the new slice.
    ///
    /// # Errors
    ///
    /// [`McError::Engine`] when the evaluator fails, [`McError::NonFinite`] when a value is not
    /// finite.
    pub fn add_batch(&mut self, n: usize) -> Result<&[f64], McError> {
        let first = self.values.len() as u64;
        let old = self.values.len();
        self.values.resize(old + n, 0.0);
        let m = self.eval.n_points();
        let out = &mut self.values[old..];
        if self.settings.per_point {
            self.per_point_buf.resize(n * m, 0.0);
            self.eval
                .evaluate(first, out, Some(&mut self.per_point_buf))?;
            let t = &self.settings.thresholds;
            for row in self.per_point_buf.chunks(m) {
                for (j, e) in row.iter().enumerate() {
                    for (ti, l) in t.iter().enumerate() {
                        self.counts[j * t.len() + ti] += u64::from(*e < *l);
                    }
                }
            }
        } else {
            self.eval.evaluate(first, out, None)?;
        }
        if let Some((i, v)) = out.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(McError::NonFinite {
                draw: first + i as u64,
                value: *v,
            });
        }
        self.batches += 1;
        Ok(&self.values[old..])
    }

    /// Summarises all values.
    pub fn finish(
        self,
        method: Method,
        batch_size: u64,
        converged: bool,
        tolerance: Option<f64>,
        trace: Vec<BatchTrace>,
    ) -> McResult {
        let mut values = self.values;
        let moments = Moments::of(&values);
        let moment_standard_errors = moment_standard_errors(&values, 20);
        // In parallel: 10^8 values took 4 s on one core of a 16-core host. The order is total, so
        // the sorted values are the same bits whatever the thread count.
        values.par_sort_unstable_by(f64::total_cmp);
        let p = self.settings.coverage_probability;
        let n = values.len() as u64;
        let reliability = self
            .settings
            .thresholds
            .iter()
            .map(|&t| Reliability::from_sorted(t, &values))
            .collect();
        let per_point_reliability = self.settings.per_point.then(|| {
            let t = &self.settings.thresholds;
            self.counts
                .chunks(t.len())
                .map(|c| {
                    c.iter()
                        .zip(t)
                        .map(|(&k, &l)| Reliability::from_count(l, k, n))
                        .collect()
                })
                .collect()
        });
        McResult {
            method,
            draws: n,
            batches: self.batches,
            batch_size,
            converged,
            numerical_tolerance: tolerance,
            ndig: None,
            estimate: moments.mean,
            std_uncertainty: moments.std_dev(),
            coverage_interval: coverage_interval(&values, p, self.settings.interval),
            moments,
            moment_standard_errors,
            min: values[0],
            max: values[values.len() - 1],
            reliability,
            per_point_reliability,
            trace,
            backend: self.eval.info(),
            seconds: self.start.elapsed().as_secs_f64(),
            settings: self.settings,
            sorted_values: values,
        }
    }
}

/// The interval kind's batch estimate helper: mean, u, low, high of one batch.
pub(crate) fn batch_estimates(batch: &[f64], p: f64, kind: IntervalKind) -> [f64; 4] {
    let m = Moments::of(batch);
    let mut sorted = batch.to_vec();
    sorted.sort_unstable_by(f64::total_cmp);
    let ci = coverage_interval(&sorted, p, kind);
    [m.mean, m.std_dev(), ci.low, ci.high]
}
