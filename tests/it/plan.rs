//! The calibration planner (`plan`) against simulated calibrations with known truth: the
//! predicted reliability is honest (the fraction of simulated calibrations whose realised
//! maximum error stays below L matches the predicted R(L)), the planned design beats random and
//! log-det designs where it claims to, and bad input is refused naming the flag.

use crate::common::{self, run, tmpdir};
use gpu_amcs::engine::CpuEvaluator;
use gpu_amcs::identify::chain::{identify_chain, nominal_state, ChainOptions, MeasuredPoint};
use gpu_amcs::identify::chain_fit::{default_free, ChainState};
use gpu_amcs::identify::NoiseModel;
use gpu_amcs::kinematics::{tx60, Joints, RobotModel};
use gpu_amcs::plan::{plan, predict, prediction_problem, Plan, PlanOptions};
use gpu_amcs::sampling::standard_normal;
use rand::{Rng, SeedableRng};

const SIGMA: f64 = 0.01;

fn with_target(mut m: RobotModel, o: &PlanOptions) -> RobotModel {
    m.tool = o.target_mm;
    m
}

/// A true robot near the nominal one: every free MDH parameter off by N(0, 0.2 mm) or
/// N(0, 0.01°), and a placement a little away from the nominal (identity) one.
fn truth(nominal: &RobotModel, seed: u64) -> ChainState {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut t = nominal_state(nominal);
    let lay = nominal.layout();
    for i in default_free(&nominal.fixed, true) {
        if i < lay.n_params() {
            let size = if lay.measured().is_angle(i) {
                0.01f64.to_radians()
            } else {
                0.2
            };
            t.set(i, t.get(i) + size * standard_normal(&mut rng));
        }
    }
    t.base = [1.5, -2.0, 0.7, 2e-3, -1e-3, 3e-3];
    t
}

/// Tracker readings of `t`'s target at `q` (degrees) with noise σ per coordinate.
fn measure(t: &ChainState, q: &[Joints], rng: &mut impl Rng) -> Vec<MeasuredPoint> {
    q.iter()
        .enumerate()
        .map(|(k, q)| {
            let p = t.predict(&q.map(f64::to_radians));
            MeasuredPoint {
                payload_kg: 0.0,
                q_deg: *q,
                position_mm: p.map(|v| v + SIGMA * standard_normal(rng)),
                sigma_mm: None,
                line: k as u64 + 2,
                target: 0,
                sides: None,
            }
        })
        .collect()
}

/// Identifies `t` from measurements at `design`; returns the error at each task point, mm.
fn calibrate(
    nominal: &RobotModel,
    t: &ChainState,
    design: &[Joints],
    task: &[Joints],
    seed: u64,
) -> Vec<f64> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let data = measure(t, design, &mut rng);
    let opts = ChainOptions {
        noise: NoiseModel::Isotropic { sigma_mm: SIGMA },
        ..ChainOptions::default()
    };
    let r = identify_chain(&data, nominal, None, None, &opts).expect("identification");
    task.iter()
        .map(|q| {
            let q = q.map(f64::to_radians);
            let (a, b) = (t.predict(&q), r.state.predict(&q));
            ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
        })
        .collect()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn task(model: &RobotModel) -> Vec<Joints> {
    gpu_amcs::points::generate(model, 50, &Default::default(), 1).expect("task points")
}

#[test]
fn predicted_reliability_matches_simulated_calibrations() {
    let o = PlanOptions {
        random_designs: 5,
        ..PlanOptions::default()
    };
    let nominal = with_target(tx60(), &o);
    let task = task(&nominal);
    let p = plan(&nominal, &task, &o).expect("plan");
    // Thresholds around the predicted bulk; test at the one whose R is nearest 0.6.
    let grid: Vec<f64> = (0..12)
        .map(|k| p.planned.q95_mm * (0.55 + 0.05 * k as f64))
        .collect();
    let mut ev = CpuEvaluator::new(prediction_problem(&p, &task, 7).unwrap());
    let pred = predict(&mut ev, 200_000, &grid).unwrap();
    let r = pred
        .reliability
        .iter()
        .min_by(|a, b| (a.r - 0.6).abs().total_cmp(&(b.r - 0.6).abs()))
        .unwrap();
    assert!((0.3..=0.9).contains(&r.r), "{:?}", pred.reliability);
    // Simulated calibrations: a new true robot and new tracker noise each time.
    let n = 300;
    let below = (0..n)
        .filter(|&k| {
            let t = truth(&nominal, 1000 + k);
            let e = calibrate(&nominal, &t, &p.design_deg, &task, 5000 + k);
            e.iter().cloned().fold(0.0, f64::max) < r.threshold
        })
        .count();
    let frac = below as f64 / n as f64;
    let sd = (r.r * (1.0 - r.r) / n as f64).sqrt();
    eprintln!(
        "L = {:.5} mm: predicted R {:.4} [{:.4}, {:.4}], realised {below}/{n} = {frac:.4} (binomial sd {sd:.4})",
        r.threshold, r.r, r.ci_low, r.ci_high
    );
    assert!(
        (frac - r.r).abs() <= 3.0 * sd + (r.ci_high - r.ci_low) / 2.0,
        "predicted {} realised {frac}",
        r.r
    );
}

/// Medians over the seeds of a design comparison.
struct Comparison {
    /// Held-out RMS at the task points of the planned design, mm.
    planned: f64,
    /// … of the log-det design.
    logdet: f64,
    /// … of a random design within the joint limits.
    random: f64,
    /// The plan's predicted RMS of its design, mm.
    planned_predicted: f64,
    /// The plan's lower bound on the predicted RMS of any design of as many poses, mm.
    bound: f64,
    /// Seeds where the plan's q95 beats the log-det design's.
    wins: usize,
}

/// Median held-out RMS at the task points of the planned, log-det and random designs over
/// `seeds` true robots (one plan per seed: its own candidates), with the plan's prediction and
/// bound, and how often the plan's q95 beats the log-det design's.
fn compare_designs(nominal: RobotModel, seeds: u64) -> Comparison {
    let task = task(&nominal);
    let (mut planned, mut logdet, mut random, mut wins) = (Vec::new(), Vec::new(), Vec::new(), 0);
    let (mut predicted, mut bound) = (Vec::new(), Vec::new());
    for s in 1..=seeds {
        // The random designs below are not checked for self-collision: neither is the plan
        // they are compared with (issue 34's capsules are checked in plan_runnable).
        let o = PlanOptions {
            random_designs: 1,
            seed: s,
            workcell: gpu_amcs::plan::Workcell {
                self_collision: false,
                ..Default::default()
            },
            ..PlanOptions::default()
        };
        let nominal = with_target(nominal.clone(), &o);
        let p: Plan = plan(&nominal, &task, &o).expect("plan");
        wins += usize::from(p.planned.q95_mm < p.log_det_design.q95_mm);
        predicted.push(p.planned.rms_mm);
        bound.push(p.rms_bound_mm);
        assert!(
            p.rms_bound_mm <= p.planned.rms_mm && p.rms_bound_mm <= p.log_det_design.rms_mm,
            "seed {s}: bound {} above a design's prediction",
            p.rms_bound_mm
        );
        let t = truth(&nominal, 100 + s);
        let rms = |design: &[Joints]| {
            let e = calibrate(&nominal, &t, design, &task, 900 + s);
            (e.iter().map(|v| v * v).sum::<f64>() / e.len() as f64).sqrt()
        };
        // A random design within the joint limits less the planner's margin.
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(77 + s);
        let rand_design: Vec<Joints> = (0..o.poses)
            .map(|_| {
                Joints::from_fn(nominal.joints(), |j| {
                    let (lo, hi) = nominal.limits_deg[j];
                    let (lo, hi) = (lo.max(-360.0) + 5.0, hi.min(360.0) - 5.0);
                    rng.random_range(lo..hi)
                })
            })
            .collect();
        // The noise is drawn pose by pose: measure in a fixed order (sorted), so that the
        // figure does not depend on the visiting order the plan chose.
        let mut sorted = p.design_deg.clone();
        sorted.sort_by(|a, b| a.iter().partial_cmp(b.iter()).unwrap());
        planned.push(rms(&sorted));
        logdet.push(rms(&p.log_det_design_deg));
        random.push(rms(&rand_design));
    }
    Comparison {
        planned: median(planned),
        logdet: median(logdet),
        random: median(random),
        planned_predicted: median(predicted),
        bound: median(bound),
        wins,
    }
}

#[test]
fn planned_designs_beat_random_ones_at_the_task_points() {
    for (name, model) in [("TX60", tx60()), ("UR5e", gpu_amcs::presets::ur5e())] {
        let seeds = 30;
        let c = compare_designs(model, seeds);
        eprintln!(
            "{name}: median held-out RMS at the task points over {seeds} true robots: planned {:.5} mm, log-det {:.5} mm, random {:.5} mm (ratio {:.3}); predicted {:.5} mm, bound for any design {:.5} mm ({:.3} of random); planned q95 below log-det's in {}/{seeds}",
            c.planned,
            c.logdet,
            c.random,
            c.planned / c.random,
            c.planned_predicted,
            c.bound,
            c.bound / c.random,
            c.wins
        );
        assert!(
            c.planned < c.logdet,
            "{name}: {} vs log-det {}",
            c.planned,
            c.logdet
        );
        assert!(2 * c.wins > seeds as usize, "{name}: {}/{seeds}", c.wins);
        // The prediction is honest (the realised median within 5 % of it, linearisation and
        // the median of 30 robots), and the plan is within 8 % of the best any design of 30
        // of its candidates could do.
        assert!(
            (c.planned / c.planned_predicted - 1.0).abs() < 0.05,
            "{name}: realised {} predicted {}",
            c.planned,
            c.planned_predicted
        );
        assert!(
            c.planned_predicted <= 1.08 * c.bound,
            "{name}: {} vs bound {}",
            c.planned_predicted,
            c.bound
        );
        // Measured 2026-11-26: TX60 0.785 of random. The UR5e's random designs over its ±360°
        // joints are already nearly as good as any design can be at these task points: the
        // bound is 0.87 of random (planned 0.934), so 0.8 is out of every design's reach.
        if name == "TX60" {
            assert!(
                c.planned <= 0.8 * c.random,
                "{name}: {} vs {}",
                c.planned,
                c.random
            );
        } else {
            assert!(
                c.bound > 0.8 * c.random,
                "{name}: bound {} vs random {}",
                c.bound,
                c.random
            );
            assert!(
                c.planned <= 0.97 * c.random,
                "{name}: {} vs {}",
                c.planned,
                c.random
            );
        }
    }
}

#[test]
fn plan_cli_writes_the_design_and_refuses_bad_input() {
    let d = tmpdir("plan-cli");
    let p = |n: &str| d.join(n).display().to_string();
    let o = run(&[
        "plan",
        "--points",
        "20",
        // Three-number flags amid others, negative values included.
        "--target",
        "30,-20,80",
        "--tracker-at",
        "-2500,0,500",
        "--poses",
        "20",
        "--candidates",
        "400",
        "--draws",
        "20000",
        "--backend",
        "cpu",
        "-q",
        "--out",
        &p("design.csv"),
        "--json",
        &p("plan.json"),
        "--html",
        &p("html"),
    ]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    let csv = std::fs::read_to_string(d.join("design.csv")).unwrap();
    assert_eq!(csv.lines().next(), Some("q1,q2,q3,q4,q5,q6"));
    assert_eq!(csv.lines().count(), 21);
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("plan.json")).unwrap()).unwrap();
    assert_eq!(j["design_deg"].as_array().unwrap().len(), 20);
    assert_eq!(j["target_mm"], serde_json::json!([30.0, -20.0, 80.0]));
    assert_eq!(
        j["tracker"]["position_mm"],
        serde_json::json!([-2500.0, 0.0, 500.0])
    );
    let bound = j["rms_bound_mm"].as_f64().unwrap();
    assert!(bound > 0.0 && bound <= j["planned"]["rms_mm"].as_f64().unwrap());
    let r = &j["prediction"]["reliability"];
    assert_eq!(r.as_array().unwrap().len(), 3);
    assert!(
        j["planned"]["q95_mm"].as_f64().unwrap() < j["random_median"]["q95_mm"].as_f64().unwrap()
    );
    for f in [
        "index.html",
        "plan.json",
        "plan_compare.csv",
        "plan_curve.csv",
        "plan_curve.svg",
    ] {
        assert!(d.join("html").join(f).is_file(), "{f}");
    }
    // Bad input: one line naming the flag, exit 2, no file.
    for (args, flag) in [
        (vec!["--poses", "500"], "--poses"),
        (vec!["--poses", "8"], "--poses"),
        (vec!["--threshold", "0.02,-1"], "--threshold"),
        (vec!["--tracker-sigma", "0"], "--tracker-sigma"),
        (vec!["--tracker-at", "100,0,300"], "--tracker-at"),
        (vec!["--target", "0,0,0"], "--target"),
        (vec!["--target", "1,2", "--poses", "20"], "--target"),
        (
            vec!["--tracker-at", "-3000,0", "--poses", "20"],
            "--tracker-at",
        ),
    ] {
        let out = p("bad.csv");
        let mut a = vec![
            "plan",
            "--points",
            "10",
            "--candidates",
            "400",
            "--backend",
            "cpu",
            "-q",
            "--out",
            &out,
        ];
        a.extend(args.iter().copied());
        let o = run(&a);
        common::assert_fails_naming(&o, flag, "");
        assert!(!d.join("bad.csv").exists(), "{args:?} left a file");
    }
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn plan_for_the_iso9283_poses_gives_each_poses_certificate() {
    let d = tmpdir("plan-iso");
    let j = d.join("plan.json");
    let o = run(&[
        "plan",
        "--iso9283",
        "--candidates",
        "500",
        "--draws",
        "20000",
        "--threshold",
        "0.01,0.015",
        "--backend",
        "cpu",
        "--out",
        d.join("design.csv").to_str().unwrap(),
        "--json",
        j.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("P5  L = 0.01:"), "{text}");
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&j).unwrap()).unwrap();
    assert_eq!(v["task_points"], 5);
    let pr = &v["prediction"];
    let per_point = pr["per_point"].as_array().unwrap();
    assert_eq!(per_point.len(), 5);
    // All five poses within L together is rarer than any one of them; each is a probability.
    for (t, all) in pr["reliability"].as_array().unwrap().iter().enumerate() {
        let r_all = all["r"].as_f64().unwrap();
        for row in per_point {
            let r = row[t]["r"].as_f64().unwrap();
            assert!(r >= r_all && r <= 1.0, "{r} vs {r_all}");
        }
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// A plan from an identified model of the robot carries its discrepancy term into the
/// prediction (what a new geometric calibration leaves too): R at the nominal-only prediction's
/// median falls well below ½; `--no-discrepancy` (a problem without the term) plans without it;
/// a compensated term goes back to the geometric model's size.
#[test]
fn a_plan_from_an_identified_model_predicts_with_its_discrepancy_term() {
    use gpu_amcs::discrepancy::{Discrepancy, NoiseSource};
    use gpu_amcs::engine::{Problem, Reference};
    use gpu_amcs::plan::model_to_plan;
    let o = PlanOptions {
        random_designs: 2,
        ..PlanOptions::default()
    };
    let plain = with_target(tx60(), &o);
    let mut identified = plain.clone();
    identified.discrepancy = Some(
        Discrepancy {
            residual_norms: (1..=40).map(|i| 0.001 * f64::from(i)).collect(),
            robot_share: 1.0,
            noise: NoiseSource::Unknown,
            noise_sigma_mm: None,
            compensation: None,
        }
        .checked()
        .unwrap(),
    );
    let task = task(&plain);
    let problem = Problem::new(identified.clone(), &task, &Reference::Calibrated, 3).unwrap();
    // The model an analysis plans from keeps the term, or leaves it out on request.
    assert!(model_to_plan(&problem).discrepancy.is_some());
    assert!(model_to_plan(&problem.clone().without_discrepancy())
        .discrepancy
        .is_none());
    let predict_median = |m: &RobotModel, at: Option<f64>| {
        let p = plan(m, &task, &o).expect("plan");
        assert_eq!(
            p.model().discrepancy.is_some(),
            m.discrepancy.is_some(),
            "the planned model carries the given model's term"
        );
        let mut ev = CpuEvaluator::new(prediction_problem(&p, &task, 7).unwrap());
        let l = at.unwrap_or(p.planned.q95_mm);
        let pred = predict(&mut ev, 20_000, &[l]).unwrap();
        (pred.reliability[0].r, l)
    };
    let (r_plain, l) = predict_median(&plain, None);
    let (r_term, _) = predict_median(&identified, Some(l));
    eprintln!("R({l:.4} mm): nominal-only {r_plain:.4}, with the term {r_term:.4}");
    assert!(
        r_plain > 0.8 && r_term < 0.5 * r_plain,
        "{r_plain} {r_term}"
    );
}
