//! The discrepancy term from a fit's residuals, and the fit's own leave-one-out check of what it
//! predicts for a new measurement (docs/METHOD.md §18).
//!
//! Per point `i` the fit gives the residual `r_i` (mm), its whitening `W_i` (whitened = `W_i r`)
//! and the 3 × 3 leverage block `H_ii = J_i (JᵀJ + P)⁻¹ J_iᵀ` of the whitened Jacobian. Then
//!
//! * the standardised residual `W_i⁻¹ (I − H_ii)^{-1/2} W_i r_i` has the variance of a new
//!   measurement's deviation from the model *beyond* the parameters' uncertainty (plain
//!   residuals are smaller by the fit's leverage);
//! * the leave-one-out prediction error is `W_i⁻¹ (I − H_ii)⁻¹ W_i r_i` (exact for a linear
//!   model, the linearisation at the solution otherwise), and the parameters' part of its
//!   variance is `W_i⁻¹ H_ii (I − H_ii)⁻¹ W_i⁻ᵀ` (Woodbury), times the covariance's scale.
//!
//! The self-check predicts, for every point left out, the distribution of
//! `|N(0, parameters' part) + δ|` with `δ` drawn as the engine draws it from the *other* points'
//! standardised residual norms (measurement use: noise kept), and reports how often the 95 %
//! bound covers the left-out error, and the PIT of the maximum over random subsets of 20 points,
//! the quantity a reliability R is about.

mod loo;
use super::gp::{self, Compensation};
use super::size;
use super::{Discrepancy, MAX_SAMPLES};
pub use loo::random_subsets;
use loo::{loo_check, parameter_loo, Drawn};
use nalgebra::{Matrix3, Vector3};
use rand::{Rng, SeedableRng};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Fewest points from which a discrepancy term is estimated.
pub const MIN_RESIDUALS: usize = 10;

/// A stated noise is rejected (lack of fit found) below this χ² upper-tail probability.
pub const SIGNIFICANCE: f64 = 0.01;

/// Points per subset of the self-check's PIT of the maximum.
const SUBSET: usize = 20;

/// Where the measurement noise of a fit came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NoiseSource {
    /// Stated with the data or by the user (tracker σ or MPE).
    Stated,
    /// Not known: the residuals carry noise and lack of fit together.
    Unknown,
}

impl NoiseSource {
    /// The name in files and reports.
    pub fn as_str(self) -> &'static str {
        match self {
            NoiseSource::Stated => "stated",
            NoiseSource::Unknown => "unknown",
        }
    }
}

/// One fitted point as the estimate takes it.
#[derive(Clone, Copy, Debug)]
pub struct FittedPoint {
    /// Measured minus predicted position, mm.
    pub residual_mm: [f64; 3],
    /// The whitening `W_i` (whitened residual = `W_i · residual`).
    pub whiten: Matrix3<f64>,
    /// The leverage block `H_ii` in whitened units.
    pub leverage: Matrix3<f64>,
}

/// The leave-one-out self-check of a fit.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LooCheck {
    /// Fraction of points whose left-out error is inside its predicted 95 % bound, with the
    /// discrepancy term.
    pub coverage_95: f64,
    /// The same with the parameters' uncertainty alone.
    pub coverage_95_parameters_only: f64,
    /// Mean PIT of the maximum left-out error over random subsets of 20 points (ideal 0.5).
    pub pit_max_mean: f64,
    /// Fraction of those subsets with PIT ≥ 0.99 (ideal 0.01).
    pub pit_max_at_least_099: f64,
    /// Subsets drawn.
    pub subsets: usize,
}

/// What the residuals say about the model's lack of fit.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LackOfFit {
    /// Points.
    pub points: usize,
    /// RMS of the standardised residual norms, mm.
    pub residual_rms_mm: f64,
    /// Where the noise came from.
    pub noise: NoiseSource,
    /// Noise σ per coordinate, mm, when known.
    pub noise_sigma_mm: Option<f64>,
    /// `Pr[χ² > observed]` under the stated noise.
    pub p_value: Option<f64>,
    /// Lack of fit found (stated noise rejected at [`SIGNIFICANCE`]); `None` when it cannot
    /// be told (noise unknown).
    pub found: Option<bool>,
    /// RMS of what the model does not explain, noise taken out (3-D), mm; `None` when the noise
    /// is unknown.
    pub unexplained_rms_mm: Option<f64>,
    /// The 95 % upper bound of that RMS the residuals allow (the posterior of the term's size,
    /// [`super::size`]); `None` when the noise is unknown, the points are too few, or the
    /// residuals rule out any part beyond the noise.
    pub unexplained_upper_mm: Option<f64>,
    /// Share of the residual mean square that is the robot's.
    pub robot_share: f64,
    /// The factor the parameters' covariance was scaled by (the geometric residuals' mean
    /// square over the stated noise's when that exceeds 1, else 1).
    pub covariance_scale: f64,
    /// The term the model carries (`None`: too few points); analyses of the robot draw it when
    /// [`Self::carried`] (a term of share 0 only serves comparisons with measurements).
    #[serde(skip)]
    pub term: Option<Discrepancy>,
    /// Whether analyses of the robot draw the term (some lack of fit, or the noise unknown).
    pub carried: bool,
    /// The leave-one-out self-check (`None` for fewer than [`MIN_RESIDUALS`] points).
    pub loo: Option<LooCheck>,
    /// The compensation by a Gaussian process over the configuration (`None`: not tried).
    pub compensation: Option<CompensationReport>,
    /// What it means, in words ([`Self::summary`]; in JSON reports).
    pub summary: String,
}

/// What the compensation search found.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CompensationReport {
    /// Whether the model carries it (it predicts left-out poses better by [`gp::MIN_GAIN`]).
    pub applied: bool,
    /// Leave-one-out RMS of the geometric model (standardised residuals), mm.
    pub loo_rms_geometric_mm: f64,
    /// The same with the compensation (`None`: no process fitted).
    pub loo_rms_compensated_mm: Option<f64>,
    /// Length scales per joint, degrees.
    pub length_scales_deg: Vec<f64>,
    /// σ_f of the smooth part, mm per coordinate.
    pub signal_sigma_mm: Option<f64>,
    /// σ_w of the white part, mm per coordinate.
    pub white_sigma_mm: Option<f64>,
    /// Why no process was fitted.
    pub not_fitted: Option<String>,
    /// How the held-out RMS was found: 5-fold cross-validation (hyperparameters refitted per
    /// fold) or the closed-form leave-one-out, each point alone or by runs of consecutive
    /// points (the names in [`gp::held_out`]'s module).
    pub validation: &'static str,
}

impl CompensationReport {
    /// One sentence.
    pub fn sentence(&self) -> String {
        match (self.loo_rms_compensated_mm, &self.not_fitted) {
            (_, Some(why)) => format!(
                " No compensation: a Gaussian process over the joint configuration was not fitted ({why})."
            ),
            (Some(after), _) if self.applied => format!(
                " A Gaussian process over the joint configuration predicts part of it: with its mean added to the model's prediction (compensation) the held-out RMS ({}) is {after:.4} mm against {:.4} mm for the geometric model ({:+.0} %); the model carries it and the discrepancy term is what it leaves.",
                self.validation,
                self.loo_rms_geometric_mm,
                100.0 * (after / self.loo_rms_geometric_mm - 1.0)
            ),
            (Some(after), _) => format!(
                " A Gaussian process over the joint configuration predicts no more of it (held-out RMS by {} {after:.4} mm against {:.4} mm): no compensation.",
                self.validation,
                self.loo_rms_geometric_mm
            ),
            (None, None) => String::new(),
        }
    }
}

/// The configurations of the fitted points, for the compensation.
#[derive(Clone, Copy, Debug)]
pub struct Configurations<'a> {
    /// Joint angles per point, radians.
    pub q_rad: &'a [Vec<f64>],
    /// Rotation from the frame of the residuals (measurement) into the robot base frame.
    pub to_base: Matrix3<f64>,
    /// Runs of consecutive points the compensation's check leaves out together (the arcs of
    /// circle-point sweeps, [`gp::held_out`]); empty: each point alone.
    pub groups: &'a [std::ops::Range<usize>],
}

/// `A^{-1/2}` of a symmetric positive definite 3 × 3 (identity when it is not).
fn inv_sqrt(a: &Matrix3<f64>) -> Matrix3<f64> {
    let eig = a.symmetric_eigen();
    let mut d = Matrix3::zeros();
    for k in 0..3 {
        let l = eig.eigenvalues[k];
        d[(k, k)] = if l > 1e-12 { 1.0 / l.sqrt() } else { 1e6 };
    }
    eig.eigenvectors * d * eig.eigenvectors.transpose()
}

/// The standardised residuals (mm) of `points`.
pub fn standardised_residuals(points: &[FittedPoint]) -> Vec<Vector3<f64>> {
    points
        .iter()
        .map(|p| {
            let w_inv = p.whiten.try_inverse().unwrap_or_else(Matrix3::identity);
            let z = inv_sqrt(&(Matrix3::identity() - p.leverage))
                * (p.whiten * Vector3::from(p.residual_mm));
            w_inv * z
        })
        .collect()
}

/// Norms of the standardised residuals, mm.
pub fn standardised_norms(points: &[FittedPoint]) -> Vec<f64> {
    standardised_residuals(points)
        .iter()
        .map(|v| v.norm())
        .collect()
}

impl LackOfFit {
    /// The lack of fit of a fit with `points`, whose noise (per-point whitening) is stated when
    /// `stated` (σ² = the mean per-coordinate variance of the whitenings) with χ² upper tail
    /// `p_value`, else estimated from the residuals. `seed` drives the self-check's draws.
    pub fn estimate(
        points: &[FittedPoint],
        stated: bool,
        p_value: Option<f64>,
        seed: u64,
    ) -> LackOfFit {
        Self::estimate_with(points, None, stated, p_value, seed, true)
    }

    /// [`Self::estimate`], and with `configurations` a compensation by a Gaussian process over
    /// the configuration ([`gp`]): kept when it predicts left-out points better, the term is then
    /// drawn from what it leaves. Without `self_check` the leave-one-out self-check is left out
    /// (`loo` is `None`; for a fit whose lack of fit is only an intermediate).
    pub fn estimate_with(
        points: &[FittedPoint],
        configurations: Option<Configurations<'_>>,
        stated: bool,
        p_value: Option<f64>,
        seed: u64,
        self_check: bool,
    ) -> LackOfFit {
        let n = points.len();
        let mut standardised = standardised_residuals(points);
        let ms_geometric = gp::rms(&standardised).powi(2);
        let mut left_out = parameter_loo(points);
        let mut compensation = None;
        let mut scales = vec![1.0; n];
        let report = configurations.map(|c| {
            let (report, kept) = compensate(points, c, &standardised, &left_out, seed);
            if let Some((comp, z, u, s)) = kept {
                compensation = Some(comp);
                standardised = z;
                left_out = u;
                scales = s;
            }
            report
        });
        let norms: Vec<f64> = standardised.iter().map(|v| v.norm()).collect();
        let ms = norms.iter().map(|r| r * r).sum::<f64>() / n.max(1) as f64;
        let (noise, sigma) = if stated {
            let var = points
                .iter()
                .map(|p| {
                    let w_inv = p.whiten.try_inverse().unwrap_or_else(Matrix3::identity);
                    (w_inv * w_inv.transpose()).trace() / 3.0
                })
                .sum::<f64>()
                / n.max(1) as f64;
            (NoiseSource::Stated, Some(var.sqrt()))
        } else {
            (NoiseSource::Unknown, None)
        };
        let found = match (noise, p_value) {
            (NoiseSource::Stated, Some(p)) => Some(p < SIGNIFICANCE),
            _ => None,
        };
        // The excess of the residuals over the stated noise (its positive part), whether or
        // not the χ² test calls it significant: a lack of fit too small for the test still adds
        // to every error.
        let robot_share = match sigma {
            Some(s) if ms > 0.0 => (1.0 - 3.0 * s * s / ms).clamp(0.0, 1.0),
            Some(_) => 0.0,
            None => 1.0,
        };
        // The parameters see the lack of fit as noise of the residuals' size, by the same rule:
        // whenever the residuals exceed the stated noise. The factor is the geometric
        // residuals' mean square over the noise's (what the fit saw, before any compensation),
        // not χ²/dof: with per-pose σs that differ, χ² is dominated by the poses stated most
        // precise, and the covariance would be inflated by far more than the residuals are
        // larger than the noise (on the UR10 data 1476 against 95).
        let covariance_scale = match sigma {
            Some(s) if noise == NoiseSource::Stated => (ms_geometric / (3.0 * s * s)).max(1.0),
            _ => 1.0,
        };
        let enough = n >= MIN_RESIDUALS;
        let ratios = size::mean_square_ratios(&norms);
        let term = enough.then(|| Discrepancy {
            residual_norms: thin(&norms),
            robot_share,
            noise,
            noise_sigma_mm: sigma,
            compensation,
        });
        let loo = (enough && self_check).then(|| {
            loo_check(
                points,
                Drawn {
                    left_out: &left_out,
                    norms: &norms,
                    scales: &scales,
                    factors: &size::factors(&ratios, 0.0),
                },
                covariance_scale,
                seed,
            )
        });
        let mut lof = LackOfFit {
            points: n,
            residual_rms_mm: ms.sqrt(),
            noise,
            noise_sigma_mm: sigma,
            p_value,
            found,
            unexplained_rms_mm: sigma.map(|_| (ms * robot_share).sqrt()),
            robot_share,
            covariance_scale,
            carried: term.as_ref().is_some_and(Discrepancy::drawn),
            unexplained_upper_mm: term
                .as_ref()
                .filter(|_| noise == NoiseSource::Stated)
                .map(Discrepancy::robot_rms_upper_mm)
                .filter(|&v| v > 0.0),
            term,
            loo,
            compensation: report,
            summary: String::new(),
        };
        lof.summary = lof.summary();
        lof
    }

    /// What the lack of fit means, in words (one or two sentences).
    pub fn summary(&self) -> String {
        let mut s = match (self.noise, self.found) {
            (NoiseSource::Stated, Some(true)) => format!(
                "The residuals (RMS {:.4} mm) are larger than the stated measurement noise (σ {:.4} mm per coordinate, p = {:.1e}): the geometric model leaves {:.4} mm RMS unexplained (compliance, gear errors, drift), {:.0} % of the residual.",
                self.residual_rms_mm,
                self.noise_sigma_mm.unwrap_or(0.0),
                self.p_value.unwrap_or(0.0),
                self.unexplained_rms_mm.unwrap_or(0.0),
                100.0 * self.robot_share
            ),
            (NoiseSource::Stated, _) => format!(
                "The residuals (RMS {:.4} mm) agree with the stated measurement noise (σ {:.4} mm per coordinate, p = {:.2}): no significant lack of fit{}.",
                self.residual_rms_mm,
                self.noise_sigma_mm.unwrap_or(0.0),
                self.p_value.unwrap_or(1.0),
                if self.carried {
                    format!(
                        "; an unexplained part too small for the test ({:.4} mm RMS estimated, up to {:.4} mm at 95 %) may still be there, and is kept",
                        self.unexplained_rms_mm.unwrap_or(0.0),
                        self.unexplained_upper_mm.unwrap_or(0.0)
                    )
                } else {
                    String::new()
                }
            ),
            (NoiseSource::Unknown, _) => format!(
                "The residuals (RMS {:.4} mm) hold measurement noise and whatever the geometric model does not explain; without a stated tracker σ the two cannot be told apart.",
                self.residual_rms_mm
            ),
        };
        if self.carried {
            s.push_str(match self.noise {
                NoiseSource::Unknown => " The model carries a discrepancy term drawn from the residuals (noise included, so reliability figures are conservative by the tracker noise); every analysis draws it.",
                NoiseSource::Stated => " The model carries a discrepancy term drawn from the residuals with the noise taken out, its size drawn with the uncertainty the residuals leave, and every analysis draws it; the parameters' covariance is scaled by the residuals' mean square over the noise's.",
            });
        } else if self.points < MIN_RESIDUALS && self.found != Some(false) {
            s.push_str(&format!(
                " Too few points ({} < {MIN_RESIDUALS}) to estimate a discrepancy term: reliability figures leave any lack of fit out.",
                self.points
            ));
        }
        if let Some(c) = &self.compensation {
            s.push_str(&c.sentence());
        }
        if let Some(l) = &self.loo {
            s.push_str(&format!(
                " Leave-one-out check: the predicted 95 % error bound covers {:.1} % of left-out measurements ({:.1} % from the parameters' uncertainty alone).",
                100.0 * l.coverage_95,
                100.0 * l.coverage_95_parameters_only
            ));
        }
        s
    }
}

/// At most [`MAX_SAMPLES`] norms: all, or evenly spaced ranks of the sorted ones.
pub(super) fn thin(norms: &[f64]) -> Vec<f64> {
    let mut v = norms.to_vec();
    v.sort_by(f64::total_cmp);
    if v.len() <= MAX_SAMPLES {
        return v;
    }
    let n = v.len();
    (0..MAX_SAMPLES)
        .map(|k| v[(k * n + n / 2) / MAX_SAMPLES])
        .collect()
}

/// A standard normal (Box–Muller; the self-check needs no counter-based reproducibility).
pub(super) fn gaussian(rng: &mut impl Rng) -> f64 {
    let u: f64 = 1.0 - rng.random::<f64>();
    (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * rng.random::<f64>()).cos()
}

/// What a compensated model leaves of `standardised` and `left_out`.
/// (with the norms at the reference σ, and each point's scale).
type Kept = (Compensation, Vec<Vector3<f64>>, Vec<Vector3<f64>>, Vec<f64>);

/// Fits the compensation to the points' residuals and keeps it when its leave-one-out RMS beats
/// the geometric model's by [`gp::required_gain`].
fn compensate(
    points: &[FittedPoint],
    c: Configurations<'_>,
    standardised: &[Vector3<f64>],
    left_out: &[Vector3<f64>],
    seed: u64,
) -> (CompensationReport, Option<Kept>) {
    let before = gp::rms(standardised);
    let mut report = CompensationReport {
        applied: false,
        loo_rms_geometric_mm: before,
        loo_rms_compensated_mm: None,
        length_scales_deg: Vec::new(),
        signal_sigma_mm: None,
        white_sigma_mm: None,
        not_fitted: None,
        validation: "",
    };
    let residuals: Vec<Vector3<f64>> = points
        .iter()
        .map(|p| Vector3::from(p.residual_mm))
        .collect();
    let fit = match gp::fit(c.q_rad, &residuals, seed) {
        Ok(f) => f,
        Err(e) => {
            report.not_fitted = Some(e.to_string());
            return (report, None);
        }
    };
    let held = match gp::held_out(
        &fit,
        c.q_rad,
        &residuals,
        &[standardised, left_out],
        c.groups,
        seed,
    ) {
        Ok(h) => h,
        Err(e) => {
            report.not_fitted = Some(format!("cross-validation: {e}"));
            return (report, None);
        }
    };
    report.validation = held.method;
    let z = &held.residuals[0];
    let after = gp::rms(z);
    // Each held-out residual in units of its own predictive σ, at the poses' RMS σ: the norms
    // drawn at a configuration are then scaled by its predictive σ over that reference.
    let sigmas = &held.sigmas;
    let reference = (sigmas.iter().map(|s| s * s).sum::<f64>() / sigmas.len().max(1) as f64).sqrt();
    let scaled: Vec<Vector3<f64>> = z
        .iter()
        .zip(sigmas)
        .map(|(v, s)| v * (reference / s))
        .collect();
    let scales: Vec<f64> = sigmas.iter().map(|s| s / reference).collect();
    report.loo_rms_compensated_mm = Some(after);
    report.length_scales_deg = fit.length_scales.iter().map(|l| l.to_degrees()).collect();
    report.signal_sigma_mm = Some(fit.signal_sigma);
    report.white_sigma_mm = Some(fit.white_sigma);
    if after >= (1.0 - gp::required_gain(points.len())) * before {
        return (report, None);
    }
    report.applied = true;
    let u = held.residuals[1].clone();
    let comp = fit.compensation(&c.to_base, before, after, reference);
    (report, Some((comp, scaled, u, scales)))
}
