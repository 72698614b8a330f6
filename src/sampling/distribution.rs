//! The parameter distribution: independent normals `μ_i + σ_i z_i`, or correlated normals
//! `μ + L z` with `L` the Cholesky factor of the covariance of the free parameters
//! (GUM S1 §6.4.8: multivariate Gaussian via `V = L Lᵀ`).
//!
//! Parameter `i` always uses standard normal number `i` of its draw, so a diagonal covariance and
//! the equivalent σ list give bit-identical draws.

use super::normal::box_muller;
use super::philox::{philox4x32_10_lanes, Philox};
use crate::kinematics::{RobotModel, Uncertainty, N_PARAMS};

/// Normals available per draw (8 Philox blocks of 4).
pub const MAX_NORMALS: usize = 32;

/// Errors building a sampler.
#[derive(Debug, thiserror::Error)]
pub enum SamplerError {
    /// The covariance of the free parameters has no Cholesky factor.
    #[error("the model's covariance matrix is not positive definite on its free parameters (rows with nonzero variance)")]
    NotPositiveDefinite,
}

#[derive(Clone, Debug)]
enum Form {
    Independent([f64; N_PARAMS]),
    Correlated {
        free: Vec<usize>,
        /// Lower-triangular factor, row-major `free.len()²`.
        chol: Vec<f64>,
    },
}

/// Draws parameter vectors for one run (one seed).
#[derive(Clone, Debug)]
pub struct ParamSampler {
    /// Parameter means (the model's values), mm and radians.
    pub mean: [f64; N_PARAMS],
    gen: Philox,
    form: Form,
    blocks: Vec<u32>,
}

/// Philox stream used for parameter draws.
pub const PARAM_STREAM: u32 = 0;

impl ParamSampler {
    /// A sampler for `model`'s values and uncertainty, keyed by `seed`.
    pub fn new(model: &RobotModel, seed: u64) -> Result<Self, SamplerError> {
        let free = model.free_params();
        let form = match &model.uncertainty {
            Uncertainty::Independent(s) => Form::Independent(*s),
            Uncertainty::Covariance(c) => {
                let n = free.len();
                let sub = nalgebra::DMatrix::from_fn(n, n, |a, b| c[free[a] * N_PARAMS + free[b]]);
                let l = nalgebra::linalg::Cholesky::new(sub)
                    .ok_or(SamplerError::NotPositiveDefinite)?
                    .l();
                let chol = (0..n * n).map(|x| l[(x / n, x % n)]).collect();
                Form::Correlated {
                    free: free.clone(),
                    chol,
                }
            }
        };
        let mut blocks: Vec<u32> = free.iter().map(|&i| (i / 4) as u32).collect();
        blocks.dedup();
        Ok(ParamSampler {
            mean: model.params,
            gen: Philox::new(seed),
            form,
            blocks,
        })
    }

    /// The Philox key of this run.
    pub fn key(&self) -> [u32; 2] {
        self.gen.key
    }

    /// Independent standard deviations, or `None` for a correlated sampler.
    pub fn sigmas(&self) -> Option<&[f64; N_PARAMS]> {
        match &self.form {
            Form::Independent(s) => Some(s),
            Form::Correlated { .. } => None,
        }
    }

    /// Free-parameter indices and the row-major lower Cholesky factor, for a correlated sampler.
    pub fn cholesky(&self) -> Option<(&[usize], &[f64])> {
        match &self.form {
            Form::Independent(_) => None,
            Form::Correlated { free, chol } => Some((free, chol)),
        }
    }

    /// Philox blocks (of 4 normals) that some free parameter uses.
    pub fn blocks(&self) -> &[u32] {
        &self.blocks
    }

    /// Offsets `δ = μ_k − μ` of draw `k` from the mean (mm, radians).
    #[inline]
    pub fn deltas(&self, k: u64, out: &mut [f64; N_PARAMS]) {
        let mut lanes = [[0.0; 1]; N_PARAMS];
        self.deltas_lanes::<1>(k, &mut lanes);
        for (o, l) in out.iter_mut().zip(&lanes) {
            *o = l[0];
        }
    }

    /// Offsets of draws `first … first + L − 1` at once, `out[i][l]` = parameter i of draw
    /// `first + l` (the lane layout vectorises; [`Self::deltas`] is the one-lane case, so both
    /// give the same bits).
    #[inline(always)]
    pub fn deltas_lanes<const L: usize>(&self, first: u64, out: &mut [[f64; L]; N_PARAMS]) {
        let mut z = [[0.0; L]; MAX_NORMALS];
        let lo: [u32; L] = std::array::from_fn(|l| (first + l as u64) as u32);
        let hi: [u32; L] = std::array::from_fn(|l| ((first + l as u64) >> 32) as u32);
        for &b in &self.blocks {
            let w = philox4x32_10_lanes([lo, hi, [b; L], [PARAM_STREAM; L]], self.gen.key);
            let base = 4 * b as usize;
            for l in 0..L {
                let (a, bb) = box_muller(w[0][l], w[1][l]);
                let (c, d) = box_muller(w[2][l], w[3][l]);
                z[base][l] = a;
                z[base + 1][l] = bb;
                z[base + 2][l] = c;
                z[base + 3][l] = d;
            }
        }
        match &self.form {
            Form::Independent(s) => {
                for i in 0..N_PARAMS {
                    for l in 0..L {
                        out[i][l] = s[i] * z[i][l];
                    }
                }
            }
            Form::Correlated { free, chol } => {
                *out = [[0.0; L]; N_PARAMS];
                let n = free.len();
                for a in 0..n {
                    let mut acc = [0.0; L];
                    for (b, &fb) in free.iter().enumerate().take(a + 1) {
                        let lab = chol[a * n + b];
                        for l in 0..L {
                            acc[l] += lab * z[fb][l];
                        }
                    }
                    out[free[a]] = acc;
                }
            }
        }
    }

    /// The full parameter vector of draw `k`.
    pub fn draw(&self, k: u64) -> [f64; N_PARAMS] {
        let mut d = [0.0; N_PARAMS];
        self.deltas(k, &mut d);
        std::array::from_fn(|i| self.mean[i] + d[i])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::tx60;

    #[test]
    fn diagonal_covariance_equals_sigma_list() {
        let m = tx60();
        let s = m.uncertainty.sigmas();
        let mut mc = m.clone();
        let mut c = vec![0.0; N_PARAMS * N_PARAMS];
        for i in 0..N_PARAMS {
            c[i * N_PARAMS + i] = s[i] * s[i];
        }
        mc.uncertainty = Uncertainty::Covariance(c);
        let (a, b) = (
            ParamSampler::new(&m, 7).unwrap(),
            ParamSampler::new(&mc, 7).unwrap(),
        );
        for k in [0u64, 1, 99, 1 << 40] {
            let (da, db) = (a.draw(k), b.draw(k));
            for i in 0..N_PARAMS {
                assert!((da[i] - db[i]).abs() <= 1e-15 * da[i].abs().max(1.0));
            }
        }
    }

    #[test]
    fn correlated_draws_reproduce_covariance() {
        // Two correlated parameters, ρ = 0.8; 2·10^5 draws: the correlation estimate's standard
        // error is (1−ρ²)/√n ≈ 8e-4, bound 5 standard errors.
        let mut m = tx60();
        let s = m.uncertainty.sigmas();
        let mut c = vec![0.0; N_PARAMS * N_PARAMS];
        for i in 0..N_PARAMS {
            c[i * N_PARAMS + i] = s[i] * s[i];
        }
        c[N_PARAMS + 2] = 0.8 * s[1] * s[2];
        c[2 * N_PARAMS + 1] = c[N_PARAMS + 2];
        m.uncertainty = Uncertainty::Covariance(c);
        let g = ParamSampler::new(&m, 3).unwrap();
        let n = 200_000;
        let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
        let mut d = [0.0; N_PARAMS];
        for k in 0..n {
            g.deltas(k, &mut d);
            sxy += d[1] * d[2];
            sxx += d[1] * d[1];
            syy += d[2] * d[2];
        }
        let rho = sxy / (sxx * syy).sqrt();
        assert!((rho - 0.8).abs() < 5.0 * 8e-4, "rho {rho}");
        assert!(((sxx / n as f64).sqrt() / s[1] - 1.0).abs() < 0.01);
    }

    #[test]
    fn indefinite_covariance_is_an_error() {
        let mut m = tx60();
        let mut c = vec![0.0; N_PARAMS * N_PARAMS];
        c[0] = 1e-8;
        c[2 * N_PARAMS + 2] = 1e-8;
        c[2] = 2e-8;
        c[2 * N_PARAMS] = 2e-8;
        m.uncertainty = Uncertainty::Covariance(c);
        assert!(ParamSampler::new(&m, 1).is_err());
    }
}
