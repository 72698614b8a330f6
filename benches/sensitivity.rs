//! Cost of a Sobol sensitivity analysis.
//!
//! `cargo bench --bench sensitivity` runs three parts (name some after `--` to run only those,
//! e.g. `cargo bench --bench sensitivity -- scaling`):
//!
//! * `scaling`: the whole analysis of `gpu-amcs sensitivity --backend cpu` (default TX60, 50 test
//!   points, 20 free inputs and 8 groups: 28 pick-freeze matrices, 300 bootstrap resamples) at
//!   N = 2^16 … 2^20 base samples (`BENCH_LOG2_DRAWS`, default `16,17,18,19,20`), timing the
//!   evaluation of the outputs (`run_outputs`) and the analysis (point estimates and bootstrap,
//!   `Design::result`) separately, `BENCH_SCALING_REPS` times (default 3); prints the medians
//!   and the ratio of the largest N's time to the smallest's (an O(N) analysis gives the ratio
//!   of the N).
//! * `thresholds`: the analysis alone of the outputs at N = 2^13 with 1000 thresholds of the
//!   failure indicator (0.05 … 0.5495 mm), and with none, medians of `BENCH_REPS`.
//! * `paths`: the rows of a pick-freeze design generated inside the evaluator from the two
//!   counter streams (`Evaluator::evaluate_pick_freeze`, what `gpu-amcs sensitivity` uses)
//!   against the same rows built on the host and passed as an offset matrix
//!   (`evaluate_offsets`, what it used before: `chunk · (2 + S)` rows of 33 offsets per call,
//!   uploaded as f32 on the GPU): the default TX60 (50 test points, 20 free inputs, a design
//!   like that of `sensitivity --draws 8192`: A, B, one matrix per input and three group
//!   matrices, 25 in all, in chunks of 1024 base samples) on the CPU evaluator and, when an
//!   adapter is present, on the GPU evaluator, `BENCH_REPS` times (default 5); prints the
//!   medians, their ratio and the bytes each call carries to the evaluator. Both paths
//!   evaluate the same rows (checked).

use gpu_amcs::engine::{CpuEvaluator, Evaluator, PickFreeze, Problem, Reference};
use gpu_amcs::gpu::{GpuEvaluator, GpuOptions};
use gpu_amcs::kinematics::{tx60, MAX_ROBOT_INPUTS};
use gpu_amcs::mc::sensitivity::{run_outputs, SensitivityOptions, B_DRAW_OFFSET};
use gpu_amcs::sampling::ALL_NORMALS;
use std::time::Instant;

const BASE_SAMPLES: usize = 8192;
const CHUNK: usize = 1024;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The design's masks: A, B, one per free input, and three group sets (joints 1–2, θ, lengths).
fn masks(free: &[usize]) -> Vec<u64> {
    let set = |keep: &dyn Fn(usize) -> bool| {
        free.iter()
            .filter(|&&i| keep(i))
            .fold(0u64, |m, &i| m | 1 << i)
    };
    let mut m = vec![0, ALL_NORMALS];
    m.extend(free.iter().map(|&i| 1u64 << i));
    m.push(set(&|i| i < 10));
    m.push(set(&|i| i % 5 == 0));
    m.push(set(&|i| i % 5 == 1 || i % 5 == 2));
    m
}

/// One pass over the design: returns (seconds, sum of w) for the generated or uploaded path.
fn pass(ev: &mut dyn Evaluator, pb: &Problem, masks: &[u64], generated: bool) -> (f64, f64) {
    let t = Instant::now();
    let mut sum = 0.0;
    let mut k0 = 0;
    while k0 < BASE_SAMPLES {
        let request = PickFreeze {
            first: k0 as u64,
            b_first: B_DRAW_OFFSET + k0 as u64,
            count: CHUNK,
            masks,
        };
        let mut w = vec![0.0; request.rows()];
        if generated {
            ev.evaluate_pick_freeze(&request, &mut w).unwrap();
        } else {
            let n_uncertain = pb.model.robot_inputs().len();
            let mut rows = vec![0.0; request.rows() * n_uncertain];
            for (r, row) in rows.chunks_exact_mut(n_uncertain).enumerate() {
                let (a, b, m) = request.row(r);
                let mut d = [0.0; MAX_ROBOT_INPUTS];
                pb.sampler
                    .pick_freeze_deltas(a, b, m, &mut d[..n_uncertain]);
                row.copy_from_slice(&d[..n_uncertain]);
            }
            ev.evaluate_offsets(&rows, &mut w, None).unwrap();
        }
        sum += w.iter().sum::<f64>();
        k0 += CHUNK;
    }
    (t.elapsed().as_secs_f64(), sum)
}

fn bench(label: &str, ev: &mut dyn Evaluator, pb: &Problem, masks: &[u64], reps: usize) {
    let rows = BASE_SAMPLES * masks.len();
    let (mut tg, mut tu) = (Vec::new(), Vec::new());
    for _ in 0..reps {
        let (g, sg) = pass(ev, pb, masks, true);
        let (u, su) = pass(ev, pb, masks, false);
        // Same rows: equal sums on the CPU (up to summation order); on the GPU the offset path
        // rounds f64 offsets to f32 where the generated one draws f32 normals, ≲ 1e-7 mm a row.
        assert!(
            (sg - su).abs() <= 1e-6 * rows as f64,
            "{label}: both paths evaluate the same rows ({sg} vs {su})"
        );
        tg.push(g);
        tu.push(u);
    }
    let (g, u) = (median(tg), median(tu));
    let per_call = CHUNK * masks.len();
    let n_uncertain = pb.model.robot_inputs().len();
    println!(
        "{label}: {rows} rows ({} matrices × {BASE_SAMPLES}), medians of {reps}: generated {g:.3} s \
         ({:.2e} rows/s), offset matrix {u:.3} s ({:.2e} rows/s), ratio {:.2}; per call: masks {} \
         B vs offsets {} B (f64; {} B as f32 on a GPU)",
        masks.len(),
        rows as f64 / g,
        rows as f64 / u,
        u / g,
        8 * masks.len(),
        8 * per_call * n_uncertain,
        4 * per_call * n_uncertain,
    );
}

/// CPU seconds of this process so far, all threads (0 where unknown).
fn cpu_seconds() -> f64 {
    #[cfg(unix)]
    {
        let mut t = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: a valid clock id and a valid pointer to a timespec.
        if unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut t) } == 0 {
            return t.tv_sec as f64 + t.tv_nsec as f64 * 1e-9;
        }
    }
    0.0
}

/// Wall and CPU seconds of `f`, and its value.
fn timed<T>(f: impl FnOnce() -> T) -> ([f64; 2], T) {
    let (t, c) = (Instant::now(), cpu_seconds());
    let v = f();
    ([t.elapsed().as_secs_f64(), cpu_seconds() - c], v)
}

/// The whole analysis at each N: medians of the evaluation, the analysis and their sum.
fn scaling(pb: &Problem) {
    let reps: usize = env("BENCH_SCALING_REPS").unwrap_or(3);
    let logs: Vec<u32> = std::env::var("BENCH_LOG2_DRAWS")
        .ok()
        .map(|v| v.split(',').filter_map(|x| x.trim().parse().ok()).collect())
        .unwrap_or_else(|| (16..=20).collect());
    println!(
        "scaling: gpu-amcs sensitivity --backend cpu (TX60, 50 points, 300 resamples), {} \
         threads, medians of {reps}",
        rayon::current_num_threads()
    );
    let mut totals = Vec::new();
    for &log in &logs {
        let opts = SensitivityOptions {
            draws: 1 << log,
            ..SensitivityOptions::default()
        };
        // Per rep: wall and CPU seconds of the evaluation, the analysis and both.
        let mut t = vec![Vec::new(); 6];
        for _ in 0..reps {
            let mut ev = CpuEvaluator::new(pb.clone());
            let (e, (out, design)) =
                timed(|| run_outputs(pb, &mut ev, &opts, 0..opts.draws).unwrap());
            let model = (pb.model.name.clone(), pb.n_points(), pb.seed);
            let (a, r) = timed(|| design.result(model, ev.info(), &out, &opts).unwrap());
            assert_eq!(r.analysis.bootstrap_resamples, opts.bootstrap);
            for (i, v) in [e[0], e[1], a[0], a[1], e[0] + a[0], e[1] + a[1]]
                .into_iter()
                .enumerate()
            {
                t[i].push(v);
            }
        }
        let m: Vec<f64> = t.into_iter().map(median).collect();
        println!(
            "  N = 2^{log} ({:>7}): evaluation {:7.3} s ({:7.3} s CPU), analysis {:7.3} s \
             ({:7.3} s CPU), total {:7.3} s ({:7.3} s CPU)",
            opts.draws, m[0], m[1], m[2], m[3], m[4], m[5]
        );
        totals.push((log, m));
    }
    if let (Some((l0, first)), Some((l1, last))) = (totals.first(), totals.last()) {
        if l1 > l0 {
            println!(
                "  time(2^{l1}) / time(2^{l0}), wall (CPU): total {:.1} ({:.1}), evaluation {:.1} \
                 ({:.1}), analysis {:.1} ({:.1}) (N grew {}×)",
                last[4] / first[4],
                last[5] / first[5],
                last[0] / first[0],
                last[1] / first[1],
                last[2] / first[2],
                last[3] / first[3],
                1u64 << (l1 - l0)
            );
        }
    }
}

/// The analysis alone at N = 2^13 with 1000 thresholds and with none.
fn thresholds(pb: &Problem, reps: usize) {
    let mut opts = SensitivityOptions::default();
    let mut ev = CpuEvaluator::new(pb.clone());
    let (out, design) = run_outputs(pb, &mut ev, &opts, 0..opts.draws).unwrap();
    let model = (pb.model.name.clone(), pb.n_points(), pb.seed);
    for count in [0, 1000] {
        opts.thresholds = (0..count).map(|i| 0.05 + 0.0005 * i as f64).collect();
        let t: Vec<[f64; 2]> = (0..reps)
            .map(|_| {
                let (t, r) = timed(|| design.result(model.clone(), ev.info(), &out, &opts));
                assert_eq!(r.unwrap().analysis.quantities.len(), 1 + count);
                t
            })
            .collect();
        println!(
            "thresholds: analysis of N = {} with {count:4} thresholds, medians of {reps}: {:.3} s \
             ({:.3} s CPU)",
            opts.draws,
            median(t.iter().map(|t| t[0]).collect()),
            median(t.iter().map(|t| t[1]).collect())
        );
    }
}

fn env<T: std::str::FromStr>(name: &str) -> Option<T> {
    std::env::var(name).ok().and_then(|v| v.parse().ok())
}

fn main() {
    let reps: usize = env("BENCH_REPS").unwrap_or(5);
    let parts = ["scaling", "thresholds", "paths"];
    let asked: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| parts.contains(&a.as_str()))
        .collect();
    let run = |part: &str| asked.is_empty() || asked.iter().any(|a| a == part);
    let m = tx60();
    let pts = gpu_amcs::points::generate(&m, 50, &Default::default(), 2025).unwrap();
    let pb = Problem::new(m, &pts, &Reference::Calibrated, 2025).unwrap();
    if run("scaling") {
        scaling(&pb);
    }
    if run("thresholds") {
        thresholds(&pb, reps);
    }
    if !run("paths") {
        return;
    }
    let masks = masks(&pb.model.free_inputs());
    let mut cpu = CpuEvaluator::new(pb.clone());
    bench(
        &format!("cpu ({})", cpu.info().adapter),
        &mut cpu,
        &pb,
        &masks,
        reps,
    );
    match GpuEvaluator::new(pb.clone(), &GpuOptions::default()) {
        Ok(mut gpu) => {
            let label = format!("gpu ({})", gpu.info().adapter);
            bench(&label, &mut gpu, &pb, &masks, reps);
        }
        Err(e) => println!("gpu: skipped ({e})"),
    }
}
