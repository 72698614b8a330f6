//! Statistics of Monte Carlo output: moments, coverage intervals (GUM S1 §7.7), reliability with
//! a binomial confidence interval, the empirical CDF and a histogram (the PDF estimate).

use serde::{Deserialize, Serialize};

/// How the coverage interval is chosen (GUM S1 §7.7).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum IntervalKind {
    /// The shortest interval containing `q` of the `M` sorted values (§7.7.2).
    Shortest,
    /// Probabilistically symmetric: equal tail fractions (§7.7.1).
    Symmetric,
}

/// A coverage interval `[low, high]`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct CoverageInterval {
    /// Lower end, mm.
    pub low: f64,
    /// Upper end, mm.
    pub high: f64,
}

/// The 100p % coverage interval of ascending `sorted` values: `q = ⌊pM + ½⌋` values are
/// covered, `low = y_(r)`, `high = y_(r+q)` (1-based order statistics) with `r` minimising
/// `high − low` over `r = 1…M−q` (shortest), or `r = ⌊(M − q + 1)/2⌋` (symmetric).
///
/// `sorted` must be non-empty and ascending; `0 < p < 1`.
pub fn coverage_interval(sorted: &[f64], p: f64, kind: IntervalKind) -> CoverageInterval {
    let m = sorted.len();
    let q = ((p * m as f64 + 0.5).floor() as usize).clamp(1, m.saturating_sub(1).max(1));
    if m < 2 {
        return CoverageInterval {
            low: sorted[0],
            high: sorted[0],
        };
    }
    let r = match kind {
        IntervalKind::Symmetric => (m - q).div_ceil(2).max(1),
        IntervalKind::Shortest => {
            let mut best = 1;
            let mut width = f64::INFINITY;
            for r in 1..=m - q {
                let w = sorted[r + q - 1] - sorted[r - 1];
                if w < width {
                    width = w;
                    best = r;
                }
            }
            best
        }
    };
    CoverageInterval {
        low: sorted[r - 1],
        high: sorted[r + q - 1],
    }
}

/// Mean, variance (n − 1), skewness and kurtosis (plain fourth standardised moment, 3 for a
/// normal), the paper's M1–M4 (two-pass, so no cancellation).
///
/// Skewness and kurtosis divide by powers of the variance: when every value is the same (all
/// σ = 0, or a single value) or the variance is not finite they are undefined, `None` here,
/// `null` in JSON and "n/a" in the text report, whichever backend produced the values.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Moments {
    /// M1, mm.
    pub mean: f64,
    /// M2, mm².
    pub variance: f64,
    /// M3 = m3 / m2^{3/2}, or `None` when undefined.
    pub skewness: Option<f64>,
    /// M4 = m4 / m2², or `None` when undefined.
    pub kurtosis: Option<f64>,
}

impl Moments {
    /// Moments of `v` (non-empty).
    pub fn of(v: &[f64]) -> Moments {
        let n = v.len() as f64;
        // Equal values: the mean is that value exactly. (Summing would round it, and the
        // rounding error would pose as a spread with skewness ±1 and kurtosis 1.)
        if let Some(&first) = v.first().filter(|&&x| v.iter().all(|&y| y == x)) {
            return Moments {
                mean: first,
                variance: 0.0,
                skewness: None,
                kurtosis: None,
            };
        }
        let mean = v.iter().sum::<f64>() / n;
        let (mut m2, mut m3, mut m4) = (0.0, 0.0, 0.0);
        for x in v {
            let d = x - mean;
            let d2 = d * d;
            m2 += d2;
            m3 += d2 * d;
            m4 += d2 * d2;
        }
        let variance = m2 / (n - 1.0);
        let (m2, m3, m4) = (m2 / n, m3 / n, m4 / n);
        let defined = |x: f64| (m2 > 0.0 && m2.is_finite() && x.is_finite()).then_some(x);
        Moments {
            mean,
            variance,
            skewness: defined(m3 / m2.powf(1.5)),
            kurtosis: defined(m4 / (m2 * m2)),
        }
    }

    /// The four as an array `[M1, M2, M3, M4]`, NaN for an undefined moment.
    pub fn as_array(&self) -> [f64; 4] {
        [
            self.mean,
            self.variance,
            self.skewness.unwrap_or(f64::NAN),
            self.kurtosis.unwrap_or(f64::NAN),
        ]
    }

    /// Standard deviation, mm.
    pub fn std_dev(&self) -> f64 {
        self.variance.sqrt()
    }

    /// Maximum relative error `|M − M_base| / |M_base|` of M1–M4 against `base`, in percent (the
    /// paper's MRE), over the moments that are defined in both with `M_base ≠ 0` (or equal);
    /// NaN when no moment qualifies.
    pub fn max_relative_error(&self, base: &Moments) -> f64 {
        self.as_array()
            .iter()
            .zip(base.as_array())
            .filter_map(|(&a, b)| {
                if a == b {
                    Some(0.0)
                } else if a.is_finite() && b.is_finite() && b != 0.0 {
                    Some(((a - b) / b).abs() * 100.0)
                } else {
                    None
                }
            })
            .reduce(f64::max)
            .unwrap_or(f64::NAN)
    }
}

/// Monte Carlo standard errors of M1–M4 by batch means: the values (in draw order) are cut into
/// `groups` equal parts, each part's moments computed, and the standard deviation of each moment
/// over the parts divided by √groups.
pub fn moment_standard_errors(values_in_draw_order: &[f64], groups: usize) -> [f64; 4] {
    let g = groups.max(2);
    let len = values_in_draw_order.len() / g;
    if len < 2 {
        return [f64::NAN; 4];
    }
    let per: Vec<[f64; 4]> = (0..g)
        .map(|i| Moments::of(&values_in_draw_order[i * len..(i + 1) * len]).as_array())
        .collect();
    std::array::from_fn(|k| {
        let mean = per.iter().map(|p| p[k]).sum::<f64>() / g as f64;
        let var = per.iter().map(|p| (p[k] - mean).powi(2)).sum::<f64>() / (g as f64 - 1.0);
        // A part has 1/g of the draws; the pooled estimate's variance is about var/g.
        (var / g as f64).sqrt()
    })
}

/// Reliability `R = Pr[w < l_c]` at one threshold with its 95 % Wilson score interval.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Reliability {
    /// Threshold l_c, mm.
    pub threshold: f64,
    /// Fraction of draws with w < l_c.
    pub r: f64,
    /// Lower end of the 95 % binomial confidence interval.
    pub ci_low: f64,
    /// Upper end of the 95 % binomial confidence interval.
    pub ci_high: f64,
}

/// z of the two-sided 95 % normal interval.
pub const Z95: f64 = 1.959_963_984_540_054;

impl Reliability {
    /// From `count` successes in `n` draws (Wilson score interval, which stays inside [0, 1] and
    /// is informative at R = 0 or 1).
    pub fn from_count(threshold: f64, count: u64, n: u64) -> Reliability {
        let nf = n as f64;
        let r = count as f64 / nf;
        let z2 = Z95 * Z95;
        let denom = 1.0 + z2 / nf;
        let centre = (r + z2 / (2.0 * nf)) / denom;
        let half = Z95 * (r * (1.0 - r) / nf + z2 / (4.0 * nf * nf)).sqrt() / denom;
        let ci_low = if count == 0 {
            0.0
        } else {
            (centre - half).max(0.0)
        };
        let ci_high = if count == n {
            1.0
        } else {
            (centre + half).min(1.0)
        };
        Reliability {
            threshold,
            r,
            ci_low,
            ci_high,
        }
    }

    /// From ascending values: the count of values strictly below the threshold.
    pub fn from_sorted(threshold: f64, sorted: &[f64]) -> Reliability {
        let count = sorted.partition_point(|&v| v < threshold) as u64;
        Self::from_count(threshold, count, sorted.len() as u64)
    }
}

/// Empirical CDF of ascending values on `points` equally spaced abscissae from 0 to a little
/// beyond the maximum: `(w, Pr[w' ≤ w])` — the reliability curve R_c(l_c) of paper eq. 18.
pub fn ecdf_grid(sorted: &[f64], points: usize) -> Vec<(f64, f64)> {
    let max = sorted.last().copied().unwrap_or(0.0) * 1.02;
    let n = sorted.len() as f64;
    (0..points)
        .map(|i| {
            let x = max * i as f64 / (points - 1).max(1) as f64;
            (x, sorted.partition_point(|&v| v <= x) as f64 / n)
        })
        .collect()
}

/// A histogram density estimate: `(bin centre, density)` for `bins` equal bins over
/// `[min, max]` of ascending values; densities integrate to 1. Empty when there are no values or
/// all are equal: a point mass has no density (the reports then write no PDF rows).
pub fn histogram(sorted: &[f64], bins: usize) -> Vec<(f64, f64)> {
    let (Some(&lo), Some(&hi)) = (sorted.first(), sorted.last()) else {
        return Vec::new();
    };
    if hi <= lo || bins == 0 {
        return Vec::new();
    }
    let width = ((hi - lo) / bins as f64).max(f64::MIN_POSITIVE);
    let mut counts = vec![0u64; bins];
    for &v in sorted {
        let b = (((v - lo) / width) as usize).min(bins - 1);
        counts[b] += 1;
    }
    let n = sorted.len() as f64;
    counts
        .iter()
        .enumerate()
        .map(|(b, &c)| (lo + (b as f64 + 0.5) * width, c as f64 / (n * width)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interval_order_statistics() {
        // M = 20, p = 0.9: q = ⌊18.5⌋ = 18, symmetric r = ⌊3/2⌋ = 1 → [y1, y19].
        let v: Vec<f64> = (1..=20).map(f64::from).collect();
        let s = coverage_interval(&v, 0.9, IntervalKind::Symmetric);
        assert_eq!((s.low, s.high), (1.0, 19.0));
        // Spread-out upper tail: the shortest interval starts at the minimum.
        let mut w: Vec<f64> = (0..20).map(|i| (i as f64).powi(2)).collect();
        w.sort_by(f64::total_cmp);
        let s = coverage_interval(&w, 0.9, IntervalKind::Shortest);
        assert_eq!((s.low, s.high), (0.0, 324.0));
        // Spread-out lower tail: it ends at the maximum.
        let w: Vec<f64> = (0..20).map(|i| -((19 - i) as f64).powi(2)).collect();
        let s = coverage_interval(&w, 0.9, IntervalKind::Shortest);
        assert_eq!((s.low, s.high), (-324.0, 0.0));
    }

    #[test]
    fn moments_of_known_set() {
        let m = Moments::of(&[1.0, 2.0, 3.0, 4.0, 10.0]);
        assert!((m.mean - 4.0).abs() < 1e-15);
        assert!((m.variance - 12.5).abs() < 1e-12);
        // m2 = 10, m3 = 28.8·... computed by hand: deviations −3,−2,−1,0,6 → m3 = (−27−8−1+216)/5 = 36
        assert!((m.skewness.unwrap() - 36.0 / 10f64.powf(1.5)).abs() < 1e-12);
        // m4 = (81+16+1+1296)/5 = 278.8
        assert!((m.kurtosis.unwrap() - 278.8 / 100.0).abs() < 1e-12);
    }

    #[test]
    fn moments_of_equal_values_are_undefined_beyond_the_mean() {
        // 0.1 + 0.2 is not exactly representable: a summed mean of copies would be off by an
        // ulp and fake a spread with skewness ±1, kurtosis 1.
        let x = 0.1 + 0.2;
        let m = Moments::of(&[x; 1000]);
        assert_eq!((m.mean, m.variance), (x, 0.0));
        assert_eq!((m.skewness, m.kurtosis), (None, None));
        assert!(m.as_array()[2].is_nan() && m.as_array()[3].is_nan());
        // A variance that overflows leaves M3 and M4 undefined, not NaN.
        let m = Moments::of(&[0.0, 1e200, 3e200]);
        assert!(m.variance.is_infinite());
        assert_eq!((m.skewness, m.kurtosis), (None, None));
    }

    #[test]
    fn relative_error_skips_undefined_moments() {
        let a = Moments::of(&[1.0, 2.0, 4.0]);
        let b = Moments::of(&[1.0, 2.0, 5.0]);
        let full = a.max_relative_error(&b);
        let mut a_undef = a;
        a_undef.skewness = None;
        a_undef.kurtosis = None;
        // Only M1 and M2 count now: (7/3 − 8/3)/(8/3) = 12.5 %, (7/3 − 13/3)/(13/3) = 46.15 %.
        let m12 = a_undef.max_relative_error(&b);
        assert!((m12 - 600.0 / 13.0).abs() < 1e-9, "{m12}");
        assert!(full >= m12);
        let zero = Moments::of(&[0.0; 4]);
        assert_eq!(zero.max_relative_error(&zero), 0.0);
        assert!(b.max_relative_error(&zero).is_nan());
    }

    #[test]
    fn wilson_interval_known_value() {
        // 0 of 100: Wilson upper end = z²/(n+z²) = 3.8415/103.8415 = 0.036994
        let r = Reliability::from_count(0.1, 0, 100);
        assert_eq!(r.ci_low, 0.0);
        assert!((r.ci_high - 0.036994).abs() < 1e-5);
        let r = Reliability::from_count(0.1, 50, 100);
        assert!((r.ci_low - 0.40383).abs() < 1e-4 && (r.ci_high - 0.59617).abs() < 1e-4);
    }

    #[test]
    fn histogram_integrates_to_one() {
        let v: Vec<f64> = (0..1000).map(|i| (i as f64 / 1000.0).sqrt()).collect();
        let h = histogram(&v, 37);
        let width = h[1].0 - h[0].0;
        let total: f64 = h.iter().map(|(_, d)| d * width).sum();
        assert!((total - 1.0).abs() < 1e-12);
        // A point mass (all σ = 0) has no density, not one bin of 1/MIN_POSITIVE.
        assert!(histogram(&[0.3; 50], 37).is_empty());
        assert!(histogram(&[], 37).is_empty());
    }
}
