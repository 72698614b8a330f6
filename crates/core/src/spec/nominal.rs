//! The nominal model of a `nominal` reference must be the same robot as the analysed model:
//! the same number of joints, and flanges that nearly coincide over the joints' ranges.

use super::{SpecError, SpecErrorKind, SpecField};
use crate::identify::validate::OTHER_ROBOT_MM;
use crate::kinematics::{position, Joints, RobotModel};

/// Configurations over which the flanges are compared.
const PROBES: usize = 64;

/// RMS distance (mm) between the flange centres of `a` and `b` (robot base frames, no tool)
/// over [`PROBES`] configurations spread evenly over `a`'s joint ranges (an additive
/// recurrence with irrational steps); both must have the same joint count.
pub(super) fn flange_gap(a: &RobotModel, b: &RobotModel) -> f64 {
    // Fractional parts of √2, √3, √5, √7, √11, √13, √17: one irrational step per joint.
    const STEPS: [f64; 7] = [
        0.414_213_562,
        0.732_050_808,
        0.236_067_977,
        0.645_751_311,
        0.316_624_790,
        0.605_551_275,
        0.123_105_626,
    ];
    let n = a.joints();
    let sq: f64 = (1..=PROBES)
        .map(|k| {
            let q = Joints::from_fn(n, |j| {
                let (lo, hi) = a.limits_deg[j];
                let (lo, hi) = (lo.max(-180.0), hi.min(180.0));
                (lo + (hi - lo) * (k as f64 * STEPS[j % STEPS.len()]).fract()).to_radians()
            });
            let (x, y) = (
                position(&a.params, &[0.0; 3], &q),
                position(&b.params, &[0.0; 3], &q),
            );
            (0..3).map(|c| (x[c] - y[c]).powi(2)).sum::<f64>()
        })
        .sum();
    (sq / PROBES as f64).sqrt()
}

/// Refuses a nominal model (`nominal`, from `nominal_source`) of another robot than `model`
/// (from `model_source`): another joint count, or flanges more than [`OTHER_ROBOT_MM`] RMS
/// apart over the joints' ranges (calibration moves a flange by millimetres, another robot's
/// geometry by hundreds).
pub(super) fn check_same_robot(
    nominal: &RobotModel,
    nominal_source: String,
    model: &RobotModel,
    model_source: String,
) -> Result<(), SpecError> {
    let kind = if nominal.joints() != model.joints() {
        SpecErrorKind::NominalJoints {
            nominal: nominal_source,
            nominal_joints: nominal.joints(),
            model: model_source,
            model_joints: model.joints(),
        }
    } else {
        let gap = flange_gap(model, nominal);
        if gap <= OTHER_ROBOT_MM {
            return Ok(());
        }
        SpecErrorKind::NominalOtherRobot {
            nominal: nominal_source,
            model: model_source,
            gap_mm: gap,
        }
    };
    Err(SpecError::new(SpecField::Nominal, kind))
}
