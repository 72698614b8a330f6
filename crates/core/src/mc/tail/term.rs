//! The model's discrepancy term in the standard-normal space of subset simulation.
//!
//! The term is empirical ([`crate::discrepancy`]): per draw a size factor `g` (one of the
//! size's posterior quantiles), and per test point j a residual norm `r_j` drawn uniformly from
//! the term's norms and a direction cosine `c_j` uniform on (−1, 1). Each is a uniform variable
//! pushed through a step or linear function, so it has an exact standard-normal representation
//! (the Rosenblatt transform): with `p = Φ(u)` for a standard normal `u`,
//!
//! ```text
//! g = factors[⌊p_g·256⌋],   r_j = radii[⌊p_rj·K⌋]·scale_j·g,   c_j = 2 p_cj − 1
//! ```
//!
//! (with the radii and factors of the term point j draws, where a second term is drawn at some
//! points: [`crate::engine::SecondTerm`]),
//!
//! has the engine's distribution exactly (up to `Φ`'s error, below 1.2e-7 absolute, against
//! index steps of at least 1/65536). Subset simulation then works on `d + 2m + 1` normals: the
//! parameters' `d`, then the m radius normals, the m cosine normals and the size normal. Its
//! chains move them like every other component, so a tail where a large discrepancy at one
//! point, or a large size overall, drives the failure is found as a parameter-driven one is.
//! The evaluator gives each row's per-point kinematic errors `e_j`; the term is applied here,
//! `e_j ← √(e_j² + r_j² + 2 e_j r_j c_j)`, and `w = max_j e_j`, as the kernels do for counter
//! draws.

use crate::engine::DiscrepancyDraws;
use crate::normal::normal_cdf;

/// The term's normals and how they map to its draws.
pub(super) struct TermSpace {
    draws: DiscrepancyDraws,
    points: usize,
}

impl TermSpace {
    pub(super) fn new(draws: DiscrepancyDraws, points: usize) -> TermSpace {
        TermSpace { draws, points }
    }

    /// Normals the term adds to a state: a radius and a cosine per point, and the size.
    pub(super) fn dim(&self) -> usize {
        2 * self.points + 1
    }

    /// The largest error over the points of one row: kinematic errors `e` (m of them) with the
    /// term of the normals `u` ([`Self::dim`] of them) applied.
    pub(super) fn max_error(&self, e: &[f64], u: &[f64]) -> f64 {
        let m = self.points;
        let pick = |table: &[f64], z: f64| {
            table[((normal_cdf(z) * table.len() as f64) as usize).min(table.len() - 1)]
        };
        let scales = self.draws.scales();
        e.iter()
            .enumerate()
            .map(|(j, &ej)| {
                // The term the point draws (a second one at some points: engine::SecondTerm),
                // its size from the draw's one size normal as the engine's one word.
                let (radii, factors) = self.draws.term_of(j);
                let g = pick(factors, u[2 * m]);
                let s = if scales.is_empty() { 1.0 } else { scales[j] };
                let r = pick(radii, u[j]) * s * g;
                let c = 2.0 * normal_cdf(u[m + j]) - 1.0;
                (ej * ej + r * r + 2.0 * ej * r * c).max(0.0).sqrt()
            })
            .fold(0.0, f64::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::discrepancy::size::SIZE_DRAWS;

    /// Normals drawn from N(0, 1) give the engine's distribution of the term: at e = 0 the
    /// error is r·g, each radius and factor equally often.
    #[test]
    fn the_normals_reproduce_the_term_distribution() {
        use rand::{Rng, SeedableRng};
        let radii = vec![1.0, 2.0, 3.0, 4.0];
        let factors: Vec<f64> = (0..SIZE_DRAWS).map(|k| 1.0 + (k / 128) as f64).collect();
        let t = TermSpace::new(DiscrepancyDraws::new(radii, factors, 1), 1);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        let n = 40_000;
        let mut counts = std::collections::BTreeMap::new();
        let mut cross = 0.0;
        for _ in 0..n {
            let u: Vec<f64> = (0..3)
                .map(|_| {
                    let a: f64 = 1.0 - rng.random::<f64>();
                    let b: f64 = rng.random();
                    (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
                })
                .collect();
            let v = t.max_error(&[0.0], &u);
            *counts.entry((v * 1000.0).round() as i64).or_insert(0usize) += 1;
            // e = 1: E[e'²] = 1 + E[r²g²], the cross term averages out
            let e1 = t.max_error(&[1.0], &u);
            cross += e1 * e1 - 1.0 - v * v;
        }
        // r·g takes 1, 2, 3, 4 (g = 1) and 2, 4, 6, 8 (g = 2), each pair equally likely:
        // value 2 and 4 twice as often as 1, 3, 6, 8.
        let share = |x: i64| counts.get(&(x * 1000)).copied().unwrap_or(0) as f64 / n as f64;
        for (x, p) in [
            (1, 0.125),
            (2, 0.25),
            (3, 0.125),
            (4, 0.25),
            (6, 0.125),
            (8, 0.125),
        ] {
            // binomial σ ≤ √(0.25·0.75/n) ≈ 0.0022
            assert!((share(x) - p).abs() < 0.011, "{x}: {} vs {p}", share(x));
        }
        assert!((cross / n as f64).abs() < 0.1, "{}", cross / n as f64);
    }

    /// A second term drawn at some points: there the radius and the size come from its
    /// tables, elsewhere from the first's (at e = 0 the error is r·g).
    #[test]
    fn a_point_of_a_second_term_draws_from_its_tables() {
        use crate::engine::SecondTerm;
        let term = |first: f64| {
            let d = DiscrepancyDraws::new(vec![first], vec![1.0; SIZE_DRAWS], 1).with_second(
                SecondTerm {
                    radii: vec![10.0, 20.0],
                    factors: vec![2.0; SIZE_DRAWS],
                    at: vec![false, true],
                },
            );
            TermSpace::new(d, 2)
        };
        for (u1, want) in [(-1.0, 20.0), (1.0, 40.0)] {
            // point 1's radius normal u1, the rest 0
            let u = [0.0, u1, 0.0, 0.0, 0.0];
            assert_eq!(term(1.0).max_error(&[0.0, 0.0], &u), want);
            // point 0 draws the first term's radius (100, factor 1)
            assert_eq!(term(100.0).max_error(&[0.0, 0.0], &u), 100.0);
        }
    }
}
