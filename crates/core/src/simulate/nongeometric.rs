//! Non-geometric errors of a simulated true robot (issue 33): joint compliance under gravity
//! and payload, gear harmonics and backlash. No geometric model holds them, so a calibration of
//! the geometry alone cannot remove them. Backlash (a gap per joint, [`BACKLASH_GAPS_DEG`]
//! times a scale) leaves each joint half its gap beyond the commanded angle on the side it
//! arrived from, which depends on the order the poses are visited in
//! ([`super::poses::simulate_poses_at`]).
//!
//! At the commanded joint angles `q` (rad) the joints stand at `q + Δθ(q)`, with
//!
//! * gear harmonics `h_i = A_i sin(q_i + φ_i) + B_i sin(2q_i + ψ_i)`;
//! * joint compliance `c_i = k_i · τ_i(q + h)`, `τ_i` the gravity torque (N·m) about joint i's
//!   axis of the links beyond it and of the payload, at the angles the harmonics give;
//!
//! and `Δθ_i = h_i + c_i`. Gravity acts along −z of the robot's base frame (9.81 m/s²). Link i
//! (the body joint i turns) has its mass at the middle of the origins of frames i − 1 and i (the
//! frames before and after joint i's transform, both of which move with link i); the payload
//! sits at the tool point.
//!
//! Sizes ([`NonGeometricSizes`]): a scale `s` each for compliance and harmonics (0: none, 1: a
//! 60 kg-class arm such as the TX60) and the payload in kg. Per robot, from a seed,
//! `k_i ~ U(1, 5)·10⁻⁶ rad/(N·m) × s_compliance` and `A_i, B_i ~ U(0.002, 0.01)° × s_harmonics`
//! with phases uniform in [0, 2π). The draws do not depend on the sizes, so one seed gives one
//! robot whose non-geometric errors scale with `s`.
//!
//! The link masses are the model's own when it has them (imported `<inertial>` data, the
//! `[links]` table), else a documented default ([`default_link_masses`]): the figures 12, 10, 6,
//! 5, 1.5, 0.5 kg for the six links of a TX60-class arm (further links 0.5 kg), scaled by the
//! square of the robot's size against the TX60's (size: the sum of |a| and |d| over the chain).
//! They are plausible, not published.

use crate::kinematics::{position, Capped, Joints, RobotModel, MAX_JOINTS};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

pub use crate::kinematics::gravity::{default_link_masses, LinkMasses, GRAVITY, TX60_LINK_MASS_KG};

/// Compliance of a joint at scale 1, rad/(N·m): drawn uniformly in this range.
pub const COMPLIANCE_RANGE: (f64, f64) = (1e-6, 5e-6);

/// Amplitude of a gear harmonic at scale 1, degrees: drawn uniformly in this range.
pub const HARMONIC_RANGE_DEG: (f64, f64) = (0.002, 0.01);

/// Backlash gaps of a 60 kg-class arm at scale 1, degrees, joints 1 to 6 (larger at the base;
/// the public IRB 120 data show 0.061°, 0.028° and 0.017° on its first three joints, Method
/// §19.5); a seventh joint takes the last. Plausible, not published.
pub const BACKLASH_GAPS_DEG: [f64; 6] = [0.05, 0.03, 0.02, 0.01, 0.02, 0.02];

/// The largest scale [`NonGeometricSizes::check`] accepts.
pub const MAX_SCALE: f64 = 10.0;

/// The largest payload [`NonGeometricSizes::check`] accepts, kg.
pub const MAX_PAYLOAD_KG: f64 = 1000.0;

/// How large a simulated robot's non-geometric errors are.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct NonGeometricSizes {
    /// Scale of the joint compliance (0: rigid joints, 1: a 60 kg-class arm).
    pub compliance: f64,
    /// Scale of the gear harmonics (0: none, 1: a 60 kg-class arm).
    pub harmonics: f64,
    /// Payload at the tool point, kg (acts through the compliance).
    pub payload_kg: f64,
    /// Scale of the gears' backlash (0: none, 1: [`BACKLASH_GAPS_DEG`]): each joint stands half
    /// its gap beyond the commanded angle on the side it arrived from.
    pub backlash: f64,
}

/// Which size [`NonGeometricSizes::check`] refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NonGeometricSetting {
    /// [`NonGeometricSizes::compliance`].
    Compliance,
    /// [`NonGeometricSizes::harmonics`].
    Harmonics,
    /// [`NonGeometricSizes::payload_kg`].
    Payload,
    /// [`NonGeometricSizes::backlash`].
    Backlash,
}

/// A non-geometric size out of range.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{message}")]
pub struct NonGeometricError {
    /// The size.
    pub setting: NonGeometricSetting,
    /// What is wrong (without the setting's name, which a front end adds).
    pub message: String,
}

impl NonGeometricSizes {
    /// No non-geometric errors: a purely geometric robot.
    pub fn none() -> Self {
        Self::default()
    }

    /// Whether the robot these sizes make is purely geometric (no compliance, no harmonics; a
    /// payload without compliance moves nothing).
    pub fn is_geometric(&self) -> bool {
        self.compliance == 0.0 && self.harmonics == 0.0 && self.backlash == 0.0
    }

    /// Checks the sizes.
    ///
    /// # Errors
    ///
    /// [`NonGeometricError`] naming the first size that is not a finite number in
    /// 0–[`MAX_SCALE`] (the scales) or 0–[`MAX_PAYLOAD_KG`] (the payload).
    pub fn check(&self) -> Result<(), NonGeometricError> {
        let within = |v: f64, max: f64| v.is_finite() && (0.0..=max).contains(&v);
        for (setting, v, max, what) in [
            (
                NonGeometricSetting::Compliance,
                self.compliance,
                MAX_SCALE,
                "scale",
            ),
            (
                NonGeometricSetting::Harmonics,
                self.harmonics,
                MAX_SCALE,
                "scale",
            ),
            (
                NonGeometricSetting::Payload,
                self.payload_kg,
                MAX_PAYLOAD_KG,
                "mass in kg",
            ),
            (
                NonGeometricSetting::Backlash,
                self.backlash,
                MAX_SCALE,
                "scale",
            ),
        ] {
            if !within(v, max) {
                return Err(NonGeometricError {
                    setting,
                    message: format!("{v} is not a {what} in 0–{max}"),
                });
            }
        }
        Ok(())
    }
}

/// The non-geometric errors of one simulated robot.
#[derive(Clone, Debug, PartialEq)]
pub struct NonGeometric {
    /// Joint compliance (inverse stiffness), rad/(N·m), per joint.
    pub compliance: Joints,
    /// `A, φ, B, ψ` of each joint's harmonics, rad.
    pub harmonics: Capped<[f64; 4], MAX_JOINTS>,
    /// Link masses and centres of mass (link i is the body joint i turns).
    pub links: LinkMasses,
    /// Payload at the tool point, kg.
    pub payload_kg: f64,
    /// Backlash gap per joint, degrees (all zero: none); see [`Self::side_turns`].
    pub backlash_deg: Joints,
}

impl NonGeometric {
    /// The errors of a robot like `model` at `sizes`, drawn from `seed` (see the module docs);
    /// `None` for a purely geometric robot ([`NonGeometricSizes::is_geometric`]), so that the
    /// simulation then is the geometric one, bit for bit.
    pub fn draw(model: &RobotModel, sizes: &NonGeometricSizes, seed: u64) -> Option<Self> {
        if sizes.is_geometric() {
            return None;
        }
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x6e6f_6e67_656f_6d00);
        let n = model.joints();
        let (klo, khi) = COMPLIANCE_RANGE;
        let compliance = Joints::from_fn(n, |_| rng.random_range(klo..khi) * sizes.compliance);
        let (hlo, hhi) = HARMONIC_RANGE_DEG;
        let harmonics = Capped::from_fn(n, |_| {
            let mut amplitude = || rng.random_range(hlo..hhi).to_radians() * sizes.harmonics;
            let a = amplitude();
            let b = amplitude();
            [
                a,
                rng.random_range(0.0..2.0 * PI),
                b,
                rng.random_range(0.0..2.0 * PI),
            ]
        });
        Some(NonGeometric {
            compliance,
            harmonics,
            links: LinkMasses::of(model),
            payload_kg: sizes.payload_kg,
            backlash_deg: Joints::from_fn(n, |j| {
                sizes.backlash * BACKLASH_GAPS_DEG[j.min(BACKLASH_GAPS_DEG.len() - 1)]
            }),
        })
    }

    /// The gravity torque about each joint's axis, N·m, of the links beyond it and the payload,
    /// with `model`'s chain at the joint angles `q` (rad).
    pub fn gravity_torques(&self, model: &RobotModel, q: &[f64]) -> Joints {
        crate::kinematics::gravity::gravity_torques(
            &model.params,
            &model.tool,
            &self.links,
            self.payload_kg,
            q,
        )
    }

    /// The joints' deflections (rad) at the commanded angles `q` (rad): harmonics plus the
    /// compliance under the gravity torques at the angles the harmonics give.
    pub fn deflections(&self, model: &RobotModel, q: &[f64]) -> Joints {
        let harmonic = Joints::from_fn(q.len(), |i| {
            let [a, phi, b, psi] = self.harmonics[i];
            a * (q[i] + phi).sin() + b * (2.0 * q[i] + psi).sin()
        });
        let geared = Joints::from_fn(q.len(), |i| q[i] + harmonic[i]);
        let tau = self.gravity_torques(model, &geared);
        Joints::from_fn(q.len(), |i| harmonic[i] + self.compliance[i] * tau[i])
    }

    /// How far (rad) each joint stands beyond its commanded angle for having arrived from
    /// `sides` (per joint 1: moving positive, −1, 0: not known or not moved, no turn): half its
    /// backlash gap on that side.
    pub fn side_turns(&self, sides: &[f64]) -> Joints {
        Joints::from_fn(sides.len(), |j| {
            0.5 * self
                .backlash_deg
                .get(j)
                .copied()
                .unwrap_or(0.0)
                .to_radians()
                * sides[j]
        })
    }

    /// The angles the joints really stand at when commanded to `q` (rad) and arriving from
    /// `sides` ([`Self::side_turns`]): [`Self::actual_angles`] with each joint's half gap added
    /// on its side.
    pub fn sided_angles(&self, model: &RobotModel, q: &[f64], sides: &[f64]) -> Joints {
        let mut at = self.actual_angles(model, q);
        for (a, t) in at.iter_mut().zip(self.side_turns(sides).iter()) {
            *a += t;
        }
        at
    }

    /// Whether the robot's gears have backlash.
    pub fn has_backlash(&self) -> bool {
        self.backlash_deg.iter().any(|&g| g > 0.0)
    }

    /// The angles the joints really stand at when commanded to `q` (rad).
    pub fn actual_angles(&self, model: &RobotModel, q: &[f64]) -> Joints {
        let dq = self.deflections(model, q);
        Joints::from_fn(q.len(), |i| q[i] + dq[i])
    }
}

/// The tool point of the true robot `model` with non-geometric errors `errors` (none: the
/// geometric robot, `kinematics::position` itself) at the commanded angles `q` (rad), in the
/// base frame, mm.
pub fn true_position(model: &RobotModel, errors: Option<&NonGeometric>, q: &[f64]) -> [f64; 3] {
    match errors {
        None => position(&model.params, &model.tool, q),
        Some(e) => position(&model.params, &model.tool, &e.actual_angles(model, q)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::tx60;

    #[test]
    fn sizes_are_checked_and_scale_the_same_robot() {
        assert!(NonGeometricSizes::none().check().is_ok());
        let bad = NonGeometricSizes {
            harmonics: f64::NAN,
            ..NonGeometricSizes::none()
        };
        assert_eq!(
            bad.check().unwrap_err().setting,
            NonGeometricSetting::Harmonics
        );
        let bad = NonGeometricSizes {
            compliance: 11.0,
            ..NonGeometricSizes::none()
        };
        assert_eq!(
            bad.check().unwrap_err().setting,
            NonGeometricSetting::Compliance
        );
        let m = tx60();
        assert!(NonGeometric::draw(&m, &NonGeometricSizes::none(), 1).is_none());
        let one = NonGeometricSizes {
            compliance: 1.0,
            harmonics: 1.0,
            payload_kg: 0.0,
            backlash: 0.0,
        };
        let two = NonGeometricSizes {
            compliance: 2.0,
            harmonics: 2.0,
            payload_kg: 0.0,
            backlash: 0.0,
        };
        let a = NonGeometric::draw(&m, &one, 7).unwrap();
        let b = NonGeometric::draw(&m, &two, 7).unwrap();
        let q = [0.3, -0.5, 1.2, 0.1, 0.7, -0.2];
        // The same draws, scaled: compliance and amplitudes doubled, phases kept.
        for i in 0..6 {
            assert!((2.0 * a.compliance[i] - b.compliance[i]).abs() < 1e-18);
            let (ha, hb) = (a.harmonics[i], b.harmonics[i]);
            assert!((2.0 * ha[0] - hb[0]).abs() < 1e-15 && (2.0 * ha[2] - hb[2]).abs() < 1e-15);
            assert_eq!((ha[1], ha[3]), (hb[1], hb[3]));
        }
        let da = a.deflections(&m, &q);
        assert!(da.iter().all(|v| v.abs() < 2e-3 && *v != 0.0), "{da:?}");
        // The masses are the TX60 figures on the TX60.
        let masses = default_link_masses(&m);
        assert!((masses[0] - 12.0).abs() < 1e-12 && (masses[5] - 0.5).abs() < 1e-12);
    }

    #[test]
    fn gravity_torque_of_a_point_mass_is_its_lever_arm() {
        // Only the payload, 1 kg, no links: J1 (vertical) sees no torque; J2 (along y at the
        // zero pose, through the base z axis) sees the weight times the payload's x.
        let m = tx60();
        let e = NonGeometric {
            compliance: Joints::filled(6, 0.0),
            harmonics: Capped::filled(6, [0.0; 4]),
            links: LinkMasses::at_midpoints(Joints::filled(6, 0.0)),
            payload_kg: 1.0,
            backlash_deg: Joints::filled(6, 0.0),
        };
        let q = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let tau = e.gravity_torques(&m, &q);
        assert!(tau[0].abs() < 1e-12);
        let p = position(&m.params, &m.tool, &q);
        let lever = p[0].abs() * 1e-3;
        assert!(
            (tau[1].abs() - lever * GRAVITY).abs() < 1e-9,
            "{tau:?} {lever}"
        );
    }
}
