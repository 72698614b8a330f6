//! Seven-axis arms as seven-joint models, the redundant joint free: the KUKA LBR iiwa 14 R820
//! and the Franka Emika Panda from their published DH tables, proved against seven-joint
//! forward kinematics written out in the tests (no crate code), round-tripped through the URDF
//! export, and run through every analysis of the command line: simulated calibration
//! (`calibrate`: sweeps and identification), `mcs`, `amcs`, `sensitivity`, `tail`, `map`,
//! `plan`, `simulate` + `identify` from sweeps and from poses in a tracker frame, and `fk`.

use super::held::{dh_modified7, iiwa_csv, panda_toml, IIWA, PANDA};
use super::{dh_standard, dist, import, max_dev, urdf_round_trip, write};
use crate::common::{run, stderr, stdout, tmpdir};
use gpu_amcs::kinematics::{param_index, ParamKind, RobotModel};

#[test]
fn lbr_iiwa_imports_as_a_seven_joint_model() {
    let dir = tmpdir("iiwa7");
    let imp = import(&write(&dir, "iiwa14.csv", &iiwa_csv())).unwrap();
    let m = &imp.model;
    assert_eq!(m.joints(), 7);
    assert_eq!(m.robot_inputs().len(), 38);
    assert!(imp.max_deviation_mm < 1e-9, "{}", imp.max_deviation_mm);
    let dev = max_dev(m, |q| dh_standard(&IIWA, q));
    assert!(dev < 1e-9, "{dev}");
    // Upright at q = 0: 360 + 420 + 400 + 126 mm straight up.
    let p = m.world_position(&m.joints_at(0.0));
    assert!(dist(p, [0.0, 0.0, 1306.0]) < 1e-9, "{p:?}");
    let limits: Vec<f64> = m.limits_deg.iter().map(|l| l.1).collect();
    assert_eq!(limits, [170.0, 120.0, 170.0, 120.0, 170.0, 120.0, 175.0]);
    let back = urdf_round_trip(&dir, m);
    assert!(back < 1e-9, "{back}");
    // The model file holds seven [[joint]] tables and reads back to the same model.
    let again = RobotModel::from_toml(&imp.to_toml(), "iiwa.toml").unwrap();
    assert_eq!(again.joints(), 7);
    let dev_file = max_dev(&again, |q| dh_standard(&IIWA, q));
    assert!(dev_file < 1e-9, "{dev_file}");
    eprintln!(
        "iiwa 14, seven joints: proof {:.2e} mm, DH FK {dev:.2e} mm, URDF round trip {back:.2e} mm",
        imp.max_deviation_mm
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn panda_imports_as_a_seven_joint_model() {
    let dir = tmpdir("panda7");
    let imp = import(&write(&dir, "panda.toml", &panda_toml())).unwrap();
    let m = &imp.model;
    assert_eq!(m.joints(), 7);
    assert!(imp.max_deviation_mm < 1e-9, "{}", imp.max_deviation_mm);
    let dev = max_dev(m, |q| dh_modified7(&PANDA, q, [0.0, 0.0, 107.0]));
    assert!(dev < 1e-9, "{dev}");
    // Joint 4's limits exclude 0: at q4 = −90° (the others 0) the flange is at
    // x = 82.5 + 384 + 107 − ... written out: the chain folds at the elbow.
    let mut q = m.joints_at(0.0);
    q[3] = -90f64.to_radians();
    let want = dh_modified7(&PANDA, &q, [0.0, 0.0, 107.0]);
    assert!(dist(m.world_position(&q), want) < 1e-9);
    let back = urdf_round_trip(&dir, m);
    assert!(back < 1e-9, "{back}");
    eprintln!(
        "Panda, seven joints: proof {:.2e} mm, DH FK {dev:.2e} mm, URDF round trip {back:.2e} mm",
        imp.max_deviation_mm
    );
    let _ = std::fs::remove_dir_all(&dir);
}

fn ok(args: &[&str]) -> String {
    let r = run(args);
    assert!(r.status.success(), "{args:?}: {}", stderr(&r));
    stdout(&r)
}

fn json(path: &std::path::Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// The imported iiwa, calibrated by simulation (seven sweeps per run, three runs), runs every
/// analysis; each result is checked for what it must say about a seven-joint arm.
#[test]
fn a_seven_joint_model_runs_every_analysis() {
    let dir = tmpdir("iiwa7-cli");
    let s = |p: &std::path::Path| p.to_str().unwrap().to_string();
    let csv = write(&dir, "iiwa14.csv", &iiwa_csv());
    let nominal = dir.join("iiwa.toml");
    ok(&["import", &s(&csv), "-o", &s(&nominal)]);
    let cal = dir.join("cal.toml");
    let out = ok(&[
        "calibrate",
        "--model",
        &s(&nominal),
        "--runs",
        "3",
        "-o",
        &s(&cal),
    ]);
    assert!(out.contains("J7:"), "{out}");
    let model = RobotModel::from_file(&cal).unwrap();
    assert_eq!(model.joints(), 7);
    // The calibration gives every joint but the last (kept nominal, the target absorbs it) a
    // spread.
    let sig = model.param_sigmas();
    for j in 0..6 {
        assert!(sig[param_index(j, ParamKind::A)] > 0.0, "a{}", j + 1);
    }
    let c = s(&cal);

    // Test points: seven columns.
    let pts = dir.join("pts.csv");
    let text = ok(&["points", "20", "--model", &c]);
    assert!(text.starts_with("q1,q2,q3,q4,q5,q6,q7\n"), "{text}");
    std::fs::write(&pts, &text).unwrap();
    let p = s(&pts);
    let fk = ok(&["fk", "--model", &c, "--points-file", &p]);
    assert!(fk.starts_with("q1,q2,q3,q4,q5,q6,q7,x,y,z\n"), "{fk}");
    assert_eq!(fk.lines().count(), 21);

    // mcs and amcs: positive errors that grow with the spread.
    let mj = dir.join("mcs.json");
    ok(&[
        "mcs",
        "--model",
        &c,
        "--points-file",
        &p,
        "--draws",
        "20000",
        "--backend",
        "cpu",
        "--json",
        &s(&mj),
    ]);
    let v = json(&mj);
    assert_eq!(v["result"]["draws"], 20000);
    let mean = v["result"]["estimate"].as_f64().unwrap();
    assert!(mean > 0.0 && mean < 1.0, "{mean}");
    let aj = dir.join("amcs.json");
    ok(&[
        "amcs",
        "--model",
        &c,
        "--points-file",
        &p,
        "--delta",
        "0.01",
        "--backend",
        "cpu",
        "--json",
        &s(&aj),
    ]);
    let v = json(&aj);
    assert_eq!(v["result"]["converged"], true);
    let amcs_mean = v["result"]["estimate"].as_f64().unwrap();
    // Both estimate the same mean: within a few of MCS's standard errors (σ_w/√20000 ≈ 2e-4·σ).
    let sd = json(&mj)["result"]["std_uncertainty"].as_f64().unwrap();
    assert!(
        (amcs_mean - mean).abs() < 0.05 * sd + 0.01,
        "{amcs_mean} vs {mean}"
    );

    // Sensitivity names the seventh joint's inputs; tail gives a probability.
    let sj = dir.join("sens.json");
    ok(&[
        "sensitivity",
        "--model",
        &c,
        "--points",
        "5",
        "--draws",
        "1024",
        "--backend",
        "cpu",
        "--json",
        &s(&sj),
    ]);
    let st = json(&sj).to_string();
    assert!(st.contains("theta6") && !st.contains("theta8"), "{st}");
    let tj = dir.join("tail.json");
    ok(&[
        "tail",
        "--model",
        &c,
        "--points",
        "5",
        "--threshold",
        "0.05",
        "--backend",
        "cpu",
        "--json",
        &s(&tj),
    ]);
    let pf = json(&tj)["tail"]["estimates"][0]["p_f"].as_f64().unwrap();
    assert!(pf > 0.0 && pf < 1.0, "{pf}");

    // The map: inverse kinematics of a redundant arm reaches cells, each solution within the
    // limits and on its cell.
    let mapj = dir.join("map.json");
    let out = ok(&[
        "map",
        "--model",
        &c,
        "--plane",
        "xz",
        "--at",
        "0",
        "--cells",
        "8,8",
        "--free-orientation",
        "--draws",
        "2000",
        "--backend",
        "cpu",
        "--json",
        &s(&mapj),
    ]);
    let reached: usize = out
        .lines()
        .find(|l| l.starts_with("reached"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|n| n.parse().ok())
        .unwrap_or(0);
    assert!(reached >= 10, "{out}");

    // Plan: 20 poses of seven angles.
    let design = dir.join("design.csv");
    ok(&[
        "plan",
        "--model",
        &c,
        "--points",
        "10",
        "--poses",
        "20",
        "--target",
        "30,-20,80",
        "--candidates",
        "300",
        "--draws",
        "1000",
        "--backend",
        "cpu",
        "-o",
        &s(&design),
    ]);
    let d = std::fs::read_to_string(&design).unwrap();
    assert!(d.starts_with("q1,q2,q3,q4,q5,q6,q7"), "{d}");
    assert_eq!(d.lines().count(), 21);

    // Identification from simulated data of a known truth: sweeps, and poses in a tracker frame.
    let truth = dir.join("truth.toml");
    let sweeps = dir.join("sweeps.csv");
    let r = run(&[
        "simulate",
        "--model",
        &s(&nominal),
        "--seed",
        "5",
        "--runs",
        "2",
        "-o",
        &s(&sweeps),
        "--truth-out",
        &s(&truth),
    ]);
    assert!(r.status.success(), "simulate: {}", stderr(&r));
    // One sweep per joint: seven, not the six of a six-axis arm.
    assert!(stderr(&r).contains("2 runs × 7 sweeps ("), "{}", stderr(&r));
    let truth_model = RobotModel::from_file(&truth).unwrap();
    assert_eq!(truth_model.joints(), 7);
    let idm = dir.join("id.toml");
    ok(&[
        "identify",
        &s(&sweeps),
        "--nominal",
        &s(&nominal),
        "-o",
        &s(&idm),
    ]);
    let id = RobotModel::from_file(&idm).unwrap();
    assert_eq!(id.joints(), 7);
    let worst = max_dev(&id, |q| truth_model.world_position(q));
    assert!(
        worst < 0.5,
        "identified from sweeps: {worst} mm from the truth"
    );
    let poses = dir.join("poses.csv");
    ok(&[
        "simulate",
        "--model",
        &s(&nominal),
        "--seed",
        "6",
        "--poses",
        "60",
        "--placement",
        "random",
        "--target",
        "30,-20,80",
        "-o",
        &s(&poses),
        "--truth-out",
        &s(&truth),
    ]);
    let truth_model = RobotModel::from_file(&truth).unwrap();
    let idp = dir.join("idp.toml");
    ok(&[
        "identify",
        &s(&poses),
        "--nominal",
        &s(&nominal),
        "-o",
        &s(&idp),
    ]);
    let id = RobotModel::from_file(&idp).unwrap();
    assert_eq!(id.joints(), 7);
    let worst = max_dev(&id, |q| truth_model.world_position(q));
    assert!(
        worst < 0.5,
        "identified from poses: {worst} mm from the truth"
    );
    eprintln!(
        "iiwa 14 identified from poses in a tracker frame: within {worst:.4} mm of the truth"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
