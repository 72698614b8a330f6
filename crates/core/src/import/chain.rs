//! The source side of an import: the serial chain of revolute joints a reader makes of its file,
//! its joints held at a fixed angle, and its own forward kinematics (what the proof checks the
//! model against).

use super::ImportError;
use crate::number::fmt_plain;
use nalgebra::{Isometry3, Unit, UnitQuaternion, Vector3};

/// The kind of file a chain came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SourceFormat {
    /// URDF (XML).
    Urdf,
    /// Standard (distal) DH table.
    StandardDh,
    /// Craig's modified (proximal) DH table.
    ModifiedDh,
    /// UR calibration file (`kinematics:` with x, y, z, roll, pitch, yaw per joint).
    UrCalibration,
}

impl SourceFormat {
    /// The name written in the model header.
    pub fn name(self) -> &'static str {
        match self {
            Self::Urdf => "URDF",
            Self::StandardDh => "standard DH table",
            Self::ModifiedDh => "modified (Craig) DH table",
            Self::UrCalibration => "UR calibration",
        }
    }
}

/// One revolute joint of a source chain (lengths in mm).
#[derive(Clone, Debug, PartialEq)]
pub struct SourceJoint {
    /// The joint's name in its file.
    pub name: String,
    /// Fixed transform from the previous joint's frame (after its rotation; the base frame for
    /// the first joint) to this joint's frame.
    pub origin: Isometry3<f64>,
    /// Rotation axis in this joint's frame (unit; positive q turns right-handed about it).
    pub axis: Unit<Vector3<f64>>,
    /// Joint limits, degrees, min < max.
    pub limits_deg: (f64, f64),
}

/// Most revolute joints a description may have before joints are held ([`JointHold`]).
pub const MAX_SOURCE_JOINTS: usize = 12;

/// A joint held at a fixed angle on import: the held joint's rotation joins the fixed transform
/// to the next joint, so each hold takes one joint off the model (a seven-axis arm with one joint
/// held becomes a six-axis model; a description of more than
/// [`MAX_JOINTS`](crate::kinematics::MAX_JOINTS) revolute joints
/// needs holds to import at all).
#[derive(Clone, Debug, PartialEq)]
pub struct JointHold {
    /// The joint: its name in the description (a URDF joint name, `joint 3` of a DH table) or
    /// its 1-based number along the chain.
    pub joint: String,
    /// The angle it is held at, degrees (within its limits).
    pub angle_deg: f64,
}

/// The body a revolute joint turns (its child link and everything fixed to it), as a description's
/// `<inertial>` data give it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SourceBody {
    /// Mass, kg.
    pub mass_kg: f64,
    /// Centre of mass in the joint's frame (after its rotation), mm.
    pub com_mm: Vector3<f64>,
}

/// A serial chain of revolute joints as a file describes it (lengths in mm); a model takes
/// [`MIN_JOINTS`](crate::kinematics::MIN_JOINTS) to [`MAX_JOINTS`](crate::kinematics::MAX_JOINTS)
/// of them.
#[derive(Clone, Debug, PartialEq)]
pub struct SourceChain {
    /// Model name.
    pub name: String,
    /// Where it came from.
    pub format: SourceFormat,
    /// The revolute joints, base to tip.
    pub joints: Vec<SourceJoint>,
    /// The chain in words for messages ("the chain from 'base_link' to 'tool0'", "the table").
    pub what: String,
    /// Fixed transform from the last joint's frame (after its rotation) to the tip.
    pub tip: Isometry3<f64>,
    /// What the reader chose that the user did not say (the tip link of a URDF given without
    /// one) and the joints held, for the user to see, one line each.
    pub notes: Vec<String>,
    /// The joints held ([`SourceChain::hold`]), one line each (also in `notes`).
    pub held: Vec<String>,
    /// The arm's own base frame in the description's frame, when the description names one
    /// (UR's `base_link_inertia`, `base_link` turned half a turn about z, which UR's calibration
    /// files are relative to). Used as the model's base frame when its z is joint 1's axis.
    pub arm_frame: Option<Isometry3<f64>>,
    /// The moving bodies, one per joint, when the description gives masses (URDF `<inertial>`);
    /// dropped when joints are held.
    pub bodies: Option<Vec<SourceBody>>,
}

impl SourceChain {
    /// Holds the joints `holds` name at their angles: each one's rotation is composed into the
    /// fixed transform that follows it (the next joint's origin, or the tip), and the joint
    /// leaves the chain. `path` names the source in errors.
    ///
    /// # Errors
    ///
    /// [`ImportError::Chain`] for a joint the chain does not have, one named twice, or an angle
    /// that is not finite or outside the joint's limits.
    pub fn hold(&mut self, holds: &[JointHold], path: &str) -> Result<(), ImportError> {
        let refuse = |message: String| ImportError::Chain {
            path: path.into(),
            message,
        };
        let mut held = vec![None; self.joints.len()];
        for h in holds {
            let k = self
                .joints
                .iter()
                .position(|j| j.name == h.joint)
                .or_else(|| {
                    h.joint
                        .parse::<usize>()
                        .ok()
                        .filter(|&n| (1..=self.joints.len()).contains(&n))
                        .map(|n| n - 1)
                })
                .ok_or_else(|| {
                    let names: Vec<&str> = self.joints.iter().map(|j| j.name.as_str()).collect();
                    refuse(format!(
                        "joint '{}' to hold is not in {} (its revolute joints: {}; or a number 1 to {})",
                        h.joint,
                        self.what,
                        names.join(", "),
                        self.joints.len()
                    ))
                })?;
            let j = &self.joints[k];
            let (lo, hi) = j.limits_deg;
            if !h.angle_deg.is_finite() || h.angle_deg < lo || h.angle_deg > hi {
                return Err(refuse(format!(
                    "joint '{}' cannot be held at {}°: its limits are {}° to {}°",
                    j.name,
                    fmt_plain(h.angle_deg),
                    fmt_plain(lo),
                    fmt_plain(hi)
                )));
            }
            if held[k].is_some() {
                return Err(refuse(format!("joint '{}' is held twice", j.name)));
            }
            held[k] = Some(h.angle_deg);
        }
        let mut kept: Vec<SourceJoint> = Vec::with_capacity(self.joints.len());
        // The fixed transform since the last kept joint's rotation.
        let mut pending: Option<Isometry3<f64>> = None;
        for (j, angle) in self.joints.drain(..).zip(held) {
            let origin = pending.take().map_or(j.origin, |p| p * j.origin);
            match angle {
                Some(a) => {
                    pending =
                        Some(origin * UnitQuaternion::from_axis_angle(&j.axis, a.to_radians()));
                    self.held.push(format!(
                        "joint '{}' held at {}° (its limits {}° to {}°)",
                        j.name,
                        fmt_plain(a),
                        fmt_plain(j.limits_deg.0),
                        fmt_plain(j.limits_deg.1)
                    ));
                }
                None => kept.push(SourceJoint { origin, ..j }),
            }
        }
        if let Some(p) = pending {
            self.tip = p * self.tip;
        }
        self.joints = kept;
        if !holds.is_empty() && self.bodies.take().is_some() {
            self.held.push(
                "link masses (<inertial>) not imported: joints are held (joint compliance assumes default masses)"
                    .into(),
            );
        }
        self.notes.extend(self.held.iter().cloned());
        Ok(())
    }

    /// Tip transform at joint angles `q` (radians, one per joint of the chain), composed from
    /// the source's own transforms.
    pub fn transform(&self, q: &[f64]) -> Isometry3<f64> {
        debug_assert_eq!(q.len(), self.joints.len());
        let mut t = Isometry3::identity();
        for (j, qj) in self.joints.iter().zip(q) {
            t = t * j.origin * UnitQuaternion::from_axis_angle(&j.axis, *qj);
        }
        t * self.tip
    }

    /// Tip position (mm) at joint angles `q` (radians, one per joint of the chain).
    pub fn position(&self, q: &[f64]) -> [f64; 3] {
        let p = self.transform(q).translation.vector;
        [p.x, p.y, p.z]
    }
}
