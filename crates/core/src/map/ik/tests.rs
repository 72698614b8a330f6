//! Unit tests of the inverse kinematics: round trips from known configurations for arms of four
//! to seven joints, the wrist bound, and the redundancy resolution of a seven-joint arm.

use super::*;
use crate::kinematics::{Capped, FixedParam, Params, Uncertainty};
use crate::presets::{preset, PRESETS};

/// A model of the MDH rows `[θ, d, a, α, β]` (degrees, mm) with the given limits (degrees).
fn chain(name: &str, rows: &[[f64; 5]], limits: &[(f64, f64)]) -> RobotModel {
    let n = rows.len();
    let params = Params::from_fn(5 * n, |i| {
        let v = rows[i / 5][i % 5];
        if matches!(i % 5, 1 | 2) {
            v
        } else {
            v.to_radians()
        }
    });
    RobotModel {
        joint_errors: None,
        links: None,
        discrepancy: None,
        name: name.into(),
        params,
        fixed: Capped::filled(n, FixedParam::Beta),
        limits_deg: Capped::from_slice(limits),
        tool: [0.0; 3],
        tool_sigma: [0.0; 3],
        uncertainty: Uncertainty::Independent(Params::filled(5 * n, 0.0)),
        base: None,
    }
}

/// A seven-joint arm of the KUKA LBR iiwa 14 R820's geometry (shoulder 360 mm, upper arm
/// 420 mm, forearm 400 mm, flange 126 mm; alternate roll and pitch axes) and limits.
pub(crate) fn seven_joint() -> RobotModel {
    crate::presets::iiwa14()
}

/// A five-joint arm (the TX60's arm with a pitch wrist) and a four-joint one.
fn short_arms() -> [RobotModel; 2] {
    [
        chain(
            "five-joint arm",
            &[
                [0.0, 375.0, 0.0, -90.0, 0.0],
                [-90.0, 0.0, 290.0, 0.0, 0.0],
                [90.0, 20.0, 0.0, 90.0, 0.0],
                [0.0, 310.0, 0.0, -90.0, 0.0],
                [0.0, 70.0, 0.0, 0.0, 0.0],
            ],
            &[
                (-180.0, 180.0),
                (-127.5, 127.5),
                (-142.5, 142.5),
                (-270.0, 270.0),
                (-120.0, 120.0),
            ],
        ),
        chain(
            "four-joint arm",
            &[
                [0.0, 375.0, 0.0, -90.0, 0.0],
                [-90.0, 0.0, 290.0, 0.0, 0.0],
                [90.0, 0.0, 310.0, 0.0, 0.0],
                [0.0, 0.0, 70.0, 90.0, 0.0],
            ],
            &[
                (-180.0, 180.0),
                (-127.5, 127.5),
                (-142.5, 142.5),
                (-180.0, 180.0),
            ],
        ),
    ]
}

/// The presets (six joints) and the arms of four, five and seven joints.
fn models() -> Vec<RobotModel> {
    let mut m: Vec<RobotModel> = PRESETS.iter().map(|p| preset(p).unwrap()).collect();
    m.push(seven_joint());
    m.extend(short_arms());
    m
}

/// The middle of each joint's range, radians.
fn mid(m: &RobotModel) -> Joints {
    m.limits_deg.map(|l| (0.5 * (l.0 + l.1)).to_radians())
}

/// Length of the direction along the self-motion towards the reference at `q`
/// ([`Ik::null_direction`], joints on a limit held): 0 where `q` is nearest the reference
/// among the nearby configurations within the limits that reach the same target.
fn null_gradient(ik: &Ik, target: &IkTarget, q: &Joints) -> f64 {
    norm(
        &ik.null_direction(target, q, &mut vec![false; q.len()])
            .unwrap(),
    )
}

#[test]
fn the_wrist_origin_of_a_pose_is_that_of_its_configurations() {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    for mut m in models() {
        let n = m.joints();
        let name = m.name.clone();
        // β on the last joint and a tool off every axis, so every term of the formula counts.
        m.params[5 * (n - 1) + 4] = 0.01;
        m.tool = [12.0, -7.0, 95.0];
        let ik = Ik::new(&m, m.joints_at(0.0), 0);
        for _ in 0..50 {
            let q = Joints::from_fn(n, |i| {
                let (lo, hi) = m.limits_deg[i];
                rng.random_range(lo..hi).to_radians()
            });
            let f = frames(&m, &q);
            let o5 = ik.wrist_origin(f.tool, &f.rot);
            let d = norm(&[
                o5[0] - f.origin[n - 1][0],
                o5[1] - f.origin[n - 1][1],
                o5[2] - f.origin[n - 1][2],
            ]);
            assert!(d < 1e-9, "{name}: {d} mm");
            let target = IkTarget {
                position: f.tool,
                rotation: Some(f.rot),
            };
            assert!(ik.within_reach(&target), "{name}");
            assert!(
                ik.within_reach(&IkTarget {
                    rotation: None,
                    ..target
                }),
                "{name}"
            );
        }
    }
}

/// Two configurations of `m` (radians): for a six-joint arm the fixed ones this test has
/// always used; for another joint count the same shares of each joint's range (a seven-axis
/// preset's joint may exclude 0, as the Panda's fourth).
fn known_configurations(m: &RobotModel) -> Vec<Joints> {
    if m.joints() == 6 {
        return vec![
            Joints::from([0.2, -0.4, 0.8, 0.3, 0.9, -0.5]),
            Joints::from([-1.0, 0.3, -0.6, 1.2, -0.8, 2.0]),
        ];
    }
    [
        [0.1, -0.2, 0.3, 0.15, 0.25, -0.2, 0.3],
        [-0.3, 0.15, -0.25, 0.3, -0.2, 0.3, -0.15],
    ]
    .iter()
    .map(|f| {
        Joints::from_fn(m.joints(), |i| {
            let (lo, hi) = m.limits_deg[i];
            (0.5 * (lo + hi) + f[i] * (hi - lo)).to_radians()
        })
    })
    .collect()
}

#[test]
fn round_trip_from_known_configurations() {
    for name in PRESETS {
        let m = preset(name).unwrap();
        let ik = Ik::new(&m, mid(&m), 8);
        for q in known_configurations(&m) {
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

/// Arms of four, five and seven joints reach poses of their own configurations, with and
/// without the orientation (more constraints than joints for four and five).
#[test]
fn round_trip_for_other_joint_counts() {
    let mut models = vec![seven_joint()];
    models.extend(short_arms());
    for m in &models {
        let n = m.joints();
        let ik = Ik::new(m, mid(m), 8);
        for q in [
            [0.2, -0.4, 0.8, 0.3, 0.9, -0.5, 0.6],
            [-1.0, 0.3, -0.6, 1.2, -0.8, 1.1, -0.3],
        ] {
            let q = Joints::from_slice(&q[..n]);
            let f = frames(m, &q);
            for rotation in [Some(f.rot), None] {
                let t = IkTarget {
                    position: f.tool,
                    rotation,
                };
                let s = ik
                    .solve(&t, &[])
                    .unwrap_or_else(|| panic!("{} {q:?} {}", m.name, rotation.is_some()));
                assert_eq!(s.q.len(), n);
                let (p, o) = ik.residuals(&t, &s.q);
                assert!(p <= POSITION_TOL_MM, "{}: {p}", m.name);
                assert!(
                    o.is_none_or(|o| o <= ORIENTATION_TOL_RAD),
                    "{}: {o:?}",
                    m.name
                );
            }
        }
    }
}

/// A redundant arm's solution is the configuration nearest the reference among those that
/// reach the target nearby (the projection of `q_ref − q` on the Jacobian's null space
/// vanishes), and no farther from it than the configuration the target was made from.
#[test]
fn a_redundant_arm_resolves_towards_the_reference() {
    let mut models = vec![seven_joint()];
    models.extend(short_arms());
    for m in &models {
        let n = m.joints();
        let reference = Joints::from_fn(n, |i| [0.1, 0.5, -0.2, -1.2, 0.3, 0.8, 0.0][i]);
        let ik = Ik::new(m, reference, 0);
        for offset in [
            [0.3, -0.2, 0.4, 0.2, -0.3, 0.1, 0.2],
            [-0.2, 0.1, -0.5, 0.3, 0.2, -0.2, 0.4],
        ] {
            let q0 = Joints::from_fn(n, |i| reference[i] + offset[i]);
            let f = frames(m, &q0);
            for rotation in [Some(f.rot), None] {
                let t = IkTarget {
                    position: f.tool,
                    rotation,
                };
                if n <= task_dim(&t) {
                    continue;
                }
                let s = ik.solve(&t, &[]).unwrap();
                let g = null_gradient(&ik, &t, &s.q);
                assert!(g < 1e-6, "{} {}: {g}", m.name, rotation.is_some());
                let (d, d0) = (ik.distance(&s.q), ik.distance(&q0));
                assert!(
                    d <= d0 + 1e-9,
                    "{} {}: {d} vs {d0}",
                    m.name,
                    rotation.is_some()
                );
                // From a neighbour's configuration (the map's seeds) it slides there too.
                let s2 = ik.solve(&t, &[q0]).unwrap();
                let g2 = null_gradient(&ik, &t, &s2.q);
                assert!(
                    g2 < 1e-6,
                    "{} {}: {g2} at {:?} (from {:?}, first {:?} at {d})",
                    m.name,
                    rotation.is_some(),
                    s2.q,
                    q0,
                    s.q
                );
            }
        }
    }
}

/// Where the configuration nearest the reference lies beyond a joint limit, the slide stops
/// with that joint on its limit, nearest the reference among the configurations within
/// the limits (the direction with the joint held vanishes).
#[test]
fn a_redundant_arm_stops_on_a_joint_limit() {
    let free = seven_joint();
    let reference = Joints::from_fn(7, |i| [0.1, 0.5, -0.2, -1.2, 0.3, 0.8, 0.0][i]);
    let q0 = Joints::from_fn(7, |i| {
        reference[i] + [0.3, -0.2, 0.4, 0.2, -0.3, 0.1, 0.2][i]
    });
    let f = frames(&free, &q0);
    for rotation in [Some(f.rot), None] {
        let t = IkTarget {
            position: f.tool,
            rotation,
        };
        let nearest = Ik::new(&free, reference, 0).solve(&t, &[q0]).unwrap().q;
        // The joint that moved most from q0, its limit put halfway so `nearest` is beyond it.
        let k = (0..7)
            .max_by(|&a, &b| {
                (nearest[a] - q0[a])
                    .abs()
                    .total_cmp(&(nearest[b] - q0[b]).abs())
            })
            .unwrap();
        let half = 0.5 * (nearest[k] + q0[k]).to_degrees();
        let mut m = free.clone();
        let (lo, hi) = m.limits_deg[k];
        m.limits_deg[k] = if nearest[k] < q0[k] {
            (half, hi)
        } else {
            (lo, half)
        };
        let ik = Ik::new(&m, reference, 0);
        let s = ik.solve(&t, &[q0]).unwrap();
        let limit = half.to_radians();
        assert!(
            (s.q[k] - limit).abs() < 1e-9,
            "joint {k}: {} vs {limit}",
            s.q[k]
        );
        let g = null_gradient(&ik, &t, &s.q);
        assert!(g < 1e-6, "{}: {g}", rotation.is_some());
        assert!(ik.distance(&s.q) <= ik.distance(&q0) + 1e-9);
        assert!(ik.distance(&s.q) > ik.distance(&nearest));
    }
}

/// A six-joint arm's position-only task keeps the earlier solver: the configuration its
/// seeds descend to, not slid along the self-motion.
#[test]
fn six_joints_keep_the_earlier_solver() {
    let m = preset("tx60").unwrap();
    let ik = Ik::new(&m, mid(&m), 0);
    let t = IkTarget {
        position: [400.0, 100.0, 500.0],
        rotation: None,
    };
    assert!(!ik.resolves_redundancy(&t));
    assert!(!ik.resolves_redundancy(&IkTarget {
        rotation: Some(rpy_rotation([180.0, 0.0, 0.0])),
        ..t
    }));
    let seven = seven_joint();
    let ik7 = Ik::new(&seven, mid(&seven), 0);
    assert!(ik7.resolves_redundancy(&t));
}
