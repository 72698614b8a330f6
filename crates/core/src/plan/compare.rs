//! The plan's figures beside its design: random designs of the same size and their medians, the
//! bound no design of as many poses can beat, and the curve of the predicted figures against the
//! number of poses.

use super::geometry::Geometry;
use super::search::greedy;
use super::{CurvePoint, DesignFigures, PlanOptions};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

/// Iterations of the multiplicative algorithm behind
/// [`Plan::rms_bound_mm`](super::Plan::rms_bound_mm).
const BOUND_ITERATIONS: usize = 200;

/// The medians of the figures of `o.random_designs` random designs of `o.poses` candidates each,
/// drawn from `rng`.
pub(super) fn random_median(g: &Geometry, o: &PlanOptions, rng: &mut ChaCha8Rng) -> DesignFigures {
    let randoms: Vec<DesignFigures> = (0..o.random_designs)
        .map(|_| {
            let mut idx: Vec<usize> = (0..g.cand.len()).collect();
            for i in 0..o.poses {
                let k = rng.random_range(i..idx.len());
                idx.swap(i, k);
            }
            idx.truncate(o.poses);
            idx
        })
        .collect::<Vec<_>>()
        .par_iter()
        .map(|d| g.figures(d, o.sigma_mm))
        .collect();
    median_figures(&randoms, o.thresholds.len())
}

/// The approximate-design bound on the predicted RMS at the task points of every design of
/// `o.poses` poses ([`Plan::rms_bound_mm`](super::Plan::rms_bound_mm)), mm.
pub(super) fn rms_bound_mm(g: &Geometry, o: &PlanOptions) -> f64 {
    g.mean_sq_bound(o.poses, BOUND_ITERATIONS).0.sqrt() * o.sigma_mm
}

/// The curve: the figures of the prefixes of `design` in its own D-optimal order, from
/// `o.curve_from` poses (at least a third of the inputs plus one) to `o.poses`.
pub(super) fn curve(g: &Geometry, design: &[usize], o: &PlanOptions) -> Vec<CurvePoint> {
    let p = g.p();
    let ordered = greedy(g, design, &[], design.len());
    let from = o.curve_from.clamp(p / 3 + 1, o.poses);
    (from..=o.poses)
        .into_par_iter()
        .map(|n| {
            let f = g.figures(&ordered[..n], o.sigma_mm);
            CurvePoint {
                poses: n,
                q95_mm: f.q95_mm,
                reliability: f.reliability,
            }
        })
        .collect::<Vec<CurvePoint>>()
        .into_iter()
        // Designs too small to determine every input have no prediction.
        .filter(|c| c.q95_mm.is_finite())
        .collect()
}

/// Figure-by-figure medians.
fn median_figures(v: &[DesignFigures], thresholds: usize) -> DesignFigures {
    let med = |f: &dyn Fn(&DesignFigures) -> f64| {
        let mut x: Vec<f64> = v.iter().map(f).collect();
        x.sort_by(f64::total_cmp);
        if x.is_empty() {
            f64::NAN
        } else if x.len() % 2 == 1 {
            x[x.len() / 2]
        } else {
            0.5 * (x[x.len() / 2 - 1] + x[x.len() / 2])
        }
    };
    DesignFigures {
        q95_mm: med(&|f| f.q95_mm),
        rms_mm: med(&|f| f.rms_mm),
        reliability: (0..thresholds)
            .map(|t| med(&|f| f.reliability[t]))
            .collect(),
        log_det: med(&|f| f.log_det),
        o1: med(&|f| f.o1),
        condition: med(&|f| f.condition),
    }
}
