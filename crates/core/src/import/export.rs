//! Writers: a model as URDF, or as a UR calibration file.
//!
//! The MDH transform `T_i(q) = Rz(θ_i + q_i)·M_i` with `M_i = Tz(d_i)·Tx(a_i)·Rx(α_i)·Ry(β_i)`
//! splits at the joint rotation: joint 1's origin is the identity, joint i's origin is
//! `Rz(θ_{i−1})·M_{i−1}`, each axis is z, and the tip is `Rz(θ_n)·M_n·Trans(tool)` (n the model's
//! joint count, 4 to 7; the URDF has as many joints). So the written
//! origins carry the model's (calibrated) geometry exactly, up to the decimal printing of f64,
//! which is the shortest representation that reads back to the same number. Only the geometry
//! fits these formats: the parameter uncertainty (σ, covariance) does not, and the model file
//! stays the full record; the writers say so in a comment. A UR calibration file has UR's six
//! joints: a model of another joint count is refused ([`ExportError::JointCount`]).
//!
//! A model identified in a measurement frame (a tracker's) carries that frame's placement as its
//! base and the tracker target as its tool point. [`UrdfBase::World`] writes the placement as its
//! own fixed joint `world` → `base_link`, so the arm's chain starts at its own base as ROS tools
//! expect; [`to_ur_calibration_tcp`] ends a UR file at the flange and gives the target as a
//! separate TCP for the controller.

use super::ur::{UR_JOINTS, UR_KEYS};
use crate::kinematics::{joint_transform, RobotModel};
use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};
use std::fmt::Write as _;

/// Largest distance (mm) of the tool point from the joint-6 axis that a UR calibration file can
/// carry: none (its chain ends at the flange on that axis); this only absorbs rounding.
pub const UR_TOOL_AXIS_EPS_MM: f64 = 1e-9;

/// Errors writing a model in another format.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// A UR calibration file holds UR's six joints (`shoulder` … `wrist_3`): a model of another
    /// joint count cannot be written as one.
    #[error("a UR calibration file holds six joints ({}); the model has {joints} (write it as URDF instead)", UR_JOINTS.join(", "))]
    JointCount {
        /// The model's joint count.
        joints: usize,
    },
    /// A UR calibration file ends at the flange, on the joint-6 axis: a tool point off that
    /// axis cannot be written.
    #[error("the tool point is {} mm off the joint-6 axis; a UR calibration file ends on that axis (flange) and cannot hold it; the file can end at the flange with the tool point as a separate TCP", crate::number::fmt_plain(*.offset_mm))]
    ToolOffAxis {
        /// Distance of the tool point from the joint-6 axis, mm.
        offset_mm: f64,
    },
}

fn iso(m: &[[f64; 4]; 4]) -> Isometry3<f64> {
    let r = Rotation3::from_matrix_unchecked(Matrix3::from_fn(|a, b| m[a][b]));
    Isometry3::from_parts(
        Translation3::new(m[0][3], m[1][3], m[2][3]),
        UnitQuaternion::from_rotation_matrix(&r),
    )
}

/// `Rz(θ_i)·M_i` of joint `i` (0-based): the fixed part of its transform.
fn fixed_part(model: &RobotModel, i: usize) -> Isometry3<f64> {
    let p = &model.params[5 * i..5 * i + 5];
    iso(&joint_transform(p[0], p[1], p[2], p[3], p[4], 0.0))
}

/// The joint origins, one per joint of the model (joint i's, in joint i−1's frame after its
/// rotation), and the tip. Joint 1's origin is the model's base transform.
pub fn origins(model: &RobotModel) -> (Vec<Isometry3<f64>>, Isometry3<f64>) {
    origins_with(model, UrdfBase::FirstJoint)
}

/// [`origins`] with the base where `base` puts it: joint 1's origin is the identity with
/// [`UrdfBase::World`] (the base is then its own fixed joint).
fn origins_with(model: &RobotModel, base: UrdfBase) -> (Vec<Isometry3<f64>>, Isometry3<f64>) {
    let n = model.joints();
    let o = (0..n)
        .map(|i| {
            if i == 0 {
                // The base transform places joint 1 in the description's frame.
                match (base, model.base) {
                    (UrdfBase::FirstJoint, Some(b)) => b.isometry(),
                    _ => Isometry3::identity(),
                }
            } else {
                fixed_part(model, i - 1)
            }
        })
        .collect();
    let t = model.tool;
    (
        o,
        fixed_part(model, n - 1) * Isometry3::translation(t[0], t[1], t[2]),
    )
}

/// `(xyz in metres, rpy)` of a transform in mm, as URDF and UR files write it.
fn xyz_rpy_of(t: &Isometry3<f64>) -> ([f64; 3], [f64; 3]) {
    let v = t.translation.vector / 1000.0;
    ([v.x, v.y, v.z], crate::kinematics::rpy_of(&t.rotation))
}

fn num(v: f64) -> String {
    // Shortest representation that parses back to the same f64; no "-0".
    if v == 0.0 {
        "0".into()
    } else {
        format!("{v:?}")
    }
}

fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
        .replace('\'', "&apos;")
}

/// Where a URDF export writes the model's base transform ([`RobotModel::base`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UrdfBase {
    /// In joint 1's origin, from `base_link`: the base is part of the arm's description (an
    /// imported robot's mount or turn), and an import of the file gives the same model back.
    FirstJoint,
    /// As its own fixed joint `world_joint` from a root link `world` to `base_link`, joint 1's
    /// origin the identity: the base is where the arm stands in another frame (the placement of
    /// a model identified in a tracker's frame), which ROS tools take as a separate joint.
    World,
}

/// The model as URDF: links `base_link`, `link_1`…`link_n`, `tool0` (the tool point), revolute
/// joints `joint_1`…`joint_n` about z with the model's limits (n the model's joint count), and a
/// fixed `tool0_joint`; the base transform in joint 1's origin ([`UrdfBase::FirstJoint`]).
/// `name` is the robot name (default: the model's).
pub fn to_urdf(model: &RobotModel, name: Option<&str>) -> String {
    to_urdf_with(model, name, UrdfBase::FirstJoint)
}

/// [`to_urdf`] with the base transform where `base` puts it. With [`UrdfBase::World`] and a
/// model with a base, the file starts with a link `world` and a fixed joint `world_joint` to
/// `base_link` carrying the base; without a base it equals [`to_urdf`]'s.
pub fn to_urdf_with(model: &RobotModel, name: Option<&str>, base: UrdfBase) -> String {
    let name = xml_escape(name.unwrap_or(&model.name));
    let world = base == UrdfBase::World && model.base.is_some();
    let (o, tip) = origins_with(model, base);
    let mut s = String::new();
    let _ = writeln!(s, "<?xml version=\"1.0\"?>");
    let _ = writeln!(
        s,
        "<!-- Written by gpu-amcs {} from the MDH model '{}'. The joint origins carry the model's",
        env!("CARGO_PKG_VERSION"),
        xml_escape(&model.name).replace("--", "- -")
    );
    let _ = writeln!(
        s,
        "     geometry; tool0 is the model's tool point (its orientation is the last MDH frame's)."
    );
    if world {
        let _ = writeln!(
            s,
            "     world is the frame the model was identified in (the tracker's); world_joint places"
        );
        let _ = writeln!(
            s,
            "     the robot's base_link in it (the identified placement); tool0 is the measured target."
        );
    }
    let _ = writeln!(
        s,
        "     The parameter uncertainty (sigma, covariance) does not fit in URDF: the gpu-amcs model"
    );
    let _ = writeln!(
        s,
        "     file (TOML) is the full record. effort/velocity are required by URDF; the model has no"
    );
    let _ = writeln!(
        s,
        "     dynamics, so they are 0{} -->",
        if model.links.is_some() {
            "; each link's <inertial> is its mass at its centre of mass (the model's point masses, zero inertia tensor)."
        } else {
            "."
        }
    );
    let _ = writeln!(s, "<robot name=\"{name}\">");
    let n = model.joints();
    let links: Vec<String> = std::iter::once("base_link".to_string())
        .chain((1..=n).map(|j| format!("link_{j}")))
        .chain(std::iter::once("tool0".to_string()))
        .collect();
    if world {
        let _ = writeln!(s, "  <link name=\"world\"/>");
    }
    let inertials = inertials(model, &o);
    for (k, l) in links.iter().enumerate() {
        match inertials.get(k.wrapping_sub(1)) {
            Some(i) if k >= 1 => {
                let _ = writeln!(s, "  <link name=\"{l}\">\n    {i}\n  </link>");
            }
            _ => {
                let _ = writeln!(s, "  <link name=\"{l}\"/>");
            }
        }
    }
    let origin = |t: &Isometry3<f64>| {
        let (x, r) = xyz_rpy_of(t);
        format!(
            "<origin xyz=\"{} {} {}\" rpy=\"{} {} {}\"/>",
            num(x[0]),
            num(x[1]),
            num(x[2]),
            num(r[0]),
            num(r[1]),
            num(r[2])
        )
    };
    let fixed = |s: &mut String, joint: &str, t: &Isometry3<f64>, parent: &str, child: &str| {
        let _ = writeln!(s, "  <joint name=\"{joint}\" type=\"fixed\">");
        let _ = writeln!(s, "    {}", origin(t));
        let _ = writeln!(s, "    <parent link=\"{parent}\"/>");
        let _ = writeln!(s, "    <child link=\"{child}\"/>");
        let _ = writeln!(s, "  </joint>");
    };
    if let (true, Some(b)) = (world, model.base) {
        fixed(&mut s, "world_joint", &b.isometry(), "world", &links[0]);
    }
    for j in 0..n {
        let (lo, hi) = model.limits_deg[j];
        let _ = writeln!(s, "  <joint name=\"joint_{}\" type=\"revolute\">", j + 1);
        let _ = writeln!(s, "    {}", origin(&o[j]));
        let _ = writeln!(s, "    <parent link=\"{}\"/>", links[j]);
        let _ = writeln!(s, "    <child link=\"{}\"/>", links[j + 1]);
        let _ = writeln!(s, "    <axis xyz=\"0 0 1\"/>");
        let _ = writeln!(
            s,
            "    <limit lower=\"{}\" upper=\"{}\" effort=\"0\" velocity=\"0\"/>",
            num(lo.to_radians()),
            num(hi.to_radians())
        );
        let _ = writeln!(s, "  </joint>");
    }
    fixed(&mut s, "tool0_joint", &tip, &links[n], "tool0");
    let _ = writeln!(s, "</robot>");
    s
}

/// The `<inertial>` element of each moving link of `model` (none without link masses): its
/// mass at its centre of mass, moved from its MDH frame into the exported link's frame (both
/// attached to the link; `o` the exported joints' origins), with a zero inertia tensor (the
/// model holds point masses).
fn inertials(model: &RobotModel, o: &[Isometry3<f64>]) -> Vec<String> {
    let Some(links) = &model.links else {
        return Vec::new();
    };
    let centres = links.centres_mm(&model.params);
    let (mut urdf, mut mdh) = (Isometry3::identity(), o[0]);
    (0..model.joints())
        .map(|j| {
            urdf *= o[j];
            mdh *= fixed_part(model, j);
            let c = urdf.inverse() * (mdh * nalgebra::Point3::from(centres[j]));
            format!(
                "<inertial><origin xyz=\"{} {} {}\"/><mass value=\"{}\"/><inertia ixx=\"0\" ixy=\"0\" ixz=\"0\" iyy=\"0\" iyz=\"0\" izz=\"0\"/></inertial>",
                num(c.x / 1000.0),
                num(c.y / 1000.0),
                num(c.z / 1000.0),
                num(links.mass_kg[j])
            )
        })
        .collect()
}

/// The model as a UR calibration file (`kinematics:` with x, y, z, roll, pitch, yaw per joint,
/// metres and radians), in UR's own layout and base frame: each joint's θ and d before its
/// rotation, its a, α, β in the next joint's origin, and the model's `base` left out (a UR
/// description places the arm with its own `base_link` → `base_link_inertia` turn and mount).
/// The file holds UR's six joints, so the model must have six. The chain ends at the flange on
/// the joint-6 axis, so the tool point must lie on that axis; its distance along the axis goes
/// into `wrist_3`'s origin (a shift along a joint's axis commutes with its rotation). The `hash` key, which the ROS 2 UR description
/// requires, is the controller's checksum of its own calibration and cannot be computed from
/// the geometry; the file carries `calib_gpu_amcs_` and the first 16 hex digits of the SHA-256
/// of its kinematics lines instead, so it loads and names its content (the driver's comparison
/// with the controller's checksum then reports a mismatch, as it should for a file the
/// controller did not write).
///
/// # Errors
///
/// [`ExportError::JointCount`] when the model does not have six joints, and
/// [`ExportError::ToolOffAxis`] when the tool point lies off the joint-6 axis (a UR calibration
/// file ends on that axis and cannot hold it).
pub fn to_ur_calibration(model: &RobotModel) -> Result<String, ExportError> {
    ur_file(model, false).map(|(text, _)| text)
}

/// A tool point as a UR controller's TCP: the pose of the tool point in the flange frame (the
/// frame a UR calibration file ends in), metres and a rotation vector in radians, as URScript's
/// `set_tcp(p[x, y, z, rx, ry, rz])` takes it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UrTcp {
    /// Position of the tool point in the flange frame, m.
    pub xyz_m: [f64; 3],
    /// Orientation of the model's last MDH frame in the flange frame, as a rotation vector
    /// (axis times angle), rad.
    pub rotation_vector: [f64; 3],
}

impl std::fmt::Display for UrTcp {
    /// URScript's pose literal, `p[x, y, z, rx, ry, rz]`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let v: Vec<String> = self
            .xyz_m
            .iter()
            .chain(&self.rotation_vector)
            .map(|v| num(*v))
            .collect();
        write!(f, "p[{}]", v.join(", "))
    }
}

/// The model as a UR calibration file that ends at the flange, with the tool point as a separate
/// [`UrTcp`] (written in the file as a comment too): for a tool point off the joint-6 axis,
/// such as the target of a model identified from tracker data, which the file itself cannot
/// hold ([`to_ur_calibration`]). The flange is joint 6's origin in the file (its rotation and
/// its shift along z, θ6 and d6); the rest of joint 6 (a6, α6, β6) and the tool point are the
/// TCP, so the file and the TCP together give the model's tool point exactly.
///
/// # Errors
///
/// [`ExportError::JointCount`] when the model does not have six joints.
pub fn to_ur_calibration_tcp(model: &RobotModel) -> Result<(String, UrTcp), ExportError> {
    ur_file(model, true)
}

/// The UR calibration file of `model`, ending on the joint-6 axis at the tool point
/// or (`at_flange`) at the flange, and the tool point as the [`UrTcp`].
fn ur_file(model: &RobotModel, at_flange: bool) -> Result<(String, UrTcp), ExportError> {
    if model.joints() != UR_JOINTS.len() {
        return Err(ExportError::JointCount {
            joints: model.joints(),
        });
    }
    let last = UR_JOINTS.len() - 1;
    let p = |i: usize| &model.params[5 * i..5 * i + 5];
    // Rz(θ_i)·Tz(d_i) commutes with joint i's own rotation, so it goes before it, as UR writes
    // its files (shoulder z = d1, …); the rest of joint i, Tx(a_i)·Rx(α_i)·Ry(β_i), starts the
    // next joint's origin. The model's base (where the arm stands) is not part of the file.
    let before = |i: usize| {
        Isometry3::from_parts(
            Translation3::new(0.0, 0.0, p(i)[1]),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), p(i)[0]),
        )
    };
    let after = |i: usize| iso(&joint_transform(0.0, 0.0, p(i)[2], p(i)[3], p(i)[4], 0.0));
    let mut o: [Isometry3<f64>; UR_JOINTS.len()] = std::array::from_fn(|i| {
        if i == 0 {
            before(0)
        } else {
            after(i - 1) * before(i)
        }
    });
    // Tool point in the frame after Rz(θ6 + q6)·Tz(d6): w = (a6, 0, 0) + Rx(α6)Ry(β6)·tool.
    let m = joint_transform(0.0, 0.0, p(last)[2], p(last)[3], p(last)[4], 0.0);
    let t = model.tool;
    let w = Vector3::from_fn(|r, _| m[r][0] * t[0] + m[r][1] * t[1] + m[r][2] * t[2] + m[r][3]);
    let offset_mm = w.x.hypot(w.y);
    let tcp = UrTcp {
        xyz_m: [w.x / 1000.0, w.y / 1000.0, w.z / 1000.0],
        rotation_vector: iso(&m).rotation.scaled_axis().into(),
    };
    if !at_flange {
        if !offset_mm.is_finite() || offset_mm > UR_TOOL_AXIS_EPS_MM {
            return Err(ExportError::ToolOffAxis { offset_mm });
        }
        o[last] *= Isometry3::translation(0.0, 0.0, w.z);
    }
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# Written by gpu-amcs {} from the MDH model '{}' (UR calibration format: metres, radians).",
        env!("CARGO_PKG_VERSION"),
        model.name.replace('\n', " ")
    );
    let _ = writeln!(
        s,
        "# The parameter uncertainty (sigma, covariance) does not fit here: the gpu-amcs model file"
    );
    let _ = writeln!(
        s,
        "# (TOML) is the full record. 'hash' is not the controller's checksum: a digest of these lines."
    );
    if at_flange {
        let _ = writeln!(
            s,
            "# The chain ends at the flange; the model's tool point is the TCP, not part of this file:"
        );
        let _ = writeln!(
            s,
            "# set it on the controller (URScript set_tcp, m and rad): TCP {tcp}"
        );
    }
    let mut body = String::new();
    for (j, t) in o.iter().enumerate() {
        let (x, r) = xyz_rpy_of(t);
        let _ = writeln!(body, "  {}:", UR_JOINTS[j]);
        for (k, v) in x.iter().chain(r.iter()).enumerate() {
            let _ = writeln!(body, "    {}: {}", UR_KEYS[k], num(*v));
        }
    }
    let digest = crate::digest::sha256_hex(body.as_bytes());
    let _ = writeln!(s, "kinematics:");
    s.push_str(&body);
    let _ = writeln!(s, "  hash: calib_gpu_amcs_{}", &digest[..16]);
    Ok((s, tcp))
}
