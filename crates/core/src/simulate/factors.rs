//! The five measurement factors of the paper (§3.2) and the physical models behind them.
//!
//! A calibration experiment is the circle-point measurement of [`super::sweep`]: every joint in
//! turn sweeps part of its measuring range from the home pose while the tracker records the
//! target. The paper varies five things about that experiment ([`Factors`]); each acts on the
//! simulated measurement through a documented model ([`RobotErrorModel`]):
//!
//! | factor | paper levels | model |
//! |---|---|---|
//! | repeatability (`runs`) | 10–50 repeated runs | the parameter statistics (mean, σ, covariance) are taken over this many independent calibrations; every measured pose also scatters by the robot's pose repeatability (TX60: RP = ±0.02 mm, ISO 9283: RP = l̄ + 3 S_l; for an isotropic 3-D Gaussian that is 3.62 σ, so σ = 5.5 µm per coordinate) |
//! | joint range (`range_fraction`) | 10–100 % of the measuring range | the centred fraction of each joint's measuring range swept: shorter arcs fix the axis worse (sagitta effect, see [`crate::identify`]) |
//! | step (`step_deg`) | 1–5° | angle between measured points: fewer points per arc at larger steps |
//! | speed (`speed_fraction`) | 10–100 % of rated | dynamic/settling error at each stop. Stable-point measurement waits for the target to settle, but what is left grows with the speed the joint stopped from: a residual vibration of the end point, isotropic Gaussian with σ = 25 µm · s² (s = speed fraction; kinetic energy ∝ s²), and a servo settling error of the moving joint, Gaussian with σ = 0.002° · s |
//! | start position (`direction`) | negative→positive limit or positive→negative | joint backlash/hysteresis b_j (0.004° on J1–J3, 0.008° on J4–J6, harmonic/cycloid class gearing; a seventh joint is a wrist joint, 0.008°, see [`RobotErrorModel::for_joints`]). Moving in direction d the output lags the command by d·b/2 (a systematic offset the calibration absorbs into θ). Where gravity pulls the distal links the way the joint moves (an overrunning load), the gear teeth float inside the backlash at every stop: the lost motion is uniform in [0, b] instead of b/2. Where gravity opposes the motion (or has no torque about the axis, e.g. J1) the driving flank stays engaged and only 10 % of b scatters. The gravity torque's sign is computed at each point from the nominal model, with the distal mass lumped at the target. So which direction is better depends on the pose, not on a rule written in here |
//!
//! Defaults are the paper's baseline: 20 runs, 50 % range, 2° step, 25 % speed, negative→positive.

use super::standard_normal;
use crate::kinematics::{position, transform, Joints, RobotModel};
use rand::Rng;

/// The order in which a joint's sweep visits its points.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SweepDirection {
    /// From the negative end of the swept range to the positive end (the paper's baseline).
    NegToPos,
    /// From the positive end to the negative end.
    PosToNeg,
}

impl SweepDirection {
    /// +1 for negative→positive, −1 otherwise.
    pub fn sign(self) -> f64 {
        match self {
            Self::NegToPos => 1.0,
            Self::PosToNeg => -1.0,
        }
    }
    /// Label for reports.
    pub fn label(self) -> &'static str {
        match self {
            Self::NegToPos => "neg→pos",
            Self::PosToNeg => "pos→neg",
        }
    }
}

/// The five factors of one calibration setting.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Factors {
    /// Number of repeated calibration runs (≥ 2).
    pub runs: usize,
    /// Fraction of each joint's measuring range swept, (0, 1].
    pub range_fraction: f64,
    /// Angle step, degrees (> 0).
    pub step_deg: f64,
    /// Joint speed as a fraction of rated, (0, 1].
    pub speed_fraction: f64,
    /// Sweep direction (start position).
    pub direction: SweepDirection,
}

impl Default for Factors {
    /// The paper's baseline: 20 runs, 50 %, 2°, 25 %, negative→positive.
    fn default() -> Self {
        Factors {
            runs: 20,
            range_fraction: 0.5,
            step_deg: 2.0,
            speed_fraction: 0.25,
            direction: SweepDirection::NegToPos,
        }
    }
}

/// The settings [`Factors::check`] and `StudySettings::check` name in their errors
/// ([`SimulateError::Setting`]); a front end maps each to its own option name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SimulateSetting {
    /// [`Factors::runs`].
    Runs,
    /// [`Factors::range_fraction`] (shown in percent).
    Range,
    /// [`Factors::step_deg`].
    Step,
    /// [`Factors::speed_fraction`] (shown in percent).
    Speed,
    /// `StudySettings::point_counts`.
    PointCounts,
    /// `StudySettings::mcs_draws`.
    McsDraws,
    /// `StudySettings::deltas`.
    Tolerances,
    /// `StudySettings::factors`.
    Factors,
    /// `JointErrorStudy::sizes` (the study's robots with joint errors).
    JointErrors,
    /// `JointErrorStudy::poses`.
    JointErrorPoses,
}

impl SimulateSetting {
    /// Every setting.
    pub const ALL: [SimulateSetting; 10] = [
        Self::Runs,
        Self::Range,
        Self::Step,
        Self::Speed,
        Self::PointCounts,
        Self::McsDraws,
        Self::Tolerances,
        Self::Factors,
        Self::JointErrors,
        Self::JointErrorPoses,
    ];
}

impl std::fmt::Display for SimulateSetting {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Runs => "runs",
            Self::Range => "range",
            Self::Step => "step",
            Self::Speed => "speed",
            Self::PointCounts => "point counts",
            Self::McsDraws => "MCS draws",
            Self::Tolerances => "tolerances",
            Self::Factors => "factors",
            Self::JointErrors => "joint error sizes",
            Self::JointErrorPoses => "poses per run",
        })
    }
}

/// Errors of the simulation and calibration settings and runs.
#[derive(Debug, thiserror::Error)]
pub enum SimulateError {
    /// A setting is out of range; `field` names the setting (see [`Factors::check`] and
    /// `StudySettings::check`).
    #[error("{field}: {message}")]
    Setting {
        /// The setting.
        field: SimulateSetting,
        /// What is wrong.
        message: String,
    },
    /// Identification of a simulated run failed.
    #[error("calibration run {run}: {cause}")]
    Identify {
        /// 1-based run.
        run: usize,
        /// Why (part of the message, not a separate source, so it is printed once).
        cause: crate::identify::IdentifyError,
    },
    /// Validation or statistics failed.
    #[error("{0}")]
    Other(String),
}

impl Factors {
    /// Checks every factor; the error names the setting.
    ///
    /// # Errors
    ///
    /// [`SimulateError::Setting`] naming the first factor out of range: fewer than 2 runs, a
    /// range or speed outside (0, 100] % or a step that is not a positive angle.
    pub fn check(&self) -> Result<(), SimulateError> {
        let bad = |field, message: String| Err(SimulateError::Setting { field, message });
        if self.runs < 2 {
            return bad(
                SimulateSetting::Runs,
                format!(
                    "must be at least 2 (statistics need repeated runs), got {}",
                    self.runs
                ),
            );
        }
        if !(self.range_fraction.is_finite()
            && self.range_fraction > 0.0
            && self.range_fraction <= 1.0)
        {
            return bad(
                SimulateSetting::Range,
                format!(
                    "must be more than 0 and at most 100 (% of the measuring range), got {}",
                    self.range_fraction * 100.0
                ),
            );
        }
        if !(self.step_deg.is_finite() && self.step_deg > 0.0) {
            return bad(
                SimulateSetting::Step,
                format!("must be a positive angle in degrees, got {}", self.step_deg),
            );
        }
        if !(self.speed_fraction.is_finite()
            && self.speed_fraction > 0.0
            && self.speed_fraction <= 1.0)
        {
            return bad(
                SimulateSetting::Speed,
                format!(
                    "must be more than 0 and at most 100 (% of rated speed), got {}",
                    self.speed_fraction * 100.0
                ),
            );
        }
        Ok(())
    }
}

/// The robot's non-geometric error sources during a calibration measurement (see the module
/// docs for the physics and the defaults).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct RobotErrorModel {
    /// ISO 9283 pose repeatability RP, mm (TX60: 0.02).
    pub repeatability_mm: f64,
    /// σ of the residual end-point vibration at rated speed, mm (scales with speed²).
    pub vibration_at_rated_mm: f64,
    /// σ of the moving joint's settling error at rated speed, degrees (scales with speed).
    pub settling_at_rated_deg: f64,
    /// Backlash of each joint, degrees (one per joint; a joint beyond the list takes the last
    /// entry, see [`RobotErrorModel::backlash`]).
    pub backlash_deg: Joints,
    /// Fraction of the backlash that scatters when the driving flank stays engaged.
    pub engaged_scatter: f64,
}

/// RP = l̄ + 3 S_l of ISO 9283 for an isotropic 3-D Gaussian of σ per coordinate, in units of σ
/// (Maxwell distribution: mean 1.596 σ, standard deviation 0.673 σ).
pub const RP_IN_SIGMAS: f64 = 1.595_769 + 3.0 * 0.673_4;

/// Backlash of the TX60's main axes J1–J3, degrees.
pub const MAIN_AXIS_BACKLASH_DEG: f64 = 0.004;
/// Backlash of the TX60's wrist axes J4–J6, degrees.
pub const WRIST_BACKLASH_DEG: f64 = 0.008;

impl Default for RobotErrorModel {
    /// The TX60's error model ([`RobotErrorModel::for_joints`] of six joints).
    fn default() -> Self {
        Self::for_joints(6)
    }
}

impl RobotErrorModel {
    /// The default error model for a robot of `joints` joints (at most
    /// [`crate::kinematics::MAX_JOINTS`]): the TX60's repeatability and dynamics, and the
    /// backlash of its gearing class per joint, [`MAIN_AXIS_BACKLASH_DEG`] on J1–J3 and
    /// [`WRIST_BACKLASH_DEG`] from J4 on. The published classes are the six TX60 joints'; a
    /// seventh joint (a seven-axis arm's last wrist joint) is given the wrist class, and a
    /// four- or five-joint arm keeps the first entries.
    pub fn for_joints(joints: usize) -> Self {
        RobotErrorModel {
            repeatability_mm: 0.02,
            vibration_at_rated_mm: 0.025,
            settling_at_rated_deg: 0.002,
            backlash_deg: Joints::from_fn(joints, |j| {
                if j < 3 {
                    MAIN_AXIS_BACKLASH_DEG
                } else {
                    WRIST_BACKLASH_DEG
                }
            }),
            engaged_scatter: 0.1,
        }
    }

    /// No error at all (for tests).
    pub fn none() -> Self {
        RobotErrorModel {
            repeatability_mm: 0.0,
            vibration_at_rated_mm: 0.0,
            settling_at_rated_deg: 0.0,
            backlash_deg: Joints::filled(6, 0.0),
            engaged_scatter: 0.0,
        }
    }

    /// Backlash of joint `joint` (0-based), degrees: its entry of [`Self::backlash_deg`], or for
    /// a joint beyond the list the last entry (the wrist class of [`Self::for_joints`]), 0 for an
    /// empty list. So the six-joint default serves a seven-axis arm too.
    pub fn backlash(&self, joint: usize) -> f64 {
        self.backlash_deg
            .get(joint)
            .or(self.backlash_deg.last())
            .copied()
            .unwrap_or(0.0)
    }

    /// σ per coordinate of the pose repeatability scatter, mm.
    pub fn repeatability_sigma_mm(&self) -> f64 {
        self.repeatability_mm / RP_IN_SIGMAS
    }

    /// Whether gravity pulls joint `joint` (0-based) of `nominal` at `q_rad` (one angle per joint
    /// of `nominal`) in the direction `dir` (+1 / −1): the sign of the gravity torque about the
    /// joint axis, distal mass lumped at the target. Torques below 1 % of the lever arm count as
    /// none.
    pub fn gravity_assists(nominal: &RobotModel, joint: usize, q_rad: &[f64], dir: f64) -> bool {
        let mut partial = Joints::filled(q_rad.len(), 0.0);
        partial[..joint].copy_from_slice(&q_rad[..joint]);
        // Frame of joint `joint`: product of the transforms before it, rotated by its q about z.
        let t = if joint == 0 {
            [
                [1.0, 0.0, 0.0, 0.0],
                [0.0, 1.0, 0.0, 0.0],
                [0.0, 0.0, 1.0, 0.0],
                [0.0, 0.0, 0.0, 1.0],
            ]
        } else {
            let mut p = nominal.params;
            // zero the joints from `joint` on: transform of the first `joint` links only
            for v in p[joint * 5..].iter_mut() {
                *v = 0.0;
            }
            transform(&p, &partial)
        };
        let axis = [t[0][2], t[1][2], t[2][2]];
        let origin = [t[0][3], t[1][3], t[2][3]];
        let target = position(&nominal.params, &nominal.tool, q_rad);
        let r = [
            target[0] - origin[0],
            target[1] - origin[1],
            target[2] - origin[2],
        ];
        // torque of a unit downward force at the target: r × (0, 0, −1) = (−r_y, r_x, 0)
        let tau = axis[0] * (-r[1]) + axis[1] * r[0];
        let lever = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt().max(1e-9);
        tau * dir > 0.01 * lever
    }

    /// The actual angle error (degrees) of the moving joint `joint` (0-based) at a stop reached
    /// in direction `dir` at speed fraction `speed` (commanded angles `q_cmd_deg`, one per joint
    /// of `nominal`): backlash lost motion plus settling error.
    pub fn joint_error_deg(
        &self,
        nominal: &RobotModel,
        joint: usize,
        q_cmd_deg: &[f64],
        dir: f64,
        speed: f64,
        rng: &mut impl Rng,
    ) -> f64 {
        let b = self.backlash(joint);
        let q_rad = Joints::from_fn(q_cmd_deg.len(), |i| q_cmd_deg[i].to_radians());
        let lost = if b == 0.0 {
            0.0
        } else if Self::gravity_assists(nominal, joint, &q_rad, dir) {
            b * rng.random::<f64>()
        } else {
            b * (0.5 + self.engaged_scatter * (rng.random::<f64>() - 0.5))
        };
        let settle = self.settling_at_rated_deg * speed * standard_normal(rng);
        -dir * lost + settle
    }

    /// End-point scatter (mm) of one stop: pose repeatability plus residual vibration.
    pub fn point_scatter_mm(&self, speed: f64, rng: &mut impl Rng) -> [f64; 3] {
        let s = (self.repeatability_sigma_mm().powi(2)
            + (self.vibration_at_rated_mm * speed * speed).powi(2))
        .sqrt();
        if s == 0.0 {
            return [0.0; 3];
        }
        std::array::from_fn(|_| s * standard_normal(rng))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checks_name_the_setting() {
        let bad = [
            (
                Factors {
                    runs: 1,
                    ..Default::default()
                },
                "runs",
            ),
            (
                Factors {
                    range_fraction: 0.0,
                    ..Default::default()
                },
                "range",
            ),
            (
                Factors {
                    step_deg: 0.0,
                    ..Default::default()
                },
                "step",
            ),
            (
                Factors {
                    speed_fraction: -0.1,
                    ..Default::default()
                },
                "speed",
            ),
        ];
        for (f, field) in bad {
            let e = f.check().unwrap_err();
            assert!(matches!(e, SimulateError::Setting { field: s, .. } if s.to_string() == field));
            assert!(e.to_string().starts_with(field));
        }
        assert!(Factors::default().check().is_ok());
    }

    #[test]
    fn repeatability_sigma_and_gravity() {
        let m = RobotErrorModel::default();
        assert!((m.repeatability_sigma_mm() - 0.02 / 3.616).abs() < 1e-4);
        assert_eq!(
            &*m.backlash_deg,
            &[0.004, 0.004, 0.004, 0.008, 0.008, 0.008]
        );
        assert_eq!(m.backlash(6), 0.008);
        assert_eq!(RobotErrorModel::for_joints(7).backlash_deg[6], 0.008);
        assert_eq!(RobotErrorModel::for_joints(4).backlash_deg.len(), 4);
        let n = crate::kinematics::tx60();
        let q = [0.0, 61.0f64, 68.5, 0.0, 60.0, 0.0].map(f64::to_radians);
        // J1 is vertical: gravity never assists it.
        assert!(!RobotErrorModel::gravity_assists(&n, 0, &q, 1.0));
        assert!(!RobotErrorModel::gravity_assists(&n, 0, &q, -1.0));
        // J2 carries the arm: gravity assists exactly one direction.
        let a = RobotErrorModel::gravity_assists(&n, 1, &q, 1.0);
        let b = RobotErrorModel::gravity_assists(&n, 1, &q, -1.0);
        assert!(a != b);
    }
}
