//! Built-in robot models by name ([`preset`], [`PRESETS`]): the Staubli TX60 of
//! [`crate::kinematics::tx60`] and published nominal geometries converted by the importer.
//!
//! The presets other than the TX60 are published nominal geometries converted by the importer
//! (`crate::import`, the same conversion and proof as `gpu-amcs import`); each one's source is
//! quoted at its function. They carry no uncertainty (every σ is 0): a published table says
//! nothing about a particular robot's spread; give σ in a model file or calibrate.
//!
//! This module sits above `kinematics` and `import`: the kinematics know nothing of the
//! importer, and the conversion of a built-in table is the importer's own.

use crate::import::dh::{Convention, DhRow, DhTable};
use crate::import::{convert, SourceBody, SourceChain, SourceFormat, SourceJoint};
use crate::kinematics::{ModelError, RobotModel};
use nalgebra::{Isometry3, Unit, Vector3};
use std::f64::consts::FRAC_PI_2;

pub use crate::kinematics::tx60;

/// Names of the built-in presets.
pub const PRESETS: &[&str] = &[
    "tx60",
    "ur5e",
    "ur10e",
    "irb2400",
    "kr6r700sixx",
    "iiwa14",
    "panda",
];

/// Joints of the UR arms.
const UR_JOINTS: usize = 6;

/// A UR-style standard DH table `(d, a, α)` in metres and radians, θ = 0, limits ±360°, with
/// the links' masses (kg) and centres of mass (m, each in its DH frame i) when published.
fn ur_dh(
    name: &str,
    d: [f64; UR_JOINTS],
    a: [f64; UR_JOINTS],
    alpha: [f64; UR_JOINTS],
    links: Option<UrLinks>,
) -> RobotModel {
    let table = DhTable {
        name: name.into(),
        convention: Convention::Standard,
        rows: (0..UR_JOINTS)
            .map(|j| DhRow {
                params: [0.0, d[j] * 1000.0, a[j] * 1000.0, alpha[j]],
                limits_deg: (-360.0, 360.0),
            })
            .collect(),
        tool: [0.0; 3],
    };
    let mut chain = table.to_chain();
    // Standard DH: joint i's frame (after its rotation) times Rz(θ)Tz(d)Tx(a)Rx(α) is DH frame
    // i, in which UR gives the centre of mass.
    chain.bodies = links.map(|(mass, com)| {
        (0..UR_JOINTS)
            .map(|j| {
                let b = Isometry3::translation(0.0, 0.0, d[j] * 1000.0)
                    * Isometry3::translation(a[j] * 1000.0, 0.0, 0.0)
                    * Isometry3::rotation(Vector3::x() * alpha[j]);
                SourceBody {
                    mass_kg: mass[j],
                    com_mm: (b * nalgebra::Point3::from(Vector3::from(com[j]) * 1000.0)).coords,
                }
            })
            .collect()
    });
    converted(&chain)
}

/// Masses (kg) and centres of mass (m, DH frame i) of a UR arm's six links.
type UrLinks = ([f64; UR_JOINTS], [[f64; 3]; UR_JOINTS]);

/// The UR5e's links as UR publishes them (same source as [`ur5e`]'s geometry).
const UR5E_LINKS: UrLinks = (
    [3.761, 8.058, 2.846, 1.37, 1.3, 0.365],
    [
        [0.0, -0.02561, 0.00193],
        [0.2125, 0.0, 0.11336],
        [0.15, 0.0, 0.0265],
        [0.0, -0.0018, 0.01634],
        [0.0, 0.0018, 0.01634],
        [0.0, 0.0, -0.001159],
    ],
);

/// The UR10e's links as UR publishes them (the same UR page; restated, with each figure's
/// source column, in the `physical_parameters.yaml` of UR's ROS 2 description, BSD-3-Clause).
const UR10E_LINKS: UrLinks = (
    [7.369, 13.051, 3.989, 2.1, 1.98, 0.615],
    [
        [0.021, 0.0, 0.027],
        [0.38, 0.0, 0.158],
        [0.24, 0.0, 0.068],
        [0.0, 0.007, 0.018],
        [0.0, 0.007, 0.018],
        [0.0, 0.0, -0.026],
    ],
);

fn converted(chain: &SourceChain) -> RobotModel {
    // The conversion of a built-in table cannot fail: the tests of every preset prove it.
    convert(chain, &chain.name)
        .expect("a built-in preset converts exactly (see the preset tests)")
        .model
}

/// Standard DH of the UR arms' α column (rad): UR's published tables.
const UR_ALPHA: [f64; UR_JOINTS] = [FRAC_PI_2, 0.0, 0.0, FRAC_PI_2, -FRAC_PI_2, 0.0];

/// Universal Robots UR5e from UR's published standard DH parameters (Universal Robots, "DH
/// parameters for calculations of kinematics and dynamics"; m, rad):
/// d = (0.1625, 0, 0, 0.1333, 0.0997, 0.0996), a = (0, −0.425, −0.3922, 0, 0, 0),
/// α = (π/2, 0, 0, π/2, −π/2, 0), θ offsets 0; limits ±360° on every joint. Base frame: UR's
/// `Base` (the DH base); tool point: the flange centre, at (−817.2, −232.9, 62.8) mm at q = 0.
/// Link masses 3.761, 8.058, 2.846, 1.37, 1.3, 0.365 kg and centres of mass from the same
/// table (the model's `links`; joint compliance's gravity torques use them).
pub fn ur5e() -> RobotModel {
    ur_dh(
        "Universal Robots UR5e",
        [0.1625, 0.0, 0.0, 0.1333, 0.0997, 0.0996],
        [0.0, -0.425, -0.3922, 0.0, 0.0, 0.0],
        UR_ALPHA,
        Some(UR5E_LINKS),
    )
}

/// Universal Robots UR10e from UR's published standard DH parameters (same source as
/// [`ur5e`]; m, rad): d = (0.1807, 0, 0, 0.17415, 0.11985, 0.11655),
/// a = (0, −0.6127, −0.57155, 0, 0, 0), α as the UR5e; limits ±360°. Link masses 7.369,
/// 13.051, 3.989, 2.1, 1.98, 0.615 kg and centres of mass from the same table.
pub fn ur10e() -> RobotModel {
    ur_dh(
        "Universal Robots UR10e",
        [0.1807, 0.0, 0.0, 0.17415, 0.11985, 0.11655],
        [0.0, -0.6127, -0.57155, 0.0, 0.0, 0.0],
        UR_ALPHA,
        Some(UR10E_LINKS),
    )
}

/// One revolute joint as a URDF gives it: origin xyz (m, rpy 0), axis, limits (rad).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UrdfJointFigures {
    /// Joint name in the URDF.
    pub name: &'static str,
    /// `<origin xyz>`, metres (`rpy` is 0).
    pub xyz: [f64; 3],
    /// `<axis xyz>`.
    pub axis: [f64; 3],
    /// `<limit lower upper>`, radians.
    pub limits_rad: (f64, f64),
}

const fn urdf_joint(
    name: &'static str,
    xyz: [f64; 3],
    axis: [f64; 3],
    limits_rad: (f64, f64),
) -> UrdfJointFigures {
    UrdfJointFigures {
        name,
        xyz,
        axis,
        limits_rad,
    }
}

/// ABB IRB 2400 joint origins, axes and limits of the ROS-Industrial `abb_irb2400_support`
/// URDF (`urdf/irb2400_macro.xacro`). `tool0` sits on `link_6` with no offset: at q = 0 it is
/// at (940, 0, 1455) mm. (±3.1416 is the file's figure, not π.)
#[allow(clippy::approx_constant)]
pub const IRB2400_URDF: [UrdfJointFigures; 6] = [
    urdf_joint(
        "joint_1",
        [0.0, 0.0, 0.0],
        [0.0, 0.0, 1.0],
        (-3.1416, 3.1416),
    ),
    urdf_joint(
        "joint_2",
        [0.1, 0.0, 0.615],
        [0.0, 1.0, 0.0],
        (-1.7453, 1.9199),
    ),
    urdf_joint(
        "joint_3",
        [0.0, 0.0, 0.705],
        [0.0, 1.0, 0.0],
        (-1.0472, 1.1345),
    ),
    urdf_joint(
        "joint_4",
        [0.258, 0.0, 0.135],
        [1.0, 0.0, 0.0],
        (-3.49, 3.49),
    ),
    urdf_joint(
        "joint_5",
        [0.497, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        (-2.0944, 2.0944),
    ),
    urdf_joint(
        "joint_6",
        [0.085, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        (-6.9813, 6.9813),
    ),
];

/// KUKA KR 6 R700 sixx joint origins, axes and limits of the ROS-Industrial
/// `kuka_experimental` repository, `kuka_kr6_support/urdf/kr6r700sixx_macro.xacro` (all
/// revolute `rpy` 0; `joint_a6 → flange` fixed identity, `flange → tool0` fixed rpy (0, 90°, 0),
/// so `tool0` sits at the flange centre: (785, 0, 435) mm at q = 0). Joint A1 turns about −z:
/// the model holds that with its base transform Rx(180°) ([`crate::kinematics::BaseTransform`]).
pub const KR6R700SIXX_URDF: [UrdfJointFigures; 6] = [
    urdf_joint(
        "joint_a1",
        [0.0, 0.0, 0.4],
        [0.0, 0.0, -1.0],
        (-170.0 * DEG, 170.0 * DEG),
    ),
    urdf_joint(
        "joint_a2",
        [0.025, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        (-190.0 * DEG, 45.0 * DEG),
    ),
    urdf_joint(
        "joint_a3",
        [0.315, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        (-120.0 * DEG, 156.0 * DEG),
    ),
    urdf_joint(
        "joint_a4",
        [0.0, 0.0, 0.035],
        [-1.0, 0.0, 0.0],
        (-185.0 * DEG, 185.0 * DEG),
    ),
    urdf_joint(
        "joint_a5",
        [0.365, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        (-120.0 * DEG, 120.0 * DEG),
    ),
    urdf_joint(
        "joint_a6",
        [0.080, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        (-350.0 * DEG, 350.0 * DEG),
    ),
];

/// Degrees to radians, for the limits the xacro gives in degrees.
const DEG: f64 = std::f64::consts::PI / 180.0;

/// KUKA KR 6 R700 sixx from [`KR6R700SIXX_URDF`]; tool point at `tool0` (the flange centre).
pub fn kr6r700sixx() -> RobotModel {
    urdf_preset("KUKA KR 6 R700 sixx", &KR6R700SIXX_URDF)
}

/// ABB IRB 2400 from [`IRB2400_URDF`]; tool point at `tool0`.
pub fn irb2400() -> RobotModel {
    urdf_preset("ABB IRB 2400", &IRB2400_URDF)
}

/// A preset from URDF joint figures (origins with rpy 0, one per joint of the model), tip at the
/// last joint's frame.
fn urdf_preset(name: &str, figures: &[UrdfJointFigures]) -> RobotModel {
    let joints = figures
        .iter()
        .map(|j| SourceJoint {
            name: j.name.into(),
            origin: Isometry3::translation(j.xyz[0] * 1000.0, j.xyz[1] * 1000.0, j.xyz[2] * 1000.0),
            axis: Unit::new_normalize(Vector3::from(j.axis)),
            limits_deg: (j.limits_rad.0.to_degrees(), j.limits_rad.1.to_degrees()),
        })
        .collect();
    converted(&SourceChain {
        name: name.into(),
        format: SourceFormat::Urdf,
        joints,
        what: format!("the {name} preset's chain"),
        tip: Isometry3::identity(),
        notes: Vec::new(),
        held: Vec::new(),
        arm_frame: None,
        bodies: None,
    })
}

/// A seven-joint DH table `[θ, d, a, α]` (mm, degrees) with limits (degrees) and a tool point in
/// the last frame (mm).
fn dh7(
    name: &str,
    convention: Convention,
    rows: [[f64; 4]; 7],
    limits_deg: [(f64, f64); 7],
    tool: [f64; 3],
) -> RobotModel {
    let table = DhTable {
        name: name.into(),
        convention,
        rows: rows
            .iter()
            .zip(limits_deg)
            .map(|(r, l)| DhRow {
                params: [r[0].to_radians(), r[1], r[2], r[3].to_radians()],
                limits_deg: l,
            })
            .collect(),
        tool,
    };
    converted(&table.to_chain())
}

/// KUKA LBR iiwa 14 R820, a seven-axis arm with all seven joints free, from its standard DH
/// table (KUKA's figures: base to shoulder 360 mm, shoulder to elbow 420 mm, elbow to wrist
/// 400 mm, wrist to flange 126 mm; α = −90°, 90°, 90°, −90°, −90°, 90°, 0°; θ offsets 0),
/// limits ±170°, ±120°, ±170°, ±120°, ±170°, ±120°, ±175°. Tool point: the flange centre, at
/// (0, 0, 1306) mm at q = 0.
pub fn iiwa14() -> RobotModel {
    dh7(
        "KUKA LBR iiwa 14 R820",
        Convention::Standard,
        [
            [0.0, 360.0, 0.0, -90.0],
            [0.0, 0.0, 0.0, 90.0],
            [0.0, 420.0, 0.0, 90.0],
            [0.0, 0.0, 0.0, -90.0],
            [0.0, 400.0, 0.0, -90.0],
            [0.0, 0.0, 0.0, 90.0],
            [0.0, 126.0, 0.0, 0.0],
        ],
        [
            (-170.0, 170.0),
            (-120.0, 120.0),
            (-170.0, 170.0),
            (-120.0, 120.0),
            (-170.0, 170.0),
            (-120.0, 120.0),
            (-175.0, 175.0),
        ],
        [0.0; 3],
    )
}

/// Franka Emika Panda, seven joints, from Franka's published modified (Craig) DH table
/// `[θ_i, d_i, a_{i−1}, α_{i−1}]`: d = (333, 0, 316, 0, 384, 0, 0) mm, a = (0, 0, 0, 82.5,
/// −82.5, 0, 88) mm, α = (0, −90°, 90°, 90°, −90°, 90°, 90°), the flange 107 mm along joint 7's
/// axis; limits (Franka's radians in degrees) ±166.0°, ±101.0°, ±166.0°, −176.0…−4.0°,
/// ±166.0°, −1.0…215.0°, ±166.0°. Tool point: the flange centre.
pub fn panda() -> RobotModel {
    let r = |v: f64| v.to_degrees();
    dh7(
        "Franka Emika Panda",
        Convention::Modified,
        [
            [0.0, 333.0, 0.0, 0.0],
            [0.0, 0.0, 0.0, -90.0],
            [0.0, 316.0, 0.0, 90.0],
            [0.0, 0.0, 82.5, 90.0],
            [0.0, 384.0, -82.5, -90.0],
            [0.0, 0.0, 0.0, 90.0],
            [0.0, 0.0, 88.0, 90.0],
        ],
        [
            (r(-2.8973), r(2.8973)),
            (r(-1.7628), r(1.7628)),
            (r(-2.8973), r(2.8973)),
            (r(-3.0718), r(-0.0698)),
            (r(-2.8973), r(2.8973)),
            (r(-0.0175), r(3.7525)),
            (r(-2.8973), r(2.8973)),
        ],
        [0.0, 0.0, 107.0],
    )
}

/// A preset by name.
///
/// # Errors
///
/// [`ModelError::UnknownPreset`] when `name` (case-insensitive) is none of [`PRESETS`].
///
/// # Examples
///
/// ```
/// use gpu_amcs_core::kinematics::{tx60, ModelError};
/// use gpu_amcs_core::presets::{preset, PRESETS};
///
/// // The name is case-insensitive; "tx60" is the TX60 of `kinematics::tx60`.
/// let m = preset("TX60")?;
/// assert_eq!(m, tx60());
/// assert_eq!(m.joints(), 6);
/// assert_eq!(preset("panda")?.joints(), 7);
/// // Every listed name is a preset.
/// assert!(PRESETS.iter().all(|name| preset(name).is_ok()));
/// // Any other name is an error that lists the known ones.
/// match preset("tx90") {
///     Err(ModelError::UnknownPreset { name, known }) => {
///         assert_eq!(name, "tx90");
///         assert_eq!(known, PRESETS);
///     }
///     other => panic!("expected an unknown preset, got {other:?}"),
/// }
/// # Ok::<(), ModelError>(())
/// ```
pub fn preset(name: &str) -> Result<RobotModel, ModelError> {
    match name.to_ascii_lowercase().as_str() {
        "tx60" => Ok(tx60()),
        "ur5e" => Ok(ur5e()),
        "ur10e" => Ok(ur10e()),
        "irb2400" => Ok(irb2400()),
        "kr6r700sixx" => Ok(kr6r700sixx()),
        "iiwa14" => Ok(iiwa14()),
        "panda" => Ok(panda()),
        _ => Err(ModelError::UnknownPreset {
            name: name.to_string(),
            known: PRESETS,
        }),
    }
}

/// The preset a model named `model_name` came from, if any: the preset whose model has that
/// name (a model file the preset printed), or whose name followed by a space begins it (the
/// models identified or calibrated from a nominal model are named "NOMINAL (identified from
/// …)", "NOMINAL calibrated (…)").
pub fn preset_named(model_name: &str) -> Option<&'static str> {
    PRESETS.iter().copied().find(|p| {
        preset(p).is_ok_and(|m| {
            model_name == m.name
                || model_name
                    .strip_prefix(m.name.as_str())
                    .is_some_and(|rest| rest.starts_with(' '))
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The seven-axis presets have seven joints and their published zero poses: the iiwa
    /// upright, 360 + 420 + 400 + 126 mm; the Panda's flange 88 mm forward and
    /// 333 + 316 + 384 − 107 mm up.
    #[test]
    fn seven_axis_presets_have_their_zero_poses() {
        for (m, want) in [
            (iiwa14(), [0.0, 0.0, 1306.0]),
            (panda(), [88.0, 0.0, 926.0]),
        ] {
            assert_eq!(m.joints(), 7, "{}", m.name);
            let p = m.world_position(&m.joints_at(0.0));
            let d = (0..3).map(|k| (p[k] - want[k]).powi(2)).sum::<f64>().sqrt();
            assert!(d < 1e-9, "{}: {p:?}", m.name);
            m.check().unwrap();
        }
    }

    /// The UR10e's gravity torques at q = 0 (the arm stretched out along −x) from its links,
    /// against the lever arms worked out by hand from UR's DH table: joint 2's axis passes
    /// through x = 0, joint 3's through x = a2 = −612.7 mm; the centres of mass lie at
    /// x = a2 + 380 (upper arm), a2 + a3 + 240 (forearm) and a2 + a3 (the wrist links).
    #[test]
    fn ur10e_gravity_torques_follow_its_published_links() {
        use crate::kinematics::gravity::{gravity_torques, LinkMasses, GRAVITY};
        let m = ur10e();
        let links = m.links.expect("the UR10e carries its links");
        let q = m.joints_at(0.0);
        let tau = gravity_torques(&m.params, &[0.0; 3], &LinkMasses::of(&m), 0.0, &q);
        let (a2, a3) = (-0.6127, -0.57155);
        let wrist = 2.1 + 1.98 + 0.615;
        let j2 = 13.051 * (a2 + 0.38) + 3.989 * (a2 + a3 + 0.24) + wrist * (a2 + a3);
        let j3 = 3.989 * (a3 + 0.24) + wrist * a3;
        assert_eq!(&links.mass_kg[..], &UR10E_LINKS.0[..]);
        assert!(tau[0].abs() < 1e-9, "J1 {}", tau[0]);
        for (got, lever) in [(tau[1], j2), (tau[2], j3)] {
            let want = GRAVITY * lever;
            assert!(
                (got.abs() - want.abs()).abs() < 1e-9 * want.abs(),
                "{got} against {want} N m"
            );
        }
        assert!(tau[1].abs() > 100.0, "J2 carries the arm: {}", tau[1]);
    }

    #[test]
    fn every_name_resolves_and_an_unknown_one_lists_them() {
        for name in PRESETS {
            assert!(preset(&name.to_ascii_uppercase()).is_ok(), "{name}");
        }
        assert_eq!(
            preset("tx90").unwrap_err().to_string(),
            "unknown preset 'tx90' (known: tx60, ur5e, ur10e, irb2400, kr6r700sixx, iiwa14, panda)"
        );
    }
}
