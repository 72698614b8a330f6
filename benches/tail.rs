//! Cost of tail probabilities by subset simulation on the CPU path: evaluations of w and seconds
//! to reach P_f ≈ 1e-9 with a coefficient of variation ≤ 0.15, against what crude Monte Carlo
//! would need for the same CoV (draws ≈ (1 − P_f)/(P_f · CoV²)).
//!
//! `cargo bench --bench tail` runs (1) the TX60 with only θ1 uncertain (σ = 0.01°, 20 test
//! points), whose exact P_f(L) = 2Φ(−2 asin(L/2ρ_max)/σ) gives the threshold of P_f = 1e-9, and
//! (2) the default TX60 (50 points) at the threshold of its ninth subset level (≈ 1e-9), and
//! (3) the same with modified Metropolis and its summed coefficient of variation (the proposal
//! before adaptive conditional sampling), each for `BENCH_REPS` seeds (default 3), and prints
//! every run and the medians.

use gpu_amcs::engine::{CpuEvaluator, Problem, Reference};
use gpu_amcs::kinematics::{tx60, Params, RobotModel, Uncertainty};
use gpu_amcs::mc::tail::{normal_quantile, run_tail, ChainProposal, TailOptions, TailResult};

const SIGMA_DEG: f64 = 0.01;

fn problem(m: RobotModel, points: usize, seed: u64) -> Problem {
    let pts = gpu_amcs::points::generate(&m, points, &Default::default(), 5).unwrap();
    Problem::new(m, &pts, &Reference::Calibrated, seed).unwrap()
}

fn run(pb: &Problem, thresholds: Vec<f64>, target: f64, cap: u64) -> TailResult {
    run_with(pb, thresholds, target, cap, ChainProposal::default())
}

fn run_with(
    pb: &Problem,
    thresholds: Vec<f64>,
    target: f64,
    cap: u64,
    proposal: ChainProposal,
) -> TailResult {
    let opts = TailOptions {
        thresholds,
        target_cov: target,
        max_evaluations: cap,
        proposal,
        ..TailOptions::default()
    };
    run_tail(&mut CpuEvaluator::new(pb.clone()), pb, &opts, None).unwrap()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn report(label: &str, runs: &[TailResult]) {
    for r in runs {
        let e = &r.estimates[0];
        let cov = e.cov.unwrap_or(f64::NAN);
        println!(
            "{label}: L = {:.5} mm  P_f = {:.3e}  CoV = {:.3}  evaluations = {}  {:.2} s  \
             (crude MC for the same CoV: {:.1e} draws)",
            e.threshold,
            e.p_f,
            cov,
            r.evaluations,
            r.seconds,
            (1.0 - e.p_f) / (e.p_f * cov * cov)
        );
    }
    println!(
        "{label}: median {} evaluations, {:.2} s over {} seeds",
        median(runs.iter().map(|r| r.evaluations as f64).collect()),
        median(runs.iter().map(|r| r.seconds).collect()),
        runs.len()
    );
}

fn main() {
    let reps: u64 = std::env::var("BENCH_REPS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(3);
    let sigma = SIGMA_DEG.to_radians();
    let theta1: Vec<TailResult> = (0..reps)
        .map(|seed| {
            let mut m = tx60();
            let mut s = Params::filled(m.layout().n_params(), 0.0);
            s[0] = sigma;
            m.uncertainty = Uncertainty::Independent(s);
            let pb = problem(m, 20, 100 + seed);
            let r_max = pb
                .reference
                .iter()
                .map(|p| p[0].hypot(p[1]))
                .fold(0.0, f64::max);
            let l = 2.0 * r_max * (-normal_quantile(0.5e-9) * sigma / 2.0).sin();
            run(&pb, vec![l], 0.15, 10_000_000)
        })
        .collect();
    report("theta1-only, P_f = 1e-9", &theta1);
    for (label, proposal) in [
        (
            "default TX60, level-9 threshold",
            ChainProposal::AdaptiveConditional,
        ),
        (
            "default TX60, level-9 threshold, modified Metropolis",
            ChainProposal::ModifiedMetropolis,
        ),
    ] {
        let runs: Vec<TailResult> = (0..reps)
            .map(|seed| {
                let pb = problem(tx60(), 50, 200 + seed);
                let probe = run(&pb, vec![10.0], 0.99, 9_000);
                let l = probe.runs[0].levels[8].next.unwrap();
                run_with(&pb, vec![l], 0.15, 10_000_000, proposal)
            })
            .collect();
        report(label, &runs);
    }
}
