//! The Monte Carlo drivers against exact answers: the additive model of GUM S1 §9.2 (normal and
//! rectangular inputs), an exponential output whose shortest interval starts at the minimum, and
//! the robot with only θ_1 uncertain, whose reliability has a closed form.

use gpu_amcs::engine::{CpuEvaluator, FnEvaluator, Problem, Reference};
use gpu_amcs::kinematics::{tx60, Params, Uncertainty};
use gpu_amcs::mc::{
    run_amcs, run_mcs, AmcsOptions, IntervalKind, McsOptions, RunSettings, Tolerance,
};
use gpu_amcs::sampling::{normals_block, uniform_open, Philox};

/// Φ(x) by composite Simpson integration of the normal density (error < 1e-12 here).
fn phi(x: f64) -> f64 {
    let n = 4000;
    let h = x / n as f64;
    let f = |t: f64| (-0.5 * t * t).exp() / (2.0 * std::f64::consts::PI).sqrt();
    let mut s = f(0.0) + f(x);
    for i in 1..n {
        s += if i % 2 == 1 { 4.0 } else { 2.0 } * f(i as f64 * h);
    }
    (0.5 + s * h / 3.0).min(1.0)
}

fn amcs_opts(tol: Tolerance, kind: IntervalKind) -> AmcsOptions {
    AmcsOptions {
        tolerance: tol,
        batch_size: 10_000,
        max_draws: 20_000_000,
        settings: RunSettings {
            coverage_probability: 0.95,
            interval: kind,
            thresholds: vec![1.0],
            per_point: false,
        },
    }
}

#[test]
fn gum_s1_9_2_additive_normal() {
    // Y = X1 + X2 + X3 + X4, Xi ~ N(0, 1): y = 0, u(y) = 2, 95 % interval ±1.959964·2.
    let mut ev = FnEvaluator::new(11, |g: &Philox, k| normals_block(g, k, 0, 7).iter().sum());
    // ndig = 2 as in GUM S1 §9.2.2: u = 2.0 → δ = 0.05.
    let r = run_amcs(
        &mut ev,
        &amcs_opts(Tolerance::Ndig(2), IntervalKind::Shortest),
        None,
    )
    .unwrap();
    assert!(r.converged);
    let d = r.numerical_tolerance.unwrap();
    assert!((d - 0.05).abs() < 1e-12);
    assert_eq!(r.ndig, Some(2));
    let half = 1.959_963_985 * 2.0;
    assert!(r.estimate.abs() <= d, "mean {}", r.estimate);
    assert!(
        (r.std_uncertainty - 2.0).abs() <= d,
        "u {}",
        r.std_uncertainty
    );
    assert!(
        (r.coverage_interval.low + half).abs() <= d,
        "{:?}",
        r.coverage_interval
    );
    assert!(
        (r.coverage_interval.high - half).abs() <= d,
        "{:?}",
        r.coverage_interval
    );
    // The stopping rule's own promise: the last trace entry has all four 2s ≤ δ.
    let last = r.trace.last().unwrap();
    assert!(last.fluctuation.iter().all(|f| *f <= d));
}

/// Upper 97.5 % point of the sum of four U(−√3, √3) (Irwin–Hall, n = 4, rescaled).
fn irwin_hall4_quantile(p: f64) -> f64 {
    let cdf = |x: f64| {
        let binom = [1.0, 4.0, 6.0, 4.0, 1.0];
        let mut s = 0.0;
        for (k, b) in binom.iter().enumerate() {
            if x > k as f64 {
                s += if k % 2 == 0 { 1.0 } else { -1.0 } * b * (x - k as f64).powi(4);
            }
        }
        s / 24.0
    };
    let (mut lo, mut hi) = (2.0, 4.0);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if cdf(mid) < p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    // S ∈ [0, 4] with mean 2 maps to Y = 2√3 (S − 2).
    2.0 * 3f64.sqrt() * (lo - 2.0)
}

#[test]
fn gum_s1_9_2_additive_rectangular() {
    // Xi ~ R(−√3, √3): u(y) = 2, the symmetric 95 % interval is ±3.88 (GUM S1 §9.2.3, Table 3).
    let s3 = 3f64.sqrt();
    let mut ev = FnEvaluator::new(12, move |g: &Philox, k| {
        g.block(k, 0, 7)
            .iter()
            .map(|&x| s3 * (2.0 * uniform_open(x) - 1.0))
            .sum()
    });
    let half = irwin_hall4_quantile(0.975);
    assert!((half - 3.88).abs() < 0.005, "{half}");
    for kind in [IntervalKind::Symmetric, IntervalKind::Shortest] {
        let r = run_amcs(&mut ev, &amcs_opts(Tolerance::Ndig(2), kind), None).unwrap();
        let d = r.numerical_tolerance.unwrap();
        assert!(r.converged);
        assert!(r.estimate.abs() <= d);
        assert!((r.std_uncertainty - 2.0).abs() <= d);
        assert!(
            (r.coverage_interval.low + half).abs() <= d,
            "{kind:?} {:?}",
            r.coverage_interval
        );
        assert!(
            (r.coverage_interval.high - half).abs() <= d,
            "{kind:?} {:?}",
            r.coverage_interval
        );
    }
}

#[test]
fn shortest_interval_of_exponential_starts_at_minimum() {
    // Y = −ln U: the shortest 95 % interval is [0, ln 20]; the symmetric one
    // [−ln 0.975, −ln 0.025].
    let mut ev = FnEvaluator::new(13, |g: &Philox, k| -uniform_open(g.block(k, 0, 3)[0]).ln());
    let r = run_amcs(
        &mut ev,
        &amcs_opts(Tolerance::Delta(0.02), IntervalKind::Shortest),
        None,
    )
    .unwrap();
    assert!(r.converged);
    assert_eq!(
        r.coverage_interval.low, r.min,
        "the shortest interval must start at the smallest value"
    );
    assert!(
        (r.coverage_interval.high - 20f64.ln()).abs() <= 0.02,
        "{:?}",
        r.coverage_interval
    );
    let r = run_amcs(
        &mut ev,
        &amcs_opts(Tolerance::Delta(0.02), IntervalKind::Symmetric),
        None,
    )
    .unwrap();
    assert!((r.coverage_interval.low + 0.975f64.ln()).abs() <= 0.02);
    assert!((r.coverage_interval.high + 0.025f64.ln()).abs() <= 0.02);
}

#[test]
fn only_theta1_uncertain_matches_closed_form() {
    // Only θ1 (rotation about the base z axis) is uncertain, σ = 0.005°. Every point turns by δ
    // about that axis, so e_j = 2 r_j |sin(δ/2)|, w = 2 r_max |sin(δ/2)| and
    // R(l) = Pr[|δ| < 2 asin(l / (2 r_max))] = 2Φ(a/σ) − 1.
    let mut m = tx60();
    let sigma = 0.005f64.to_radians();
    let mut s = Params::filled(m.layout().n_params(), 0.0);
    s[0] = sigma;
    m.uncertainty = Uncertainty::Independent(s);
    let pts = gpu_amcs::points::generate(&m, 20, &Default::default(), 5).unwrap();
    let pb = Problem::new(m, &pts, &Reference::Calibrated, 99).unwrap();
    let r_max = pb
        .reference
        .iter()
        .map(|p| p[0].hypot(p[1]))
        .fold(0.0, f64::max);
    let thresholds = vec![0.01, 0.03, 0.06, 0.1, 0.15];
    let n = 200_000u64;
    let opts = McsOptions {
        draws: n,
        chunk: 50_000,
        settings: RunSettings {
            thresholds: thresholds.clone(),
            per_point: true,
            ..RunSettings::default()
        },
    };
    let res = run_mcs(&mut CpuEvaluator::new(pb.clone()), &opts, None).unwrap();
    for rel in &res.reliability {
        let a = 2.0 * (rel.threshold / (2.0 * r_max)).asin();
        let exact = 2.0 * phi(a / sigma) - 1.0;
        let sd = (exact * (1.0 - exact) / n as f64).sqrt();
        assert!(
            (rel.r - exact).abs() <= 3.0 * sd + 1e-12,
            "l = {}: MC {} exact {} (3σ = {})",
            rel.threshold,
            rel.r,
            exact,
            3.0 * sd
        );
    }
    // Single-point reliability of each point has the same closed form with its own radius.
    // 100 simultaneous checks: 4σ each (false alarm 6e-5 per check), plus 3/n for the tails,
    // where the count of misses is Poisson with a mean below 1 and the normal σ misleads.
    let pp = res.per_point_reliability.as_ref().unwrap();
    for (j, row) in pp.iter().enumerate() {
        let rj = pb.reference[j][0].hypot(pb.reference[j][1]);
        for rel in row {
            let exact = if rel.threshold >= 2.0 * rj {
                1.0
            } else {
                2.0 * phi(2.0 * (rel.threshold / (2.0 * rj)).asin() / sigma) - 1.0
            };
            let sd = (exact * (1.0 - exact) / n as f64).sqrt();
            assert!(
                (rel.r - exact).abs() <= 4.0 * sd + 3.0 / n as f64,
                "point {j} l = {}: {} vs {}",
                rel.threshold,
                rel.r,
                exact
            );
        }
    }
    // Mean of w: 2 r_max E|sin(δ/2)| ≈ r_max σ √(2/π) (δ tiny); 3 standard errors.
    let mean_exact = r_max * sigma * (2.0 / std::f64::consts::PI).sqrt();
    let se = res.std_uncertainty / (n as f64).sqrt();
    assert!(
        (res.estimate - mean_exact).abs() <= 3.0 * se,
        "{} vs {}",
        res.estimate,
        mean_exact
    );
}
