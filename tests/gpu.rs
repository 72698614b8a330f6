//! GPU evaluator tests (run on Mesa lavapipe in CI): the shader validates with naga, the shader's
//! Philox reproduces the Random123 known answers, and GPU and CPU evaluators agree draw by draw,
//! per point and in the moments, for independent and correlated spreads, calibrated and nominal
//! references, a moved parameter mean, and split batches.
//!
//! Without any Vulkan/Metal/DX12 adapter the GPU tests print a skip note and pass, unless the
//! environment variable `CI` is `true`, where they fail.

mod common;

use gpu_amcs::engine::gpu::{self, philox_on_gpu, GpuEvaluator, GpuOptions};
use gpu_amcs::engine::{
    make_evaluator, BackendChoice, CpuEvaluator, Evaluator, Problem, Reference,
};
use gpu_amcs::kinematics::{tx60, RobotModel, Uncertainty, N_PARAMS};
use gpu_amcs::mc::Moments;
use gpu_amcs::sampling::{normals_block, philox4x32_10, Philox};

/// Largest allowed |e_gpu − e_cpu| per draw and point, mm (the module docs of
/// `engine::gpu` estimate ≲ 1e-5 mm at these spreads; measured ≤ 2.4e-7 mm on lavapipe).
const SAMPLE_TOL_MM: f64 = 1e-5;
/// Largest allowed relative difference of each of the four moments (the requirement is 1e-3;
/// measured ~2e-8 on lavapipe).
const MOMENT_TOL: f64 = 1e-5;

fn have_adapter(test: &str) -> bool {
    if !gpu::adapters().is_empty() {
        return true;
    }
    if std::env::var("CI").map(|v| v == "true").unwrap_or(false) {
        panic!("{test}: no Vulkan/Metal/DX12 adapter found and CI=true (install mesa-vulkan-drivers for lavapipe)");
    }
    eprintln!("{test}: skipped, no GPU adapter (set CI=true to make this a failure)");
    false
}

fn points(model: &RobotModel, n: usize) -> Vec<[f64; 6]> {
    gpu_amcs::points::generate(model, n, &Default::default(), 11).expect("points")
}

fn evaluate(ev: &mut dyn Evaluator, first: u64, n: usize) -> (Vec<f64>, Vec<f64>) {
    let m = ev.n_points();
    let mut w = vec![0.0; n];
    let mut e = vec![0.0; n * m];
    ev.evaluate(first, &mut w, Some(&mut e)).expect("evaluate");
    (w, e)
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// Mean, variance, skewness, kurtosis, as the library computes them.
fn moments(x: &[f64]) -> [f64; 4] {
    Moments::of(x).as_array()
}

/// Compares GPU and CPU on `n` draws from `first`; returns (max |Δw|, max |Δe|).
fn compare(problem: Problem, first: u64, n: usize, label: &str) -> (f64, f64) {
    let mut cpu = CpuEvaluator::new(problem.clone());
    let mut gpu = GpuEvaluator::new(problem, &GpuOptions::default()).expect("GPU evaluator");
    let (wc, ec) = evaluate(&mut cpu, first, n);
    let (wg, eg) = evaluate(&mut gpu, first, n);
    let (dw, de) = (max_diff(&wc, &wg), max_diff(&ec, &eg));
    let (mc, mg) = (moments(&wc), moments(&wg));
    let rel: Vec<f64> = mc
        .iter()
        .zip(&mg)
        .map(|(a, b)| ((a - b) / a).abs())
        .collect();
    eprintln!(
        "{label}: {n} draws, max |Δw| = {dw:.3e} mm, max |Δe_j| = {de:.3e} mm, \
         moments cpu {mc:.6?} gpu {mg:.6?}, relative differences {}",
        rel.iter()
            .map(|r| format!("{r:.2e}"))
            .collect::<Vec<_>>()
            .join(" ")
    );
    assert!(dw <= SAMPLE_TOL_MM, "{label}: max |Δw| {dw} mm");
    assert!(de <= SAMPLE_TOL_MM, "{label}: max |Δe| {de} mm");
    for (k, r) in rel.iter().enumerate() {
        assert!(*r <= MOMENT_TOL, "{label}: moment {} differs by {r}", k + 1);
    }
    (dw, de)
}

fn correlated_tx60() -> RobotModel {
    let mut m = tx60();
    let s = m.uncertainty.sigmas();
    let mut c = vec![0.0; N_PARAMS * N_PARAMS];
    for i in 0..N_PARAMS {
        c[i * N_PARAMS + i] = s[i] * s[i];
    }
    // θ2–θ3 and a2–α2 strongly, d1–d4 mildly correlated.
    for (i, j, rho) in [(5, 10, 0.8), (7, 8, -0.6), (1, 16, 0.3)] {
        c[i * N_PARAMS + j] = rho * s[i] * s[j];
        c[j * N_PARAMS + i] = c[i * N_PARAMS + j];
    }
    m.uncertainty = Uncertainty::Covariance(c);
    m
}

#[test]
fn shaders_validate_with_naga() {
    for (name, src) in [
        ("evaluator", gpu::shader_source()),
        ("philox test", gpu::philox_test_source()),
    ] {
        let module = naga::front::wgsl::parse_str(&src)
            .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(&src)));
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::default(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{name}: {e:?}"));
    }
}

#[test]
fn shader_philox_matches_known_answers_and_cpu_normals() {
    if !have_adapter("shader_philox_matches_known_answers_and_cpu_normals") {
        return;
    }
    let mut cases = vec![
        ([0u32; 4], [0u32; 2]),
        ([u32::MAX; 4], [u32::MAX; 2]),
        (
            [0x243f6a88, 0x85a308d3, 0x13198a2e, 0x03707344],
            [0xa4093822, 0x299f31d0],
        ),
    ];
    let g = Philox::new(0x0123_4567_89ab_cdef);
    for k in 0..2000u64 {
        let draw = k.wrapping_mul(0x9E37_79B9_7F4A_7C15);
        cases.push(([draw as u32, (draw >> 32) as u32, (k % 8) as u32, 0], g.key));
    }
    let out = philox_on_gpu(None, &cases).expect("philox kernel");
    let kat = [
        [0x6627e8d5, 0xe169c58d, 0xbc57ac4c, 0x9b00dbd8],
        [0x408f276d, 0x41c83b0e, 0xa20bc7c6, 0x6d5451fd],
        [0xd16cfe09, 0x94fdcceb, 0x5001e420, 0x24126ea1],
    ];
    for (i, want) in kat.iter().enumerate() {
        assert_eq!(&out[i].0, want, "KAT {i}");
    }
    let mut worst: f64 = 0.0;
    for ((c, k), (words, z)) in cases.iter().zip(&out) {
        assert_eq!(*words, philox4x32_10(*c, *k));
        if *k == g.key {
            let draw = u64::from(c[0]) | (u64::from(c[1]) << 32);
            let zc = normals_block(&g, draw, c[2], c[3]);
            for q in 0..4 {
                worst = worst.max((f64::from(z[q]) - zc[q]).abs() / (1.0 + zc[q].abs()));
            }
        }
    }
    eprintln!("normals: max |z_gpu − z_cpu|/(1+|z|) = {worst:.2e}");
    assert!(worst < 1e-6, "normals differ by {worst}");
}

#[test]
fn gpu_matches_cpu_independent() {
    if !have_adapter("gpu_matches_cpu_independent") {
        return;
    }
    let m = tx60();
    let pts = points(&m, 50);
    let pb = Problem::new(m, &pts, &Reference::Calibrated, 20240601).expect("problem");
    // Crosses a 2^32 boundary of the draw index (carry into the high counter word).
    compare(pb, (1u64 << 32) - 30_000, 60_000, "independent");
}

#[test]
fn gpu_matches_cpu_correlated() {
    if !have_adapter("gpu_matches_cpu_correlated") {
        return;
    }
    let m = correlated_tx60();
    let pts = points(&m, 30);
    let pb = Problem::new(m, &pts, &Reference::Calibrated, 7).expect("problem");
    compare(pb, 123_456, 40_000, "correlated");
}

#[test]
fn gpu_matches_cpu_nominal_reference() {
    if !have_adapter("gpu_matches_cpu_nominal_reference") {
        return;
    }
    let nominal = tx60();
    let mut calibrated = tx60();
    calibrated.params[7] += 0.35; // a2, mm
    calibrated.params[13] += 0.002; // α3, rad
    calibrated.params[0] -= 0.001; // θ1, rad
    let pts = points(&calibrated, 30);
    let pb = Problem::new(calibrated, &pts, &Reference::Nominal(Box::new(nominal)), 99)
        .expect("problem");
    compare(pb, 0, 40_000, "nominal reference");
}

#[test]
fn moved_parameter_mean_moves_gpu_like_cpu() {
    if !have_adapter("moved_parameter_mean_moves_gpu_like_cpu") {
        return;
    }
    let base = tx60();
    let mut moved = tx60();
    moved.params[18] += 0.004; // α4, rad: changes the shader's joint constants
    moved.params[16] += 0.2; // d4, mm
    let pts = points(&base, 20);
    let n = 20_000;
    let run = |model: RobotModel| {
        let pb =
            Problem::new(model, &pts, &Reference::Nominal(Box::new(tx60())), 5).expect("problem");
        let (wc, _) = evaluate(&mut CpuEvaluator::new(pb.clone()), 0, n);
        let mut g = GpuEvaluator::new(pb, &GpuOptions::default()).expect("GPU evaluator");
        let (wg, _) = evaluate(&mut g, 0, n);
        (wc, wg)
    };
    let (c0, g0) = run(base);
    let (c1, g1) = run(moved);
    let shift_cpu = c1.iter().zip(&c0).map(|(a, b)| a - b).collect::<Vec<_>>();
    let shift_gpu = g1.iter().zip(&g0).map(|(a, b)| a - b).collect::<Vec<_>>();
    let mean_shift = shift_cpu.iter().sum::<f64>() / n as f64;
    let d = max_diff(&shift_cpu, &shift_gpu);
    eprintln!(
        "moved mean: mean shift of w {mean_shift:.4} mm, max |shift_gpu − shift_cpu| = {d:.3e} mm"
    );
    assert!(mean_shift.abs() > 0.05, "the perturbation should move w");
    assert!(d <= 2.0 * SAMPLE_TOL_MM);
}

#[test]
fn split_batches_equal_one_batch() {
    if !have_adapter("split_batches_equal_one_batch") {
        return;
    }
    let m = tx60();
    let pts = points(&m, 10);
    let pb = Problem::new(m, &pts, &Reference::Calibrated, 3).expect("problem");
    let n = 10_000;
    let mut whole = GpuEvaluator::new(pb.clone(), &GpuOptions::default()).expect("GPU");
    let small = GpuOptions {
        chunk: 999,
        ..GpuOptions::default()
    };
    let mut split = GpuEvaluator::new(pb, &small).expect("GPU");
    assert_eq!(split.chunk_sizes().0, 999);
    let (w1, e1) = evaluate(&mut whole, 77, n);
    let (w2, e2) = evaluate(&mut split, 77, n);
    // Per-point requests are not followed by a speculative chunk.
    assert_eq!(split.last_timings().chunks, n.div_ceil(999));
    assert_eq!(w1, w2);
    assert_eq!(e1, e2);
    // Without per-point output, and as two requests.
    let mut w3 = vec![0.0; n];
    split.evaluate(77, &mut w3[..4321], None).expect("evaluate");
    split
        .evaluate(77 + 4321, &mut w3[4321..], None)
        .expect("evaluate");
    assert_eq!(w1, w3);
    // The second request started from the speculative chunk of the first.
    assert_eq!(split.last_timings().prefetch_hits, 1);
    // A request elsewhere discards the speculative chunk and is still right.
    let mut w4 = vec![0.0; 500];
    split.evaluate(77 + 100, &mut w4, None).expect("evaluate");
    assert_eq!(split.last_timings().prefetch_hits, 0);
    assert_eq!(&w1[100..600], &w4[..]);
}

#[test]
fn consecutive_batches_with_prefetch_equal_one_batch() {
    if !have_adapter("consecutive_batches_with_prefetch_equal_one_batch") {
        return;
    }
    let m = tx60();
    let pts = points(&m, 10);
    let pb = Problem::new(m, &pts, &Reference::Calibrated, 8).expect("problem");
    let (batch, batches) = (1_000, 20);
    let mut plain = GpuEvaluator::new(
        pb.clone(),
        &GpuOptions {
            prefetch: false,
            ..GpuOptions::default()
        },
    )
    .expect("GPU");
    let mut all = vec![0.0; batch * batches];
    plain.evaluate(1 << 40, &mut all, None).expect("evaluate");
    let mut ev = GpuEvaluator::new(pb, &GpuOptions::default()).expect("GPU");
    let mut hits = 0;
    for b in 0..batches {
        let mut w = vec![0.0; batch];
        ev.evaluate((1 << 40) + (b * batch) as u64, &mut w, None)
            .expect("evaluate");
        hits += ev.last_timings().prefetch_hits;
        assert_eq!(&all[b * batch..(b + 1) * batch], &w[..], "batch {b}");
    }
    assert_eq!(hits, batches - 1);
}

#[test]
fn backend_choice_and_errors() {
    assert_eq!("GPU".parse::<BackendChoice>(), Ok(BackendChoice::Gpu));
    assert!("tpu".parse::<BackendChoice>().is_err());
    let m = tx60();
    let pts = points(&m, 3);
    let pb = Problem::new(m, &pts, &Reference::Calibrated, 1).expect("problem");
    let (ev, _) = make_evaluator(pb.clone(), BackendChoice::Cpu, None).expect("cpu");
    assert_eq!(ev.info().backend, "cpu");
    // An adapter name that matches nothing is an error, not a panic.
    let r = make_evaluator(pb.clone(), BackendChoice::Gpu, Some("no-such-adapter-xyz"));
    match r {
        Err(e) => eprintln!("expected error: {e}"),
        Ok(_) => panic!("a non-matching adapter name must fail"),
    }
    let (ev, note) = make_evaluator(pb.clone(), BackendChoice::Auto, None).expect("auto");
    eprintln!("auto: {:?} note {note:?}", ev.info());
    if !have_adapter("backend_choice_and_errors") {
        return;
    }
    assert!(!gpu_amcs::engine::list_adapters().is_empty());
    let (ev, note) = make_evaluator(pb, BackendChoice::Gpu, None).expect("gpu");
    let info = ev.info();
    eprintln!("gpu: {info:?} note {note:?}");
    assert_eq!(info.backend, "gpu");
    assert!(!info.adapter.is_empty());
}

/// The main job on `--backend gpu` and `--backend cpu`: same batches and draws, the same report
/// within the per-sample bound (1e-5 mm), reliabilities equal unless a draw lies within that
/// bound of a threshold.
#[test]
fn main_job_gpu_report_equals_cpu_report() {
    if !have_adapter("main_job_gpu_report_equals_cpu_report") {
        return;
    }
    let dir = common::tmpdir("gpu-cli");
    let run = |backend: &str| -> serde_json::Value {
        let f = dir.join(format!("{backend}.json"));
        let o = common::run(&[
            "--points",
            "50",
            "--delta",
            "0.01",
            "--quiet",
            "--backend",
            backend,
            "--json",
            f.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", common::stderr(&o));
        serde_json::from_str::<serde_json::Value>(&std::fs::read_to_string(f).unwrap()).unwrap()
            ["result"]
            .clone()
    };
    let (g, c) = (run("gpu"), run("cpu"));
    assert_eq!(g["backend"]["backend"], "gpu");
    assert_eq!(c["backend"]["backend"], "cpu");
    assert_eq!(g["draws"], c["draws"]);
    assert_eq!(g["batches"], c["batches"]);
    let f = |v: &serde_json::Value| v.as_f64().unwrap();
    for k in ["estimate", "std_uncertainty", "min", "max"] {
        assert!((f(&g[k]) - f(&c[k])).abs() < 1e-5, "{k}");
    }
    for k in ["low", "high"] {
        assert!(
            (f(&g["coverage_interval"][k]) - f(&c["coverage_interval"][k])).abs() < 1e-5,
            "{k}"
        );
    }
    for k in ["mean", "variance", "skewness", "kurtosis"] {
        let (a, b) = (f(&g["moments"][k]), f(&c["moments"][k]));
        assert!(((a - b) / b).abs() < 1e-4, "{k}: {a} vs {b}");
    }
    for (a, b) in g["reliability"]
        .as_array()
        .unwrap()
        .iter()
        .zip(c["reliability"].as_array().unwrap())
    {
        assert!(
            (f(&a["r"]) - f(&b["r"])).abs() <= 2.0 / f(&g["draws"]),
            "{a} vs {b}"
        );
    }
    for (a, b) in g["trace"]
        .as_array()
        .unwrap()
        .iter()
        .zip(c["trace"].as_array().unwrap())
    {
        for k in ["mean", "std_uncertainty", "low", "high"] {
            assert!((f(&a[k]) - f(&b[k])).abs() < 1e-5, "trace {k}");
        }
    }
}
