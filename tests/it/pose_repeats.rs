//! Pose files as trackers write them (issue 34): each pose measured several times (the scatter
//! of the repeats is the noise when none is stated, and is checked against a stated one), joint
//! angles in radians (refused when undeclared, read when the columns say `_rad`), and runs that
//! disagree beyond their uncertainty flagged instead of silently averaged.

use crate::common::tmpdir;
use gpu_amcs::identify::chain::nominal_state;
use gpu_amcs::identify::{
    render_identify_report, write_poses, IdentifyJob, IdentifyOutcome, NoiseModel, PoseData,
};
use gpu_amcs::kinematics::{
    param_index, position, tx60, BaseTransform, Joints, ParamKind, RobotModel,
};
use gpu_amcs::simulate::{random_poses, simulate_poses, TrackerNoise};

/// σ of the simulated tracker, mm per coordinate.
const SIGMA: f64 = 0.01;

/// A TX60 a calibration would find: a few tenths of a millimetre and hundredths of a degree off
/// nominal, with a tool.
fn truth() -> RobotModel {
    let mut t = tx60();
    t.tool = [30.0, -20.0, 80.0];
    for (j, kind, d) in [
        (2, ParamKind::A, 0.3),
        (3, ParamKind::D, -0.2),
        (4, ParamKind::D, 0.25),
        (2, ParamKind::Alpha, 4e-4),
        (1, ParamKind::Beta, -3e-4),
    ] {
        t.params[param_index(j, kind)] += d;
    }
    t
}

fn placement() -> BaseTransform {
    BaseTransform {
        xyz: [2000.0, 300.0, -100.0],
        rpy: [0.02, -0.01, 1.0],
    }
}

/// `poses` configurations each measured `repeats` times in a row (independent noise), as one
/// run labelled `run`.
fn measured(
    truth: &RobotModel,
    poses: usize,
    repeats: usize,
    seed: u64,
    run: Option<&str>,
) -> PoseData {
    let configs = random_poses(truth, poses, seed);
    let takes: Vec<PoseData> = (0..repeats as u64)
        .map(|r| {
            simulate_poses(
                truth,
                &configs,
                &placement(),
                &TrackerNoise::Isotropic(SIGMA),
                100 * seed + r,
            )
        })
        .collect();
    let mut data = takes[0].clone();
    data.runs[0].run = run.map(str::to_string);
    data.runs[0].points = (0..poses)
        .flat_map(|i| takes.iter().map(move |t| t.runs[0].points[i].clone()))
        .collect();
    data
}

fn write(name: &str, data: &PoseData) -> std::path::PathBuf {
    let path = tmpdir(name).join("poses.csv");
    let mut csv = Vec::new();
    write_poses(data, &mut csv).unwrap();
    std::fs::write(&path, csv).unwrap();
    path
}

fn identify(path: &std::path::Path, sigma: Option<f64>) -> IdentifyOutcome {
    let mut job = IdentifyJob::new(path.to_path_buf(), tx60());
    job.tracker_sigma_mm = sigma;
    job.run().unwrap()
}

/// 60 poses × 3 repeats, σ = 0.01 mm and no σ stated: the noise is the pure error (360 degrees
/// of freedom, within 3 standard errors of 0.01 mm), the report says where it came from, the
/// fit takes 60 pose means, and the identified parameters agree with the truth within their
/// σ (z-scores RMS < 1.5, none beyond 4), as do positions at new configurations.
#[test]
fn repeats_give_the_noise_and_the_truth() {
    let truth = truth();
    let path = write("repeats-truth", &measured(&truth, 60, 3, 1, None));
    let out = identify(&path, None);
    let NoiseModel::PureError {
        sigma_mm,
        dof,
        repeated,
        min_k,
        max_k,
    } = out.chain.noise
    else {
        panic!("noise {:?}", out.chain.noise)
    };
    assert_eq!((dof, repeated, min_k, max_k), (360, 60, 3, 3));
    let se = SIGMA / (2.0 * dof as f64).sqrt();
    eprintln!("pure-error σ = {sigma_mm:.5} mm (truth {SIGMA}, standard error {se:.5})");
    assert!((sigma_mm - SIGMA).abs() < 3.0 * se, "{sigma_mm}");
    let chain = out.runs[0].report.chain.as_ref().unwrap();
    assert_eq!(chain.points, 60);
    assert!(
        chain
            .noise
            .source
            .contains("from repeated measurements (pure error): 60 poses measured 3 times")
            && chain.noise.source.contains("360 degrees of freedom"),
        "{}",
        chain.noise.source
    );
    assert!(
        chain.lack_of_fit.summary.contains("pure error") && chain.lack_of_fit.found == Some(false),
        "{}",
        chain.lack_of_fit.summary
    );
    let text = render_identify_report(&out.runs[0].report);
    assert!(text.contains("from repeated measurements"), "{text}");
    // The parameters against the truth, in report units.
    let mut placed = truth.clone();
    let p = placement();
    placed.base = Some(p);
    let state = nominal_state(&placed);
    let space = state.space();
    let mut z = Vec::new();
    for row in chain.parameters.iter().filter(|r| r.status == "identified") {
        let i = space.find(&row.name).unwrap();
        let mut d = row.value - state.get(i) * space.from_internal(i);
        if row.unit == "deg" {
            d = (d + 180.0).rem_euclid(360.0) - 180.0;
        }
        z.push(d / row.sigma);
    }
    let rms = (z.iter().map(|v| v * v).sum::<f64>() / z.len() as f64).sqrt();
    let worst = z.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    eprintln!(
        "{} identified parameters: z-score RMS {rms:.2}, largest {worst:.2}",
        z.len()
    );
    assert!(rms < 1.5 && worst < 4.0, "{z:?}");
    // Positions at new configurations, tracker frame.
    let model = &out.model;
    let at = |m: &RobotModel, q: &Joints| {
        let v = position(&m.params, &m.tool, &q.map(f64::to_radians));
        m.base.unwrap_or(p).apply(v)
    };
    let worst = random_poses(&truth, 200, 77)
        .iter()
        .map(|q| {
            let (a, b) = (
                at(model, q),
                p.apply(position(
                    &truth.params,
                    &truth.tool,
                    &q.map(f64::to_radians),
                )),
            );
            ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
        })
        .fold(0.0f64, f64::max);
    eprintln!("largest position error at 200 new configurations: {worst:.4} mm");
    assert!(worst < 3.0 * SIGMA, "{worst}");
}

/// A stated σ beside repeats: both are reported; one the repeats agree with gives no warning,
/// one five times too small is a warning naming both.
#[test]
fn a_stated_sigma_is_checked_against_the_repeats() {
    let path = write("repeats-stated", &measured(&truth(), 40, 3, 2, None));
    let out = identify(&path, Some(SIGMA));
    let chain = out.runs[0].report.chain.as_ref().unwrap();
    assert_eq!(chain.points, 40);
    assert!(
        chain
            .noise
            .source
            .starts_with("stated: 0.01 mm per coordinate")
            && chain.noise.source.contains("40 poses measured 3 times")
            && chain.noise.source.contains("the repeats scatter"),
        "{}",
        chain.noise.source
    );
    assert!(
        !out.warnings
            .iter()
            .any(|w| w.contains("repeated measurements")),
        "{:?}",
        out.warnings
    );
    let out = identify(&path, Some(SIGMA / 5.0));
    assert!(
        out.warnings
            .iter()
            .any(|w| w.contains("repeated measurements scatter") && w.contains("too small")),
        "{:?}",
        out.warnings
    );
}

/// Joint angles written in radians: refused with one line naming the file and the remedy;
/// declared by `_rad` columns, read and identified.
#[test]
fn radians_are_refused_or_read_when_declared() {
    let truth = truth();
    let mut data = simulate_poses(
        &truth,
        &random_poses(&truth, 40, 3),
        &placement(),
        &TrackerNoise::Isotropic(SIGMA),
        3,
    );
    for p in &mut data.runs[0].points {
        p.q_deg = p.q_deg.map(f64::to_radians);
    }
    let path = write("radians", &data);
    let e = IdentifyJob::new(path.clone(), tx60())
        .run()
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("poses.csv")
            && e.contains("line 2")
            && e.contains("joint angles look like radians")
            && e.contains("q1_rad")
            && !e.contains('\n'),
        "{e}"
    );
    let text = std::fs::read_to_string(&path).unwrap();
    let declared = text.replacen(
        "q1,q2,q3,q4,q5,q6",
        "q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad",
        1,
    );
    std::fs::write(&path, declared).unwrap();
    let out = identify(&path, None);
    for k in 0..3 {
        assert!(
            (out.model.tool[k] - truth.tool[k]).abs() < 0.1,
            "{:?}",
            out.model.tool
        );
    }
}

/// Two runs of one robot agree; a run of a robot whose a2 is 0.5 mm longer is flagged with
/// both run names instead of being silently averaged.
#[test]
fn runs_that_disagree_are_flagged() {
    let same = {
        let mut d = measured(&truth(), 40, 1, 4, Some("monday"));
        d.runs
            .extend(measured(&truth(), 40, 1, 5, Some("tuesday")).runs);
        d
    };
    let out = identify(&write("runs-agree", &same), None);
    assert!(
        !out.warnings.iter().any(|w| w.contains("disagree")),
        "{:?}",
        out.warnings
    );
    let mut other = truth();
    other.params[param_index(2, ParamKind::A)] += 0.5;
    let mut differ = measured(&truth(), 40, 1, 4, Some("monday"));
    differ
        .runs
        .extend(measured(&other, 40, 1, 5, Some("tuesday")).runs);
    let out = identify(&write("runs-differ", &differ), None);
    assert!(
        out.warnings
            .iter()
            .any(|w| w.contains("runs monday and tuesday disagree beyond their uncertainty")),
        "{:?}",
        out.warnings
    );
}
