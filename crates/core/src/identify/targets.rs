//! Corrected targets: what to command a controller that runs the nominal kinematics so that the
//! calibrated robot reaches the positions the task meant (docs/METHOD.md §18.2).
//!
//! A task pose is given as the configuration `q` the controller would take for it; the intended
//! position is where the *nominal* model puts the tool there, `x = p_nom(q)`. The calibrated
//! robot — its identified geometry plus its compensation ([`RobotModel::compensated_position`])
//! — is at `p_cal(q) ≠ x`. The corrected configuration `q*` solves `p_cal(q*) = x` (Newton
//! steps with the minimum-norm change of the joints, so the orientation moves as little as the
//! position allows), and the corrected target is `x* = p_nom(q*)`: commanded to the nominal
//! controller, it drives the joints to `q*`, where the calibrated robot is at `x`. Everything is
//! in the robot's base frame.

use super::validate::SAME_TOOL_MM;
use super::IdentifyError;
use crate::kinematics::{position, RobotModel};
use nalgebra::{Matrix3, Vector3};
use serde::Serialize;

/// Largest number of Newton steps per target.
const MAX_STEPS: usize = 60;
/// A corrected configuration reaches the target to this, mm.
pub const TOLERANCE_MM: f64 = 1e-7;
/// Largest joint change a correction may make, degrees: a calibration corrects tenths of a
/// millimetre to millimetres (hundredths to tenths of a degree); a larger change means the pose
/// is singular for the position (a stretched arm cannot reach further) and the correction
/// would move the robot somewhere else.
pub const MAX_CORRECTION_DEG: f64 = 2.0;
/// Largest joint change of one Newton step, radians.
const MAX_STEP_RAD: f64 = 0.01;

/// One task pose, corrected.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CorrectedTarget {
    /// The configuration the controller would take for the task pose, degrees.
    pub q_deg: Vec<f64>,
    /// The intended position (the nominal model at `q_deg`), mm.
    pub target_mm: [f64; 3],
    /// Where the calibrated robot is at `q_deg`, mm.
    pub predicted_mm: [f64; 3],
    /// The configuration at which the calibrated robot is at the target, degrees.
    pub corrected_q_deg: Vec<f64>,
    /// The position to command the nominal controller (the nominal model at
    /// `corrected_q_deg`), mm.
    pub corrected_target_mm: [f64; 3],
}

impl CorrectedTarget {
    /// How far the calibrated robot would miss the target uncorrected, mm.
    pub fn error_mm(&self) -> f64 {
        (Vector3::from(self.predicted_mm) - Vector3::from(self.target_mm)).norm()
    }
}

/// Corrected targets of a task.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CorrectedTargets {
    /// One per task pose.
    pub targets: Vec<CorrectedTarget>,
    /// Whether the calibrated model's compensation was part of the prediction.
    pub compensated: bool,
    /// The nominal model's own tool point when it was another target than the calibrated
    /// model's (more than [`SAME_TOOL_MM`] apart) and the model's was used instead, mm.
    pub nominal_tool_replaced: Option<[f64; 3]>,
}

/// The calibrated robot's position and its joint Jacobian (central differences) at `q` rad.
fn position_and_jacobian(model: &RobotModel, q: &[f64]) -> (Vector3<f64>, Vec<Vector3<f64>>) {
    let p = Vector3::from(model.compensated_position(q));
    let h = 1e-6;
    let columns = (0..q.len())
        .map(|j| {
            let mut a = q.to_vec();
            let mut b = q.to_vec();
            a[j] += h;
            b[j] -= h;
            (Vector3::from(model.compensated_position(&a))
                - Vector3::from(model.compensated_position(&b)))
                / (2.0 * h)
        })
        .collect();
    (p, columns)
}

/// The configuration near `q` (radians) where `model` is at `target` (mm), or `None`.
fn solve(model: &RobotModel, q: &[f64], target: Vector3<f64>) -> Option<Vec<f64>> {
    let mut x = q.to_vec();
    for _ in 0..MAX_STEPS {
        let (p, cols) = position_and_jacobian(model, &x);
        let r = target - p;
        if r.norm() < TOLERANCE_MM {
            return Some(x);
        }
        // Minimum-norm step: Δq = Jᵀ (J Jᵀ + λ I)⁻¹ r, λ tiny (regularises a singular pose).
        let mut jjt = Matrix3::zeros();
        for c in &cols {
            jjt += c * c.transpose();
        }
        let lambda = 1e-12 * jjt.trace().max(1e-30);
        let y = (jjt + Matrix3::identity() * lambda).try_inverse()? * r;
        let step: Vec<f64> = cols.iter().map(|c| c.dot(&y)).collect();
        let largest = step.iter().fold(0.0f64, |a, b| a.max(b.abs()));
        let shrink = if largest > MAX_STEP_RAD {
            MAX_STEP_RAD / largest
        } else {
            1.0
        };
        for (xj, d) in x.iter_mut().zip(&step) {
            *xj += shrink * d;
        }
        let moved = x
            .iter()
            .zip(q)
            .fold(0.0f64, |a, (b, c)| a.max((b - c).abs()));
        if !moved.is_finite() || moved > MAX_CORRECTION_DEG.to_radians() {
            return None;
        }
    }
    let (p, _) = position_and_jacobian(model, &x);
    ((target - p).norm() < TOLERANCE_MM).then_some(x)
}

/// Corrected targets of the task configurations `configs` (degrees) for a controller running
/// `nominal`, the robot being `model` (see the module text). The nominal model is evaluated
/// with the model's tool when its own is another target (as [`super::validate_in`]).
///
/// # Errors
///
/// [`IdentifyError::JointCount`] when `nominal` or a configuration has another number of joints
/// than `model`, [`IdentifyError::OutsideLimits`] when a configuration or its correction is
/// outside the model's joint limits (naming the configuration, 1-based, as the line), and
/// [`IdentifyError::NoData`] for no configurations or ones that cannot be corrected within
/// [`MAX_CORRECTION_DEG`] of every joint (singular poses; all are named).
pub fn corrected_targets(
    model: &RobotModel,
    nominal: &RobotModel,
    configs: &[Vec<f64>],
) -> Result<CorrectedTargets, IdentifyError> {
    if configs.is_empty() {
        return Err(IdentifyError::NoData("no task configurations".into()));
    }
    if nominal.joints() != model.joints() {
        return Err(IdentifyError::JointCount(format!(
            "the nominal model {} has {} joints, the model {} has {}",
            nominal.name,
            nominal.joints(),
            model.name,
            model.joints()
        )));
    }
    let gap = (Vector3::from(nominal.tool) - Vector3::from(model.tool)).norm();
    let (tool, nominal_tool_replaced) = if gap.is_nan() || gap > SAME_TOOL_MM {
        (model.tool, Some(nominal.tool))
    } else {
        (nominal.tool, None)
    };
    let p_nom = |q: &[f64]| Vector3::from(position(&nominal.params, &tool, q));
    let mut targets = Vec::with_capacity(configs.len());
    let mut singular = Vec::new();
    for (i, q_deg) in configs.iter().enumerate() {
        if q_deg.len() != model.joints() {
            return Err(IdentifyError::JointCount(format!(
                "configuration {}: {} joint angles, the model {} has {} joints",
                i + 1,
                q_deg.len(),
                model.name,
                model.joints()
            )));
        }
        let outside = |q: &[f64]| {
            model
                .check_limits(q)
                .map_err(|message| IdentifyError::OutsideLimits {
                    line: i as u64 + 1,
                    message,
                })
        };
        outside(q_deg)?;
        let q: Vec<f64> = q_deg.iter().map(|v| v.to_radians()).collect();
        let target = p_nom(&q);
        let Some(corrected) = solve(model, &q, target) else {
            singular.push(i + 1);
            continue;
        };
        let corrected_deg: Vec<f64> = corrected.iter().map(|v| v.to_degrees()).collect();
        outside(&corrected_deg)?;
        let v = |x: Vector3<f64>| [x.x, x.y, x.z];
        targets.push(CorrectedTarget {
            q_deg: q_deg.clone(),
            target_mm: v(target),
            predicted_mm: model.compensated_position(&q),
            corrected_q_deg: corrected_deg,
            corrected_target_mm: v(p_nom(&corrected)),
        });
    }
    if !singular.is_empty() {
        let shown: Vec<String> = singular.iter().take(10).map(|i| i.to_string()).collect();
        return Err(IdentifyError::NoData(format!(
            "configuration{} {}{}: the calibrated robot cannot reach the target within {MAX_CORRECTION_DEG}° of every joint (a pose singular for the position, e.g. a stretched arm or wrist); leave {} out or move {} away from the singularity",
            if singular.len() > 1 { "s" } else { "" },
            shown.join(", "),
            if singular.len() > 10 { format!(" and {} more", singular.len() - 10) } else { String::new() },
            if singular.len() > 1 { "them" } else { "it" },
            if singular.len() > 1 { "them" } else { "it" },
        )));
    }
    Ok(CorrectedTargets {
        targets,
        compensated: model.compensated(),
        nominal_tool_replaced,
    })
}

impl CorrectedTargets {
    /// CSV: the task configuration, the intended position, the calibrated robot's position there
    /// and its miss, the corrected configuration and the corrected target (degrees, mm; full
    /// precision).
    pub fn to_csv(&self) -> String {
        let n = self.targets.first().map_or(0, |t| t.q_deg.len());
        let mut s: String = (1..=n).map(|j| format!("q{j},")).collect();
        s.push_str("x,y,z,predicted_x,predicted_y,predicted_z,error_mm,");
        s.extend((1..=n).map(|j| format!("corrected_q{j},")));
        s.push_str("corrected_x,corrected_y,corrected_z\n");
        let join = |v: &[f64]| {
            v.iter()
                .map(|x| format!("{x}"))
                .collect::<Vec<_>>()
                .join(",")
        };
        for t in &self.targets {
            s.push_str(&format!(
                "{},{},{},{},{},{}\n",
                join(&t.q_deg),
                join(&t.target_mm),
                join(&t.predicted_mm),
                t.error_mm(),
                join(&t.corrected_q_deg),
                join(&t.corrected_target_mm)
            ));
        }
        s
    }
}

/// A 3 × n matrix of columns, for tests of the Jacobian.
#[cfg(test)]
fn jacobian_matrix(cols: &[Vector3<f64>]) -> nalgebra::SMatrix<f64, 3, 6> {
    nalgebra::SMatrix::<f64, 3, 6>::from_fn(|r, c| cols[c][r])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::discrepancy::{Compensation, Discrepancy, NoiseSource};
    use crate::kinematics::tx60;

    /// The TX60 with a few tenths of a millimetre of geometric error and a compensation field.
    fn calibrated() -> RobotModel {
        let mut m = tx60();
        m.params[1] += 0.3; // d1 (θ, d, a, α, β per joint)
        m.params[7] += 0.3; // a2
        m.params[11] -= 0.2; // d3
        m.params[13] += 0.0005; // α3
        m.discrepancy = Some(Discrepancy {
            residual_norms: vec![0.05; 20],
            robot_share: 1.0,
            noise: NoiseSource::Unknown,
            noise_sigma_mm: None,
            compensation: Some(Compensation {
                length_scales_deg: vec![200.0, 60.0, 60.0, 300.0, 300.0, 300.0],
                signal_sigma_mm: 0.3,
                white_sigma_mm: 0.02,
                loo_sigma_mm: 0.05,
                loo_rms_geometric_mm: 0.4,
                loo_rms_compensated_mm: 0.3,
                configurations_deg: vec![
                    vec![0.0, 30.0, 60.0, 0.0, 20.0, 0.0],
                    vec![40.0, -20.0, 90.0, 10.0, -30.0, 5.0],
                ],
                weights: vec![[2.0, -1.0, 0.5], [-1.0, 3.0, 1.0]],
            }),
        });
        m
    }

    #[test]
    fn the_corrected_configuration_reaches_the_target() {
        let m = calibrated();
        let nominal = tx60();
        let configs = vec![
            vec![10.0, 20.0, 70.0, 5.0, 30.0, -10.0],
            vec![-30.0, 40.0, 100.0, 0.0, -40.0, 20.0],
        ];
        let out = corrected_targets(&m, &nominal, &configs).unwrap();
        assert!(out.compensated && out.nominal_tool_replaced.is_none());
        for t in &out.targets {
            let q: Vec<f64> = t.corrected_q_deg.iter().map(|v| v.to_radians()).collect();
            let reached = Vector3::from(m.compensated_position(&q));
            assert!((reached - Vector3::from(t.target_mm)).norm() < 1e-6);
            // Uncorrected the robot misses by tenths of a millimetre (the errors above).
            assert!(
                t.error_mm() > 0.05 && t.error_mm() < 5.0,
                "{}",
                t.error_mm()
            );
            // To first order the corrected target is the target minus the miss; the rest is
            // second order in the miss over the arm's lever (< 1e-3 mm here).
            let first_order = 2.0 * Vector3::from(t.target_mm) - Vector3::from(t.predicted_mm);
            assert!(
                (Vector3::from(t.corrected_target_mm) - first_order).norm() < 2e-2 * t.error_mm()
            );
        }
        // The nominal model itself needs no correction.
        let same = corrected_targets(&nominal, &nominal, &configs).unwrap();
        for t in &same.targets {
            assert!(t.error_mm() < 1e-12);
            for (a, b) in t.q_deg.iter().zip(&t.corrected_q_deg) {
                assert!((a - b).abs() < 1e-9);
            }
        }
        assert!(out
            .to_csv()
            .lines()
            .next()
            .unwrap()
            .contains("corrected_q6"));
    }

    #[test]
    fn the_jacobian_matches_the_kinematics() {
        let m = calibrated();
        let q = [0.2, 0.4, 1.2, 0.1, 0.5, -0.2];
        let (p, cols) = position_and_jacobian(&m, &q);
        let j = jacobian_matrix(&cols);
        let dq = nalgebra::SVector::<f64, 6>::from_fn(|i, _| 1e-4 * (i as f64 - 2.5));
        let plus: Vec<f64> = q.iter().zip(dq.iter()).map(|(a, b)| a + b).collect();
        let minus: Vec<f64> = q.iter().zip(dq.iter()).map(|(a, b)| a - b).collect();
        // The symmetric difference cancels the second order: what is left is third order in
        // |dq| (≈ 4·10⁻⁴ rad, lever ≈ 10³ mm: ~10⁻⁸ mm) and the columns' own truncation.
        let direct = (Vector3::from(m.compensated_position(&plus))
            - Vector3::from(m.compensated_position(&minus)))
            / 2.0;
        assert!((direct - j * dq).norm() < 1e-7, "{direct} vs {}", j * dq);
        assert!(p.norm() > 100.0);
    }

    #[test]
    fn bad_task_is_one_clear_error() {
        let m = calibrated();
        let e = corrected_targets(&m, &tx60(), &[vec![0.0; 5]]).unwrap_err();
        assert!(
            e.to_string().contains("configuration 1") && e.to_string().contains("5 joint angles"),
            "{e}"
        );
        assert!(corrected_targets(&m, &tx60(), &[]).is_err());
        // A stretched arm (q3 = 0 … the elbow straight) cannot reach a target beyond it.
        let mut far = calibrated();
        far.params[7] -= 2.0; // a2 two millimetres short: the nominal target is out of reach
        let stretched = vec![
            vec![0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            vec![10.0, 20.0, 70.0, 5.0, 30.0, -10.0],
        ];
        let e = corrected_targets(&far, &tx60(), &stretched).unwrap_err();
        assert!(
            e.to_string().contains("configuration 1:") && e.to_string().contains("singular"),
            "{e}"
        );
    }
}
