//! Numerical inverse kinematics on the model's own MDH chain (docs/METHOD.md §15.1).
//!
//! Damped least squares (Levenberg–Marquardt): with the task error `e` (tool-point position, mm,
//! and, when the orientation is fixed, the flange orientation error scaled by a length so both
//! are in mm) and the geometric Jacobian `J` of the chain, a step is
//! `Δq = Jᵀ (J Jᵀ + λ I)⁻¹ e` (the minimum-norm damped step, which also serves the redundant
//! position-only task), accepted when it lowers `‖e‖` (then λ shrinks tenfold) and rejected
//! otherwise (λ grows tenfold). Every iterate is projected into the joint limits. Several
//! seeds are tried; of the configurations that reach the target the one nearest a reference
//! configuration is kept, which picks one branch (elbow, wrist, shoulder) for the whole map.
//!
//! The Jacobian is exact: joint i turns about the z axis of frame i − 1 (`T_i = Rz(θ_i + q_i)·…`),
//! so its column is `z × (p − o)` for the position and `z` for the orientation, with `z` and
//! `o` that frame's axis and origin in the base frame.

use crate::kinematics::{joint_transform, position, RobotModel, JOINTS};

/// Largest accepted distance between the tool point of a solution and its target, mm.
pub const POSITION_TOL_MM: f64 = 1e-9;
/// Largest accepted angle between a solution's flange orientation and the target's, radians
/// (1e-10 rad turns a point one metre from the flange by 1e-7 mm).
pub const ORIENTATION_TOL_RAD: f64 = 1e-10;
/// Iterations per seed; converging seeds need 5–30.
const MAX_ITERATIONS: usize = 200;

/// A 3 × 3 rotation matrix, row-major.
pub type Rot3 = [[f64; 3]; 3];

/// What a cell asks of the robot: a tool-point position and, optionally, a flange orientation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IkTarget {
    /// Tool-point position in the base frame, mm.
    pub position: [f64; 3],
    /// Flange orientation in the base frame, or `None` for a position-only (3-DOF) task.
    pub rotation: Option<Rot3>,
}

/// A configuration that reaches its target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IkSolution {
    /// Joint angles, radians, within the limits.
    pub q: [f64; JOINTS],
    /// Distance between the tool point and the target, mm.
    pub position_residual: f64,
    /// Angle between the flange orientation and the target's, radians (`None` for a
    /// position-only task).
    pub orientation_residual: Option<f64>,
}

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

/// The chain at one configuration: per joint its axis and a point on it (base frame), the tool
/// point and the flange rotation.
struct Frames {
    axis: [[f64; 3]; JOINTS],
    origin: [[f64; 3]; JOINTS],
    tool: [f64; 3],
    rot: Rot3,
}

fn frames(model: &RobotModel, q: &[f64; JOINTS]) -> Frames {
    let mut t = [[0.0; 4]; 4];
    for (i, row) in t.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    let mut axis = [[0.0; 3]; JOINTS];
    let mut origin = [[0.0; 3]; JOINTS];
    for i in 0..JOINTS {
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
    fn position_column(&self, i: usize) -> [f64; 3] {
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

fn norm(a: &[f64]) -> f64 {
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
fn orientation_error(r: &Rot3, d: &Rot3) -> [f64; 3] {
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
fn solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Option<Vec<f64>> {
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

/// The 3 × 6 position Jacobian of the tool point, mm per radian: column i is `z_i × (p − o_i)`.
pub fn position_jacobian(model: &RobotModel, q: &[f64; JOINTS]) -> [[f64; JOINTS]; 3] {
    let f = frames(model, q);
    let mut j = [[0.0; JOINTS]; 3];
    for i in 0..JOINTS {
        let c = f.position_column(i);
        for k in 0..3 {
            j[k][i] = c[k];
        }
    }
    j
}

/// Condition number `σ_max / σ_min` of the 3 × 6 position Jacobian at `q`, from the eigenvalues
/// of `J Jᵀ` (closed form for a symmetric 3 × 3 matrix); `None` at a position singularity.
pub fn position_condition(model: &RobotModel, q: &[f64; JOINTS]) -> Option<f64> {
    let j = position_jacobian(model, q);
    let mut a = [[0.0; 3]; 3];
    for r in 0..3 {
        for c in 0..3 {
            a[r][c] = (0..JOINTS).map(|k| j[r][k] * j[c][k]).sum();
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

/// An inverse-kinematics solver for one model: its limits, its reference configuration and its
/// fixed set of seeds.
#[derive(Clone, Debug)]
pub struct Ik<'a> {
    model: &'a RobotModel,
    lo: [f64; JOINTS],
    hi: [f64; JOINTS],
    reference: [f64; JOINTS],
    seeds: Vec<[f64; JOINTS]>,
    /// Length (mm) that turns orientation errors (rad) into mm: half the reach bound.
    scale: f64,
}

/// A bound on the distance from the base origin the tool point can reach, mm: every link
/// length and offset and the tool added up.
pub fn reach_bound(model: &RobotModel) -> f64 {
    (0..JOINTS)
        .map(|i| model.params[5 * i + 1].abs() + model.params[5 * i + 2].abs())
        .sum::<f64>()
        + norm(&model.tool)
}

impl<'a> Ik<'a> {
    /// A solver for `model` choosing solutions nearest `reference` (radians, within the limits),
    /// with `extra_seeds` seeds spread over the joint ranges besides the reference (a fixed
    /// low-discrepancy set, so a map is reproducible).
    pub fn new(model: &'a RobotModel, reference: [f64; JOINTS], extra_seeds: usize) -> Self {
        let lo = model.limits_deg.map(|l| l.0.to_radians());
        let hi = model.limits_deg.map(|l| l.1.to_radians());
        // Additive recurrence with the generalised golden ratio of dimension 6 (a Kronecker
        // sequence; M. Roberts, "The unreasonable effectiveness of quasirandom sequences", 2018).
        let g = {
            let mut x: f64 = 2.0;
            for _ in 0..64 {
                x = (1.0 + x).powf(1.0 / 7.0);
            }
            x
        };
        let alpha: [f64; JOINTS] = std::array::from_fn(|i| 1.0 / g.powi(i as i32 + 1));
        let seeds = (1..=extra_seeds)
            .map(|n| {
                std::array::from_fn(|i| {
                    let u = (0.5 + alpha[i] * n as f64).fract();
                    // Stay off the limits themselves: the middle 90 % of each range.
                    lo[i] + (hi[i] - lo[i]) * (0.05 + 0.9 * u)
                })
            })
            .collect();
        Ik {
            model,
            lo,
            hi,
            reference,
            seeds,
            scale: 0.5 * reach_bound(model).max(1.0),
        }
    }

    fn clamp(&self, q: &mut [f64; JOINTS]) {
        for i in 0..JOINTS {
            q[i] = q[i].clamp(self.lo[i], self.hi[i]);
        }
    }

    /// Task error (mm; orientation scaled by [`Ik::scale`]) at `q`.
    fn error(&self, target: &IkTarget, f: &Frames) -> Vec<f64> {
        let mut e: Vec<f64> = (0..3).map(|k| target.position[k] - f.tool[k]).collect();
        if let Some(d) = &target.rotation {
            e.extend(orientation_error(&f.rot, d).map(|v| v * self.scale));
        }
        e
    }

    /// Task Jacobian rows matching [`Ik::error`].
    fn jacobian(&self, target: &IkTarget, f: &Frames) -> Vec<[f64; JOINTS]> {
        let mut rows = vec![[0.0; JOINTS]; if target.rotation.is_some() { 6 } else { 3 }];
        for i in 0..JOINTS {
            let c = f.position_column(i);
            for k in 0..3 {
                rows[k][i] = c[k];
                if target.rotation.is_some() {
                    rows[3 + k][i] = f.axis[i][k] * self.scale;
                }
            }
        }
        rows
    }

    /// Residuals of `q` against `target`: position (mm) and orientation (rad).
    pub fn residuals(&self, target: &IkTarget, q: &[f64; JOINTS]) -> (f64, Option<f64>) {
        let f = frames(self.model, q);
        let p = norm(&[
            f.tool[0] - target.position[0],
            f.tool[1] - target.position[1],
            f.tool[2] - target.position[2],
        ]);
        (p, target.rotation.map(|d| rotation_angle(&f.rot, &d)))
    }

    fn accepted(&self, target: &IkTarget, q: &[f64; JOINTS]) -> Option<IkSolution> {
        let (p, o) = self.residuals(target, q);
        let in_limits = (0..JOINTS).all(|i| q[i] >= self.lo[i] && q[i] <= self.hi[i]);
        (in_limits && p <= POSITION_TOL_MM && o.is_none_or(|o| o <= ORIENTATION_TOL_RAD)).then_some(
            IkSolution {
                q: *q,
                position_residual: p,
                orientation_residual: o,
            },
        )
    }

    /// Damped least squares from one seed; the configuration it ends at.
    fn descend(&self, target: &IkTarget, seed: &[f64; JOINTS]) -> [f64; JOINTS] {
        let mut q = *seed;
        self.clamp(&mut q);
        let mut f = frames(self.model, &q);
        let mut e = self.error(target, &f);
        let mut cost = norm(&e);
        let s2 = self.scale * self.scale;
        let mut lambda = 1e-2 * s2;
        let mut checkpoint = cost;
        for it in 0..MAX_ITERATIONS {
            // A seed still far from the target that gained less than 1 % in 20 iterations is
            // caught in a local minimum or against a limit: give up on it.
            if it % 20 == 19 {
                if cost > 1e-6 * self.scale && cost > 0.99 * checkpoint {
                    break;
                }
                checkpoint = cost;
            }
            let p = norm(&e[..3]);
            let o = target.rotation.map(|d| rotation_angle(&f.rot, &d));
            if p <= 1e-3 * POSITION_TOL_MM && o.is_none_or(|o| o <= 1e-3 * ORIENTATION_TOL_RAD) {
                break;
            }
            let j = self.jacobian(target, &f);
            let m = j.len();
            let a: Vec<Vec<f64>> = (0..m)
                .map(|r| {
                    (0..m)
                        .map(|c| {
                            (0..JOINTS).map(|k| j[r][k] * j[c][k]).sum::<f64>()
                                + if r == c { lambda } else { 0.0 }
                        })
                        .collect()
                })
                .collect();
            let Some(y) = solve(a, e.clone()) else {
                lambda *= 10.0;
                continue;
            };
            let mut next = q;
            for k in 0..JOINTS {
                next[k] += (0..m).map(|r| j[r][k] * y[r]).sum::<f64>();
            }
            self.clamp(&mut next);
            let nf = frames(self.model, &next);
            let ne = self.error(target, &nf);
            let nc = norm(&ne);
            if nc < cost {
                (q, f, e, cost) = (next, nf, ne, nc);
                lambda = (lambda * 0.1).max(1e-15 * s2);
            } else {
                lambda *= 10.0;
                if lambda > 1e8 * s2 {
                    break;
                }
            }
        }
        q
    }

    /// Moves joints whose range exceeds a full turn by whole turns towards the reference,
    /// staying within the limits (the same pose, the branch nearest the reference).
    fn unwrap_turns(&self, q: &mut [f64; JOINTS]) {
        let tau = std::f64::consts::TAU;
        for i in 0..JOINTS {
            loop {
                let d = q[i] - self.reference[i];
                let step = if d > 0.5 * tau {
                    -tau
                } else if d < -0.5 * tau {
                    tau
                } else {
                    break;
                };
                let moved = q[i] + step;
                if moved < self.lo[i] || moved > self.hi[i] {
                    break;
                }
                q[i] = moved;
            }
        }
    }

    /// `seed` turned about joint 1 so its tool point lies at the target's azimuth, and turned
    /// half a turn further (the arm reaching over its base), each within the limits of joint 1;
    /// `seed` itself when the tool point or the target lies on the base axis. Joint 1 turns
    /// the whole arm about the base z axis (`T_1 = Rz(θ_1 + q_1)·…`), so this keeps the seed's
    /// reach and height and only aims it.
    fn turned_towards(&self, seed: &[f64; JOINTS], target: &IkTarget) -> Vec<[f64; JOINTS]> {
        let p = position(&self.model.params, &self.model.tool, seed);
        let t = target.position;
        if p[0].hypot(p[1]) < 1e-6 || t[0].hypot(t[1]) < 1e-6 {
            return vec![*seed];
        }
        let turn = t[1].atan2(t[0]) - p[1].atan2(p[0]);
        let tau = std::f64::consts::TAU;
        [0.0, std::f64::consts::PI]
            .iter()
            .filter_map(|extra| {
                let q1 = seed[0] + turn + extra;
                // The turn nearest the seed's own q1 that lies within the limits.
                let base = q1 - tau * ((q1 - seed[0]) / tau).round();
                [base, base - tau, base + tau]
                    .into_iter()
                    .find(|v| *v >= self.lo[0] && *v <= self.hi[0])
                    .map(|v| {
                        let mut q = *seed;
                        q[0] = v;
                        q
                    })
            })
            .collect()
    }

    fn distance(&self, q: &[f64; JOINTS]) -> f64 {
        norm(&std::array::from_fn::<f64, JOINTS, _>(|i| {
            q[i] - self.reference[i]
        }))
    }

    /// Solves for `target`: first from the `neighbours`' configurations (already solved
    /// cells), which continues their branch; when none of them reaches the target (the first
    /// cell of a region, or no neighbours), from the reference and the fixed seeds. Of the
    /// configurations that reach the target within the limits, the one nearest the reference.
    /// `None` when no seed reaches it.
    pub fn solve(&self, target: &IkTarget, neighbours: &[[f64; JOINTS]]) -> Option<IkSolution> {
        self.nearest(target, neighbours.to_vec()).or_else(|| {
            let aimed = std::iter::once(&self.reference)
                .chain(&self.seeds)
                .flat_map(|s| self.turned_towards(s, target))
                .collect();
            self.nearest(target, aimed)
        })
    }

    /// Of the configurations the `seeds` descend to that reach `target`, the one nearest the
    /// reference.
    fn nearest(&self, target: &IkTarget, seeds: Vec<[f64; JOINTS]>) -> Option<IkSolution> {
        use rayon::prelude::*;
        // Seeds descend independently (in parallel); the choice among the results is made in
        // seed order, so it does not depend on the thread count.
        let found: Vec<Option<IkSolution>> = seeds
            .par_iter()
            .map(|seed| {
                let mut q = self.descend(target, seed);
                self.unwrap_turns(&mut q);
                self.accepted(target, &q)
            })
            .collect();
        let mut best: Option<(f64, IkSolution)> = None;
        for s in found.into_iter().flatten() {
            let d = self.distance(&s.q);
            if best.as_ref().is_none_or(|(bd, _)| d < *bd) {
                best = Some((d, s));
            }
        }
        best.map(|(_, s)| s)
    }
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
            let q = [0.3, -0.5, 0.9, 0.4, -0.7, 0.2];
            let j = position_jacobian(&m, &q);
            let h = 1e-6;
            for i in 0..JOINTS {
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

    #[test]
    fn round_trip_from_known_configurations() {
        for name in PRESETS {
            let m = preset(name).unwrap();
            let mid = m.limits_deg.map(|l| (0.5 * (l.0 + l.1)).to_radians());
            let ik = Ik::new(&m, mid, 8);
            for q in [
                [0.2, -0.4, 0.8, 0.3, 0.9, -0.5],
                [-1.0, 0.3, -0.6, 1.2, -0.8, 2.0],
            ] {
                let f = frames(&m, &q);
                for rotation in [Some(f.rot), None] {
                    let t = IkTarget {
                        position: f.tool,
                        rotation,
                    };
                    let s = ik.solve(&t, &[]).unwrap_or_else(|| panic!("{name} {q:?}"));
                    let p = position(&m.params, &m.tool, &s.q);
                    let d = norm(&[p[0] - f.tool[0], p[1] - f.tool[1], p[2] - f.tool[2]]);
                    assert!(d <= POSITION_TOL_MM, "{name}: {d}");
                }
            }
        }
    }
}
