//! Throughput of the CPU (rayon, f64) and GPU (wgpu) evaluators: draws × points per second for
//! 10^4, 10^6 and 10^7 draws at 50 generated TX60 test points, median of several repetitions.
//! For the GPU the device time (timestamp queries, when the adapter has them) is printed apart
//! from the host's submit+wait and map/readback time.
//!
//! `cargo bench --bench gpu_throughput [-- --quick]`; `--quick` or `GPU_BENCH_QUICK=1` skips 10^7
//! draws (slow on a software adapter such as lavapipe); `GPU_BENCH_REPS=N` sets the repetitions;
//! `GPU_BENCH_ADAPTER=NAME` picks an adapter by name substring.

use gpu_amcs::engine::{CpuEvaluator, Evaluator, Problem, Reference};
use gpu_amcs::gpu::{self, GpuEvaluator, GpuOptions, GpuTimings};
use gpu_amcs::kinematics::tx60;
use std::time::Instant;

const POINTS: usize = 50;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let quick = args.iter().any(|a| a == "--quick")
        || std::env::var("GPU_BENCH_QUICK").is_ok_and(|v| v != "0");
    let reps: usize = std::env::var("GPU_BENCH_REPS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(3)
        .max(1);
    let adapter = std::env::var("GPU_BENCH_ADAPTER").ok();

    let model = tx60();
    let pts = gpu_amcs::points::generate(&model, POINTS, &Default::default(), 1).expect("points");
    let problem = Problem::new(model, &pts, &Reference::Calibrated, 1).expect("problem");
    let problem_for_batches = problem.clone();
    let mut sizes = vec![10_000usize, 1_000_000];
    if !quick {
        sizes.push(10_000_000);
    }

    let mut cpu = CpuEvaluator::new(problem.clone());
    let ci = cpu.info();
    println!("CPU: {} ({})", ci.adapter, ci.driver);
    let gpu_ev = if gpu::adapters().is_empty() {
        println!("GPU: no adapter found; GPU rows skipped");
        None
    } else {
        let opts = GpuOptions {
            adapter,
            timestamps: true,
            // Throughput rows repeat the same range; speculation would add unasked-for work.
            prefetch: false,
            ..GpuOptions::default()
        };
        match GpuEvaluator::new(problem, &opts) {
            Ok(g) => {
                let i = g.info();
                println!(
                    "GPU: {} | driver: {} | timestamps: {} | draws per dispatch: {}",
                    i.adapter,
                    i.driver,
                    if g.has_timestamps() { "yes" } else { "n/a" },
                    g.chunk_sizes().0
                );
                Some(g)
            }
            Err(e) => {
                println!("GPU: {e}; GPU rows skipped");
                None
            }
        }
    };
    let mut gpu_ev = gpu_ev;
    let spec_problem = problem_for_batches.clone();
    println!(
        "{POINTS} test points, median of {reps} repetitions{}",
        if quick { " (quick: 10^7 skipped)" } else { "" }
    );
    println!(
        "{:<4} {:>9} {:>10} {:>14} {:>11} {:>13} {:>11}",
        "", "draws", "wall s", "draw·pts/s", "device s", "submit+wait", "readback s"
    );
    for &n in &sizes {
        let mut w = vec![0.0f64; n];
        // CPU
        cpu.evaluate(0, &mut w[..n.min(10_000)], None).expect("cpu");
        let t: Vec<f64> = (0..reps)
            .map(|_| {
                let t0 = Instant::now();
                cpu.evaluate(0, &mut w, None).expect("cpu");
                t0.elapsed().as_secs_f64()
            })
            .collect();
        let tc = median(t);
        println!(
            "{:<4} {:>9} {:>10.4} {:>14.3e} {:>11} {:>13} {:>11}",
            "cpu",
            n,
            tc,
            (n * POINTS) as f64 / tc,
            "-",
            "-",
            "-"
        );
        // GPU
        if let Some(g) = gpu_ev.as_mut() {
            g.evaluate(0, &mut w[..n.min(10_000)], None).expect("gpu");
            let mut runs: Vec<(f64, GpuTimings)> = (0..reps)
                .map(|_| {
                    let t0 = Instant::now();
                    g.evaluate(0, &mut w, None).expect("gpu");
                    (t0.elapsed().as_secs_f64(), g.last_timings())
                })
                .collect();
            runs.sort_by(|a, b| a.0.total_cmp(&b.0));
            let (tg, tm) = runs[runs.len() / 2];
            println!(
                "{:<4} {:>9} {:>10.4} {:>14.3e} {:>11} {:>13.4} {:>11.4}",
                "gpu",
                n,
                tg,
                (n * POINTS) as f64 / tg,
                tm.device_s
                    .map(|d| format!("{d:.4}"))
                    .unwrap_or_else(|| "n/a".into()),
                tm.submit_wait_s,
                tm.readback_s
            );
        }
    }
    // AMCS-like use: 100 consecutive batches of 10^4, with and without speculative prefetch.
    if gpu_ev.is_some() {
        for prefetch in [false, true] {
            let opts = GpuOptions {
                adapter: std::env::var("GPU_BENCH_ADAPTER").ok(),
                prefetch,
                ..GpuOptions::default()
            };
            let Ok(mut g) = GpuEvaluator::new(spec_problem.clone(), &opts) else {
                continue;
            };
            let mut w = vec![0.0; 10_000];
            g.evaluate(0, &mut w, None).expect("gpu");
            let t: Vec<f64> = (0..reps)
                .map(|_| {
                    let t0 = Instant::now();
                    for b in 0..100u64 {
                        g.evaluate(b * 10_000, &mut w, None).expect("gpu");
                    }
                    t0.elapsed().as_secs_f64()
                })
                .collect();
            let tb = median(t);
            println!(
                "gpu 100 consecutive batches of 10^4, prefetch {:<5}: {:.4} s ({:.3e} draw·pts/s)",
                prefetch,
                tb,
                (1_000_000 * POINTS) as f64 / tb
            );
        }
    }
}
