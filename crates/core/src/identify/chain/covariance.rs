//! The covariance of the fit inputs and the statistics of a finished fit: the linearised
//! covariance `s²(JᵀWJ)⁻¹`, its embedding over all fit inputs and its correlations, the χ² noise
//! check and the point residuals.

use super::NoiseReport;
use crate::identify::chain_fit::{
    jacobian, local_jacobian, position_residuals, residuals, rotation_free, rpy_to_local,
    ChainState, Observation, Prior,
};
use crate::identify::noise::{chi2_upper_tail, NoiseModel};
use crate::kinematics::Block;
use nalgebra::DMatrix;

/// The inverse of a symmetric positive (semi)definite matrix: Cholesky, or the pseudo-inverse by
/// eigen-decomposition when it is singular to working precision.
pub(super) fn invert_spd(a: &DMatrix<f64>) -> DMatrix<f64> {
    if let Some(ch) = a.clone().cholesky() {
        return ch.inverse();
    }
    let eig = a.clone().symmetric_eigen();
    let max = eig.eigenvalues.iter().fold(0.0f64, |m, v| m.max(*v));
    let mut inv = DMatrix::zeros(a.nrows(), a.ncols());
    for k in 0..eig.eigenvalues.len() {
        let l = eig.eigenvalues[k];
        if l > 1e-12 * max {
            let v = eig.eigenvectors.column(k);
            inv += v * v.transpose() / l;
        }
    }
    inv
}

/// The covariance of the free inputs (whitened units) by each method.
pub(super) struct FreeCovariance {
    /// `(JᵀWJ + prior)⁻¹` at the solution.
    pub linearised: DMatrix<f64>,
    /// The sample covariance of the Monte Carlo re-identifications, when asked for.
    pub monte_carlo: Option<DMatrix<f64>>,
}

impl FreeCovariance {
    /// The covariance the result holds: the Monte Carlo one when computed, else the linearised.
    pub fn chosen(&self) -> &DMatrix<f64> {
        self.monte_carlo.as_ref().unwrap_or(&self.linearised)
    }
}

/// The covariance over the free inputs `free` at `state`: `(JᵀWJ + prior)⁻¹` in whitened units.
pub(super) fn linearised_covariance(
    obs: &[Observation],
    state: &ChainState,
    free: &[usize],
    prior: Option<&Prior>,
) -> DMatrix<f64> {
    invert_spd(&information(&jacobian(obs, state, free), free, prior))
}

/// The linearised covariance of the free inputs `free` with the placement's rotation as small
/// rotations about the measurement frame's axes ([`local_jacobian`]), and the same covariance in
/// the model's roll, pitch and yaw (`δ(r, p, y) = M⁻¹ δω`, [`rpy_to_local`]). Where `M` cannot
/// be inverted (±90° pitch) or the rotation is not free, both are the roll-pitch-yaw one.
pub(super) fn linearised_covariances(
    obs: &[Observation],
    state: &ChainState,
    free: &[usize],
    prior: Option<&Prior>,
) -> (DMatrix<f64>, DMatrix<f64>) {
    let space = state.space();
    let to_rpy = rotation_free(space, free)
        .then(|| rpy_to_local(state).try_inverse())
        .flatten();
    let Some(m_inv) = to_rpy else {
        let c = linearised_covariance(obs, state, free, prior);
        return (c.clone(), c);
    };
    let local = invert_spd(&information(&local_jacobian(obs, state, free), free, prior));
    let mut t = DMatrix::<f64>::identity(free.len(), free.len());
    let at: Vec<usize> = free
        .iter()
        .enumerate()
        .filter(|(_, &i)| i < space.len() && matches!(space.locate(i), (Block::Placement, 3..=5)))
        .map(|(c, _)| c)
        .collect();
    for (a, &ca) in at.iter().enumerate() {
        for (b, &cb) in at.iter().enumerate() {
            t[(ca, cb)] = m_inv[(a, b)];
        }
    }
    let rpy = &t * &local * t.transpose();
    (local, (&rpy + rpy.transpose()) * 0.5)
}

/// The information `JᵀJ + prior` of the free inputs `free` whose whitened Jacobian is `j`.
pub(super) fn information(j: &DMatrix<f64>, free: &[usize], prior: Option<&Prior>) -> DMatrix<f64> {
    let mut a = j.transpose() * j;
    if let Some(p) = prior {
        for (k, &i) in free.iter().enumerate() {
            if p.sigma_of(i) > 0.0 {
                a[(k, k)] += 1.0 / (p.sigma_of(i) * p.sigma_of(i));
            }
        }
    }
    a
}

/// The standard uncertainties of the first `p` inputs of covariance `c` (negative variances
/// read as 0).
pub(super) fn standard_deviations(c: &DMatrix<f64>, p: usize) -> Vec<f64> {
    (0..p).map(|k| c[(k, k)].max(0.0).sqrt()).collect()
}

/// The covariance `chosen` over the free inputs `free` as a row-major `nf × nf` covariance over
/// all fit inputs, zero rows and columns for the inputs held fixed.
pub(super) fn embed(chosen: &DMatrix<f64>, free: &[usize], nf: usize) -> Vec<f64> {
    let mut covariance = vec![0.0; nf * nf];
    // Inputs at or past `nf` (the other targets' offsets) are left out: the kept block of a
    // Gaussian's covariance is the covariance of its marginal.
    for (a_k, &ia) in free.iter().enumerate().filter(|(_, &i)| i < nf) {
        for (b_k, &ib) in free.iter().enumerate().filter(|(_, &i)| i < nf) {
            covariance[ia * nf + ib] = chosen[(a_k, b_k)];
        }
    }
    covariance
}

/// The row-major `p × p` correlation matrix of covariance `chosen` (0 where a variance is 0).
pub(super) fn correlation(chosen: &DMatrix<f64>, p: usize) -> Vec<f64> {
    let mut correlation = vec![0.0; p * p];
    for a_k in 0..p {
        for b_k in 0..p {
            let d = (chosen[(a_k, a_k)] * chosen[(b_k, b_k)]).sqrt();
            correlation[a_k * p + b_k] = if d > 0.0 { chosen[(a_k, b_k)] / d } else { 0.0 };
        }
    }
    correlation
}

/// The noise check of a fit at `state`: χ² of the whitened residuals for `dof` degrees of
/// freedom, and its upper tail when `noise` is stated (σ estimated as `estimated_sigma` else).
pub(super) fn noise_report(
    obs: &[Observation],
    state: &ChainState,
    noise: &NoiseModel,
    estimated_sigma: Option<f64>,
    dof: usize,
) -> NoiseReport {
    let r = residuals(obs, state);
    let chi2 = r.iter().map(|v| v * v).sum::<f64>();
    NoiseReport {
        source: noise.describe(),
        sigma_mm: estimated_sigma,
        chi2,
        dof,
        p_value: noise.is_stated().then(|| chi2_upper_tail(chi2, dof)),
    }
}

/// The 3-D residual of each point (mm, in data order), their RMS and the largest.
pub(super) fn residual_norms(obs: &[Observation], state: &ChainState) -> (Vec<f64>, f64, f64) {
    let plain = position_residuals(obs, state);
    let norms: Vec<f64> = plain
        .iter()
        .map(|e| (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt())
        .collect();
    let rms = (norms.iter().map(|v| v * v).sum::<f64>() / norms.len() as f64).sqrt();
    let max = norms.iter().fold(0.0f64, |m, v| m.max(*v));
    (norms, rms, max)
}
