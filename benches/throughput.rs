//! End-to-end speed of the CPU path and what the AMCS tolerance δ buys.
//!
//! `cargo bench --bench throughput` prints medians over repeated runs of: the CPU evaluator on
//! 10^6 draws × 50 points, a full MCS of 10^6 draws (evaluation, moments, sorting, reliability),
//! AMCS with δ = 0.01, the binary's main job from process start to report, and, for
//! δ = 0.005, 0.01, 0.02 over several seeds, the draws AMCS used and the maximum relative error
//! of M1–M4 against a 10^6-draw MCS. `BENCH_REPS` sets the repetitions (default 7).

use gpu_amcs::engine::{CpuEvaluator, Evaluator, Problem, Reference};
use gpu_amcs::kinematics::tx60;
use gpu_amcs::mc::{run_amcs, run_mcs, AmcsOptions, McsOptions, Tolerance};
use gpu_amcs::report::max_relative_error;
use std::time::Instant;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn time<F: FnMut()>(reps: usize, mut f: F) -> (f64, f64, f64) {
    let t: Vec<f64> = (0..reps)
        .map(|_| {
            let s = Instant::now();
            f();
            s.elapsed().as_secs_f64()
        })
        .collect();
    let min = t.iter().cloned().fold(f64::INFINITY, f64::min);
    let max = t.iter().cloned().fold(0.0, f64::max);
    (median(t), min, max)
}

fn problem(seed: u64) -> Problem {
    let m = tx60();
    let pts = gpu_amcs::points::generate(&m, 50, &Default::default(), 1).unwrap();
    Problem::new(m, &pts, &Reference::Calibrated, seed).unwrap()
}

fn main() {
    let reps: usize = std::env::var("BENCH_REPS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(7);
    let mut ev = CpuEvaluator::new(problem(1));
    println!(
        "machine: {} threads; backend {:?}",
        rayon::current_num_threads(),
        ev.info()
    );
    println!("TX60, 50 test points; medians of {reps} runs (min–max)\n");

    let mut w = vec![0.0; 1_000_000];
    let (m, lo, hi) = time(reps, || ev.evaluate(0, &mut w, None).unwrap());
    println!("CPU evaluator 10^6 draws × 50 points     {m:.3} s  ({lo:.3}–{hi:.3})  {:.2e} draw·points/s", 5e7 / m);

    let (m, lo, hi) = time(reps, || {
        run_mcs(&mut ev, &McsOptions::default(), None).unwrap();
    });
    println!("MCS 10^6 end to end (library)            {m:.3} s  ({lo:.3}–{hi:.3})");

    let opts = AmcsOptions::default();
    let (m, lo, hi) = time(reps, || {
        run_amcs(&mut ev, &opts, None).unwrap();
    });
    println!("AMCS δ = 0.01 end to end (library)       {m:.4} s  ({lo:.4}–{hi:.4})");

    // Whole processes, start to report: the main job and MCS 10^6, on the CPU and (when an
    // adapter exists) on the GPU backend.
    // GPU_AMCS_BIN overrides the path cargo baked in, for a bench executable carried to another
    // machine together with the binary.
    let exe_env = std::env::var("GPU_AMCS_BIN").ok();
    let exe = exe_env.as_deref().unwrap_or(env!("CARGO_BIN_EXE_gpu-amcs"));
    let mut backends = vec!["cpu"];
    if !gpu_amcs::backends().list_adapters().is_empty() {
        backends.push("gpu");
    }
    for backend in backends {
        let jobs: [(&str, &[&str], usize); 2] = [
            (
                "gpu-amcs --points 50 --delta 0.01",
                &["--points", "50", "--delta", "0.01"],
                reps,
            ),
            (
                "gpu-amcs mcs --draws 1000000",
                &["mcs", "--draws", "1000000", "--points", "50"],
                reps.min(3),
            ),
        ];
        for (label, args, n) in jobs {
            let (m, lo, hi) = time(n, || {
                let o = std::process::Command::new(exe)
                    .args(args)
                    .args(["--backend", backend, "--quiet"])
                    .output()
                    .unwrap();
                assert!(o.status.success());
            });
            println!("`{label}` (process, {backend})  {m:.3} s  ({lo:.3}–{hi:.3})");
        }
    }

    println!("\nWhat δ buys (AMCS against MCS 10^6, seeds 1..=5 for AMCS, seed 100 for MCS):");
    let mcs = run_mcs(
        &mut CpuEvaluator::new(problem(100)),
        &McsOptions::default(),
        None,
    )
    .unwrap();
    println!(
        "MCS: M1 {:.5} M2 {:.4e} M3 {:.4} M4 {:.4}",
        mcs.moments.mean,
        mcs.moments.variance,
        mcs.moments.as_array()[2],
        mcs.moments.as_array()[3]
    );
    println!(
        "{:>7} {:>14} {:>14} {:>12}",
        "δ (mm)", "draws (median)", "MRE % (median)", "MRE % (max)"
    );
    for delta in [0.005, 0.01, 0.02, 0.002, 0.001] {
        let mut draws = Vec::new();
        let mut mres = Vec::new();
        for seed in 1..=5 {
            let o = AmcsOptions {
                tolerance: Tolerance::Delta(delta),
                ..AmcsOptions::default()
            };
            let r = run_amcs(&mut CpuEvaluator::new(problem(seed)), &o, None).unwrap();
            draws.push(r.draws as f64);
            mres.push(max_relative_error(&r, &mcs));
        }
        let mx = mres.iter().cloned().fold(0.0, f64::max);
        println!(
            "{delta:>7} {:>14} {:>14.3} {:>12.3}",
            median(draws),
            median(mres),
            mx
        );
    }
}
