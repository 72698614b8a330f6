//! Base reference reflectors (`mount` = `base`): measured at every pose, they follow a tracker
//! that drifts during the campaign; identify corrects the tool rows when the drift exceeds the
//! references' noise, and leaves data without drift exactly as measured. Checked against a
//! simulated robot with a known drift.

use crate::common::{run, run_ok, stderr, stdout, tmpdir};
use crate::multi_target::{configs, identify_to, truth, validate_json};
use gpu_amcs::kinematics::{Joints, RobotModel};
use nalgebra::{Rotation3, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::fmt::Write;

/// The tool reflector of [`truth`], mm.
const TOOL: [f64; 3] = [30.0, -20.0, 80.0];
const SIGMA: f64 = 0.01;
/// Reflectors on the base, in the robot's base frame, mm.
const REFERENCES: [[f64; 3]; 3] = [
    [350.0, 0.0, 20.0],
    [-175.0, 300.0, 20.0],
    [-175.0, -300.0, 20.0],
];

/// Pose rows (`mount`, `target`) at `qs`, each pose's tool and references seen through a
/// tracker that has drifted by `drift(share)` (share of the campaign done: a translation, mm,
/// and a turn about the tracker's z axis, rad); with `references` false, the tool rows alone.
fn rows(
    t: &RobotModel,
    qs: &[Joints],
    drift: impl Fn(f64) -> ([f64; 3], f64),
    references: bool,
    rng: &mut ChaCha8Rng,
) -> String {
    let b = t.base.unwrap().isometry();
    let mut s = String::from("q1,q2,q3,q4,q5,q6,x,y,z,target,mount\n");
    for (e, q) in qs.iter().enumerate() {
        let (shift, turn) = drift(e as f64 / (qs.len() - 1) as f64);
        let seen = |p: Vector3<f64>| {
            Rotation3::from_euler_angles(0.0, 0.0, turn) * p + Vector3::from(shift)
        };
        let noisy = |p: Vector3<f64>, rng: &mut ChaCha8Rng| {
            p.map(|v| v + SIGMA * gpu_amcs::sampling::standard_normal(rng))
        };
        let qs: Vec<String> = q.iter().map(|v| format!("{v:.9}")).collect();
        let tool = noisy(
            seen(Vector3::from(t.world_position(&q.map(f64::to_radians)))),
            rng,
        );
        let _ = writeln!(
            s,
            "{},{:.6},{:.6},{:.6},SMR,tool",
            qs.join(","),
            tool.x,
            tool.y,
            tool.z
        );
        if references {
            for (k, r) in REFERENCES.iter().enumerate() {
                let p = noisy(seen(b.transform_point(&(*r).into()).coords), rng);
                let _ = writeln!(
                    s,
                    "{},{:.6},{:.6},{:.6},B{},base",
                    qs.join(","),
                    p.x,
                    p.y,
                    p.z,
                    k + 1
                );
            }
        }
    }
    s
}

/// The tool's identified coordinates and σ from a JSON report.
fn tool(json: &std::path::Path) -> Vec<(f64, f64)> {
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap();
    ["tool_x", "tool_y", "tool_z"]
        .iter()
        .map(|n| {
            let p = r["identify"]["runs"][0]["chain"]["parameters"]
                .as_array()
                .unwrap()
                .iter()
                .find(|p| p["name"] == *n)
                .unwrap();
            (p["value"].as_f64().unwrap(), p["sigma"].as_f64().unwrap())
        })
        .collect()
}

/// A tracker drifting 0.3 mm and 40 µrad over 60 poses: without references the fit is biased
/// and its held-out error several times the noise; with them the drift is found, corrected, the
/// tool lies within 4σ of the truth and held-out poses are met within the noise.
#[test]
fn a_drifting_tracker_is_corrected_by_base_references() {
    let dir = tmpdir("base_references");
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let t = truth(&mut rng);
    let q = configs(&t, 60, &mut rng);
    let drift = |s: f64| ([0.2 * s, -0.15 * s, 0.12 * s], 4e-5 * s);
    let with = dir.join("with.csv");
    std::fs::write(&with, rows(&t, &q, drift, true, &mut rng)).unwrap();
    let without = dir.join("without.csv");
    std::fs::write(&without, rows(&t, &q, drift, false, &mut rng)).unwrap();
    let held = dir.join("held.csv");
    let hq = configs(&t, 30, &mut rng);
    std::fs::write(&held, rows(&t, &hq, |_| ([0.0; 3], 0.0), false, &mut rng)).unwrap();
    let mut rms = Vec::new();
    for (name, data) in [("with", &with), ("without", &without)] {
        let m = dir.join(format!("{name}.toml"));
        let j = dir.join(format!("{name}.json"));
        let o = run(&[
            "identify",
            data.to_str().unwrap(),
            "-o",
            m.to_str().unwrap(),
            "--json",
            j.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let text = stdout(&o) + &stderr(&o);
        if name == "with" {
            assert!(
                text.contains("base references (B1, B2, B3) at 60 poses"),
                "{text}"
            );
            assert!(
                text.contains(": corrected to the tracker frame of the first pose (rigid motion"),
                "{text}"
            );
            for ((v, s), want) in tool(&j).into_iter().zip(TOOL) {
                assert!((v - want).abs() < 4.0 * s, "tool {v} ± {s}, truth {want}");
            }
        }
        let vj = dir.join(format!("v_{name}.json"));
        run_ok(&[
            "validate",
            held.to_str().unwrap(),
            "--model",
            m.to_str().unwrap(),
            "--json",
            vj.to_str().unwrap(),
        ]);
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&vj).unwrap()).unwrap();
        rms.push(v["model"]["errors_mm"]["rms_mm"].as_f64().unwrap());
    }
    // 3-D noise of one reading √3·σ = 0.017 mm
    assert!(rms[0] < 0.025, "corrected held-out RMS {}", rms[0]);
    assert!(
        rms[1] > 2.0 * rms[0],
        "uncorrected {} vs corrected {}",
        rms[1],
        rms[0]
    );
}

/// References that hold still leave the data as measured: the same model as without them.
#[test]
fn still_references_change_nothing() {
    let dir = tmpdir("base_references_still");
    let mut rng = ChaCha8Rng::seed_from_u64(22);
    let t = truth(&mut rng);
    let q = configs(&t, 40, &mut rng);
    let text = rows(&t, &q, |_| ([0.0; 3], 0.0), true, &mut rng);
    let with = dir.join("with.csv");
    std::fs::write(&with, &text).unwrap();
    let tool_only: String = text
        .lines()
        .filter(|l| !l.ends_with(",base"))
        .map(|l| format!("{l}\n"))
        .collect();
    let without = dir.join("without.csv");
    std::fs::write(&without, tool_only).unwrap();
    let (a, b) = (dir.join("a.json"), dir.join("b.json"));
    let o = run(&[
        "identify",
        with.to_str().unwrap(),
        "--json",
        a.to_str().unwrap(),
    ]);
    assert!((stdout(&o) + &stderr(&o)).contains("within their noise: left as measured"));
    run_ok(&[
        "identify",
        without.to_str().unwrap(),
        "--json",
        b.to_str().unwrap(),
    ]);
    assert_eq!(tool(&a), tool(&b));
}

/// A pose without one of the references, or a mount that is neither tool nor base, is refused
/// naming the line.
#[test]
fn incomplete_references_are_refused() {
    let dir = tmpdir("base_references_bad");
    let mut rng = ChaCha8Rng::seed_from_u64(23);
    let t = truth(&mut rng);
    let q = configs(&t, 20, &mut rng);
    let text = rows(&t, &q, |_| ([0.0; 3], 0.0), true, &mut rng);
    let mut lines: Vec<&str> = text.lines().collect();
    lines.remove(7); // pose 2's B2 (line 8)
    let gap = dir.join("gap.csv");
    std::fs::write(&gap, lines.join("\n") + "\n").unwrap();
    let o = run(&["identify", gap.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(
        e.contains("line 6") && e.contains("base reference 'B2'"),
        "{e}"
    );
    let bad = dir.join("bad.csv");
    std::fs::write(&bad, text.replacen(",base\n", ",floor\n", 1)).unwrap();
    let o = run(&["identify", bad.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(e.contains("line 3") && e.contains("mount = 'floor'"), "{e}");
}

/// The model file records where its base references stood; measurements of a later session
/// from another tracker station (50 mm and 0.6° away) are registered to the model's frame by
/// the same references and validate within the noise; without their rows they would be 50 mm
/// off, and the model without a record leaves them out and says so.
#[test]
fn another_tracker_station_is_registered_by_the_references() {
    let dir = tmpdir("base_references_station");
    let mut rng = ChaCha8Rng::seed_from_u64(24);
    let t = truth(&mut rng);
    let q = configs(&t, 40, &mut rng);
    let data = dir.join("fit.csv");
    std::fs::write(&data, rows(&t, &q, |_| ([0.0; 3], 0.0), true, &mut rng)).unwrap();
    let model = dir.join("m.toml");
    identify_to(&data, &model);
    let text = std::fs::read_to_string(&model).unwrap();
    assert!(
        text.contains("reference_labels = [\"B1\", \"B2\", \"B3\"]"),
        "{text}"
    );
    let later = dir.join("later.csv");
    let hq = configs(&t, 20, &mut rng);
    let moved = rows(&t, &hq, |_| ([50.0, -20.0, 10.0], 0.01), true, &mut rng);
    std::fs::write(&later, &moved).unwrap();
    let vj = dir.join("v.json");
    let o = run(&[
        "validate",
        later.to_str().unwrap(),
        "--model",
        model.to_str().unwrap(),
        "--json",
        vj.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains(
            "registered to the model's frame by its base references (B1, B2, B3) at 20 poses"
        ),
        "{}",
        stdout(&o)
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&vj).unwrap()).unwrap();
    let rms = v["model"]["errors_mm"]["rms_mm"].as_f64().unwrap();
    // noise √3·0.01 = 0.017 mm, plus the references' own noise in the recorded home and in
    // this session's registration (σ/√5 over a 350 mm spread, ~1e-5 rad at a 1 m lever: about
    // 0.01 mm each)
    assert!(rms < 0.04, "registered RMS {rms}");
    // The same rows without the references: the other station's frame, tens of mm off.
    let tool_only: String = moved
        .lines()
        .filter(|l| !l.ends_with(",base"))
        .map(|l| format!("{l}\n"))
        .collect();
    let bare = dir.join("bare.csv");
    std::fs::write(&bare, tool_only).unwrap();
    let bj = dir.join("b.json");
    let b = validate_json(&bare, &model, &bj);
    assert!(b["model"]["errors_mm"]["rms_mm"].as_f64().unwrap() > 10.0);
    // A model identified without references cannot register them: left out, said so.
    let plain = dir.join("plain.csv");
    std::fs::write(&plain, rows(&t, &q, |_| ([0.0; 3], 0.0), false, &mut rng)).unwrap();
    let m2 = dir.join("m2.toml");
    identify_to(&plain, &m2);
    let o = run_ok(&[
        "validate",
        later.to_str().unwrap(),
        "--model",
        m2.to_str().unwrap(),
    ]);
    assert!(o.contains("60 base reference rows left out"), "{o}");
}
