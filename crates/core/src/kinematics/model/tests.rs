//! Unit tests of the robot model.

use super::rpy_of;
use nalgebra::{UnitQuaternion, Vector3};

/// The angles give the rotation back to rounding, also at and near pitch ±90° (where a plain
/// Euler extraction loses about 1e-8 rad at pitch 90° + 3.7e-6 rad, a URDF's 1.5708).
#[test]
fn rpy_gives_the_rotation_back_near_gimbal_lock() {
    let h = std::f64::consts::FRAC_PI_2;
    for (r, p, y) in [
        (0.0, h + 3.67e-6, 0.0),
        (0.3, h, -0.2),
        (-2.0, -h, 1.0),
        (0.1, -h + 1e-4, 3.0),
        (3.0, 0.4, -3.1),
        (std::f64::consts::PI, 0.0, 0.0),
    ] {
        let q = UnitQuaternion::from_euler_angles(r, p, y);
        let a = rpy_of(&q);
        let back = UnitQuaternion::from_euler_angles(a[0], a[1], a[2]);
        let err = (0..3)
            .map(|k| {
                let e = Vector3::ith(k, 1.0);
                (q * e - back * e).norm()
            })
            .fold(0.0, f64::max);
        assert!(err < 1e-15, "({r}, {p}, {y}) -> {a:?}: {err}");
    }
}
