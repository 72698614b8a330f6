//! Compensation: a Gaussian process over the joint configuration fitted to the residuals the
//! geometric model leaves, whose posterior mean is added to the model's prediction
//! (docs/METHOD.md §18.1).
//!
//! The residual vector `r(q)` (measured minus predicted, mm) is modelled per coordinate as
//! independent draws of one Gaussian process with the squared-exponential kernel over the joint
//! angles (one length scale per joint, automatic relevance) plus white noise:
//!
//! ```text
//! k(q, q') = σ_f² exp(−½ Σ_d ((q_d − q'_d)/ℓ_d)²) + σ_w² [q = q']
//! ```
//!
//! The white part is measurement noise plus whatever varies faster than the poses resolve
//! (backlash, jitter); the smooth part is what a neighbouring configuration predicts
//! (compliance under gravity, gear errors of long period). The hyperparameters `ℓ, σ_f, σ_w` maximise the log
//! marginal likelihood summed over the three coordinates (resilient back-propagation on their
//! logarithms, on a seeded subset of at most [`HYPER_POINTS`] poses); the posterior mean at a
//! new configuration is `μ(q) = Σ_i k(q, q_i) α_i` with `α = K_y⁻¹ R`.
//!
//! Whether to compensate is decided on the data: the leave-one-out residual of a GP has the
//! closed form `e_i = [K_y⁻¹ R]_i / [K_y⁻¹]_ii`, so the RMS a new pose would show with the
//! compensation is known before any new pose is measured; the compensation is kept only when it
//! is below the geometric model's own leave-one-out RMS by [`required_gain`] at least. The same
//! formula turns the fit's standardised residuals into the compensated model's, from which the
//! discrepancy term is then drawn (what the compensation does not predict).

mod held_out;
mod inverse;
mod predictive;

pub use held_out::{
    held_out, HeldOut, CROSS_VALIDATION, CROSS_VALIDATION_GROUPS, LEAVE_GROUP_OUT, LEAVE_ONE_OUT,
};
use inverse::par_inverse;
use nalgebra::{DMatrix, Vector3};
use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};

/// Fewest poses from which a compensation is fitted.
pub const MIN_POINTS: usize = 20;
/// Most poses the posterior is conditioned on (an `n³` factorisation; larger data sets are
/// thinned evenly, the poses left out then count as held out in the leave-one-out figures).
pub const MAX_TRAINING: usize = 1500;
/// Most poses the hyperparameters are fitted on (a seeded subset; each step of their search
/// factorises its `n × n` matrix). 150 since 2026-11-27 (300 before): on the public UR10 poses
/// the compensated held-out RMS is 0.3295 against 0.3298 mm with the same coverage, and
/// identifying 1000 simulated poses (`cargo bench --bench joint_errors`, identify's defaults)
/// takes 0.80 against 1.76 s (docs/guide/performance.md).
pub const HYPER_POINTS: usize = 150;
/// Up to this many poses the compensation is judged by [`FOLDS`]-fold cross-validation with
/// the hyperparameters refitted on each fold's training part; above, by the closed-form
/// leave-one-out at the hyperparameters fitted to all poses (their optimism is of order
/// hyperparameters / poses, and refitting would cost [`FOLDS`] fits).
pub const CROSS_VALIDATION_LIMIT: usize = 400;
/// Folds of that cross-validation.
pub const FOLDS: usize = 5;
/// Iterations of the hyperparameter search before it is declared not converged.
pub const MAX_ITERATIONS: usize = 300;
/// The compensation is kept when its leave-one-out RMS is below `1 − g` times the geometric
/// model's, `g` = [`required_gain`]: at least this …
pub const MIN_GAIN: f64 = 0.03;

/// … and at least `1/√n` for `n` poses: a leave-one-out RMS of few poses is itself uncertain
/// by about that much (24 poses: 20 %), and a compensation that only seems to help would make
/// the predictions worse.
pub fn required_gain(n: usize) -> f64 {
    MIN_GAIN.max(1.0 / (n.max(1) as f64).sqrt())
}

/// A fitted compensation as the model file stores it (base frame, degrees, mm).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Compensation {
    /// Length scale per joint, degrees.
    pub length_scales_deg: Vec<f64>,
    /// σ_f of the smooth part per coordinate, mm.
    pub signal_sigma_mm: f64,
    /// σ_w of the white part per coordinate, mm (noise and what the poses do not resolve).
    pub white_sigma_mm: f64,
    /// Leave-one-out RMS (3-D) of the geometric model's standardised residuals, mm.
    pub loo_rms_geometric_mm: f64,
    /// Leave-one-out RMS (3-D) with the compensation, mm.
    pub loo_rms_compensated_mm: f64,
    /// The reference σ of the residual norms, mm per coordinate: the RMS over the poses of the
    /// leave-one-out predictive σ. The norms are at this σ; at a configuration where the
    /// process predicts σ(q) (far from the poses: up to √(σ_f² + σ_w²)) they are drawn times
    /// σ(q)/σ_ref ([`Compensation::point_scales`]).
    pub loo_sigma_mm: f64,
    /// The configurations the posterior is conditioned on, degrees, one row per pose.
    pub configurations_deg: Vec<Vec<f64>>,
    /// `α = K_y⁻¹ R` per pose, base frame, mm⁻¹ (the mean is `Σ_i k(q, q_i) α_i`).
    pub weights: Vec<[f64; 3]>,
}

/// Why a compensation could not be fitted or read.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum GpError {
    /// Too few poses.
    #[error("{0} poses: a compensation needs at least {MIN_POINTS}")]
    TooFew(usize),
    /// The hyperparameter search did not settle.
    #[error("its hyperparameters did not converge in {MAX_ITERATIONS} iterations")]
    NotConverged,
    /// The kernel matrix could not be factorised (poses repeated to machine precision with no
    /// white noise).
    #[error("the kernel matrix is not positive definite")]
    Singular,
}

impl Compensation {
    /// The posterior mean at `q_deg`, base frame, mm.
    pub fn correction_mm(&self, q_deg: &[f64]) -> [f64; 3] {
        let sf2 = self.signal_sigma_mm * self.signal_sigma_mm;
        let mut out = [0.0; 3];
        for (row, w) in self.configurations_deg.iter().zip(&self.weights) {
            let s: f64 = row
                .iter()
                .zip(q_deg)
                .zip(&self.length_scales_deg)
                .map(|((a, b), l)| ((a - b) / l).powi(2))
                .sum();
            let k = sf2 * (-0.5 * s).exp();
            for c in 0..3 {
                out[c] += k * w[c];
            }
        }
        out
    }

    /// The process's predictive σ per coordinate at each configuration (degrees), mm:
    /// `√(σ_f² − k*ᵀ K_y⁻¹ k* + σ_w²)`. Should the stored kernel not factorise (a hand-edited
    /// file), the prior σ `√(σ_f² + σ_w²)`, the largest it can be.
    pub fn predictive_sigmas<Q: AsRef<[f64]>>(&self, q_deg: &[Q]) -> Vec<f64> {
        let sf2 = self.signal_sigma_mm * self.signal_sigma_mm;
        let sw2 = self.white_sigma_mm * self.white_sigma_mm;
        let x: Vec<&[f64]> = self
            .configurations_deg
            .iter()
            .map(|r| r.as_slice())
            .collect();
        let mut ky = gram(&x, &self.length_scales_deg, sf2);
        for i in 0..x.len() {
            ky[(i, i)] += sw2 + 1e-10 * sf2;
        }
        let Some(chol) = ky.cholesky() else {
            return vec![(sf2 + sw2).sqrt(); q_deg.len()];
        };
        let l = chol.l();
        q_deg
            .iter()
            .map(|q| {
                let k = kernel_column(q.as_ref(), &x, &self.length_scales_deg, sf2);
                // kᵀ K_y⁻¹ k = |L⁻¹ k|²
                let explained = l
                    .solve_lower_triangular(&k)
                    .map_or(0.0, |v| v.norm_squared());
                predictive_sd(sf2, sw2, explained)
            })
            .collect()
    }

    /// The factor the residual norms are drawn with at each configuration (degrees):
    /// [`Self::predictive_sigmas`] over [`Compensation::loo_sigma_mm`].
    pub fn point_scales<Q: AsRef<[f64]>>(&self, q_deg: &[Q]) -> Vec<f64> {
        self.predictive_sigmas(q_deg)
            .into_iter()
            .map(|s| s / self.loo_sigma_mm)
            .collect()
    }

    /// Joints of the configurations.
    pub fn joints(&self) -> usize {
        self.length_scales_deg.len()
    }

    /// Checks a compensation as a model file gives it, for a model of `joints` joints: one
    /// length scale per joint (finite, positive), finite σs, one weight row per configuration,
    /// every row `joints` finite angles, at most [`MAX_TRAINING`] rows.
    ///
    /// # Errors
    ///
    /// `(field, message)`: the field as the model file spells it below `[discrepancy]`, and
    /// what is wrong with it.
    pub fn check(&self, joints: usize) -> Result<(), (String, String)> {
        let f = |name: &str| format!("compensation.{name}");
        if self.length_scales_deg.len() != joints {
            return Err((
                f("length_scales_deg"),
                format!(
                    "{} values for a model of {joints} joints (one per joint)",
                    self.length_scales_deg.len()
                ),
            ));
        }
        if let Some(l) = self
            .length_scales_deg
            .iter()
            .find(|l| !(l.is_finite() && **l > 0.0))
        {
            return Err((
                f("length_scales_deg"),
                format!("{l} is not a length scale (finite, positive degrees)"),
            ));
        }
        if !(self.loo_sigma_mm.is_finite() && self.loo_sigma_mm > 0.0 && self.loo_sigma_mm < 1e4) {
            return Err((
                f("loo_sigma_mm"),
                format!(
                    "{} is not a σ in mm (finite, positive, below 10000)",
                    self.loo_sigma_mm
                ),
            ));
        }
        for (name, v) in [
            ("signal_sigma_mm", self.signal_sigma_mm),
            ("white_sigma_mm", self.white_sigma_mm),
            ("loo_rms_geometric_mm", self.loo_rms_geometric_mm),
            ("loo_rms_compensated_mm", self.loo_rms_compensated_mm),
        ] {
            if !(v.is_finite() && (0.0..1e4).contains(&v)) {
                return Err((
                    f(name),
                    format!("{v} is not a size in mm (finite, 0 … 10000)"),
                ));
            }
        }
        let n = self.configurations_deg.len();
        if n == 0 || n > MAX_TRAINING {
            return Err((
                f("configurations_deg"),
                format!("{n} rows: a compensation holds 1 to {MAX_TRAINING}"),
            ));
        }
        if self.weights.len() != n {
            return Err((
                f("weights"),
                format!("{} rows for {n} configurations", self.weights.len()),
            ));
        }
        for (i, row) in self.configurations_deg.iter().enumerate() {
            if row.len() != joints || row.iter().any(|v| !v.is_finite()) {
                return Err((
                    f("configurations_deg"),
                    format!(
                        "row {}: {} angles, a model of {joints} joints needs {joints} finite ones",
                        i + 1,
                        row.len()
                    ),
                ));
            }
        }
        if let Some(i) = self
            .weights
            .iter()
            .position(|w| w.iter().any(|v| !v.is_finite()))
        {
            return Err((f("weights"), format!("row {} is not finite", i + 1)));
        }
        Ok(())
    }
}

/// A fitted process: its hyperparameters and the factorised kernel over its training poses.
#[derive(Clone, Debug)]
pub struct GpFit {
    /// Length scales, radians.
    pub length_scales: Vec<f64>,
    /// σ_f, mm.
    pub signal_sigma: f64,
    /// σ_w, mm.
    pub white_sigma: f64,
    /// Indices of the training poses.
    training: Vec<usize>,
    /// Configurations of all poses, radians.
    configs: Vec<Vec<f64>>,
    /// `K_y⁻¹` over the training poses.
    inverse: DMatrix<f64>,
    /// `K_y⁻¹ R` of the targets it was fitted to.
    alpha: DMatrix<f64>,
}

/// Squared-exponential kernel value of two configurations.
fn kernel(a: &[f64], b: &[f64], ell: &[f64], sf2: f64) -> f64 {
    let s: f64 = a
        .iter()
        .zip(b)
        .zip(ell)
        .map(|((x, y), l)| ((x - y) / l).powi(2))
        .sum();
    sf2 * (-0.5 * s).exp()
}

/// The kernel values `k(q, x_i)` over configurations `x`.
fn kernel_column(q: &[f64], x: &[&[f64]], ell: &[f64], sf2: f64) -> nalgebra::DVector<f64> {
    nalgebra::DVector::from_iterator(x.len(), x.iter().map(|c| kernel(q, c, ell, sf2)))
}

/// The predictive σ per coordinate of a new measurement, `√(σ_f² − kᵀK_y⁻¹k + σ_w²)`, from the
/// part `kᵀK_y⁻¹k` the poses explain (the fit and the stored compensation compute it each in
/// their own units and factorisation).
fn predictive_sd(sf2: f64, sw2: f64, explained: f64) -> f64 {
    ((sf2 - explained).max(0.0) + sw2).sqrt()
}

/// `K_f` over `x` (the smooth part only).
fn gram(x: &[&[f64]], ell: &[f64], sf2: f64) -> DMatrix<f64> {
    let n = x.len();
    let mut k = DMatrix::zeros(n, n);
    for a in 0..n {
        for b in a..n {
            let v = kernel(x[a], x[b], ell, sf2);
            k[(a, b)] = v;
            k[(b, a)] = v;
        }
    }
    k
}

/// Log marginal likelihood of the three coordinates and its gradient in
/// `θ = (ln ℓ_1 … ln ℓ_J, ln σ_f, ln σ_w)`; `None` when `K_y` is not positive definite.
fn objective(x: &[&[f64]], y: &DMatrix<f64>, theta: &[f64]) -> Option<(f64, Vec<f64>)> {
    let j = theta.len() - 2;
    let ell: Vec<f64> = theta[..j].iter().map(|t| t.exp()).collect();
    let sf2 = (2.0 * theta[j]).exp();
    let sw2 = (2.0 * theta[j + 1]).exp();
    let n = x.len();
    let kf = gram(x, &ell, sf2);
    let mut ky = kf.clone();
    for i in 0..n {
        ky[(i, i)] += sw2 + 1e-10 * sf2;
    }
    let chol = ky.cholesky()?;
    let alpha = chol.solve(y);
    let logdet: f64 = 2.0
        * chol
            .l_dirty()
            .diagonal()
            .iter()
            .map(|v| v.ln())
            .sum::<f64>();
    let fit: f64 = y.component_mul(&alpha).sum();
    let value = -0.5 * fit - 1.5 * logdet - 1.5 * n as f64 * std::f64::consts::TAU.ln();
    let w = &alpha * alpha.transpose() - par_inverse(&chol) * 3.0;
    let mut grad = vec![0.0; j + 2];
    for a in 0..n {
        for b in 0..n {
            let wk = w[(a, b)] * kf[(a, b)];
            grad[j] += wk;
            for (d, l) in ell.iter().enumerate() {
                grad[d] += 0.5 * wk * ((x[a][d] - x[b][d]) / l).powi(2);
            }
        }
    }
    grad[j + 1] = sw2 * w.trace();
    Some((value, grad))
}

/// Fits a process to `targets` (mm, one vector per pose) over `configs` (radians), seeded.
///
/// # Errors
///
/// [`GpError::TooFew`] below [`MIN_POINTS`] poses, [`GpError::NotConverged`] when the
/// hyperparameter search does not settle, [`GpError::Singular`] when the kernel cannot be
/// factorised.
pub fn fit(configs: &[Vec<f64>], targets: &[Vector3<f64>], seed: u64) -> Result<GpFit, GpError> {
    let n = configs.len().min(targets.len());
    if n < MIN_POINTS {
        return Err(GpError::TooFew(n));
    }
    let joints = configs[0].len();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x6A55_1A40);
    // Joints that did not move carry no information: their length scale is held huge.
    let spread: Vec<f64> = (0..joints)
        .map(|d| {
            let (lo, hi) = configs[..n]
                .iter()
                .fold((f64::MAX, f64::MIN), |(lo, hi), c| {
                    (lo.min(c[d]), hi.max(c[d]))
                });
            hi - lo
        })
        .collect();
    let scale = (targets[..n].iter().map(|t| t.norm_squared()).sum::<f64>() / (3 * n) as f64)
        .sqrt()
        .max(1e-9);
    let hyper: Vec<usize> = if n > HYPER_POINTS {
        let mut idx: Vec<usize> = (0..n).collect();
        for a in 0..HYPER_POINTS {
            let b = rng.random_range(a..n);
            idx.swap(a, b);
        }
        idx.truncate(HYPER_POINTS);
        idx
    } else {
        (0..n).collect()
    };
    let x: Vec<&[f64]> = hyper.iter().map(|&i| configs[i].as_slice()).collect();
    let y = DMatrix::from_fn(hyper.len(), 3, |r, c| targets[hyper[r]][c]);
    // Bounds on the logarithms: length scales from a fiftieth of a joint's range to a hundred
    // times it, σs from 10⁻⁴ to 10 times the residuals' RMS.
    let mut lo = Vec::with_capacity(joints + 2);
    let mut hi = Vec::with_capacity(joints + 2);
    let mut theta = Vec::with_capacity(joints + 2);
    let mut active = Vec::with_capacity(joints + 2);
    for &s in &spread {
        if s > 1e-9 {
            lo.push((s / 50.0).ln());
            hi.push((s * 100.0).ln());
            theta.push((s / 2.0).ln());
            active.push(true);
        } else {
            lo.push(1e6f64.ln());
            hi.push(1e6f64.ln());
            theta.push(1e6f64.ln());
            active.push(false);
        }
    }
    for _ in 0..2 {
        lo.push((scale * 1e-4).ln());
        hi.push((scale * 10.0).ln());
        theta.push((scale * 0.7).ln());
        active.push(true);
    }
    let p = theta.len();
    let mut step = vec![0.3f64; p];
    let mut previous = vec![0.0; p];
    let mut best: Option<(f64, Vec<f64>)> = None;
    let mut converged = false;
    for _ in 0..MAX_ITERATIONS {
        let Some((value, mut grad)) = objective(&x, &y, &theta) else {
            // Step back towards the best point with smaller steps.
            let Some((_, b)) = &best else {
                return Err(GpError::Singular);
            };
            theta.clone_from(b);
            step.iter_mut().for_each(|s| *s *= 0.5);
            continue;
        };
        if best.as_ref().is_none_or(|(v, _)| value > *v) {
            best = Some((value, theta.clone()));
        }
        for k in 0..p {
            if !active[k] {
                continue;
            }
            let product = grad[k] * previous[k];
            if product > 0.0 {
                step[k] = (step[k] * 1.2).min(1.0);
            } else if product < 0.0 {
                step[k] *= 0.5;
                grad[k] = 0.0;
            }
            let next = (theta[k] + grad[k].signum() * step[k] * f64::from(grad[k] != 0.0))
                .clamp(lo[k], hi[k]);
            // A parameter held at a bound by its gradient has settled there.
            if (next == lo[k] && grad[k] < 0.0) || (next == hi[k] && grad[k] > 0.0) {
                step[k] = step[k].min(1e-4);
            }
            theta[k] = next;
        }
        previous = grad;
        if (0..p).all(|k| !active[k] || step[k] < 1e-3) {
            converged = true;
            break;
        }
    }
    if !converged {
        return Err(GpError::NotConverged);
    }
    let theta = best.map(|(_, t)| t).ok_or(GpError::Singular)?;
    condition(configs, targets, n, &theta, joints)
}

/// The posterior over (at most [`MAX_TRAINING`] evenly spaced of) the first `n` poses with
/// hyperparameters `theta`.
fn condition(
    configs: &[Vec<f64>],
    targets: &[Vector3<f64>],
    n: usize,
    theta: &[f64],
    joints: usize,
) -> Result<GpFit, GpError> {
    let ell: Vec<f64> = theta[..joints].iter().map(|t| t.exp()).collect();
    let (sf, sw) = (theta[joints].exp(), theta[joints + 1].exp());
    let training: Vec<usize> = if n > MAX_TRAINING {
        (0..MAX_TRAINING).map(|k| k * n / MAX_TRAINING).collect()
    } else {
        (0..n).collect()
    };
    let x: Vec<&[f64]> = training.iter().map(|&i| configs[i].as_slice()).collect();
    let mut ky = gram(&x, &ell, sf * sf);
    for i in 0..training.len() {
        ky[(i, i)] += sw * sw + 1e-10 * sf * sf;
    }
    let chol = ky.cholesky().ok_or(GpError::Singular)?;
    let y = DMatrix::from_fn(training.len(), 3, |r, c| targets[training[r]][c]);
    let alpha = chol.solve(&y);
    Ok(GpFit {
        length_scales: ell,
        signal_sigma: sf,
        white_sigma: sw,
        training,
        configs: configs[..n].to_vec(),
        inverse: par_inverse(&chol),
        alpha,
    })
}

/// The posterior over `configs` at `theta` (ln ℓ…, ln σ_f, ln σ_w), for tests.
#[cfg(test)]
pub(crate) fn condition_for_tests(
    configs: &[Vec<f64>],
    targets: &[Vector3<f64>],
    theta: &[f64],
) -> GpFit {
    condition(configs, targets, configs.len(), theta, configs[0].len()).unwrap()
}

impl GpFit {
    /// Posterior mean at `q` (radians) of the targets it was fitted to.
    pub fn mean(&self, q: &[f64]) -> Vector3<f64> {
        self.mean_of(&self.alpha, q)
    }

    fn mean_of(&self, alpha: &DMatrix<f64>, q: &[f64]) -> Vector3<f64> {
        let sf2 = self.signal_sigma * self.signal_sigma;
        let mut out = Vector3::zeros();
        for (r, &i) in self.training.iter().enumerate() {
            let k = kernel(q, &self.configs[i], &self.length_scales, sf2);
            out += k * Vector3::new(alpha[(r, 0)], alpha[(r, 1)], alpha[(r, 2)]);
        }
        out
    }

    /// The posterior mean at `q` (radians) of `values` given at every pose the process was
    /// fitted to (only its training poses' values are used).
    pub fn mean_of_values(&self, values: &[Vector3<f64>], q: &[f64]) -> Vector3<f64> {
        let y = DMatrix::from_fn(self.training.len(), 3, |r, c| values[self.training[r]][c]);
        self.mean_of(&(&self.inverse * y), q)
    }

    /// Leave-one-out residuals of `values` (one vector per pose, the poses it was fitted on):
    /// for a training pose `[K_y⁻¹ V]_i / [K_y⁻¹]_ii`, for a pose outside the training set its
    /// value minus the posterior mean of `values` there.
    pub fn loo(&self, values: &[Vector3<f64>]) -> Vec<Vector3<f64>> {
        let y = DMatrix::from_fn(self.training.len(), 3, |r, c| values[self.training[r]][c]);
        let a = &self.inverse * &y;
        let mut out: Vec<Vector3<f64>> = values.to_vec();
        let mut in_training = vec![false; values.len()];
        for (r, &i) in self.training.iter().enumerate() {
            let d = self.inverse[(r, r)];
            out[i] = Vector3::new(a[(r, 0)], a[(r, 1)], a[(r, 2)]) / d;
            in_training[i] = true;
        }
        for (i, v) in out.iter_mut().enumerate() {
            if !in_training[i] {
                *v = values[i] - self.mean_of(&a, &self.configs[i]);
            }
        }
        out
    }

    /// The compensation to store, with weights turned into the base frame by `to_base`.
    pub fn compensation(
        &self,
        to_base: &nalgebra::Matrix3<f64>,
        loo_rms_geometric_mm: f64,
        loo_rms_compensated_mm: f64,
        loo_sigma_mm: f64,
    ) -> Compensation {
        Compensation {
            loo_sigma_mm,
            length_scales_deg: self.length_scales.iter().map(|l| l.to_degrees()).collect(),
            signal_sigma_mm: self.signal_sigma,
            white_sigma_mm: self.white_sigma,
            loo_rms_geometric_mm,
            loo_rms_compensated_mm,
            configurations_deg: self
                .training
                .iter()
                .map(|&i| self.configs[i].iter().map(|v| v.to_degrees()).collect())
                .collect(),
            weights: (0..self.training.len())
                .map(|r| {
                    let v = to_base
                        * Vector3::new(self.alpha[(r, 0)], self.alpha[(r, 1)], self.alpha[(r, 2)]);
                    [v.x, v.y, v.z]
                })
                .collect(),
        }
    }
}

/// RMS of the norms of `v`.
pub fn rms(v: &[Vector3<f64>]) -> f64 {
    (v.iter().map(|x| x.norm_squared()).sum::<f64>() / v.len().max(1) as f64).sqrt()
}
