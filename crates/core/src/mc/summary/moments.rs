//! Mergeable moment sums of a set of values (Chan et al. for M2, Pébay 2008 for M3 and M4).

use crate::mc::stats::Moments;
use serde::{Deserialize, Serialize};

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
