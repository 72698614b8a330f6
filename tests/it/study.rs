//! The calibration simulator, the calibrate command and the factor study as a user runs them
//! (issue 5), plus the check that the baked TX60 σ is what the simulator produces.

use crate::common;
use gpu_amcs::kinematics::{tx60, Layout, ParamKind, RobotModel, Uncertainty};
use gpu_amcs::simulate::{calibrate, Experiment, Factors};

use common::*;

/// The six-joint TX60's parameter count (30) and uncertain inputs (33).
const N_PARAMS: usize = Layout::SIX.n_params();
const N_UNCERTAIN: usize = 33;

/// Well-formed SVG with at least one curve.
fn check_xml(text: &str, name: &str) {
    check_svg(text, name);
    assert!(text.contains("<polyline"), "{name}: no curve");
}

/// Column `col` of the CSV rows whose first cells are `factor` and whose points (col 2) or
/// method (col 2) cell is `key`, in file order.
fn column(csv: &str, factor: &str, key: &str, col: usize) -> Vec<f64> {
    csv.lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|c| c[0] == factor && c[2] == key)
        .map(|c| c[col].parse().unwrap())
        .collect()
}

#[test]
fn quick_study_writes_tables_figures_and_shows_the_directions() {
    let d = tmpdir("quick");
    let out = d.join("study");
    let o = run(&[
        "study",
        "--quick",
        "--backend",
        "cpu",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in [
        "STUDY.md",
        "table1.md",
        "table1.csv",
        "table2.md",
        "table2.csv",
        "correlation.md",
        "correlation.csv",
        "accuracy.csv",
        "study.json",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let mut svgs = 0;
    for e in std::fs::read_dir(&out).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "svg") {
            check_xml(
                &std::fs::read_to_string(&p).unwrap(),
                &p.display().to_string(),
            );
            svgs += 1;
        }
    }
    assert_eq!(
        svgs,
        5 * 4,
        "fig4 + fig5 + two convergence plots per factor"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("study.json")).unwrap()).unwrap();
    assert_eq!(json["levels"].as_array().unwrap().len(), 11);
    // Directions that must emerge from the simulation: R_c(0.1 mm) at 50 points rises with the
    // joint range and falls with the speed; M1 (MCS) falls with the range.
    let t1 = std::fs::read_to_string(out.join("table1.csv")).unwrap();
    let range = column(&t1, "range", "50", 3);
    assert!(
        range.windows(2).all(|w| w[1] >= w[0]) && range[2] > range[0],
        "{range:?}"
    );
    let speed = column(&t1, "speed", "50", 3);
    assert!(speed[1] < speed[0], "{speed:?}");
    let t2 = std::fs::read_to_string(out.join("table2.csv")).unwrap();
    let m1 = column(&t2, "range", "MCS", 3);
    assert!(m1.windows(2).all(|w| w[1] < w[0]), "{m1:?}");
    let md = std::fs::read_to_string(out.join("STUDY.md")).unwrap();
    assert!(md.contains("Correlated parameters") && md.contains("22.9 %"));
    check_ranking(&json, &md);
    assert!(out.join("ranking.md").is_file() && out.join("ranking.csv").is_file());
}

/// The ranking section recomputed from the study's own JSON: the parameters come by decreasing
/// total index; each level's σ ratios are that level's σ over the baseline level's (the level
/// whose factors are the baseline's); `r` is the total-index-weighted mean of the squared
/// ratios; the recommended factor has the smallest best `r`, below 1, and STUDY.md names it.
fn check_ranking(json: &serde_json::Value, md: &str) {
    let r = &json["ranking"];
    let params = r["parameters"].as_array().unwrap();
    assert!(params.len() >= 3, "{params:?}");
    let totals: Vec<f64> = params
        .iter()
        .map(|p| p["total"].as_f64().unwrap())
        .collect();
    assert!(totals.windows(2).all(|w| w[0] >= w[1]), "{totals:?}");
    let top: Vec<&str> = r["top"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| n.as_str().unwrap())
        .collect();
    assert_eq!(top.len(), 3);
    let index = |name: &str| {
        (0..N_PARAMS)
            .find(|&i| format!("{}{}", ParamKind::ALL[i % 5].name(), i / 5 + 1) == name)
            .unwrap_or_else(|| panic!("{name}"))
    };
    let levels = json["levels"].as_array().unwrap();
    let baseline = &json["settings"]["baseline"];
    let base = levels
        .iter()
        .find(|l| &l["factors"] == baseline)
        .expect("a baseline level");
    let sigma = |l: &serde_json::Value, i: usize| l["sigma"][i].as_f64().unwrap();
    let weight: Vec<f64> = top
        .iter()
        .map(|n| {
            params.iter().find(|p| p["name"] == *n).unwrap()["total"]
                .as_f64()
                .unwrap()
                .max(0.0)
        })
        .collect();
    let mut best: Option<(f64, String)> = None;
    for f in r["factors"].as_array().unwrap() {
        let name = f["factor"].as_str().unwrap();
        let mine: Vec<&serde_json::Value> = levels.iter().filter(|l| l["factor"] == name).collect();
        let effects = f["levels"].as_array().unwrap();
        assert_eq!(effects.len(), mine.len());
        for (e, l) in effects.iter().zip(&mine) {
            let mut num = 0.0;
            for (k, n) in top.iter().enumerate() {
                let i = index(n);
                let q = sigma(l, i) / sigma(base, i);
                // Same arithmetic on the same f64 values: equal to rounding.
                assert!((e["sigma_ratios"][k].as_f64().unwrap() - q).abs() < 1e-12);
                num += weight[k] * q * q;
            }
            let rr = num / weight.iter().sum::<f64>();
            assert!((e["variance_ratio"].as_f64().unwrap() - rr).abs() < 1e-12);
            if best.as_ref().is_none_or(|b| rr < b.0) {
                best = Some((rr, name.to_string()));
            }
        }
    }
    let (r_best, f_best) = best.unwrap();
    assert!(
        r_best < 1.0,
        "no factor reduces the top parameters: {r_best}"
    );
    assert_eq!(r["recommended"].as_str().unwrap(), f_best);
    assert!(
        md.contains(&format!("The {f_best} factor reduces them most")),
        "{md}"
    );
}

#[test]
fn bad_settings_are_one_line_errors_naming_the_flag() {
    for cmd in ["simulate", "calibrate", "study"] {
        let extra: &[&str] = if cmd == "study" { &["--quick"] } else { &[] };
        let with = |a: &[&'static str]| -> Vec<&'static str> { [&[cmd][..], extra, a].concat() };
        if cmd != "study" {
            fails_naming(&with(&["--range", "0"]), "--range");
            fails_naming(&with(&["--step", "0"]), "--step");
            fails_naming(&with(&["--speed", "-10"]), "--speed");
        }
        fails_naming(&with(&["--runs", "1"]), "--runs");
    }
    fails_naming(&["study", "--factors", "colour"], "--factors");
    fails_naming(&["calibrate", "--range", "150"], "--range");
}

#[test]
fn simulated_sweeps_identify_and_calibrate_writes_a_covariance_model() {
    let d = tmpdir("sim");
    let sweeps = d.join("sweeps.csv");
    let o = run(&[
        "simulate",
        "--runs",
        "3",
        "--step",
        "5",
        "--out",
        sweeps.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let data = gpu_amcs::identify::read_sweeps(&sweeps).unwrap();
    assert_eq!(data.runs.len(), 3);
    let model = d.join("id.toml");
    let o = run(&[
        "identify",
        sweeps.to_str().unwrap(),
        "--out",
        model.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    let cal = d.join("cal.toml");
    let o = run(&[
        "calibrate",
        "--runs",
        "4",
        "--step",
        "5",
        "--out",
        cal.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("improvement"), "{out}");
    let m = RobotModel::from_file(&cal).unwrap();
    let Uncertainty::Covariance(c) = &m.uncertainty else {
        panic!("no covariance")
    };
    // The tracker target varies between the runs: 33 rows, the parameters then the tool.
    let n = N_UNCERTAIN;
    assert_eq!(c.dim(), n);
    assert_eq!(c.space().block_names(), ["joints", "tool"]);
    assert!(m.tool_uncertain(), "the tool's run-to-run σ is estimated");
    // the written model is usable by the main job
    let o = run(&[
        "--model",
        cal.to_str().unwrap(),
        "--points",
        "5",
        "--backend",
        "cpu",
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// The baked default σ of the TX60 preset is the simulator's baseline calibration
/// (robot seed 2025, calibration seed 1, `Factors::default()`); see `kinematics::tx60`.
#[test]
fn baked_tx60_sigma_matches_the_simulator() {
    let c = calibrate(&Experiment::tx60(2025), &Factors::default(), 1).unwrap();
    let sim = c.independent.param_sigmas();
    let baked = tx60().param_sigmas();
    for i in 0..N_PARAMS {
        let unit = ParamKind::ALL[i % 5].to_internal();
        let (s, b) = (sim[i] / unit, baked[i] / unit);
        assert!(
            (s - b).abs() <= 1e-3 * b.abs().max(1e-12) || (s == 0.0 && b == 0.0),
            "parameter {i}: simulator {s:.4e}, preset {b:.4e}"
        );
    }
}
