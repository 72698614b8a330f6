//! The order a plan's poses are visited in: the shortest joint travel found between them, each
//! joint that turns more than a full turn taking the turn nearest the previous pose.

use super::candidates::within_margin;
use crate::kinematics::Joints;

/// Joint travel along `q` in its order: Σ max_j |Δq_j| between consecutive poses, degrees.
pub(super) fn travel(q: &[Joints]) -> f64 {
    q.windows(2)
        .map(|w| {
            (0..w[0].len())
                .map(|j| (w[0][j] - w[1][j]).abs())
                .fold(0.0, f64::max)
        })
        .sum()
}

/// The poses `q` (degrees) in visiting order and their joint travel ([`travel`]): the order
/// from [`order`] on the move each joint needs (the shorter way round for a joint that may
/// turn a full turn within `limits` less `margin_deg`), then each such joint on the turn
/// nearest its previous angle that stays within the limits.
pub(super) fn visiting_order(
    q: &[Joints],
    limits: &[(f64, f64)],
    margin_deg: f64,
) -> (Vec<Joints>, f64) {
    let ranges: Vec<(f64, f64)> = limits
        .iter()
        .map(|&(lo, hi)| within_margin(lo, hi, margin_deg))
        .collect();
    let wraps: Vec<bool> = ranges.iter().map(|(lo, hi)| hi - lo >= 360.0).collect();
    let step = |j: usize, a: f64, b: f64| {
        let d = (a - b).abs();
        if wraps.get(j).copied().unwrap_or(false) {
            let d = d % 360.0;
            d.min(360.0 - d)
        } else {
            d
        }
    };
    let d = |a: usize, b: usize| {
        (0..q[a].len())
            .map(|j| step(j, q[a][j], q[b][j]))
            .fold(0.0, f64::max)
    };
    let mut out: Vec<Joints> = order(q.len(), &|a, b| d(a, b), &|a| {
        q[a].iter().map(|v| v.abs()).fold(0.0, f64::max)
    })
    .iter()
    .map(|&i| q[i])
    .collect();
    for k in 1..out.len() {
        let prev = out[k - 1];
        for (j, v) in out[k].iter_mut().enumerate() {
            let Some(&(lo, hi)) = ranges.get(j).filter(|_| wraps[j]) else {
                continue;
            };
            let best = [*v - 360.0, *v, *v + 360.0]
                .into_iter()
                .filter(|c| (lo..=hi).contains(c) || *c == *v)
                .min_by(|a, b| (a - prev[j]).abs().total_cmp(&(b - prev[j]).abs()));
            if let Some(b) = best {
                *v = b;
            }
        }
    }
    let t = travel(&out);
    (out, t)
}

/// An open path through `n` points of distance `d`: nearest neighbour from the point nearest
/// the origin (`origin`), then 2-opt.
fn order(n: usize, d: &dyn Fn(usize, usize) -> f64, origin: &dyn Fn(usize) -> f64) -> Vec<usize> {
    if n < 2 {
        return (0..n).collect();
    }
    let first = (0..n)
        .min_by(|&a, &b| origin(a).total_cmp(&origin(b)))
        .unwrap_or(0);
    let mut order = vec![first];
    let mut left: Vec<usize> = (0..n).filter(|&i| i != first).collect();
    while !left.is_empty() {
        let last = *order.last().unwrap_or(&first);
        let (k, _) = left
            .iter()
            .enumerate()
            .min_by(|a, b| d(last, *a.1).total_cmp(&d(last, *b.1)))
            .unwrap_or((0, &0));
        order.push(left.swap_remove(k));
    }
    // 2-opt on the open path.
    let mut improved = true;
    let mut rounds = 0;
    while improved && rounds < 50 {
        improved = false;
        rounds += 1;
        for i in 0..n - 2 {
            for k in i + 2..n {
                let before = d(order[i], order[i + 1])
                    + if k + 1 < n {
                        d(order[k], order[k + 1])
                    } else {
                        0.0
                    };
                let after = d(order[i], order[k])
                    + if k + 1 < n {
                        d(order[i + 1], order[k + 1])
                    } else {
                        0.0
                    };
                if after + 1e-9 < before {
                    order[i + 1..=k].reverse();
                    improved = true;
                }
            }
        }
    }
    order
}
