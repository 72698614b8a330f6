//! Time of pose-based identification with its covariance (issue targets: 1000 poses in ≤ 1 s,
//! the Monte Carlo check with K = 200 in ≤ 20 s, on 2 cores).
//!
//! A perturbed TX60 (default simulation errors, target (30, −20, 80) mm) in a tracker frame
//! 2.6 m away and turned, measured with σ = 10 µm per coordinate at N random configurations;
//! `identify_chain` from the nominal model (rigid alignment start, 27 quantities, covariance with
//! s² from the residuals). Median of 5 repetitions per size; then one run of the Monte Carlo
//! re-identification (K = 200) on 60 poses. Run with `cargo bench --bench identify_poses`.

use gpu_amcs::identify::chain::{identify_chain, ChainOptions};
use gpu_amcs::identify::{MeasuredPoint, UncertaintyMethod};
use gpu_amcs::kinematics::{tx60, BaseTransform, RobotModel};
use gpu_amcs::simulate::{perturbed_model, random_configurations, ParameterErrors};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::time::Instant;

fn data(truth: &RobotModel, n: usize, rng: &mut ChaCha8Rng) -> Vec<MeasuredPoint> {
    random_configurations(&truth.limits_deg, n, rng)
        .into_iter()
        .enumerate()
        .map(|(k, q)| MeasuredPoint {
            payload_kg: 0.0,
            q_deg: q,
            position_mm: truth
                .world_position(&q.map(f64::to_radians))
                .map(|v| v + 0.01 * gpu_amcs::sampling::standard_normal(rng)),
            sigma_mm: None,
            line: k as u64 + 2,
            target: 0,
            sides: None,
        })
        .collect()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let nominal = tx60();
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut truth = perturbed_model(
        &nominal,
        &ParameterErrors::default(),
        [30.0, -20.0, 80.0],
        &mut rng,
    );
    truth.base = Some(BaseTransform {
        xyz: [2600.0, 500.0, -200.0],
        rpy: [0.03, -0.05, 2.3],
    });
    println!("threads: {}", rayon::current_num_threads());
    println!(
        "{:>6} {:>12} {:>12} {:>8}",
        "poses", "median s", "rms mm", "kappa"
    );
    for n in [60usize, 200, 1000] {
        let d = data(&truth, n, &mut rng);
        let mut times = Vec::new();
        let mut last = None;
        for _ in 0..5 {
            let t = Instant::now();
            let r = identify_chain(&d, &nominal, None, None, &ChainOptions::default()).unwrap();
            times.push(t.elapsed().as_secs_f64());
            last = Some(r);
        }
        let r = last.unwrap();
        println!(
            "{n:>6} {:>12.4} {:>12.5} {:>8.1}",
            median(times),
            r.report.rms_residual_mm,
            r.report.identifiability.condition_number
        );
    }
    let d = data(&truth, 60, &mut rng);
    let opts = ChainOptions {
        uncertainty: UncertaintyMethod::MonteCarlo { draws: 200 },
        ..ChainOptions::default()
    };
    let t = Instant::now();
    let r = identify_chain(&d, &nominal, None, None, &opts).unwrap();
    let mc = r.report.monte_carlo.unwrap();
    println!(
        "Monte Carlo check, K = 200, 60 poses: {:.2} s; σ_MC/σ_lin min {:.3} median {:.3} max {:.3}",
        t.elapsed().as_secs_f64(),
        mc.ratio_min,
        mc.ratio_median,
        mc.ratio_max
    );
}
