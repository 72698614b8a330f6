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
pub(super) const BOUND_ITERATIONS: usize = 200;

/// The medians of the figures of `o.random_designs` random designs of `o.poses` candidates each,
/// drawn from `rng`; `tick` is told the share of the designs done.
pub(super) fn random_median(
    g: &Geometry,
    o: &PlanOptions,
    rng: &mut ChaCha8Rng,
    tick: &dyn Fn(f64),
) -> DesignFigures {
    let total = o.random_designs.max(1) as f64;
    let mut idx: Vec<usize> = (0..g.cand.len()).collect();
    let designs: Vec<Vec<usize>> = (0..o.random_designs)
        .map(|k| {
            // A partial shuffle of the identity, undone after (the next design shuffles the
            // identity again, as if drawn afresh).
            let swaps: Vec<(usize, usize)> = (0..o.poses)
                .map(|i| {
                    let k = rng.random_range(i..idx.len());
                    idx.swap(i, k);
                    (i, k)
                })
                .collect();
            let design = idx[..o.poses].to_vec();
            for &(i, k) in swaps.iter().rev() {
                idx.swap(i, k);
            }
            tick(0.5 * k as f64 / total);
            design
        })
        .collect();
    let mut randoms = Vec::with_capacity(designs.len());
    for (k, chunk) in designs.chunks(RANDOM_CHUNK).enumerate() {
        randoms.par_extend(chunk.par_iter().map(|d| g.figures(d, o.sigma_mm)));
        tick(0.5 + 0.5 * ((k + 1) * RANDOM_CHUNK) as f64 / total);
    }
    median_figures(&randoms, o.thresholds.len())
}

/// Random designs judged at a time between two progress reports.
const RANDOM_CHUNK: usize = 16;

/// The approximate-design bound on the predicted RMS at the task points of every design of
/// `o.poses` poses ([`Plan::rms_bound_mm`](super::Plan::rms_bound_mm)), mm.
/// `tick` is told the share of the iterations done.
pub(super) fn rms_bound_mm(g: &Geometry, o: &PlanOptions, tick: &dyn Fn(f64)) -> f64 {
    g.mean_sq_bound(o.poses, BOUND_ITERATIONS, tick).0.sqrt() * o.sigma_mm
}

/// The curve: the figures of the prefixes of `design` in its own D-optimal order, from
/// `o.curve_from` poses (at least a third of the inputs plus one) to `o.poses`.
pub(super) fn curve(g: &Geometry, design: &[usize], o: &PlanOptions) -> Vec<CurvePoint> {
    let p = g.p();
    let ordered = greedy(g, design, &[], design.len(), &|_| {});
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
