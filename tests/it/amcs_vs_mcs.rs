//! AMCS (δ = 0.01 mm) against a 10^6-draw MCS on the default model (TX60, 50 points), judged by
//! what each procedure promises, and the reproducibility of both.

use gpu_amcs::engine::{CpuEvaluator, Problem, Reference};
use gpu_amcs::kinematics::tx60;
use gpu_amcs::mc::{run_amcs, run_mcs, AmcsOptions, McResult, McsOptions, Tolerance};
use gpu_amcs::report::max_relative_error;

fn problem(seed: u64) -> Problem {
    let m = tx60();
    let pts = gpu_amcs::points::generate(&m, 50, &Default::default(), 1).unwrap();
    Problem::new(m, &pts, &Reference::Calibrated, seed).unwrap()
}

fn amcs(seed: u64, delta: f64) -> McResult {
    let opts = AmcsOptions {
        tolerance: Tolerance::Delta(delta),
        ..AmcsOptions::default()
    };
    run_amcs(&mut CpuEvaluator::new(problem(seed)), &opts, None).unwrap()
}

#[test]
fn amcs_agrees_with_mcs_within_its_promises() {
    // Different seeds: the two runs are independent.
    let mcs = run_mcs(
        &mut CpuEvaluator::new(problem(1)),
        &McsOptions::default(),
        None,
    )
    .unwrap();
    let a = amcs(2, 0.01);
    assert!(a.converged);
    let d = 0.01;
    // The stopping rule controls the mean, u(w) and the interval ends to about δ.
    assert!((a.estimate - mcs.estimate).abs() <= d);
    assert!((a.std_uncertainty - mcs.std_uncertainty).abs() <= d);
    assert!((a.coverage_interval.low - mcs.coverage_interval.low).abs() <= d);
    assert!((a.coverage_interval.high - mcs.coverage_interval.high).abs() <= d);
    // Skewness and kurtosis are not controlled by the rule: within 3 combined standard errors.
    for k in [2, 3] {
        let se =
            (a.moment_standard_errors[k].powi(2) + mcs.moment_standard_errors[k].powi(2)).sqrt();
        let (x, y) = (a.moments.as_array()[k], mcs.moments.as_array()[k]);
        assert!(
            (x - y).abs() <= 3.0 * se,
            "moment {}: {x} vs {y}, 3σ = {}",
            k + 1,
            3.0 * se
        );
    }
    // Reliability: the difference within the combined 95 % half-widths.
    for (ra, rm) in a.reliability.iter().zip(&mcs.reliability) {
        let ha = 0.5 * (ra.ci_high - ra.ci_low);
        let hm = 0.5 * (rm.ci_high - rm.ci_low);
        assert!(
            (ra.r - rm.r).abs() <= (ha * ha + hm * hm).sqrt() * 1.5,
            "l = {}: {} vs {}",
            ra.threshold,
            ra.r,
            rm.r
        );
    }
    let mre = max_relative_error(&a, &mcs);
    println!(
        "AMCS δ=0.01: {} draws, MRE {mre:.3} % against MCS {} draws",
        a.draws, mcs.draws
    );
    assert!(mre < 10.0);
}

#[test]
fn same_seed_same_result_any_thread_count() {
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| amcs(7, 0.002));
    let two = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap()
        .install(|| amcs(7, 0.002));
    let three = rayon::ThreadPoolBuilder::new()
        .num_threads(3)
        .build()
        .unwrap()
        .install(|| amcs(7, 0.002));
    assert_eq!(one.sorted_values, two.sorted_values);
    assert_eq!(one.sorted_values, three.sorted_values);
    assert_eq!(format!("{:?}", one.trace), format!("{:?}", two.trace)); // NaN-safe
    let other = amcs(8, 0.002);
    assert_ne!(one.sorted_values, other.sorted_values);
}
