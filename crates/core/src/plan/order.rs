//! The order a plan's poses are visited in: the shortest joint travel found between them.

use crate::kinematics::Joints;

/// The visiting order: nearest neighbour in joint space (largest joint move), then 2-opt.
pub(super) fn visiting_order(q: &[Joints]) -> (Vec<usize>, f64) {
    let n = q.len();
    let d = |a: usize, b: usize| {
        (0..q[a].len())
            .map(|j| (q[a][j] - q[b][j]).abs())
            .fold(0.0, f64::max)
    };
    if n < 2 {
        return ((0..n).collect(), 0.0);
    }
    let origin = |a: usize| q[a].iter().map(|v| v.abs()).fold(0.0, f64::max);
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
    let travel = order.windows(2).map(|w| d(w[0], w[1])).sum();
    (order, travel)
}
