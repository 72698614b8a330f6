//! What the measurement frame costs: a TX60 identified from 60 noisy poses in a tracker frame
//! (its covariance covers the placement: 39 × 39), analysed with the placement drawn (the
//! measurement frame) and without it (`Frame::Base`, the 33 × 33 block).
//!
//! `cargo bench --bench frames` prints medians of `BENCH_REPS` runs (default 7) of
//! - the CPU evaluator on 10^6 counter draws × 50 points (what `mcs` and `amcs` spend), and
//! - a Sobol analysis with N = 2^14 base samples (pick-freeze rows, what `sensitivity` spends),
//!
//! in each frame, and the ratio measurement / base of each median. Both frames run in one
//! process, interleaved, so the ratio is measured under the same load.

use gpu_amcs::engine::{CpuEvaluator, Frame, Problem, Reference};

use gpu_amcs::mc::sensitivity::{run_sensitivity, SensitivityOptions};
use std::time::Instant;

#[path = "support/identified.rs"]
mod identified;
use identified::{identified, interleaved_medians, median, reps};

fn main() {
    let reps = reps();
    let model = identified();
    assert!(model.base_uncertain(), "the placement is drawn");
    let pts = gpu_amcs::simulate::random_poses(&model, 50, 7);
    // The frame's own cost: the model's discrepancy term (noise unknown here, so the fit
    // carries one) is left out; `benches/discrepancy.rs` measures it.
    let measured = Problem::new(model, &pts, &Reference::Calibrated, 1)
        .unwrap()
        .without_discrepancy();
    let base = measured.clone().in_frame(Frame::Base);
    println!(
        "machine: {} threads; identified TX60, 50 points; medians of {reps} runs",
        rayon::current_num_threads()
    );

    let mut evs = [
        CpuEvaluator::new(measured.clone()),
        CpuEvaluator::new(base.clone()),
    ];
    let [m, b] = interleaved_medians(&mut evs, reps);
    println!(
        "mcs draws 10^6 × 50 points       measurement {m:.3} s  base {b:.3} s  ratio {:.2}",
        m / b
    );

    let opts = SensitivityOptions {
        draws: 1 << 14,
        ..SensitivityOptions::default()
    };
    let mut t = [Vec::new(), Vec::new()];
    for _ in 0..reps {
        for ((pb, ev), t) in [&measured, &base].iter().zip(&mut evs).zip(&mut t) {
            let s = Instant::now();
            let r = run_sensitivity(pb, ev, &opts).unwrap();
            t.push(s.elapsed().as_secs_f64());
            std::hint::black_box(r);
        }
    }
    let [m, b] = t.map(median);
    println!(
        "sensitivity N = 2^14, 50 points  measurement {m:.3} s  base {b:.3} s  ratio {:.2}",
        m / b
    );
}
