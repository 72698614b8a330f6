//! UR calibration file reader (the `kinematics:` YAML that Universal Robots' ROS drivers export
//! from a controller's factory calibration).
//!
//! ```text
//! kinematics:
//!   shoulder:  { x, y, z, roll, pitch, yaw }   # block mappings, one key per line
//!   upper_arm: ...
//!   forearm: ...
//!   wrist_1: ...
//!   wrist_2: ...
//!   wrist_3: ...
//!   hash: calib_...
//! ```
//! Each joint's transform is `Trans(x, y, z)·Rz(yaw)·Ry(pitch)·Rx(roll)` (metres, radians) from
//! the previous joint's frame, followed by the joint's rotation about its z axis, exactly as UR's
//! URDF uses them; the chain starts in UR's base frame (the controller's `Base`) and ends at the
//! `wrist_3` frame (the flange). The file has no joint limits: every joint gets UR's ±360°.
//!
//! The reader takes the block-mapping subset of YAML these files use (`key: value` lines,
//! indentation, `#` comments, a leading `---`); anything else is refused with its line.

use super::{xyz_rpy, ImportError, SourceChain, SourceFormat, SourceJoint};
use nalgebra::{Isometry3, Vector3};

/// The joints of a UR calibration file, base to flange.
pub const UR_JOINTS: [&str; 6] = [
    "shoulder",
    "upper_arm",
    "forearm",
    "wrist_1",
    "wrist_2",
    "wrist_3",
];
/// The six values of each joint, in file order.
pub const UR_KEYS: [&str; 6] = ["x", "y", "z", "roll", "pitch", "yaw"];
/// Joint limits given to every joint (UR e-series: ±360°).
pub const UR_LIMITS_DEG: (f64, f64) = (-360.0, 360.0);

/// Parses a UR calibration file and returns its chain (lengths in mm).
///
/// # Errors
///
/// [`ImportError::Syntax`] for a line that is not the expected YAML (naming it) and
/// [`ImportError::Element`] for a missing joint or key, or a value that is not a finite number.
pub fn parse(text: &str, path: &str, name: &str) -> Result<SourceChain, ImportError> {
    let syntax = |line: usize, message: String| ImportError::Syntax {
        path: path.into(),
        line,
        message,
    };
    // (line, indent, key, value)
    let mut entries = Vec::new();
    for (k, raw) in text.lines().enumerate() {
        let line = k + 1;
        let l = match raw.find(" #") {
            Some(p) => &raw[..p],
            None => raw,
        };
        let t = l.trim_end();
        if t.trim() == "---" {
            // A document marker: one leading `---` is allowed; another after content starts
            // a second document, which a calibration file does not have.
            if !entries.is_empty() {
                return Err(syntax(
                    line,
                    "a second YAML document: a calibration file holds one".into(),
                ));
            }
            continue;
        }
        if t.trim().is_empty() || t.trim_start().starts_with('#') {
            continue;
        }
        if t.contains('\t') {
            return Err(syntax(
                line,
                "tabs are not allowed in YAML indentation".into(),
            ));
        }
        let indent = t.len() - t.trim_start().len();
        let (key, value) = t
            .trim_start()
            .split_once(':')
            .ok_or_else(|| syntax(line, "expected 'key: value' (block mappings only)".into()))?;
        entries.push((
            line,
            indent,
            key.trim().to_string(),
            value.trim().to_string(),
        ));
    }
    let top = entries
        .iter()
        .position(|e| e.1 == 0 && e.2 == "kinematics")
        .ok_or_else(|| syntax(1, "missing the top-level 'kinematics:' mapping".into()))?;
    if !entries[top].3.is_empty() {
        return Err(syntax(
            entries[top].0,
            "'kinematics:' must be a block mapping (nothing after the colon)".into(),
        ));
    }
    // Children of kinematics: entries after it with indent > 0 until the next indent-0 entry.
    let body: Vec<_> = entries[top + 1..].iter().take_while(|e| e.1 > 0).collect();
    let joint_indent = body.first().map_or(0, |e| e.1);
    let mut values: Vec<Option<[Option<f64>; 6]>> = vec![None; 6];
    let mut current: Option<usize> = None;
    for (line, indent, key, value) in body {
        if *indent == joint_indent {
            current = None;
            if let Some(j) = UR_JOINTS.iter().position(|n| n == key) {
                if !value.is_empty() {
                    return Err(syntax(*line, format!("'{key}:' must be a block mapping")));
                }
                if values[j].is_some() {
                    return Err(syntax(*line, format!("'{key}' appears twice")));
                }
                values[j] = Some([None; 6]);
                current = Some(j);
            } else if key != "hash" {
                return Err(syntax(
                    *line,
                    format!(
                        "unknown key '{key}' under kinematics (expected {} or hash)",
                        UR_JOINTS.join(", ")
                    ),
                ));
            }
        } else if *indent > joint_indent {
            let j =
                current.ok_or_else(|| syntax(*line, format!("'{key}' is not under a joint")))?;
            let k = UR_KEYS.iter().position(|n| n == key).ok_or_else(|| {
                syntax(
                    *line,
                    format!(
                        "unknown key '{key}' in {} (expected {})",
                        UR_JOINTS[j],
                        UR_KEYS.join(", ")
                    ),
                )
            })?;
            let v: f64 = value
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite())
                .ok_or_else(|| ImportError::Element {
                    path: path.into(),
                    line: *line,
                    element: format!("kinematics.{}.{key}", UR_JOINTS[j]),
                    message: format!("'{value}' is not a finite number"),
                })?;
            let slot = &mut values[j].as_mut().expect("current joint has values")[k];
            if slot.is_some() {
                return Err(syntax(*line, format!("'{key}' appears twice")));
            }
            *slot = Some(v);
        } else {
            return Err(syntax(*line, "inconsistent indentation".into()));
        }
    }
    let mut joints = Vec::with_capacity(6);
    for (j, v) in values.iter().enumerate() {
        let v = v.ok_or_else(|| ImportError::Element {
            path: path.into(),
            line: entries[top].0,
            element: format!("kinematics.{}", UR_JOINTS[j]),
            message: "missing".into(),
        })?;
        let mut x = [0.0; 6];
        for k in 0..6 {
            x[k] = v[k].ok_or_else(|| ImportError::Element {
                path: path.into(),
                line: entries[top].0,
                element: format!("kinematics.{}.{}", UR_JOINTS[j], UR_KEYS[k]),
                message: "missing".into(),
            })?;
        }
        joints.push(SourceJoint {
            name: UR_JOINTS[j].into(),
            origin: xyz_rpy([x[0] * 1e3, x[1] * 1e3, x[2] * 1e3], [x[3], x[4], x[5]]),
            axis: Vector3::z_axis(),
            limits_deg: UR_LIMITS_DEG,
        });
    }
    Ok(SourceChain {
        name: name.into(),
        format: SourceFormat::UrCalibration,
        joints,
        tip: Isometry3::identity(),
        what: "the calibration file".into(),
        notes: Vec::new(),
        held: Vec::new(),
        arm_frame: None,
        bodies: None,
    })
}
