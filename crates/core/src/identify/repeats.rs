//! Poses measured more than once (docs/METHOD.md §2.6): a tracker measures each pose several
//! times, and the rows of a run with the same joint angles (as written, anywhere in the run) are
//! repeats of one pose.
//!
//! * **Pure error.** The scatter of the repeats about their pose's mean is measurement noise
//!   alone, whatever the model: pooled over the poses, `s² = Σ_i Σ_j ‖y_ij − ȳ_i‖² / (3 Σ (k_i −
//!   1))` per coordinate, with `Σ (k_i − 1)` degrees of freedom per coordinate. Without a stated σ
//!   it is the noise ([`NoiseModel::PureError`]); with one, the two are compared.
//! * **The fit takes each pose's mean.** With weights `WᵀW` the mean is `ȳ = (Σ_j A_j)⁻¹ Σ_j A_j
//!   y_j` (`A_j = W_jᵀ W_j`) with covariance `(Σ_j A_j)⁻¹` (σ/√k for equal σ). For the parameters
//!   this is the same least-squares problem as the rows themselves (same estimate, same
//!   covariance); for the lack-of-fit analysis it is the right one: the means' residuals hold
//!   the lack of fit and σ/√k of noise, their χ² tests the model against the pure error (an F
//!   test), and left-out poses are poses, not one repeat beside its twins.

use super::chain::MeasuredPoint;
use super::noise::{chi2_upper_tail, fmt_sig, NoiseModel, MIN_SIGMA_MM};
use super::poses::{PosePoint, PoseRun};
use nalgebra::{Matrix3, Vector3};
use std::collections::HashMap;

/// Two-sided level at which a stated σ and the repeats' scatter are said to disagree.
pub const DISAGREEMENT_LEVEL: f64 = 0.01;

/// The rows of `run` grouped by identical joint angles, payload, target and sides, in order of first
/// appearance (indices into `run.points`).
pub fn pose_groups(run: &PoseRun) -> Vec<Vec<usize>> {
    let mut at: HashMap<Vec<u64>, usize> = HashMap::new();
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for (i, p) in run.points.iter().enumerate() {
        // + 0.0 makes −0 and 0 the same angle
        let key: Vec<u64> = p
            .q_deg
            .iter()
            .chain([&p.payload_kg, &f64::from(p.target)])
            .chain(p.sides.iter().flat_map(|s| s.iter()))
            .map(|v| (v + 0.0).to_bits())
            .collect();
        match at.get(&key) {
            Some(&g) => groups[g].push(i),
            None => {
                at.insert(key, groups.len());
                groups.push(vec![i]);
            }
        }
    }
    groups
}

/// The pure error of repeated measurements.
#[derive(Clone, Debug, PartialEq)]
pub struct PureError {
    /// Pooled σ per coordinate, mm.
    pub sigma_mm: f64,
    /// σ of x, y and z separately, mm.
    pub sigma_xyz_mm: [f64; 3],
    /// Degrees of freedom per coordinate, `Σ (k_i − 1)`.
    pub dof: usize,
    /// Poses measured more than once.
    pub repeated: usize,
    /// Fewest and most measurements of a repeated pose.
    pub k_range: (usize, usize),
}

impl PureError {
    /// The noise model it gives when no σ is stated.
    pub fn noise_model(&self) -> NoiseModel {
        NoiseModel::PureError {
            sigma_mm: self.sigma_mm.max(MIN_SIGMA_MM),
            dof: 3 * self.dof,
            repeated: self.repeated,
            min_k: self.k_range.0,
            max_k: self.k_range.1,
        }
    }

    /// "60 poses measured 3 times, σ = … mm per coordinate (x …, y …, z …; … degrees of freedom
    /// per coordinate)".
    pub fn describe(&self) -> String {
        let (lo, hi) = self.k_range;
        let s = self.sigma_xyz_mm;
        format!(
            "{} poses measured {} times, pure-error σ = {} mm per coordinate (x {}, y {}, z {}; {} degrees of freedom each)",
            self.repeated,
            if lo == hi { lo.to_string() } else { format!("{lo}–{hi}") },
            fmt_sig(self.sigma_mm),
            fmt_sig(s[0]),
            fmt_sig(s[1]),
            fmt_sig(s[2]),
            self.dof
        )
    }
}

/// The pure error pooled over `runs` (repeats are rows of one run with the same joint angles);
/// `None` without a pose measured twice.
pub fn pure_error(runs: &[PoseRun]) -> Option<PureError> {
    let mut ss = [0.0; 3];
    let mut dof = 0;
    let mut repeated = 0;
    let mut k_range = (usize::MAX, 0);
    for run in runs {
        for g in pose_groups(run).iter().filter(|g| g.len() > 1) {
            let pts: Vec<&PosePoint> = g.iter().map(|&i| &run.points[i]).collect();
            let k = pts.len();
            for (c, s) in ss.iter_mut().enumerate() {
                let mean = pts.iter().map(|p| p.position_mm[c]).sum::<f64>() / k as f64;
                *s += pts
                    .iter()
                    .map(|p| (p.position_mm[c] - mean).powi(2))
                    .sum::<f64>();
            }
            dof += k - 1;
            repeated += 1;
            k_range = (k_range.0.min(k), k_range.1.max(k));
        }
    }
    (dof > 0).then(|| PureError {
        sigma_mm: (ss.iter().sum::<f64>() / (3 * dof) as f64).sqrt(),
        sigma_xyz_mm: ss.map(|s| (s / dof as f64).sqrt()),
        dof,
        repeated,
        k_range,
    })
}

/// One run's poses as the whole-chain fit takes them.
#[derive(Clone, Debug)]
pub struct FitInput {
    /// The points: one per pose (its mean) when poses were repeated, else the rows.
    pub points: Vec<MeasuredPoint>,
    /// The noise the fit weights them with.
    pub noise: NoiseModel,
    /// Where the noise came from, for the report (`None`: as the noise model says).
    pub source: Option<String>,
    /// Warnings: a stated σ the repeats disagree with.
    pub warnings: Vec<String>,
}

/// A pose's rows as one point: the weighted mean `(Σ A_j)⁻¹ Σ A_j y_j` and `Σ A_j`.
fn weighted_mean(rows: &[&PosePoint], whiten: &[Matrix3<f64>]) -> (Vector3<f64>, Matrix3<f64>) {
    let a: Vec<Matrix3<f64>> = whiten.iter().map(|w| w.transpose() * w).collect();
    let total: Matrix3<f64> = a.iter().sum();
    let plain = rows
        .iter()
        .map(|p| Vector3::from(p.position_mm))
        .sum::<Vector3<f64>>()
        / rows.len() as f64;
    let mean = total.try_inverse().map_or(plain, |inv| {
        inv * rows
            .iter()
            .zip(&a)
            .map(|(p, a)| a * Vector3::from(p.position_mm))
            .sum::<Vector3<f64>>()
    });
    (mean, total)
}

/// The rows of `run` as measured points.
fn rows(run: &PoseRun) -> Vec<MeasuredPoint> {
    run.points
        .iter()
        .map(|p| MeasuredPoint {
            q_deg: p.q_deg,
            position_mm: p.position_mm,
            sigma_mm: p.sigma_mm,
            payload_kg: p.payload_kg,
            line: p.line,
            target: p.target,
            sides: p.sides,
        })
        .collect()
}

/// The fit's input of `run` under `noise`: the rows unchanged when no pose of the run was
/// measured twice (and the noise is not [`NoiseModel::PureError`]); else one point per pose,
/// its mean weighted by the noise (σ/√k), and the noise that weights the means: the pure error
/// (this run's when `noise` is to be estimated from the residuals), or the stated noise per
/// point, or a tracker model with its MPE divided by √k when every pose has the same k. With a
/// tracker model and poses repeated unequally the rows stay separate points (the same
/// parameters; the lack-of-fit test then counts the pure error among its degrees of freedom).
pub fn fit_input(run: &PoseRun, noise: &NoiseModel) -> FitInput {
    let groups = pose_groups(run);
    let repeated = groups.iter().any(|g| g.len() > 1);
    let noise = match noise {
        NoiseModel::FromResiduals if repeated => {
            pure_error(std::slice::from_ref(run)).map_or(*noise, |e| e.noise_model())
        }
        n => *n,
    };
    let unchanged = FitInput {
        points: rows(run),
        noise,
        source: None,
        warnings: Vec::new(),
    };
    if !repeated && !matches!(noise, NoiseModel::PureError { .. }) {
        return unchanged;
    }
    // Each row's whitening under the stated noise (the pooled σ for pure error).
    let row_whiten = |p: &PosePoint| match noise {
        NoiseModel::PureError { sigma_mm, .. } => Some(Matrix3::identity() / sigma_mm),
        n => n.whiten(&p.position_mm, p.sigma_mm),
    };
    let mut points = Vec::with_capacity(groups.len());
    let mut chi2 = 0.0;
    let mut dof = 0;
    for g in &groups {
        let pts: Vec<&PosePoint> = g.iter().map(|&i| &run.points[i]).collect();
        let Some(w) = pts
            .iter()
            .map(|p| row_whiten(p))
            .collect::<Option<Vec<_>>>()
        else {
            // a point without the σ the noise needs: the fit names it
            return unchanged;
        };
        let (mean, total) = weighted_mean(&pts, &w);
        chi2 += pts
            .iter()
            .zip(&w)
            .map(|(p, w)| (w * (Vector3::from(p.position_mm) - mean)).norm_squared())
            .sum::<f64>();
        dof += 3 * (pts.len() - 1);
        points.push(MeasuredPoint {
            q_deg: pts[0].q_deg,
            position_mm: [mean.x, mean.y, mean.z],
            sigma_mm: Some([0, 1, 2].map(|c| 1.0 / total[(c, c)].max(f64::MIN_POSITIVE).sqrt())),
            payload_kg: pts[0].payload_kg,
            line: pts[0].line,
            target: pts[0].target,
            sides: pts[0].sides,
        });
    }
    let ks: Vec<usize> = groups.iter().map(Vec::len).collect();
    let how = format!(
        "{} rows of {} poses, each pose entering as its mean (σ/√k)",
        run.points.len(),
        groups.len()
    );
    let fit_noise = match noise {
        NoiseModel::PureError { .. } => {
            return FitInput {
                points,
                noise,
                source: None,
                warnings: Vec::new(),
            }
        }
        NoiseModel::Tracker { .. } if ks.iter().all(|&k| k == ks[0]) => {
            for p in &mut points {
                p.sigma_mm = None;
            }
            noise.mpe_divided_by((ks[0] as f64).sqrt())
        }
        NoiseModel::Tracker { .. } => {
            let mut out = unchanged;
            out.source = Some(format!(
                "{}; poses repeated unequally: each of the {} rows enters as its own point",
                noise.describe(),
                run.points.len()
            ));
            out.warnings = compare(&noise, run, chi2, dof).1;
            return out;
        }
        _ => NoiseModel::PerPoint,
    };
    let (sentence, warnings) = compare(&noise, run, chi2, dof);
    FitInput {
        points,
        noise: fit_noise,
        source: Some(format!("{}; {how}; {sentence}", noise.describe())),
        warnings,
    }
}

/// The stated `noise` against the repeats' scatter: `chi2` of the rows' whitened deviations
/// from their pose means over `dof` (`3 Σ (k − 1)`). One clause for the report and a warning
/// when they disagree (two-sided, [`DISAGREEMENT_LEVEL`]).
fn compare(noise: &NoiseModel, run: &PoseRun, chi2: f64, dof: usize) -> (String, Vec<String>) {
    let Some(pe) = pure_error(std::slice::from_ref(run)) else {
        return (String::new(), Vec::new());
    };
    let p = chi2_upper_tail(chi2, dof);
    let ratio = (chi2 / dof.max(1) as f64).sqrt();
    let clause = format!(
        "{}: the repeats scatter {ratio:.2}× the stated σ (χ² = {chi2:.1} for {dof} degrees of freedom, p = {p:.2})",
        pe.describe()
    );
    let mut warnings = Vec::new();
    if p < DISAGREEMENT_LEVEL / 2.0 {
        warnings.push(format!(
            "the repeated measurements scatter {ratio:.2}× the stated noise ({}; χ² = {chi2:.1} for {dof} degrees of freedom, p = {p:.1e}): the stated σ ({}) is too small, or the target or the robot moved between repeats",
            pe.describe(),
            noise.describe()
        ));
    } else if p > 1.0 - DISAGREEMENT_LEVEL / 2.0 {
        warnings.push(format!(
            "the repeated measurements scatter only {ratio:.2}× the stated noise ({}; χ² = {chi2:.1} for {dof} degrees of freedom, p = {:.1e} of so little): the stated σ ({}) is larger than the tracker's short-term noise; repeats in quick succession leave out drift, and a stated σ may rightly include it",
            pe.describe(),
            1.0 - p,
            noise.describe()
        ));
    }
    (clause, warnings)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::Joints;

    fn point(q: f64, xyz: [f64; 3], line: u64) -> PosePoint {
        PosePoint {
            payload_kg: 0.0,
            q_deg: Joints::from_slice(&[q, 0.0, 0.0, 0.0, 0.0, 0.0]),
            position_mm: xyz,
            sigma_mm: None,
            line,
            target: 0,
            sides: None,
        }
    }

    /// Repeats anywhere in a run form one pose; the pooled σ, its degrees of freedom and the
    /// means weighted σ/√k.
    #[test]
    fn repeats_give_pure_error_and_means() {
        let run = PoseRun {
            run: None,
            points: vec![
                point(1.0, [0.0, 0.0, 0.0], 2),
                point(2.0, [5.0, 5.0, 5.0], 3),
                point(1.0, [0.02, 0.0, 0.0], 4),
                point(-0.0, [9.0, 9.0, 9.0], 5),
                point(0.0, [9.0, 9.0, 9.03], 6),
            ],
        };
        assert_eq!(pose_groups(&run), vec![vec![0, 2], vec![1], vec![3, 4]]);
        let e = pure_error(std::slice::from_ref(&run)).unwrap();
        assert_eq!((e.dof, e.repeated, e.k_range), (2, 2, (2, 2)));
        // SS = 2·0.01² + 2·0.015² over 3·2 dof
        let want = ((2.0 * 1e-4 + 2.0 * 2.25e-4) / 6.0f64).sqrt();
        assert!((e.sigma_mm - want).abs() < 1e-12, "{e:?}");
        assert!((e.sigma_xyz_mm[0] - (2e-4f64 / 2.0).sqrt()).abs() < 1e-12);
        let input = fit_input(&run, &NoiseModel::FromResiduals);
        assert_eq!(input.points.len(), 3);
        assert!(matches!(input.noise, NoiseModel::PureError { dof: 6, .. }));
        assert!((input.points[0].position_mm[0] - 0.01).abs() < 1e-15);
        assert_eq!(input.points[0].line, 2);
        let s = input.points[0].sigma_mm.unwrap()[0];
        assert!((s - want / 2f64.sqrt()).abs() < 1e-12);
        let s1 = input.points[1].sigma_mm.unwrap()[0];
        assert!((s1 - want).abs() < 1e-12);
        // A stated σ: the means under it, and the comparison in the report.
        let stated = fit_input(&run, &NoiseModel::Isotropic { sigma_mm: 0.01 });
        assert_eq!(stated.noise, NoiseModel::PerPoint);
        assert!((stated.points[2].sigma_mm.unwrap()[2] - 0.01 / 2f64.sqrt()).abs() < 1e-12);
        let src = stated.source.unwrap();
        assert!(src.contains("2 poses measured 2 times") && src.contains("5 rows of 3 poses"));
        // No repeats: the rows as they are.
        let single = PoseRun {
            run: None,
            points: vec![run.points[0].clone(), run.points[1].clone()],
        };
        let plain = fit_input(&single, &NoiseModel::FromResiduals);
        assert_eq!(plain.noise, NoiseModel::FromResiduals);
        assert_eq!(plain.points.len(), 2);
        assert!(plain.source.is_none() && pure_error(&[single]).is_none());
    }

    /// A tracker MPE model: poses repeated equally enter as means under the MPE over √k;
    /// repeated unequally, as rows, and the report says so.
    #[test]
    fn tracker_model_with_repeats() {
        let tracker = NoiseModel::Tracker {
            constant_um: 15.0,
            per_metre_um: 6.0,
            radial_um: 10.0,
            mpe_sigmas: 2.0,
            position_mm: [0.0; 3],
        };
        let equal = PoseRun {
            run: None,
            points: vec![
                point(1.0, [1000.0, 0.0, 0.0], 2),
                point(1.0, [1000.01, 0.0, 0.0], 3),
                point(2.0, [0.0, 1000.0, 0.0], 4),
                point(2.0, [0.0, 1000.0, 0.01], 5),
            ],
        };
        let input = fit_input(&equal, &tracker);
        assert_eq!(input.points.len(), 2);
        assert!(input.points.iter().all(|p| p.sigma_mm.is_none()));
        let NoiseModel::Tracker { constant_um, .. } = input.noise else {
            panic!("{:?}", input.noise)
        };
        assert!((constant_um - 15.0 / 2f64.sqrt()).abs() < 1e-12);
        let mut unequal = equal.clone();
        unequal.points.push(point(2.0, [0.0, 1000.0, 0.02], 6));
        let input = fit_input(&unequal, &tracker);
        assert_eq!((input.points.len(), input.noise), (5, tracker));
        assert!(input.source.unwrap().contains("each of the 5 rows"));
    }

    /// A stated σ far from the repeats' scatter is a warning either way.
    #[test]
    fn stated_sigma_against_the_repeats() {
        let mut points = Vec::new();
        for i in 0..20 {
            let d = if i % 2 == 0 { 0.05 } else { -0.05 };
            points.push(point(i as f64, [0.0, 0.0, 0.0], 2 * i + 2));
            points.push(point(i as f64, [d, -d, d], 2 * i + 3));
        }
        let run = PoseRun { run: None, points };
        // scatter σ = 0.05/√2 · … ≈ 0.035 mm against 0.001: far too small a stated σ
        let w = fit_input(&run, &NoiseModel::Isotropic { sigma_mm: 0.001 }).warnings;
        assert!(w.len() == 1 && w[0].contains("too small"), "{w:?}");
        let w = fit_input(&run, &NoiseModel::Isotropic { sigma_mm: 1.0 }).warnings;
        assert!(w.len() == 1 && w[0].contains("only"), "{w:?}");
        let w = fit_input(&run, &NoiseModel::Isotropic { sigma_mm: 0.0354 }).warnings;
        assert!(w.is_empty(), "{w:?}");
    }
}
