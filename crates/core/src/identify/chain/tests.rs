//! Unit tests of the whole-chain identification: poses in a tracker frame, a frozen wrist.

use super::*;
use crate::kinematics::tx60;
use rand::{Rng, SeedableRng};

/// A TX60 with every free parameter off by tenths of a mm / hundredths of a degree, target
/// (30, −20, 80) mm, placed 2.6 m from the tracker and turned.
pub(super) fn truth() -> ChainState {
    let nominal = tx60();
    let mut t = ChainState {
        params: nominal.params,
        tool: [30.0, -20.0, 80.0],
        base: [2600.0, 500.0, -200.0, 0.03, -0.05, 2.3],
        others: OtherTargets::NONE,
    };
    let six = crate::kinematics::Layout::SIX;
    for (k, i) in default_free(&nominal.fixed, true).into_iter().enumerate() {
        if i < six.n_params() {
            let size = if six.measured().is_angle(i) {
                5e-4
            } else {
                0.3
            };
            t.set(i, t.get(i) + size * [1.0, -0.6, 0.8, -1.0, 0.5][k % 5]);
        }
    }
    t
}

fn points(t: &ChainState, n: usize, sigma: f64, seed: u64) -> Vec<MeasuredPoint> {
    let m = tx60();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|k| {
            let q_deg = Joints::from_fn(m.joints(), |j| {
                let (lo, hi) = m.limits_deg[j];
                rng.random_range(lo.max(-170.0)..hi.min(170.0))
            });
            let p = t.predict(&q_deg.map(f64::to_radians));
            let position_mm = p.map(|v| v + sigma * crate::sampling::standard_normal(&mut rng));
            MeasuredPoint {
                q_deg,
                position_mm,
                sigma_mm: None,
                payload_kg: 0.0,
                line: k as u64 + 2,
                target: 0,
                sides: None,
            }
        })
        .collect()
}

#[test]
fn noise_free_poses_in_a_tracker_frame_are_reproduced() {
    let t = truth();
    let data = points(&t, 60, 0.0, 1);
    let r = identify_chain(&data, &tx60(), None, None, &ChainOptions::default()).unwrap();
    assert_eq!(r.report.identifiability.parameters, 27);
    assert!(r.report.identifiability.null_directions.is_empty());
    for p in points(&t, 20, 0.0, 99) {
        let got = r.state.predict(&p.q_deg.map(f64::to_radians));
        for k in 0..3 {
            assert!(
                (got[k] - p.position_mm[k]).abs() < 1e-6,
                "{got:?} {:?}",
                p.position_mm
            );
        }
    }
    eprintln!(
        "KAPPA {} sv {:?}",
        r.report.identifiability.condition_number, r.report.identifiability.singular_values
    );
}

#[test]
fn frozen_wrist_is_named() {
    let t = truth();
    let mut data = points(&t, 60, 0.01, 2);
    for p in &mut data {
        p.q_deg[3] = 10.0;
        p.q_deg[4] = 40.0;
        p.q_deg[5] = -20.0;
        p.position_mm = t.predict(&p.q_deg.map(f64::to_radians));
    }
    let r = identify_chain(&data, &tx60(), None, None, &ChainOptions::default()).unwrap();
    let a = &r.report.identifiability;
    assert!(!a.null_directions.is_empty(), "{a:?}");
    assert!(
        r.report
            .warnings
            .iter()
            .any(|w| w.contains("rank deficient") && w.contains("barely moved")),
        "{:?}",
        r.report.warnings
    );
}

/// The progress hook hears each step once, in order, counting up to a plan that ends where the
/// work does: one pass of four steps by default (the check runs: the noise is not stated), two
/// passes when the joint errors are kept.
#[test]
fn the_progress_hook_hears_every_step_in_order() {
    use crate::progress::ProgressHook;
    use std::sync::{Arc, Mutex};
    let data = points(&truth(), 60, 0.01, 3);
    let heard = |beyond_geometry: JointErrorFit| {
        let log = Arc::new(Mutex::new(Vec::new()));
        let sink = log.clone();
        let opts = ChainOptions {
            beyond_geometry,
            compensate: false,
            progress: ProgressHook::new(move |label: &str, done, total| {
                sink.lock().unwrap().push((label.to_string(), done, total));
            }),
            ..ChainOptions::default()
        };
        identify_chain(&data, &tx60(), None, None, &opts).unwrap();
        let steps = log.lock().unwrap().clone();
        for (k, (label, done, total)) in steps.iter().enumerate() {
            assert_eq!(*done, k as u64 * steps::UNITS, "{steps:?}");
            assert!(done < total || label == "done", "{steps:?}");
        }
        let (last, done, total) = steps.last().unwrap().clone();
        assert_eq!((last.as_str(), done), ("done", total), "{steps:?}");
        steps.into_iter().map(|s| s.0).collect::<Vec<_>>()
    };
    let pass = ["fitting the geometry", "identifiability and covariance"];
    let mut one = pass.to_vec();
    one.extend(["checking beyond geometry", "lack of fit", "done"]);
    assert_eq!(heard(JointErrorFit::Auto), one);
    let mut off = pass.to_vec();
    off.extend(["lack of fit", "done"]);
    assert_eq!(heard(JointErrorFit::Off), off);
    let mut two = pass.to_vec();
    two.extend(["checking beyond geometry", "lack of fit"]);
    two.extend(pass);
    two.extend(["lack of fit", "done"]);
    assert_eq!(heard(JointErrorFit::Keep), two);
}

/// The Monte Carlo re-identifications are a step of their own that reports its share done.
#[test]
fn monte_carlo_re_identifications_report_their_share() {
    use crate::progress::ProgressHook;
    use std::sync::{Arc, Mutex};
    let data = points(&truth(), 60, 0.01, 4);
    let log = Arc::new(Mutex::new(Vec::new()));
    let sink = log.clone();
    let opts = ChainOptions {
        beyond_geometry: JointErrorFit::Off,
        compensate: false,
        uncertainty: UncertaintyMethod::MonteCarlo { draws: 40 },
        progress: ProgressHook::new(move |label: &str, done, total| {
            sink.lock().unwrap().push((label.to_string(), done, total));
        }),
        ..ChainOptions::default()
    };
    identify_chain(&data, &tx60(), None, None, &opts).unwrap();
    let heard = log.lock().unwrap().clone();
    let mut labels: Vec<&str> = heard.iter().map(|h| h.0.as_str()).collect();
    labels.dedup();
    let mc = "40 Monte Carlo re-identifications";
    assert_eq!(
        labels,
        [
            "fitting the geometry",
            "identifiability and covariance",
            "lack of fit",
            mc,
            "done"
        ]
    );
    let u = steps::UNITS;
    let ticks: Vec<u64> = heard.iter().filter(|h| h.0 == mc).map(|h| h.1).collect();
    // The step's start and every hundredth of the draws (each one of 40), within the step.
    assert_eq!(ticks.len(), 41, "{heard:?}");
    assert!(
        ticks.iter().all(|&d| (3 * u..=4 * u).contains(&d)),
        "{heard:?}"
    );
    assert!(ticks.contains(&(4 * u)), "{heard:?}");
    assert!(heard.iter().all(|h| h.2 == 4 * u), "{heard:?}");
}
