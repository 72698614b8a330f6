//! The geometry of the inverse kinematics: roll-pitch-yaw rotations, the chain's frames at a
//! configuration, the exact position Jacobian and its condition number, and a small dense
//! linear solve.

use crate::kinematics::{joint_transform, position, Capped, Joints, RobotModel, MAX_JOINTS};

/// A 3 × 3 rotation matrix, row-major.
pub type Rot3 = [[f64; 3]; 3];

/// The rotation of roll, pitch, yaw in degrees about the fixed x, y, z axes:
/// `Rz(yaw)·Ry(pitch)·Rx(roll)` (the URDF / ROS convention).
pub fn rpy_rotation(rpy_deg: [f64; 3]) -> Rot3 {
    let [r, p, y] = rpy_deg.map(f64::to_radians);
    let (sr, cr) = r.sin_cos();
    let (sp, cp) = p.sin_cos();
    let (sy, cy) = y.sin_cos();
    [
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ]
}

/// One 3-vector per joint of the model.
pub(super) type PerJoint = Capped<[f64; 3], MAX_JOINTS>;

/// The chain at one configuration: per joint its axis and a point on it (base frame), the tool
/// point and the flange rotation.
pub(super) struct Frames {
    pub(super) axis: PerJoint,
    pub(super) origin: PerJoint,
    pub(super) tool: [f64; 3],
    pub(super) rot: Rot3,
}

pub(super) fn frames(model: &RobotModel, q: &[f64]) -> Frames {
    let n = model.joints();
    debug_assert_eq!(q.len(), n);
    let mut t = [[0.0; 4]; 4];
    for (i, row) in t.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    let mut axis = PerJoint::filled(n, [0.0; 3]);
    let mut origin = PerJoint::filled(n, [0.0; 3]);
    for i in 0..n {
        axis[i] = [t[0][2], t[1][2], t[2][2]];
        origin[i] = [t[0][3], t[1][3], t[2][3]];
        let p = &model.params[5 * i..5 * i + 5];
        let j = joint_transform(p[0], p[1], p[2], p[3], p[4], q[i]);
        let mut n = [[0.0; 4]; 4];
        for (r, row) in n.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate() {
                *v = (0..4).map(|k| t[r][k] * j[k][c]).sum();
            }
        }
        t = n;
    }
    let rot = [
        [t[0][0], t[0][1], t[0][2]],
        [t[1][0], t[1][1], t[1][2]],
        [t[2][0], t[2][1], t[2][2]],
    ];
    // The tool point by the point form, so a solution's residual is that of `position`, the
    // function every evaluator's reference positions come from.
    let tool = position(&model.params, &model.tool, q);
    Frames {
        axis,
        origin,
        tool,
        rot,
    }
}

impl Frames {
    /// Column `i` of the position Jacobian: `z_i × (p − o_i)`, mm per radian.
    pub(super) fn position_column(&self, i: usize) -> [f64; 3] {
        let o = self.origin[i];
        cross(
            self.axis[i],
            [
                self.tool[0] - o[0],
                self.tool[1] - o[1],
                self.tool[2] - o[2],
            ],
        )
    }
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub(super) fn norm(a: &[f64]) -> f64 {
    a.iter().map(|v| v * v).sum::<f64>().sqrt()
}

/// Angle between two rotations, radians: the angle of `aᵀ b`, from its sine (the norm of the
/// skew part) and cosine, accurate near 0.
pub fn rotation_angle(a: &Rot3, b: &Rot3) -> f64 {
    let m = |i: usize, j: usize| (0..3).map(|k| a[k][i] * b[k][j]).sum::<f64>();
    let s = 0.5 * norm(&[m(2, 1) - m(1, 2), m(0, 2) - m(2, 0), m(1, 0) - m(0, 1)]);
    let c = 0.5 * (m(0, 0) + m(1, 1) + m(2, 2) - 1.0);
    s.atan2(c)
}

/// Orientation error vector `½ Σ_k r_k × d_k` of rotation `r` against the desired `d` (columns
/// `r_k`, `d_k`): zero at `r = d`, `sin(angle)·axis` nearby.
pub(super) fn orientation_error(r: &Rot3, d: &Rot3) -> [f64; 3] {
    let mut e = [0.0; 3];
    for k in 0..3 {
        let c = cross([r[0][k], r[1][k], r[2][k]], [d[0][k], d[1][k], d[2][k]]);
        for i in 0..3 {
            e[i] += 0.5 * c[i];
        }
    }
    e
}

/// Solves `a x = b` for a small square system by Gaussian elimination with partial pivoting;
/// `None` when singular.
pub(super) fn solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Option<Vec<f64>> {
    let n = b.len();
    for c in 0..n {
        let p = (c..n).max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))?;
        if a[p][c] == 0.0 || !a[p][c].is_finite() {
            return None;
        }
        a.swap(c, p);
        b.swap(c, p);
        for r in c + 1..n {
            let f = a[r][c] / a[c][c];
            for k in c..n {
                a[r][k] -= f * a[c][k];
            }
            b[r] -= f * b[c];
        }
    }
    let mut x = vec![0.0; n];
    for r in (0..n).rev() {
        let s: f64 = (r + 1..n).map(|k| a[r][k] * x[k]).sum();
        x[r] = (b[r] - s) / a[r][r];
    }
    Some(x)
}

/// The 3 × n position Jacobian of the tool point (one row per coordinate, one column per
/// joint of the model), mm per radian: column i is `z_i × (p − o_i)`.
pub fn position_jacobian(model: &RobotModel, q: &[f64]) -> [Joints; 3] {
    let f = frames(model, q);
    let n = model.joints();
    let mut j = [Joints::filled(n, 0.0); 3];
    for i in 0..n {
        let c = f.position_column(i);
        for k in 0..3 {
            j[k][i] = c[k];
        }
    }
    j
}

/// Condition number `σ_max / σ_min` of the 3 × n position Jacobian at `q`, from the eigenvalues
/// of `J Jᵀ` (closed form for a symmetric 3 × 3 matrix); `None` at a position singularity.
pub fn position_condition(model: &RobotModel, q: &[f64]) -> Option<f64> {
    let j = position_jacobian(model, q);
    let n = model.joints();
    let mut a = [[0.0; 3]; 3];
    for r in 0..3 {
        for c in 0..3 {
            a[r][c] = (0..n).map(|k| j[r][k] * j[c][k]).sum();
        }
    }
    let ev = sym3_eigenvalues(&a);
    let (lo, hi) = (ev[0], ev[2]);
    (lo > hi * 1e-24 && hi > 0.0).then(|| (hi / lo).sqrt())
}

/// Eigenvalues of a symmetric 3 × 3 matrix, ascending (the trigonometric closed form of
/// O. K. Smith, "Eigenvalues of a symmetric 3 × 3 matrix", Comm. ACM 4(4), 1961).
fn sym3_eigenvalues(a: &[[f64; 3]; 3]) -> [f64; 3] {
    let p1 = a[0][1].powi(2) + a[0][2].powi(2) + a[1][2].powi(2);
    let tr = a[0][0] + a[1][1] + a[2][2];
    if p1 == 0.0 {
        let mut d = [a[0][0], a[1][1], a[2][2]];
        d.sort_by(f64::total_cmp);
        return d;
    }
    let qm = tr / 3.0;
    let p2 = (a[0][0] - qm).powi(2) + (a[1][1] - qm).powi(2) + (a[2][2] - qm).powi(2) + 2.0 * p1;
    let p = (p2 / 6.0).sqrt();
    let mut b = [[0.0; 3]; 3];
    for r in 0..3 {
        for c in 0..3 {
            b[r][c] = (a[r][c] - if r == c { qm } else { 0.0 }) / p;
        }
    }
    let det = b[0][0] * (b[1][1] * b[2][2] - b[1][2] * b[2][1])
        - b[0][1] * (b[1][0] * b[2][2] - b[1][2] * b[2][0])
        + b[0][2] * (b[1][0] * b[2][1] - b[1][1] * b[2][0]);
    let phi = (det / 2.0).clamp(-1.0, 1.0).acos() / 3.0;
    let e1 = qm + 2.0 * p * phi.cos();
    let e3 = qm + 2.0 * p * (phi + 2.0 * std::f64::consts::PI / 3.0).cos();
    let e2 = tr - e1 - e3;
    let mut e = [e1, e2, e3];
    e.sort_by(f64::total_cmp);
    e
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::presets::{preset, PRESETS};

    #[test]
    fn rpy_matches_its_definition() {
        // Roll 180°: x stays, y and z flip (tool axis down).
        let r = rpy_rotation([180.0, 0.0, 0.0]);
        let want = [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]];
        for i in 0..3 {
            for j in 0..3 {
                assert!((r[i][j] - want[i][j]).abs() < 1e-15, "{r:?}");
            }
        }
        // Yaw 90°: x → y.
        let r = rpy_rotation([0.0, 0.0, 90.0]);
        assert!((r[1][0] - 1.0).abs() < 1e-15 && r[0][0].abs() < 1e-15);
        assert!(
            (rotation_angle(&rpy_rotation([10.0, 0.0, 0.0]), &rpy_rotation([0.0; 3]))
                - 10f64.to_radians())
            .abs()
                < 1e-15
        );
    }

    #[test]
    fn condition_of_a_diagonal_gram() {
        let e = sym3_eigenvalues(&[[4.0, 1.0, 0.0], [1.0, 4.0, 0.0], [0.0, 0.0, 9.0]]);
        for (got, want) in e.iter().zip([3.0, 5.0, 9.0]) {
            assert!((got - want).abs() < 1e-12, "{e:?}");
        }
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        for name in PRESETS {
            let m = preset(name).unwrap();
            let q = crate::kinematics::Joints::from_slice(
                &[0.3, -0.5, 0.9, 0.4, -0.7, 0.2, 0.6][..m.joints()],
            );
            let j = position_jacobian(&m, &q);
            let h = 1e-6;
            for i in 0..m.joints() {
                let (mut a, mut b) = (q, q);
                a[i] += h;
                b[i] -= h;
                let (pa, pb) = (
                    position(&m.params, &m.tool, &a),
                    position(&m.params, &m.tool, &b),
                );
                for k in 0..3 {
                    let fd = (pa[k] - pb[k]) / (2.0 * h);
                    // Central difference: truncation ~h²·|p'''| ≈ 1e-12·1e3 mm, rounding
                    // ~1e-16·1e3/1e-6 = 1e-7 mm per rad.
                    assert!(
                        (fd - j[k][i]).abs() < 1e-5,
                        "{name} J[{k}][{i}] {} vs {fd}",
                        j[k][i]
                    );
                }
            }
        }
    }
}
