//! The side every joint arrives at each pose from (docs/METHOD.md §19.5): a plan measured with
//! the robot's backlash engaged the same way at every pose, by a move to an approach pose just
//! short of each pose on that side first. The gaps then act as offsets the calibration takes
//! into the joints' zeros, the pose file records the sides (`s1..sn`), and a task program that
//! approaches its points the same way is predicted without the spread the sides would draw.

use super::{setting, Plan, PlanError, PlanField};
use crate::kinematics::Joints;

/// How far short of each pose every joint stops on the approach side, degrees: more than any
/// gear's backlash the model accepts (at most 1°), well within the plan's margin from the joint
/// limits (5° by default).
pub const APPROACH_STEP_DEG: f64 = 2.0;

/// The side every joint arrives from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Approach {
    /// Every joint arrives moving in its positive direction.
    Positive,
    /// Every joint arrives moving in its negative direction.
    Negative,
}

impl Approach {
    /// `+1` or `−1`: the side as pose files write it.
    pub fn sign(self) -> f64 {
        match self {
            Approach::Positive => 1.0,
            Approach::Negative => -1.0,
        }
    }

    /// The side a name gives (`positive`, `negative`; any case).
    pub fn from_name(name: &str) -> Option<Approach> {
        match name.to_ascii_lowercase().as_str() {
            "positive" | "+" => Some(Approach::Positive),
            "negative" | "-" => Some(Approach::Negative),
            _ => None,
        }
    }

    /// The side's name in words.
    pub fn name(self) -> &'static str {
        match self {
            Approach::Positive => "positive",
            Approach::Negative => "negative",
        }
    }
}

/// The approach pose of `q` (degrees): every joint [`APPROACH_STEP_DEG`] short of it on the side
/// `approach` opposes.
pub fn approach_pose(q: &Joints, approach: Approach) -> Joints {
    let step = approach.sign() * APPROACH_STEP_DEG;
    q.map(|v| v - step)
}

impl Plan {
    /// The approach pose of each design pose (degrees, visiting order): every joint
    /// [`APPROACH_STEP_DEG`] short of the pose on the side `approach` opposes, so that the move
    /// from it arrives from that side.
    ///
    /// # Errors
    ///
    /// [`PlanError::Setting`] ([`PlanField::Approach`]) naming the first pose whose approach pose
    /// leaves a joint limit the plan kept to or breaks its workcell (floor, keep-out boxes,
    /// self-collision): never for a plan made with that approach, whose candidates were
    /// chosen with theirs clear ([`super::PlanOptions::approach`]).
    pub fn approach_poses(&self, approach: Approach) -> Result<Vec<Joints>, PlanError> {
        let s = crate::identify::chain::nominal_state(&self.nominal);
        (self.design_deg.iter().enumerate())
            .map(|(k, q)| {
                let p = approach_pose(q, approach);
                for (j, (&v, &(lo, hi))) in p.iter().zip(&self.limits_deg).enumerate() {
                    if !(lo..=hi).contains(&v) {
                        return Err(setting(
                            PlanField::Approach,
                            format!(
                                "pose {}: joint {} would start its {} approach at {v:.3}°, outside its limits {lo}° … {hi}°",
                                k + 1,
                                j + 1,
                                approach.name()
                            ),
                        ));
                    }
                }
                let rad = p.map(f64::to_radians);
                match super::workcell::clash(&self.nominal, &s, &rad, &self.workcell, true) {
                    Some(c) => Err(setting(
                        PlanField::Approach,
                        format!("pose {}: at its {} approach pose {c}", k + 1, approach.name()),
                    )),
                    None => Ok(p),
                }
            })
            .collect()
    }
}
