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
//! With more task constraints than joints (a fixed orientation for an arm of four or five
//! joints) the step solves the damped normal equations `(JᵀJ + λ I) Δq = Jᵀ e` instead, the
//! same step written for the smaller system.
//!
//! **Redundancy.** An arm of `n` joints has `n − m` degrees of freedom left by a task of `m`
//! constraints (3 for a position, 6 with the orientation): a seven-joint arm keeps one with a
//! fixed orientation and four without. There a configuration that reaches the target is slid
//! along the set of configurations that reach it (the self-motion) to the one locally nearest
//! the reference: each step moves `q` by the projection of `q_ref − q` on the null space of
//! `J`, `(I − Jᵀ (J Jᵀ)⁻¹ J)(q_ref − q)` (a first-order step of `min ‖q − q_ref‖` subject to
//! reaching the target), lengthened by a Barzilai–Borwein factor where the self-motion curves
//! and at most [`NULL_STEP_RAD`] long, then returns to the target with the damped least squares
//! above, and is kept when it reached the target nearer the reference (else the step is
//! shortened), until that projection vanishes. A joint on a limit that the step would move
//! beyond is held there (left out of `J` and of `q_ref − q`), so the slide ends at the
//! configuration nearest the reference within the limits. The seeds then choose among the
//! local minima as for any arm. A six-joint arm keeps its earlier solver unchanged
//! (for a position-only task it chooses among the configurations its seeds descend to, without
//! sliding), so its maps do not change.
//!
//! The Jacobian is exact: joint i turns about the z axis of frame i − 1 (`T_i = Rz(θ_i + q_i)·…`),
//! so its column is `z × (p − o)` for the position and `z` for the orientation, with `z` and
//! `o` that frame's axis and origin in the base frame.
//!
//! The chain's frames, its Jacobian and the small linear algebra the solver needs are in
//! `geometry`, the slide along the self-motion of a redundant arm in `redundancy`, the unit
//! tests in `tests`; this file is the solver.

mod geometry;
mod redundancy;
#[cfg(test)]
mod tests;

pub use geometry::{position_condition, position_jacobian, rotation_angle, rpy_rotation, Rot3};

use crate::kinematics::{position, Joints, RobotModel};
use geometry::{frames, norm, orientation_error, solve, Frames};

/// Largest accepted distance between the tool point of a solution and its target, mm.
pub const POSITION_TOL_MM: f64 = 1e-9;
/// Largest accepted angle between a solution's flange orientation and the target's, radians
/// (1e-10 rad turns a point one metre from the flange by 1e-7 mm).
pub const ORIENTATION_TOL_RAD: f64 = 1e-10;
/// Seeds every solve may use where no neighbour's branch reaches the target: enough that the
/// branch nearest the reference is among the solutions found (on the TX60's 50 × 50 plane, 64
/// and 256 seeds give the same 1507 cells and configurations; 8 gave 1500, with 263 cells on
/// another branch).
pub const BUILT_IN_SEEDS: usize = 64;
/// Iterations per seed; converging seeds need 5–30.
const MAX_ITERATIONS: usize = 200;
/// Iterations after which a seed that gained less than 1 % is given up.
const STALL_WINDOW: usize = 10;
/// Longest step along the self-motion of a redundant arm, radians (see the module docs).
pub const NULL_STEP_RAD: f64 = 0.25;
/// Most steps along the self-motion from one configuration.
const MAX_NULL_STEPS: usize = 200;
/// Largest Barzilai–Borwein factor of a step along the self-motion.
const MAX_NULL_FACTOR: f64 = 1e3;
/// The self-motion stops when its step (the projection of `q_ref − q` on the null space) is
/// shorter than this, radians: the configuration is then nearest the reference to first order.
const NULL_TOL_RAD: f64 = 1e-9;

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
    /// Joint angles, radians, within the limits (one per joint of the model).
    pub q: Joints,
    /// Distance between the tool point and the target, mm.
    pub position_residual: f64,
    /// Angle between the flange orientation and the target's, radians (`None` for a
    /// position-only task).
    pub orientation_residual: Option<f64>,
}

/// An inverse-kinematics solver for one model: its limits, its reference configuration and its
/// fixed set of seeds.
#[derive(Clone, Debug)]
pub struct Ik<'a> {
    model: &'a RobotModel,
    lo: Joints,
    hi: Joints,
    reference: Joints,
    /// The built-in seeds ([`BUILT_IN_SEEDS`]), tried wherever no neighbour's branch reaches.
    seeds: Vec<Joints>,
    /// The caller's extra seeds, tried only where the built-in ones reach nothing.
    extra: Vec<Joints>,
    /// Where the tool point can be at most: the point on joint 1's axis at height d1 and the
    /// radius around it (see [`Ik::within_reach`]).
    reach: ([f64; 3], f64),
    /// The radius the origin of frame `n − 1` (on the last joint's axis; frame 5 of a six-joint
    /// arm) stays within around the same point.
    reach5: f64,
    /// Length (mm) that turns orientation errors (rad) into mm: half the reach bound.
    scale: f64,
}

/// A bound on the distance from the base origin the tool point can reach, mm: every link
/// length and offset and the tool added up.
pub fn reach_bound(model: &RobotModel) -> f64 {
    (0..model.joints())
        .map(|i| model.params[5 * i + 1].abs() + model.params[5 * i + 2].abs())
        .sum::<f64>()
        + norm(&model.tool)
}

impl<'a> Ik<'a> {
    /// A solver for `model` choosing solutions nearest `reference` (radians, within the limits,
    /// one per joint of the model), with [`BUILT_IN_SEEDS`] seeds spread over the joint ranges
    /// besides the reference (a fixed low-discrepancy set, so a map is reproducible), and
    /// `extra_seeds` more of the same sequence tried only where those reach nothing, so that the
    /// branch a cell gets does not depend on the extra count.
    pub fn new(model: &'a RobotModel, reference: Joints, extra_seeds: usize) -> Self {
        let n = model.joints();
        debug_assert_eq!(reference.len(), n);
        let lo = model.limits_deg.map(|l| l.0.to_radians());
        let hi = model.limits_deg.map(|l| l.1.to_radians());
        // Additive recurrence with the generalised golden ratio of dimension n, the root of
        // x^(n+1) = x + 1 (a Kronecker sequence; M. Roberts, "The unreasonable effectiveness of
        // quasirandom sequences", 2018).
        let g = {
            let mut x: f64 = 2.0;
            for _ in 0..64 {
                x = (1.0 + x).powf(1.0 / (n + 1) as f64);
            }
            x
        };
        let alpha = Joints::from_fn(n, |i| 1.0 / g.powi(i as i32 + 1));
        let mut seeds: Vec<Joints> = (1..=BUILT_IN_SEEDS + extra_seeds)
            .map(|k| {
                Joints::from_fn(n, |i| {
                    let u = (0.5 + alpha[i] * k as f64).fract();
                    // Stay off the limits themselves: the middle 90 % of each range.
                    lo[i] + (hi[i] - lo[i]) * (0.05 + 0.9 * u)
                })
            })
            .collect();
        let extra = seeds.split_off(BUILT_IN_SEEDS);
        // Frame 1's origin is within |a1| of (0, 0, d1) on joint 1's axis, each later link
        // moves the next origin by √(a² + d²), and the tool point is |tool| from the flange.
        let p = &model.params;
        let link = |j: usize| p[5 * j + 1].hypot(p[5 * j + 2]);
        let reach5 = p[2].abs() + (1..n - 1).map(link).sum::<f64>();
        let radius = reach5 + link(n - 1) + norm(&model.tool);
        Ik {
            model,
            lo,
            hi,
            reference,
            seeds,
            extra,
            reach: ([0.0, 0.0, p[1]], radius),
            reach5,
            scale: 0.5 * reach_bound(model).max(1.0),
        }
    }

    /// Whether `target` lies within the ball every configuration's tool point stays in: frame
    /// 1's origin is within |a1| of the point (0, 0, d1) on joint 1's axis, and the tool point
    /// within the sum of the later links' lengths and the tool's of it. A target outside is
    /// unreachable whatever the seeds: a proof, not a failed search.
    ///
    /// With the flange orientation `R6` fixed, the origin of the frame before the last joint is
    /// fixed too. Written for six joints (frame 5; for `n` joints frame `n − 1` and the last
    /// joint's parameters): the last joint `T_6 = Rz(φ)·Tz(d6)·Tx(a6)·Rx(α6)·Ry(β6)` gives
    /// `R6 = R5·Rz(φ)·Rx(α6)·Ry(β6)` and `o6 = o5 + R5·Rz(φ)·(a6, 0, d6)`, so with
    /// `M = R6·(Rx(α6)·Ry(β6))ᵀ`, `o5 = p − R6·tool − M·(a6, 0, d6)`, which must lie within the
    /// links 1…5's ball.
    pub fn within_reach(&self, target: &IkTarget) -> bool {
        let (c, r) = self.reach;
        let dist = |v: [f64; 3]| norm(&[v[0] - c[0], v[1] - c[1], v[2] - c[2]]);
        let slack = |r: f64| r * (1.0 + 1e-9) + POSITION_TOL_MM;
        if dist(target.position) > slack(r) {
            return false;
        }
        let Some(r6) = &target.rotation else {
            return true;
        };
        dist(self.wrist_origin(target.position, r6)) <= slack(self.reach5)
    }

    /// The origin of frame `n − 1` (frame 5 of a six-joint arm) of every configuration whose
    /// tool point is at `position` with the flange rotation `r6` (see [`Ik::within_reach`]).
    fn wrist_origin(&self, position: [f64; 3], r6: &Rot3) -> [f64; 3] {
        let p = &self.model.params;
        let j = 5 * (self.model.joints() - 1);
        let (d6, a6, alpha, beta) = (p[j + 1], p[j + 2], p[j + 3], p[j + 4]);
        let (sa, ca) = alpha.sin_cos();
        let (sb, cb) = beta.sin_cos();
        // Rx(α)·Ry(β)
        let xy: Rot3 = [
            [cb, 0.0, sb],
            [sa * sb, ca, -sa * cb],
            [-ca * sb, sa, ca * cb],
        ];
        let tool = self.model.tool;
        std::array::from_fn(|i| {
            let r_tool: f64 = (0..3).map(|k| r6[i][k] * tool[k]).sum();
            // (M·(a6, 0, d6))_i with M = R6·xyᵀ: Σ_k R6[i][k]·(xyᵀ·v)_k, (xyᵀ·v)_k = Σ_l xy[l][k]·v_l.
            let v = [a6, 0.0, d6];
            let m_v: f64 = (0..3)
                .map(|k| r6[i][k] * (0..3).map(|l| xy[l][k] * v[l]).sum::<f64>())
                .sum();
            position[i] - r_tool - m_v
        })
    }

    fn clamp(&self, q: &mut [f64]) {
        for i in 0..q.len() {
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
    fn jacobian(&self, target: &IkTarget, f: &Frames) -> Vec<Joints> {
        let n = self.model.joints();
        let mut rows = vec![Joints::filled(n, 0.0); task_dim(target)];
        for i in 0..n {
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
    pub fn residuals(&self, target: &IkTarget, q: &[f64]) -> (f64, Option<f64>) {
        let f = frames(self.model, q);
        let p = norm(&[
            f.tool[0] - target.position[0],
            f.tool[1] - target.position[1],
            f.tool[2] - target.position[2],
        ]);
        (p, target.rotation.map(|d| rotation_angle(&f.rot, &d)))
    }

    fn accepted(&self, target: &IkTarget, q: &Joints) -> Option<IkSolution> {
        let (p, o) = self.residuals(target, q);
        let in_limits = (0..q.len()).all(|i| q[i] >= self.lo[i] && q[i] <= self.hi[i]);
        (in_limits && p <= POSITION_TOL_MM && o.is_none_or(|o| o <= ORIENTATION_TOL_RAD)).then_some(
            IkSolution {
                q: *q,
                position_residual: p,
                orientation_residual: o,
            },
        )
    }

    /// Damped least squares from one seed; the configuration it ends at.
    fn descend(&self, target: &IkTarget, seed: &Joints) -> Joints {
        self.descend_holding(target, seed, &[])
    }

    /// [`Ik::descend`] with the joints `held[k]` kept at their seed's angle (their columns of
    /// the Jacobian left out, so the step does not move them); none held for an empty `held`.
    fn descend_holding(&self, target: &IkTarget, seed: &Joints, held: &[bool]) -> Joints {
        let mut q = *seed;
        self.clamp(&mut q);
        let mut f = frames(self.model, &q);
        let mut e = self.error(target, &f);
        let mut cost = norm(&e);
        let s2 = self.scale * self.scale;
        let mut lambda = 1e-2 * s2;
        let mut checkpoint = cost;
        for it in 0..MAX_ITERATIONS {
            // A seed still far from the target that gained less than 1 % in STALL_WINDOW iterations is
            // caught in a local minimum or against a limit: give up on it.
            if it % STALL_WINDOW == STALL_WINDOW - 1 {
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
            let mut j = self.jacobian(target, &f);
            hold_columns(&mut j, held);
            let Some(dq) = damped_step(&j, &e, lambda) else {
                lambda *= 10.0;
                continue;
            };
            let mut next = q;
            for k in 0..next.len() {
                next[k] += dq[k];
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
    fn unwrap_turns(&self, q: &mut [f64]) {
        let tau = std::f64::consts::TAU;
        for i in 0..q.len() {
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
    fn turned_towards(&self, seed: &Joints, target: &IkTarget) -> Vec<Joints> {
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

    fn distance(&self, q: &[f64]) -> f64 {
        norm(&Joints::from_fn(q.len(), |i| q[i] - self.reference[i]))
    }

    /// Solves for `target`: first from the `neighbours`' configurations (already solved
    /// cells), which continues their branch; when none of them reaches the target (the first
    /// cell of a region, or no neighbours), from the reference and the fixed seeds. Of the
    /// configurations that reach the target within the limits, the one nearest the reference.
    /// `None` when no seed reaches it.
    pub fn solve(&self, target: &IkTarget, neighbours: &[Joints]) -> Option<IkSolution> {
        if !self.within_reach(target) {
            return None;
        }
        let aimed = |seeds: &mut dyn Iterator<Item = &Joints>| -> Vec<Joints> {
            seeds.flat_map(|s| self.turned_towards(s, target)).collect()
        };
        self.nearest(target, neighbours.to_vec())
            .or_else(|| {
                let built_in = aimed(&mut std::iter::once(&self.reference).chain(&self.seeds));
                self.nearest(target, built_in)
            })
            .or_else(|| self.nearest(target, aimed(&mut self.extra.iter())))
    }

    /// Of the configurations the `seeds` descend to that reach `target` (for a redundant arm
    /// slid along the self-motion towards the reference, [`Ik::toward_reference`]), the one
    /// nearest the reference.
    fn nearest(&self, target: &IkTarget, seeds: Vec<Joints>) -> Option<IkSolution> {
        use rayon::prelude::*;
        // Seeds descend independently (in parallel); the choice among the results is made in
        // seed order, so it does not depend on the thread count.
        let found: Vec<Option<IkSolution>> = seeds
            .par_iter()
            .map(|seed| {
                let mut q = self.descend(target, seed);
                self.unwrap_turns(&mut q);
                let found = self.accepted(target, &q);
                if found.is_none() || !self.resolves_redundancy(target) {
                    return found;
                }
                let mut q = self.toward_reference(target, &q);
                self.unwrap_turns(&mut q);
                self.accepted(target, &q).or(found)
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

/// Rows of the task of `target`: 3 for a position, 6 with the orientation.
fn task_dim(target: &IkTarget) -> usize {
    if target.rotation.is_some() {
        6
    } else {
        3
    }
}

/// Zeroes the columns of the task Jacobian rows `j` of the joints `held[k]` (none for an empty
/// `held`), which a step then leaves where they are.
fn hold_columns(j: &mut [Joints], held: &[bool]) {
    for (k, _) in held.iter().enumerate().filter(|(_, &h)| h) {
        for row in j.iter_mut() {
            row[k] = 0.0;
        }
    }
}

/// `J Jᵀ + λ I` of the task Jacobian rows `j`.
fn gram(j: &[Joints], lambda: f64) -> Vec<Vec<f64>> {
    let m = j.len();
    (0..m)
        .map(|r| {
            (0..m)
                .map(|c| {
                    (0..j[r].len()).map(|k| j[r][k] * j[c][k]).sum::<f64>()
                        + if r == c { lambda } else { 0.0 }
                })
                .collect()
        })
        .collect()
}

/// The damped least-squares step `Δq` for the task error `e` with the task Jacobian rows `j`:
/// `Jᵀ (J Jᵀ + λ I)⁻¹ e`, or, with more rows than joints, the same step from the smaller system
/// `(JᵀJ + λ I) Δq = Jᵀ e`. `None` when the system is singular.
fn damped_step(j: &[Joints], e: &[f64], lambda: f64) -> Option<Joints> {
    let m = j.len();
    let n = j[0].len();
    if m <= n {
        let y = solve(gram(j, lambda), e.to_vec())?;
        Some(Joints::from_fn(n, |k| {
            (0..m).map(|r| j[r][k] * y[r]).sum::<f64>()
        }))
    } else {
        let a = (0..n)
            .map(|r| {
                (0..n)
                    .map(|c| {
                        (0..m).map(|k| j[k][r] * j[k][c]).sum::<f64>()
                            + if r == c { lambda } else { 0.0 }
                    })
                    .collect()
            })
            .collect();
        let g = (0..n)
            .map(|r| (0..m).map(|k| j[k][r] * e[k]).sum())
            .collect();
        solve(a, g).map(|dq| Joints::from_slice(&dq))
    }
}
