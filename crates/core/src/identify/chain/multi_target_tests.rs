//! Unit tests of several targets measured at each pose (reflectors on one tool): identified
//! together, one offset each, one chain and placement.

use super::*;
use crate::kinematics::tx60;
use rand::{Rng, SeedableRng};

/// The TX60 of the chain tests (off its nominal geometry, 2.6 m from the tracker), carrying
/// three reflectors.
fn truth() -> ChainState {
    ChainState {
        others: OtherTargets::new(&[[-45.0, 25.0, 95.0], [5.0, 55.0, 60.0]]),
        ..super::tests::truth()
    }
}

/// `n` random poses, each target of `t` measured at each with noise `sigma` (mm); `targets`
/// of them (the first ones).
fn points(t: &ChainState, n: usize, targets: usize, sigma: f64, seed: u64) -> Vec<MeasuredPoint> {
    let m = tx60();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut out = Vec::new();
    for k in 0..n {
        let q_deg = Joints::from_fn(m.joints(), |j| {
            let (lo, hi) = m.limits_deg[j];
            rng.random_range(lo.max(-170.0)..hi.min(170.0))
        });
        for target in 0..targets {
            let p = t.predict_target(&q_deg.map(f64::to_radians), target);
            out.push(MeasuredPoint {
                q_deg,
                position_mm: p.map(|v| v + sigma * crate::sampling::standard_normal(&mut rng)),
                sigma_mm: None,
                payload_kg: 0.0,
                line: (targets * k + target) as u64 + 2,
                target: target as u8,
                sides: None,
            });
        }
    }
    out
}

fn options() -> ChainOptions {
    ChainOptions {
        compensate: false,
        beyond_geometry: JointErrorFit::Off,
        ..ChainOptions::default()
    }
}

/// Noise-free: every target's held-out positions are reproduced, and the other targets'
/// offsets are recovered; the model keeps the first target and its covariance only the
/// space's inputs.
#[test]
fn noise_free_targets_share_one_chain() {
    let t = truth();
    let r = identify_chain(&points(&t, 40, 3, 0.0, 1), &tx60(), None, None, &options()).unwrap();
    assert_eq!(r.state.targets(), 3);
    // 27 of one target, 3 per other target
    assert_eq!(r.report.identifiability.parameters, 33);
    assert!(r.report.identifiability.null_directions.is_empty());
    for p in points(&t, 20, 3, 0.0, 99) {
        let got = r
            .state
            .predict_target(&p.q_deg.map(f64::to_radians), p.target as usize);
        for k in 0..3 {
            assert!((got[k] - p.position_mm[k]).abs() < 1e-6, "{got:?} {p:?}");
        }
    }
    for (got, want) in r.state.others.offsets().iter().zip(t.others.offsets()) {
        for k in 0..3 {
            assert!((got[k] - want[k]).abs() < 1e-6, "{got:?} {want:?}");
        }
    }
    let n = r.state.space().len();
    assert_eq!(r.covariance.len(), n * n);
    let names: Vec<&str> = r
        .report
        .parameters
        .iter()
        .map(|p| p.name.as_str())
        .collect();
    assert!(names.ends_with(&[
        "target2_x",
        "target2_y",
        "target2_z",
        "target3_x",
        "target3_y",
        "target3_z"
    ]));
    // the correlation matrix covers every identified row, the other targets' included
    let identified = r
        .report
        .parameters
        .iter()
        .filter(|p| p.status == "identified")
        .count();
    assert_eq!(r.report.correlation.len(), identified * identified);
}

/// With noise: the offsets and the model's inputs lie within their reported σ (z-scores over
/// every identified input), and three targets at each pose determine the chain better than one.
#[test]
fn several_targets_are_honest_and_sharper() {
    let t = truth();
    let sigma = 0.02;
    let three = identify_chain(
        &points(&t, 40, 3, sigma, 5),
        &tx60(),
        None,
        None,
        &options(),
    )
    .unwrap();
    let one = identify_chain(
        &points(&t, 40, 1, sigma, 5),
        &tx60(),
        None,
        None,
        &options(),
    )
    .unwrap();
    let mut z2 = Vec::new();
    for row in three
        .report
        .parameters
        .iter()
        .filter(|p| p.status == "identified")
    {
        let i = (0..three.state.n_inputs())
            .find(|&i| three.state.input_name(i) == row.name)
            .unwrap();
        let f = if three.state.is_angle(i) {
            180.0 / std::f64::consts::PI
        } else {
            1.0
        };
        let z = (row.value - t.get(i) * f) / row.sigma;
        z2.push(z * z);
    }
    // χ² over the identified inputs with as many degrees of freedom (they are correlated,
    // so a loose check): the mean z² near 1, not 10.
    let mean = z2.iter().sum::<f64>() / z2.len() as f64;
    assert!(
        (0.2..3.0).contains(&mean),
        "mean z² {mean} over {}",
        z2.len()
    );
    assert!(z2.iter().all(|&z| z < 25.0), "{z2:?}");
    // the chain's parameters: three targets per pose at least halve the mean variance... of
    // the parameters the single target identifies as well
    let var = |r: &ChainResult| -> f64 {
        r.report
            .parameters
            .iter()
            .filter(|p| p.status == "identified" && !p.name.starts_with("target"))
            .map(|p| p.sigma * p.sigma)
            .sum::<f64>()
    };
    let ratio = var(&three) / var(&one);
    eprintln!("variance ratio three/one targets {ratio:.3}, mean z² {mean:.2}");
    assert!(ratio < 0.5, "{ratio}");
}

/// Coverage over 100 seeded experiments: the reported σ of every reflector's offset (the
/// model's tool and the two others) covers the truth at the stated 95 % as often as it says.
#[test]
fn the_offsets_sigma_covers_the_truth() {
    let t = truth();
    let (mut inside, mut all) = (0usize, 0usize);
    for seed in 0..100 {
        let r = identify_chain(
            &points(&t, 30, 3, 0.02, 1000 + seed),
            &tx60(),
            None,
            None,
            &options(),
        )
        .unwrap();
        for row in &r.report.parameters {
            let want = match row.name.as_str() {
                n if n.starts_with("tool_") => t.tool,
                n if n.starts_with("target2_") => t.others.offsets()[0],
                n if n.starts_with("target3_") => t.others.offsets()[1],
                _ => continue,
            };
            let axis = ["x", "y", "z"]
                .iter()
                .position(|a| row.name.ends_with(a))
                .unwrap();
            all += 1;
            if (row.value - want[axis]).abs() < 1.96 * row.sigma {
                inside += 1;
            }
        }
    }
    let coverage = inside as f64 / all as f64;
    eprintln!("coverage of the offsets' 95 % intervals: {coverage:.3} over {all}");
    assert_eq!(all, 900);
    assert!((0.92..=0.98).contains(&coverage), "{coverage}");
}
