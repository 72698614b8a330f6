//! The identification's check beyond geometry (issue 33, first step): joint compliance under
//! gravity and gear harmonics fitted with the geometry, on robots of the library's simulator
//! (`simulate::nongeometric`) with known truth.

use gpu_amcs::identify::chain::{identify_chain, ChainOptions, ChainResult};
use gpu_amcs::identify::noise::NoiseModel;
use gpu_amcs::identify::NominalPrior;
use gpu_amcs::kinematics::{tx60, Joints};
use gpu_amcs::simulate::{
    random_placement, random_poses, simulate_poses_of, true_position, Experiment, NonGeometric,
    NonGeometricSizes, TrackerNoise,
};

/// A TX60 of `sizes` (robot `seed`) measured at `n` random poses with noise `sigma` (mm per
/// coordinate, stated), identified with the check beyond geometry; and the held-out errors
/// (mm) of the geometric model and of the extended one at 100 noise-free poses.
fn experiment(
    sizes: &NonGeometricSizes,
    seed: u64,
    n: usize,
    sigma: f64,
) -> (ChainResult, Vec<f64>, Vec<f64>, Option<NonGeometric>) {
    let truth = Experiment::tx60(seed).truth;
    let errors = NonGeometric::draw(&truth, sizes, seed);
    let placement = random_placement(seed);
    let configs = random_poses(&truth, n, seed + 1);
    let data = simulate_poses_of(
        &truth,
        errors.as_ref(),
        &configs,
        &placement,
        &TrackerNoise::Isotropic(sigma),
        seed + 2,
    );
    let points = crate::common::measured_points(&data);
    let opts = ChainOptions {
        noise: NoiseModel::Isotropic {
            sigma_mm: sigma.max(1e-4),
        },
        beyond_geometry: gpu_amcs::identify::JointErrorFit::On,
        compensate: false,
        ..ChainOptions::default()
    };
    let r = identify_chain(&points, &tx60(), None, Some(NominalPrior::default()), &opts).unwrap();
    let held = random_poses(&truth, 100, seed + 3);
    let (mut geometric, mut extended) = (Vec::new(), Vec::new());
    let ext = r.extended.as_ref().expect("the check was asked for");
    for q in &held {
        let q: Joints = q.map(f64::to_radians);
        let p = placement.apply(true_position(&truth, errors.as_ref(), &q));
        let d = |m: [f64; 3]| ((0..3).map(|k| (m[k] - p[k]).powi(2)).sum::<f64>()).sqrt();
        geometric.push(d(r.state.predict(&q)));
        extended.push(d(ext.predict(&q)));
    }
    (r, geometric, extended, errors)
}

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

pub(crate) const BENT: NonGeometricSizes = NonGeometricSizes {
    compliance: 1.0,
    harmonics: 1.0,
    payload_kg: 0.0,
    backlash: 0.0,
};

/// Noise-free data of a robot with compliance and harmonics: the extended model reproduces
/// held-out positions to 1e-4 mm (the figure), where the geometry alone misses by
/// tenths of a millimetre; the check says so.
#[test]
fn noise_free_compliance_and_harmonics_are_reproduced() {
    for seed in [2025u64, 7] {
        let (r, geometric, extended, truth) = experiment(&BENT, seed, 200, 0.0);
        let worst = extended.iter().copied().fold(0.0, f64::max);
        let check = r.report.beyond_geometry.as_ref().unwrap();
        eprintln!(
            "seed {seed}: held-out RMS geometric {:.2e} mm, extended {:.2e} mm (largest {worst:.2e}); {}",
            rms(&geometric),
            rms(&extended),
            check.sentence()
        );
        assert!(worst < 1e-4, "seed {seed}: {worst}");
        assert!(rms(&geometric) > 100.0 * rms(&extended));
        assert!(check.predicts_better, "{check:?}");
        // The coefficients are the true robot's: the compliance of J2 and J3 (the joints that
        // carry the arm) and every joint's harmonic amplitudes.
        let truth = truth.unwrap();
        for j in [1, 2] {
            let [k, _] = check.compliance_urad_per_nm[j].expect("J2 and J3 carry torque");
            let want = truth.compliance[j] * 1e6;
            assert!((k - want).abs() < 1e-2 * want, "J{}: {k} vs {want}", j + 1);
        }
        for (j, [h1, h2]) in check.harmonic_amplitudes_deg.iter().enumerate() {
            let [a, _, b, _] = truth.harmonics[j];
            assert!(
                (h1 - a.to_degrees()).abs() < 2e-4,
                "J{}: {h1} vs {}",
                j + 1,
                a.to_degrees()
            );
            assert!(
                (h2 - b.to_degrees()).abs() < 2e-4,
                "J{}: {h2} vs {}",
                j + 1,
                b.to_degrees()
            );
        }
    }
}

/// 10 µm noise, 200 poses, four robots: the extended model's held-out RMS on a robot with
/// compliance and harmonics against the geometric model's on a purely geometric robot (the same
/// poses and noise): 1.75, 1.57, 1.42, 1.63× (mean 1.59×, with the terms chosen by Akaike's
/// criterion the same as with every term fitted; a test at 1 % dropped seed 2025's J6 second
/// harmonic, χ² 7.0, and left 2.07×). Four robots scatter: the issue's
/// 1.5× is checked over 24 in `tests/it/simulate_nongeometric.rs`. The geometric model on the
/// bent robot is 23–33× off; on the geometric robot the check finds no gain (the selection keeps
/// 4–6 coefficients there, terms whose `χ²` passes `2d` by chance, and the leave-one-out RMS
/// moves by 1 % or less).
#[test]
fn noisy_compliance_and_harmonics_come_close_to_a_geometric_robot() {
    let mut ratios = Vec::new();
    for seed in [2025u64, 7, 11, 12] {
        let (r0, plain, _, _) = experiment(&NonGeometricSizes::none(), seed, 200, 0.01);
        let (r, geometric, extended, truth) = experiment(&BENT, seed, 200, 0.01);
        let check = r.report.beyond_geometry.as_ref().unwrap();
        let check0 = r0.report.beyond_geometry.as_ref().unwrap();
        eprintln!(
            "seed {seed}: geometric robot {:.4} mm; bent robot: geometric model {:.4} mm, extended {:.4} mm ({:.2}×); check on the geometric robot: {}",
            rms(&plain),
            rms(&geometric),
            rms(&extended),
            rms(&extended) / rms(&plain),
            check0.sentence()
        );
        ratios.push(rms(&extended) / rms(&plain));
        // The compliance of J2 and J3 within 4 of its stated σ of the truth.
        let truth = truth.unwrap();
        for j in [1, 2] {
            let [k, s] = check.compliance_urad_per_nm[j].unwrap();
            let want = truth.compliance[j] * 1e6;
            assert!(
                (k - want).abs() < 4.0 * s,
                "seed {seed}, J{}: {k} ± {s} vs {want}",
                j + 1
            );
        }
        assert!(rms(&geometric) > 10.0 * rms(&extended), "seed {seed}");
        assert!(
            check.predicts_better && !check0.predicts_better,
            "{check:?} {check0:?}"
        );
    }
    let mean = ratios.iter().sum::<f64>() / ratios.len() as f64;
    eprintln!(
        "extended on the bent robot / geometric on the geometric robot: {ratios:?}, mean {mean:.2}"
    );
    assert!(mean < 1.75 && ratios.iter().all(|&r| r < 2.0), "{ratios:?}");
}

/// The explicit check's report on pose `data` measured with 10 µm noise (stated).
fn checked(data: &gpu_amcs::identify::PoseData) -> gpu_amcs::identify::chain::BeyondGeometry {
    let opts = ChainOptions {
        noise: NoiseModel::Isotropic { sigma_mm: 0.01 },
        beyond_geometry: gpu_amcs::identify::JointErrorFit::On,
        compensate: false,
        ..ChainOptions::default()
    };
    let points = crate::common::measured_points(data);
    let r = identify_chain(&points, &tx60(), None, Some(NominalPrior::default()), &opts).unwrap();
    r.report.beyond_geometry.unwrap()
}

/// Poses in which joint 4 never moves: its harmonics are constants (cos1_4, cos2_4 an offset of
/// θ4, sin1_4, sin2_4 nothing), so the report names them as not determined; with all joints
/// moving (the same robot, 200 random poses) it names none of joint 4's.
#[test]
fn the_report_names_what_the_data_cannot_determine() {
    let seed = 2025u64;
    let truth = Experiment::tx60(seed).truth;
    let errors = NonGeometric::draw(&truth, &BENT, seed);
    let placement = random_placement(seed);
    let run = |still: bool| {
        let mut configs = random_poses(&truth, 200, seed + 1);
        if still {
            configs.iter_mut().for_each(|q| q[3] = 0.0);
        }
        let data = simulate_poses_of(
            &truth,
            errors.as_ref(),
            &configs,
            &placement,
            &TrackerNoise::Isotropic(0.01),
            seed + 2,
        );
        checked(&data).undetermined
    };
    let still = run(true);
    eprintln!("joint 4 still: {still:?}");
    for c in ["sin1_4", "cos1_4", "sin2_4", "cos2_4"] {
        assert!(
            still.iter().any(|l| l.starts_with(&format!("{c}:"))),
            "{c}: {still:?}"
        );
    }
    let moving = run(false);
    eprintln!("all moving: {moving:?}");
    assert!(!moving.iter().any(|l| l.contains("_4:")), "{moving:?}");
}

/// Backlash: a robot whose joints stand half a gap from their commanded angles on the side they
/// arrived from (the poses measured in random order, so each joint comes from either side).
/// The explicit check fits a gap per joint from the poses' order, finds it predicts better and
/// recovers the gaps within 4σ; without backlash it finds no gain.
#[test]
fn the_check_finds_backlash_from_the_poses_order() {
    let seed = 2025u64;
    let truth = Experiment::tx60(seed).truth;
    let errors = NonGeometric::draw(&truth, &BENT, seed);
    let placement = random_placement(seed);
    let gaps_deg = [0.05, 0.03, 0.02, 0.01, 0.02, 0.02];
    let run = |gaps: [f64; 6]| {
        let commanded = random_poses(&truth, 300, seed + 1);
        let actual = standing_at(&commanded, &gaps);
        let mut data = simulate_poses_of(
            &truth,
            errors.as_ref(),
            &actual,
            &placement,
            &TrackerNoise::Isotropic(0.01),
            seed + 2,
        );
        for (p, q) in data.runs[0].points.iter_mut().zip(&commanded) {
            p.q_deg = *q;
        }
        checked(&data)
    };
    let with = run(gaps_deg);
    let k = with
        .backlash
        .as_ref()
        .expect("every joint came from both sides");
    eprintln!(
        "with backlash: LOO {:.4} mm against {:.4} mm; gaps {:?}",
        k.loo_rms_mm, with.loo_rms_extended_mm, k.gap_deg
    );
    assert!(k.predicts_better);
    for (j, [g, s]) in k.gap_deg.iter().enumerate().take(5) {
        assert!(
            (g - gaps_deg[j]).abs() < 4.0 * s,
            "J{}: {g} ± {s} vs {}",
            j + 1,
            gaps_deg[j]
        );
    }
    let without = run([0.0; 6]);
    let k0 = without.backlash.unwrap();
    eprintln!(
        "without: LOO {:.4} mm against {:.4} mm",
        k0.loo_rms_mm, without.loo_rms_extended_mm
    );
    assert!(!k0.predicts_better);
}

/// The command line: `identify` with its defaults on `simulate --compliance 1 --harmonics 1`
/// data finds the lack of fit, runs the check and keeps the joint errors, reporting them in its
/// text and JSON (J2's and J3's compliance with σ); `--beyond-geometry=off` gives the geometry
/// alone, without the field. On a geometric robot the default does not check (no lack of fit
/// against the stated noise), a bare `--beyond-geometry` checks and keeps nothing, and `=keep`
/// keeps them all the same.
#[test]
fn the_command_line_reports_the_check() {
    let d = crate::common::tmpdir("beyond-geometry-cli");
    let p = |f: &str| d.join(f).display().to_string();
    let ok = crate::common::run_ok;
    let simulate = |extra: &[&str], out: &str| {
        let mut args = vec!["simulate", "--poses", "150", "--tracker-sigma", "0.01"];
        args.extend_from_slice(extra);
        let out = p(out);
        args.extend_from_slice(&["-o", &out]);
        ok(&args);
    };
    simulate(&["--compliance", "1", "--harmonics", "1"], "cal.csv");
    let text = ok(&[
        "identify",
        &p("cal.csv"),
        "--tracker-sigma",
        "0.01",
        "-o",
        &p("with.toml"),
        "--json",
        &p("with.json"),
    ]);
    assert!(text.contains("Beyond geometry:"), "{text}");
    ok(&[
        "identify",
        &p("cal.csv"),
        "--tracker-sigma",
        "0.01",
        "--beyond-geometry=off",
        "-o",
        &p("without.toml"),
        "--json",
        &p("without.json"),
    ]);
    let json = |f: &str| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(p(f)).unwrap()).unwrap()
    };
    let with = json("with.json");
    let b = &with["identify"]["runs"][0]["chain"]["beyond_geometry"];
    assert_eq!(b["predicts_better"], true, "{b}");
    assert!(
        b["loo_rms_extended_mm"].as_f64().unwrap()
            < 0.5 * b["loo_rms_geometric_mm"].as_f64().unwrap(),
        "{b}"
    );
    for j in [1, 2] {
        let k = &b["compliance_urad_per_nm"][j];
        assert!(
            k[0].as_f64().unwrap() > 0.0 && k[1].as_f64().unwrap() > 0.0,
            "{b}"
        );
    }
    let without = &json("without.json")["identify"]["runs"][0]["chain"];
    assert!(without.get("beyond_geometry").is_none());
    assert_eq!(without["joint_error_fit"], "off");
    // A geometric robot: by default no check (its residuals agree with the stated noise).
    simulate(&[], "geo.csv");
    let identify_geo = |mode: Option<&str>, name: &str| -> (String, serde_json::Value) {
        let (toml, js) = (p(&format!("{name}.toml")), p(&format!("{name}.json")));
        let mut args = vec![
            "identify",
            "--tracker-sigma",
            "0.01",
            "-o",
            &toml,
            "--json",
            &js,
        ];
        let geo = p("geo.csv");
        args.insert(1, &geo);
        if let Some(m) = mode {
            args.push(m);
        }
        let text = ok(&args);
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&js).unwrap()).unwrap();
        let chain = v["identify"]["runs"][0]["chain"].clone();
        (text + &std::fs::read_to_string(&toml).unwrap(), chain)
    };
    let (text, chain) = identify_geo(None, "geo-auto");
    assert_eq!(chain["joint_error_fit"], "auto");
    assert!(chain.get("beyond_geometry").is_none(), "{chain}");
    assert!(text.contains("beyond geometry: not checked"), "{text}");
    assert!(!text.contains("[joint_errors]"));
    let (text, chain) = identify_geo(Some("--beyond-geometry"), "geo-on");
    assert_eq!(chain["joint_error_fit"], "on");
    assert_eq!(
        chain["beyond_geometry"]["predicts_better"], false,
        "{chain}"
    );
    assert_eq!(chain["beyond_geometry"]["kept"], false);
    assert!(!text.contains("[joint_errors]"));
    let (text, chain) = identify_geo(Some("--beyond-geometry=keep"), "geo-keep");
    assert_eq!(chain["beyond_geometry"]["kept"], true, "{chain}");
    assert!(text.contains("[joint_errors]"));
    assert_eq!(b["kept"], true, "{b}");
    // The model carries the joint errors; every analysis draws them, and a payload at the task
    // bends the robot away from its calibrated predictions.
    let with = std::fs::read_to_string(p("with.toml")).unwrap();
    assert!(with.contains("[joint_errors]"), "{with}");
    assert!(!std::fs::read_to_string(p("without.toml"))
        .unwrap()
        .contains("[joint_errors]"));
    let mean = |extra: &[&str]| -> f64 {
        let out = p("w.json");
        let mut args = vec![
            "mcs",
            "--model",
            &p("with.toml"),
            "--points",
            "10",
            "--draws",
            "20000",
            "--backend",
            "cpu",
            "--json",
            &out,
        ]
        .into_iter()
        .map(String::from)
        .collect::<Vec<_>>();
        args.extend(extra.iter().map(|s| s.to_string()));
        let refs: Vec<&str> = args.iter().map(String::as_str).collect();
        crate::common::run_ok(&refs);
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
        v["result"]["estimate"].as_f64().unwrap()
    };
    let (light, heavy) = (mean(&[]), mean(&["--payload-kg", "8"]));
    assert!(
        heavy > 1.5 * light,
        "w: {light} mm without a payload, {heavy} mm with 8 kg"
    );
    // URDF cannot hold them: the export says so.
    let o = crate::common::run(&[
        "export",
        "--model",
        &p("with.toml"),
        "--urdf",
        &p("with.urdf"),
    ]);
    assert!(o.status.success(), "{}", crate::common::stderr(&o));
    assert!(crate::common::stderr(&o).contains("joint errors beyond geometry"));
    // A payload for a model without compliance is refused, naming the flag.
    crate::common::fails_naming(
        &[
            "mcs",
            "--model",
            &p("without.toml"),
            "--points",
            "5",
            "--payload-kg",
            "5",
        ],
        "--payload-kg",
    );
}

/// Several runs give their mean model, which holds no joint errors: an explicit check (`on`,
/// `keep`) runs and is reported per run, and no run's geometry is fitted beside joint errors
/// the mean model would then lack. Before, each run's report said the model carried them
/// ("every analysis draws them") and the mean geometry was that of the extended fits, while the
/// model file held the geometry alone.
#[test]
fn several_runs_check_but_keep_the_geometry() {
    let d = crate::common::tmpdir("beyond-geometry-runs");
    let p = |f: &str| d.join(f).display().to_string();
    let ok = crate::common::run_ok;
    let mut rows = Vec::new();
    for (run, seed) in [("a", "4"), ("b", "5")] {
        let f = p(&format!("{run}.csv"));
        ok(&[
            "simulate",
            "--poses",
            "120",
            "--seed",
            seed,
            "--robot-seed",
            "9",
            "--placement",
            "base",
            "--tracker-sigma",
            "0.01",
            "--compliance",
            "1",
            "--harmonics",
            "1",
            "-o",
            &f,
        ]);
        let text = std::fs::read_to_string(&f).unwrap();
        let mut lines = text.lines();
        let header = lines.next().unwrap();
        if rows.is_empty() {
            rows.push(format!("run,{header}"));
        }
        rows.extend(lines.map(|l| format!("{run},{l}")));
    }
    std::fs::write(p("runs.csv"), rows.join("\n") + "\n").unwrap();
    for mode in [
        "--beyond-geometry=on",
        "--beyond-geometry=keep",
        "--beyond-geometry=check",
    ] {
        let text = ok(&[
            "identify",
            &p("runs.csv"),
            "--tracker-sigma",
            "0.01",
            mode,
            "-o",
            &p("m.toml"),
            "--json",
            &p("m.json"),
        ]);
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(p("m.json")).unwrap()).unwrap();
        let runs = v["identify"]["runs"].as_array().unwrap();
        assert_eq!(runs.len(), 2, "{mode}");
        for r in runs {
            let chain = &r["chain"];
            assert_eq!(chain["joint_error_fit"], "check", "{mode}: {chain}");
            let b = &chain["beyond_geometry"];
            assert_eq!(b["predicts_better"], true, "{mode}: {b}");
            assert_eq!(b["kept"], false, "{mode}: {b}");
        }
        assert!(
            text.contains("identify one run to keep them"),
            "{mode}: {text}"
        );
        assert!(
            !text.contains("every analysis draws them"),
            "{mode}: {text}"
        );
        let model = std::fs::read_to_string(p("m.toml")).unwrap();
        assert!(!model.contains("[joint_errors]"), "{mode}");
    }
}

/// The angles joints with backlash stand at when commanded to `commanded` in that order: half
/// the gap (deg) towards where each came from (none at the first configuration and for a joint
/// that did not move).
pub(crate) fn standing_at(commanded: &[Joints], gaps_deg: &[f64]) -> Vec<Joints> {
    (commanded.iter().enumerate())
        .map(|(k, q)| {
            Joints::from_fn(q.len(), |j| {
                let d = if k == 0 {
                    0.0
                } else {
                    q[j] - commanded[k - 1][j]
                };
                q[j] + 0.5 * gaps_deg[j] * d.signum() * f64::from(d != 0.0)
            })
        })
        .collect()
}
