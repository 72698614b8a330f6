//! Issue 35, item 2: inputs with another number of joints than the model. A nominal model for
//! `--reference nominal` and the cycles of `validate --iso9283` are refused in one line naming
//! the files (and the line) and both joint counts, exit 2, in either direction (more joints than
//! the model: a panic before; fewer: a nonsense answer).

use crate::common::{assert_fails_naming, run, stdout, tmpdir};
use std::path::{Path, PathBuf};

/// The model file of `preset` written into `dir`.
fn preset_file(dir: &Path, preset: &str, name: &str) -> PathBuf {
    let o = run(&["model", "--preset", preset]);
    assert!(o.status.success());
    let p = dir.join(name);
    std::fs::write(&p, stdout(&o)).unwrap();
    p
}

#[test]
fn a_nominal_model_with_another_joint_count_is_refused() {
    let dir = tmpdir("nominal-joints");
    let seven = preset_file(&dir, "iiwa14", "seven.toml");
    let six = preset_file(&dir, "ur5e", "six.toml");
    let (s7, s6) = (seven.to_str().unwrap(), six.to_str().unwrap());
    for (model, nominal, mj, nj) in [(s7, s6, 7, 6), (s6, s7, 6, 7)] {
        for cmd in [
            &["mcs", "--draws", "2000"][..],
            &["amcs"],
            &["compare"],
            &["sensitivity", "--draws", "64"],
            &["tail", "--threshold", "1"],
        ] {
            let mut args = cmd.to_vec();
            args.extend([
                "--model",
                model,
                "--reference",
                "nominal",
                "--nominal",
                nominal,
                "--points",
                "5",
                "--backend",
                "cpu",
                "-q",
            ]);
            let o = run(&args);
            let label = format!("{args:?}");
            assert_fails_naming(&o, "--nominal", &label);
            for want in [
                nominal.to_string(),
                model.to_string(),
                format!("{nj} joints"),
                format!("{mj}"),
            ] {
                assert_fails_naming(&o, &want, &label);
            }
        }
    }
    // The same robot as its own nominal model still runs.
    let o = run(&[
        "mcs",
        "--draws",
        "2000",
        "--model",
        s7,
        "--reference",
        "nominal",
        "--nominal",
        s7,
        "--points",
        "5",
        "--backend",
        "cpu",
        "-q",
    ]);
    assert!(o.status.success(), "{}", crate::common::stderr(&o));
}

/// Five cycles at one pose, `n` joint columns.
fn cycles(dir: &Path, n: usize) -> PathBuf {
    let q: Vec<String> = (1..=n).map(|k| format!("q{k}")).collect();
    let mut s = format!("{},x,y,z\n", q.join(","));
    for i in 0..5 {
        let angles: Vec<String> = (0..n).map(|k| format!("{}", 10 * k)).collect();
        s += &format!("{},400,100,30{i}\n", angles.join(","));
    }
    let p = dir.join(format!("cycles{n}.csv"));
    std::fs::write(&p, s).unwrap();
    p
}

#[test]
fn iso9283_cycles_with_another_joint_count_are_refused() {
    let dir = tmpdir("iso-joints");
    let seven = preset_file(&dir, "iiwa14", "seven.toml");
    let six = preset_file(&dir, "ur5e", "six.toml");
    for (model, data, mj, dj) in [
        (&seven, cycles(&dir, 6), 7, 6),
        (&six, cycles(&dir, 7), 6, 7),
    ] {
        let (m, d) = (model.to_str().unwrap(), data.to_str().unwrap());
        for extra in [&[][..], &["--spec", "1", "--draws", "2000"]] {
            let mut args = vec!["validate", "--model", m, d, "--iso9283"];
            args.extend(extra);
            let o = run(&args);
            let label = format!("{args:?}");
            for want in [
                d.to_string(),
                "line 2".to_string(),
                format!("{dj} joint angles"),
                format!("{mj} joints"),
            ] {
                assert_fails_naming(&o, &want, &label);
            }
        }
    }
    // Matching columns still give the figures.
    let o = run(&[
        "validate",
        "--model",
        six.to_str().unwrap(),
        cycles(&dir, 6).to_str().unwrap(),
        "--iso9283",
    ]);
    assert!(o.status.success(), "{}", crate::common::stderr(&o));
}

/// A nominal model of another robot with as many joints (a TX60 for a UR5e) ran and printed a
/// w of 1126 mm, exit 0, where `validate` refused the same pair: now refused by every analysis
/// with a nominal reference, naming `--nominal`; an identified model against its own nominal
/// (flanges millimetres apart) still runs.
#[test]
fn a_nominal_model_of_another_robot_is_refused() {
    let dir = tmpdir("nominal-other-robot");
    let ur5e = preset_file(&dir, "ur5e", "ur5e.toml");
    let tx60 = preset_file(&dir, "tx60", "tx60.toml");
    let (u, t) = (ur5e.to_str().unwrap(), tx60.to_str().unwrap());
    for cmd in [
        &["mcs", "--draws", "2000"][..],
        &["amcs"],
        &["compare"],
        &["sensitivity", "--draws", "64"],
        &["tail", "--threshold", "1"],
    ] {
        let mut args = cmd.to_vec();
        args.extend([
            "--model",
            u,
            "--reference",
            "nominal",
            "--nominal",
            t,
            "--points",
            "5",
            "--backend",
            "cpu",
            "-q",
        ]);
        let o = run(&args);
        let label = format!("{args:?}");
        assert_fails_naming(&o, "--nominal", &label);
        assert_fails_naming(&o, "another robot", &label);
    }
    let identified = dir.join("identified.toml");
    let data = dir.join("poses.csv");
    for args in [
        &[
            "simulate",
            "--poses",
            "60",
            "--seed",
            "2",
            "-o",
            data.to_str().unwrap(),
        ][..],
        &[
            "identify",
            data.to_str().unwrap(),
            "-q",
            "-o",
            identified.to_str().unwrap(),
        ],
    ] {
        let o = run(args);
        assert!(o.status.success(), "{}", crate::common::stderr(&o));
    }
    let o = run(&[
        "mcs",
        "--draws",
        "2000",
        "--model",
        identified.to_str().unwrap(),
        "--reference",
        "nominal",
        "--nominal",
        t,
        "--points",
        "5",
        "--backend",
        "cpu",
        "-q",
    ]);
    assert!(o.status.success(), "{}", crate::common::stderr(&o));
}
