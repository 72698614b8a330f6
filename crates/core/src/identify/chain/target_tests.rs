//! Unit test of the target-placement warning of the whole-chain identification.

use super::*;
use crate::kinematics::tx60;

/// A target on the J6 axis leaves its phase invisible: flagged, with the advice to move it.
#[test]
fn target_on_the_j6_axis_is_flagged() {
    let m = tx60();
    let s = ChainState {
        params: m.params,
        tool: [0.0, 0.0, 80.0],
        base: [2000.0, 0.0, 0.0, 0.0, 0.0, 1.0],
        others: OtherTargets::NONE,
    };
    let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(4);
    use rand::Rng;
    let configs: Vec<Joints> = (0..60)
        .map(|_| {
            Joints::from_fn(m.joints(), |j| {
                rng.random_range(m.limits_deg[j].0..m.limits_deg[j].1)
            })
        })
        .collect();
    let pts: Vec<MeasuredPoint> = configs
        .into_iter()
        .enumerate()
        .map(|(k, q)| MeasuredPoint {
            q_deg: q,
            position_mm: s.predict(&q.map(f64::to_radians)),
            sigma_mm: None,
            payload_kg: 0.0,
            line: k as u64,
            target: 0,
            sides: None,
        })
        .collect();
    let r = identify_chain(&pts, &m, None, None, &ChainOptions::default()).unwrap();
    let w = r.report.warnings.join("\n");
    assert!(w.contains("away from the J6 axis"), "{w}");
}
