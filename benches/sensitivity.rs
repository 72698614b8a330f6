//! Cost of the rows of a Sobol pick-freeze design, generated inside the evaluator from the two
//! counter streams (`Evaluator::evaluate_pick_freeze`, what `gpu-amcs sensitivity` uses) against
//! the same rows built on the host and passed as an offset matrix (`evaluate_offsets`, what it
//! used before: `chunk · (2 + S)` rows of 33 offsets per call, uploaded as f32 on the GPU).
//!
//! `cargo bench --bench sensitivity` runs the default TX60 (50 test points, 20 free inputs, a
//! design like that of `sensitivity --draws 8192`: A, B, one matrix per input and three group
//! matrices, 25 in all, in chunks of 1024 base samples) on the CPU evaluator and, when an adapter is present, on the GPU
//! evaluator, `BENCH_REPS` times (default 5), and prints the medians, their ratio and the bytes
//! each call carries to the evaluator. Both paths evaluate the same rows (checked).

use gpu_amcs::engine::{CpuEvaluator, Evaluator, PickFreeze, Problem, Reference};
use gpu_amcs::gpu::{GpuEvaluator, GpuOptions};
use gpu_amcs::kinematics::{tx60, N_UNCERTAIN};
use gpu_amcs::mc::sensitivity::B_DRAW_OFFSET;
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
            let mut rows = vec![0.0; request.rows() * N_UNCERTAIN];
            for (r, row) in rows.chunks_exact_mut(N_UNCERTAIN).enumerate() {
                let (a, b, m) = request.row(r);
                let mut d = [0.0; N_UNCERTAIN];
                pb.sampler.pick_freeze_deltas(a, b, m, &mut d);
                row.copy_from_slice(&d);
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
    println!(
        "{label}: {rows} rows ({} matrices × {BASE_SAMPLES}), medians of {reps}: generated {g:.3} s \
         ({:.2e} rows/s), offset matrix {u:.3} s ({:.2e} rows/s), ratio {:.2}; per call: masks {} \
         B vs offsets {} B (f64; {} B as f32 on a GPU)",
        masks.len(),
        rows as f64 / g,
        rows as f64 / u,
        u / g,
        8 * masks.len(),
        8 * per_call * N_UNCERTAIN,
        4 * per_call * N_UNCERTAIN,
    );
}

fn main() {
    let reps: usize = std::env::var("BENCH_REPS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(5);
    let m = tx60();
    let pts = gpu_amcs::points::generate(&m, 50, &Default::default(), 2025).unwrap();
    let pb = Problem::new(m, &pts, &Reference::Calibrated, 2025).unwrap();
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
