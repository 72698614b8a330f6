//! The measurement noise of tracker data, as the identification weights it
//! (docs/METHOD.md §2.6): where the standard uncertainty of each measured point comes from, the
//! whitening matrix `W` with `Wᵀ W = Σ⁻¹` that turns a residual into standard units, and the χ²
//! consistency of the residuals with a stated noise.

use crate::number::fmt_plain;
use nalgebra::{Matrix3, Vector3};
use serde::Serialize;

/// Where the noise of the measured points comes from.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum NoiseModel {
    /// Unknown: estimated from the residuals, `s² = Σ‖r‖² / (3n − p)`, the same σ for every
    /// coordinate.
    FromResiduals,
    /// The data's own `sx, sy, sz` per point.
    PerPoint,
    /// A plain σ per coordinate, mm.
    Isotropic {
        /// σ, mm.
        sigma_mm: f64,
    },
    /// A laser tracker at `position_mm` (in the data's frame) with a point MPE of
    /// `±(constant_um + per_metre_um · L)` across the line of sight and `±radial_um` along it,
    /// each MPE standing for `mpe_sigmas` σ (the AT960 model of the simulator's tracker).
    Tracker {
        /// Constant part of the transverse MPE, µm.
        constant_um: f64,
        /// Distance-proportional part of the transverse MPE, µm per metre.
        per_metre_um: f64,
        /// MPE along the line of sight, µm.
        radial_um: f64,
        /// σ per MPE.
        mpe_sigmas: f64,
        /// Tracker position in the data's frame, mm.
        position_mm: [f64; 3],
    },
    /// No σ stated, but poses measured several times: σ per coordinate is the pooled scatter
    /// of the repeats about their pose's mean (pure error, docs/METHOD.md §2.6), and each pose
    /// enters the fit as its mean with σ/√k ([`super::repeats`]).
    PureError {
        /// Pooled σ per coordinate, mm.
        sigma_mm: f64,
        /// Degrees of freedom pooled over x, y, z: `3 Σ (k_i − 1)`.
        dof: usize,
        /// Poses measured more than once.
        repeated: usize,
        /// Fewest measurements of a repeated pose.
        min_k: usize,
        /// Most measurements of a repeated pose.
        max_k: usize,
    },
}

impl NoiseModel {
    /// The default for `data`: the data's own `sx, sy, sz` when every point has them, else
    /// the pure error of repeated measurements when poses were measured more than once, else
    /// estimated from the residuals.
    pub fn default_for(data: &super::TrackerData) -> NoiseModel {
        if data.has_sigmas() {
            return NoiseModel::PerPoint;
        }
        match data {
            super::TrackerData::Poses(p) => super::repeats::pure_error(&p.runs)
                .map_or(NoiseModel::FromResiduals, |e| e.noise_model()),
            super::TrackerData::Sweeps(_) => NoiseModel::FromResiduals,
        }
    }

    /// For [`NoiseModel::PureError`], the lack-of-fit test's `Pr[F > χ²/dof]` with `(dof,
    /// pure-error dof)` degrees of freedom: the whitened residuals' `χ²` over `dof` (of the pose
    /// means) is the lack-of-fit mean square over the pure-error one, an F variate when the
    /// model fits (σ was estimated, so χ² would overstate the evidence). `None` for other models.
    pub fn pure_error_p_value(&self, chi2: f64, dof: usize) -> Option<f64> {
        match self {
            NoiseModel::PureError { dof: pe, .. } if dof > 0 && *pe > 0 => {
                Some(f_upper_tail(chi2 / dof as f64, dof as f64, *pe as f64))
            }
            _ => None,
        }
    }

    /// Whether the noise is stated (not estimated from the residuals).
    pub fn is_stated(&self) -> bool {
        !matches!(self, NoiseModel::FromResiduals)
    }

    /// A tracker model with every MPE part divided by `factor` (the noise of the mean of
    /// `factor²` measurements at one point); other models unchanged.
    pub fn mpe_divided_by(&self, factor: f64) -> NoiseModel {
        match *self {
            NoiseModel::Tracker {
                constant_um,
                per_metre_um,
                radial_um,
                mpe_sigmas,
                position_mm,
            } => NoiseModel::Tracker {
                constant_um: constant_um / factor,
                per_metre_um: per_metre_um / factor,
                radial_um: radial_um / factor,
                mpe_sigmas,
                position_mm,
            },
            other => other,
        }
    }

    /// One line saying where σ came from.
    pub fn describe(&self) -> String {
        match self {
            NoiseModel::FromResiduals => "estimated from the residuals".into(),
            NoiseModel::PerPoint => "the data's sx, sy, sz per point".into(),
            NoiseModel::Isotropic { sigma_mm } => format!("stated: {sigma_mm} mm per coordinate"),
            NoiseModel::Tracker {
                constant_um,
                per_metre_um,
                radial_um,
                mpe_sigmas,
                ..
            } => format!(
                "stated tracker model: MPE ±({constant_um} µm + {per_metre_um} µm/m) across the \
                 line of sight, ±{radial_um} µm along it, MPE = {mpe_sigmas}σ"
            ),
            NoiseModel::PureError {
                sigma_mm,
                dof,
                repeated,
                min_k,
                max_k,
            } => format!(
                "from repeated measurements (pure error): {repeated} poses measured {} times, σ = {} mm per coordinate ({dof} degrees of freedom over x, y, z); each pose enters as its mean, σ/√k",
                if min_k == max_k { min_k.to_string() } else { format!("{min_k}–{max_k}") },
                fmt_sig(*sigma_mm)
            ),
        }
    }

    /// The whitening matrix of a point measured at `p` (data frame, mm) with the stated
    /// per-point σ `sigma` (when the data have them; for [`Self::PureError`] a pose mean's
    /// σ/√k, the pooled σ without); the identity for [`Self::FromResiduals`] (scaled later by
    /// the estimated σ). `None` when the model needs per-point σ and the point has none.
    pub fn whiten(&self, p: &[f64; 3], sigma: Option<[f64; 3]>) -> Option<Matrix3<f64>> {
        match self {
            NoiseModel::FromResiduals => Some(Matrix3::identity()),
            NoiseModel::PerPoint => sigma
                .map(|s| Matrix3::from_diagonal(&Vector3::new(1.0 / s[0], 1.0 / s[1], 1.0 / s[2]))),
            NoiseModel::Isotropic { sigma_mm } => Some(Matrix3::identity() / *sigma_mm),
            NoiseModel::PureError { sigma_mm, .. } => Some(sigma.map_or_else(
                || Matrix3::identity() / *sigma_mm,
                |s| Matrix3::from_diagonal(&Vector3::new(1.0 / s[0], 1.0 / s[1], 1.0 / s[2])),
            )),
            NoiseModel::Tracker {
                constant_um,
                per_metre_um,
                radial_um,
                mpe_sigmas,
                position_mm,
            } => {
                let d = Vector3::from(*p) - Vector3::from(*position_mm);
                let l = d.norm();
                let sigma_t = (constant_um + per_metre_um * l / 1000.0) / 1000.0 / mpe_sigmas;
                let sigma_r = radial_um / 1000.0 / mpe_sigmas;
                if l == 0.0 {
                    return Some(Matrix3::identity() / sigma_t.min(sigma_r));
                }
                let u = d / l;
                let radial = u * u.transpose();
                Some(radial / sigma_r + (Matrix3::identity() - radial) / sigma_t)
            }
        }
    }
}

/// σ per MPE of a tracker's stated MPE.
const MPE_SIGMAS: f64 = 2.0;
/// The MPE along the line of sight when none is given, µm.
const DEFAULT_RADIAL_UM: f64 = 10.0;

/// Smallest stated standard uncertainty of a coordinate, mm (1 nm): below it the weights
/// `1/σ²` leave the range of f64 in the normal equations long before any instrument does.
pub const MIN_SIGMA_MM: f64 = 1e-9;
/// Largest stated standard uncertainty of a coordinate, mm (1 m): no measurement of a robot's
/// position is that poor, and far above it the weights underflow.
pub const MAX_SIGMA_MM: f64 = 1e3;

/// Whether `sigma_mm` is a usable stated standard uncertainty: within [`MIN_SIGMA_MM`] …
/// [`MAX_SIGMA_MM`].
pub fn sigma_in_range(sigma_mm: f64) -> bool {
    (MIN_SIGMA_MM..=MAX_SIGMA_MM).contains(&sigma_mm)
}

/// A noise setting that cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NoiseSettingError {
    /// σ per coordinate not a number of mm within [`MIN_SIGMA_MM`] … [`MAX_SIGMA_MM`].
    #[error("{} mm is not a usable σ per coordinate: it must be within {MIN_SIGMA_MM:e} … {MAX_SIGMA_MM} mm", fmt_plain(*.0))]
    Sigma(f64),
    /// MPE parts not two or three numbers whose σ (MPE/2) are within [`MIN_SIGMA_MM`] …
    /// [`MAX_SIGMA_MM`] (A and R; B at most as large per metre).
    #[error(
        "A,B[,R] must be two or three numbers (µm, µm/m, µm) with A and R within {lo} … {hi} µm and 0 ≤ B ≤ {hi} µm/m (each MPE is 2σ, and σ must be within {MIN_SIGMA_MM:e} … {MAX_SIGMA_MM} mm), got {got}",
        lo = fmt_plain(MIN_SIGMA_MM * MPE_SIGMAS * 1e3),
        hi = fmt_plain(MAX_SIGMA_MM * MPE_SIGMAS * 1e3),
        got = .0.iter().map(|v| fmt_plain(*v)).collect::<Vec<_>>().join(",")
    )]
    Mpe(Vec<f64>),
    /// Tracker position not three finite numbers.
    #[error("x, y, z must be three finite numbers of mm, got {0:?}")]
    Position(Vec<f64>),
    /// Tracker position farther than [`MAX_TRACKER_RANGE_MM`] from a measured point.
    #[error(
        "the tracker at ({}) mm is {} m from the farthest measured point; a laser tracker measures within {} m (a position in metres, or a slip?)",
        .at.iter().map(|v| fmt_plain(*v)).collect::<Vec<_>>().join(", "),
        fmt_plain(.farthest_mm / 1e3),
        fmt_plain(MAX_TRACKER_RANGE_MM / 1e3)
    )]
    Range {
        /// The position given, mm.
        at: Vec<f64>,
        /// Its distance to the farthest measured point, mm.
        farthest_mm: f64,
    },
}

/// Farthest a tracker may stand from a measured point, mm: laser trackers measure within a
/// radius of 80 m at most (Leica AT960: 160 m in diameter); 100 m leaves room.
pub const MAX_TRACKER_RANGE_MM: f64 = 100_000.0;

/// Every measured position of `data`, mm, in the data's frame.
fn measured_positions(data: &super::TrackerData) -> Box<dyn Iterator<Item = [f64; 3]> + '_> {
    match data {
        super::TrackerData::Poses(p) => Box::new(
            p.runs
                .iter()
                .flat_map(|r| r.points.iter().map(|q| q.position_mm)),
        ),
        super::TrackerData::Sweeps(d) => Box::new(d.runs.iter().flat_map(|r| {
            r.sweeps
                .iter()
                .flat_map(|s| s.points.iter().map(|q| q.position_mm))
        })),
    }
}

/// Which noise setting a [`NoiseSettingError`] is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoiseSetting {
    /// The plain σ per coordinate.
    Sigma,
    /// The tracker's MPE.
    Mpe,
    /// The tracker's position.
    Position,
}

impl NoiseSettingError {
    /// The setting at fault.
    pub fn setting(&self) -> NoiseSetting {
        match self {
            Self::Sigma(_) => NoiseSetting::Sigma,
            Self::Mpe(_) => NoiseSetting::Mpe,
            Self::Position(_) | Self::Range { .. } => NoiseSetting::Position,
        }
    }
}

impl NoiseModel {
    /// The noise model of the settings: a plain σ per coordinate, or a tracker MPE `A,B[,R]`
    /// (µm, µm/m, µm; R defaults to 10 µm; MPE = 2σ) with the tracker at `position` (default:
    /// the data frame's origin), else [`NoiseModel::default_for`] the data.
    ///
    /// # Errors
    ///
    /// [`NoiseSettingError`] naming a σ that is not positive, MPE parts that are not usable, a
    /// position that is not three finite numbers.
    pub fn from_settings(
        sigma_mm: Option<f64>,
        mpe: Option<&[f64]>,
        position: Option<&[f64]>,
        data: &super::TrackerData,
    ) -> Result<NoiseModel, NoiseSettingError> {
        if let Some(s) = sigma_mm {
            if !sigma_in_range(s) {
                return Err(NoiseSettingError::Sigma(s));
            }
            return Ok(NoiseModel::Isotropic { sigma_mm: s });
        }
        let Some(m) = mpe else {
            return Ok(NoiseModel::default_for(data));
        };
        // σ in mm of an MPE part in µm.
        let sigma = |um: f64| um / 1e3 / MPE_SIGMAS;
        let radial = m.get(2).copied().unwrap_or(DEFAULT_RADIAL_UM);
        if !(2..=3).contains(&m.len())
            || !sigma_in_range(sigma(m[0]))
            || !sigma_in_range(sigma(radial))
            || !(0.0..=MAX_SIGMA_MM).contains(&sigma(m[1]))
        {
            return Err(NoiseSettingError::Mpe(m.to_vec()));
        }
        let at = match position {
            None => [0.0; 3],
            Some(p) if p.len() == 3 && p.iter().all(|v| v.is_finite()) => [p[0], p[1], p[2]],
            Some(p) => return Err(NoiseSettingError::Position(p.to_vec())),
        };
        // A tracker farther from a measured point than any tracker measures gives σ the fit
        // cannot use (a position in metres, or a typing slip).
        let farthest = measured_positions(data)
            .map(|p| (p[0] - at[0]).hypot(p[1] - at[1]).hypot(p[2] - at[2]))
            .fold(0.0, f64::max);
        if farthest > MAX_TRACKER_RANGE_MM {
            return Err(NoiseSettingError::Range {
                at: at.to_vec(),
                farthest_mm: farthest,
            });
        }
        Ok(NoiseModel::Tracker {
            constant_um: m[0],
            per_metre_um: m[1],
            radial_um: radial,
            mpe_sigmas: MPE_SIGMAS,
            position_mm: at,
        })
    }
}

/// Standard normal upper tail `Pr[Z > z]` (complementary error function by a Chebyshev-fitted
/// rational approximation, relative error below 1.2e-7: Press et al., Numerical Recipes §6.2).
pub fn normal_upper_tail(z: f64) -> f64 {
    let x = z / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.5 * x.abs());
    let poly = -x * x - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98
                                + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let erfc = t * poly.exp();
    let erfc = if x >= 0.0 { erfc } else { 2.0 - erfc };
    0.5 * erfc
}

/// σ in mm to 0.01 µm (scientific below 1 µm).
pub(crate) fn fmt_sig(v: f64) -> String {
    if v >= 1e-3 {
        format!("{v:.5}")
    } else {
        format!("{v:.3e}")
    }
}

/// `ln Γ(x)` for `x > 0` (Lanczos approximation, g = 7, nine terms; relative error ~1e-15).
fn ln_gamma(x: f64) -> f64 {
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // reflection: Γ(x) Γ(1 − x) = π / sin(πx)
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let t = x + 7.5;
    let series = C[1..]
        .iter()
        .enumerate()
        .fold(C[0], |acc, (i, c)| acc + c / (x + i as f64 + 1.0));
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + series.ln()
}

/// The continued fraction of the incomplete beta function (modified Lentz), valid for
/// `x < (a + 1) / (a + b + 2)`.
fn beta_fraction(a: f64, b: f64, x: f64) -> f64 {
    const TINY: f64 = 1e-300;
    let clamp = |v: f64| if v.abs() < TINY { TINY } else { v };
    let mut c = 1.0;
    let mut d = 1.0 / clamp(1.0 - (a + b) * x / (a + 1.0));
    let mut h = d;
    for m in 1..=300 {
        let m = m as f64;
        let even = m * (b - m) * x / ((a + 2.0 * m - 1.0) * (a + 2.0 * m));
        d = 1.0 / clamp(1.0 + even * d);
        c = clamp(1.0 + even / c);
        h *= d * c;
        let odd = -(a + m) * (a + b + m) * x / ((a + 2.0 * m) * (a + 2.0 * m + 1.0));
        d = 1.0 / clamp(1.0 + odd * d);
        c = clamp(1.0 + odd / c);
        let step = d * c;
        h *= step;
        if (step - 1.0).abs() < 1e-14 {
            break;
        }
    }
    h
}

/// The regularised incomplete beta function `I_x(a, b)`.
fn incomplete_beta(a: f64, b: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    let front =
        (ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * x.ln() + b * (1.0 - x).ln()).exp();
    if x < (a + 1.0) / (a + b + 2.0) {
        front * beta_fraction(a, b, x) / a
    } else {
        1.0 - front * beta_fraction(b, a, 1.0 - x) / b
    }
}

/// `Pr[F_{d1,d2} > f]` of Fisher's F distribution (exact, through the incomplete beta
/// function: `I_{d2/(d2 + d1 f)}(d2/2, d1/2)`).
pub fn f_upper_tail(f: f64, d1: f64, d2: f64) -> f64 {
    if f.is_nan() || d1 <= 0.0 || d2 <= 0.0 {
        return f64::NAN;
    }
    if f <= 0.0 {
        return 1.0;
    }
    incomplete_beta(0.5 * d2, 0.5 * d1, d2 / (d2 + d1 * f))
}

/// `Pr[χ²_ν > x]` by the Wilson–Hilferty cube-root normal approximation (accurate to a few
/// 1e-3 in probability for ν ≥ 10, which a calibration always has).
pub fn chi2_upper_tail(x: f64, dof: usize) -> f64 {
    let nu = dof.max(1) as f64;
    let a = 2.0 / (9.0 * nu);
    let z = ((x / nu).cbrt() - (1.0 - a)) / a.sqrt();
    normal_upper_tail(z)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tails_match_tables() {
        // Φ̄(1.959964) = 0.025, Φ̄(0) = 0.5, Φ̄(−1) = 0.841345
        assert!((normal_upper_tail(1.959_964) - 0.025).abs() < 1e-7);
        assert!((normal_upper_tail(0.0) - 0.5).abs() < 1e-7);
        assert!((normal_upper_tail(-1.0) - 0.841_344_7).abs() < 1e-6);
        // χ²_100 upper 5 % point 124.342 (tables)
        assert!((chi2_upper_tail(124.342, 100) - 0.05).abs() < 2e-3);
        assert!((chi2_upper_tail(100.0, 100) - 0.481).abs() < 3e-3);
    }

    /// F and its special functions against tables: Γ(5) = 24, Γ(½) = √π, F(5, 10) upper 5 %
    /// point 3.3258, F(10, 360) upper 1 % point 2.37 (≈ χ²₁₀/10), F(1, 1) median 1.
    #[test]
    fn f_tail_matches_tables() {
        assert!((ln_gamma(5.0) - 24f64.ln()).abs() < 1e-12);
        assert!((ln_gamma(0.5) - std::f64::consts::PI.sqrt().ln()).abs() < 1e-12);
        assert!((f_upper_tail(3.3258, 5.0, 10.0) - 0.05).abs() < 1e-4);
        assert!((f_upper_tail(1.0, 1.0, 1.0) - 0.5).abs() < 1e-12);
        assert!((f_upper_tail(2.3209, 10.0, 1e6) - 0.01).abs() < 2e-4);
        assert_eq!(f_upper_tail(0.0, 3.0, 4.0), 1.0);
        assert!(f_upper_tail(1e6, 3.0, 4.0) < 1e-9);
        assert!(f_upper_tail(f64::NAN, 3.0, 4.0).is_nan());
    }

    #[test]
    fn tracker_whitening_is_radial_and_transverse() {
        let m = NoiseModel::Tracker {
            constant_um: 15.0,
            per_metre_um: 6.0,
            radial_um: 10.0,
            mpe_sigmas: 2.0,
            position_mm: [0.0; 3],
        };
        let w = m.whiten(&[2000.0, 0.0, 0.0], None).unwrap();
        // along x: 1/σ_r = 1/0.005; across: 1/σ_t = 1/0.0135
        assert!((w[(0, 0)] - 200.0).abs() < 1e-9);
        assert!((w[(1, 1)] - 1.0 / 0.0135).abs() < 1e-9);
        assert!(w[(0, 1)].abs() < 1e-12);
    }

    /// A stated σ outside 1e-9 … 1000 mm (directly, or through an MPE part) is refused: 1e-300
    /// or 1e200 used to overflow or underflow the weights and panic the identifiability SVD, and
    /// R = 0 whitened with 1/0.
    #[test]
    fn stated_sigma_must_be_within_the_physical_range() {
        let data = super::super::TrackerData::Poses(super::super::PoseData::default());
        let sigma = |s: f64| NoiseModel::from_settings(Some(s), None, None, &data);
        let mpe = |m: &[f64]| NoiseModel::from_settings(None, Some(m), None, &data);
        for s in [MIN_SIGMA_MM, 0.01, MAX_SIGMA_MM] {
            assert_eq!(sigma(s), Ok(NoiseModel::Isotropic { sigma_mm: s }));
        }
        for s in [
            0.0,
            -1.0,
            1e-300,
            1e-155,
            1e-10,
            1000.5,
            1e200,
            f64::NAN,
            f64::INFINITY,
        ] {
            assert!(matches!(sigma(s), Err(NoiseSettingError::Sigma(_))), "{s}");
        }
        assert_eq!(
            sigma(1e-300).unwrap_err().to_string(),
            "1e-300 mm is not a usable σ per coordinate: it must be within 1e-9 … 1000 mm"
        );
        for m in [&[15.0, 6.0][..], &[15.0, 0.0, 10.0], &[3e-6, 0.0, 1.9e6]] {
            assert!(mpe(m).is_ok(), "{m:?}");
        }
        for m in [
            &[15.0, 6.0, 0.0][..],
            &[1e-300, 0.0],
            &[1e300, 0.0],
            &[15.0, 1e300],
            &[15.0, -1.0],
            &[15.0, 6.0, 1e300],
            &[15.0],
            &[0.0, 6.0],
        ] {
            assert_eq!(mpe(m), Err(NoiseSettingError::Mpe(m.to_vec())), "{m:?}");
        }
    }
}
