//! Several targets (reflectors) on the tool measured at each pose, as trackers and some public
//! data sets record them: one `target` column, identified together (one offset each, one chain
//! and placement), checked against a simulated robot whose truth is known; validation compares
//! the model's own target; bad labels are refused naming the line.

use crate::common::{run, run_ok, stderr, stdout, tmpdir};
use gpu_amcs::kinematics::{BaseTransform, Joints, RobotModel};
use gpu_amcs::presets::preset;
use gpu_amcs::simulate::{perturbed_model, random_configurations, ParameterErrors};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::fmt::Write;
use std::path::Path;

/// The reflectors in the flange frame, mm: the first is the model's tool.
const TARGETS: [(&str, [f64; 3]); 3] = [
    ("SMR1", [30.0, -20.0, 80.0]),
    ("SMR2", [-45.0, 25.0, 95.0]),
    ("SMR3", [5.0, 55.0, 60.0]),
];
const SIGMA: f64 = 0.01;

/// A TX60 off its nominal geometry (the simulator's default errors), 2.4 m from the tracker.
/// Joint 6 keeps its nominal parameters: a fit holds them there (the targets' offsets take up
/// any error of the last link, so only then are the offsets the truth's, to compare).
pub(crate) fn truth(rng: &mut ChaCha8Rng) -> RobotModel {
    let nominal = preset("tx60").unwrap();
    let mut t = perturbed_model(&nominal, &ParameterErrors::default(), TARGETS[0].1, rng);
    t.params[25..30].copy_from_slice(&nominal.params[25..30]);
    t.base = Some(BaseTransform {
        xyz: [2400.0, -300.0, 150.0],
        rpy: [0.02, -0.03, 2.1],
    });
    t
}

/// Pose rows `q1..q6,x,y,z,target` of `targets` at `n` poses (noise σ), in pose order.
fn rows(
    t: &RobotModel,
    qs: &[Joints],
    targets: &[(&str, [f64; 3])],
    rng: &mut ChaCha8Rng,
) -> String {
    let mut s = String::from("q1,q2,q3,q4,q5,q6,x,y,z,target\n");
    for q in qs {
        for (label, offset) in targets {
            let mut m = t.clone();
            m.tool = *offset;
            let p = m.world_position(&q.map(f64::to_radians));
            let q: Vec<String> = q.iter().map(|v| format!("{v:.9}")).collect();
            let _ = writeln!(
                s,
                "{},{:.6},{:.6},{:.6},{label}",
                q.join(","),
                p[0] + SIGMA * gpu_amcs::sampling::standard_normal(rng),
                p[1] + SIGMA * gpu_amcs::sampling::standard_normal(rng),
                p[2] + SIGMA * gpu_amcs::sampling::standard_normal(rng),
            );
        }
    }
    s
}

/// Configurations within the limits, kept 10° inside them.
pub(crate) fn configs(t: &RobotModel, n: usize, rng: &mut ChaCha8Rng) -> Vec<Joints> {
    let mut lim = t.limits_deg;
    for l in lim.iter_mut() {
        *l = (l.0 + 10.0, l.1 - 10.0);
    }
    random_configurations(&lim, n, rng)
}

/// `identify DATA -o MODEL`, which must succeed.
pub(crate) fn identify_to(data: &Path, model: &Path) {
    run_ok(&[
        "identify",
        data.to_str().unwrap(),
        "-o",
        model.to_str().unwrap(),
    ]);
}

/// `validate DATA --model MODEL --json FILE` (must succeed): the JSON document.
pub(crate) fn validate_json(data: &Path, model: &Path, json: &Path) -> serde_json::Value {
    run_ok(&[
        "validate",
        data.to_str().unwrap(),
        "--model",
        model.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
    ]);
    serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap()
}

/// Three reflectors at 40 poses: one chain, the first reflector the model's tool, each offset
/// within 4σ of the truth, the model predicting held-out poses of its target within the noise,
/// and validation comparing that target's rows alone.
#[test]
fn several_reflectors_identify_one_chain() {
    let dir = tmpdir("multi_target");
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let t = truth(&mut rng);
    let fit_q = configs(&t, 40, &mut rng);
    let data = dir.join("poses.csv");
    std::fs::write(&data, rows(&t, &fit_q, &TARGETS, &mut rng)).unwrap();
    let model = dir.join("m.toml");
    let json = dir.join("r.json");
    let d = data.to_str().unwrap();
    let o = run(&[
        "identify",
        d,
        "-o",
        model.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o) + &stderr(&o);
    assert!(text.contains("targets: 3 measured at each pose"), "{text}");
    assert!(text.contains("'SMR2' (target2)"), "{text}");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let chain = &report["identify"]["runs"][0]["chain"];
    assert_eq!(chain["points"], 120);
    assert_eq!(
        chain["targets"],
        serde_json::json!(["SMR1", "SMR2", "SMR3"])
    );
    let row = |name: &str| -> (f64, f64) {
        let r = chain["parameters"]
            .as_array()
            .unwrap()
            .iter()
            .find(|p| p["name"] == name)
            .unwrap_or_else(|| panic!("no row {name}"));
        (r["value"].as_f64().unwrap(), r["sigma"].as_f64().unwrap())
    };
    for (k, (_, offset)) in TARGETS.iter().enumerate() {
        for (a, axis) in ["x", "y", "z"].iter().enumerate() {
            let name = if k == 0 {
                format!("tool_{axis}")
            } else {
                format!("target{}_{axis}", k + 1)
            };
            let (v, s) = row(&name);
            assert!(s > 0.0 && s < 0.05, "{name}: σ {s}");
            assert!(
                (v - offset[a]).abs() < 4.0 * s,
                "{name}: {v} ± {s}, truth {}",
                offset[a]
            );
        }
    }
    let text = std::fs::read_to_string(&model).unwrap();
    assert!(text.contains("target = \"SMR1\""), "{text}");
    // Held-out poses of all three targets: validation takes SMR1's and says so.
    let held = dir.join("held.csv");
    let held_q = configs(&t, 30, &mut rng);
    std::fs::write(&held, rows(&t, &held_q, &TARGETS, &mut rng)).unwrap();
    let vj = dir.join("v.json");
    let v = validate_json(&held, &model, &vj);
    assert_eq!(v["target"]["label"], "SMR1");
    assert_eq!(v["target"]["left_out"], 60);
    let rms = v["model"]["errors_mm"]["rms_mm"].as_f64().unwrap();
    // 3-D noise of one measurement is √3·σ = 0.017 mm; the model's own error adds a little
    assert!(rms < 0.03, "held-out RMS {rms}");
    // A model identified without a target column cannot pick one of three.
    let single = dir.join("single.csv");
    std::fs::write(
        &single,
        rows(&t, &fit_q, &TARGETS[..1], &mut rng)
            .replace(",target\n", "\n")
            .replace(",SMR1\n", "\n"),
    )
    .unwrap();
    let m1 = dir.join("m1.toml");
    identify_to(&single, &m1);
    let o = run(&[
        "validate",
        held.to_str().unwrap(),
        "--model",
        m1.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("the rows measure 3 targets (SMR1, SMR2, SMR3)"),
        "{}",
        stderr(&o)
    );
}

/// Three reflectors determine the chain better than one at the same poses: the identified
/// parameters' variances shrink (more equations, and the flange's orientation is seen).
#[test]
fn three_reflectors_sharpen_the_chain() {
    let dir = tmpdir("multi_target_sharper");
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    let t = truth(&mut rng);
    let q = configs(&t, 40, &mut rng);
    let variance = |targets: &[(&str, [f64; 3])], rng: &mut ChaCha8Rng, name: &str| -> f64 {
        let data = dir.join(format!("{name}.csv"));
        std::fs::write(&data, rows(&t, &q, targets, rng)).unwrap();
        let json = dir.join(format!("{name}.json"));
        run_ok(&[
            "identify",
            data.to_str().unwrap(),
            "--json",
            json.to_str().unwrap(),
        ]);
        let r: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        r["identify"]["runs"][0]["chain"]["parameters"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|p| p["status"] == "identified" && p["unit"] == "mm")
            .filter(|p| !p["name"].as_str().unwrap().starts_with("target"))
            .map(|p| p["sigma"].as_f64().unwrap().powi(2))
            .sum()
    };
    let three = variance(&TARGETS, &mut rng, "three");
    let one = variance(&TARGETS[..1], &mut rng, "one");
    assert!(three < 0.5 * one, "three {three} one {one}");
}

/// Labels that cannot be used are refused naming the file, the line and the column; a run
/// that leaves a target out is refused naming both.
#[test]
fn bad_target_labels_are_refused() {
    let dir = tmpdir("multi_target_bad");
    let mut rng = ChaCha8Rng::seed_from_u64(13);
    let t = truth(&mut rng);
    let q = configs(&t, 30, &mut rng);
    let good = rows(&t, &q, &TARGETS, &mut rng);
    let empty = dir.join("empty.csv");
    let mut lines: Vec<String> = good.lines().map(str::to_string).collect();
    let cut = lines[5].rfind(',').unwrap();
    lines[5].truncate(cut + 1);
    std::fs::write(&empty, lines.join("\n") + "\n").unwrap();
    let o = run(&["identify", empty.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(
        e.contains("line 6") && e.contains("column target is empty"),
        "{e}"
    );
    let nine = dir.join("nine.csv");
    let mut s = String::from("q1,q2,q3,q4,q5,q6,x,y,z,target\n");
    for k in 0..9 {
        let _ = writeln!(s, "0,-90,90,0,0,{k},1000,0,{k},T{k}");
    }
    std::fs::write(&nine, s).unwrap();
    let o = run(&["identify", nine.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("at most 8 targets"), "{}", stderr(&o));
    // run A measures SMR1 and SMR2 only
    let runs = dir.join("runs.csv");
    let mut s = String::from("q1,q2,q3,q4,q5,q6,x,y,z,target,run\n");
    for (k, l) in good.lines().skip(1).enumerate() {
        let run = if k < 45 { "A" } else { "B" };
        if run == "A" && l.ends_with("SMR3") {
            continue;
        }
        let _ = writeln!(s, "{l},{run}");
    }
    std::fs::write(&runs, s).unwrap();
    let o = run(&["identify", runs.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(
        e.contains("target 'SMR3' has no rows") && e.contains("run A"),
        "{e}"
    );
}

/// `simulate --other-target` writes the readings of further reflectors after each pose's row,
/// labelled T1, T2, …; the target's own rows keep their bits, and identify takes the file.
#[test]
fn simulate_writes_several_reflectors() {
    let dir = tmpdir("multi_target_simulate");
    let (a, b) = (dir.join("a.csv"), dir.join("b.csv"));
    run_ok(&[
        "simulate",
        "--poses",
        "30",
        "--seed",
        "3",
        "-o",
        a.to_str().unwrap(),
    ]);
    let o = run(&[
        "simulate",
        "--poses",
        "30",
        "--seed",
        "3",
        "--other-target",
        "-45,25,95",
        "--other-target",
        "5,55,60",
        "-o",
        b.to_str().unwrap(),
    ]);
    let said = stdout(&o) + &stderr(&o);
    assert!(said.contains("30 poses (3 reflectors each)"), "{said}");
    let plain = std::fs::read_to_string(&a).unwrap();
    let three = std::fs::read_to_string(&b).unwrap();
    let rows: Vec<&str> = three.lines().collect();
    assert_eq!(rows[0], format!("{},target", plain.lines().next().unwrap()));
    assert_eq!(rows.len(), 1 + 90);
    for (k, l) in plain.lines().skip(1).enumerate() {
        assert_eq!(rows[1 + 3 * k], format!("{l},T1"));
        assert!(rows[2 + 3 * k].ends_with(",T2") && rows[3 + 3 * k].ends_with(",T3"));
    }
    let o = run(&["identify", b.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("targets: 3 measured at each pose"),
        "{}",
        stdout(&o)
    );
    let o = run(&[
        "simulate",
        "--poses",
        "3",
        "--other-target",
        "1,2",
        "-o",
        a.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("--other-target needs three numbers"),
        "{}",
        stderr(&o)
    );
}

/// ISO 9283 cycles written with every reflector's rows: the figures are the model's own
/// reflector's (mixed in, the others would put each pose's mean 100 mm off).
#[test]
fn iso9283_cycles_take_the_models_reflector() {
    let dir = tmpdir("multi_target_iso");
    let mut rng = ChaCha8Rng::seed_from_u64(14);
    let t = truth(&mut rng);
    let data = dir.join("poses.csv");
    let fit_q = configs(&t, 40, &mut rng);
    std::fs::write(&data, rows(&t, &fit_q, &TARGETS, &mut rng)).unwrap();
    let model = dir.join("m.toml");
    run_ok(&[
        "identify",
        data.to_str().unwrap(),
        "-o",
        model.to_str().unwrap(),
    ]);
    let poses = configs(&t, 5, &mut rng);
    let cycles_q: Vec<Joints> = (0..10).flat_map(|_| poses.iter().copied()).collect();
    let cycles = dir.join("cycles.csv");
    std::fs::write(&cycles, rows(&t, &cycles_q, &TARGETS, &mut rng)).unwrap();
    let json = dir.join("iso.json");
    let o = run(&[
        "validate",
        "--model",
        model.to_str().unwrap(),
        cycles.to_str().unwrap(),
        "--iso9283",
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("the cycles of 'SMR1', the model's own reflector (100 rows of other reflectors left out)"),
        "{}",
        stderr(&o)
    );
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let p = j["poses"].as_array().unwrap();
    assert_eq!(p.len(), 5);
    for pose in p {
        assert!(pose["ap_mm"].as_f64().unwrap() < 0.05, "{pose}");
    }
}
