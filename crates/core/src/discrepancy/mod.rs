//! The model-discrepancy term: what the geometric model does not explain, carried into every
//! reliability figure (docs/METHOD.md §18).
//!
//! A real robot keeps errors after a geometric calibration that no MDH parameter describes
//! (joint compliance under gravity, gear harmonics, backlash, drift). They show in the
//! identification's residuals and nowhere else, so the parameters' covariance alone predicts
//! errors that are too small (on public tracker data of real arms the predicted per-point 95 %
//! bound covered 3 % of held-out errors). Following Kennedy and O'Hagan's
//! `y = η(x, θ) + δ(x) + ε`, the error at a task point is
//!
//! ```text
//! e_j = |Δp_j(θ') + δ_j|
//! ```
//!
//! with `Δp_j` the deviation the drawn parameters `θ'` cause (the engine's kinematics) and `δ_j`
//! the discrepancy at point `j`. The term is *empirical*: real residuals are heavy-tailed (excess
//! kurtosis 2–5 per coordinate), so a Gaussian `δ` underpredicts the maximum over many points.
//! `|δ_j|` is drawn from the norms of the fit's standardised residuals (a bootstrap; a
//! standardised residual `(I − H_ii)^{-1/2} r_i` has the variance of a new measurement's deviation
//! from the model beyond the parameters' own uncertainty, which the parameter draws carry), and
//! its direction uniformly on the sphere, independently at every point and draw. For a uniform
//! direction the cosine `c` of the angle between `δ_j` and `Δp_j` is uniform on [−1, 1], so
//!
//! ```text
//! e_j² = |Δp_j|² + r² + 2 |Δp_j| r c,   r ~ the residual norms,  c ~ U(−1, 1)
//! ```
//!
//! needs one uniform radius index and one cosine per point, and nothing of the error vector but
//! its length: every kernel (f64 lanes, the f64 point form, the WGSL shader) applies it after its
//! own `|Δp_j|`. The engine draws it ([`crate::engine::DiscrepancyDraws`]): point `j` of draw `k`
//! takes one 32-bit word hashed from Philox block `(k, 0, DISCREPANCY_STREAM)` and `j`, keyed by
//! the run's seed like the parameter draws, so a draw's discrepancy is the same on every backend, batch split
//! and thread count, and the parameter draws keep their bits. The word's high half gives the
//! residual index `⌊(w ≫ 16)·K / 2¹⁶⌋` (integer arithmetic, exact on both sides; K ≤ 2¹⁶), its
//! low half the cosine `((w mod 2¹⁶) + ½)·2⁻¹⁵ − 1` (a grid of 2⁻¹⁵, far finer than anything
//! the cross term can resolve).
//!
//! Two uses ([`DiscrepancyUse`]): the robot's own deviation (the default of every analysis: the
//! tracker noise that is part of the residuals is taken out, by the share of the residual
//! variance it explains when the noise is known), or what a new *measurement* would show
//! (noise kept: the self-check and held-out validation compare against measured positions).
//!
//! Isotropy is an approximation: real residuals are larger along some directions (gravity). It
//! only enters through the cross term `2|Δp|rc`, which is small where the discrepancy dominates,
//! and the per-point norms keep their empirical distribution exactly.

mod estimate;
pub mod gp;
pub mod size;
#[cfg(test)]
mod tests;

pub use estimate::{
    random_subsets, standardised_norms, standardised_residuals, CompensationReport, Configurations,
    FittedPoint, LackOfFit, LooCheck, NoiseSource, MIN_RESIDUALS, SIGNIFICANCE,
};
pub use gp::Compensation;

use serde::{Deserialize, Serialize};

/// Largest number of residual norms a term holds (the integer index rule needs K ≤ 2¹⁶; more
/// residuals are thinned evenly by rank).
pub const MAX_SAMPLES: usize = 1 << 16;

/// The discrepancy term of a model: the norms of the identification's standardised residuals
/// and how much of them is the robot's.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Discrepancy {
    /// Norms of the standardised residuals, mm, ascending (each at most [`MAX_SAMPLES`]).
    pub residual_norms: Vec<f64>,
    /// The share of the residuals' mean square that is the robot's (not measurement noise),
    /// 0 … 1: 1 when the noise is unknown (the term then carries the tracker noise too).
    pub robot_share: f64,
    /// Where the measurement noise came from.
    pub noise: NoiseSource,
    /// Measurement noise σ per coordinate, mm, when known.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise_sigma_mm: Option<f64>,
    /// The compensation whose mean the model adds to its prediction (then the norms are what
    /// it leaves); `None` when a geometric model predicts as well.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub compensation: Option<Compensation>,
}

/// Errors of a discrepancy term read from a file or built from residuals.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum DiscrepancyError {
    /// A field out of range (the field as the model file spells it).
    #[error("{field}: {message}")]
    Invalid {
        /// The field, e.g. `discrepancy.robot_share`.
        field: String,
        /// What is wrong.
        message: String,
    },
}

fn invalid(field: &str, message: impl Into<String>) -> DiscrepancyError {
    DiscrepancyError::Invalid {
        field: format!("discrepancy.{field}"),
        message: message.into(),
    }
}

impl Discrepancy {
    /// Checks a term as a model file gives it: [`MIN_RESIDUALS`] to [`MAX_SAMPLES`] finite,
    /// non-negative norms below 10 m, a share in [0, 1], a finite positive noise σ when one is
    /// given. The norms are sorted.
    ///
    /// # Errors
    ///
    /// [`DiscrepancyError::Invalid`] naming the field.
    pub fn checked(mut self) -> Result<Discrepancy, DiscrepancyError> {
        let n = self.residual_norms.len();
        if !(MIN_RESIDUALS..=MAX_SAMPLES).contains(&n) {
            return Err(invalid(
                "residual_norms",
                format!(
                    "{n} values: a discrepancy term needs {MIN_RESIDUALS} to {MAX_SAMPLES} residuals"
                ),
            ));
        }
        if let Some((i, v)) = self
            .residual_norms
            .iter()
            .enumerate()
            .find(|(_, v)| !(v.is_finite() && **v >= 0.0 && **v < 1e4))
        {
            return Err(invalid(
                "residual_norms",
                format!("value {} is {v}: norms are finite, 0 … 10000 mm", i + 1),
            ));
        }
        if !(0.0..=1.0).contains(&self.robot_share) {
            return Err(invalid(
                "robot_share",
                format!("{} is not a share in 0 … 1", self.robot_share),
            ));
        }
        if let Some(s) = self.noise_sigma_mm {
            if !(s.is_finite() && s > 0.0 && s < 1e3) {
                return Err(invalid(
                    "noise_sigma_mm",
                    format!("{s} is not a σ in mm (finite, positive, below 1000)"),
                ));
            }
        }
        if self.noise_sigma_mm.is_none() && self.noise != NoiseSource::Unknown {
            return Err(invalid(
                "noise_sigma_mm",
                format!(
                    "missing: noise = \"{}\" needs the σ it found",
                    self.noise.as_str()
                ),
            ));
        }
        self.residual_norms.sort_by(f64::total_cmp);
        Ok(self)
    }

    /// Whether analyses of the robot draw it: some of the residual is the robot's (share > 0),
    /// or, with the residuals close to the stated noise (share 0), some draws of the size's
    /// posterior leave a part the noise does not explain ([`size`]). A term whose every draw is
    /// noise (residuals well below the stated noise) is kept for comparisons with measurements,
    /// which include the noise.
    pub fn drawn(&self) -> bool {
        self.robot_share > 0.0
            || self
                .draw_factors(DiscrepancyUse::Robot)
                .last()
                .is_some_and(|&g| g > 0.0)
    }

    /// The part of the norms' mean square that is measurement noise, for the robot: `1 − share`
    /// when the share is positive, the stated noise's `3σ²` over the mean square when the share
    /// is 0 (it can exceed 1), 0 when the noise is unknown.
    fn noise_part(&self) -> f64 {
        if self.robot_share > 0.0 {
            return 1.0 - self.robot_share;
        }
        let ms = self.rms_mm().powi(2);
        match self.noise_sigma_mm {
            Some(s) if self.noise != NoiseSource::Unknown && ms > 0.0 => 3.0 * s * s / ms,
            _ => 1.0,
        }
    }

    /// The factors a run multiplies the radii ([`Self::radii`]) of each draw by: [`size::SIZE_DRAWS`]
    /// quantiles of the posterior of the term's size, ascending (see [`size`]). For the robot
    /// `√(max(0, ms_k/ms − noise part))`, for a measurement `√(ms_k/ms)`.
    pub fn draw_factors(&self, usage: DiscrepancyUse) -> Vec<f64> {
        let ratios = size::mean_square_ratios(&self.residual_norms);
        let noise = match usage {
            DiscrepancyUse::Robot => self.noise_part(),
            DiscrepancyUse::Measured => 0.0,
        };
        size::factors(&ratios, noise)
    }

    /// The 95 % upper bound of the robot's own RMS (mm) the residuals allow: the size's
    /// posterior quantile.
    pub fn robot_rms_upper_mm(&self) -> f64 {
        let g = self.draw_factors(DiscrepancyUse::Robot);
        self.rms_mm() * g[(0.95 * g.len() as f64).ceil() as usize - 1]
    }

    /// A term drawn from `norms` (mm; thinned by rank to [`MAX_SAMPLES`]) with the noise
    /// `noise` of σ `noise_sigma_mm` per coordinate: the robot's share is the norms' mean square
    /// beyond the stated noise's (1 when the noise is not stated), as a fit's term has it.
    pub fn from_norms(
        norms: &[f64],
        noise: NoiseSource,
        noise_sigma_mm: Option<f64>,
        compensation: Option<Compensation>,
    ) -> Discrepancy {
        let ms = norms.iter().map(|r| r * r).sum::<f64>() / norms.len().max(1) as f64;
        let robot_share = match (noise, noise_sigma_mm) {
            (NoiseSource::Stated, Some(s)) if ms > 0.0 => (1.0 - 3.0 * s * s / ms).clamp(0.0, 1.0),
            (NoiseSource::Stated, Some(_)) => 0.0,
            _ => 1.0,
        };
        Discrepancy {
            residual_norms: estimate::thin(norms),
            robot_share,
            noise,
            noise_sigma_mm: noise_sigma_mm.filter(|_| noise == NoiseSource::Stated),
            compensation,
        }
    }

    /// The term of several runs' mean model: every run's norms (thinned to [`MAX_SAMPLES`] by
    /// rank), the shares weighted by the runs' residual counts, the noise σ as the RMS of the
    /// runs' (stated only when every run stated it). `None` when no run has a term.
    pub fn pooled(terms: &[&Discrepancy]) -> Option<Discrepancy> {
        let count: usize = terms.iter().map(|t| t.residual_norms.len()).sum();
        if count == 0 {
            return None;
        }
        let norms: Vec<f64> = terms
            .iter()
            .flat_map(|t| t.residual_norms.iter().copied())
            .collect();
        let weight = |t: &Discrepancy| t.residual_norms.len() as f64 / count as f64;
        let stated = terms.iter().all(|t| t.noise == NoiseSource::Stated);
        let sigma = stated.then(|| {
            terms
                .iter()
                .map(|t| weight(t) * t.noise_sigma_mm.unwrap_or(0.0).powi(2))
                .sum::<f64>()
                .sqrt()
        });
        Some(Discrepancy {
            residual_norms: estimate::thin(&norms),
            robot_share: if stated {
                terms.iter().map(|t| weight(t) * t.robot_share).sum()
            } else {
                1.0
            },
            noise: if stated {
                NoiseSource::Stated
            } else {
                NoiseSource::Unknown
            },
            noise_sigma_mm: sigma,
            // Each run's compensation is conditioned on its own poses; their mean is no process
            // of its own, so the pooled term compensates nothing.
            compensation: None,
        })
    }

    /// The term a new calibration of the same robot is expected to leave, for planning it: the
    /// same norms and noise split, without the compensation (a new fit has its own), so a
    /// compensated term's norms go back to the geometric model's size (times its held-out RMS
    /// ratio, geometric over compensated). Conservative when the new fit compensates too.
    pub fn for_new_calibration(&self) -> Discrepancy {
        let ratio = self.compensation.as_ref().map_or(1.0, |c| {
            if c.loo_rms_compensated_mm > 0.0 {
                (c.loo_rms_geometric_mm / c.loo_rms_compensated_mm).max(1.0)
            } else {
                1.0
            }
        });
        Discrepancy {
            residual_norms: self.residual_norms.iter().map(|r| r * ratio).collect(),
            compensation: None,
            ..self.clone()
        }
    }

    /// The factor the norms are drawn with at each configuration (radians): the
    /// compensation's [`Compensation::point_scales`]; empty (all 1) without one.
    pub fn point_scales<Q: AsRef<[f64]>>(&self, q_rad: &[Q]) -> Vec<f64> {
        match &self.compensation {
            None => Vec::new(),
            Some(c) => {
                let deg: Vec<Vec<f64>> = q_rad
                    .iter()
                    .map(|q| q.as_ref().iter().map(|v| v.to_degrees()).collect())
                    .collect();
                c.point_scales(&deg)
            }
        }
    }

    /// The compensation's correction at `q_deg` (robot base frame, mm; zero without one).
    pub fn correction_mm(&self, q_deg: &[f64]) -> [f64; 3] {
        self.compensation
            .as_ref()
            .map_or([0.0; 3], |c| c.correction_mm(q_deg))
    }

    /// RMS of the standardised residual norms, mm (what a new measurement misses by beyond the
    /// parameters' uncertainty, noise included).
    pub fn rms_mm(&self) -> f64 {
        let n = self.residual_norms.len().max(1) as f64;
        (self.residual_norms.iter().map(|r| r * r).sum::<f64>() / n).sqrt()
    }

    /// RMS of the robot's own part (noise taken out), mm.
    pub fn robot_rms_mm(&self) -> f64 {
        self.rms_mm() * self.robot_share.sqrt()
    }

    /// The radii an analysis draws: the norms, each draw's times its factor
    /// ([`Self::draw_factors`]: the robot's share of them, with its uncertainty).
    pub fn radii(&self) -> &[f64] {
        &self.residual_norms
    }

    /// One line for reports: size and noise split (and the compensation when there is one).
    pub fn describe(&self) -> String {
        let mut s = self.describe_term();
        if let Some(c) = &self.compensation {
            s.push_str(&format!(
                "; compensated by a Gaussian process over the configuration (held-out RMS {:.4} mm against {:.4} mm geometric)",
                c.loo_rms_compensated_mm, c.loo_rms_geometric_mm
            ));
        }
        s
    }

    fn describe_term(&self) -> String {
        match self.noise {
            NoiseSource::Unknown => format!(
                "model discrepancy drawn from {} residuals (RMS {:.4} mm; measurement noise unknown, so it is included)",
                self.residual_norms.len(),
                self.rms_mm()
            ),
            _ => format!(
                "model discrepancy drawn from {} residuals (RMS {:.4} mm of which the robot's own {:.4} mm, up to {:.4} mm at 95 %, each draw its own size; {} noise σ {:.4} mm per coordinate taken out)",
                self.residual_norms.len(),
                self.rms_mm(),
                self.robot_rms_mm(),
                self.robot_rms_upper_mm(),
                self.noise.as_str(),
                self.noise_sigma_mm.unwrap_or(0.0)
            ),
        }
    }
}

/// What a drawn discrepancy stands for.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DiscrepancyUse {
    /// The robot's own deviation from the model (measurement noise taken out): reliability.
    #[default]
    Robot,
    /// What a new measurement would show (noise kept): validation against measured positions.
    Measured,
}
