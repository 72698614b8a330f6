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
    #[error("the tool point is {} mm off the joint-6 axis; a UR calibration file ends on that axis (flange) and cannot hold it", crate::number::fmt_plain(*.offset_mm))]
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
/// rotation), and the tip.
pub fn origins(model: &RobotModel) -> (Vec<Isometry3<f64>>, Isometry3<f64>) {
    let n = model.joints();
    let o = (0..n)
        .map(|i| {
            if i == 0 {
                // The base transform places joint 1 in the description's frame.
                model
                    .base
                    .map_or_else(Isometry3::identity, |b| b.isometry())
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

/// The model as URDF: links `base_link`, `link_1`…`link_n`, `tool0` (the tool point), revolute
/// joints `joint_1`…`joint_n` about z with the model's limits (n the model's joint count), and a
/// fixed `tool0_joint`.
/// `name` is the robot name (default: the model's).
pub fn to_urdf(model: &RobotModel, name: Option<&str>) -> String {
    let name = xml_escape(name.unwrap_or(&model.name));
    let (o, tip) = origins(model);
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
    let _ = writeln!(
        s,
        "     The parameter uncertainty (sigma, covariance) does not fit in URDF: the gpu-amcs model"
    );
    let _ = writeln!(
        s,
        "     file (TOML) is the full record. effort/velocity are required by URDF; the model has no"
    );
    let _ = writeln!(s, "     dynamics, so they are 0. -->");
    let _ = writeln!(s, "<robot name=\"{name}\">");
    let n = model.joints();
    let links: Vec<String> = std::iter::once("base_link".to_string())
        .chain((1..=n).map(|j| format!("link_{j}")))
        .chain(std::iter::once("tool0".to_string()))
        .collect();
    for l in &links {
        let _ = writeln!(s, "  <link name=\"{l}\"/>");
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
    let _ = writeln!(s, "  <joint name=\"tool0_joint\" type=\"fixed\">");
    let _ = writeln!(s, "    {}", origin(&tip));
    let _ = writeln!(s, "    <parent link=\"{}\"/>", links[n]);
    let _ = writeln!(s, "    <child link=\"tool0\"/>");
    let _ = writeln!(s, "  </joint>");
    let _ = writeln!(s, "</robot>");
    s
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
    if !offset_mm.is_finite() || offset_mm > UR_TOOL_AXIS_EPS_MM {
        return Err(ExportError::ToolOffAxis { offset_mm });
    }
    o[last] *= Isometry3::translation(0.0, 0.0, w.z);
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
    Ok(s)
}
