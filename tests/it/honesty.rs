//! The honesty experiment of `benches/honesty.rs` in small: the simulated robots of
//! `benches/support/nongeometric.rs` (forward kinematics written independently of the library)
//! agree with the library's conventions, and for purely geometric robots (size 0) the predicted
//! reliability of the identified model is not grossly off.

#[path = "../../benches/support/nongeometric.rs"]
mod nongeometric;

use nongeometric::{
    check_fk, configurations, errors, experiment, identify, measure, Outcome, TrueRobot,
    CALIBRATION_POSES,
};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

/// The generator's chain is the library's: its forward kinematics matches
/// `kinematics::position` on the nominal and perturbed TX60s, and a geometric robot (size 0)
/// measured without noise in its tracker frame is identified by the library so that the model
/// reproduces the truth at held-out configurations within 1e-6 mm. The noise is estimated from
/// the residuals (`identify` without `--tracker-sigma`), so that the nominal prior has no weight
/// against exact data; with a stated σ of 10 µm the prior's pull leaves about 2e-5 mm.
#[test]
fn generator_agrees_with_the_library() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let perturbed: Vec<_> = (0..3)
        .map(|_| TrueRobot::draw(0.0, &mut rng).params)
        .collect();
    check_fk(&perturbed);
    for seed in [1u64, 2] {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let truth = TrueRobot::draw(0.0, &mut rng);
        let calibration = configurations(CALIBRATION_POSES, &mut rng);
        let data = measure(&truth, &calibration, 0.0, &mut rng);
        let model = identify(data, None);
        let held = configurations(20, &mut rng);
        let worst = errors(&truth, &model, &held)
            .into_iter()
            .fold(0.0, f64::max);
        eprintln!("seed {seed}: largest held-out error {worst:.1e} mm");
        assert!(worst < 1e-6, "seed {seed}: held-out error {worst:e} mm");
    }
}

/// Geometric robots (size 0), 30 experiments: the PIT `u = R_pred(w_true)` of the realised
/// largest error over 20 task points has a mean within [0.2, 0.8] and fewer than 30 % of the
/// experiments have u ≥ 0.99 (the full experiment, with the tighter targets, is
/// `cargo bench --bench honesty`).
#[test]
fn geometric_robots_pit_is_not_grossly_off() {
    let out: Vec<Outcome> = (0..30u64)
        .into_par_iter()
        .map(|e| experiment(0.0, 20_000 + e, 5_000))
        .collect();
    let n = out.len() as f64;
    let u: Vec<f64> = out.iter().map(|o| o.u).collect();
    let mean = u.iter().sum::<f64>() / n;
    let high = u.iter().filter(|&&v| v >= 0.99).count() as f64 / n;
    eprintln!(
        "size 0: PIT mean {mean:.3}, u ≥ 0.99 in {:.0} %; mean held-out RMS {:.4} mm, w_true {:.4} mm, predicted median w {:.4} mm; {} of {} models draw a discrepancy term (mean robot RMS {:.4} mm); PIT mean from the parameters alone {:.3}",
        100.0 * high,
        out.iter().map(|o| o.rms).sum::<f64>() / n,
        out.iter().map(|o| o.w_true).sum::<f64>() / n,
        out.iter().map(|o| o.w_median).sum::<f64>() / n,
        out.iter().filter(|o| o.discrepancy).count(),
        out.len(),
        out.iter().map(|o| o.term_rms_mm).sum::<f64>() / n,
        out.iter().map(|o| o.u_parameters).sum::<f64>() / n
    );
    assert!((0.2..=0.8).contains(&mean), "PIT mean {mean}: {u:?}");
    assert!(high < 0.3, "{high} with u ≥ 0.99: {u:?}");
    // A purely geometric robot leaves white residuals: no fit keeps a compensation, and the
    // prediction is the geometric model's.
    for o in &out {
        assert!(!o.compensated && o.rms == o.rms_geometric, "{o:?}");
    }
}
