//! Tail probabilities by subset simulation against exact answers: the TX60 with only θ1
//! uncertain has `P_f(l) = 2Φ(−2 asin(l / 2ρ_max)/σ)`, two failure regions (θ1 too far either
//! way); the reported coefficient of variation is checked for honesty over many seeds; the
//! default TX60 against crude Monte Carlo; GPU (lavapipe) against CPU; typed errors for bad
//! settings; the evaluation cap as an outcome.
//!
//! Over 600 lines: the exact answers, the coverage experiments and the CLI checks share their fixtures.

use crate::common;

#[cfg(feature = "gpu")]
use common::have_adapter;
use gpu_amcs::engine::{CpuEvaluator, Evaluator, Problem, Reference};
#[cfg(feature = "gpu")]
use gpu_amcs::gpu::{GpuEvaluator, GpuOptions};
use gpu_amcs::kinematics::{tx60, Layout, RobotModel, Uncertainty};
use gpu_amcs::mc::tail::{
    normal_quantile, run_tail, ChainProposal, TailError, TailMethod, TailOptions, TailOutcome,
    TailResult, TailSetting,
};

/// The six-joint TX60's parameter count (30).
const N_PARAMS: usize = Layout::SIX.n_params();

/// `1 − Φ(x)` for x ≥ 0 by composite Simpson integration of the density over [x, x + 12]
/// (truncation below φ(12) ≈ 2e-32; 6000 panels give a relative error far below 1e-9).
fn phi_upper(x: f64) -> f64 {
    let n = 6000;
    let h = 12.0 / n as f64;
    let f = |t: f64| (-0.5 * t * t).exp() / (2.0 * std::f64::consts::PI).sqrt();
    let mut s = f(x) + f(x + 12.0);
    for i in 1..n {
        s += if i % 2 == 1 { 4.0 } else { 2.0 } * f(x + i as f64 * h);
    }
    s * h / 3.0
}

/// σ of θ1 in the θ1-only model, radians.
const SIGMA: f64 = 0.005 * std::f64::consts::PI / 180.0;

/// The TX60 with only θ1 uncertain at 20 generated points, and ρ_max.
fn theta1_problem(seed: u64) -> (Problem, f64) {
    let mut m = tx60();
    let mut s = [0.0; N_PARAMS];
    s[0] = SIGMA;
    m.uncertainty = Uncertainty::Independent(s.into());
    let pb = problem(m, 20, seed);
    let r_max = pb
        .reference
        .iter()
        .map(|p| p[0].hypot(p[1]))
        .fold(0.0, f64::max);
    (pb, r_max)
}

fn problem(m: RobotModel, points: usize, seed: u64) -> Problem {
    let pts = gpu_amcs::points::generate(&m, points, &Default::default(), 5).unwrap();
    Problem::new(m, &pts, &Reference::Calibrated, seed).unwrap()
}

/// The threshold whose exact P_f is about `p` (chosen with the library's Φ⁻¹; the truth is
/// recomputed by quadrature).
fn theta1_threshold(p: f64, r_max: f64) -> f64 {
    let z = -normal_quantile(p / 2.0);
    2.0 * r_max * (z * SIGMA / 2.0).sin()
}

fn theta1_exact(l: f64, r_max: f64) -> f64 {
    2.0 * phi_upper(2.0 * (l / (2.0 * r_max)).asin() / SIGMA)
}

fn subset(thresholds: Vec<f64>, n: usize, target: f64, cap: u64) -> TailOptions {
    TailOptions {
        thresholds,
        samples_per_level: n,
        target_cov: target,
        max_evaluations: cap,
        ..TailOptions::default()
    }
}

fn run_cpu(pb: &Problem, opts: &TailOptions) -> TailResult {
    run_tail(&mut CpuEvaluator::new(pb.clone()), pb, opts, None).unwrap()
}

#[test]
fn quantile_matches_quadrature() {
    for p in [1e-12, 1e-9, 1e-6, 1e-4, 0.01, 0.2, 0.45] {
        let z = -normal_quantile(p);
        // Acklam's relative error in z is below 1.2e-9, so p moves by at most φ(z)·1.2e-9·z.
        let back = phi_upper(z);
        let density = (-0.5 * z * z).exp() / (2.0 * std::f64::consts::PI).sqrt();
        let tol = 1.2e-9 * z * density / p + 1e-10;
        assert!((back / p - 1.0).abs() < tol, "p {p}: Φ(−Φ⁻¹) = {back}");
        if p >= 1e-4 {
            // 1 − p is exact to 1e-16, a relative 1e-12 of p here.
            assert!((normal_quantile(1.0 - p) - z).abs() < 1e-9 * z.max(1.0));
        }
    }
}

#[test]
fn theta1_closed_form_down_to_1e_9() {
    let (pb, r_max) = theta1_problem(21);
    let ls: Vec<f64> = [1e-4, 1e-6, 1e-9]
        .iter()
        .map(|&p| theta1_threshold(p, r_max))
        .collect();
    let res = run_cpu(&pb, &subset(ls.clone(), 1000, 0.15, 2_000_000));
    assert_eq!(res.outcome, TailOutcome::TargetReached, "{res:?}");
    assert!(res.evaluations <= 2_000_000);
    for (e, &l) in res.estimates.iter().zip(&ls) {
        let exact = theta1_exact(l, r_max);
        let cov = e.cov.unwrap();
        assert!(cov <= 0.15, "l {l}: cov {cov}");
        assert!(
            (e.p_f - exact).abs() <= 3.0 * cov * exact,
            "l {l}: subset {} exact {exact} (cov {cov})",
            e.p_f
        );
        let beta = e.beta.unwrap();
        assert!((beta + normal_quantile(e.p_f)).abs() < 1e-12);
    }
    eprintln!(
        "theta1 1e-9: {} evaluations, runs of N = {:?}, {:.2} s, P/exact {:?}, cov {:?}",
        res.evaluations,
        res.runs
            .iter()
            .map(|r| r.samples_per_level)
            .collect::<Vec<_>>(),
        res.seconds,
        res.estimates
            .iter()
            .zip(&ls)
            .map(|(e, &l)| e.p_f / theta1_exact(l, r_max))
            .collect::<Vec<_>>(),
        res.estimates.iter().map(|e| e.cov).collect::<Vec<_>>()
    );
}

/// The band for (empirical coefficient of variation over the seeds) / (mean reported one): the
/// reported figure may be somewhat wide but never clearly narrow. The sampling error of a
/// standard deviation of 200 skewed estimates is near 7 %, so the band is about ±1.5 of it.
const HONEST: std::ops::RangeInclusive<f64> = 0.85..=1.1;

/// `(mean, empirical CoV against `exact`, ratio to the mean reported CoV)` of `est`.
fn spread(est: &[f64], mean_reported: f64, exact: f64) -> (f64, f64, f64) {
    let n = est.len() as f64;
    let mean = est.iter().sum::<f64>() / n;
    let sd = (est.iter().map(|p| (p - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    (mean, sd / exact, sd / exact / mean_reported)
}

/// Over 200 seeds (one run of `N` = 500 each), the spread of the estimates over the mean
/// reported coefficient of variation lies in [`HONEST`], for both proposals, each with its own
/// combination of the levels' δ_j ([`ChainProposal::combined_cov`]).
#[test]
fn reported_cov_is_honest() {
    for proposal in [
        ChainProposal::AdaptiveConditional,
        ChainProposal::ModifiedMetropolis,
    ] {
        cov_is_honest(proposal);
    }
}

fn cov_is_honest(proposal: ChainProposal) {
    let (_, r_max) = theta1_problem(0);
    let ls = vec![theta1_threshold(1e-4, r_max), theta1_threshold(1e-6, r_max)];
    let seeds = 200;
    let mut est = vec![Vec::new(); ls.len()];
    let mut cov = vec![0.0; ls.len()];
    let mut cov_ind = vec![0.0; ls.len()];
    for seed in 0..seeds {
        let (pb, _) = theta1_problem(1000 + seed);
        // A cap that leaves room for the pilot run only.
        let opts = TailOptions {
            proposal,
            ..subset(ls.clone(), 500, 0.99, 3_200)
        };
        let res = run_cpu(&pb, &opts);
        assert_eq!(res.runs.len(), 1);
        assert!(res.runs[0].complete);
        for (i, e) in res.estimates.iter().enumerate() {
            est[i].push(e.p_f);
            cov[i] += e.cov.unwrap() / seeds as f64;
            cov_ind[i] += e.cov_independent_levels.unwrap() / seeds as f64;
        }
    }
    for (i, &l) in ls.iter().enumerate() {
        let exact = theta1_exact(l, r_max);
        let (mean, empirical, ratio) = spread(&est[i], cov[i], exact);
        eprintln!(
            "{proposal:?}, P_f {exact:.3e}: mean estimate {mean:.3e}, empirical cov {empirical:.3}, \
             mean reported {:.3} (independent levels {:.3}), ratio {ratio:.3}",
            cov[i], cov_ind[i]
        );
        assert!(
            HONEST.contains(&ratio),
            "{proposal:?}, P_f {exact:.1e}: ratio {ratio}"
        );
        // The mean of 200 estimates is unbiased within 4 of its standard errors.
        let n = est[i].len() as f64;
        assert!(
            (mean - exact).abs() <= 4.0 * empirical * exact / n.sqrt(),
            "{mean} vs {exact}"
        );
    }
}

/// The default TX60 (20 normals) at 5 test points, adaptive conditional sampling: the threshold
/// with `P_f` ≈ 1e-4 (the 20th largest of 2·10^5 draws of another seed), its truth from 10^7
/// crude Monte Carlo draws (CoV about 0.04), then 1000 seeds of one run with `N` = 500 (2 s;
/// 200 seeds alone gave 1.14, the spread of a few hundred of these skewed estimates is itself
/// uncertain by 10 % or more): the ratio in [`HONEST`]. Here the chains forget their seeds more than on the θ1-only problem, and
/// the reported figure follows (adjacent levels taken as fully correlated gave 0.72).
#[test]
fn reported_cov_is_honest_on_default_tx60() {
    let pick = problem(tx60(), 5, 7);
    let mut w = vec![0.0; 200_000];
    CpuEvaluator::new(pick).evaluate(0, &mut w, None).unwrap();
    w.sort_by(|a, b| b.total_cmp(a));
    let l = w[19];
    let mc_opts = TailOptions {
        method: TailMethod::MonteCarlo,
        ..subset(vec![l], 1000, 0.01, 10_000_000)
    };
    let exact = run_cpu(&problem(tx60(), 5, 9), &mc_opts).estimates[0].p_f;
    let seeds = 1000;
    let mut est = Vec::new();
    let (mut cov, mut cov_ind) = (0.0, 0.0);
    for seed in 0..seeds {
        let pb = problem(tx60(), 5, 2000 + seed);
        let res = run_cpu(&pb, &subset(vec![l], 500, 0.99, 5_000));
        assert!(res.runs[0].complete);
        let e = &res.estimates[0];
        est.push(e.p_f);
        cov += e.cov.unwrap() / seeds as f64;
        cov_ind += e.cov_independent_levels.unwrap() / seeds as f64;
    }
    let (mean, empirical, ratio) = spread(&est, cov, exact);
    eprintln!(
        "default TX60, 5 points, P_f {exact:.3e} (crude MC): mean estimate {mean:.3e}, \
         empirical cov {empirical:.3}, mean reported {cov:.3} (independent levels {cov_ind:.3}), \
         ratio {ratio:.3}"
    );
    assert!(HONEST.contains(&ratio), "TX60: ratio {ratio}");
}

/// The ratio of [`reported_cov_is_honest_on_default_tx60`] at P_f ≈ 1e-3, 1e-4 and 1e-6 for
/// both proposals (1000 seeds of `N` = 500 each). Each threshold is the k-th largest `w` of a
/// crude Monte Carlo run of `k / P_f` draws (k = 1000, 1000, 200), which is also its truth
/// (within 1/√k). A measurement for the method doc (`cargo test --release -- --ignored
/// tail::measure_cov_ratios_on_default_tx60 --nocapture`); the ratios it printed are quoted there.
#[test]
#[ignore = "measurement: about a minute on 2 cores"]
fn measure_cov_ratios_on_default_tx60() {
    let mut ev = CpuEvaluator::new(problem(tx60(), 5, 7));
    for (p, k) in [(1e-3, 1000usize), (1e-4, 1000), (1e-6, 200)] {
        let draws = (k as f64 / p) as u64;
        let batch = 1u64 << 22;
        let mut top: Vec<f64> = Vec::new();
        let mut w = vec![0.0; batch as usize];
        let mut floor = 0.0;
        for first in (0..draws).step_by(batch as usize) {
            let n = batch.min(draws - first) as usize;
            ev.evaluate(first, &mut w[..n], None).unwrap();
            top.extend(w[..n].iter().copied().filter(|&x| x >= floor));
            if top.len() > 4 * k {
                top.sort_by(|a, b| b.total_cmp(a));
                top.truncate(k);
                floor = top[k - 1];
            }
        }
        top.sort_by(|a, b| b.total_cmp(a));
        let l = top[k - 1];
        let exact = k as f64 / draws as f64;
        for proposal in [
            ChainProposal::AdaptiveConditional,
            ChainProposal::ModifiedMetropolis,
        ] {
            let seeds = 1000;
            let mut est = Vec::new();
            let mut cov = 0.0;
            for seed in 0..seeds {
                let pb = problem(tx60(), 5, 5000 + seed);
                let opts = TailOptions {
                    proposal,
                    ..subset(vec![l], 500, 0.99, 4_000)
                };
                let res = run_cpu(&pb, &opts);
                assert!(res.runs[0].complete);
                est.push(res.estimates[0].p_f);
                cov += res.estimates[0].cov.unwrap_or(0.0) / seeds as f64;
            }
            let (mean, empirical, ratio) = spread(&est, cov, exact);
            eprintln!(
                "TX60 {proposal:?}, P_f {exact:.1e}: mean {mean:.3e}, empirical cov {empirical:.3}, \
                 mean reported {cov:.3}, ratio {ratio:.3}"
            );
        }
    }
}

/// The default TX60 at `points` test points: a threshold with P_f ≈ 1e-4 (the 20th largest of
/// 2·10^5 draws of another seed), then subset simulation (pilot N = 1000, `target`) and crude
/// Monte Carlo (to `mc_target`, `mc_draws` at most) on seed 8. Checks that they agree within 3 combined standard
/// deviations (each side's own reported CoV; a normal difference exceeds 3σ with probability
/// 0.3 %) and that subset simulation reached its target; returns both.
fn against_crude_mc(
    points: usize,
    target: f64,
    mc_target: f64,
    mc_draws: u64,
) -> (TailResult, TailResult) {
    let pick = problem(tx60(), points, 7);
    let mut w = vec![0.0; 200_000];
    CpuEvaluator::new(pick).evaluate(0, &mut w, None).unwrap();
    w.sort_by(|a, b| b.total_cmp(a));
    let l = w[19];
    let pb = problem(tx60(), points, 8);
    let ss = run_cpu(&pb, &subset(vec![l], 1000, target, 2_000_000));
    let mc_opts = TailOptions {
        method: TailMethod::MonteCarlo,
        ..subset(vec![l], 1000, mc_target, mc_draws)
    };
    let mc = run_cpu(&pb, &mc_opts);
    let (a, b) = (&ss.estimates[0], &mc.estimates[0]);
    let (da, db) = (a.cov.unwrap() * a.p_f, b.cov.unwrap() * b.p_f);
    eprintln!(
        "TX60 {points} points, l = {l:.4} mm: subset {:.4e} ± {da:.1e} (CoV {:.3}, {} evaluations, {:.1} s), \
         crude MC {:.4e} ± {db:.1e} (CoV {:.3}, {} draws, {:.1} s), difference {:.2} combined σ",
        a.p_f,
        a.cov.unwrap(),
        ss.evaluations,
        ss.seconds,
        b.p_f,
        b.cov.unwrap(),
        mc.evaluations,
        mc.seconds,
        (a.p_f - b.p_f).abs() / da.hypot(db)
    );
    assert!((a.p_f - b.p_f).abs() <= 3.0 * da.hypot(db));
    assert_eq!(ss.outcome, TailOutcome::TargetReached);
    (ss, mc)
}

#[test]
fn default_tx60_agrees_with_crude_monte_carlo() {
    // 20 points, both at a target of 0.1: crude MC stops near 10^6 draws.
    let (ss, mc) = against_crude_mc(20, 0.1, 0.1, 1_000_000);
    assert!(ss.evaluations < mc.evaluations);
}

/// The issue's comparison at full size (run with `--ignored --nocapture`; some 10 s of CPU,
/// too slow for every test run, so `default_tx60_agrees_with_crude_monte_carlo` above is the
/// always-run version at 10^6 draws): the default TX60 at its 50 default test points,
/// `P_f ≈ 1e-4`, subset simulation at a target of 0.05 against crude Monte Carlo with all
/// 10^7 draws (target 0.001 is out of reach: about 10^3 failures, CoV ≈ 0.03).
#[test]
#[ignore]
fn default_tx60_against_crude_monte_carlo_1e7() {
    let (_, mc) = against_crude_mc(50, 0.05, 0.001, 10_000_000);
    assert_eq!(mc.evaluations, 10_000_000);
}

#[test]
fn reproducible_and_independent_of_batch_size() {
    let (pb, r_max) = theta1_problem(3);
    let opts = subset(vec![theta1_threshold(1e-5, r_max)], 500, 0.3, 100_000);
    let a = run_cpu(&pb, &opts);
    let b = run_cpu(
        &pb,
        &TailOptions {
            batch_size: 37,
            ..opts.clone()
        },
    );
    assert_eq!(a.estimates, b.estimates);
    assert_eq!(a.runs, b.runs);
    let (other, _) = theta1_problem(4);
    assert_ne!(run_cpu(&other, &opts).estimates, a.estimates);
}

#[test]
fn evaluation_cap_is_an_outcome() {
    let (pb, r_max) = theta1_problem(5);
    let ls = vec![theta1_threshold(1e-3, r_max), theta1_threshold(1e-9, r_max)];
    // Level 0 and two Markov levels (1000 + 2·900) fit; 1e-9 needs nine levels.
    let res = run_cpu(&pb, &subset(ls, 1000, 0.1, 3000));
    assert_eq!(res.outcome, TailOutcome::EvaluationCapReached);
    assert!(res.evaluations <= 3000);
    assert_eq!(res.runs.len(), 1);
    assert!(!res.runs[0].complete);
    assert_eq!(res.runs[0].levels.len(), 3);
    // 1e-3 is resolved on the way; 1e-9 is not (no sample reached it).
    assert!(res.estimates[0].cov.is_some());
    assert_eq!(res.estimates[1].p_f, 0.0);
    assert!(res.estimates[1].beta.is_none());
    let json = serde_json::to_string(&res).unwrap();
    assert!(json.contains("\"evaluation_cap_reached\""), "{json}");
    // Crude MC cannot see 1e-9 in 3000 draws either.
    let mc = TailOptions {
        method: TailMethod::MonteCarlo,
        ..subset(vec![theta1_threshold(1e-9, r_max)], 1000, 0.1, 3000)
    };
    let res = run_cpu(&pb, &mc);
    assert_eq!(res.outcome, TailOutcome::EvaluationCapReached);
    assert_eq!((res.evaluations, res.estimates[0].p_f), (3000, 0.0));
}

#[test]
fn bad_settings_name_the_field() {
    let (pb, _) = theta1_problem(1);
    let ok = subset(vec![0.1], 1000, 0.1, 100_000);
    use TailSetting as S;
    let cases: Vec<(TailOptions, TailSetting)> = vec![
        (subset(vec![], 1000, 0.1, 100_000), S::Thresholds),
        (subset(vec![0.1, 0.0], 1000, 0.1, 100_000), S::Thresholds),
        (subset(vec![-1.0], 1000, 0.1, 100_000), S::Thresholds),
        (subset(vec![f64::NAN], 1000, 0.1, 100_000), S::Thresholds),
        (
            subset(vec![f64::INFINITY], 1000, 0.1, 100_000),
            S::Thresholds,
        ),
        (subset(vec![0.1], 1000, 0.0, 100_000), S::TargetCov),
        (subset(vec![0.1], 1000, 1.0, 100_000), S::TargetCov),
        (subset(vec![0.1], 1000, f64::NAN, 100_000), S::TargetCov),
        (
            TailOptions {
                p0: 0.0,
                ..ok.clone()
            },
            S::P0,
        ),
        (
            TailOptions {
                p0: 0.6,
                ..ok.clone()
            },
            S::P0,
        ),
        (
            TailOptions {
                p0: f64::NAN,
                ..ok.clone()
            },
            S::P0,
        ),
        (
            TailOptions {
                p0: 0.3,
                ..ok.clone()
            },
            S::SamplesPerLevel,
        ),
        (subset(vec![0.1], 1, 0.1, 100_000), S::SamplesPerLevel),
        (subset(vec![0.1], 1000, 0.1, 999), S::MaxEvaluations),
        (subset(vec![0.1], 1000, 0.1, 0), S::MaxEvaluations),
        (
            TailOptions {
                proposal_spread: 0.0,
                ..ok.clone()
            },
            S::ProposalSpread,
        ),
        (
            TailOptions {
                batch_size: 0,
                ..ok.clone()
            },
            S::BatchSize,
        ),
    ];
    for (opts, field) in cases {
        match run_tail(&mut CpuEvaluator::new(pb.clone()), &pb, &opts, None) {
            Err(TailError::Setting { field: f, message }) => {
                assert_eq!(f, field, "{message}");
                let line = TailError::Setting { field: f, message }.to_string();
                assert!(line.starts_with(&field.to_string()), "{line}");
                assert!(!line.contains("--"), "{line}");
            }
            r => panic!("{field}: expected a setting error, got {r:?}"),
        }
    }
    assert!(ok.check().is_ok());
    // No uncertain parameter: a typed error, not a run.
    let mut m = tx60();
    m.uncertainty = Uncertainty::Independent([0.0; N_PARAMS].into());
    let pb = problem(m, 5, 1);
    let r = run_tail(&mut CpuEvaluator::new(pb.clone()), &pb, &ok, None);
    assert!(matches!(r, Err(TailError::NoUncertainty)), "{r:?}");
}

/// The same run on the GPU: its f32 `w` differ from the CPU's by ≲ 1e-5 mm (see tests/gpu.rs),
/// far below the spacing of the sample values at the level thresholds, so every comparison and
/// count agrees and the estimates are equal; the intermediate thresholds (sample values) agree
/// to the f32 tolerance.
#[test]
#[cfg(feature = "gpu")]
fn gpu_matches_cpu() {
    if !have_adapter("gpu_matches_cpu") {
        return;
    }
    let pick = problem(tx60(), 10, 7);
    let mut w = vec![0.0; 20_000];
    CpuEvaluator::new(pick).evaluate(0, &mut w, None).unwrap();
    w.sort_by(|a, b| b.total_cmp(a));
    let pb = problem(tx60(), 10, 9);
    let opts = subset(vec![w[1], w[19]], 500, 0.99, 100_000);
    let cpu = run_cpu(&pb, &opts);
    let gopts = GpuOptions {
        prefetch: false,
        ..GpuOptions::default()
    };
    let mut gev = GpuEvaluator::new(pb.clone(), &gopts).unwrap();
    let gpu = run_tail(&mut gev, &pb, &opts, None).unwrap();
    assert_eq!(gpu.backend.backend, "gpu");
    assert_eq!(cpu.evaluations, gpu.evaluations);
    for (a, b) in cpu.estimates.iter().zip(&gpu.estimates) {
        assert!((a.p_f / b.p_f - 1.0).abs() < 1e-12, "{a:?} {b:?}");
    }
    for (a, b) in cpu.runs[0].levels.iter().zip(&gpu.runs[0].levels) {
        if let (Some(x), Some(y)) = (a.next, b.next) {
            assert!((x - y).abs() <= 1e-5, "{x} vs {y}");
        }
    }
}

/// A diagonal covariance and the equivalent σ list give the same map `u ↦ L u`, so the same run.
#[test]
fn diagonal_covariance_equals_sigma_list() {
    let m = tx60();
    let s = m.param_sigmas();
    let mut mc = m.clone();
    let mut c = vec![0.0; N_PARAMS * N_PARAMS];
    for i in 0..N_PARAMS {
        c[i * N_PARAMS + i] = s[i] * s[i];
    }
    mc.uncertainty = Uncertainty::from_matrix(gpu_amcs::kinematics::InputSpace::parameters(6), c);
    let opts = subset(vec![0.2], 500, 0.9, 20_000);
    let a = run_cpu(&problem(m, 10, 3), &opts);
    let b = run_cpu(&problem(mc, 10, 3), &opts);
    assert_eq!(a.dimension, b.dimension);
    for (x, y) in a.estimates.iter().zip(&b.estimates) {
        assert!((x.p_f / y.p_f - 1.0).abs() < 1e-12, "{x:?} {y:?}");
    }
}

/// Measurement, not a check of correctness (run with `--ignored --nocapture`): evaluations and
/// seconds for P_f ≈ 1e-9 at a coefficient of variation ≤ 0.15 on the CPU, for the default
/// TX60 at 50 points. The threshold is the ninth intermediate level of a first run
/// (P ≈ 0.1^9).
#[test]
#[ignore]
fn measure_default_tx60_at_1e_9() {
    let pb = problem(tx60(), 50, 1);
    let probe = run_cpu(&pb, &subset(vec![10.0], 1000, 0.99, 9_000));
    let l = probe.runs[0].levels[8].next.unwrap();
    let res = run_cpu(&pb, &subset(vec![l], 1000, 0.15, 10_000_000));
    let e = &res.estimates[0];
    eprintln!(
        "default TX60, l = {l:.4} mm: P_f {:.3e}, cov {:.3} (independent levels {:.3}), beta {:.3}, {} evaluations in runs of N = {:?}, {:.1} s, outcome {:?}",
        e.p_f,
        e.cov.unwrap(),
        e.cov_independent_levels.unwrap(),
        e.beta.unwrap(),
        res.evaluations,
        res.runs.iter().map(|r| r.samples_per_level).collect::<Vec<_>>(),
        res.seconds,
        res.outcome
    );
    assert_eq!(res.outcome, TailOutcome::TargetReached);
}

/// A threshold every draw exceeds: `P_f = 1` from level 0 alone, β undefined (not ±∞ in the
/// output), and nothing beyond the first level is evaluated.
#[test]
fn certain_failure_stops_at_level_zero() {
    let (pb, _) = theta1_problem(2);
    let res = run_cpu(&pb, &subset(vec![1e-12], 500, 0.1, 100_000));
    assert_eq!(res.outcome, TailOutcome::TargetReached);
    assert_eq!(res.evaluations, 500);
    let e = &res.estimates[0];
    assert_eq!((e.p_f, e.cov, e.beta), (1.0, Some(0.0), None));
    let json = serde_json::to_string(&res).unwrap();
    assert!(!json.contains("inf") && !json.contains("NaN"), "{json}");
}

/// The `tail` subcommand: JSON and CSV of one run agree, P_f falls with the threshold, β is
/// −Φ⁻¹(P_f); bad settings are one-line errors naming the flag, with no output written.
#[test]
fn tail_subcommand_writes_json_and_csv() {
    let d = common::tmpdir("tail-cli");
    let json = d.join("t.json");
    let csv = d.join("csv");
    let o = common::run(&[
        "tail",
        "--backend",
        "cpu",
        "--points",
        "10",
        "--threshold",
        "0.15,0.2",
        "--cov",
        "0.3",
        "--samples-per-level",
        "500",
        "--json",
        json.to_str().unwrap(),
        "--csv",
        csv.to_str().unwrap(),
        "-q",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", common::stderr(&o));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let est = v["tail"]["estimates"].as_array().unwrap();
    assert_eq!(est.len(), 2);
    let p: Vec<f64> = est.iter().map(|e| e["p_f"].as_f64().unwrap()).collect();
    assert!(p[0] > p[1] && p[1] > 0.0, "{p:?}");
    for e in est {
        let (pf, beta) = (e["p_f"].as_f64().unwrap(), e["beta"].as_f64().unwrap());
        assert!((-normal_quantile(pf) - beta).abs() < 1e-9 * beta.abs().max(1.0));
    }
    let rows = std::fs::read_to_string(csv.join("tail.csv")).unwrap();
    let second: f64 = rows
        .lines()
        .nth(2)
        .unwrap()
        .split(',')
        .nth(1)
        .unwrap()
        .parse()
        .unwrap();
    assert_eq!(second, p[1]);
    for (args, flag) in [
        (vec!["tail", "--threshold", "0"], "--threshold"),
        (vec!["tail", "--threshold", "0.3", "--cov", "1.5"], "--cov"),
        (vec!["tail", "--threshold", "0.3", "--p0", "0.7"], "--p0"),
    ] {
        let out = d.join("bad.json");
        let mut args = args.clone();
        args.extend(["--json", out.to_str().unwrap()]);
        common::fails_leaving_nothing(&d, &args, flag);
    }
}

/// The exponents of the log-axis tick labels `1eK` of a tail.svg.
fn log_ticks(text: &str) -> Vec<i32> {
    text.split(r#"<text class="ytick""#)
        .skip(1)
        .map(|t| {
            let label = &t[t.find('>').unwrap() + 1..t.find("</text>").unwrap()];
            label.strip_prefix("1e").unwrap().parse().unwrap()
        })
        .collect()
}

/// `tail --svg DIR`: tail.svg is well-formed, has one marker per positive estimate, the level
/// curve of the last run, and a log axis spanning the smallest positive P_f; crude Monte Carlo
/// with a threshold no draw reaches draws no levels and names the left-out estimate in a note.
#[test]
fn tail_subcommand_writes_svg() {
    let d = common::tmpdir("tail-svg");
    let json = d.join("t.json");
    let svg = d.join("svg");
    let o = common::run(&[
        "tail",
        "--backend",
        "cpu",
        "--points",
        "10",
        "--threshold",
        "0.15,0.2",
        "--cov",
        "0.3",
        "--samples-per-level",
        "500",
        "--json",
        json.to_str().unwrap(),
        "--svg",
        svg.to_str().unwrap(),
        "-q",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", common::stderr(&o));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let p: Vec<f64> = v["tail"]["estimates"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["p_f"].as_f64().unwrap())
        .filter(|p| *p > 0.0)
        .collect();
    assert_eq!(p.len(), 2);
    let text = std::fs::read_to_string(svg.join("tail.svg")).unwrap();
    common::check_svg_finite(&text, "tail.svg");
    assert_eq!(text.matches(r#"class="estimate""#).count(), p.len());
    assert_eq!(text.matches(r#"class="err""#).count(), p.len());
    assert_eq!(text.matches(r#"<polyline class="levels""#).count(), 1);
    let ticks = log_ticks(&text);
    let smallest = p.iter().copied().fold(f64::INFINITY, f64::min);
    let (lo, hi) = (*ticks.iter().min().unwrap(), *ticks.iter().max().unwrap());
    assert!(
        f64::from(lo) <= smallest.log10() && f64::from(hi) >= -1.0 && hi <= 0,
        "{ticks:?} for P_f down to {smallest}"
    );
    assert!(ticks.windows(2).all(|w| w[1] == w[0] + 1), "{ticks:?}");

    let mc = d.join("mc");
    let o = common::run(&[
        "tail",
        "--backend",
        "cpu",
        "--points",
        "10",
        "--threshold",
        "0.12,5",
        "--method",
        "mc",
        "--cov",
        "0.3",
        "--max-evaluations",
        "20000",
        "--svg",
        mc.to_str().unwrap(),
        "-q",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", common::stderr(&o));
    let text = std::fs::read_to_string(mc.join("tail.svg")).unwrap();
    common::check_svg_finite(&text, "mc/tail.svg");
    assert_eq!(text.matches(r#"class="estimate""#).count(), 1);
    assert!(!text.contains("<polyline"));
    assert!(
        text.contains("P_f = 0") && text.contains("L = 5 mm"),
        "no note on the left-out estimate"
    );
    assert!(!log_ticks(&text).is_empty());
}

/// A model with a discrepancy term (heavy-tailed norms, noise unknown): subset simulation in the
/// space of the parameters' and the term's normals (`mc/tail/term.rs`) agrees with crude Monte
/// Carlo on the counter draws, which the kernels draw the term for, within 3 combined standard
/// deviations; the parameters alone give a far smaller probability at the same threshold, so
/// the agreement is the term's.
#[test]
fn a_discrepancy_term_is_part_of_the_tail() {
    use gpu_amcs::discrepancy::{Discrepancy, NoiseSource};
    let mut m = tx60();
    m.discrepancy = Some(
        Discrepancy {
            // exponential-like quantiles: a few large norms, as real residuals have
            residual_norms: (0..200)
                .map(|i| -0.03 * (1.0 - (f64::from(i) + 0.5) / 200.0).ln())
                .collect(),
            robot_share: 1.0,
            noise: NoiseSource::Unknown,
            noise_sigma_mm: None,
            compensation: None,
        }
        .checked()
        .unwrap(),
    );
    let pick = problem(m.clone(), 10, 7);
    let mut w = vec![0.0; 200_000];
    CpuEvaluator::new(pick).evaluate(0, &mut w, None).unwrap();
    w.sort_by(|a, b| b.total_cmp(a));
    // P_f ≈ 1e-3
    let l = w[199];
    let pb = problem(m, 10, 8);
    let ss = run_cpu(&pb, &subset(vec![l], 1000, 0.1, 2_000_000));
    assert_eq!(ss.dimension, 20 + 2 * 10 + 1, "the term's 2m + 1 normals");
    let mc = run_cpu(
        &pb,
        &TailOptions {
            method: TailMethod::MonteCarlo,
            ..subset(vec![l], 1000, 0.05, 2_000_000)
        },
    );
    let (a, b) = (&ss.estimates[0], &mc.estimates[0]);
    let (da, db) = (a.cov.unwrap() * a.p_f, b.cov.unwrap() * b.p_f);
    eprintln!(
        "TX60 + term, 10 points, l = {l:.4} mm: subset {:.4e} ± {da:.1e}, crude MC {:.4e} ± {db:.1e}",
        a.p_f, b.p_f
    );
    assert!((a.p_f - b.p_f).abs() <= 3.0 * da.hypot(db));
    let alone = run_cpu(
        &pb.clone().without_discrepancy(),
        &subset(vec![l], 1000, 0.2, 2_000_000),
    );
    assert!(
        alone.estimates[0].p_f < 0.1 * b.p_f,
        "parameters alone {:.3e}",
        alone.estimates[0].p_f
    );
}
