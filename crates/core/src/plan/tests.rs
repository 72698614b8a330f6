//! Unit tests of the plan's geometry: the approximate-design bound against brute force.

use super::geometry::Geometry;
use crate::sampling::standard_normal;
use nalgebra::DMatrix;
use rand::SeedableRng;

/// A geometry of `k` random 3 × p candidate blocks and `m` random task blocks.
fn toy(k: usize, m: usize, p: usize, seed: u64) -> Geometry {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let stacked = DMatrix::from_fn(3 * k, p, |_, _| standard_normal(&mut rng));
    let task = DMatrix::from_fn(3 * m, p, |_, _| standard_normal(&mut rng));
    let cand: Vec<DMatrix<f64>> = (0..k)
        .map(|i| stacked.rows(3 * i, 3).into_owned())
        .collect();
    Geometry {
        info: cand.iter().map(|j| j.transpose() * j).collect(),
        cand,
        stacked,
        grams: (0..m)
            .map(|j| {
                let r = task.rows(3 * j, 3);
                r.transpose() * r
            })
            .collect(),
        task,
        z: DMatrix::zeros(p, 1),
        z_eval: DMatrix::zeros(p, 1),
        scale: vec![1.0; p],
        thresholds_sigma: Vec::new(),
    }
}

/// Every multiset of `n` of `0..k`, in order.
fn multisets(k: usize, n: usize) -> Vec<Vec<usize>> {
    if n == 0 {
        return vec![Vec::new()];
    }
    let mut out = Vec::new();
    for rest in multisets(k, n - 1) {
        let from = rest.last().copied().unwrap_or(0);
        for i in from..k {
            let mut d = rest.clone();
            d.push(i);
            out.push(d);
        }
    }
    out
}

#[test]
fn the_design_bound_is_below_every_exact_design_and_near_the_best() {
    for seed in 1..=5 {
        let (k, n) = (8, 6);
        let g = toy(k, 4, 5, seed);
        let (bound, best_weights) = g.mean_sq_bound(n, 2000, &|_| {});
        // Brute force over every design of n poses, repeats allowed (1716 of them).
        let best_exact = multisets(k, n)
            .iter()
            .map(|d| g.mean_sq(&g.information(d)))
            .fold(f64::INFINITY, f64::min);
        eprintln!("seed {seed}: bound {bound:.5}, best weights {best_weights:.5}, best exact {best_exact:.5}");
        assert!(bound.is_finite() && bound > 0.0);
        assert!(
            bound <= best_exact * (1.0 + 1e-12),
            "seed {seed}: bound {bound} above the best exact design {best_exact}"
        );
        assert!(bound <= best_weights * (1.0 + 1e-12));
        // Rounding n = 6 weights to whole poses costs little here: the bound is not vacuous.
        assert!(
            bound >= 0.8 * best_exact,
            "seed {seed}: bound {bound}, best exact {best_exact}"
        );
    }
}
