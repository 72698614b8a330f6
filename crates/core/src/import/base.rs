//! The model's base frame for an imported chain: the frame whose z is the description's first
//! joint axis (see the module docs of [`super`]), its base transform, and the check that the
//! chain expressed in it starts on base z.

use super::ImportError;
use crate::kinematics::lines::Line;
use crate::kinematics::BaseTransform;
use crate::number::fmt_plain;
use nalgebra::{Isometry3, UnitQuaternion, Vector3};

/// Rounding tolerances of joint 1's axis: a tilt from z (radians) and an offset from the origin
/// (mm) within them is not turned or moved into the base frame, and the check after the move
/// allows them. Well below what would move a 2 m arm by 1e-9 mm.
const BASE_TILT_EPS: f64 = 1e-13;
const BASE_OFFSET_EPS_MM: f64 = 1e-10;

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

/// Expresses the joint `axes` and the `tip` point (description frame at q = 0) in the model's
/// base frame B, and returns B's base transform (`None` for the identity).
pub(super) fn to_base_frame(
    arm_frame: Option<Isometry3<f64>>,
    axes: &mut [Line],
    tip: &mut Vector3<f64>,
) -> Option<BaseTransform> {
    // The model's base frame B: the arm's own base frame when the description names one whose z
    // is joint 1's axis (UR's `base_link_inertia`), else the canonical one of `base_frame`.
    // Express every axis and the tip in it.
    let own = arm_frame.filter(|f| on_axis(f, &axes[0]));
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
    for a in axes.iter_mut() {
        *a = Line {
            point: to_base_point(a.point),
            dir: to_base(a.dir),
        };
    }
    *tip = to_base_point(*tip);
    match &own {
        Some(f) => {
            let t = f.translation.vector;
            let xyz = [t.x, t.y, t.z];
            let rpy = crate::kinematics::rpy_of(&f.rotation);
            (rpy != [0.0; 3] || xyz != [0.0; 3]).then_some(BaseTransform { xyz, rpy })
        }
        None => base_transform(flip, turn, origin),
    }
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
pub(super) fn check_base(axis: &Line, joint: &str, path: &str) -> Result<(), ImportError> {
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
