//! Joint errors beyond geometry (compliance, gear harmonics, payload; docs/METHOD.md §19):
//! what drawing them costs, what identifying them costs, and whether the payload what-if is
//! honest on simulated robots that carry the payload.
//!
//! `cargo bench --bench joint_errors` prints
//!
//! 1. medians of `BENCH_REPS` runs (default 7) of the CPU evaluator on 10^6 counter draws × 50
//!    points of a TX60 identified with `--beyond-geometry` (200 poses, 10 µm), with its joint
//!    errors drawn and with them left out (same mean chain), in the measurement and the base
//!    frame, interleaved in one process (issue target: at most 1.5×); built with the `gpu`
//!    feature and an adapter present, the same on the GPU evaluator first (wall and device
//!    time); then the same with a backlash of the IRB 120's size added to the model (drawn
//!    against left out with the joint errors); `BENCH_ONLY=cost` stops after these rows,
//!    `BENCH_ONLY=identify` runs only the next;
//! 2. the time of identifying 200 and 1000 poses with identify's defaults and with the explicit
//!    check beyond geometry (issue target for 1000: 1 s), medians of 3;
//! 3. the payload what-if on `BENCH_ROBOTS` robots (default 30): calibrated without a payload,
//!    then asked for w over 20 task poses with 5 kg at the tool; the PIT of each robot's true w
//!    in the predicted distribution (4000 draws), with the payload modelled and, for
//!    comparison, with the identified model's prediction at the calibration payload.

use gpu_amcs::engine::{CpuEvaluator, Evaluator, Frame, Problem, Reference};
use gpu_amcs::identify::chain::{chain_model, identify_chain, ChainOptions, MeasuredPoint};
use gpu_amcs::identify::{NominalPrior, PoseData};
use gpu_amcs::kinematics::{position, tx60, Joints, RobotModel};
use gpu_amcs::simulate::{
    random_placement, random_poses, simulate_poses_of, true_position, Experiment, NonGeometric,
    NonGeometricSizes, TrackerNoise,
};
use std::time::Instant;

#[path = "support/identified.rs"]
#[allow(dead_code)] // `identified()`: the joint errors need their own fit
mod identified;
use identified::{interleaved_medians, median, reps};

const SIZES: NonGeometricSizes = NonGeometricSizes {
    compliance: 1.0,
    harmonics: 1.0,
    payload_kg: 0.0,
    backlash: 0.0,
};

/// The GPU evaluator's cost of the joint errors, when a hardware or software adapter is present:
/// medians of `reps` interleaved runs of 10^6 counter draws × 50 points, wall time of the
/// evaluation and the device time of its passes (timestamp queries, when the adapter has them).
#[cfg(feature = "gpu")]
fn gpu_rows(with: &Problem, without: &Problem, label: &str, reps: usize) {
    use gpu_amcs::gpu::{self, GpuEvaluator, GpuOptions};
    if gpu::adapters().is_empty() {
        println!("GPU: no adapter found; GPU rows skipped");
        return;
    }
    let opts = GpuOptions {
        timestamps: true,
        prefetch: false,
        ..GpuOptions::default()
    };
    let (Ok(a), Ok(b)) = (
        GpuEvaluator::new(with.clone(), &opts),
        GpuEvaluator::new(without.clone(), &opts),
    ) else {
        println!("GPU: the evaluator did not open; GPU rows skipped");
        return;
    };
    let adapter = a.info().adapter;
    let mut evs = [a, b];
    let mut w = vec![0.0; 1_000_000];
    // One untimed run each: pipeline compilation and buffers.
    for ev in &mut evs {
        ev.evaluate(0, &mut w, None).unwrap();
    }
    let (mut wall, mut device) = ([Vec::new(), Vec::new()], [Vec::new(), Vec::new()]);
    for _ in 0..reps {
        for (k, ev) in evs.iter_mut().enumerate() {
            let s = Instant::now();
            ev.evaluate(0, &mut w, None).unwrap();
            wall[k].push(s.elapsed().as_secs_f64());
            if let Some(d) = ev.last_timings().device_s {
                device[k].push(d);
            }
        }
    }
    let [ww, wo] = wall.map(median);
    let dev = match device {
        [a, b] if !a.is_empty() && !b.is_empty() => {
            let (a, b) = (median(a), median(b));
            format!(
                ", device {:.2} ms vs {:.2} ms (ratio {:.2})",
                1e3 * a,
                1e3 * b,
                a / b
            )
        }
        _ => String::new(),
    };
    println!(
        "GPU ({adapter}) mcs 10^6 × 50, {label:<17}  with the joint errors {ww:.4} s  without {wo:.4} s  ratio {:.2}{dev}",
        ww / wo
    );
}

/// The first run of `data` as the whole-chain fit takes it.
fn points(data: &PoseData) -> Vec<MeasuredPoint> {
    data.runs[0]
        .points
        .iter()
        .map(|p| MeasuredPoint {
            q_deg: p.q_deg,
            position_mm: p.position_mm,
            sigma_mm: None,
            payload_kg: p.payload_kg,
            line: p.line,
            target: 0,
            sides: None,
        })
        .collect()
}

/// Robot `seed` (compliance and harmonics of a 60 kg-class arm), its errors and placement, and
/// its measured poses.
fn robot(
    seed: u64,
    n: usize,
) -> (
    RobotModel,
    NonGeometric,
    gpu_amcs::kinematics::BaseTransform,
    Vec<MeasuredPoint>,
) {
    let truth = Experiment::tx60(seed).truth;
    let errors = NonGeometric::draw(&truth, &SIZES, seed).expect("nonzero sizes");
    let placement = random_placement(seed);
    let configs = random_poses(&truth, n, seed + 1);
    let data = simulate_poses_of(
        &truth,
        Some(&errors),
        &configs,
        &placement,
        &TrackerNoise::Isotropic(0.01),
        seed + 2,
    );
    (truth, errors, placement, points(&data))
}

fn options() -> ChainOptions {
    ChainOptions {
        beyond_geometry: gpu_amcs::identify::JointErrorFit::On,
        ..ChainOptions::default()
    }
}

fn main() {
    let reps = reps();
    println!(
        "machine: {} threads; medians of {reps} runs",
        rayon::current_num_threads()
    );
    let only = std::env::var("BENCH_ONLY").unwrap_or_default();
    // 1. Cost of drawing them.
    if only != "identify" {
        draw_cost(reps);
    }
    if only == "cost" {
        return;
    }
    identify_cost();
    if only == "identify" {
        return;
    }
    // 3. The payload what-if against robots that carry the payload.
    let robots: u64 = std::env::var("BENCH_ROBOTS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(30);
    let (mut modelled, mut ignored) = (Vec::new(), Vec::new());
    for seed in 0..robots {
        let (truth, errors, placement, pts) = robot(100 + seed, 200);
        let r = identify_chain(
            &pts,
            &tx60(),
            None,
            Some(NominalPrior::default()),
            &options(),
        )
        .unwrap();
        let calibrated = chain_model(&tx60(), &r, "identified".into());
        let task = random_poses(&truth, 20, 400 + seed);
        let loaded = NonGeometric {
            payload_kg: 5.0,
            ..errors.clone()
        };
        let base = calibrated.base.expect("identified in a tracker frame");
        let w_true = task
            .iter()
            .map(|q| {
                let q: Joints = q.map(f64::to_radians);
                let t = placement.apply(true_position(&truth, Some(&loaded), &q));
                let p = base.apply(position(
                    &calibrated.params,
                    &calibrated.tool,
                    &calibrated.calibrated_chain_angles(&q),
                ));
                (0..3).map(|c| (t[c] - p[c]).powi(2)).sum::<f64>().sqrt()
            })
            .fold(0.0, f64::max);
        let mut heavy = calibrated.clone();
        if let Some(e) = heavy.joint_errors.as_mut() {
            e.payload.mass_kg = 5.0;
        }
        for (m, out) in [(heavy, &mut modelled), (calibrated, &mut ignored)] {
            let pb = Problem::new(m, &task, &Reference::Calibrated, 500 + seed).unwrap();
            let mut w = vec![0.0; 4000];
            CpuEvaluator::new(pb).evaluate(0, &mut w, None).unwrap();
            out.push(w.iter().filter(|&&x| x < w_true).count() as f64 / w.len() as f64);
        }
    }
    for (label, pits) in [
        ("payload modelled (5 kg)", &modelled),
        ("payload left out", &ignored),
    ] {
        let n = pits.len() as f64;
        let mean = pits.iter().sum::<f64>() / n;
        let share =
            |f: &dyn Fn(f64) -> bool| 100.0 * pits.iter().filter(|&&u| f(u)).count() as f64 / n;
        println!(
            "payload what-if, {robots} robots, {label:<24} PIT mean {mean:.3}, u ≥ 0.9 {:.0} %, u ≥ 0.99 {:.0} %, u ≤ 0.1 {:.0} %",
            share(&|u| u >= 0.9),
            share(&|u| u >= 0.99),
            share(&|u| u <= 0.1)
        );
    }
}

/// 1. The cost of drawing the joint errors (and a backlash) in the evaluators.
fn draw_cost(reps: usize) {
    let (_, _, _, pts) = robot(11, 200);
    let r = identify_chain(
        &pts,
        &tx60(),
        None,
        Some(NominalPrior::default()),
        &options(),
    )
    .unwrap();
    let model = chain_model(&tx60(), &r, "identified".into());
    assert!(
        model.joint_errors.is_some(),
        "the fit keeps its joint errors"
    );
    let task = random_poses(&model, 50, 7);
    // The same model with backlash of the IRB 120's size (docs/METHOD.md §19.5: gaps 0.061,
    // 0.028, 0.018° on J1–J3, the wrist's within 2σ of 0).
    let mut lash = model.clone();
    if let Some(e) = lash.joint_errors.as_mut() {
        e.backlash = Some(gpu_amcs::kinematics::Backlash {
            gap_rad: [0.061, 0.028, 0.018, 0.004, 0.004, 0.004]
                .iter()
                .map(|g: &f64| g.to_radians())
                .collect(),
            sigma_rad: vec![0.003f64.to_radians(); 6],
            sides_unknown: None,
        });
    }
    let measured = Problem::new(model, &task, &Reference::Calibrated, 1).unwrap();
    let lashed = Problem::new(lash, &task, &Reference::Calibrated, 1).unwrap();
    for (label, pb) in [
        ("measurement frame", measured.clone()),
        ("base frame", measured.in_frame(Frame::Base)),
        ("meas. + backlash", lashed.clone()),
        ("base + backlash", lashed.in_frame(Frame::Base)),
    ] {
        let mut without = pb.clone();
        without.joint_errors = None;
        #[cfg(feature = "gpu")]
        gpu_rows(&pb, &without, label, reps);
        let mut evs = [CpuEvaluator::new(pb), CpuEvaluator::new(without)];
        let [with, without] = interleaved_medians(&mut evs, reps);
        println!(
            "mcs 10^6 × 50, {label:<17}  with the joint errors {with:.3} s  without {without:.3} s  ratio {:.2}",
            with / without
        );
    }
}

/// 2. The cost of identifying them.
fn identify_cost() {
    // 2. Cost of identifying them: identify's defaults (the check when the geometric fit shows
    // a lack of fit) and the explicit check (which fits the backlash too).
    for n in [200, 1000] {
        let (_, _, _, pts) = robot(12, n);
        for (label, opts) in [
            ("identify's defaults", ChainOptions::default()),
            ("the explicit check", options()),
        ] {
            let t: Vec<f64> = (0..3)
                .map(|_| {
                    let s = Instant::now();
                    identify_chain(&pts, &tx60(), None, Some(NominalPrior::default()), &opts)
                        .unwrap();
                    s.elapsed().as_secs_f64()
                })
                .collect();
            println!("identify {n} poses, {label}: {:.2} s", median(t));
        }
    }
}
