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
//!
//! The submodules besides the readers: `chain` (the source chain and its holds), `base` (the
//! model's base frame) and `file` (a file's reader, [`import_file`]); the unit tests are in
//! `tests`.

mod base;
mod chain;
pub mod dh;
pub mod export;
mod file;
#[cfg(test)]
mod tests;
pub mod ur;
pub mod urdf;
pub mod xacro;
mod xml;

pub use chain::{JointHold, SourceBody, SourceChain, SourceFormat, SourceJoint, MAX_SOURCE_JOINTS};
pub use file::{import_file, kind_of, FileKind, ImportOptions};

use crate::kinematics::lines::Line;
use crate::kinematics::mdh::{chain_from_zero_pose, GeometryError};
use crate::kinematics::{
    gravity::LinkMasses, joint_transform, Capped, Joints, Layout, Limits, Params, RobotModel,
    Uncertainty, MAX_JOINTS, MIN_JOINTS,
};
use crate::number::fmt_plain;
use base::{check_base, to_base_frame};
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use std::fmt::Write as _;

/// Random configurations of the import proof (q = 0 is checked besides).
pub const PROOF_CONFIGURATIONS: usize = 1000;
/// Largest tool-point deviation (mm) between source and model that the proof accepts. The
/// conversion is exact; what remains is f64 rounding, about 1e-13 mm at a 2 m reach.
pub const PROOF_TOLERANCE_MM: f64 = 1e-9;
/// Seed of the proof's configurations (fixed: an import is reproducible).
pub const PROOF_SEED: u64 = 0x1d_2024;

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
    /// Every file the import read, canonical: the description and, for xacro, each included
    /// file and package.xml (empty from [`convert`], which reads none). An output must not be
    /// one of them.
    pub files: Vec<std::path::PathBuf>,
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
    check_joint_count(chain, path)?;
    let (mut axes, mut tip) = zero_pose_axes(chain);
    let base = to_base_frame(chain.arm_frame, &mut axes, &mut tip);
    check_base(&axes[0], &chain.joints[0].name, path)?;
    let c = chain_from_zero_pose(&axes, tip).map_err(|GeometryError { joint, message }| {
        ImportError::NotRepresentable {
            path: path.into(),
            joint: chain.joints[joint - 1].name.clone(),
            message,
        }
    })?;
    let model = RobotModel {
        joint_errors: None,
        links: None,
        discrepancy: None,
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
    let mut model = model;
    model.links = chain.bodies.as_ref().map(|b| link_masses(chain, b, &model));
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
        files: Vec::new(),
    })
}

/// The bodies `bodies` of `chain` (masses, centres of mass in each joint's frame) as the link
/// masses of `model`, its conversion: each centre of mass moved into its MDH frame through the
/// two descriptions' frames at q = 0 (`model`'s base placement included), where both are
/// attached to the same body.
fn link_masses(chain: &SourceChain, bodies: &[SourceBody], model: &RobotModel) -> LinkMasses {
    let n = model.joints();
    let base = model
        .base
        .map_or_else(Isometry3::identity, |b| b.isometry());
    let mut source = Isometry3::identity();
    let mut mdh = base;
    let com = Capped::from_fn(n, |j| {
        source *= chain.joints[j].origin;
        let p = &model.params[5 * j..5 * j + 5];
        mdh *= mat4_isometry(&joint_transform(p[0], p[1], p[2], p[3], p[4], 0.0));
        let c = mdh.inverse() * (source * Point3::from(bodies[j].com_mm));
        [c.x, c.y, c.z]
    });
    LinkMasses {
        mass_kg: Joints::from_fn(n, |j| bodies[j].mass_kg),
        com_mm: Some(com),
    }
}

/// A homogeneous transform (rotation and translation, mm) as an isometry.
fn mat4_isometry(m: &[[f64; 4]; 4]) -> Isometry3<f64> {
    let r = nalgebra::Matrix3::from_fn(|i, j| m[i][j]);
    Isometry3::from_parts(
        Translation3::new(m[0][3], m[1][3], m[2][3]),
        UnitQuaternion::from_matrix(&r),
    )
}

/// The chain has [`MIN_JOINTS`] to [`MAX_JOINTS`] joints; else the error names the count, the
/// range and, for too many, how many to hold.
fn check_joint_count(chain: &SourceChain, path: &str) -> Result<(), ImportError> {
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
    Ok(())
}

/// The joint axes and the tip point of `chain` at q = 0, in the description's frame.
fn zero_pose_axes(chain: &SourceChain) -> (Vec<Line>, Vector3<f64>) {
    let n = chain.joints.len();
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
    let tip = (frame * chain.tip).translation.vector;
    (axes, tip)
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

/// `Trans(xyz)·Rz(yaw)·Ry(pitch)·Rx(roll)`: the URDF `<origin>` and UR calibration transform.
pub(crate) fn xyz_rpy(xyz: [f64; 3], rpy: [f64; 3]) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(xyz[0], xyz[1], xyz[2]),
        UnitQuaternion::from_euler_angles(rpy[0], rpy[1], rpy[2]),
    )
}
