//! Cost of a calibration plan: 30 poses out of 2000 candidates for the TX60's 50 generated task
//! points (the library's `plan::plan`, without the engine's final Monte Carlo, and the whole
//! `gpu-amcs plan` process with it), medians of `BENCH_REPS` runs (default 5).
//!
//! `cargo bench --bench plan`

use gpu_amcs::kinematics::tx60;
use gpu_amcs::plan::{plan, PlanOptions};
use std::time::Instant;

fn main() {
    let reps: usize = std::env::var("BENCH_REPS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(5)
        .max(1);
    let mut model = tx60();
    let task = gpu_amcs::points::generate(&model, 50, &Default::default(), 1).expect("points");
    let o = PlanOptions::default();
    model.tool = o.target_mm;
    let mut times = Vec::new();
    let mut last = None;
    for _ in 0..reps {
        let t = Instant::now();
        last = Some(plan(&model, &task, &o).expect("plan"));
        times.push(t.elapsed().as_secs_f64());
    }
    times.sort_by(f64::total_cmp);
    let p = last.expect("a plan");
    println!(
        "machine: {} threads; plan of {} poses out of {} candidates, {} task points",
        rayon::current_num_threads(),
        o.poses,
        o.candidates,
        task.len()
    );
    println!(
        "library plan::plan: median {:.3} s (min {:.3}, max {:.3}) over {reps} runs",
        times[times.len() / 2],
        times[0],
        times[times.len() - 1]
    );
    println!(
        "q95 of w: planned {:.5} mm, log-det {:.5} mm, random median {:.5} mm",
        p.planned.q95_mm, p.log_det_design.q95_mm, p.random_median.q95_mm
    );
    let exe_env = std::env::var("GPU_AMCS_BIN").ok();
    let exe = exe_env.as_deref().unwrap_or(env!("CARGO_BIN_EXE_gpu-amcs"));
    let out = std::env::temp_dir().join(format!("plan-bench-{}.csv", std::process::id()));
    let mut times = Vec::new();
    for _ in 0..reps {
        let t = Instant::now();
        let o = std::process::Command::new(exe)
            .args(["plan", "--points", "50", "--backend", "cpu", "-q", "--out"])
            .arg(&out)
            .output()
            .expect("gpu-amcs");
        assert!(o.status.success());
        times.push(t.elapsed().as_secs_f64());
        let _ = std::fs::remove_file(&out);
    }
    times.sort_by(f64::total_cmp);
    println!(
        "`gpu-amcs plan --points 50 --backend cpu` (process, with 10^5 draws of the prediction): median {:.3} s",
        times[times.len() / 2]
    );
}
