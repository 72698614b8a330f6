//! The self-motion of a redundant arm (see the module docs of [`super`]): a configuration that
//! reaches its target slid along the configurations that reach it, to the one nearest the
//! reference within the limits.

use super::geometry::{frames, norm, solve};
use super::{gram, hold_columns, task_dim, Ik, IkTarget};
use super::{MAX_NULL_FACTOR, MAX_NULL_STEPS, NULL_STEP_RAD, NULL_TOL_RAD};
use crate::kinematics::Joints;

impl Ik<'_> {
    /// Whether a configuration that reaches `target` is slid along its self-motion to the one
    /// nearest the reference (see the module docs of [`super`]): the task leaves some joint
    /// freedom and the arm has other than six joints.
    pub(super) fn resolves_redundancy(&self, target: &IkTarget) -> bool {
        let n = self.model.joints();
        n != 6 && n > task_dim(target)
    }

    /// The direction along the self-motion that brings `q` nearest the reference to first
    /// order: the projection of `d = q_ref − q` on the null space of the task Jacobian at `q`,
    /// `d − Jᵀ (J Jᵀ)⁻¹ J d` (lightly damped, so a singular configuration still projects), with
    /// the joints that lie on a limit and would be moved beyond it held (their columns of `J`
    /// and entries of `d` left out, and `held` set for them, until no further joint needs
    /// holding). `None` when the system is singular even so.
    pub(super) fn null_direction(
        &self,
        target: &IkTarget,
        q: &Joints,
        held: &mut [bool],
    ) -> Option<Joints> {
        let n = q.len();
        let f = frames(self.model, q);
        let mut j = self.jacobian(target, &f);
        let m = j.len();
        loop {
            hold_columns(&mut j, held);
            let d = Joints::from_fn(n, |k| {
                if held[k] {
                    0.0
                } else {
                    self.reference[k] - q[k]
                }
            });
            let jd: Vec<f64> = (0..m)
                .map(|r| (0..n).map(|k| j[r][k] * d[k]).sum())
                .collect();
            let y = solve(gram(&j, 1e-12 * self.scale * self.scale), jd)?;
            let p = Joints::from_fn(n, |k| d[k] - (0..m).map(|r| j[r][k] * y[r]).sum::<f64>());
            let mut more = false;
            for k in 0..n {
                if !held[k]
                    && ((q[k] <= self.lo[k] && p[k] < 0.0) || (q[k] >= self.hi[k] && p[k] > 0.0))
                {
                    held[k] = true;
                    more = true;
                }
            }
            if !more {
                return Some(p);
            }
        }
    }

    /// From `start`, a configuration that reaches `target` within the limits, steps along the
    /// self-motion towards the reference while they bring the configuration nearer it (see
    /// the module docs of [`super`]); the configuration where they stop, which reaches `target`
    /// too.
    ///
    /// A step is `t·p` with `p` the [`Ik::null_direction`] and `t` the Barzilai–Borwein factor
    /// `sᵀs / sᵀy` of the last accepted step `s` and the change `y` of `−p` over it (1 where
    /// the self-motion is straight; larger where it curves so that `p` shrinks slowly), at
    /// most [`NULL_STEP_RAD`] long. Joints the step takes beyond a limit stop on it and are
    /// held there while the configuration returns to the target, so that the next direction
    /// sees them on the limit. A step that does not end nearer the reference on the target is
    /// shortened fourfold.
    pub(super) fn toward_reference(&self, target: &IkTarget, start: &Joints) -> Joints {
        let n = start.len();
        let mut q = *start;
        let mut dist = self.distance(&q);
        let mut factor = 1.0;
        let mut cap = NULL_STEP_RAD;
        // The last accepted step and the direction before it, for the Barzilai–Borwein factor.
        let mut last: Option<(Joints, Joints)> = None;
        let mut direction: Option<(Joints, Vec<bool>)> = None;
        for _ in 0..MAX_NULL_STEPS {
            let (p, held) = match direction.take() {
                Some(pd) => pd,
                None => {
                    let mut held = vec![false; n];
                    let Some(p) = self.null_direction(target, &q, &mut held) else {
                        break;
                    };
                    if let Some((s, before)) = last.take() {
                        let (ss, sy) = (0..n).fold((0.0, 0.0), |(ss, sy), k| {
                            (ss + s[k] * s[k], sy + s[k] * (before[k] - p[k]))
                        });
                        factor = if sy > 0.0 {
                            (ss / sy).clamp(1.0, MAX_NULL_FACTOR)
                        } else {
                            1.0
                        };
                    }
                    (p, held)
                }
            };
            let len = norm(&p);
            if len <= NULL_TOL_RAD {
                break;
            }
            let tried = (factor * len).min(cap);
            let t = tried / len;
            let mut next = Joints::from_fn(n, |k| q[k] + t * p[k]);
            self.clamp(&mut next);
            let stopped: Vec<bool> = (0..n)
                .map(|k| held[k] || next[k] == self.lo[k] || next[k] == self.hi[k])
                .collect();
            let next = self.descend_holding(target, &next, &stopped);
            let nd = self.distance(&next);
            if nd < dist && self.accepted(target, &next).is_some() {
                last = Some((Joints::from_fn(n, |k| next[k] - q[k]), p));
                (q, dist) = (next, nd);
                cap = (2.0 * cap).min(NULL_STEP_RAD);
            } else {
                direction = Some((p, held));
                cap = 0.25 * tried;
                if cap < NULL_TOL_RAD {
                    break;
                }
            }
        }
        q
    }
}
