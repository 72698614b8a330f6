//! Recorded approach sides (docs/METHOD.md §19.5): pose and measurement files' `s1..sn` columns
//! give the side each joint arrived from, so that a split of the poses keeps them (the order of
//! a subset does not give them), identification fits the gaps to them, and `validate` predicts
//! each held-out pose with its side known.

use crate::backlash::{simulated_backlash_poses, GAPS_DEG};
use crate::common::{arg, run, run_ok, stderr, tmpdir};

/// A TX60 with compliance, harmonics and backlash, 500 poses in random order with their sides
/// recorded, every 5th held out. Identified from the other 400:
/// - with the sides recorded, the gaps of J1–J3 come out within 4σ of the truth; from the
///   order of the 400 alone (the poses after a held-out one compared with the pose before it)
///   they come out low (measured 77 %, 71 % and 42 % of the truth, 4.4–4.6σ);
/// - `validate` with the held-out poses' sides predicts them far closer than without (at the
///   centre of the gaps, with the term for unknown sides), and its 95 % bound covers about 95 %
///   of them either way (100 poses: ±4.4 % at 2σ).
#[test]
fn recorded_sides_survive_a_split_and_sharpen_validation() {
    let d = tmpdir("backlash_sides");
    let (header, rows) = simulated_backlash_poses(&d);
    let sided = |r: &str, s: &[f64; 6]| {
        let s: Vec<String> = s.iter().map(|v| format!("{v}")).collect();
        format!("{r},{}", s.join(","))
    };
    let (mut train_s, mut test_s, mut train_o, mut test_o) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (k, (r, s)) in rows.iter().enumerate() {
        let (with, without) = if k % 5 == 4 {
            (&mut test_s, &mut test_o)
        } else {
            (&mut train_s, &mut train_o)
        };
        with.push(sided(r, s));
        without.push(r.clone());
    }
    let file = |name: &str, head: &str, r: &[String]| -> String {
        let p = arg(&d, name);
        std::fs::write(&p, format!("{head}\n{}\n", r.join("\n"))).unwrap();
        p
    };
    let head_s = format!("{header},s1,s2,s3,s4,s5,s6");
    let (train_s, test_s) = (
        file("train_s.csv", &head_s, &train_s),
        file("test_s.csv", &head_s, &test_s),
    );
    let (train_o, test_o) = (
        file("train_o.csv", &header, &train_o),
        file("test_o.csv", &header, &test_o),
    );
    let identify = |data: &str, name: &str| -> (String, serde_json::Value, String) {
        let (model, json) = (
            arg(&d, &format!("{name}.toml")),
            arg(&d, &format!("{name}.json")),
        );
        let o = run(&[
            "identify",
            data,
            "--beyond-geometry=on",
            "-o",
            &model,
            "--json",
            &json,
        ]);
        let text = String::from_utf8_lossy(&o.stdout).to_string();
        assert!(o.status.success(), "{}", stderr(&o));
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        (model, v, text)
    };
    let gaps = |v: &serde_json::Value| -> Vec<[f64; 2]> {
        let b = &v["identify"]["runs"][0]["chain"]["beyond_geometry"]["backlash"];
        (b["gap_deg"].as_array().unwrap().iter())
            .map(|g| [g[0].as_f64().unwrap(), g[1].as_f64().unwrap()])
            .collect()
    };
    let (model_s, js, text_s) = identify(&train_s, "m_s");
    let (_, jo, text_o) = identify(&train_o, "m_o");
    assert!(
        text_s.contains("approach direction from the data's s1..sn columns"),
        "{text_s}"
    );
    assert!(
        text_o.contains("approach direction from the poses' order"),
        "{text_o}"
    );
    let (gs, go) = (gaps(&js), gaps(&jo));
    eprintln!("gaps with the recorded sides {gs:?}\nfrom the order of the subset {go:?}");
    // The model's two terms: the residuals at the centre of the gaps hold the backlash (the
    // gaps are 5–50 times the 10 µm noise), those with the sides turned do not.
    let r = &js["identify"]["runs"][0]["chain"]["beyond_geometry"]["backlash"]["residual_rms_mm"];
    let (sided, centre) = (r["sided"].as_f64().unwrap(), r["centre"].as_f64().unwrap());
    eprintln!("residual RMS with the sides {sided:.4} mm, at the centre {centre:.4} mm");
    assert!(centre > 3.0 * sided && sided < 0.05, "{r}");
    assert!(
        text_s.contains(&format!("residual RMS {centre:.4} mm at the centre")),
        "{text_s}"
    );
    for j in 0..3 {
        let [g, s] = gs[j];
        assert!((g - GAPS_DEG[j]).abs() < 4.0 * s, "J{}: {g} ± {s}", j + 1);
    }
    for j in 0..3 {
        let [g, s] = go[j];
        assert!(
            g < 0.85 * GAPS_DEG[j],
            "J{} from the subset's order: {g} ± {s}",
            j + 1
        );
    }
    let validate = |test: &str, name: &str| -> (f64, f64) {
        let json = arg(&d, &format!("{name}.json"));
        run_ok(&["validate", "--model", &model_s, test, "--json", &json]);
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        (
            v["model"]["errors_mm"]["rms_mm"].as_f64().unwrap(),
            v["predictive_check"]["with_term"]["coverage_95"]
                .as_f64()
                .unwrap(),
        )
    };
    let (rms_known, cov_known) = validate(&test_s, "v_s");
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(arg(&d, "v_s.json")).unwrap()).unwrap();
    assert_eq!(v["recorded_sides"]["poses"], 100);
    assert_eq!(v["recorded_sides"]["used"], true);
    assert_eq!(v["recorded_sides"]["complete"], 100);
    let o = run(&["validate", "--model", &model_s, &test_s]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains(
            "approach sides recorded at 100 poses, every side at 100: those predicted with them"
        ),
        "{text}"
    );
    // A model without backlash says the sides change nothing, and predicts as without them.
    let geometric = arg(&d, "geometric.toml");
    run_ok(&[
        "identify",
        &train_s,
        "--beyond-geometry=off",
        "-o",
        &geometric,
    ]);
    let with = run(&["validate", "--model", &geometric, &test_s]);
    let without = run(&["validate", "--model", &geometric, &test_o]);
    let (with, without) = (
        String::from_utf8_lossy(&with.stdout).to_string(),
        String::from_utf8_lossy(&without.stdout).to_string(),
    );
    assert!(
        with.contains("the model has no backlash, so they change nothing"),
        "{with}"
    );
    let table = |t: &str| t.lines().take(3).collect::<Vec<_>>().join("\n");
    assert_eq!(table(&with), table(&without));
    let (rms_centre, cov_centre) = validate(&test_o, "v_o");
    eprintln!(
        "held out: sides known RMS {rms_known:.4} mm, covered {cov_known}; at the centre RMS {rms_centre:.4} mm, covered {cov_centre}"
    );
    assert!(
        rms_known < 0.5 * rms_centre,
        "{rms_known} against {rms_centre}"
    );
    assert!((0.90..=0.995).contains(&cov_known), "{cov_known}");
    assert!((0.90..=0.995).contains(&cov_centre), "{cov_centre}");
}

/// A side that is not −1, 0 or 1 is refused naming its column and line, in a pose file and in a
/// measurement file; a column for a joint the robot does not have too.
#[test]
fn a_bad_side_names_its_column_and_line() {
    let d = tmpdir("backlash_sides_bad");
    let q = "q1,q2,q3,q4,q5,q6,x,y,z";
    let row = "0,10,80,0,30,0,500,0,600";
    let bad = arg(&d, "bad.csv");
    std::fs::write(&bad, format!("{q},s1,s3\n{row},1,0\n{row},-1,x\n")).unwrap();
    let model = arg(&d, "m.toml");
    run_ok(&["model", "--preset", "tx60", "-o", &model]);
    for args in [
        vec!["identify", bad.as_str(), "-o", &arg(&d, "out.toml")],
        vec!["validate", "--model", &model, bad.as_str()],
    ] {
        let o = run(&args);
        let err = stderr(&o);
        assert!(!o.status.success(), "{args:?}");
        assert!(
            err.contains("line 3") && err.contains("s3 = 'x' is not a side"),
            "{args:?}: {err}"
        );
    }
    std::fs::write(&bad, format!("{q},s7\n{row},1\n")).unwrap();
    let o = run(&["validate", "--model", &model, &bad]);
    let err = stderr(&o);
    assert!(!o.status.success() && err.contains("'s7'"), "{err}");
}

/// A prediction that knows the sides (`Problem::predict_known_sides`, as `validate` builds it
/// for poses with recorded sides): on a model whose only uncertainty is the backlash, with
/// every side known, every draw stands where the prediction puts the target (error 0 to
/// rounding), and that prediction is the model's own (`RobotModel::predicted_position` with
/// `side_turns`), half the gap from the commanded chain on each known side. With J1's side left
/// unknown every draw turns J1 by ±h from that prediction.
#[test]
fn a_prediction_with_every_side_known_leaves_the_backlash_no_spread() {
    use crate::backlash::{only_backlash, points};
    use gpu_amcs::engine::{CpuEvaluator, Evaluator, Problem, Reference};
    use gpu_amcs::kinematics::{position, Joints};
    let gaps = [0.08, 0.05, 0.03, 0.0, 0.0, 0.0];
    let model = only_backlash(&gaps);
    let pts = points();
    let m = pts.len();
    let side = |j: usize, i: usize| {
        if (j * 7 + i).is_multiple_of(3) {
            -1.0
        } else {
            1.0
        }
    };
    let known: Vec<Joints> = (0..m).map(|j| Joints::from_fn(6, |i| side(j, i))).collect();
    let mut p = Problem::new(model.clone(), &pts, &Reference::Calibrated, 5).unwrap();
    p.predict_known_sides(&known).unwrap();
    for (j, q) in pts.iter().enumerate() {
        let q: Vec<f64> = q.iter().map(|v| v.to_radians()).collect();
        let t = model.side_turns(&known[j]).unwrap();
        for i in 0..6 {
            assert_eq!(t[i], side(j, i) * 0.5 * gaps[i].to_radians());
        }
        let want = model.predicted_position(&q, Some(&t), false, false);
        let chain: Vec<f64> = (0..6).map(|i| p.chain_points[j][i] + t[i]).collect();
        let direct = position(&model.params, &model.tool, &chain);
        for k in 0..3 {
            assert!((p.reference[j][k] - want[k]).abs() < 1e-12);
            assert!((direct[k] - want[k]).abs() < 1e-12);
        }
    }
    let n = 128;
    let (mut w, mut e) = (vec![0.0; n], vec![0.0; n * m]);
    CpuEvaluator::new(p)
        .evaluate(0, &mut w, Some(&mut e))
        .unwrap();
    assert!(
        e.iter().all(|&v| v < 1e-9),
        "{:e}",
        e.iter().fold(0.0f64, |a, &b| a.max(b))
    );
    // J1's side unknown: the prediction leaves J1 where the chain puts it and every draw turns
    // it by ±h, so each point's error is the chord of that turn (the same either side).
    let half: Vec<Joints> = (known.iter())
        .map(|s| Joints::from_fn(6, |i| if i == 0 { 0.0 } else { s[i] }))
        .collect();
    let mut p = Problem::new(model.clone(), &pts, &Reference::Calibrated, 5).unwrap();
    p.predict_known_sides(&half).unwrap();
    let h1 = 0.5 * gaps[0].to_radians();
    let chord: Vec<f64> = (0..m)
        .map(|j| {
            let t = model.side_turns(&half[j]).unwrap();
            let chain: Vec<f64> = (0..6)
                .map(|i| p.chain_points[j][i] + t[i] + if i == 0 { h1 } else { 0.0 })
                .collect();
            let x = position(&model.params, &model.tool, &chain);
            (0..3)
                .map(|k| (x[k] - p.reference[j][k]).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .collect();
    let (mut w, mut e) = (vec![0.0; n], vec![0.0; n * m]);
    CpuEvaluator::new(p)
        .evaluate(0, &mut w, Some(&mut e))
        .unwrap();
    for k in 0..n {
        for j in 0..m {
            assert!(chord[j] > 1e-3, "point {j}: {}", chord[j]);
            assert!((e[k * m + j] - chord[j]).abs() < 1e-9, "draw {k} point {j}");
        }
    }
}

/// Pose and measurement files keep their sides when written and read back, and repeated
/// measurements of one pose from different sides stay separate poses.
#[test]
fn files_keep_their_sides() {
    use gpu_amcs::identify::poses::{parse_poses, write_poses};
    use gpu_amcs::identify::repeats::pose_groups;
    use gpu_amcs::identify::validate::{parse_measurements, write_measurements};
    let text = "q1,q2,q3,q4,q5,q6,x,y,z,s1,s2,s3,s4,s5,s6\n\
                0,10,80,0,30,0,500,0,600,1,-1,0,1,1,1\n\
                0,10,80,0,30,0,500.01,0,600,-1,-1,0,1,1,1\n\
                0,10,80,0,30,0,500.02,0,600,-1,-1,0,1,1,1\n";
    let data = parse_poses(text.as_bytes(), "poses").unwrap();
    let pts = &data.runs[0].points;
    assert_eq!(&*pts[0].sides.unwrap(), &[1.0, -1.0, 0.0, 1.0, 1.0, 1.0]);
    assert_eq!(pose_groups(&data.runs[0]), vec![vec![0], vec![1, 2]]);
    let mut out = Vec::new();
    write_poses(&data, &mut out).unwrap();
    assert_eq!(parse_poses(out.as_slice(), "again").unwrap(), data);
    let m = parse_measurements(text.as_bytes(), "measured").unwrap();
    assert_eq!(&*m[1].sides.unwrap(), &[-1.0, -1.0, 0.0, 1.0, 1.0, 1.0]);
    let mut out = Vec::new();
    write_measurements(&m, &mut out).unwrap();
    let back = parse_measurements(out.as_slice(), "again").unwrap();
    for (a, b) in m.iter().zip(&back) {
        assert_eq!(a.sides, b.sides);
    }
    // Without the columns, none.
    let plain = parse_poses(
        "q1,q2,q3,q4,q5,q6,x,y,z\n0,10,80,0,30,0,500,0,600\n".as_bytes(),
        "p",
    )
    .unwrap();
    assert!(plain.runs[0].points[0].sides.is_none());
}

/// The simulator's backlash (`simulate --backlash`, `simulate_poses_sided`): noise free, each
/// pose is forward kinematics of the commanded angles plus the deflections plus half of each
/// joint's gap on the side it arrived from, the sides from the poses' order (none at the first)
/// or as given; the pose records them. Without backlash nothing changes, bit for bit.
#[test]
fn the_simulator_stands_each_joint_half_its_gap_on_its_side() {
    use gpu_amcs::kinematics::{position, tx60, BaseTransform, Joints};
    use gpu_amcs::simulate::{
        random_poses, simulate_poses_at, simulate_poses_sided, NonGeometric, NonGeometricSizes,
        TrackerNoise,
    };
    let truth = tx60();
    let sizes = NonGeometricSizes {
        compliance: 1.0,
        harmonics: 1.0,
        backlash: 2.0,
        ..NonGeometricSizes::none()
    };
    let e = NonGeometric::draw(&truth, &sizes, 7).unwrap();
    for j in 0..6 {
        assert_eq!(e.backlash_deg[j], 2.0 * GAPS_DEG[j]);
    }
    let qs = random_poses(&truth, 40, 3);
    let place = BaseTransform {
        xyz: [0.0; 3],
        rpy: [0.0; 3],
    };
    let exact = TrackerNoise::Isotropic(0.0);
    let at = |q: &Joints, s: &[f64]| {
        let mut a = e.actual_angles(&truth, &q.map(f64::to_radians));
        for j in 0..6 {
            a[j] += 0.5 * (2.0 * GAPS_DEG[j]).to_radians() * s[j];
        }
        position(&truth.params, &truth.tool, &a)
    };
    let from_order = simulate_poses_sided(&truth, Some(&e), &qs, None, &[], &place, &exact, 1);
    let given: Vec<Joints> = (0..qs.len())
        .map(|k| Joints::from_fn(6, |j| if (k + j) % 3 == 0 { -1.0 } else { 1.0 }))
        .collect();
    let fixed = simulate_poses_sided(&truth, Some(&e), &qs, Some(&given), &[], &place, &exact, 1);
    for k in 0..qs.len() {
        let s: Vec<f64> = (0..6)
            .map(|j| match k {
                0 => 0.0,
                _ => (qs[k][j] - qs[k - 1][j]).signum(),
            })
            .collect();
        let p = &from_order.runs[0].points[k];
        assert_eq!(&*p.sides.unwrap(), &s[..]);
        let want = at(&qs[k], &s);
        let q = &fixed.runs[0].points[k];
        let want_given = at(&qs[k], &given[k]);
        for c in 0..3 {
            assert!((p.position_mm[c] - want[c]).abs() < 1e-9, "pose {k}");
            assert!((q.position_mm[c] - want_given[c]).abs() < 1e-9, "pose {k}");
        }
    }
    // Without backlash: simulate_poses_at's bits, and no sides.
    let rigid = NonGeometric {
        backlash_deg: Joints::filled(6, 0.0),
        ..e.clone()
    };
    let noisy = TrackerNoise::Isotropic(0.01);
    let a = simulate_poses_sided(&truth, Some(&rigid), &qs, None, &[], &place, &noisy, 4);
    let b = simulate_poses_at(&truth, Some(&rigid), &qs, &[], &place, &noisy, 4);
    assert_eq!(a, b);
    assert!(a.runs[0].points.iter().all(|p| p.sides.is_none()));
}

/// End to end: `simulate --backlash 1` writes the sides, identify recovers the gaps of J1–J3
/// within 4σ; a plan with `--approach positive` measured by the simulator arrives from the
/// positive side at every pose, and identification then finds no joint arriving from both
/// sides (no backlash check: the gaps are offsets the zeros take up). A sweep simulation with
/// backlash is refused naming the flag.
#[test]
fn simulated_backlash_from_the_command_line() {
    let d = tmpdir("backlash_sim");
    let poses = arg(&d, "poses.csv");
    run_ok(&[
        "simulate",
        "--poses",
        "300",
        "--robot-seed",
        "2025",
        "--seed",
        "5",
        "--compliance",
        "1",
        "--harmonics",
        "1",
        "--backlash",
        "1",
        "--tracker-sigma",
        "0.01",
        "-o",
        &poses,
    ]);
    let text = std::fs::read_to_string(&poses).unwrap();
    assert!(text.lines().next().unwrap().ends_with(",s1,s2,s3,s4,s5,s6"));
    let json = arg(&d, "m.json");
    run_ok(&[
        "identify",
        &poses,
        "--beyond-geometry=on",
        "-o",
        &arg(&d, "m.toml"),
        "--json",
        &json,
    ]);
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let g = &v["identify"]["runs"][0]["chain"]["beyond_geometry"]["backlash"]["gap_deg"];
    for j in 0..3 {
        let (gap, s) = (g[j][0].as_f64().unwrap(), g[j][1].as_f64().unwrap());
        assert!(
            (gap - GAPS_DEG[j]).abs() < 4.0 * s,
            "J{}: {gap} ± {s}",
            j + 1
        );
    }
    // identify's default runs no backlash check, and says the data would allow one.
    let o = run(&["identify", &poses, "-o", &arg(&d, "auto.toml")]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("the data record the side each joint arrived from (s1..sn)"),
        "{text}"
    );
    let (design, planned) = (arg(&d, "design.csv"), arg(&d, "planned.csv"));
    run_ok(&[
        "plan",
        "--poses",
        "12",
        "--candidates",
        "300",
        "--draws",
        "1000",
        "--points",
        "5",
        "--approach",
        "positive",
        "--out",
        &design,
        "-q",
    ]);
    run_ok(&[
        "simulate",
        "--points-file",
        &design,
        "--poses",
        "12",
        "--backlash",
        "1",
        "--tracker-sigma",
        "0.01",
        "-o",
        &planned,
    ]);
    let text = std::fs::read_to_string(&planned).unwrap();
    assert!(
        text.lines().skip(1).all(|l| l.ends_with(",1,1,1,1,1,1")),
        "{text}"
    );
    let o = run(&[
        "identify",
        &planned,
        "--beyond-geometry=on",
        "-o",
        &arg(&d, "p.toml"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!String::from_utf8_lossy(&o.stdout).contains("backlash ("));
    let o = run(&["simulate", "--backlash", "1", "-o", &arg(&d, "sweeps.csv")]);
    assert!(!o.status.success() && stderr(&o).contains("--backlash: simulated for pose data"));
    let o = run(&[
        "simulate",
        "--poses",
        "5",
        "--backlash",
        "11",
        "-o",
        &arg(&d, "x.csv"),
    ]);
    assert!(!o.status.success() && stderr(&o).contains("--backlash: 11 is not a scale in 0–10"));
}

/// Given configurations can carry their sides in the spec (the Python keyword `sides`, a job
/// file's `sides`): the problem it builds fixes them as a points file's `s1..sn` would, and
/// sides without given configurations, of another count, or for a model without backlash are
/// refused naming the field.
#[test]
fn given_configurations_carry_their_sides_in_the_spec() {
    use crate::backlash::{only_backlash, points};
    use gpu_amcs::engine::{CpuEvaluator, Evaluator, Problem, Reference};
    use gpu_amcs::kinematics::Joints;
    use gpu_amcs::spec::{GeneratedPoints, ModelSource, PointsSource, ProblemSpec, SpecField};
    let gaps = [0.08, 0.05, 0.03, 0.0, 0.0, 0.0];
    let model = only_backlash(&gaps);
    let pts = points();
    let m = pts.len();
    let known: Vec<Joints> = (0..m)
        .map(|j| Joints::from_fn(6, |i| if (j + i) % 2 == 0 { 1.0 } else { -1.0 }))
        .collect();
    let given: Vec<Joints> = pts.iter().map(|q| Joints::from_fn(6, |i| q[i])).collect();
    let spec = ProblemSpec {
        model: ModelSource::Model(Box::new(model.clone())),
        points: PointsSource::Given(given.clone()),
        seed: 5,
        sides: Some(known.clone()),
        ..ProblemSpec::default()
    };
    let built = spec.build_problem().unwrap().problem;
    let mut direct = Problem::new(model.clone(), &pts, &Reference::Calibrated, 5).unwrap();
    direct.set_known_sides(&known).unwrap();
    let n = 64;
    let eval = |p: Problem| {
        let (mut w, mut e) = (vec![0.0; n], vec![0.0; n * m]);
        CpuEvaluator::new(p)
            .evaluate(0, &mut w, Some(&mut e))
            .unwrap();
        e
    };
    let (a, b) = (eval(built), eval(direct));
    assert_eq!(a, b, "the spec's sides are the problem's");
    // Every side known: each point's error is the same in every draw (no spread), and not 0
    // (the reference stays the calibrated chain's).
    for j in 0..m {
        assert!(a[j] > 1e-4, "point {j}: {}", a[j]);
        assert!((0..n).all(|k| a[k * m + j] == a[j]), "point {j} spreads");
    }
    // Without the sides every draw draws them: the errors spread.
    let free = ProblemSpec {
        sides: None,
        ..spec.clone()
    };
    let c = eval(free.build_problem().unwrap().problem);
    assert!((0..m).any(|j| (0..n).any(|k| c[k * m + j] != c[j])));
    let refused = |s: ProblemSpec, what: &str| {
        let Err(e) = s.build_problem() else {
            panic!("{what}: accepted")
        };
        assert_eq!(e.field, SpecField::Sides, "{what}: {e}");
        e.to_string()
    };
    let msg = refused(
        ProblemSpec {
            points: PointsSource::Generate(GeneratedPoints {
                count: m,
                ..GeneratedPoints::default()
            }),
            ..spec.clone()
        },
        "generated points",
    );
    assert!(msg.contains("only given configurations"), "{msg}");
    refused(
        ProblemSpec {
            sides: Some(known[..m - 1].to_vec()),
            ..spec.clone()
        },
        "one row short",
    );
    let mut bad = known.clone();
    bad[1] = Joints::from_fn(6, |_| 2.0);
    refused(
        ProblemSpec {
            sides: Some(bad),
            ..spec.clone()
        },
        "a side of 2",
    );
    let mut plain = model.clone();
    plain.joint_errors = None;
    refused(
        ProblemSpec {
            model: ModelSource::Model(Box::new(plain)),
            ..spec
        },
        "a model without backlash",
    );
}

/// An analysis's note says what it does with the backlash's sides: given at every point, at
/// some (counted over the joints with a gap), or drawn at every point with what drawing them
/// showed on real data.
#[test]
fn the_note_says_whether_the_sides_are_given_or_drawn() {
    use crate::backlash::{only_backlash, points};
    use crate::common::stdout;
    let d = tmpdir("backlash_sides_note");
    let model = arg(&d, "lash.toml");
    // Gaps on J1–J3: 3 joints × 5 points.
    std::fs::write(
        &model,
        only_backlash(&[0.08, 0.05, 0.03, 0.0, 0.0, 0.0]).to_toml(),
    )
    .unwrap();
    let pts = points();
    let write = |name: &str, side: &dyn Fn(usize, usize) -> i32| {
        let rows: Vec<String> = (pts.iter().enumerate())
            .map(|(j, q)| {
                let q: Vec<String> = q.iter().map(|v| v.to_string()).collect();
                let s: Vec<String> = (0..6).map(|i| side(j, i).to_string()).collect();
                format!("{},{}", q.join(","), s.join(","))
            })
            .collect();
        let f = arg(&d, name);
        std::fs::write(
            &f,
            format!("q1,q2,q3,q4,q5,q6,s1,s2,s3,s4,s5,s6\n{}\n", rows.join("\n")),
        )
        .unwrap();
        f
    };
    let all = write("all.csv", &|_, _| 1);
    let some = write("some.csv", &|j, i| if j == 0 && i == 1 { 0 } else { -1 });
    let none = write("none.csv", &|_, _| 0);
    let note = |file: &str| {
        let o = run(&[
            "mcs",
            "--model",
            &model,
            "--points-file",
            file,
            "--draws",
            "2000",
            "--backend",
            "cpu",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let out = stdout(&o);
        out.lines()
            .find(|l| l.contains("joint errors drawn"))
            .unwrap_or_else(|| panic!("no joint errors note: {out}"))
            .to_string()
    };
    assert!(note(&all).ends_with("its sides given at every point"));
    assert!(note(&some)
        .ends_with("its sides given for 14 of the 15 (point, joint) pairs, the rest drawn"));
    let drawn = note(&none);
    assert!(
        drawn.contains("its sides drawn at every point, as they are not known there"),
        "{drawn}"
    );
    assert!(
        drawn.contains("91.8 %") && drawn.contains("95.4 %"),
        "{drawn}"
    );
}
