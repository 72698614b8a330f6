//! The identification geometry a plan's search works on: the scaled Jacobian blocks of the
//! candidates and of the task points, the common random numbers, and every figure of a design
//! computed from them (w and its q95, the screen of the exchange, the expected squared error
//! and its approximate-design bound, the information figures, the planned covariance).

use super::{DesignFigures, PlanError, PlanOptions, EVAL_DRAWS};
use crate::identify::chain_fit::{jacobian, ChainState, Observation};
use crate::kinematics::Joints;
use crate::sampling::standard_normal;
use nalgebra::{Cholesky, DMatrix, Matrix3, SymmetricEigen};
use rand_chacha::ChaCha8Rng;

/// The identification geometry the search works on: scaled Jacobian rows of every candidate and
/// of the task points, and the common random numbers.
pub(super) struct Geometry {
    /// Per candidate, its 3 × p scaled Jacobian.
    pub(super) cand: Vec<DMatrix<f64>>,
    /// The same rows stacked, 3M × p.
    pub(super) stacked: DMatrix<f64>,
    /// Per candidate, `JᵀJ` (p × p).
    pub(super) info: Vec<DMatrix<f64>>,
    /// 3m × p scaled task Jacobian.
    pub(super) task: DMatrix<f64>,
    /// Per task point j, `J_jᵀ J_j`: `⟨M⁻¹, G_j⟩` is point j's expected ‖e_j‖² under
    /// information M.
    pub(super) grams: Vec<DMatrix<f64>>,
    /// p × K standard normals of the search.
    pub(super) z: DMatrix<f64>,
    /// p × K' standard normals of the reported figures, drawn apart from the search's so that
    /// the design chosen on `z` is not judged on the noise it was chosen for.
    pub(super) z_eval: DMatrix<f64>,
    /// Column scale (RMS over candidates of each input's column).
    pub(super) scale: Vec<f64>,
    /// Thresholds in units of σ.
    pub(super) thresholds_sigma: Vec<f64>,
}

impl Geometry {
    /// The geometry of the candidates `cands` and the task points `task` (degrees) on the free
    /// inputs `free` of the nominal chain `s`: each column scaled by its RMS over the
    /// candidates, the search's and the figures' standard normals drawn from `rng`. `tick` is
    /// told the share of the candidates' Jacobians done.
    pub(super) fn new(
        s: &ChainState,
        free: &[usize],
        cands: &[Joints],
        task: &[Joints],
        o: &PlanOptions,
        rng: &mut ChaCha8Rng,
        tick: &dyn Fn(f64),
    ) -> Geometry {
        let p = free.len();
        // Chunk by chunk (each candidate's rows are its own), to tell the progress.
        let mut cj = DMatrix::<f64>::zeros(3 * cands.len(), p);
        let chunk = cands.len().div_ceil(JACOBIAN_CHUNKS).max(1);
        for (k, part) in cands.chunks(chunk).enumerate() {
            cj.rows_mut(3 * k * chunk, 3 * part.len())
                .copy_from(&jacobian(&observations(s, part), s, free));
            tick(((k + 1) * chunk).min(cands.len()) as f64 / cands.len() as f64);
        }
        let tj = jacobian(&observations(s, task), s, free);
        let scale: Vec<f64> = (0..p)
            .map(|c| {
                let n = cj.column(c).norm() / (cands.len() as f64).sqrt();
                if n > 0.0 {
                    n
                } else {
                    1.0
                }
            })
            .collect();
        let scaled = |mut j: DMatrix<f64>| {
            for (c, sc) in scale.iter().enumerate() {
                j.column_mut(c).unscale_mut(*sc);
            }
            j
        };
        let cj = scaled(cj);
        let cand: Vec<DMatrix<f64>> = (0..cands.len())
            .map(|i| cj.rows(3 * i, 3).into_owned())
            .collect();
        let info = cand.iter().map(|j| j.transpose() * j).collect();
        let z = DMatrix::from_fn(p, o.search_draws, |_, _| standard_normal(rng));
        let z_eval = DMatrix::from_fn(p, EVAL_DRAWS, |_, _| standard_normal(rng));
        let task_j = scaled(tj);
        Geometry {
            cand,
            stacked: cj,
            info,
            grams: (0..task.len())
                .map(|j| {
                    let r = task_j.rows(3 * j, 3);
                    r.transpose() * r
                })
                .collect(),
            task: task_j,
            z,
            z_eval,
            scale,
            thresholds_sigma: o.thresholds.iter().map(|t| t / o.sigma_mm).collect(),
        }
    }

    pub(super) fn p(&self) -> usize {
        self.scale.len()
    }

    /// Scaled information of `design` (σ = 1).
    pub(super) fn information(&self, design: &[usize]) -> DMatrix<f64> {
        let mut m = DMatrix::zeros(self.p(), self.p());
        for &i in design {
            m += &self.info[i];
        }
        m
    }

    /// w of each common random vector of `z` (units of σ) for information `m`; `None` when `m`
    /// is singular.
    fn w(&self, m: &DMatrix<f64>, z: &DMatrix<f64>) -> Option<Vec<f64>> {
        let inv = Cholesky::new(m.clone())?.inverse();
        let l = Cholesky::new(inv)?.l();
        let a = &self.task * l;
        let e = a * z;
        let pts = e.nrows() / 3;
        Some(
            (0..e.ncols())
                .map(|k| {
                    (0..pts)
                        .map(|j| {
                            let (x, y, z) = (e[(3 * j, k)], e[(3 * j + 1, k)], e[(3 * j + 2, k)]);
                            x * x + y * y + z * z
                        })
                        .fold(0.0, f64::max)
                        .sqrt()
                })
                .collect(),
        )
    }

    /// The screen of the exchange, smooth and free of Monte Carlo noise: `Σ_j v_j⁴` of the
    /// task points' expected squared errors `v_j` (units of σ²) under information `m`, which
    /// weighs the worst points as the maximum in w does; +∞ when `m` is singular.
    pub(super) fn screen(&self, m: &DMatrix<f64>) -> f64 {
        match Cholesky::new(m.clone()) {
            Some(c) => {
                let inv = c.inverse();
                self.grams
                    .iter()
                    .map(|g| inv.dot(g).powi(SCREEN_POWER))
                    .sum()
            }
            None => f64::INFINITY,
        }
    }

    /// Mean over the task points of the expected squared error (units of σ²) under information
    /// `m`; +∞ when `m` is singular.
    pub(super) fn mean_sq(&self, m: &DMatrix<f64>) -> f64 {
        match Cholesky::new(m.clone()) {
            Some(c) => {
                let inv = c.inverse();
                self.grams.iter().map(|g| inv.dot(g)).sum::<f64>() / self.grams.len() as f64
            }
            None => f64::INFINITY,
        }
    }

    /// A lower bound (units of σ²) on [`Geometry::mean_sq`] of every design of `n` poses
    /// from the candidates, repeats allowed (Method §17): the bound of approximate design
    /// theory for the linear criterion `Φ(M) = tr(A M⁻¹)`, `A = Σ_j G_j / m`. For weights `w`
    /// (`Σ w_i = n`) with `M = Σ w_i I_i` and `d_i = tr(I_i M⁻¹ A M⁻¹)`, convexity and
    /// `Φ(cM) = Φ(M)/c` give `Φ(M*) ≥ Φ(M)² / (n · max_i d_i)` for the best `M*` of any
    /// weights, hence of any exact design. The weights are improved by the multiplicative
    /// algorithm `w_i ← w_i·√(n·d_i/Φ)`; every iterate's bound is valid, the iterations only
    /// tighten it. Returns the bound and the criterion of the best weights found.
    /// `tick` is told the share of the most iterations done.
    pub(super) fn mean_sq_bound(
        &self,
        n: usize,
        iterations: usize,
        tick: &dyn Fn(f64),
    ) -> (f64, f64) {
        let k = self.info.len();
        let p = self.p();
        let a = self
            .grams
            .iter()
            .fold(DMatrix::<f64>::zeros(p, p), |acc, g| acc + g)
            / self.grams.len() as f64;
        let nf = n as f64;
        let mut w = vec![nf / k as f64; k];
        let (mut bound, mut best) = (0.0f64, f64::INFINITY);
        let mut weighted = self.stacked.clone();
        for it in 0..iterations {
            tick(it as f64 / iterations as f64);
            // M = Σ w_i J_iᵀ J_i as one product of the stacked rows scaled by √w_i.
            for (i, wi) in w.iter().enumerate() {
                let r = wi.sqrt();
                for row in 3 * i..3 * i + 3 {
                    for c in 0..p {
                        weighted[(row, c)] = self.stacked[(row, c)] * r;
                    }
                }
            }
            let m = weighted.tr_mul(&weighted);
            let Some(c) = Cholesky::new(m) else {
                break;
            };
            let minv = c.inverse();
            let b = &minv * &a * &minv;
            let phi = a.dot(&minv);
            // d_i = tr(J_i B J_iᵀ): the row sums of (J B) ∘ J, three rows per candidate.
            let jb = (&self.stacked * &b).component_mul(&self.stacked);
            let rows: Vec<f64> = jb.column_sum().iter().copied().collect();
            let d: Vec<f64> = (0..k)
                .map(|i| rows[3 * i] + rows[3 * i + 1] + rows[3 * i + 2])
                .collect();
            let dmax = d.iter().cloned().fold(0.0, f64::max);
            if !(phi.is_finite() && dmax > 0.0) {
                break;
            }
            bound = bound.max(phi * phi / (nf * dmax));
            best = best.min(phi);
            if bound >= best * (1.0 - BOUND_GAP) {
                break;
            }
            for (wi, di) in w.iter_mut().zip(&d) {
                *wi *= (nf * di / phi).sqrt();
            }
            let total: f64 = w.iter().sum();
            w.iter_mut().for_each(|wi| *wi *= nf / total);
        }
        (bound, best)
    }

    /// q95 (units of σ) for information `m`, +∞ when singular.
    pub(super) fn q95(&self, m: &DMatrix<f64>) -> f64 {
        match self.w(m, &self.z) {
            Some(mut w) => {
                w.sort_by(f64::total_cmp);
                quantile(&w, 0.95)
            }
            None => f64::INFINITY,
        }
    }

    /// Every figure of `design`; `sigma` converts to mm.
    pub(super) fn figures(&self, design: &[usize], sigma: f64) -> DesignFigures {
        let m = self.information(design);
        let mut w = self.w(&m, &self.z_eval).unwrap_or_default();
        w.sort_by(f64::total_cmp);
        let reliability = self
            .thresholds_sigma
            .iter()
            .map(|&t| {
                if w.is_empty() {
                    0.0
                } else {
                    w.partition_point(|&v| v < t) as f64 / w.len() as f64
                }
            })
            .collect();
        let rms_mm = self.mean_sq(&m).sqrt() * sigma;
        let ev = SymmetricEigen::new(m).eigenvalues;
        let (lo, hi) = ev
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(a, b), &v| (a.min(v), b.max(v)));
        let p = self.p() as f64;
        let log_det: f64 = ev.iter().map(|v| v.max(f64::MIN_POSITIVE).ln()).sum();
        DesignFigures {
            q95_mm: if w.is_empty() {
                f64::INFINITY
            } else {
                quantile(&w, 0.95) * sigma
            },
            rms_mm,
            reliability,
            log_det,
            o1: (log_det / (2.0 * p)).exp() / (design.len() as f64).sqrt(),
            condition: if lo > 0.0 {
                (hi / lo).sqrt()
            } else {
                f64::INFINITY
            },
        }
    }

    /// The planned covariance of `design` in internal units, row-major over the `nf` measured
    /// inputs: σ² · S⁻¹ M⁻¹ S⁻¹ on the `free` inputs, 0 elsewhere.
    ///
    /// # Errors
    ///
    /// [`PlanError::NotIdentifiable`] when the design's information is singular.
    pub(super) fn covariance(
        &self,
        design: &[usize],
        free: &[usize],
        nf: usize,
        sigma_mm: f64,
    ) -> Result<Vec<f64>, PlanError> {
        let minv = Cholesky::new(self.information(design))
            .map(|c| c.inverse())
            .ok_or_else(|| PlanError::NotIdentifiable("the planned design is singular".into()))?;
        let mut covariance = vec![0.0; nf * nf];
        let s2 = sigma_mm * sigma_mm;
        for (a, &ia) in free.iter().enumerate() {
            for (b, &ib) in free.iter().enumerate() {
                // Symmetric to the last bit, as a model file's covariance must be.
                let v = 0.5 * (minv[(a, b)] + minv[(b, a)]);
                covariance[ia * nf + ib] = s2 * v / (self.scale[a] * self.scale[b]);
            }
        }
        Ok(covariance)
    }
}

/// Chunks the candidates' Jacobians are computed in (for the progress).
const JACOBIAN_CHUNKS: usize = 50;

/// Power of the task points' expected squared errors in the screen.
const SCREEN_POWER: i32 = 4;

/// Relative gap between the bound and the best weights' criterion at which the algorithm stops.
const BOUND_GAP: f64 = 2e-3;

/// The value of rank ⌈q·n⌉ of ascending values.
pub(super) fn quantile(sorted: &[f64], q: f64) -> f64 {
    let k = ((q * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len());
    sorted[k - 1]
}

/// Unit-weight observations of the nominal chain's own predictions at `q_deg`.
fn observations(s: &ChainState, q_deg: &[Joints]) -> Vec<Observation> {
    q_deg
        .iter()
        .map(|q| {
            let q = q.map(f64::to_radians);
            Observation {
                q,
                p: s.predict(&q),
                whiten: Matrix3::identity(),
                payload_kg: 0.0,
                target: 0,
                sides: None,
            }
        })
        .collect()
}
