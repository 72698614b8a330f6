//! `calibrate` and `study` with robots that carry joint compliance and gear harmonics (issue 33,
//! "beyond geometry"): each run identified with the geometry alone and with joint errors, the
//! accuracy of both at test poses of the true robot, and the mean model carrying what the report
//! says it carries.

use crate::common::{run_ok, tmpdir};
use gpu_amcs::identify::JointErrorFit;
use gpu_amcs::points::WorkspaceBox;
use gpu_amcs::progress::ProgressHook;
use gpu_amcs::simulate::{
    accuracy_full, calibrate_full, Experiment, Factors, FullAccuracy, FullCalibration,
    NonGeometricSizes, RunData,
};

/// Two runs of 150 random poses of the TX60 of `robot_seed` with joint errors of `size`,
/// identified with `mode` beside the geometry alone, and their accuracy at 50 test poses.
fn calibrated(robot_seed: u64, size: f64, mode: JointErrorFit) -> (FullCalibration, FullAccuracy) {
    calibrated_from(robot_seed, size, mode, RunData::Poses(150))
}

/// [`calibrated`] from `data`.
fn calibrated_from(
    robot_seed: u64,
    size: f64,
    mode: JointErrorFit,
    data: RunData,
) -> (FullCalibration, FullAccuracy) {
    let mut exp = Experiment::tx60(robot_seed);
    let sizes = NonGeometricSizes {
        compliance: size,
        harmonics: size,
        payload_kg: 0.0,
        backlash: 0.0,
    };
    exp.set_nongeometric(&sizes, robot_seed).unwrap();
    let f = Factors {
        runs: 2,
        ..Factors::default()
    };
    let cal = calibrate_full(&exp, &f, 1, data, mode, &ProgressHook::none()).unwrap();
    let acc = accuracy_full(&exp, &cal, 50, &WorkspaceBox::default(), 7).unwrap();
    (cal, acc)
}

/// The result in the simulator: on TX60s with compliance and harmonics of size 1, a
/// geometric calibration from two runs of 150 random poses leaves a mean error at the test poses
/// 2.6–4.6× the geometric robot's (`calibrate --poses 150 --runs 2`, robot seeds 1–4: 0.059–0.104
/// against 0.0224 mm; here, at 50 other test poses, robots 1 and 4: 0.114 and 0.108 against
/// 0.019 mm); the full model (auto: kept in every run) comes down to the geometric robot's
/// figure (0.0226 and 0.0192 mm), 0.17–0.38 of the geometric calibration's. The bounds (≥ 2× and
/// ≤ 0.5×) leave that spread a margin. On the geometric robot the joint errors forced in
/// (`keep`) are no worse than the geometry alone within noise (+1 %; bound 5 %), and auto does
/// not keep them.
#[test]
fn full_model_removes_what_the_geometric_calibration_leaves() {
    let (plain, plain_acc) = calibrated(3, 0.0, JointErrorFit::Keep);
    assert!(plain.carries_joint_errors);
    let floor = plain_acc.mean.geometric.mean_mm;
    eprintln!(
        "geometric robot: geometric {floor:.4}, full (keep) {:.4} mm",
        plain_acc.mean.full.mean_mm
    );
    assert!(
        plain_acc.mean.full.mean_mm <= 1.05 * floor,
        "geometric robot: full {} against geometric {floor}",
        plain_acc.mean.full.mean_mm
    );
    let (auto, auto_acc) = calibrated(3, 0.0, JointErrorFit::Auto);
    assert!(!auto.carries_joint_errors && auto.kept_by_mode() == 0);
    assert_eq!(auto_acc.mean.full, auto_acc.mean.geometric);
    for seed in [1, 4] {
        let (cal, acc) = calibrated(seed, 1.0, JointErrorFit::Auto);
        let (g, full) = (acc.mean.geometric.mean_mm, acc.mean.full.mean_mm);
        eprintln!(
            "robot {seed}: before {:.4}, geometric {g:.4}, full {full:.4} mm (geometric robot {floor:.4})",
            acc.nominal.mean_mm
        );
        assert!(cal.carries_joint_errors && cal.kept_by_mode() == 2);
        assert!(
            g >= 2.0 * floor,
            "robot {seed}: geometric {g} against {floor}"
        );
        assert!(
            full <= 0.5 * g,
            "robot {seed}: full {full} against geometric {g}"
        );
        // The mean models are what was evaluated: the full one carries the joint errors, the
        // geometric one none; every run's own full model carries them too.
        assert!(cal.full.independent.joint_errors.is_some());
        assert!(cal.full.correlated.joint_errors.is_some());
        assert!(cal.geometric.independent.joint_errors.is_none());
        assert!(cal.runs.iter().all(|r| r.full.joint_errors.is_some()));
        for r in &acc.runs {
            assert!(r.full.mean_mm <= 0.5 * r.geometric.mean_mm, "{r:?}");
        }
    }
}

/// No report says "kept" for what the evaluated model lacks (before, several runs' mean model
/// held the geometry alone whatever the runs kept): the text says the mean model carries the
/// joint errors exactly when the model file has them, and a check-only mode leaves them out of
/// both. A geometric robot without the flag takes the paper's geometric calibration (no check,
/// no table of the full model).
#[test]
fn calibrate_says_what_its_mean_model_carries() {
    let d = tmpdir("calibrate-beyond");
    let m = d.join("m.toml").display().to_string();
    let base = [
        "calibrate",
        "--runs",
        "2",
        "--poses",
        "120",
        "--compliance",
        "1",
        "--harmonics",
        "1",
        "--accuracy-points",
        "20",
        "-o",
        &m,
    ];
    let text = run_ok(&base);
    assert!(text.contains("Beyond geometry (auto"), "{text}");
    assert!(text.contains("kept in 2 of the 2 runs"), "{text}");
    assert!(text.contains("the mean model carries them"), "{text}");
    assert!(text.contains("mean of 2"), "{text}");
    let model = std::fs::read_to_string(&m).unwrap();
    assert!(model.contains("[joint_errors]"), "{model}");
    // The model file reads back, joint errors and all.
    let back = gpu_amcs::kinematics::RobotModel::from_toml(&model, "m.toml").unwrap();
    assert!(back.joint_errors.is_some());

    let mut check = base.to_vec();
    check.push("--beyond-geometry=check");
    let text = run_ok(&check);
    assert!(text.contains("kept in 0 of the 2 runs"), "{text}");
    assert!(text.contains("holds the geometry alone"), "{text}");
    assert!(!text.contains("carries them"), "{text}");
    assert!(!std::fs::read_to_string(&m)
        .unwrap()
        .contains("[joint_errors]"));

    let text = run_ok(&["calibrate", "--runs", "2", "--accuracy-points", "10"]);
    assert!(!text.contains("Beyond geometry"), "{text}");
    assert!(text.contains("improvement"), "{text}");

    // Backlash: simulated in pose runs (the explicit check by default, which fits the gaps);
    // sweeps refuse it, and so do several payloads (a run carries one).
    let args = [
        "calibrate",
        "--runs",
        "2",
        "--poses",
        "150",
        "--backlash",
        "1",
        "--accuracy-points",
        "20",
        "-o",
        &m,
    ];
    let text = run_ok(&args);
    assert!(text.contains("Beyond geometry (on"), "{text}");
    assert!(
        text.contains("Backlash (each joint's side from the order of the run's poses")
            && text.contains("kept in 2 of the 2 runs; the mean model carries the runs' mean gaps"),
        "{text}"
    );
    let back =
        gpu_amcs::kinematics::RobotModel::from_toml(&std::fs::read_to_string(&m).unwrap(), "m")
            .unwrap();
    let lash = back.joint_errors.and_then(|e| e.backlash).unwrap();
    // J1's gap is 0.05°: found to a few thousandths of a degree.
    assert!(
        (lash.gap_rad[0].to_degrees() - 0.05).abs() < 0.005,
        "{lash:?}"
    );
    let mut auto = args.to_vec();
    auto.push("--beyond-geometry=auto");
    let text = run_ok(&auto);
    assert!(
        text.contains("record the side each joint arrived from, but the auto mode checks no gaps"),
        "{text}"
    );
    for (args, want) in [
        (
            &["--backlash", "1"][..],
            "--backlash: simulated in pose runs (--poses N)",
        ),
        (
            &["--poses", "60", "--compliance", "1", "--payload-kg", "0,5"][..],
            "--payload-kg: each calibration run carries one payload",
        ),
    ] {
        let args = [&["calibrate", "--runs", "2"][..], args].concat();
        let o = crate::common::run(&args);
        let err = crate::common::stderr(&o);
        assert!(!o.status.success(), "{args:?}");
        assert!(err.contains(want), "{err}");
    }
}

/// A robot with backlash calibrated from poses (each run's sides from its poses' order): every
/// run keeps the gaps, the mean model carries gaps near the true ones, within the σ it states,
/// and the full model at test poses (predicted with their recorded sides) removes what the
/// geometric calibration leaves. Sweeps of such a robot are refused: they cannot show a gap.
#[test]
fn calibrate_simulates_backlash_in_pose_runs() {
    let mut exp = Experiment::tx60(2);
    let sizes = NonGeometricSizes {
        compliance: 1.0,
        harmonics: 1.0,
        payload_kg: 0.0,
        backlash: 1.0,
    };
    exp.set_nongeometric(&sizes, 2).unwrap();
    let truth = exp.nongeometric.as_ref().unwrap().backlash_deg;
    let f = Factors {
        runs: 3,
        ..Factors::default()
    };
    let hook = ProgressHook::none();
    let cal = calibrate_full(&exp, &f, 1, RunData::Poses(200), JointErrorFit::On, &hook).unwrap();
    assert!(cal.runs.iter().all(|r| r
        .full
        .joint_errors
        .as_ref()
        .is_some_and(|e| e.backlash.is_some())));
    for model in [&cal.full.independent, &cal.full.correlated] {
        let lash = model
            .joint_errors
            .as_ref()
            .unwrap()
            .backlash
            .as_ref()
            .unwrap();
        assert!(lash.sides_unknown.is_none());
        for j in 0..6 {
            let (g, s) = (lash.gap_rad[j].to_degrees(), lash.sigma_rad[j].to_degrees());
            eprintln!("J{}: {g:.4} ± {s:.4}° (true {:.4}°)", j + 1, truth[j]);
            assert!((g - truth[j]).abs() <= 3.0 * s, "J{}: {g} ± {s}", j + 1);
        }
    }
    let acc = accuracy_full(&exp, &cal, 50, &WorkspaceBox::default(), 7).unwrap();
    let (g, full) = (acc.mean.geometric.mean_mm, acc.mean.full.mean_mm);
    eprintln!("geometric {g:.4}, full {full:.4} mm");
    assert!(full <= 0.25 * g, "full {full} against geometric {g}");
    let text = gpu_amcs::simulate::render_full_calibration(&cal);
    assert!(
        text.contains("kept in 3 of the 3 runs; the mean model carries"),
        "{text}"
    );
    let err = calibrate_full(&exp, &f, 1, RunData::Sweeps, JointErrorFit::On, &hook).unwrap_err();
    assert!(
        err.to_string()
            .contains("backlash is simulated in pose runs only"),
        "{err}"
    );
    let err = gpu_amcs::simulate::calibrate(&exp, &f, 1).unwrap_err();
    assert!(
        err.to_string()
            .contains("backlash is simulated in pose runs only"),
        "{err}"
    );
}

/// The study's robots with joint errors: beyond.csv has a row per size and kind of data whose
/// figures are the calibrations' (size 1 from poses: the full model below half the geometric
/// calibration's error), and STUDY.md says so.
#[test]
fn study_tabulates_before_geometric_and_full() {
    let d = tmpdir("study-beyond");
    let out = d.join("s").display().to_string();
    run_ok(&[
        "study",
        "--quick",
        "--factors",
        "start",
        "--runs",
        "2",
        "--mcs-draws",
        "2000",
        "--points",
        "5",
        "--joint-errors",
        "1",
        "--joint-error-poses",
        "120",
        "--backend",
        "cpu",
        "-q",
        "-o",
        &out,
    ]);
    let csv = std::fs::read_to_string(d.join("s/beyond.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    assert_eq!(rows.len(), 2, "{csv}");
    let poses = rows.iter().find(|r| r[1].contains("poses")).unwrap();
    let num = |r: &[&str], k: usize| r[k].parse::<f64>().unwrap();
    let (before, geometric, full) = (num(poses, 4), num(poses, 5), num(poses, 6));
    assert!(geometric < before && full < 0.5 * geometric, "{csv}");
    let md = std::fs::read_to_string(d.join("s/STUDY.md")).unwrap();
    assert!(md.contains("## Beyond geometry"), "{md}");
    let json = std::fs::read_to_string(d.join("s/study.json")).unwrap();
    assert!(json.contains("\"beyond_geometry\""));
}

/// From the paper's circle-point sweeps the check leaves out a third of each sweep at a time
/// (docs/METHOD.md §19.6). At size 0.5 the joint errors these sweeps give predict the test poses
/// worse than the geometry (forced in with `keep`), and the check keeps none in either run (one
/// point at a time it kept them in every run); at size 3 they predict the test poses better and
/// every run keeps them.
#[test]
fn sweeps_keep_joint_errors_only_where_they_predict_poses_better() {
    let (forced, forced_acc) = calibrated_from(2025, 0.5, JointErrorFit::Keep, RunData::Sweeps);
    assert!(forced.carries_joint_errors);
    let (g, full) = (
        forced_acc.mean.geometric.mean_mm,
        forced_acc.mean.full.mean_mm,
    );
    eprintln!("size 0.5, sweeps: geometric {g:.4}, full (keep) {full:.4} mm");
    assert!(
        full > 1.2 * g,
        "size 0.5: full {full} against geometric {g}"
    );
    let (checked, acc) = calibrated_from(2025, 0.5, JointErrorFit::On, RunData::Sweeps);
    assert_eq!(
        checked.kept_by_mode(),
        0,
        "size 0.5: a run kept the joint errors"
    );
    assert!(!checked.carries_joint_errors);
    assert_eq!(acc.mean.full, acc.mean.geometric);
    let (large, acc) = calibrated_from(2025, 3.0, JointErrorFit::Auto, RunData::Sweeps);
    let (g, full) = (acc.mean.geometric.mean_mm, acc.mean.full.mean_mm);
    eprintln!("size 3, sweeps: geometric {g:.4}, full {full:.4} mm");
    assert!(large.carries_joint_errors && large.kept_by_mode() == 2);
    assert!(full < 0.7 * g, "size 3: full {full} against geometric {g}");
}
