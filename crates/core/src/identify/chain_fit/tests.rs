//! Unit tests of [`super`].
use super::*;
use crate::kinematics::tx60;
use rand::{Rng, SeedableRng};

fn observations(truth: &ChainState, n: usize, seed: u64) -> Vec<Observation> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let q = Joints::from_fn(6, |_| rng.random_range(-2.0..2.0));
            Observation {
                q,
                p: truth.predict(&q),
                whiten: Matrix3::identity(),
                payload_kg: 0.0,
                target: 0,
                sides: None,
            }
        })
        .collect()
}

#[test]
fn input_joints() {
    for n in 4..=7 {
        let space = Layout::new(n).measured();
        let tool = space.index(Block::Tool, 0).unwrap();
        assert_eq!(input_joint(space, tool), Some(n));
        assert_eq!(input_joint(space, 5 * n - 1), Some(n));
        assert_eq!(input_joint(space, tool + 3), None);
    }
}

#[test]
fn free_counts_follow_everett() {
    let m = tx60();
    assert_eq!(default_free(&m.fixed, true).len(), 27);
    assert_eq!(default_free(&m.fixed, false).len(), 23);
}

/// Noise-free data in a placement 2.5 m away, turned 140° and tilted: the alignment start and
/// the fit recover every identifiable input.
#[test]
fn recovers_a_far_placement() {
    let nominal = tx60();
    let mut truth = ChainState {
        params: nominal.params,
        tool: [30.0, -20.0, 80.0],
        base: [2500.0, -400.0, 300.0, 0.05, -0.08, 140f64.to_radians()],
        others: OtherTargets::NONE,
    };
    let free = default_free(&nominal.fixed, true);
    for (k, &i) in free.iter().enumerate() {
        if i < Layout::SIX.n_params() {
            let size = if Layout::SIX.measured().is_angle(i) {
                5e-4
            } else {
                0.3
            };
            truth.set(i, truth.get(i) + size * if k % 2 == 0 { 1.0 } else { -0.7 });
        }
    }
    let obs = observations(&truth, 40, 3);
    let start = initial_state(&obs, &nominal.params, &[0.0; 3]);
    let got = fit(&obs, &start, &free, None);
    for &i in &free {
        assert!(
            (got.get(i) - truth.get(i)).abs() < 1e-6,
            "{}: {} vs {}",
            Layout::SIX.measured().name(i),
            got.get(i),
            truth.get(i)
        );
    }
}
