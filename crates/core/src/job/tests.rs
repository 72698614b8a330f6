//! Each job gives what the driver calls it replaces gave, and its refusals name the setting.

use super::*;
use crate::engine::{BackendChoice, CpuOnly};
use crate::map::{MapSetting, Plane};
use crate::mc::sensitivity::{run_sensitivity, SensitivitySetting};
use crate::mc::tail::run_tail;
use crate::mc::{run_amcs, run_mcs, McsOptions};
use crate::memory::LimitSource;
use crate::plan::{PlanField, PlanOptions};
use crate::report::Report;
use crate::spec::{GeneratedPoints, PointsSource};
use std::sync::{Arc, Mutex};

/// The TX60 at `m` generated points on the CPU.
fn spec(m: usize) -> ProblemSpec {
    ProblemSpec {
        points: PointsSource::Generate(GeneratedPoints {
            count: m,
            ..GeneratedPoints::default()
        }),
        backend: BackendChoice::Cpu,
        ..ProblemSpec::default()
    }
}

/// A budget of `bytes`, as a user gives it.
fn budget(bytes: u64) -> MemoryBudget {
    MemoryBudget {
        limit: bytes,
        source: LimitSource::User,
    }
}

/// The problem of `spec` and its CPU evaluator, as the front ends built them by hand.
fn by_hand(spec: &ProblemSpec) -> (Problem, Box<dyn Evaluator>) {
    let built = spec.build(&CpuOnly).unwrap();
    (built.problem, built.evaluator)
}

#[test]
fn the_amcs_job_gives_the_drivers_result_with_the_reports_fields() {
    let mut job = AmcsJob::new(spec(6));
    job.options.batch_size = 2000;
    job.options.max_draws = 40_000;
    let outcome = job.run(&CpuOnly).unwrap();
    let (problem, mut ev) = by_hand(&job.setup.problem);
    let direct = run_amcs(ev.as_mut(), &job.options, None).unwrap();
    let r = &outcome.report;
    assert_eq!(r.result.sorted_values, direct.sorted_values);
    assert_eq!(r.result.estimate, direct.estimate);
    assert_eq!(r.result.draws, direct.draws);
    assert_eq!(
        (r.model.as_str(), r.points, r.seed),
        ("Staubli TX60", 6, 2025)
    );
    assert_eq!(r.reference, "calibrated model");
    assert_eq!(outcome.analysed.points, problem.n_points());
    assert!(outcome.summary.is_none());
}

#[test]
fn an_mcs_job_keeps_its_values_or_summarises_them_when_they_do_not_fit() {
    let mut job = McsJob::new(spec(2));
    job.draws = 1_000_000;
    let kept = job.run(&CpuOnly).unwrap();
    let (_, mut ev) = by_hand(&job.setup.problem);
    let direct = run_mcs(
        ev.as_mut(),
        &McsOptions {
            draws: 1_000_000,
            chunk: McsJob::chunk(1_000_000),
            settings: job.settings.clone(),
        },
        None,
    )
    .unwrap();
    assert_eq!(kept.report.result.sorted_values, direct.sorted_values);
    // The values of 10^6 draws need 16 MB: within 10 MB the run is summarised (its histogram
    // reserves 4 MiB), and says so.
    job.setup.memory = budget(10 << 20);
    let summarised = job.run(&CpuOnly).unwrap();
    assert!(summarised.summary.is_some());
    assert!(summarised.report.notes[0].starts_with("summary mode: keeping the values of 1000000"));
    let (a, b) = (summarised.report.result.estimate, direct.estimate);
    assert!((a - b).abs() <= 1e-12 * b, "{a} {b}");
    // Never summarised: refused, naming the check.
    job.summary = SummaryMode::Never;
    match job.run(&CpuOnly) {
        Err(JobError::Memory {
            check: MemoryCheck::Mcs,
            error,
        }) => assert!(error.to_string().contains("MCS with 1000000 draws needs")),
        other => panic!("{other:?}"),
    }
}

#[test]
fn mcs_shards_cover_the_run_and_too_many_are_refused() {
    let mut job = McsJob::new(spec(3));
    job.draws = 3000;
    job.summary = SummaryMode::Always;
    let whole = job.run(&CpuOnly).unwrap().summary.unwrap();
    let shards: Vec<_> = (0..3)
        .map(|k| {
            job.shard = Shard::new(k, 3).unwrap();
            let s = job.run(&CpuOnly).unwrap().summary.unwrap();
            (format!("shard {k}"), s)
        })
        .collect();
    let merged = crate::mc::summary::merge(&shards).unwrap();
    assert_eq!(merged.to_result().draws, whole.to_result().draws);
    assert_eq!(
        merged.to_result().coverage_interval,
        whole.to_result().coverage_interval
    );
    job.shard = Shard::new(0, 4000).unwrap();
    match job.run(&CpuOnly) {
        Err(JobError::Setting {
            setting: JobSetting::Shard,
            message,
        }) => assert_eq!(message, "4000 shards of 3000 draws leave some empty"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn the_sensitivity_job_gives_the_analysis_and_tells_its_estimate() {
    let mut job = SensitivityJob::new(spec(3));
    job.options.draws = 256;
    job.options.bootstrap = 100;
    let heard = Arc::new(Mutex::new(Vec::new()));
    let log = heard.clone();
    job.setup.progress = ProgressHook::none().with_notices(move |n: Notice<'_>| {
        if let Notice::Estimate { label, what, .. } = n {
            log.lock().unwrap().push(format!("{label}: {what}"));
        }
    });
    let outcome = job.run(&CpuOnly).unwrap();
    let (problem, mut ev) = by_hand(&job.setup.problem);
    let direct = run_sensitivity(&problem, ev.as_mut(), &job.options).unwrap();
    assert_eq!(outcome.result.json(), direct.json());
    let heard = heard.lock().unwrap();
    assert_eq!(heard.len(), 1);
    assert!(
        heard[0].starts_with("sensitivity: N = 256 base samples ("),
        "{heard:?}"
    );
    // Refusals name the setting: the options', the memory's.
    job.options.draws = 100;
    assert!(matches!(
        job.run(&CpuOnly),
        Err(JobError::Sensitivity(
            crate::mc::sensitivity::SensitivityError::Setting {
                field: SensitivitySetting::Draws,
                ..
            }
        ))
    ));
    job.options.draws = 256;
    job.setup.memory = budget(1000);
    assert!(matches!(
        job.check(),
        Err(JobError::Memory {
            check: MemoryCheck::Sensitivity,
            ..
        })
    ));
}

#[test]
fn the_tail_job_gives_the_estimators_result() {
    let mut job = TailJob::new(spec(3));
    job.options.thresholds = vec![0.25];
    job.options.samples_per_level = 200;
    job.options.target_cov = 0.5;
    let outcome = job.run(&CpuOnly).unwrap();
    let (problem, mut ev) = by_hand(&job.setup.problem);
    let direct = run_tail(ev.as_mut(), &problem, &job.options, None).unwrap();
    assert_eq!(outcome.result.estimates, direct.estimates);
    assert_eq!(outcome.result.evaluations, direct.evaluations);
    assert_eq!(outcome.notes, Vec::<String>::new());
    job.setup.memory = budget(1000);
    assert!(matches!(
        job.run(&CpuOnly),
        Err(JobError::Memory {
            check: MemoryCheck::Tail,
            ..
        })
    ));
}

/// A 5 × 5 map of the TX60's xz plane at 300 draws.
fn map_job() -> MapJob {
    let mut job = MapJob::new(crate::spec::ModelSource::Preset("tx60".into()));
    job.grid.plane = Some(Plane::Xz);
    job.grid.at = Some(0.0);
    job.grid.cells = Some(vec![5, 5]);
    job.draws = 300;
    job.backend = BackendChoice::Cpu;
    job
}

#[test]
fn the_map_job_maps_and_its_shards_cover_the_reached_cells() {
    let job = map_job();
    let whole = job.run(&CpuOnly).unwrap().result;
    let shards: Vec<_> = (0..2)
        .map(|k| {
            let s = job.run_shard(&CpuOnly, Shard::new(k, 2).unwrap()).unwrap();
            (format!("shard {k}"), s)
        })
        .collect();
    let merged = crate::map::shard::merge(&shards).unwrap();
    assert_eq!(merged.reached, whole.reached);
    assert_eq!(merged.multi_point, whole.multi_point);
}

#[test]
fn map_refusals_name_the_setting_and_the_shards_that_would_fit() {
    let mut job = map_job();
    job.grid.at = None;
    assert!(matches!(
        job.run(&CpuOnly),
        Err(JobError::Map(crate::map::MapError::Setting {
            field: MapSetting::PlanePosition,
            ..
        }))
    ));
    assert!(job.layers().is_err());
    let mut job = map_job();
    job.grid.orientation = Some(vec![180.0, 0.0]);
    assert!(matches!(
        job.run(&CpuOnly),
        Err(JobError::Map(crate::map::MapError::Setting {
            field: MapSetting::Orientation,
            ..
        }))
    ));
    // A 100 × 100 map at 10^4 draws keeps 800 MB of errors: 64 MB fit it in shards.
    let mut job = map_job();
    job.grid.cells = Some(vec![100, 100]);
    job.draws = 10_000;
    job.memory = budget(64 << 20);
    match job.run(&CpuOnly) {
        Err(JobError::Memory {
            check: MemoryCheck::Map { shards: Some(k) },
            ..
        }) => assert!(k > 10, "{k}"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn the_plan_job_plans_then_predicts_and_refuses_draws_out_of_range() {
    let mut job = PlanJob::new(spec(5));
    job.poses = 10;
    job.candidates = 200;
    job.draws = 1000;
    let outcome = job.run(&CpuOnly).unwrap();
    // The same plan by hand: the model, the task's degrees, the planner, the prediction.
    let built = job.setup.problem.build_problem().unwrap();
    let model = crate::plan::model_to_plan(&built.problem);
    let task: Vec<_> = built
        .problem
        .points
        .iter()
        .map(|q| q.map(f64::to_degrees))
        .collect();
    let opts = PlanOptions {
        poses: 10,
        candidates: 200,
        target_mm: PlanOptions::default_target(&model),
        seed: 2025,
        ..PlanOptions::default()
    };
    let mut direct = crate::plan::plan(&model, &task, &opts).unwrap();
    let problem = crate::plan::prediction_problem(&direct, &task, 2025).unwrap();
    let mut ev = CpuOnly
        .make_evaluator(problem, BackendChoice::Cpu, None)
        .unwrap()
        .0;
    direct.prediction = Some(crate::plan::predict(ev.as_mut(), 1000, &job.thresholds).unwrap());
    assert_eq!(outcome.plan.design_deg, direct.design_deg);
    assert_eq!(outcome.plan.prediction, direct.prediction);
    job.draws = 50;
    assert!(matches!(
        job.run(&CpuOnly),
        Err(JobError::Plan(crate::plan::PlanError::Setting {
            field: PlanField::Search,
            ..
        }))
    ));
    job.draws = 1000;
    job.candidates = 100_000_000;
    job.setup.memory = budget(1 << 30);
    assert!(matches!(
        job.run(&CpuOnly),
        Err(JobError::Memory {
            check: MemoryCheck::PlanSearch,
            ..
        })
    ));
}

#[test]
fn the_plan_job_refuses_what_a_plan_does_not_use_before_any_work() {
    use crate::plan::{KeepOut, PlanError, TrackerSite};
    use crate::spec::ReferenceSource;
    let refused = |job: &PlanJob| match job.check() {
        Err(JobError::Setting { setting, message }) => {
            assert!(!message.contains("--"), "{message}");
            Some(setting)
        }
        Err(e) => panic!("{e}"),
        Ok(()) => None,
    };
    let ok = PlanJob::new(spec(5));
    assert_eq!(refused(&ok), None);
    let mut job = ok.clone();
    job.setup.problem.reference = ReferenceSource::Nominal(None);
    assert_eq!(refused(&job), Some(JobSetting::Reference));
    let mut job = ok.clone();
    job.setup.frame = Frame::Base;
    assert_eq!(refused(&job), Some(JobSetting::Frame));
    // The tracker's range and incidence, each named (the planner names them the same).
    let field = |job: &PlanJob| match job.check() {
        Err(JobError::Plan(PlanError::Setting { field, message })) => {
            assert!(!message.contains("--"), "{message}");
            field
        }
        other => panic!("{other:?}"),
    };
    let site = |range_mm, max_incidence_deg| TrackerSite {
        position_mm: [3000.0, 0.0, 500.0],
        range_mm,
        max_incidence_deg,
    };
    let mut job = ok.clone();
    for (range, incidence, want) in [
        (0.0, 60.0, PlanField::TrackerRange),
        (f64::NAN, 60.0, PlanField::TrackerRange),
        (1e30, 60.0, PlanField::TrackerRange),
        (20_000.0, 0.0, PlanField::MaxIncidence),
        (20_000.0, 91.0, PlanField::MaxIncidence),
    ] {
        job.tracker = Some(site(range, incidence));
        assert_eq!(field(&job), want, "{range} mm, {incidence}°");
        let opts = PlanOptions {
            tracker: job.tracker.clone(),
            ..PlanOptions::default()
        };
        let model = crate::kinematics::tx60();
        match crate::plan::plan(&model, &[[0.0; 6].into()], &opts) {
            Err(PlanError::Setting { field, .. }) => assert_eq!(field, want),
            other => panic!("{:?}", other.map(|p| p.design_deg)),
        }
    }
    job.tracker = Some(site(100_000.0, 90.0));
    assert_eq!(refused(&job), None);
    // A link radius nothing checks: no self-collision check, no floor, no keep-out box.
    let mut job = ok.clone();
    job.workcell.link_radius_mm = Some(100.0);
    job.workcell.self_collision = false;
    match job.check() {
        Err(JobError::Plan(PlanError::Unused { field, needs, .. })) => {
            assert_eq!(field, PlanField::LinkRadius);
            assert_eq!(
                needs,
                [
                    PlanField::SelfCollision,
                    PlanField::Floor,
                    PlanField::KeepOut
                ]
            );
        }
        other => panic!("{other:?}"),
    }
    job.workcell.keep_out = vec![KeepOut::between([1.0, 2.0, 3.0, 0.0, 5.0, -1.0])];
    assert_eq!(job.workcell.keep_out[0].min_mm, [0.0, 2.0, -1.0]);
    assert_eq!(job.workcell.keep_out[0].max_mm, [1.0, 5.0, 3.0]);
    assert_eq!(refused(&job), None);
}

#[test]
fn the_compare_job_is_an_mcs_job_then_an_amcs_job_per_delta() {
    let mut job = CompareJob::new(spec(4));
    job.draws = 50_000;
    job.deltas = vec![0.05, 0.02];
    job.batch_size = 2000;
    job.coverage_probability = 0.9;
    let labels = Arc::new(Mutex::new(Vec::<String>::new()));
    let seen = labels.clone();
    job.setup.progress = crate::progress::ProgressHook::new(move |label: &str, _, _| {
        let mut l = seen.lock().unwrap();
        if l.last().map(String::as_str) != Some(label) {
            l.push(label.to_string());
        }
    });
    let c = job.run(&CpuOnly).unwrap().comparison;
    assert_eq!(
        *labels.lock().unwrap(),
        ["MCS", "AMCS δ=0.05", "AMCS δ=0.02"]
    );
    // The MCS run is the MCS job's with the same seed, bit for bit.
    let mut mcs = McsJob::new(spec(4));
    mcs.draws = 50_000;
    mcs.settings.coverage_probability = 0.9;
    let alone = mcs.run(&CpuOnly).unwrap().report;
    assert_eq!(c.mcs.sorted_values, alone.result.sorted_values);
    assert_eq!(c.mcs.moments, alone.result.moments);
    assert_eq!(
        (c.model.as_str(), c.points, c.seed),
        ("Staubli TX60", 4, alone.seed)
    );
    assert_eq!(c.notes, alone.notes);
    // Each AMCS run is the AMCS job's at its δ, and its MRE is against the MCS run.
    assert_eq!(c.amcs.len(), 2);
    for (d, r, mre) in &c.amcs {
        let mut amcs = AmcsJob::new(spec(4));
        amcs.options.tolerance = crate::mc::Tolerance::Delta(*d);
        amcs.options.batch_size = 2000;
        amcs.options.max_draws = COMPARE_AMCS_CAP;
        amcs.options.settings.coverage_probability = 0.9;
        let alone = amcs.run(&CpuOnly).unwrap().report.result;
        assert_eq!(r.sorted_values, alone.sorted_values, "δ = {d}");
        assert_eq!(r.draws, alone.draws, "δ = {d}");
        assert_eq!(*mre, crate::report::max_relative_error(&alone, &c.mcs));
    }
    // Its settings are refused before any work, the AMCS runs' first; its memory as a whole.
    job.deltas = vec![0.05, -1.0];
    job.draws = 10;
    assert!(matches!(
        job.run(&CpuOnly),
        Err(JobError::Run(crate::mc::McError::Setting {
            field: crate::mc::Setting::Tolerance,
            ..
        }))
    ));
    job.deltas = vec![0.05];
    assert!(matches!(
        job.check(),
        Err(JobError::Run(crate::mc::McError::Setting {
            field: crate::mc::Setting::Draws,
            ..
        }))
    ));
    job.draws = 50_000;
    job.setup.memory = budget(1 << 20);
    assert!(matches!(
        job.run(&CpuOnly),
        Err(JobError::Memory {
            check: MemoryCheck::Compare,
            ..
        })
    ));
}
