//! The fitted process's predictive σ at many configurations: the kernel columns of a block of
//! configurations times `K_y⁻¹` as one matrix product, blocks in parallel.
//!
//! `kᵀ K_y⁻¹ k` one configuration at a time is a matrix-vector product over the training poses
//! (at most [`super::MAX_TRAINING`]²); the leave-one-out σ of every pose outside the training
//! set took most of an identification of 10⁴ poses that way. A block of [`BLOCK`]
//! configurations makes it a matrix product, which runs near the machine's peak.

use super::{kernel, kernel_column, predictive_sd, GpFit};
use nalgebra::DMatrix;
use rayon::prelude::*;

/// Configurations per matrix product.
const BLOCK: usize = 128;

impl GpFit {
    /// The configurations of the training poses, in the order of `K_y⁻¹`'s rows.
    pub(super) fn training_configs(&self) -> Vec<&[f64]> {
        self.training
            .iter()
            .map(|&t| self.configs[t].as_slice())
            .collect()
    }

    /// The predictive σ per coordinate of a new measurement at `q` (radians), mm:
    /// `√(σ_f² − kᵀ K_y⁻¹ k + σ_w²)`.
    pub fn predictive_sigma(&self, q: &[f64]) -> f64 {
        let sf2 = self.signal_sigma * self.signal_sigma;
        let k = kernel_column(q, &self.training_configs(), &self.length_scales, sf2);
        let explained = (k.transpose() * &self.inverse * &k)[(0, 0)];
        predictive_sd(sf2, self.white_sigma * self.white_sigma, explained)
    }

    /// [`Self::predictive_sigma`] at each of `qs` (radians), in blocks run in parallel; the
    /// same values to rounding.
    pub fn predictive_sigmas(&self, qs: &[&[f64]]) -> Vec<f64> {
        let sf2 = self.signal_sigma * self.signal_sigma;
        let sw2 = self.white_sigma * self.white_sigma;
        let t = self.training.len();
        qs.par_chunks(BLOCK)
            .flat_map_iter(|block| {
                // Column j holds k(q_j, x_i) over the training poses i.
                let k = DMatrix::from_fn(t, block.len(), |i, j| {
                    kernel(
                        block[j],
                        &self.configs[self.training[i]],
                        &self.length_scales,
                        sf2,
                    )
                });
                let p = &self.inverse * &k;
                (0..block.len())
                    .map(|j| predictive_sd(sf2, sw2, k.column(j).dot(&p.column(j))))
                    .collect::<Vec<_>>()
            })
            .collect()
    }

    /// The leave-one-out predictive σ per coordinate of every pose, mm: `1/√[K_y⁻¹]_ii` for a
    /// training pose, the predictive σ there for one outside the training set.
    pub fn loo_sigmas(&self) -> Vec<f64> {
        let mut out = vec![f64::NAN; self.configs.len()];
        for (r, &i) in self.training.iter().enumerate() {
            out[i] = 1.0 / self.inverse[(r, r)].max(1e-300).sqrt();
        }
        let outside: Vec<usize> = (0..out.len()).filter(|&i| out[i].is_nan()).collect();
        let qs: Vec<&[f64]> = outside
            .iter()
            .map(|&i| self.configs[i].as_slice())
            .collect();
        for (i, s) in outside.into_iter().zip(self.predictive_sigmas(&qs)) {
            out[i] = s;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::super::condition_for_tests;
    use nalgebra::Vector3;

    /// The blocked, parallel σ equal the one-at-a-time σ to rounding, across block edges.
    #[test]
    fn blocked_sigmas_equal_one_at_a_time() {
        let configs: Vec<Vec<f64>> = (0..60)
            .map(|i| {
                let t = i as f64 * 0.37;
                vec![t.sin(), (1.3 * t).cos(), 0.5 * (0.7 * t).sin()]
            })
            .collect();
        let targets: Vec<Vector3<f64>> = configs
            .iter()
            .map(|c| Vector3::new(c[0] * 0.1, c[1] * 0.05, (c[0] * c[2]) * 0.02))
            .collect();
        let fit = condition_for_tests(
            &configs,
            &targets,
            &[0.0, 0.2, -0.3, (0.05f64).ln(), (0.01f64).ln()],
        );
        let probes: Vec<Vec<f64>> = (0..300)
            .map(|i| {
                let t = i as f64 * 0.113;
                vec![(2.0 * t).sin(), t.cos(), 0.4 * t.sin()]
            })
            .collect();
        let qs: Vec<&[f64]> = probes.iter().map(|p| p.as_slice()).collect();
        let blocked = fit.predictive_sigmas(&qs);
        assert_eq!(blocked.len(), probes.len());
        for (p, b) in probes.iter().zip(&blocked) {
            let one = fit.predictive_sigma(p);
            // The two orders of the product round differently: |δ(kᵀK⁻¹k)| ≤ t·ε·|k|²·‖K⁻¹‖
            // ≈ 60·1.1e-16·0.15·1e4 = 1e-11 mm², so |δσ| ≤ 1e-11 / (2 σ_w) = 5e-10 mm.
            assert!((one - b).abs() <= 5e-10, "{one} vs {b}");
        }
    }
}
