//! What the model-discrepancy term costs (issue target: at most 1.3× for `mcs` 10^6 × 50 on
//! the CPU): a TX60 identified from 60 poses with 20 µm noise in a tracker frame (noise not
//! stated, so the fit carries a discrepancy term drawn from its 60 residuals), analysed with
//! and without the term, in the measurement frame (placement drawn) and the base frame.
//!
//! `cargo bench --bench discrepancy` prints medians of `BENCH_REPS` runs (default 7) of the CPU
//! evaluator on 10^6 counter draws × 50 points, with and without the term, interleaved in one
//! process so that the ratios are measured under the same load.

use gpu_amcs::engine::{CpuEvaluator, Frame, Problem, Reference};

#[path = "support/identified.rs"]
mod identified;
use identified::{identified, interleaved_medians, reps};

fn main() {
    let reps = reps();
    let model = identified();
    assert!(model.discrepancy.is_some(), "the fit carries a term");
    let pts = gpu_amcs::simulate::random_poses(&model, 50, 7);
    let measured = Problem::new(model, &pts, &Reference::Calibrated, 1).unwrap();
    let base = measured.clone().in_frame(Frame::Base);
    println!(
        "machine: {} threads; identified TX60, 50 points, 10^6 draws; medians of {reps} runs",
        rayon::current_num_threads()
    );
    for (label, pb) in [("measurement frame", measured), ("base frame", base)] {
        let mut evs = [
            CpuEvaluator::new(pb.clone()),
            CpuEvaluator::new(pb.without_discrepancy()),
        ];
        let [with, without] = interleaved_medians(&mut evs, reps);
        println!(
            "mcs 10^6 × 50, {label:<17}  with the term {with:.3} s  without {without:.3} s  ratio {:.2}",
            with / without
        );
    }
}
