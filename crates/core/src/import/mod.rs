//! Robot descriptions from other tools to the MDH model and back (docs/METHOD.md §1).
//!
//! Every reader ([`urdf`], [`dh`], [`ur`]) turns its file into a [`SourceChain`]: `n` revolute
//! joints, each a fixed transform from the previous joint's frame followed by a rotation about
//! its axis, and the fixed transform from the last joint's frame to the tip. A chain of
//! [`MIN_JOINTS`] to [`MAX_JOINTS`] joints (4 to 7: a six-axis industrial arm, a seven-axis
//! KUKA LBR iiwa or Franka Panda) becomes a model of as many joints; joints held at a fixed
//! angle ([`SourceChain::hold`]) leave the chain first. [`convert`] then
//!
//! 1. places every joint axis in the base frame at q = 0 and hands the `n` lines and the tip
//!    point to the lines → MDH conversion the identification uses too
//!    ([`crate::kinematics::mdh::chain_from_zero_pose`]): one conversion for measured and
//!    imported axes;
//! 2. **proves** the result: the source's own forward kinematics ([`SourceChain::position`],
//!    composed from its transforms with no MDH code) against the model's at q = 0 and
//!    [`PROOF_CONFIGURATIONS`] random configurations within the limits; a maximum deviation above
//!    [`PROOF_TOLERANCE_MM`] fails the import.
//!
//! What the MDH form cannot hold is an error naming the joint, never an approximation: two
//! consecutive axes cannot coincide. The model's first axis is its base z axis through its base
//! origin, pointing up (there are no parameters before `Rz(θ_1 + q_1)`), so the first axis of
//! the description, wherever it lies (a wall or ceiling mount, ROS-Industrial's KUKA arms whose
//! first axis points down and sits off the origin, a world → base joint with an offset), defines
//! the model's base frame B: z along that axis, the origin at the axis point nearest the
//! description's origin, x the description's x carried along by the smallest rotation that
//! takes z to the axis (after a half turn about x when the axis points within 45° of down). The chain is
//! expressed in B and the model keeps B's placement as its base transform
//! ([`crate::kinematics::BaseTransform`]), which forward kinematics, export and the proof apply
//! (errors and `w` are invariant to it). An axis along +z through the origin gives no base
//! transform, one along −z through the origin exactly `Rx(180°)`. Source q = 0 is
//! model q = 0 and each joint turns in its source's sense. Only the tip's position is kept (the
//! model's tool point); its orientation is not part of the model.
//!
//! [`export`] writes a model back out as URDF or as a UR calibration file.

pub mod dh;
pub mod export;
#[cfg(test)]
mod tests;
pub mod ur;
pub mod urdf;
pub mod xacro;

use crate::kinematics::lines::Line;
use crate::kinematics::mdh::{chain_from_zero_pose, GeometryError};
use crate::kinematics::{
    BaseTransform, Joints, Layout, Limits, Params, RobotModel, Uncertainty, MAX_JOINTS, MIN_JOINTS,
};
use crate::number::fmt_plain;
use nalgebra::{Isometry3, Translation3, Unit, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use std::fmt::Write as _;

/// Random configurations of the import proof (q = 0 is checked besides).
pub const PROOF_CONFIGURATIONS: usize = 1000;
/// Largest tool-point deviation (mm) between source and model that the proof accepts. The
/// conversion is exact; what remains is f64 rounding, about 1e-13 mm at a 2 m reach.
pub const PROOF_TOLERANCE_MM: f64 = 1e-9;
/// Seed of the proof's configurations (fixed: an import is reproducible).
pub const PROOF_SEED: u64 = 0x1d_2024;
/// Rounding tolerances of joint 1's axis: a tilt from z (radians) and an offset from the origin
/// (mm) within them is not turned or moved into the base frame, and the check after the move
/// allows them. Well below what would move a 2 m arm by 1e-9 mm.
const BASE_TILT_EPS: f64 = 1e-13;
const BASE_OFFSET_EPS_MM: f64 = 1e-10;

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
/// held becomes a six-axis model; a description of more than [`MAX_JOINTS`] revolute joints
/// needs holds to import at all).
#[derive(Clone, Debug, PartialEq)]
pub struct JointHold {
    /// The joint: its name in the description (a URDF joint name, `joint 3` of a DH table) or
    /// its 1-based number along the chain.
    pub joint: String,
    /// The angle it is held at, degrees (within its limits).
    pub angle_deg: f64,
}

/// A serial chain of revolute joints as a file describes it (lengths in mm); a model takes
/// [`MIN_JOINTS`] to [`MAX_JOINTS`] of them.
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

/// Errors reading or converting a robot description.
#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    /// The file could not be read, is not UTF-8 or is larger than
    /// [`DESCRIPTION_FILE_LIMIT`](crate::input::DESCRIPTION_FILE_LIMIT).
    #[error(transparent)]
    Read(#[from] crate::input::ReadError),
    /// The file is not well-formed (XML, CSV, TOML or YAML).
    #[error("{path}:{line}: {message}")]
    Syntax {
        /// The path given.
        path: String,
        /// 1-based line.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// A xacro construct that is not supported or does not expand (see [`xacro`]), or xacro
    /// left in a `.urdf` file.
    #[error("{path}:{line}: xacro: {what}")]
    Xacro {
        /// The file (the one given, or the included file the construct is in).
        path: String,
        /// 1-based line of the construct.
        line: usize,
        /// The construct and what is wrong with it.
        what: String,
    },
    /// An element or field is wrong or not supported; the message names it.
    #[error("{path}{}: {element}: {message}", at_line(.line))]
    Element {
        /// The path given.
        path: String,
        /// 1-based line (0 when the file has no line for it: then none is printed).
        line: usize,
        /// The element, e.g. `joint 'elbow'` or `joint[3].alpha`.
        element: String,
        /// What is wrong.
        message: String,
    },
    /// The chain between base and tip is not [`MIN_JOINTS`] to [`MAX_JOINTS`] revolute joints
    /// (after any held), or cannot be found.
    #[error("{path}: {message}")]
    Chain {
        /// The path given.
        path: String,
        /// What is wrong, naming links and joints.
        message: String,
    },
    /// The chain branches below the base and no tip link was named.
    #[error("{path}: the chain branches below link '{base}' (leaf links: {}); name the tip link", leaves.join(", "))]
    Branching {
        /// The path given.
        path: String,
        /// The base link.
        base: String,
        /// The leaf links found.
        leaves: Vec<String>,
    },
    /// A joint's geometry has no exact MDH representation.
    #[error("{path}: joint '{joint}': {message}")]
    NotRepresentable {
        /// The path given.
        path: String,
        /// The joint's name in the file.
        joint: String,
        /// Why.
        message: String,
    },
    /// The converted model's forward kinematics differs from the source's.
    #[error("{path}: the MDH model deviates from the source by {} mm at q = {q_deg:?} deg (limit {} mm)", fmt_plain(*.deviation_mm), fmt_plain(PROOF_TOLERANCE_MM))]
    Proof {
        /// The path given.
        path: String,
        /// The deviation found, mm.
        deviation_mm: f64,
        /// The configuration, degrees (one angle per joint).
        q_deg: Joints,
    },
}

/// `":LINE"`, or nothing for line 0 (a field with no line, e.g. one the TOML reader located only
/// by name).
fn at_line(line: &usize) -> String {
    if *line == 0 {
        String::new()
    } else {
        format!(":{line}")
    }
}

/// A converted model and the evidence that it reproduces its source.
#[derive(Clone, Debug, PartialEq)]
pub struct Imported {
    /// The MDH model (zero uncertainty: a description carries none).
    pub model: RobotModel,
    /// The file it came from, as given.
    pub source: String,
    /// Its format.
    pub format: SourceFormat,
    /// Largest tool-point deviation source vs model over the proof configurations, mm.
    pub max_deviation_mm: f64,
    /// Number of configurations checked (q = 0 and the random ones).
    pub configurations: usize,
    /// What looks wrong but converts (a reach that suggests the wrong units), one line each.
    pub warnings: Vec<String>,
    /// What the reader chose on the user's behalf (the tip link) and the joints held, one line
    /// each.
    pub notes: Vec<String>,
    /// The joints held at a fixed angle, one line each (also in `notes`); the model file's
    /// header records them.
    pub held: Vec<String>,
}

/// Reach below which an imported arm is suspected of lengths in the wrong unit, mm.
pub const MIN_PLAUSIBLE_REACH_MM: f64 = 50.0;

/// Reach above which an imported arm is suspected of lengths in the wrong unit, mm.
pub const MAX_PLAUSIBLE_REACH_MM: f64 = 20_000.0;

/// The warning for an arm whose reach beyond joint 1 (the sum of the later links' lengths) is outside
/// [`MIN_PLAUSIBLE_REACH_MM`] … [`MAX_PLAUSIBLE_REACH_MM`]: industrial and research arms reach
/// from about 0.3 m to 4 m, so a reach of millimetres or kilometres is a unit slip.
pub fn reach_warning(model: &RobotModel) -> Option<String> {
    // The reach beyond joint 1 (as `points::reach_mm`, which this module cannot use: points
    // depend on the presets, which are imported).
    let p = &model.params;
    let reach: f64 = (1..model.joints())
        .map(|j| p[5 * j + 1].hypot(p[5 * j + 2]))
        .sum();
    if reach < MIN_PLAUSIBLE_REACH_MM {
        Some(format!(
            "the arm reaches only {} mm beyond joint 1; if its lengths are in metres, say so (a DH table's 'units,m-rad', a URDF is always in metres)",
            fmt_plain(reach)
        ))
    } else if reach > MAX_PLAUSIBLE_REACH_MM {
        Some(format!(
            "the arm reaches {} m beyond joint 1; if its lengths are in millimetres, say so (a DH table's 'units,mm-deg')",
            fmt_plain(reach / 1000.0)
        ))
    } else {
        None
    }
}

impl Imported {
    /// The provenance as TOML comment lines (no schema change: the model reader skips them).
    pub fn header(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "# Imported by gpu-amcs {} from {} ({}).",
            env!("CARGO_PKG_VERSION"),
            self.source,
            self.format.name()
        );
        let _ = writeln!(
            s,
            "# Proof: max tool-point deviation source vs MDH model = {:e} mm over {} configurations within the limits (limit {:e} mm).",
            self.max_deviation_mm, self.configurations, PROOF_TOLERANCE_MM
        );
        for n in &self.held {
            let _ = writeln!(s, "# Note: {n}.");
        }
        let _ = writeln!(
            s,
            "# The description carries no uncertainty: every sigma is 0 until calibrated."
        );
        s
    }

    /// The model file: [`Imported::header`] then [`RobotModel::to_toml`].
    pub fn to_toml(&self) -> String {
        format!("{}{}", self.header(), self.model.to_toml())
    }
}

/// Converts a source chain to the MDH model and proves the conversion (see the module docs).
/// `path` names the source in errors and in the header.
///
/// # Errors
///
/// [`ImportError::Chain`] when the chain does not have [`MIN_JOINTS`] to [`MAX_JOINTS`] joints
/// (naming the count and the range, and how many to hold when there are too many),
/// [`ImportError::NotRepresentable`] naming the joint whose geometry has no exact MDH form
/// (coinciding axes, …), and [`ImportError::Proof`] when the model's forward
/// kinematics deviates from the source's by more than [`PROOF_TOLERANCE_MM`].
pub fn convert(chain: &SourceChain, path: &str) -> Result<Imported, ImportError> {
    let n = chain.joints.len();
    if !(MIN_JOINTS..=MAX_JOINTS).contains(&n) {
        let names: Vec<&str> = chain.joints.iter().map(|j| j.name.as_str()).collect();
        return Err(ImportError::Chain {
            path: path.into(),
            message: format!(
                "{} has {n} revolute joints ({}); the model needs {MIN_JOINTS} to {MAX_JOINTS}{}",
                chain.what,
                if names.is_empty() {
                    "none".to_string()
                } else {
                    names.join(", ")
                },
                if n > MAX_JOINTS {
                    format!(
                        ": hold {} of them at a fixed angle to import the arm as a {MAX_JOINTS}-axis model (or more of them for fewer axes)",
                        n - MAX_JOINTS
                    )
                } else {
                    String::new()
                }
            ),
        });
    }
    // Axis lines at q = 0 in the base frame.
    let mut frame = Isometry3::identity();
    let mut axes = Vec::with_capacity(n);
    for joint in &chain.joints {
        frame *= joint.origin;
        axes.push(Line {
            point: frame.translation.vector,
            dir: frame.rotation * joint.axis.into_inner(),
        });
    }
    let mut tip = (frame * chain.tip).translation.vector;
    // The model's base frame B: the arm's own base frame when the description names one whose z
    // is joint 1's axis (UR's `base_link_inertia`), else the canonical one of `base_frame`.
    // Express every axis and the tip in it.
    let own = chain.arm_frame.filter(|f| on_axis(f, &axes[0]));
    let (flip, turn, origin) = base_frame(&axes[0]);
    let to_base = |v: Vector3<f64>| match &own {
        Some(f) => f.rotation.inverse_transform_vector(&v),
        None => {
            let v = if flip {
                Vector3::new(v.x, -v.y, -v.z)
            } else {
                v
            };
            turn.map_or(v, |r| r.inverse_transform_vector(&v))
        }
    };
    let shift = own.map_or(origin, |f| f.translation.vector);
    let to_base_point = |p: Vector3<f64>| to_base(p - shift);
    for a in &mut axes {
        *a = Line {
            point: to_base_point(a.point),
            dir: to_base(a.dir),
        };
    }
    tip = to_base_point(tip);
    let base = match &own {
        Some(f) => {
            let t = f.translation.vector;
            let xyz = [t.x, t.y, t.z];
            let rpy = crate::kinematics::rpy_of(&f.rotation);
            (rpy != [0.0; 3] || xyz != [0.0; 3]).then_some(BaseTransform { xyz, rpy })
        }
        None => base_transform(flip, turn, origin),
    };
    check_base(&axes[0], &chain.joints[0].name, path)?;
    let c = chain_from_zero_pose(&axes, tip).map_err(|GeometryError { joint, message }| {
        ImportError::NotRepresentable {
            path: path.into(),
            joint: chain.joints[joint - 1].name.clone(),
            message,
        }
    })?;
    let model = RobotModel {
        name: chain.name.clone(),
        params: c.params,
        fixed: c.fixed,
        limits_deg: Limits::from_fn(n, |j| chain.joints[j].limits_deg),
        tool: c.tool,
        tool_sigma: [0.0; 3],
        uncertainty: Uncertainty::Independent(Params::filled(Layout::new(n).n_params(), 0.0)),
        base,
    };
    check_model(&model, chain, path)?;
    let (max_deviation_mm, configurations) = prove(chain, &model, path)?;
    let warnings = reach_warning(&model).into_iter().collect();
    Ok(Imported {
        model,
        source: path.into(),
        format: chain.format,
        max_deviation_mm,
        configurations,
        warnings,
        notes: chain.notes.clone(),
        held: chain.held.clone(),
    })
}

/// The model file's own rules ([`RobotModel::check`]) applied to an imported model, so that
/// import never writes a file every other command refuses; the error names the source's joint
/// (or the tip link) and the element.
fn check_model(model: &RobotModel, chain: &SourceChain, path: &str) -> Result<(), ImportError> {
    let Err(e) = model.check() else {
        return Ok(());
    };
    // `joint[N].limits`, `joint[N].d`, … (1-based) name the source's joint N.
    let joint = e
        .field
        .strip_prefix("joint[")
        .and_then(|rest| rest.split_once(']'))
        .and_then(|(n, rest)| Some((n.parse::<usize>().ok()?, rest.trim_start_matches('.'))))
        .filter(|(n, _)| (1..=chain.joints.len()).contains(n));
    Err(match joint {
        Some((n, element)) => {
            let what = match element {
                "limits" => "limits".to_string(),
                other => format!("MDH {other}"),
            };
            ImportError::NotRepresentable {
                path: path.into(),
                joint: chain.joints[n - 1].name.clone(),
                message: format!(
                    "{what} (the model's {}): {}; the model files accept lengths up to {} mm and limits up to ±{}° (check the units)",
                    e.field,
                    e.message,
                    fmt_plain(crate::kinematics::MAX_LENGTH_MM),
                    fmt_plain(crate::kinematics::MAX_LIMIT_DEG)
                ),
            }
        }
        None => ImportError::Chain {
            path: path.into(),
            message: format!(
                "the model it gives is invalid: {} (the tool point, from the tip link's offset, or the base): {}",
                e.field, e.message
            ),
        },
    })
}

/// The model's base frame B for a first axis `axis` (description frame at q = 0), as
/// `(flip, turn, origin)`: B = Trans(origin) · Rx(π if flip) · turn.
///
/// * z: the axis direction (the model's first axis is B's z through B's origin);
/// * origin: the foot of the perpendicular from the description's origin onto the axis (the
///   axis point nearest the description's origin; the origin itself when the axis passes
///   through it);
/// * x: the description's x carried along by the smallest rotation that takes the description's
///   z to the axis; for an axis within 45° of straight down (a ceiling mount, ROS-Industrial's
///   KUKA arms), by the half turn about x and then the smallest rotation from −z (the smallest
///   rotation from +z is ill-defined near a half turn). θ_1 takes whatever angle the next axis
///   needs, so this choice only fixes where θ_1 counts from.
///
/// An axis along +z through the origin gives the identity (no base transform) and one along −z
/// through the origin exactly the half turn `Rx(180°)`, as before this was general.
fn base_frame(axis: &Line) -> (bool, Option<UnitQuaternion<f64>>, Vector3<f64>) {
    let d = axis.dir.normalize();
    let flip = d.z < -std::f64::consts::FRAC_1_SQRT_2;
    let d_flipped = if flip {
        Vector3::new(d.x, -d.y, -d.z)
    } else {
        d
    };
    // d_flipped.z > −1/√2: the smallest rotation from z is well defined (at most 135°). A tilt
    // within rounding (which the model took as base z before any placement was accepted) is
    // not turned, so those imports stay exactly as they were.
    let turn = (d_flipped.x.hypot(d_flipped.y) > BASE_TILT_EPS)
        .then(|| UnitQuaternion::rotation_between(&Vector3::z(), &d_flipped))
        .flatten();
    let along = axis.point.dot(&d);
    let foot = axis.point - d * along;
    let origin = if foot.iter().all(|c| c.abs() <= BASE_OFFSET_EPS_MM) {
        Vector3::zeros()
    } else {
        foot
    };
    (flip, turn, origin)
}

/// Whether the frame `f` has joint 1's `axis` as its z axis (same direction, through its
/// origin), within the tolerances of the base check.
fn on_axis(f: &Isometry3<f64>, axis: &Line) -> bool {
    let z = f.rotation * Vector3::z();
    let d = axis.dir.normalize();
    let off = (f.translation.vector - axis.point).cross(&d).norm();
    z.cross(&d).norm() <= 1e-9 && z.dot(&d) > 0.0 && off <= 1e-6
}

/// The base transform of [`base_frame`]'s frame, `None` for the identity.
fn base_transform(
    flip: bool,
    turn: Option<UnitQuaternion<f64>>,
    origin: Vector3<f64>,
) -> Option<BaseTransform> {
    let rpy = match (flip, turn) {
        (false, None) => [0.0; 3],
        (true, None) => [std::f64::consts::PI, 0.0, 0.0],
        (f, Some(t)) => {
            let half = if f {
                UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
            } else {
                UnitQuaternion::identity()
            };
            crate::kinematics::rpy_of(&(half * t))
        }
    };
    let xyz = [origin.x, origin.y, origin.z];
    (rpy != [0.0; 3] || xyz != [0.0; 3]).then_some(BaseTransform { xyz, rpy })
}

/// The model's first axis is fixed: base z through the origin, pointing up.
fn check_base(axis: &Line, joint: &str, path: &str) -> Result<(), ImportError> {
    let tilt = axis.dir.cross(&Vector3::z()).norm();
    let offset = Vector3::new(axis.point.x, axis.point.y, 0.0).norm();
    // An axis along −z has been turned up by the base transform (see `convert`).
    let message = if tilt > BASE_TILT_EPS {
        Some(format!(
            "its axis is tilted {}° from base z; the model's first axis is base z: express the chain in a base frame whose z is this axis",
            fmt_plain(tilt.asin().to_degrees())
        ))
    } else if offset > BASE_OFFSET_EPS_MM {
        Some(format!(
            "its axis is {} mm from the base origin; the model's first axis passes through it: express the chain in a base frame on this axis",
            fmt_plain(offset)
        ))
    } else {
        None
    };
    match message {
        Some(message) => Err(ImportError::NotRepresentable {
            path: path.into(),
            joint: joint.into(),
            message,
        }),
        None => Ok(()),
    }
}

/// Maximum tool-point deviation source vs model at q = 0 and [`PROOF_CONFIGURATIONS`] uniform
/// random configurations within the limits, for a chain and model of any joint count (the
/// model's: one angle per joint, drawn joint by joint);
///
/// # Errors
///
/// [`ImportError::Proof`] naming the configuration where the deviation exceeds
/// [`PROOF_TOLERANCE_MM`], and [`ImportError::Chain`] when the chain and the model do not have
/// the same number of joints.
pub fn prove(
    chain: &SourceChain,
    model: &RobotModel,
    path: &str,
) -> Result<(f64, usize), ImportError> {
    let n = model.joints();
    if chain.joints.len() != n {
        return Err(ImportError::Chain {
            path: path.into(),
            message: format!(
                "{} has {} revolute joints, the model to prove against it {n}",
                chain.what,
                chain.joints.len()
            ),
        });
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(PROOF_SEED);
    let mut worst = (0.0_f64, Joints::filled(n, 0.0));
    for k in 0..=PROOF_CONFIGURATIONS {
        let q_deg = if k == 0 {
            Joints::filled(n, 0.0)
        } else {
            Joints::from_fn(n, |j| {
                let (lo, hi) = model.limits_deg[j];
                lo + (hi - lo) * rng.random::<f64>()
            })
        };
        let q = q_deg.map(f64::to_radians);
        let a = chain.position(&q);
        let b = model.world_position(&q);
        let dev = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
        // NaN compares false: treat it as the worst.
        if dev > worst.0 || dev.is_nan() {
            worst = (dev, q_deg);
        }
    }
    if worst.0.is_nan() || worst.0 > PROOF_TOLERANCE_MM {
        return Err(ImportError::Proof {
            path: path.into(),
            deviation_mm: worst.0,
            q_deg: worst.1,
        });
    }
    Ok((worst.0, PROOF_CONFIGURATIONS + 1))
}

/// Which reader a file needs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileKind {
    /// `.urdf`, `.xml`.
    Urdf,
    /// `.xacro`: expanded ([`xacro::expand_file`]) to URDF.
    Xacro,
    /// `.csv`, `.toml`: a DH table (standard or modified, as the file states).
    DhTable,
    /// `.yaml`, `.yml`: a UR calibration file.
    UrCalibration,
}

/// Options of [`import_file`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ImportOptions {
    /// URDF: the base link (default: the root link).
    pub base: Option<String>,
    /// URDF: the tip link (default: the single leaf below the base, else tool0, flange or the
    /// deepest leaf of the longest revolute chain, with a note).
    pub tip: Option<String>,
    /// Model name (default: the file's robot name, else the file stem).
    pub name: Option<String>,
    /// xacro: package name → its directory, for `$(find NAME)` (before the search upwards
    /// from the including file).
    pub packages: std::collections::BTreeMap<String, std::path::PathBuf>,
    /// xacro: `$(arg NAME)` values that override the file's `<xacro:arg>` defaults.
    pub xacro_args: std::collections::BTreeMap<String, String>,
    /// Joints held at a fixed angle ([`SourceChain::hold`]).
    pub held: Vec<JointHold>,
}

/// The reader for `path` by its extension.
///
/// # Errors
///
/// [`ImportError::Chain`] for an unknown extension.
pub fn kind_of(path: &std::path::Path) -> Result<FileKind, ImportError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    match ext.as_str() {
        "urdf" | "xml" => Ok(FileKind::Urdf),
        "csv" | "toml" => Ok(FileKind::DhTable),
        "yaml" | "yml" => Ok(FileKind::UrCalibration),
        "xacro" => Ok(FileKind::Xacro),
        _ => Err(ImportError::Chain {
            path: path.display().to_string(),
            message: "unknown file type: expected .urdf/.xml (URDF), .xacro (xacro), .csv/.toml (DH table) or .yaml/.yml (UR calibration)".into(),
        }),
    }
}

/// Reads a robot description of any supported format (chosen by [`kind_of`]), converts and
/// proves it.
///
/// # Errors
///
/// The errors of [`kind_of`] for the file's type; [`ImportError::Read`] when the file cannot be
/// read, is too large or is not UTF-8; the reader's errors ([`urdf::parse`], [`dh::parse_csv`],
/// [`dh::parse_toml`], [`ur::parse`]) for its contents; and those of [`convert`].
pub fn import_file(path: &std::path::Path, opts: &ImportOptions) -> Result<Imported, ImportError> {
    let kind = kind_of(path)?;
    let p = path.display().to_string();
    if kind == FileKind::Xacro {
        let e = xacro::expand_file(path, &opts.packages, &opts.xacro_args)?;
        let mut chain = urdf::parse(&e.text, &p, opts.base.as_deref(), opts.tip.as_deref())
            .map_err(|err| relocate(err, &e))?;
        if let Some(n) = &opts.name {
            chain.name = n.clone();
        }
        chain.hold(&opts.held, &p)?;
        return convert(&chain, &p);
    }
    let text = crate::input::read_text(
        path,
        crate::input::DESCRIPTION_FILE_LIMIT,
        "robot description",
    )?;
    let stem = path
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("robot")
        .to_string();
    let mut chain = match kind {
        FileKind::Urdf => urdf::parse(&text, &p, opts.base.as_deref(), opts.tip.as_deref())?,
        FileKind::DhTable => {
            let is_toml = path
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("toml"));
            if is_toml {
                dh::parse_toml(&text, &p, &stem)?
            } else {
                dh::parse_csv(&text, &p, &stem)?
            }
        }
        FileKind::UrCalibration => ur::parse(&text, &p, &stem)?,
        FileKind::Xacro => unreachable!("expanded above"),
    };
    if let Some(n) = &opts.name {
        chain.name = n.clone();
    }
    chain.hold(&opts.held, &p)?;
    convert(&chain, &p)
}

/// A URDF reader's error on expanded xacro text, naming the source file and line the offending
/// output line came from instead of the expansion's line.
fn relocate(err: ImportError, e: &xacro::Expanded) -> ImportError {
    let at = |line: usize| e.origins.get(line.wrapping_sub(1)).cloned();
    match err {
        ImportError::Element {
            path,
            line,
            element,
            message,
        } => {
            let (path, line) = at(line).unwrap_or((path, line));
            ImportError::Element {
                path,
                line,
                element,
                message,
            }
        }
        ImportError::Syntax {
            path,
            line,
            message,
        } => {
            let (path, line) = at(line).unwrap_or((path, line));
            ImportError::Syntax {
                path,
                line,
                message,
            }
        }
        ImportError::Xacro { path, line, what } => {
            let (path, line) = at(line).unwrap_or((path, line));
            ImportError::Xacro { path, line, what }
        }
        other => other,
    }
}

/// `Trans(xyz)·Rz(yaw)·Ry(pitch)·Rx(roll)`: the URDF `<origin>` and UR calibration transform.
pub(crate) fn xyz_rpy(xyz: [f64; 3], rpy: [f64; 3]) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(xyz[0], xyz[1], xyz[2]),
        UnitQuaternion::from_euler_angles(rpy[0], rpy[1], rpy[2]),
    )
}
