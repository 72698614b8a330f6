//! The model the frame and discrepancy benches analyse: a TX60 (target (30, −20, 80) mm)
//! identified from 60 poses measured with 20 µm noise 2.3 m from the tracker (the library path
//! of `gpu-amcs identify poses.csv`; the noise is not stated, so the fit carries a discrepancy
//! term).

use gpu_amcs::engine::Evaluator;
use gpu_amcs::identify::chain::ChainOptions;
use gpu_amcs::identify::{identify_poses, IdentifyOptions};
use gpu_amcs::kinematics::{tx60, BaseTransform, RobotModel};
use gpu_amcs::simulate::{simulate_poses, TrackerNoise};
use std::time::Instant;

/// The identified TX60.
pub fn identified() -> RobotModel {
    let mut truth = tx60();
    truth.tool = [30.0, -20.0, 80.0];
    let placement = BaseTransform {
        xyz: [2300.0, -700.0, 250.0],
        rpy: [0.08, -0.12, 2.4],
    };
    let configs = gpu_amcs::simulate::random_poses(&truth, 60, 5);
    let data = simulate_poses(
        &truth,
        &configs,
        &placement,
        &TrackerNoise::Isotropic(0.02),
        9,
    );
    let ids = identify_poses(
        &data,
        &tx60(),
        &IdentifyOptions::default(),
        &ChainOptions::default(),
    )
    .unwrap();
    ids.into_iter().next().unwrap().model
}

/// Medians of `reps` runs of 10^6 counter draws on each of the two evaluators, interleaved so
/// that their ratio is measured under the same load.
pub fn interleaved_medians<E: Evaluator>(evs: &mut [E; 2], reps: usize) -> [f64; 2] {
    let mut w = vec![0.0; 1_000_000];
    let mut t = [Vec::new(), Vec::new()];
    for _ in 0..reps {
        for (ev, t) in evs.iter_mut().zip(&mut t) {
            let s = Instant::now();
            ev.evaluate(0, &mut w, None).unwrap();
            t.push(s.elapsed().as_secs_f64());
        }
    }
    t.map(median)
}

/// Repetitions per timing: `BENCH_REPS`, default 7.
pub fn reps() -> usize {
    std::env::var("BENCH_REPS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(7)
}

/// The median of `v`.
pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}
