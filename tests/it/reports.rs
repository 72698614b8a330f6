//! Every analysis is one `Report`: for a run (AMCS with single-point reliabilities, and MCS), a
//! comparison, Sobol indices, tail probabilities, a plane and a 3-D map, an identification and
//! the factor study, the files each part writes are the ones its layout names before the run,
//! the report directory is its JSON, other, CSV and SVG files with the page last, and the page
//! links every JSON and CSV file of the directory.

use gpu_amcs::engine::{CpuEvaluator, CpuOnly, Problem, Reference};
use gpu_amcs::identify::{identify, IdentifyOptions, IdentifyReports};
use gpu_amcs::kinematics::tx60;
use gpu_amcs::map::{
    default_reference_deg, evaluate, test_points, tool_down_rpy_deg, Grid, MapResult, MapSpec,
    Plane, Timings,
};
use gpu_amcs::mc::sensitivity::{run_sensitivity, SensitivityOptions, SensitivityResult};
use gpu_amcs::mc::tail::{run_tail, TailOptions, TailResult};
use gpu_amcs::mc::{run_amcs, run_mcs, AmcsOptions, McsOptions, RunSettings, Tolerance};
use gpu_amcs::points::WorkspaceBox;
use gpu_amcs::report::{max_relative_error, Comparison, Layout, Report, RunReport, INDEX};
use gpu_amcs::simulate::{simulate_sweeps, SweepPlan};
use gpu_amcs::study::{run_study, Factor, StudyResult, StudySettings};

/// The checks of one report against `planned`, the layout its type gives before the run.
fn check(r: &dyn Report, planned: Layout, what: &str) {
    let layout = r.layout();
    assert_eq!(layout, planned, "{what}: layout");
    let names = |files: Vec<(String, String)>| -> Vec<String> {
        files.into_iter().map(|(n, _)| n).collect()
    };
    for (part, written, allowed) in [
        ("csv", names(r.csv()), &layout.csv),
        ("svg", names(r.svg()), &layout.svg),
        ("other", names(r.other()), &layout.other),
    ] {
        assert!(
            !written.is_empty() || allowed.is_empty(),
            "{what}: no {part}"
        );
        for n in written {
            assert!(
                allowed.contains(&n),
                "{what}: {part} {n} not in {allowed:?}"
            );
        }
    }
    assert!(!r.text().is_empty(), "{what}: text");
    serde_json::from_str::<serde_json::Value>(&r.json())
        .unwrap_or_else(|e| panic!("{what}: JSON {e}"));
    let settings = [("where it came from".to_string(), "a test".to_string())];
    let html = r.html(&settings);
    let (page_name, page) = html.last().unwrap();
    assert_eq!(page_name, INDEX, "{what}: the page is last");
    assert!(page.contains("where it came from"), "{what}: settings rows");
    let files = r.files();
    assert_eq!(
        &html[..html.len() - 1],
        &files[..],
        "{what}: directory = files + page"
    );
    assert_eq!(
        files[0],
        (layout.json.clone(), r.json()),
        "{what}: JSON first"
    );
    for (n, _) in &html {
        assert!(layout.html().contains(n), "{what}: {n} not in the layout");
        if n.ends_with(".json") || n.ends_with(".csv") {
            assert!(
                page.contains(&format!("href=\"./{n}\"")),
                "{what}: {n} not linked"
            );
        }
    }
}

fn problem(points: usize) -> Problem {
    let m = tx60();
    let pts = gpu_amcs::points::generate(&m, points, &WorkspaceBox::default(), 1).unwrap();
    Problem::new(m, &pts, &Reference::Calibrated, 2025).unwrap()
}

fn run_report(result: gpu_amcs::mc::McResult) -> RunReport {
    RunReport {
        model: "Staubli TX60".into(),
        points: 4,
        reference: "calibrated model".into(),
        seed: 2025,
        notes: Vec::new(),
        result,
    }
}

#[test]
fn runs_and_comparisons_write_what_their_layout_names() {
    let mut ev = CpuEvaluator::new(problem(4));
    let settings = RunSettings {
        per_point: true,
        ..RunSettings::default()
    };
    let amcs = run_amcs(
        &mut ev,
        &AmcsOptions {
            tolerance: Tolerance::Delta(0.05),
            settings: settings.clone(),
            ..AmcsOptions::default()
        },
        None,
    )
    .unwrap();
    let rep = run_report(amcs.clone());
    check(&rep, RunReport::planned_layout(), "amcs");
    // Every CSV of an AMCS run with single-point reliabilities is written.
    assert_eq!(rep.csv().len(), RunReport::planned_layout().csv.len());
    let mcs = run_mcs(
        &mut ev,
        &McsOptions {
            draws: 20_000,
            chunk: 10_000,
            settings: RunSettings::default(),
        },
        None,
    )
    .unwrap();
    check(&run_report(mcs.clone()), RunReport::planned_layout(), "mcs");
    let mre = max_relative_error(&amcs, &mcs);
    let c = Comparison {
        model: "Staubli TX60".into(),
        points: 4,
        seed: 2025,
        mcs,
        amcs: vec![(0.05, amcs, mre)],
        notes: vec!["a note".into()],
    };
    check(&c, Comparison::planned_layout(), "comparison");
}

#[test]
fn sensitivity_and_tail_write_what_their_layout_names() {
    let pb = problem(3);
    let opts = SensitivityOptions {
        draws: 64,
        bootstrap: 100,
        thresholds: vec![0.1],
        ..SensitivityOptions::default()
    };
    let s = run_sensitivity(&pb, &mut CpuEvaluator::new(pb.clone()), &opts).unwrap();
    check(&s, SensitivityResult::planned_layout(), "sensitivity");
    let opts = TailOptions {
        thresholds: vec![0.12],
        samples_per_level: 200,
        max_evaluations: 20_000,
        ..TailOptions::default()
    };
    let t = run_tail(&mut CpuEvaluator::new(pb.clone()), &pb, &opts, None).unwrap();
    check(&t, TailResult::planned_layout(), "tail");
}

#[test]
fn maps_write_what_their_layout_names() {
    let m = tx60();
    for (grid, layers) in [
        (
            Grid::Plane {
                plane: Plane::Xz,
                at: 0.0,
                cells: [6, 5],
            },
            1,
        ),
        (Grid::Volume { cells: [3, 3, 2] }, 2),
    ] {
        let spec = MapSpec {
            grid,
            workspace: WorkspaceBox::default(),
            orientation_rpy_deg: Some(tool_down_rpy_deg(&m)),
            reference_q_deg: default_reference_deg(&m),
            ik_seeds: 4,
        };
        let sol = spec.solve(&m).unwrap();
        let pb = Problem::new(m.clone(), &test_points(&sol), &Reference::Calibrated, 7).unwrap();
        let mut ev = CpuEvaluator::new(pb);
        let e = evaluate(&mut ev, 200, 200, &[0.1, 0.2], None).unwrap();
        let info = gpu_amcs::engine::Evaluator::info(&ev);
        let r = MapResult::new(&m.name, &spec, 7, sol, e, info, Timings::default());
        check(&r, MapResult::planned_layout(layers), "map");
        assert_eq!(r.svg().len(), 2 * layers, "two heat maps per layer");
    }
}

#[test]
fn identification_writes_what_its_layout_names() {
    let mut truth = tx60();
    truth.tool = [30.0, -20.0, 80.0];
    for runs in [1, 3] {
        let data = simulate_sweeps(&truth, &SweepPlan::default(), 0.01, runs, 5);
        let ids = identify(&data, &tx60(), &IdentifyOptions::default()).unwrap();
        let r = IdentifyReports::new("Staubli TX60", &ids);
        check(&r, IdentifyReports::planned_layout(), "identify");
        let json: serde_json::Value = serde_json::from_str(&r.json()).unwrap();
        let json_runs = json["identify"]["runs"].as_array().unwrap();
        assert_eq!(json_runs.len(), runs);
        let tool = &json_runs[0]["tool_mm"];
        assert!((tool[0].as_f64().unwrap() - 30.0).abs() < 0.5, "{tool}");
        // One row per run and joint, one per run.
        let csv = r.csv();
        assert_eq!(csv[0].1.lines().count(), 1 + 6 * runs);
        assert_eq!(csv[1].1.lines().count(), 1 + runs);
    }
}

#[test]
fn the_study_writes_what_its_layout_names() {
    let mut s = StudySettings::quick();
    s.factors = vec![Factor::Step];
    s.baseline.runs = 3;
    s.mcs_draws = 20_000;
    s.point_counts = vec![5];
    let r: StudyResult = run_study(&s, &CpuOnly, None).unwrap();
    check(&r, StudyResult::planned_layout(&s), "study");
    // Every figure the layout names for one factor at two tolerances is drawn.
    assert_eq!(r.svg().len(), StudyResult::planned_layout(&s).svg.len());
}
