//! From joint axis lines to the MDH (Hayati) parameters and the tool point (docs/METHOD.md §1–2,
//! paper eqs. 7–11): the conversion of the identification (measured axes, `crate::identify`) and
//! of the importer (the axes of a kinematic description, `crate::import`).
//!
//! Frame `i−1` has its z axis on joint `i`'s axis; `T_i = Rz(θ_i+q_i)·Tz(d_i)·Tx(a_i)·Rx(α_i)·Ry(β_i)`
//! carries it to frame `i`, whose z axis is joint `i+1`'s axis. Given frame `i−1` and joint
//! `i+1`'s axis line (both known in the base frame at the home pose of joint `i+1`'s sweep), the
//! parameters of joint `i` are read off in frame `i−1` coordinates:
//!
//! * **Non-parallel pair** (`β_i` fixed at 0): the common normal of the z axis and the next axis
//!   gives `d_i` (height of its foot on z), its direction `x'` (±`z × n`, the sign chosen so `θ_i`
//!   is nearest the nominal `θ_i`), the signed length `a_i` along `x'`, and `α_i`, the angle from z
//!   to the next axis about `x'`. Intersecting axes need no special case: the normal's direction
//!   is always `z × n`.
//! * **Parallel or nearly parallel pair** (the nominal model fixes `d_i`, or the measured axes are
//!   within [`PARALLEL_THRESHOLD_DEG`] of parallel): the common normal is not unique, so `d_i` is
//!   kept at its nominal value and the next axis is intersected with the plane `z = d_i`; that
//!   point gives `x'` and `a_i`, and the next axis direction `n = Rx(α)Ry(β)·e_z` gives
//!   `β_i = asin(n·x')`, `α_i = atan2(−n·y', n·z)`.
//!
//! `θ_i` is the angle from `x_{i−1}` to `x'` about z minus the commanded `q_i` at which the next
//! axis was measured, so FK at commanded angles reproduces the measurements.
//!
//! Conventions for what point measurements cannot separate or the 5-parameter form cannot hold:
//! * **Base / joint 1**: the model's first axis is the base z axis through the base origin (the
//!   form has no parameters before `Rz(θ_1+q_1)`). The measured J1 axis is not used for the
//!   parameters; its tilt and offset from base z are reported as a diagnostic. With a tracker
//!   frame that is the robot base frame (as the data format requires) they are zero up to noise.
//!   `θ_1, d_1, a_1, α_1` come from the common normal of base z and the J2 axis.
//! * **The last joint (J6 of a six-axis arm) and the tool**: `θ_n, d_n, a_n, α_n, β_n` keep their
//!   nominal values; only the target's position relative to the last axis is observable (three
//!   numbers), and it is absorbed in the tool point, estimated as the mean of the last sweep's
//!   points mapped into the flange frame.
//! * A fixed `β` is fixed at 0 (docs/METHOD.md §1); a fixed `d` at its nominal value.

use super::lines::{common_normal, Line};
use super::{
    joint_transform, param_index, FixedParam, FixedParams, Joints, ParamKind, Params, RobotModel,
};
use nalgebra::{Matrix3, Vector3};

/// Consecutive axes closer to parallel than this (degrees) are identified with `β` instead of
/// `d` even when the nominal model fixes `β`: below it the common normal's foot (and so `d`)
/// slides along the axes and amplifies measurement noise.
pub const PARALLEL_THRESHOLD_DEG: f64 = 1.0;

/// The axes cannot be turned into a joint's parameters (the identification reports it as
/// `IdentifyError::Geometry`, the importer as `ImportError::NotRepresentable`).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("joint {joint}: {message}")]
pub struct GeometryError {
    /// 1-based joint.
    pub joint: usize,
    /// What is wrong.
    pub message: String,
}

/// Parameters of one joint read off from the next axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointGeometry {
    /// `[θ, d, a, α, β]`, mm and radians.
    pub params: [f64; 5],
    /// Which of d / β is fixed.
    pub fixed: FixedParam,
    /// Angle between this axis and the next, degrees in [0, 180].
    pub axis_angle_deg: f64,
}

fn wrap_near(angle: f64, reference: f64) -> f64 {
    let tau = std::f64::consts::TAU;
    reference + (angle - reference + std::f64::consts::PI).rem_euclid(tau) - std::f64::consts::PI
}

/// Parameters of joint `i` from the next axis `next` expressed in frame `i−1` coordinates (frame
/// `i−1` is the identity there: joint `i`'s axis is the z axis through the origin), measured with
/// joint `i` at `q_home` (radians). `nominal` supplies the sign conventions, the fixed `d` and the
/// structure.
///
/// # Errors
///
/// A message when the parallel-axis (`β`) form is needed but the next axis is perpendicular to this
/// one, or passes through this axis at height `d`.
pub fn joint_from_next_axis(
    next: &Line,
    q_home: f64,
    nominal: [f64; 5],
    nominal_fixed: FixedParam,
) -> Result<JointGeometry, String> {
    let z = Vector3::z();
    let n = next.dir;
    let axis_angle_deg = n.dot(&z).clamp(-1.0, 1.0).acos().to_degrees();
    let near_parallel = axis_angle_deg.min(180.0 - axis_angle_deg) < PARALLEL_THRESHOLD_DEG;
    let fixed = if near_parallel {
        FixedParam::D
    } else {
        nominal_fixed
    };
    let theta_ref = nominal[0] + q_home;
    let x_ref = Vector3::new(theta_ref.cos(), theta_ref.sin(), 0.0);
    let (d, foot_on_z, foot_on_next, mut x) = match fixed {
        FixedParam::Beta => {
            let zl = Line {
                point: Vector3::zeros(),
                dir: z,
            };
            let cn = common_normal(&zl, next);
            let x = z.cross(&n).normalize();
            (cn.foot1.z, cn.foot1, cn.foot2, x)
        }
        FixedParam::D => {
            let d = nominal[1];
            if n.z.abs() < 1e-6 {
                return Err(format!(
                    "the next axis is perpendicular to this one ({axis_angle_deg:.3} deg): cannot use the parallel-axis (beta) form"
                ));
            }
            let s = (d - next.point.z) / n.z;
            let o = next.point + n * s;
            let xy = Vector3::new(o.x, o.y, 0.0);
            if xy.norm() < 1e-6 {
                return Err(format!(
                    "the next axis ({axis_angle_deg:.3} deg away) passes through this axis at height d = {d} mm: the parallel-axis (beta) form needs a nonzero common normal"
                ));
            }
            (d, Vector3::new(0.0, 0.0, d), o, xy.normalize())
        }
    };
    if x.dot(&x_ref) < 0.0 {
        x = -x;
    }
    let y = z.cross(&x);
    let a = (foot_on_next - foot_on_z).dot(&x);
    let beta = match fixed {
        FixedParam::Beta => 0.0,
        FixedParam::D => n.dot(&x).clamp(-1.0, 1.0).asin(),
    };
    let alpha = (-n.dot(&y)).atan2(n.dot(&z));
    let theta = wrap_near(x.y.atan2(x.x) - q_home, nominal[0]);
    let alpha = wrap_near(alpha, nominal[3]);
    Ok(JointGeometry {
        params: [theta, d, a, alpha, beta],
        fixed,
        axis_angle_deg,
    })
}

/// Rotation and translation of frame `k` (after the first `k` joints) in the base frame.
pub fn frame(params: &[f64], k: usize, q_rad: &[f64]) -> (Matrix3<f64>, Vector3<f64>) {
    let mut r = Matrix3::identity();
    let mut t = Vector3::zeros();
    for (j, q) in q_rad.iter().enumerate().take(k) {
        let p = &params[param_index(j, ParamKind::Theta)..param_index(j + 1, ParamKind::Theta)];
        let m = joint_transform(p[0], p[1], p[2], p[3], p[4], *q);
        let rj = Matrix3::from_fn(|a, b| m[a][b]);
        let tj = Vector3::new(m[0][3], m[1][3], m[2][3]);
        t += r * tj;
        r *= rj;
    }
    (r, t)
}

/// A measured axis: its line in the base frame and the commanded pose (degrees) of its sweep's
/// home (the non-swept joints).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeasuredAxis {
    /// The axis line in the base frame.
    pub line: Line,
    /// The sweep's home pose, degrees (the swept joint's entry is not used).
    pub home_deg: Joints,
}

/// The identified chain.
#[derive(Clone, Debug, PartialEq)]
pub struct Chain {
    /// The `5n` parameters, mm and radians.
    pub params: Params,
    /// Per joint, which of d / β is fixed.
    pub fixed: FixedParams,
    /// Tool point in the flange frame, mm.
    pub tool: [f64; 3],
    /// Angle between axis i and i+1 (degrees), for joints 1 to n − 1.
    pub axis_angles_deg: Vec<f64>,
}

/// Builds the chain from the measured axes of joints 1 to n (`axes[0]` is not used, see the
/// module docs; one axis per joint of `nominal`) and the last sweep's points `(q_deg, position)`.
///
/// # Errors
///
/// [`GeometryError`] naming the joint when its next axis cannot be turned into parameters
/// ([`joint_from_next_axis`]), or the last joint when there are no tool points.
pub fn axes_to_chain(
    nominal: &RobotModel,
    axes: &[MeasuredAxis],
    tool_points: &[(Joints, Vector3<f64>)],
) -> Result<Chain, GeometryError> {
    let n = nominal.joints();
    debug_assert_eq!(axes.len(), n);
    let last = n - 1;
    let mut params = nominal.params;
    let mut fixed = nominal.fixed;
    let mut axis_angles_deg = vec![0.0; last];
    for i in 0..last {
        let next = &axes[i + 1];
        let q = next.home_deg.map(f64::to_radians);
        let (r, t) = frame(&params, i, &q);
        // Next axis in frame i−1 coordinates.
        let local = Line {
            point: r.transpose() * (next.line.point - t),
            dir: r.transpose() * next.line.dir,
        };
        let mut nom = [0.0; 5];
        nom.copy_from_slice(&nominal.params[5 * i..5 * i + 5]);
        let g = joint_from_next_axis(&local, q[i], nom, nominal.fixed[i]).map_err(|message| {
            GeometryError {
                joint: i + 1,
                message,
            }
        })?;
        params[5 * i..5 * i + 5].copy_from_slice(&g.params);
        fixed[i] = g.fixed;
        axis_angles_deg[i] = g.axis_angle_deg;
    }
    // The last joint keeps its nominal parameters (fixed β at 0); the tool absorbs the rest.
    if fixed[last] == FixedParam::Beta {
        params[param_index(last, ParamKind::Beta)] = 0.0;
    }
    if tool_points.is_empty() {
        return Err(GeometryError {
            joint: n,
            message: "no points to place the tool".into(),
        });
    }
    let mut p6 = [0.0; 5];
    p6.copy_from_slice(&params[5 * last..5 * last + 5]);
    let mut w = Vector3::zeros();
    for (q_deg, p) in tool_points {
        let q = q_deg.map(f64::to_radians);
        let (r, t) = frame(&params, last, &q);
        let local = r.transpose() * (p - t);
        let (s, c) = (-(p6[0] + q[last])).sin_cos();
        w += Vector3::new(
            c * local.x - s * local.y,
            s * local.x + c * local.y,
            local.z,
        );
    }
    w /= tool_points.len() as f64;
    // M6 · tool = (a6, 0, d6) + Rx(α6) Ry(β6) · tool.
    let m = joint_transform(0.0, 0.0, 0.0, p6[3], p6[4], 0.0);
    let rxy = Matrix3::from_fn(|a, b| m[a][b]);
    let tool = rxy.transpose() * (w - Vector3::new(p6[2], 0.0, p6[1]));
    Ok(Chain {
        params,
        fixed,
        tool: [tool.x, tool.y, tool.z],
        axis_angles_deg,
    })
}

/// The chain whose joint axes at q = 0 are `axes` (base frame, direction = positive rotation
/// sense) and whose tool point at q = 0 is `tip`: the conversion of a kinematic description
/// (URDF, DH table, UR calibration; `crate::import`) to the MDH form, by the same
/// [`axes_to_chain`] that identification uses, with the reference parameters all zero:
///
/// * every `θ_i` is chosen nearest 0 and every `α_i` nearest 0 (the sign of the common normal);
/// * consecutive axes within [`PARALLEL_THRESHOLD_DEG`] of parallel get `β_i` free and `d_i = 0`;
/// * the last joint n keeps `θ_n = a_n = α_n = β_n = 0`; the tip's offset along its axis goes
///   into `d_n` and the rest into the tool point, so a flange on the axis gives a zero tool point.
///
/// `axes[0]` must be the base z axis (the model has no parameters before `Rz(θ_1 + q_1)`); the
/// caller checks that (this function cannot see it: [`axes_to_chain`] does not use `axes[0]`).
///
/// # Errors
///
/// [`GeometryError`] naming the joint whose next axis cannot be turned into parameters (see
/// [`axes_to_chain`]).
pub fn chain_from_zero_pose(axes: &[Line], tip: Vector3<f64>) -> Result<Chain, GeometryError> {
    let n = axes.len();
    let reference = RobotModel {
        joint_errors: None,
        links: None,
        discrepancy: None,
        name: String::new(),
        params: Params::filled(5 * n, 0.0),
        fixed: FixedParams::filled(n, FixedParam::Beta),
        limits_deg: crate::kinematics::Limits::filled(n, (-180.0, 180.0)),
        tool: [0.0; 3],
        tool_sigma: [0.0; 3],
        base: None,
        uncertainty: crate::kinematics::Uncertainty::Independent(Params::filled(5 * n, 0.0)),
    };
    let measured: Vec<MeasuredAxis> = axes
        .iter()
        .map(|&line| MeasuredAxis {
            line,
            home_deg: Joints::filled(n, 0.0),
        })
        .collect();
    let mut chain = axes_to_chain(&reference, &measured, &[(Joints::filled(n, 0.0), tip)])?;
    // With θn = an = αn = βn = 0, Tn·p = Rz(qn)·(p + (0, 0, dn)): the along-axis part of the tool
    // point is dn, exactly.
    chain.params[param_index(n - 1, ParamKind::D)] = chain.tool[2];
    chain.tool[2] = 0.0;
    Ok(chain)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::{position, tx60};

    #[test]
    fn joint_params_recovered_from_next_axis() {
        // Frame i−1 = identity; build T_i from known params and read them back.
        for (p, fx) in [
            ([0.3, 12.0, 4.0, -1.2, 0.0], FixedParam::Beta),
            ([-1.6, 0.0, 290.0, 0.002, 0.001], FixedParam::D),
            ([1.57, 20.0, -0.2, 1.5, 0.0], FixedParam::Beta),
        ] {
            let q = 0.4;
            let m = joint_transform(p[0], p[1], p[2], p[3], p[4], q);
            let line = Line {
                point: Vector3::new(m[0][3], m[1][3], m[2][3]),
                dir: Vector3::new(m[0][2], m[1][2], m[2][2]),
            };
            let nominal = [p[0] + 0.01, p[1], 0.0, p[3] - 0.01, 0.0];
            let g = joint_from_next_axis(&line, q, nominal, fx).unwrap();
            for k in 0..5 {
                assert!(
                    (g.params[k] - p[k]).abs() < 1e-9,
                    "{k}: {:?} vs {p:?}",
                    g.params
                );
            }
        }
    }

    #[test]
    fn nominal_chain_from_its_own_axes() {
        let m = tx60();
        let home = Joints::from([10.0, 40.0, 50.0, 20.0, 60.0, 0.0]);
        let q = home.map(f64::to_radians);
        let mut axes = [MeasuredAxis {
            line: Line {
                point: Vector3::zeros(),
                dir: Vector3::z(),
            },
            home_deg: home,
        }; 6];
        for (i, ax) in axes.iter_mut().enumerate() {
            let (r, t) = frame(&m.params, i, &q);
            ax.line = Line {
                point: t,
                dir: r * Vector3::z(),
            };
        }
        let tool = [30.0, -20.0, 80.0];
        let pts: Vec<_> = (0..5)
            .map(|k| {
                let mut qd = home;
                qd[5] = k as f64 * 20.0;
                let p = position(&m.params, &tool, &qd.map(f64::to_radians));
                (qd, Vector3::from(p))
            })
            .collect();
        let c = axes_to_chain(&m, &axes, &pts).unwrap();
        for k in 0..m.params.len() {
            assert!((c.params[k] - m.params[k]).abs() < 1e-9, "param {k}");
        }
        for (a, b) in c.tool.iter().zip(&tool) {
            assert!((a - b).abs() < 1e-9);
        }
    }
}
