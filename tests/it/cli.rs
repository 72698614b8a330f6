//! The binary as a user runs it: the main job, outputs, reproducibility and bad input.
//!
//! Over 600 lines: one test per user-visible behaviour of the main job; splitting by line count would scatter them.

use crate::common;

use common::*;
use std::path::PathBuf;

#[test]
fn main_job_runs_and_writes_outputs() {
    let d = tmpdir("main");
    let json = d.join("r.json");
    let o = run(&[
        "--points",
        "50",
        "--delta",
        "0.01",
        "--backend",
        "cpu",
        "--json",
        json.to_str().unwrap(),
        "--csv",
        d.join("csv").to_str().unwrap(),
        "--svg",
        d.join("svg").to_str().unwrap(),
        "--per-point",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("converged") && out.contains("M4 kurtosis"),
        "{out}"
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["schema_version"], 1);
    assert_eq!(v["result"]["method"], "amcs");
    assert!(v["result"]["converged"].as_bool().unwrap());
    assert_eq!(v["result"]["reliability"].as_array().unwrap().len(), 8);
    assert_eq!(
        v["result"]["per_point_reliability"]
            .as_array()
            .unwrap()
            .len(),
        50
    );
    assert_eq!(v["result"]["backend"]["backend"], "cpu");
    for f in [
        "cdf.csv",
        "pdf.csv",
        "reliability.csv",
        "trace.csv",
        "per_point.csv",
    ] {
        assert!(d.join("csv").join(f).is_file(), "{f}");
    }
    for f in ["pdf.svg", "reliability.svg", "convergence.svg"] {
        let s = std::fs::read_to_string(d.join("svg").join(f)).unwrap();
        assert!(
            s.starts_with("<?xml") && s.trim_end().ends_with("</svg>"),
            "{f}"
        );
    }
}

fn json_result(args: &[&str], file: &PathBuf) -> serde_json::Value {
    let mut a: Vec<&str> = args.to_vec();
    a.extend(["--quiet", "--json", file.to_str().unwrap()]);
    let o = run(&a);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(file).unwrap()).unwrap();
    let r = v["result"].as_object_mut().unwrap();
    r.remove("seconds");
    r.remove("backend");
    v["result"].clone()
}

#[test]
fn same_seed_same_report_any_thread_count() {
    let d = tmpdir("seed");
    let base = [
        "mcs",
        "--draws",
        "20000",
        "--points",
        "10",
        "--backend",
        "cpu",
        "--seed",
        "9",
    ];
    let a = json_result(
        &[&base[..], &["--threads", "1"]].concat(),
        &d.join("a.json"),
    );
    let b = json_result(
        &[&base[..], &["--threads", "2"]].concat(),
        &d.join("b.json"),
    );
    assert_eq!(a, b);
    let c = json_result(
        &[
            "mcs",
            "--draws",
            "20000",
            "--points",
            "10",
            "--backend",
            "cpu",
            "--seed",
            "10",
        ],
        &d.join("c.json"),
    );
    assert_ne!(a, c);
}

#[test]
fn model_preset_round_trips_through_a_file() {
    let d = tmpdir("model");
    let f = d.join("m.toml");
    let o = run(&["model", "--preset", "tx60", "--out", f.to_str().unwrap()]);
    assert!(o.status.success());
    let o = run(&[
        "mcs",
        "--draws",
        "2000",
        "--points",
        "5",
        "--backend",
        "cpu",
        "--model",
        f.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn points_and_fk_commands() {
    let d = tmpdir("pts");
    let f = d.join("p.csv");
    assert!(run(&["points", "7", "--out", f.to_str().unwrap()])
        .status
        .success());
    let text = std::fs::read_to_string(&f).unwrap();
    assert_eq!(text.lines().count(), 8);
    let o = run(&["fk", "--points-file", f.to_str().unwrap()]);
    assert!(o.status.success());
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.starts_with("q1,q2,q3,q4,q5,q6,x,y,z"));
    assert_eq!(out.lines().count(), 8);
    // A configuration outside the joint limits (the TX60's q3 stops at 142.5°) is refused as
    // every analysis refuses it, naming the row and the joint.
    std::fs::write(&f, "q1,q2,q3,q4,q5,q6\n0,0,90,0,0,0\n0,0,170,0,0,0\n").unwrap();
    let o = run(&["fk", "--points-file", f.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(
        e.contains("configuration 2") && e.contains("q3 = 170") && e.contains("limits"),
        "{e}"
    );
    assert!(o.stdout.is_empty());
}

/// A model without any spread (a preset from a published table, an import) says so in `mcs`,
/// `amcs` and `map`, in the text, the JSON and the HTML page, and in `compare`; a model with
/// spread does not.
#[test]
fn a_model_without_uncertainty_says_so_everywhere() {
    let d = tmpdir("zero-sigma");
    let said = "carries no uncertainty";
    for cmd in ["mcs", "amcs"] {
        let (json, html) = (
            arg(&d, &format!("{cmd}.json")),
            arg(&d, &format!("{cmd}-html")),
        );
        let mut args = vec![
            cmd,
            "--preset",
            "ur5e",
            "--points",
            "5",
            "--backend",
            "cpu",
            "--json",
            &json,
            "--html",
            &html,
        ];
        if cmd == "mcs" {
            args.extend(["--draws", "2000"]);
        }
        let o = run(&args);
        assert!(o.status.success(), "{cmd}: {}", stderr(&o));
        assert!(stdout(&o).contains(said), "{cmd}: {}", stdout(&o));
        assert!(
            std::fs::read_to_string(&json).unwrap().contains(said),
            "{cmd} json"
        );
        let page = std::fs::read_to_string(d.join(format!("{cmd}-html/index.html"))).unwrap();
        assert!(page.contains(said), "{cmd} html");
    }
    let (json, html) = (arg(&d, "map.json"), arg(&d, "map-html"));
    let o = run(&[
        "map",
        "--preset",
        "ur5e",
        "--plane",
        "xz",
        "--at",
        "0",
        "--cells",
        "3,3",
        "--backend",
        "cpu",
        "--json",
        &json,
        "--html",
        &html,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains(said), "{}", stdout(&o));
    assert!(std::fs::read_to_string(&json).unwrap().contains(said));
    assert!(std::fs::read_to_string(d.join("map-html/index.html"))
        .unwrap()
        .contains(said));
    // compare too, in its table and its Markdown.
    let md = arg(&d, "compare.md");
    let o = run(&[
        "compare",
        "--preset",
        "ur5e",
        "--points",
        "3",
        "--draws",
        "20000",
        "--backend",
        "cpu",
        "--markdown",
        &md,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains(said), "{}", stdout(&o));
    assert!(std::fs::read_to_string(&md).unwrap().contains(said));
    // The TX60 has σ: no such note.
    let o = run(&[
        "mcs",
        "--points",
        "5",
        "--draws",
        "2000",
        "--backend",
        "cpu",
    ]);
    assert!(
        o.status.success() && !stdout(&o).contains(said),
        "{}",
        stdout(&o)
    );
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn bad_settings_are_named() {
    fails_naming(&["--delta", "0", "--backend", "cpu"], "--delta");
    fails_naming(&["--delta", "-1", "--backend", "cpu"], "--delta");
    fails_naming(&["--coverage", "1.5", "--backend", "cpu"], "--coverage");
    fails_naming(&["--coverage", "0", "--backend", "cpu"], "--coverage");
    fails_naming(&["--batch", "1000", "--backend", "cpu"], "--batch");
    fails_naming(&["--points", "0", "--backend", "cpu"], "test points");
    fails_naming(
        &["--thresholds", "0.1,-2", "--backend", "cpu"],
        "--thresholds",
    );
    fails_naming(&["--max-draws", "15000", "--backend", "cpu"], "--max-draws");
    fails_naming(&["mcs", "--draws", "10", "--backend", "cpu"], "--draws");
    fails_naming(&["--box-center", "1,2", "--backend", "cpu"], "--box-center");
}

#[test]
fn bad_files_are_named_and_nothing_is_half_written() {
    let d = tmpdir("bad");
    let good = String::from_utf8(run(&["model"]).stdout).unwrap();
    let cases = [
        (
            good.replacen("d = 0.005056,", "d = -0.005056,", 1),
            "joint[1].sigma.d",
        ),
        (
            good.replacen("d = 0.005056,", "d = nan,", 1),
            "joint[1].sigma.d",
        ),
        (
            good.replacen(
                "sigma = { theta = 0.003216, d = 0.005056,",
                "sigma = { d = 0.005056,",
                1,
            ),
            "theta",
        ),
        (
            good.replacen("fixed = \"beta\"", "fixed = \"beta\"\ncolour = 3", 1),
            "colour",
        ),
    ];
    for (i, (text, what)) in cases.iter().enumerate() {
        assert_ne!(text, &good);
        let f = d.join(format!("m{i}.toml"));
        std::fs::write(&f, text).unwrap();
        let out = d.join(format!("out{i}.json"));
        fails_naming(
            &[
                "--model",
                f.to_str().unwrap(),
                "--json",
                out.to_str().unwrap(),
                "--backend",
                "cpu",
            ],
            what,
        );
        assert!(!out.exists(), "an output file was written after an error");
    }
    let csv = d.join("p.csv");
    std::fs::write(&csv, "q1,q2,q3,q4,q5,q6\n0,0,0,0,0,0\n0,0,x,0,0,0\n").unwrap();
    fails_naming(
        &["--points-file", csv.to_str().unwrap(), "--backend", "cpu"],
        "line 3",
    );
    std::fs::write(&csv, "q1,q2,q3,q4,q5,q6\n0,0,0,0,0,0\n0,170,0,0,0,0\n").unwrap();
    fails_naming(
        &["--points-file", csv.to_str().unwrap(), "--backend", "cpu"],
        "test point 2: q2",
    );
    std::fs::write(&csv, "q1,q2,q3,q4,q5\n0,0,0,0,0\n").unwrap();
    fails_naming(
        &["--points-file", csv.to_str().unwrap(), "--backend", "cpu"],
        "q6",
    );
    std::fs::write(&csv, "q1,q2,q3,q4,q5,q6\n").unwrap();
    fails_naming(
        &["--points-file", csv.to_str().unwrap(), "--backend", "cpu"],
        "no configurations",
    );
    // An output that is an input is refused, and the input survives.
    std::fs::write(&csv, "q1,q2,q3,q4,q5,q6\n0,0,0,0,0,0\n").unwrap();
    fails_naming(
        &[
            "--points-file",
            csv.to_str().unwrap(),
            "--json",
            csv.to_str().unwrap(),
            "--backend",
            "cpu",
        ],
        "also an input",
    );
    assert_eq!(
        std::fs::read_to_string(&csv).unwrap(),
        "q1,q2,q3,q4,q5,q6\n0,0,0,0,0,0\n"
    );
    fails_naming(
        &["--model", d.join("missing.toml").to_str().unwrap()],
        "missing.toml",
    );
}

#[test]
fn identify_then_analyse_then_validate() {
    use gpu_amcs::simulate::{
        measure_positions, perturbed_model, random_configurations, simulate_sweeps,
        write_measurements, write_sweeps, ParameterErrors, SweepPlan,
    };
    use rand::SeedableRng;
    let d = tmpdir("ident");
    let nominal = gpu_amcs::kinematics::tx60();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
    let truth = perturbed_model(
        &nominal,
        &ParameterErrors::default(),
        [30.0, -20.0, 80.0],
        &mut rng,
    );
    let sweeps = simulate_sweeps(&truth, &SweepPlan::default(), 0.0, 3, 5);
    let sweeps_csv = d.join("sweeps.csv");
    write_sweeps(&sweeps, std::fs::File::create(&sweeps_csv).unwrap()).unwrap();
    let model = d.join("model.toml");
    let o = run(&[
        "identify",
        sweeps_csv.to_str().unwrap(),
        "--out",
        model.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("3 runs"), "{out}");
    // The identified model is usable by the Monte Carlo commands.
    let o = run(&[
        "mcs",
        "--draws",
        "2000",
        "--points",
        "5",
        "--backend",
        "cpu",
        "--quiet",
        "--model",
        model.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    // Validation against noise-free measurements of the true robot: ~0 error, better than nominal.
    let q = random_configurations(&nominal.limits_deg, 20, &mut rng);
    let meas = measure_positions(&truth, &q, 0.0, &mut rng);
    let meas_csv = d.join("measured.csv");
    write_measurements(&meas, std::fs::File::create(&meas_csv).unwrap()).unwrap();
    let o = run(&[
        "validate",
        "--model",
        model.to_str().unwrap(),
        meas_csv.to_str().unwrap(),
        "--nominal",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    // The rows are the nominal model, the identified model and the improvement, each ending in
    // mean, RMS and maximum (mm, or % for the improvement).
    let identified_name = format!("{} (identified from", nominal.name);
    let row = |label: &str| -> [f64; 3] {
        let line = out
            .lines()
            .find(|l| {
                l.starts_with(label) && (label == identified_name || !l.contains("(identified"))
            })
            .unwrap_or_else(|| panic!("no row {label}: {out}"));
        let v: Vec<f64> = line
            .split_whitespace()
            .rev()
            .take(3)
            .map(|t| t.trim_end_matches('%').parse().unwrap())
            .collect();
        [v[2], v[1], v[0]]
    };
    let identified = row(&identified_name);
    let nominal_row = row(&nominal.name);
    let improvement = row("improvement");
    // Noise-free sweeps of the true robot identify it: what is left is rounding.
    assert!(identified[2] < 0.01, "{identified:?} mm: {out}");
    for k in 0..3 {
        assert!(
            identified[k] < 0.2 * nominal_row[k],
            "identified {identified:?} mm not well below nominal {nominal_row:?} mm: {out}"
        );
        let percent = 100.0 * (1.0 - identified[k] / nominal_row[k]);
        assert!(
            (improvement[k] - percent).abs() < 0.1,
            "improvement {improvement:?} % is not (1 − identified/nominal): {out}"
        );
    }
    // With --covariance the model file carries the runs' full covariance, and it samples.
    let model_cov = d.join("model_cov.toml");
    let o = run(&[
        "identify",
        sweeps_csv.to_str().unwrap(),
        "--covariance",
        "--out",
        model_cov.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(std::fs::read_to_string(&model_cov)
        .unwrap()
        .contains("[covariance]"));
    let o = run(&[
        "mcs",
        "--draws",
        "2000",
        "--points",
        "5",
        "--backend",
        "cpu",
        "--quiet",
        "--model",
        model_cov.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    // Writing the model over the sweeps is refused.
    fails_naming(
        &[
            "identify",
            sweeps_csv.to_str().unwrap(),
            "--out",
            sweeps_csv.to_str().unwrap(),
        ],
        "also an input",
    );
}

#[test]
fn draw_cap_ends_as_not_converged() {
    let d = tmpdir("cap");
    let f = d.join("r.json");
    let o = run(&[
        "--delta",
        "0.00001",
        "--max-draws",
        "30000",
        "--points",
        "5",
        "--backend",
        "cpu",
        "--json",
        f.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("NOT CONVERGED"));
    assert!(stderr(&o).contains("did not converge"));
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&f).unwrap()).unwrap();
    assert_eq!(v["result"]["converged"], false);
    assert_eq!(v["result"]["draws"], 30000);
}

#[test]
fn nominal_reference_adds_the_systematic_error() {
    // A model whose a2 is 0.5 mm longer than the preset's: measured from the preset (nominal),
    // every error grows by up to the systematic offset; from itself (calibrated) it does not.
    let d = tmpdir("nominal");
    let text =
        String::from_utf8(run(&["model"]).stdout)
            .unwrap()
            .replacen("a = 290.0", "a = 290.5", 1);
    let f = d.join("m.toml");
    std::fs::write(&f, text).unwrap();
    let mean = |reference: &str| -> f64 {
        let j = d.join(format!("{reference}.json"));
        let o = run(&[
            "mcs",
            "--draws",
            "5000",
            "--points",
            "10",
            "--backend",
            "cpu",
            "--quiet",
            "--model",
            f.to_str().unwrap(),
            "--reference",
            reference,
            "--json",
            j.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&j).unwrap()).unwrap();
        v["result"]["estimate"].as_f64().unwrap()
    };
    let (cal, nom) = (mean("calibrated"), mean("nominal"));
    assert!(
        cal < 0.2 && nom > cal + 0.2,
        "calibrated {cal}, nominal {nom}"
    );
}

/// A model with an uncertain tool point says so in the run's notes (JSON and text), with the
/// σ from the file; the same model without `tool_sigma` has no such note.
#[test]
fn an_uncertain_tool_point_is_named_in_the_report() {
    let dir = tmpdir("tool-note");
    let text = String::from_utf8(run(&["model", "--preset", "tx60"]).stdout).unwrap();
    let plain = dir.join("plain.toml");
    std::fs::write(&plain, &text).unwrap();
    let with_tool = dir.join("tool.toml");
    let tool_text = text.replacen(
        "tool = [0.0, 0.0, 0.0]",
        "tool = [0.0, 0.0, 0.0]\ntool_sigma = [0.004, 0.002, 0.006]",
        1,
    );
    assert_ne!(tool_text, text, "the preset's tool line moved");
    std::fs::write(&with_tool, tool_text).unwrap();
    let notes = |model: &PathBuf, name: &str| -> Vec<String> {
        let json = dir.join(name);
        let out = run(&[
            "mcs",
            "--model",
            model.to_str().unwrap(),
            "--draws",
            "2000",
            "--points",
            "5",
            "--backend",
            "cpu",
            "--json",
            json.to_str().unwrap(),
        ]);
        assert!(out.status.success(), "{}", stderr(&out));
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        let notes: Vec<String> = v["notes"]
            .as_array()
            .expect("notes array")
            .iter()
            .map(|n| n.as_str().unwrap().to_string())
            .collect();
        for n in &notes {
            assert!(stdout(&out).contains(n.as_str()), "text report lacks {n}");
        }
        notes
    };
    let tool = notes(&with_tool, "tool.json");
    assert!(
        tool.iter()
            .any(|n| n.contains("tool point uncertain: σ = (0.004, 0.002, 0.006) mm")),
        "{tool:?}"
    );
    let plain = notes(&plain, "plain.json");
    assert!(!plain.iter().any(|n| n.contains("tool point")), "{plain:?}");
}

/// Drops every `seconds` field (timing) from a JSON report, recursively.
fn without_timing(v: &mut serde_json::Value) {
    match v {
        serde_json::Value::Object(m) => {
            m.remove("seconds");
            m.values_mut().for_each(without_timing);
        }
        serde_json::Value::Array(a) => a.iter_mut().for_each(without_timing),
        _ => {}
    }
}

/// A robot description is a model wherever a model file is: `mcs --model robot.urdf` gives the
/// report of the model `import` writes from it, `identify --nominal robot.urdf` identifies on
/// it, and `study --preset ur5e` studies the UR5e (its own box, its own name).
#[test]
fn descriptions_and_presets_work_where_model_files_do() {
    let dir = tmpdir("descriptions");
    let p = |n: &str| dir.join(n).to_str().unwrap().to_string();
    let ok = |args: &[&str]| {
        let out = run(args);
        assert!(out.status.success(), "{args:?}: {}", stderr(&out));
        out
    };
    ok(&["model", "--preset", "ur5e"]);
    std::fs::write(p("ur5e.toml"), run(&["model", "--preset", "ur5e"]).stdout).unwrap();
    ok(&[
        "export",
        "--model",
        &p("ur5e.toml"),
        "--urdf",
        &p("ur5e.urdf"),
    ]);
    ok(&["import", &p("ur5e.urdf"), "--out", &p("imported.toml")]);
    let report = |model: &str, json: &str| {
        ok(&[
            "mcs",
            "--model",
            model,
            "--draws",
            "3000",
            "--points",
            "8",
            "--backend",
            "cpu",
            "--json",
            json,
        ]);
        let mut v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap();
        without_timing(&mut v);
        v
    };
    assert_eq!(
        report(&p("ur5e.urdf"), &p("from-urdf.json")),
        report(&p("imported.toml"), &p("from-toml.json"))
    );
    ok(&[
        "simulate",
        "--preset",
        "ur5e",
        "--runs",
        "2",
        "--out",
        &p("sweeps.csv"),
    ]);
    ok(&[
        "identify",
        &p("sweeps.csv"),
        "--nominal",
        &p("ur5e.urdf"),
        "--out",
        &p("id.toml"),
    ]);
    let id = std::fs::read_to_string(p("id.toml")).unwrap();
    assert!(id.contains("UR5e") || id.contains("ur5e"), "{id}");
    ok(&[
        "study",
        "--quick",
        "--preset",
        "ur5e",
        "--factors",
        "range",
        "--backend",
        "cpu",
        "-q",
        "--out",
        &p("study"),
    ]);
    let md = std::fs::read_to_string(dir.join("study/STUDY.md")).unwrap();
    assert!(md.contains("UR5e"), "{md}");
    // The UR5e's own box (from its reach), not the TX60's.
    assert!(md.contains("[1500.0, 2000.0, 1350.0] mm box"), "{md}");
}

/// `validate --iso9283`: 30 cycles at each of five poses, attained = command + a known offset per
/// pose + a circle of radius 0.015 mm: each pose's AP is its offset's length and RP is 0.015
/// (every cycle is 0.015 from the barycentre, S_l = 0); `--spec` adds the certificate, whose
/// probability at every pose is at least the all-poses one; a pose with one cycle is refused
/// naming it and its line.
#[test]
fn validate_iso9283_reports_ap_rp_and_the_certificate() {
    use gpu_amcs::kinematics::{position, tx60};
    let d = tmpdir("iso9283");
    let model = arg(&d, "m.toml");
    std::fs::write(&model, stdout(&run(&["model"]))).unwrap();
    let m = tx60();
    let poses = [
        [0.0, 0.0, 90.0, 0.0, 0.0, 0.0],
        [20.0, 10.0, 80.0, 10.0, 20.0, 0.0],
        [-20.0, 10.0, 80.0, -10.0, 20.0, 0.0],
        [20.0, -10.0, 100.0, 10.0, -20.0, 0.0],
        [-20.0, -10.0, 100.0, -10.0, -20.0, 0.0],
    ];
    let offsets = [
        [0.01, 0.0, 0.0],
        [0.0, 0.02, 0.0],
        [0.0, 0.0, -0.03],
        [0.03, 0.04, 0.0],
        [0.0, 0.0, 0.0],
    ];
    let mut csv = String::from("q1,q2,q3,q4,q5,q6,x,y,z\n");
    for i in 0..30 {
        let t = i as f64 * std::f64::consts::TAU / 30.0;
        for (q, o) in poses.iter().zip(&offsets) {
            let c = position(&m.params, &m.tool, &q.map(f64::to_radians));
            let p = [
                c[0] + o[0] + 0.015 * t.cos(),
                c[1] + o[1],
                c[2] + o[2] + 0.015 * t.sin(),
            ];
            let qs: Vec<String> = q.iter().map(|v| v.to_string()).collect();
            csv.push_str(&format!(
                "{},{:.9},{:.9},{:.9}\n",
                qs.join(","),
                p[0],
                p[1],
                p[2]
            ));
        }
    }
    let cycles = arg(&d, "cycles.csv");
    std::fs::write(&cycles, &csv).unwrap();
    let o = run(&[
        "validate",
        "--model",
        &model,
        &cycles,
        "--iso9283",
        "--spec",
        "0.05",
        "--draws",
        "20000",
        "--json",
        &arg(&d, "iso.json"),
        "--html",
        &arg(&d, "html"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    // The JSON and the HTML report hold the same figures.
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("iso.json")).unwrap()).unwrap();
    let jp = j["poses"].as_array().unwrap();
    assert_eq!(jp.len(), 5);
    for (p, o) in jp.iter().zip(&offsets) {
        let ap = (o[0] * o[0] + o[1] * o[1] + o[2] * o[2]).sqrt();
        assert!((p["ap_mm"].as_f64().unwrap() - ap).abs() < 1e-6, "{p}");
        assert!((p["rp_mm"].as_f64().unwrap() - 0.015).abs() < 1e-6, "{p}");
        for k in 0..3 {
            assert!(
                (p["ap_xyz_mm"][k].as_f64().unwrap() - o[k]).abs() < 1e-6,
                "{p}"
            );
        }
    }
    assert_eq!(j["certificate"]["per_pose"].as_array().unwrap().len(), 5);
    for f in [
        "index.html",
        "iso9283.json",
        "iso9283_poses.csv",
        "iso9283_certificate.csv",
        "iso9283_ap_rp.svg",
    ] {
        assert!(d.join("html").join(f).is_file(), "{f}");
    }
    let page = std::fs::read_to_string(d.join("html/index.html")).unwrap();
    assert!(
        page.contains("Certificate") && page.contains("P5"),
        "{page}"
    );
    let cert_csv = std::fs::read_to_string(d.join("html/iso9283_certificate.csv")).unwrap();
    assert_eq!(cert_csv.lines().count(), 7, "{cert_csv}");
    assert!(
        cert_csv.lines().last().unwrap().starts_with("all,0.05,"),
        "{cert_csv}"
    );
    let rows: Vec<Vec<f64>> = out
        .lines()
        .filter(|l| l.trim_start().starts_with('P') && l.split_whitespace().count() == 9)
        .map(|l| {
            l.split_whitespace()
                .skip(1)
                .map(|v| v.parse().unwrap())
                .collect()
        })
        .collect();
    assert_eq!(rows.len(), 5, "{out}");
    for (r, o) in rows.iter().zip(&offsets) {
        let ap = (o[0] * o[0] + o[1] * o[1] + o[2] * o[2]).sqrt();
        assert_eq!(r[0], 30.0);
        assert!((r[1] - ap).abs() < 1e-4, "AP {} vs {ap}: {out}", r[1]);
        assert!((r[7] - 0.015).abs() < 1e-4, "RP {}: {out}", r[7]);
    }
    let cert: Vec<f64> = out
        .lines()
        .skip_while(|l| !l.starts_with("certificate"))
        .skip(1)
        .map(|l| l.split_whitespace().nth(1).unwrap().parse().unwrap())
        .collect();
    assert_eq!(cert.len(), 6, "{out}");
    assert!(cert[..5].iter().all(|&p| p >= cert[5] && p <= 1.0), "{out}");
    // Report directories belong to --iso9283 only (validate writes --json, issue 34).
    let o = run(&[
        "validate",
        "--model",
        &model,
        &cycles,
        "--csv",
        &arg(&d, "v-csv"),
    ]);
    common::assert_fails_naming(&o, "--csv", "");
    assert!(!d.join("v-csv").exists());
    // One cycle at a sixth pose: refused, naming it.
    std::fs::write(&cycles, format!("{csv}1,2,3,4,5,6,0,0,0\n")).unwrap();
    let o = run(&["validate", "--model", &model, &cycles, "--iso9283"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("pose 6 (first at line 152) has 1 cycle"),
        "{}",
        stderr(&o)
    );
}

/// A box the user gives is in the world frame (the frame `fk` reports in), also for a robot
/// whose base transform turns its MDH chain upside down (the KR 6, base Rx(180°)): points in a
/// box in front of and above its shoulder are found, from the preset and from its model file,
/// and `fk` puts every one inside the box.
#[test]
fn box_of_a_base_turned_robot_is_in_the_world_frame() {
    let d = tmpdir("pts-kr6");
    let model = d.join("kr6.toml");
    let o = run(&["model", "--preset", "kr6r700sixx"]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    std::fs::write(&model, &o.stdout).unwrap();
    let m = gpu_amcs::presets::kr6r700sixx();
    for source in [
        ["--preset", "kr6r700sixx"],
        ["--model", model.to_str().unwrap()],
    ] {
        let f = d.join("p.csv");
        let mut args = vec![
            "points",
            "5",
            "--box-center",
            "400,0,600",
            "--box-size",
            "300,300,300",
            "--out",
            f.to_str().unwrap(),
        ];
        args.extend(source);
        let o = run(&args);
        assert!(o.status.success(), "{source:?}: {}", common::stderr(&o));
        let text = std::fs::read_to_string(&f).unwrap();
        assert_eq!(text.lines().count(), 6);
        let mut fk_args = vec!["fk", "--points-file", f.to_str().unwrap()];
        fk_args.extend(source);
        let o = run(&fk_args);
        assert!(o.status.success(), "{}", common::stderr(&o));
        let out = String::from_utf8_lossy(&o.stdout).into_owned();
        for line in out.lines().skip(1) {
            let v: Vec<f64> = line.split(',').map(|x| x.trim().parse().unwrap()).collect();
            let p = [v[6], v[7], v[8]];
            let c = [400.0, 0.0, 600.0];
            assert!((0..3).all(|k| (p[k] - c[k]).abs() <= 150.0), "{line}");
            let w = m.world_position(&std::array::from_fn::<_, 6, _>(|j| v[j].to_radians()));
            assert!((0..3).all(|k| (w[k] - p[k]).abs() < 1e-6), "{line}");
        }
    }
}

/// `--reference nominal` needs the same robot's design geometry: a model file of an imported
/// robot (no preset's name) is refused in one line naming `--nominal`; with `--nominal` it runs,
/// and a model file the preset printed (the KR 6) takes that preset.
#[test]
fn nominal_reference_of_an_imported_model_needs_its_nominal() {
    let d = tmpdir("nominal-import");
    let model = d.join("arm.toml");
    let o = run(&["model", "--preset", "ur5e"]);
    let text = String::from_utf8(o.stdout)
        .unwrap()
        .replace("Universal Robots UR5e", "my imported arm");
    assert!(text.contains("my imported arm"));
    std::fs::write(&model, text).unwrap();
    let m = model.to_str().unwrap();
    let base = [
        "mcs",
        "--draws",
        "2000",
        "--points",
        "3",
        "--backend",
        "cpu",
        "-q",
    ];
    let mut args = base.to_vec();
    args.extend(["--model", m, "--reference", "nominal"]);
    let o = run(&args);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(
        e.contains("'my imported arm'")
            && e.contains("has no nominal model")
            && e.contains("--nominal FILE")
            && e.trim().lines().count() == 1,
        "{e}"
    );
    let mut args = base.to_vec();
    args.extend(["--model", m, "--reference", "nominal", "--nominal", m]);
    let o = run(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let kr6 = d.join("kr6.toml");
    std::fs::write(&kr6, run(&["model", "--preset", "kr6r700sixx"]).stdout).unwrap();
    let mut args = base.to_vec();
    args.extend(["--model", kr6.to_str().unwrap(), "--reference", "nominal"]);
    let o = run(&args);
    assert!(o.status.success(), "{}", stderr(&o));
}
