//! The lack of fit's leave-one-out figures: each point's residual as a fit without it would
//! leave it, and the self-check of the predicted error bound on them.

use super::*;

/// `count` random subsets of `size` distinct indices below `n` (partial Fisher–Yates shuffles).
pub fn random_subsets(n: usize, size: usize, count: usize, rng: &mut impl Rng) -> Vec<Vec<usize>> {
    let mut idx: Vec<usize> = (0..n).collect();
    (0..count)
        .map(|_| {
            for a in 0..size.min(n) {
                let b = rng.random_range(a..n);
                idx.swap(a, b);
            }
            idx[..size.min(n)].to_vec()
        })
        .collect()
}

/// A unit vector uniform on the sphere.
fn unit(rng: &mut impl Rng) -> Vector3<f64> {
    let c: f64 = rng.random_range(-1.0..1.0);
    let phi: f64 = rng.random_range(0.0..std::f64::consts::TAU);
    let s = (1.0 - c * c).max(0.0).sqrt();
    Vector3::new(s * phi.cos(), s * phi.sin(), c)
}

/// What the self-check compares: each point's left-out error, the term's norms, and the factor
/// they are drawn with at each point.
pub(super) struct Drawn<'a> {
    pub(super) left_out: &'a [Vector3<f64>],
    pub(super) norms: &'a [f64],
    pub(super) scales: &'a [f64],
    /// The size's per-draw factors for a measurement ([`size::factors`], noise kept).
    pub(super) factors: &'a [f64],
}

/// The leave-one-out check (see the module text).
pub(super) fn loo_check(
    points: &[FittedPoint],
    drawn: Drawn<'_>,
    scale: f64,
    seed: u64,
) -> LooCheck {
    let Drawn {
        left_out,
        norms,
        scales,
        factors,
    } = drawn;
    let n = points.len();
    // Draws per point: enough for a 95 % quantile, bounded in total work.
    let m = (20_000_000 / n).clamp(200, 2000);
    let mut samples_with = vec![0.0; n * m];
    let mut samples_without = vec![0.0; n * m];
    // Each point draws from its own stream of the seed (the points in parallel, the same
    // figures on any number of threads).
    let inside: Vec<(bool, bool)> = samples_with
        .par_chunks_mut(m)
        .zip(samples_without.par_chunks_mut(m))
        .enumerate()
        .map(|(i, (with, without))| {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x100F_C0DE);
            rng.set_stream(i as u64 + 1);
            let p = &points[i];
            let w_inv = p.whiten.try_inverse().unwrap_or_else(Matrix3::identity);
            let free = Matrix3::identity() - p.leverage;
            let free_inv = free.try_inverse().unwrap_or_else(Matrix3::identity);
            let cov = w_inv * (p.leverage * free_inv) * w_inv.transpose() * scale;
            let cov = (cov + cov.transpose()) * 0.5;
            let l = cov.cholesky().map(|c| c.l()).unwrap_or_else(Matrix3::zeros);
            for k in 0..m {
                let z = Vector3::from_fn(|_, _| gaussian(&mut rng));
                let dp = l * z;
                // the other points' norms
                let mut j = rng.random_range(0..n - 1);
                if j >= i {
                    j += 1;
                }
                let g = factors[rng.random_range(0..factors.len())];
                let d = unit(&mut rng) * (norms[j] * scales[i] * g);
                with[k] = (dp + d).norm();
                without[k] = dp.norm();
            }
            // The 95 % quantile: the ⌈0.95 m⌉-th smallest.
            let rank = ((0.95 * m as f64).ceil() as usize).min(m) - 1;
            let q = |s: &[f64]| {
                let mut s = s.to_vec();
                *s.select_nth_unstable_by(rank, f64::total_cmp).1
            };
            let observed = left_out[i].norm();
            (observed <= q(with), observed <= q(without))
        })
        .collect();
    let observed: Vec<f64> = left_out.iter().map(|v| v.norm()).collect();
    let inside_with = inside.iter().filter(|p| p.0).count();
    let inside_without = inside.iter().filter(|p| p.1).count();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x100F_C0DE);
    // PIT of the maximum over random subsets of SUBSET points (all points when fewer).
    let subsets = 200;
    let mut pits = Vec::with_capacity(subsets);
    for chosen in random_subsets(n, SUBSET.min(n), subsets, &mut rng) {
        let w_obs = chosen.iter().map(|&i| observed[i]).fold(0.0, f64::max);
        let below = (0..m)
            .filter(|&k| {
                chosen
                    .iter()
                    .map(|&i| samples_with[i * m + k])
                    .fold(0.0, f64::max)
                    <= w_obs
            })
            .count();
        pits.push(below as f64 / m as f64);
    }
    LooCheck {
        coverage_95: inside_with as f64 / n as f64,
        coverage_95_parameters_only: inside_without as f64 / n as f64,
        pit_max_mean: pits.iter().sum::<f64>() / subsets as f64,
        pit_max_at_least_099: pits.iter().filter(|&&u| u >= 0.99).count() as f64 / subsets as f64,
        subsets,
    }
}

/// The leave-one-out prediction errors of the parameters' fit, `W⁻¹ (I − H_ii)⁻¹ W r_i`, mm.
pub(super) fn parameter_loo(points: &[FittedPoint]) -> Vec<Vector3<f64>> {
    points
        .iter()
        .map(|p| {
            let w_inv = p.whiten.try_inverse().unwrap_or_else(Matrix3::identity);
            let free_inv = (Matrix3::identity() - p.leverage)
                .try_inverse()
                .unwrap_or_else(Matrix3::identity);
            w_inv * free_inv * (p.whiten * Vector3::from(p.residual_mm))
        })
        .collect()
}
