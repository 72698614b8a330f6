//! Sobol indices against known answers: the Ishigami function and a linear additive model
//! through the generic pick-freeze core, the robot with only θ1 and d1 uncertain against 2-D
//! Gauss–Hermite quadrature (independent and correlated), CPU against GPU, the failure
//! indicator, and bad input as typed errors naming the field.
//!
//! Tolerances: an estimate must lie within 4 of its own bootstrap standard errors of the
//! analytic value (a normal deviation beyond 4 sd has probability 6e-5 per index), plus, for
//! the robot, the quadrature error (estimated by comparing two quadrature orders).
//!
//! Over 600 lines: the known-answer models and the quadrature they are checked against belong together.

use crate::common;

#[cfg(feature = "gpu")]
use common::have_adapter;

use gpu_amcs::engine::{CpuEvaluator, Evaluator, Problem, Reference};
#[cfg(feature = "gpu")]
use gpu_amcs::gpu::{GpuEvaluator, GpuOptions};
use gpu_amcs::kinematics::{param_index, tx60, Layout, ParamKind, RobotModel, Uncertainty};
use gpu_amcs::mc::sensitivity::{
    pick_freeze, run_sensitivity, InputGroup, InputKind, Quantity, QuantityIndices,
    SensitivityError, SensitivityOptions, SensitivitySetting, SobolIndex,
};
use gpu_amcs::sampling::{normals_block, uniform_open, Philox};

/// The six-joint TX60's parameter count (30).
const N_PARAMS: usize = Layout::SIX.n_params();

/// Standard errors an estimate may be from the analytic value.
const K_SE: f64 = 4.0;

fn opts(draws: usize) -> SensitivityOptions {
    SensitivityOptions {
        draws,
        bootstrap: 200,
        bootstrap_seed: 5,
        chunk: 1024,
        thresholds: Vec::new(),
    }
}

fn find<'a>(v: &'a [SobolIndex], name: &str) -> &'a SobolIndex {
    v.iter()
        .find(|x| x.name == name)
        .unwrap_or_else(|| panic!("no index {name}"))
}

/// Asserts first-order and total index of `name` within `K_SE` bootstrap standard errors
/// (plus `extra`) of the given values.
fn check(v: &[SobolIndex], name: &str, s1: f64, st: f64, extra: f64) {
    let x = find(v, name);
    for (what, e, truth) in [("S1", x.first_order, s1), ("ST", x.total, st)] {
        let se = e.std_error.expect("bootstrap standard error");
        let (lo, hi) = (e.ci_low.unwrap(), e.ci_high.unwrap());
        assert!(lo <= e.value && e.value <= hi, "{name} {what}: {e:?}");
        assert!(
            (e.value - truth).abs() <= K_SE * se + extra,
            "{name} {what} = {} ± {se}, expected {truth} (± {extra})",
            e.value
        );
    }
}

fn names(d: usize) -> Vec<String> {
    (1..=d).map(|i| format!("x{i}")).collect()
}

/// Ishigami f = sin x1 + a sin² x2 + b x3⁴ sin x1, x_i uniform on (−π, π), with a = 7,
/// b = 0.1.
const ISHIGAMI: (f64, f64) = (7.0, 0.1);

/// Analytic `[S1, S2, S3, ST1, ST2, ST3]` of the Ishigami function (Sobol' & Levitan 1999):
/// V = a²/8 + bπ⁴/5 + b²π⁸/18 + 1/2, V1 = (1 + bπ⁴/5)²/2, V2 = a²/8, V13 = b²π⁸(1/18 − 1/50).
fn ishigami_indices() -> [f64; 6] {
    let (a, b) = ISHIGAMI;
    let pi4 = std::f64::consts::PI.powi(4);
    let v = a * a / 8.0 + b * pi4 / 5.0 + b * b * pi4 * pi4 / 18.0 + 0.5;
    let v1 = (1.0 + b * pi4 / 5.0).powi(2) / 2.0;
    let v2 = a * a / 8.0;
    let v13 = b * b * pi4 * pi4 * (1.0 / 18.0 - 1.0 / 50.0);
    [v1 / v, v2 / v, 0.0, (v1 + v13) / v, v2 / v, v13 / v]
}

/// Ishigami indices estimated from `draws` base samples of the Philox stream `seed`.
fn ishigami_run(seed: u64, o: &SensitivityOptions) -> QuantityIndices {
    let (a, b) = ISHIGAMI;
    let gen = Philox::new(seed);
    let draw = |k: u64, x: &mut [f64]| {
        let w = gen.block(k, 0, 0);
        for i in 0..3 {
            x[i] = std::f64::consts::PI * (2.0 * uniform_open(w[i]) - 1.0);
        }
    };
    let model = |rows: &[f64]| {
        Ok(rows
            .chunks(3)
            .map(|x| x[0].sin() + a * x[1].sin().powi(2) + b * x[2].powi(4) * x[0].sin())
            .collect())
    };
    let r = pick_freeze(&names(3), &[], draw, model, o).unwrap();
    assert_eq!(r.evaluations, o.draws as u64 * 5);
    r.quantities[0].clone()
}

#[test]
fn ishigami_known_indices() {
    let s = ishigami_indices();
    let expected = [0.3139, 0.4424, 0.0, 0.5576, 0.4424, 0.2437];
    for (x, e) in s.iter().zip(expected) {
        assert!((x - e).abs() < 1e-4, "{s:?}");
    }
    let q = ishigami_run(42, &opts(1 << 14));
    for i in 0..3 {
        check(&q.inputs, &format!("x{}", i + 1), s[i], s[3 + i], 0.0);
    }
    // Ranked by total index: x1, x2, x3.
    let order: Vec<&str> = q.inputs.iter().map(|x| x.name.as_str()).collect();
    assert_eq!(order, ["x1", "x2", "x3"]);
}

/// Over 40 independent seeds the estimates scatter about the analytic indices with the spread
/// the bootstrap claims: the empirical standard deviation of 40 values is within ±11 % (one
/// standard error, 1/√(2·39)) of the true one, so the ratio to the mean bootstrap standard
/// error must lie within a factor 1.5 (about 4 of those standard errors); the mean of the 40
/// estimates lies within 4 sd/√40 of the truth (the estimators are unbiased up to O(1/N)).
#[test]
fn bootstrap_standard_errors_are_honest() {
    let truth = ishigami_indices();
    let seeds = 40;
    let mut est = vec![Vec::new(); 6];
    let mut se = [0.0; 6];
    for seed in 0..seeds {
        let o = SensitivityOptions {
            bootstrap: 100,
            bootstrap_seed: seed,
            ..opts(1 << 10)
        };
        let q = ishigami_run(1000 + seed, &o);
        for i in 0..3 {
            let x = find(&q.inputs, &format!("x{}", i + 1));
            for (j, e) in [(i, x.first_order), (3 + i, x.total)] {
                est[j].push(e.value);
                se[j] += e.std_error.unwrap() / seeds as f64;
            }
        }
    }
    for j in 0..6 {
        let n = seeds as f64;
        let mean = est[j].iter().sum::<f64>() / n;
        let sd = (est[j].iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let ratio = sd / se[j];
        assert!(
            (1.0 / 1.5..=1.5).contains(&ratio),
            "index {j}: empirical sd {sd:.4}, bootstrap se {:.4}",
            se[j]
        );
        assert!(
            (mean - truth[j]).abs() <= 4.0 * sd / n.sqrt(),
            "index {j}: mean {mean:.4} of {seeds} seeds, truth {:.4}, sd {sd:.4}",
            truth[j]
        );
    }
}

/// y = Σ c_i u_i with independent standard normals: S_i = S_T,i = c_i² / Σ c²; a group's
/// closed index is the sum over its members.
#[test]
fn linear_additive_known_indices() {
    let c = [1.0, 2.0, 3.0, 0.5];
    let gen = Philox::new(7);
    let draw = |k: u64, u: &mut [f64]| u.copy_from_slice(&normals_block(&gen, k, 0, 0));
    let model = |rows: &[f64]| {
        Ok(rows
            .chunks(4)
            .map(|u| u.iter().zip(&c).map(|(x, c)| x * c).sum())
            .collect())
    };
    let groups = [InputGroup {
        name: "first two".into(),
        members: vec![1, 0],
    }];
    let r = pick_freeze(&names(4), &groups, draw, model, &opts(1 << 13)).unwrap();
    assert_eq!((r.pick_freeze_matrices, r.evaluations), (5, (1 << 13) * 7));
    let q = &r.quantities[0];
    let v: f64 = c.iter().map(|c| c * c).sum();
    for (i, ci) in c.iter().enumerate() {
        let s = ci * ci / v;
        check(&q.inputs, &format!("x{}", i + 1), s, s, 0.0);
    }
    let s = (c[0] * c[0] + c[1] * c[1]) / v;
    check(&q.groups, "first two", s, s, 0.0);
    assert_eq!(q.groups[0].members, ["x1", "x2"]);
}

/// Nodes and probability weights of the n-point Gauss–Hermite rule for the standard normal
/// (Golub–Welsch: eigen-decomposition of the Jacobi matrix with off-diagonal √k).
fn gauss_hermite(n: usize) -> Vec<(f64, f64)> {
    let j = nalgebra::DMatrix::from_fn(n, n, |a, b| {
        if a + 1 == b || b + 1 == a {
            (a.max(b) as f64).sqrt()
        } else {
            0.0
        }
    });
    let e = nalgebra::SymmetricEigen::new(j);
    (0..n)
        .map(|i| (e.eigenvalues[i], e.eigenvectors[(0, i)].powi(2)))
        .collect()
}

/// First-order indices of w(z1, z2) over two independent standard normals by an n × n
/// Gauss–Hermite rule, `w` from the kinematics (`Problem::point_errors`).
fn quadrature_indices(
    pb: &Problem,
    n: usize,
    delta: &dyn Fn(f64, f64) -> [f64; N_PARAMS],
) -> [f64; 2] {
    let rule = gauss_hermite(n);
    let w: Vec<Vec<f64>> = rule
        .iter()
        .map(|&(x, _)| {
            rule.iter()
                .map(|&(y, _)| {
                    let d = delta(x, y);
                    let p: [f64; N_PARAMS] = std::array::from_fn(|i| pb.model.params[i] + d[i]);
                    pb.point_errors(&p).into_iter().fold(0.0, f64::max)
                })
                .collect()
        })
        .collect();
    let mean: f64 = (0..n)
        .map(|i| (0..n).map(|j| rule[i].1 * rule[j].1 * w[i][j]).sum::<f64>())
        .sum();
    let m2: f64 = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| rule[i].1 * rule[j].1 * w[i][j].powi(2))
                .sum::<f64>()
        })
        .sum();
    let var = m2 - mean * mean;
    let cond1: f64 = (0..n)
        .map(|i| rule[i].1 * (0..n).map(|j| rule[j].1 * w[i][j]).sum::<f64>().powi(2))
        .sum();
    let cond2: f64 = (0..n)
        .map(|j| rule[j].1 * (0..n).map(|i| rule[i].1 * w[i][j]).sum::<f64>().powi(2))
        .sum();
    [(cond1 - mean * mean) / var, (cond2 - mean * mean) / var]
}

/// The covariance of standard deviations `s` with correlations `(i, j, ρ_ij)`.
fn covariance(s: &[f64], corr: &[(usize, usize, f64)]) -> Uncertainty {
    let mut c = vec![0.0; N_PARAMS * N_PARAMS];
    for (i, si) in s.iter().enumerate() {
        c[i * N_PARAMS + i] = si * si;
    }
    for &(i, j, rho) in corr {
        c[i * N_PARAMS + j] = rho * s[i] * s[j];
        c[j * N_PARAMS + i] = rho * s[i] * s[j];
    }
    Uncertainty::from_matrix(gpu_amcs::kinematics::InputSpace::parameters(6), c)
}

/// σ(θ1) = 5e-5 rad (0.03 mm at 600 mm) and σ(d1) = 0.03 mm: both matter.
const SIGMA_THETA1: f64 = 5e-5;
const SIGMA_D1: f64 = 0.03;

fn theta1_d1_problem(correlation: Option<f64>) -> Problem {
    let mut m = tx60();
    let (t, d) = (
        param_index(0, ParamKind::Theta),
        param_index(0, ParamKind::D),
    );
    let mut s = [0.0; N_PARAMS];
    s[t] = SIGMA_THETA1;
    s[d] = SIGMA_D1;
    m.uncertainty = match correlation {
        None => Uncertainty::Independent(s.into()),
        Some(rho) => covariance(&s, &[(t, d, rho)]),
    };
    let pts = gpu_amcs::points::generate(&m, 8, &Default::default(), 3).unwrap();
    Problem::new(m, &pts, &Reference::Calibrated, 2024).unwrap()
}

/// Compares the pick-freeze indices of θ1 and d1 with quadrature; `delta(z1, z2)` maps the
/// two independent normals (the inputs) to parameter offsets.
fn robot_against_quadrature(
    pb: &Problem,
    delta: &dyn Fn(f64, f64) -> [f64; N_PARAMS],
) -> QuantityIndices {
    let coarse = quadrature_indices(pb, 40, delta);
    let fine = quadrature_indices(pb, 80, delta);
    let qerr = (0..2)
        .map(|i| (fine[i] - coarse[i]).abs())
        .fold(0.0, f64::max);
    assert!(qerr < 0.01, "quadrature not converged: {coarse:?} {fine:?}");
    let o = opts(1 << 13);
    let r = run_sensitivity(pb, &mut CpuEvaluator::new(pb.clone()), &o).unwrap();
    assert_eq!(r.parameters, ["theta1", "d1"]);
    assert_eq!(r.skipped_parameters.len(), N_PARAMS - 2);
    // A, B, θ1, d1 and joint 1 = {θ1, d1}; the kind groups reuse the single inputs.
    assert_eq!(r.analysis.evaluations, 5 << 13);
    let q = r.w().clone();
    eprintln!(
        "quadrature S = {fine:?} (40 vs 80 nodes: {qerr:.1e}); pick-freeze S = {:.4}, {:.4}",
        find(&q.inputs, "theta1").first_order.value,
        find(&q.inputs, "d1").first_order.value
    );
    // S_T of one of two inputs is 1 − S of the other.
    check(&q.inputs, "theta1", fine[0], 1.0 - fine[1], qerr);
    check(&q.inputs, "d1", fine[1], 1.0 - fine[0], qerr);
    check(&q.groups, "joint 1", 1.0, 1.0, 0.0);
    check(&q.groups, "joint angles θ", fine[0], 1.0 - fine[1], qerr);
    q
}

#[test]
fn robot_theta1_d1_matches_quadrature() {
    let pb = theta1_d1_problem(None);
    let (t, d) = (
        param_index(0, ParamKind::Theta),
        param_index(0, ParamKind::D),
    );
    let q = robot_against_quadrature(&pb, &|x, y| {
        let mut o = [0.0; N_PARAMS];
        o[t] = SIGMA_THETA1 * x;
        o[d] = SIGMA_D1 * y;
        o
    });
    // Both matter, and neither explains everything.
    let s = find(&q.inputs, "theta1").first_order.value;
    assert!(s > 0.2 && s < 0.8, "S(theta1) = {s}");
}

/// A correlated θ1/d1 pair (ρ = 0.6): the inputs are the Cholesky innovations, δθ = σθ u1,
/// δd = σd (ρ u1 + √(1 − ρ²) u2).
#[test]
fn robot_correlated_uses_cholesky_innovations() {
    let rho: f64 = 0.6;
    let pb = theta1_d1_problem(Some(rho));
    let (t, d) = (
        param_index(0, ParamKind::Theta),
        param_index(0, ParamKind::D),
    );
    robot_against_quadrature(&pb, &|x, y| {
        let mut o = [0.0; N_PARAMS];
        o[t] = SIGMA_THETA1 * x;
        o[d] = SIGMA_D1 * (rho * x + (1.0 - rho * rho).sqrt() * y);
        o
    });
    let o = SensitivityOptions {
        bootstrap: 100,
        ..opts(1 << 8)
    };
    let r = run_sensitivity(&pb, &mut CpuEvaluator::new(pb.clone()), &o).unwrap();
    assert_eq!(r.input_kind, InputKind::CholeskyInnovations);
    let json = serde_json::to_string(&r).unwrap();
    assert!(json.contains("\"input_kind\":\"Cholesky innovations (correlated model)\""));
}

/// A diagonal covariance gives the same draws as the σ list, so the same indices; only the
/// stated input kind differs.
#[test]
fn diagonal_covariance_gives_the_independent_indices() {
    let m = tx60();
    let s = m.param_sigmas();
    let mut mc = m.clone();
    mc.uncertainty = covariance(&s, &[]);
    let o = SensitivityOptions {
        bootstrap: 100,
        ..opts(1 << 8)
    };
    let run = |m: RobotModel| {
        let pts = gpu_amcs::points::generate(&m, 5, &Default::default(), 1).unwrap();
        let pb = Problem::new(m, &pts, &Reference::Calibrated, 9).unwrap();
        run_sensitivity(&pb, &mut CpuEvaluator::new(pb.clone()), &o).unwrap()
    };
    let (a, b) = (run(m), run(mc));
    assert_eq!(a.input_kind, InputKind::IndependentParameters);
    assert_eq!(b.input_kind, InputKind::CholeskyInnovations);
    assert_eq!(a.parameters, b.parameters);
    assert_eq!(a.parameters.len(), 20);
    assert_eq!(a.analysis.evaluations, 256 * (20 + 2 + 8));
    let (qa, qb) = (&a.analysis.quantities[0], &b.analysis.quantities[0]);
    for x in &qa.inputs {
        let y = find(&qb.inputs, &x.name);
        assert!((x.first_order.value - y.first_order.value).abs() < 1e-9);
        assert!((x.total.value - y.total.value).abs() < 1e-9);
    }
}

/// The failure indicator at the median of w has indices; at a threshold no draw reaches it has
/// a note and none (never a NaN).
#[test]
fn failure_indicator() {
    let pb = theta1_d1_problem(None);
    let mut ev = CpuEvaluator::new(pb.clone());
    let mut o = opts(1 << 10);
    let r = run_sensitivity(&pb, &mut ev, &o).unwrap();
    let w = &r.analysis.quantities[0];
    o.thresholds = vec![w.mean, 100.0];
    let r = run_sensitivity(&pb, &mut ev, &o).unwrap();
    assert_eq!(r.analysis.quantities.len(), 3);
    let mid = &r.analysis.quantities[1];
    assert_eq!(mid.quantity, Quantity::Exceedance { threshold: w.mean });
    assert!(mid.mean > 0.2 && mid.mean < 0.8, "P = {}", mid.mean);
    assert_eq!(mid.inputs.len(), 2);
    assert!(mid.bootstrap_valid == o.bootstrap);
    let none = &r.analysis.quantities[2];
    assert_eq!((none.mean, none.variance), (0.0, 0.0));
    assert!(none.inputs.is_empty() && none.note.is_some());
    assert!(mid.note.is_none(), "{:?}", mid.note);
    // A threshold only a few draws reach: indices, with a note that they rest on few events.
    let mut all: Vec<f64> = Vec::new();
    let mut w = vec![0.0; 4096];
    ev.evaluate(0, &mut w, None).unwrap();
    all.extend(&w);
    all.sort_by(f64::total_cmp);
    o.thresholds = vec![all[4096 - 20]];
    let r = run_sensitivity(&pb, &mut ev, &o).unwrap();
    let rare = &r.analysis.quantities[1];
    assert_eq!(rare.inputs.len(), 2);
    assert!(
        rare.note.as_deref().unwrap_or("").contains("few events"),
        "{rare:?}"
    );
    // Every number reported is finite (serde_json would write a NaN as null).
    for q in &r.analysis.quantities {
        assert!(q.mean.is_finite() && q.variance.is_finite());
        for x in q.inputs.iter().chain(&q.groups) {
            for e in [x.first_order, x.total] {
                let ci = [e.ci_low, e.ci_high, e.std_error];
                assert!(e.value.is_finite() && ci.iter().all(|v| v.is_some_and(f64::is_finite)));
            }
        }
    }
    // Evaluation count does not change with thresholds: the indicators reuse the w values.
    assert_eq!(r.analysis.evaluations, 5 << 10);
}

#[test]
fn bad_input_is_a_typed_error() {
    let pb = theta1_d1_problem(None);
    let mut ev = CpuEvaluator::new(pb.clone());
    let field = |o: SensitivityOptions, ev: &mut CpuEvaluator| match run_sensitivity(&pb, ev, &o) {
        Err(SensitivityError::Setting { field, message }) => {
            assert!(!message.contains("--"), "{message}");
            field
        }
        r => panic!("{:?}", r.map(|_| ())),
    };
    assert_eq!(field(opts(1000), &mut ev), SensitivitySetting::Draws);
    assert_eq!(field(opts(16), &mut ev), SensitivitySetting::Draws);
    let t = SensitivityOptions {
        thresholds: vec![0.0],
        ..opts(64)
    };
    assert_eq!(field(t, &mut ev), SensitivitySetting::Thresholds);
    let mut m = tx60();
    m.uncertainty = Uncertainty::Independent([0.0; N_PARAMS].into());
    let pts = gpu_amcs::points::generate(&m, 3, &Default::default(), 1).unwrap();
    let pb0 = Problem::new(m, &pts, &Reference::Calibrated, 1).unwrap();
    let e = run_sensitivity(&pb0, &mut CpuEvaluator::new(pb0.clone()), &opts(64)).unwrap_err();
    assert!(matches!(e, SensitivityError::NoFreeParameter { .. }), "{e}");
    // An evaluator built for another problem.
    let e = run_sensitivity(&pb0, &mut ev, &opts(64)).unwrap_err();
    assert!(
        matches!(e, SensitivityError::EvaluatorMismatch { .. }),
        "{e}"
    );
    // A generic model returning too few outputs.
    let e = pick_freeze(
        &names(2),
        &[],
        |_, u| u.fill(0.5),
        |_| Ok(vec![1.0]),
        &opts(64),
    )
    .unwrap_err();
    assert!(matches!(e, SensitivityError::ModelOutput { .. }), "{e}");
}

/// GPU and CPU indices of the TX60 agree: per draw |Δw| ≤ 1e-5 mm (tests/gpu.rs); an index is
/// a ratio of sums of products of outputs with V(Y) = σ_w², so a perturbation Δ per output
/// moves it by at most about 8 Δ / σ_w.
#[test]
#[cfg(feature = "gpu")]
fn gpu_and_cpu_agree() {
    if !have_adapter("gpu_and_cpu_agree") {
        return;
    }
    let m = tx60();
    let pts = gpu_amcs::points::generate(&m, 10, &Default::default(), 11).unwrap();
    let pb = Problem::new(m, &pts, &Reference::Calibrated, 3).unwrap();
    let o = SensitivityOptions {
        bootstrap: 100,
        ..opts(1 << 10)
    };
    let cpu = run_sensitivity(&pb, &mut CpuEvaluator::new(pb.clone()), &o).unwrap();
    let gopts = GpuOptions {
        prefetch: false,
        ..GpuOptions::default()
    };
    let mut g = GpuEvaluator::new(pb.clone(), &gopts).expect("GPU evaluator");
    assert_eq!(g.info().backend, "gpu");
    let gpu = run_sensitivity(&pb, &mut g, &o).unwrap();
    let (qc, qg) = (&cpu.analysis.quantities[0], &gpu.analysis.quantities[0]);
    let tol = 8.0 * 1e-5 / qc.variance.sqrt();
    let mut worst: f64 = 0.0;
    for (vc, vg) in [(&qc.inputs, &qg.inputs), (&qc.groups, &qg.groups)] {
        assert_eq!(vc.len(), vg.len());
        for x in vc {
            let y = find(vg, &x.name);
            worst = worst
                .max((x.first_order.value - y.first_order.value).abs())
                .max((x.total.value - y.total.value).abs());
        }
    }
    eprintln!("largest |GPU − CPU| index difference {worst:.2e} (tolerance {tol:.2e})");
    assert!(worst <= tol);
}

/// The `sensitivity` subcommand: JSON and CSV from one run agree with each other and with the
/// estimator's bookkeeping; bad settings are one-line errors naming the flag, with no output.
#[test]
fn sensitivity_subcommand_writes_json_and_csv() {
    let d = common::tmpdir("sens-cli");
    let json = d.join("s.json");
    let csv = d.join("csv");
    let o = common::run(&[
        "sensitivity",
        "--backend",
        "cpu",
        "--points",
        "10",
        "--draws",
        "1024",
        "--thresholds",
        "0.12",
        "--json",
        json.to_str().unwrap(),
        "--csv",
        csv.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", common::stderr(&o));
    let text = common::stdout(&o);
    assert!(
        text.contains("theta1") && text.contains("twists α/β"),
        "{text}"
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let s = &v["sensitivity"];
    let n = s["draws"].as_u64().unwrap();
    let extra = s["pick_freeze_matrices"].as_u64().unwrap();
    assert_eq!(n, 1024);
    assert_eq!(s["evaluations"].as_u64().unwrap(), n * (2 + extra));
    assert_eq!(s["quantities"].as_array().unwrap().len(), 2);
    let inputs = s["quantities"][0]["inputs"].as_array().unwrap();
    assert_eq!(inputs.len(), s["dimension"].as_u64().unwrap() as usize);
    // Ranked by total index, and every total index is in [0, 1] within its interval.
    let totals: Vec<f64> = inputs
        .iter()
        .map(|i| i["total"]["value"].as_f64().unwrap())
        .collect();
    assert!(totals.windows(2).all(|w| w[0] >= w[1]), "{totals:?}");
    assert!(
        totals.iter().all(|t| (-0.05..=1.05).contains(t)),
        "{totals:?}"
    );
    let rows = std::fs::read_to_string(csv.join("indices.csv")).unwrap();
    let first = inputs[0]["name"].as_str().unwrap();
    let line = rows
        .lines()
        .find(|l| l.starts_with(&format!("w,,input,{first},")))
        .unwrap();
    let total: f64 = line.split(',').nth(7).unwrap().parse().unwrap();
    assert_eq!(total, totals[0]);
    for (args, flag) in [
        (vec!["sensitivity", "--draws", "1000"], "--draws"),
        (vec!["sensitivity", "--thresholds", "0"], "--thresholds"),
        (vec!["sensitivity", "--bootstrap", "1"], "--bootstrap"),
    ] {
        let out = d.join("bad.json");
        let mut args = args.clone();
        args.extend(["--json", out.to_str().unwrap()]);
        common::fails_leaving_nothing(&d, &args, flag);
    }
}

/// The report is the same bits with 1 and with 3 threads (the bootstrap sums each resample in
/// base-sample order, whichever thread runs it), thresholds included.
#[test]
fn sensitivity_report_does_not_depend_on_the_thread_count() {
    let d = common::tmpdir("sens-threads");
    let run = |threads: &str| {
        let json = d.join(format!("t{threads}.json"));
        let o = common::run(&[
            "sensitivity",
            "--backend",
            "cpu",
            "--points",
            "5",
            "--draws",
            "2048",
            "--thresholds",
            "0.08,0.1,0.12",
            "--threads",
            threads,
            "-q",
            "--json",
            json.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(0), "{}", common::stderr(&o));
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        v["sensitivity"]["quantities"].to_string()
    };
    let one = run("1");
    assert!(one.contains("\"std_error\""), "{one}");
    assert_eq!(one, run("3"));
}

/// `sensitivity --svg DIR`: indices.svg and groups.svg are well-formed, with one first-order
/// and one total bar per parameter (at most 20) and per group, each with an interval.
#[test]
fn sensitivity_subcommand_writes_svg() {
    let d = common::tmpdir("sens-svg");
    let json = d.join("s.json");
    let svg = d.join("svg");
    let o = common::run(&[
        "sensitivity",
        "--backend",
        "cpu",
        "--points",
        "10",
        "--draws",
        "1024",
        "--json",
        json.to_str().unwrap(),
        "--svg",
        svg.to_str().unwrap(),
        "-q",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", common::stderr(&o));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let q = &v["sensitivity"]["quantities"][0];
    for (file, key) in [("indices.svg", "inputs"), ("groups.svg", "groups")] {
        let text = std::fs::read_to_string(svg.join(file)).unwrap();
        common::check_svg_finite(&text, file);
        let rows = q[key].as_array().unwrap();
        let bars = rows.len().min(20);
        assert!(bars > 0, "{file}");
        assert_eq!(text.matches(r#"class="bar-s""#).count(), bars, "{file}");
        assert_eq!(text.matches(r#"class="bar-st""#).count(), bars, "{file}");
        let intervals = rows[..bars]
            .iter()
            .flat_map(|r| [&r["first_order"], &r["total"]])
            .filter(|e| e["ci_low"].is_number() && e["ci_high"].is_number())
            .count();
        assert_eq!(text.matches(r#"class="ci""#).count(), intervals, "{file}");
        // Negative estimates are drawn as zero-width bars, and the figure says so.
        let negative = rows[..bars]
            .iter()
            .flat_map(|r| [&r["first_order"], &r["total"]])
            .any(|e| e["value"].as_f64().unwrap() < 0.0);
        assert_eq!(text.contains("drawn as 0"), negative, "{file}");
        assert!(!text.contains(r#"width="-"#), "{file}");
        // The first bar is the parameter (group) with the largest total index.
        let first = rows[0]["name"].as_str().unwrap();
        assert!(
            text.contains(&format!(">{first}</text>")),
            "{file}: {first}"
        );
    }
    let names: Vec<String> = std::fs::read_dir(&svg)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names.len(), 2, "{names:?}");
}

/// A model's discrepancy term is one more Sobol input (`model_discrepancy`, its own group): it
/// takes nearly all of w's variance when its radii dwarf what the parameters do (1 mm against
/// the TX60's ~0.1 mm), next to none when they are tiny (1e-5 mm), and the parameters' indices
/// then match the analysis without the term.
#[test]
fn the_discrepancy_term_is_an_input_of_its_own() {
    use gpu_amcs::discrepancy::{Discrepancy, NoiseSource};
    let pts = [
        [10.0, -20.0, 30.0, 40.0, 50.0, 60.0],
        [-40.0, 10.0, 80.0, 0.0, 30.0, 0.0],
    ];
    let analyse = |radius: f64| {
        let mut m = tx60();
        m.discrepancy = Some(
            Discrepancy {
                residual_norms: (0..20)
                    .map(|i| radius * (1.0 + 0.05 * f64::from(i)))
                    .collect(),
                robot_share: 1.0,
                noise: NoiseSource::Unknown,
                noise_sigma_mm: None,
                compensation: None,
            }
            .checked()
            .unwrap(),
        );
        let pb = Problem::new(m, &pts, &Reference::Calibrated, 3).unwrap();
        let r = run_sensitivity(&pb, &mut CpuEvaluator::new(pb.clone()), &opts(4096)).unwrap();
        assert_eq!(
            r.parameters.last().map(String::as_str),
            Some("model_discrepancy")
        );
        assert!(r.w().groups.iter().any(|g| g.name == "model discrepancy"));
        (
            r.clone(),
            find(&r.w().inputs, "model_discrepancy").total.value,
        )
    };
    let (_, big) = analyse(1.0);
    assert!(big > 0.9, "total index of a dominant term: {big}");
    let (small, tiny) = analyse(1e-5);
    assert!(tiny < 0.01, "total index of a negligible term: {tiny}");
    let pb = Problem::new(tx60(), &pts, &Reference::Calibrated, 3).unwrap();
    let plain = run_sensitivity(&pb, &mut CpuEvaluator::new(pb.clone()), &opts(4096)).unwrap();
    let a = find(&small.w().inputs, "theta2").total.value;
    let b = find(&plain.w().inputs, "theta2").total.value;
    assert!(
        (a - b).abs() < 0.02,
        "theta2 with a negligible term {a}, without {b}"
    );
}
