//! Bad and extreme input: model-file magnitudes, the tool, covariances, CRLF and oversized files,
//! error chains, undefined moments and the tool of the nominal reference.

use crate::common;
use gpu_amcs::engine::{Problem, ProblemError, Reference};
use gpu_amcs::kinematics::{
    param_index, position, tx60, Joints, Layout, ParamKind, Params, RobotModel, Uncertainty,
};

use common::{run, stderr, stdout, tmpdir};
use std::path::{Path, PathBuf};

/// Parameters of the six-joint robots these tests use.
const N_PARAMS: usize = Layout::SIX.n_params();

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A failing run: exit code 2 and one error line that names every string of `what`.
fn fails_naming(args: &[&str], what: &[&str]) -> String {
    let o = run(args);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {e}");
    for w in what {
        assert!(e.contains(w), "{args:?}: error does not name '{w}': {e}");
    }
    assert!(!e.contains("panicked"), "{args:?} panicked: {e}");
    assert_eq!(e.trim().lines().count(), 1, "{args:?}: not one line: {e}");
    e
}

/// The TX60 preset's model file with the first occurrence of `from` replaced by `to`.
fn preset_with(from: &str, to: &str) -> String {
    let good = tx60().to_toml();
    let text = good.replacen(from, to, 1);
    assert_ne!(text, good, "'{from}' is not in the preset's file");
    text
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let f = dir.join(name);
    std::fs::write(&f, text).unwrap();
    f
}

fn json(f: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(f).unwrap()).unwrap()
}

#[test]
fn nominal_reference_measures_the_models_own_target() {
    // Every identified or calibrated model carries the tracker target it was measured with; the
    // preset (the nominal model) has none. The reference must put the same target where the
    // design geometry would: errors of calibration size (the simulated robot's geometric errors
    // are a few tenths of a mm to ~1 mm), not the ~88 mm tool offset.
    let d = tmpdir("nominal");
    let model = d.join("calibrated.toml");
    let o = run(&["calibrate", "--out", s(&model)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let calibrated = RobotModel::from_file(&model).unwrap();
    let tool_norm = calibrated.tool.iter().map(|v| v * v).sum::<f64>().sqrt();
    assert!(
        tool_norm > 50.0,
        "the calibration's target is {tool_norm} mm off the flange"
    );
    let j = d.join("nominal.json");
    let o = run(&[
        "mcs",
        "--draws",
        "2000",
        "--points",
        "10",
        "--backend",
        "cpu",
        "--quiet",
        "--model",
        s(&model),
        "--reference",
        "nominal",
        "--json",
        s(&j),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v = json(&j);
    let w = v["result"]["estimate"].as_f64().unwrap();
    assert!(w < 2.0, "w = {w} mm against the nominal model");
    assert!(w > 0.05, "w = {w} mm: the systematic error is missing");
    let label = v["reference"].as_str().unwrap();
    assert!(
        label.contains("nominal model (Staubli TX60) with the model's tool ["),
        "{label}"
    );

    // The library: at the mean parameters the reference is exactly the model's own target
    // through the nominal joints.
    let mut m = tx60();
    m.tool = [30.0, -20.0, 80.0];
    m.params[param_index(1, ParamKind::A)] += 0.5;
    let q = [[10.0, -20.0, 30.0, 40.0, 50.0, 60.0]];
    let pb = Problem::new(m.clone(), &q, &Reference::Nominal(Box::new(tx60())), 1).unwrap();
    let expected = position(&tx60().params, &m.tool, &q[0].map(f64::to_radians));
    for (r, x) in pb.reference[0].iter().zip(expected) {
        assert!((r - x).abs() < 1e-9);
    }
    let e = pb.point_errors(&m.params)[0];
    assert!(e > 0.1 && e < 0.6, "a2 + 0.5 mm moves the target {e} mm");
    // Same tool: the label is unchanged.
    let mut n = tx60();
    n.tool = m.tool;
    assert_eq!(
        Reference::Nominal(Box::new(n)).label(&m),
        "nominal model (Staubli TX60)"
    );
}

#[test]
fn indefinite_covariance_names_the_model_file_and_field() {
    let d = tmpdir("indefinite");
    let mut m = tx60();
    let s0 = m.param_sigmas();
    let mut c = vec![0.0; N_PARAMS * N_PARAMS];
    for i in 0..N_PARAMS {
        c[i * N_PARAMS + i] = s0[i] * s0[i];
    }
    // Correlation 1.5 between θ1 and d1: symmetric, right diagonal, no Cholesky factor.
    c[1] = 1.5 * s0[0] * s0[1];
    c[N_PARAMS] = c[1];
    m.uncertainty = Uncertainty::from_matrix(gpu_amcs::kinematics::InputSpace::parameters(6), c);
    let f = write(&d, "m.toml", &m.to_toml());
    let pts = write(&d, "p.csv", "q1,q2,q3,q4,q5,q6\n0,0,0,0,0,0\n");
    for extra in [&[][..], &["--points-file", s(&pts)][..]] {
        let mut args = vec!["--backend", "cpu", "--model", s(&f)];
        args.extend_from_slice(extra);
        let e = fails_naming(
            &args,
            &["m.toml", "covariance.matrix", "not positive definite"],
        );
        assert!(!e.contains("test points") && !e.contains("p.csv"), "{e}");
        // The factorisation fails at d1's row (row 2), the first that the correlation breaks.
        assert!(e.contains("row 2 (joint[1].d)"), "{e}");
    }
}

#[test]
fn absurd_magnitudes_are_refused_naming_the_field() {
    let d = tmpdir("magnitudes");
    let sig = "sigma = { theta = 0.003216, d = 0.005056";
    let cases = [
        // σ_d = 1e308 used to end in "draw 0 gave a non-finite maximum point error".
        (
            preset_with(sig, "sigma = { theta = 0.003216, d = 1e308"),
            "joint[1].sigma.d",
        ),
        (
            preset_with(sig, "sigma = { theta = 0.003216, d = 1e100"),
            "joint[1].sigma.d",
        ),
        (
            preset_with(sig, "sigma = { theta = 0.003216, d = 100.5"),
            "joint[1].sigma.d",
        ),
        // An angle's σ of 1e6° wraps sin/cos many times over: not a calibration spread.
        (
            preset_with(sig, "sigma = { theta = 1e6, d = 0.005056"),
            "joint[1].sigma.theta",
        ),
        (
            preset_with(sig, "sigma = { theta = 10.5, d = 0.005056"),
            "joint[1].sigma.theta",
        ),
        // d = 1e300 used to be blamed on --points.
        (preset_with("d = 375.0", "d = 1e300"), "joint[1].d"),
        (
            preset_with("alpha = -90.0", "alpha = 400.0"),
            "joint[1].alpha",
        ),
        (
            preset_with("tool = [0.0, 0.0, 0.0]", "tool = [0.0, 2e5, 0.0]"),
            "tool[1]",
        ),
        (
            preset_with("limits = [-180.0, 180.0]", "limits = [-1e9, 180.0]"),
            "joint[1].limits",
        ),
    ];
    for (i, (text, field)) in cases.iter().enumerate() {
        let f = write(&d, &format!("m{i}.toml"), text);
        let out = d.join(format!("out{i}.json"));
        let e = fails_naming(
            &["--model", s(&f), "--backend", "cpu", "--json", s(&out)],
            &[&format!("m{i}.toml"), field],
        );
        assert!(!e.contains("--points") && !e.contains("draw"), "{e}");
        assert!(!out.exists());
    }
    // The limits themselves are accepted, and give finite results.
    let edge = preset_with(sig, "sigma = { theta = 10.0, d = 100.0")
        .replacen("d = 375.0", "d = 1e5", 1)
        .replacen("alpha = -90.0", "alpha = -360.0", 1);
    let f = write(&d, "edge.toml", &edge);
    let j = d.join("edge.json");
    let o = run(&[
        "mcs",
        "--draws",
        "2000",
        "--points",
        "3",
        "--box-center",
        "0,0,100000",
        "--box-size",
        "1e6,1e6,1e6",
        "--backend",
        "cpu",
        "--quiet",
        "--model",
        s(&f),
        "--json",
        s(&j),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(json(&j)["result"]["estimate"].as_f64().unwrap().is_finite());
    // A model built in code is held to the same rules.
    let mut m = tx60();
    let mut sg = m.param_sigmas();
    sg[param_index(0, ParamKind::D)] = 1e100;
    m.uncertainty = Uncertainty::Independent(sg);
    let q = [[0.0; 6]];
    match Problem::new(m, &q, &Reference::Calibrated, 1) {
        Err(e @ ProblemError::Model { .. }) => {
            assert!(e.to_string().contains("joint[1].sigma.d"), "{e}")
        }
        other => panic!("σ_d = 1e100 accepted: {:?}", other.map(|_| ())),
    }
}

#[test]
fn limits_need_exactly_two_values() {
    let d = tmpdir("limits");
    for (limits, found) in [("[-180.0, 180.0, 5.0]", 3), ("[-180.0]", 1)] {
        let text = preset_with("limits = [-180.0, 180.0]", &format!("limits = {limits}"));
        let f = write(&d, "m.toml", &text);
        fails_naming(
            &["--model", s(&f), "--backend", "cpu"],
            &[
                "m.toml",
                "joint[1].limits",
                &format!("exactly 2 numbers [min, max] (deg), found {found}"),
            ],
        );
    }
}

#[test]
fn tool_needs_exactly_three_values() {
    let d = tmpdir("tool");
    for (tool, ok) in [
        ("[0.0, 0.0, 0.0, 1.0]", false),
        ("[0.0, 0.0]", false),
        ("[]", false),
        ("[1.0, 2.0, 3.0]", true),
    ] {
        let text = preset_with("tool = [0.0, 0.0, 0.0]", &format!("tool = {tool}"));
        let f = write(&d, "m.toml", &text);
        let r = RobotModel::from_file(&f);
        if ok {
            assert_eq!(r.unwrap().tool, [1.0, 2.0, 3.0]);
        } else {
            let e = fails_naming(&["--model", s(&f), "--backend", "cpu"], &["m.toml", "tool"]);
            assert!(e.contains("exactly 3"), "{e}");
        }
    }
}

#[test]
fn crlf_files_give_the_line_an_editor_shows() {
    let d = tmpdir("crlf");
    let bad = "q1,q2,q3,q4,q5,q6\r\n0,0,0,0,0,0\r\n0,0,0,0,0,0\r\n0,0,x,0,0,0\r\n";
    let f = write(&d, "p.csv", bad);
    fails_naming(
        &["--points-file", s(&f), "--backend", "cpu"],
        &["p.csv", "line 4", "q3"],
    );
    fails_naming(&["fk", "--points-file", s(&f)], &["p.csv", "line 4"]);
    let short = "q1,q2,q3,q4,q5,q6\r\n0,0,0,0,0,0\r\n0,0,0,0,0\r\n";
    let f = write(&d, "short.csv", short);
    fails_naming(&["fk", "--points-file", s(&f)], &["short.csv", "line 3"]);
    // Sweeps and measurements too: line 3 of a CRLF file is line 3.
    let sweeps = "joint,q1,q2,q3,q4,q5,q6,x,y,z\r\n1,0,0,0,0,0,0,1,2,3\r\n1,2,0,0,0,0,0,1,2,zz\r\n";
    let f = write(&d, "sweeps.csv", sweeps);
    fails_naming(&["identify", s(&f)], &["sweeps.csv", "line 3", "column z"]);
    let measured = "q1,q2,q3,q4,q5,q6,x,y,z\r\n0,0,0,0,0,0,1,2,3\r\n0,0,0,0,0,0,1,2,zz\r\n";
    let f = write(&d, "measured.csv", measured);
    let model = write(&d, "m.toml", &tx60().to_toml());
    fails_naming(
        &["validate", "--model", s(&model), s(&f)],
        &["measured.csv", "line 3", "column z"],
    );
    // A good CRLF file reads the same as with LF, also with a spreadsheet's byte-order mark.
    let good = "\u{feff}q1,q2,q3,q4,q5,q6\r\n10,20,30,40,50,60\r\n";
    let f = write(&d, "good.csv", good);
    assert_eq!(
        gpu_amcs::points::read_csv(&f, 6).unwrap(),
        vec![Joints::from([10.0, 20.0, 30.0, 40.0, 50.0, 60.0])]
    );
}

/// Every error in the chain says something its cause does not already say.
fn assert_each_cause_once(e: &(dyn std::error::Error + 'static)) {
    let mut cur = Some(e);
    while let Some(x) = cur {
        if let Some(src) = x.source() {
            let (outer, inner) = (x.to_string(), src.to_string());
            assert!(
                !outer.contains(&inner),
                "'{outer}' repeats its source '{inner}'"
            );
        }
        cur = x.source();
    }
}

#[test]
fn each_cause_is_printed_once() {
    let d = tmpdir("causes");
    let missing = d.join("missing.toml");
    let e = fails_naming(
        &["--model", s(&missing), "--backend", "cpu"],
        &["missing.toml"],
    );
    assert_eq!(e.matches("os error").count(), 1, "{e}");
    let e = fails_naming(
        &["--points-file", s(&missing), "--backend", "cpu"],
        &["missing.toml"],
    );
    assert_eq!(e.matches("os error").count(), 1, "{e}");
    let f = d.join("latin1.toml");
    std::fs::write(&f, b"name = \"x\"\n# caf\xe9\n").unwrap();
    let e = fails_naming(
        &["--model", s(&f), "--backend", "cpu"],
        &["latin1.toml", "line 2"],
    );
    assert_eq!(e.matches("UTF-8").count(), 1, "{e}");
    let e = fails_naming(&["--points-file", s(&f), "--backend", "cpu"], &["line 2"]);
    assert_eq!(e.matches("UTF-8").count(), 1, "{e}");

    assert_each_cause_once(&RobotModel::from_file(&missing).unwrap_err());
    assert_each_cause_once(&gpu_amcs::points::read_csv(&missing, 6).unwrap_err());
    assert_each_cause_once(&RobotModel::from_file(&f).unwrap_err());
    let identify = gpu_amcs::simulate::SimulateError::Identify {
        run: 3,
        cause: gpu_amcs::identify::IdentifyError::Empty {
            origin: "sweeps.csv".into(),
        },
    };
    assert_each_cause_once(&identify);
}

#[test]
fn oversized_inputs_are_refused_naming_the_limit() {
    let e = fails_naming(
        &["--model", "/dev/zero", "--backend", "cpu"],
        &["/dev/zero", "1 MiB"],
    );
    assert!(e.contains("model file"), "{e}");
    fails_naming(
        &["--points-file", "/dev/zero", "--backend", "cpu"],
        &["/dev/zero", "128 MiB"],
    );
    fails_naming(&["identify", "/dev/zero"], &["/dev/zero", "128 MiB"]);
    // A model file of comments past the limit is refused as well; one under it is read.
    let d = tmpdir("big");
    let model = tx60().to_toml();
    let pad = |n: usize| format!("{model}{}", "# padding padding padding padding\n".repeat(n));
    let small = write(&d, "small.toml", &pad(1000));
    assert!(RobotModel::from_file(&small).is_ok());
    let big = write(&d, "big.toml", &pad(40_000));
    assert!(std::fs::metadata(&big).unwrap().len() > 1 << 20);
    fails_naming(
        &["--model", s(&big), "--backend", "cpu"],
        &["big.toml", "1 MiB"],
    );
    // A mistyped count of test points is an error, not an allocation of terabytes.
    fails_naming(
        &["--points", "100000000000", "--backend", "cpu"],
        &["at most 1000000", "100000000000"],
    );
    let rows = gpu_amcs::points::MAX_POINTS + 1;
    let csv = write(
        &d,
        "many.csv",
        &format!("q1,q2,q3,q4,q5,q6\n{}", "0,0,0,0,0,0\n".repeat(rows)),
    );
    fails_naming(
        &["fk", "--points-file", s(&csv)],
        &[
            "many.csv",
            &format!("line {}", rows + 1),
            "more than 1000000",
        ],
    );
}

/// A preset whose every σ is 0: every draw is the mean.
fn zero_spread(dir: &Path) -> PathBuf {
    let mut m = tx60();
    m.uncertainty = Uncertainty::Independent(Params::filled(N_PARAMS, 0.0));
    write(dir, "zero.toml", &m.to_toml())
}

#[test]
fn undefined_moments_are_reported_as_undefined_on_every_backend() {
    let d = tmpdir("zero");
    let f = zero_spread(&d);
    let mut seen = Vec::new();
    for backend in ["cpu", "gpu"] {
        let j = d.join(format!("{backend}.json"));
        let o = run(&[
            "--model",
            s(&f),
            "--points",
            "10",
            "--backend",
            backend,
            "--json",
            s(&j),
            "--csv",
            s(&d.join(backend)),
        ]);
        if backend == "gpu" && !o.status.success() {
            eprintln!("no GPU adapter, GPU half skipped: {}", stderr(&o));
            continue;
        }
        assert!(o.status.success(), "{backend}: {}", stderr(&o));
        let text = stdout(&o);
        assert!(!text.contains("NaN"), "{backend}: {text}");
        assert!(
            text.contains("M3 skewness            n/a"),
            "{backend}: {text}"
        );
        assert!(
            text.contains("M4 kurtosis            n/a"),
            "{backend}: {text}"
        );
        let v = json(&j);
        let m = &v["result"]["moments"];
        assert!(
            m["skewness"].is_null() && m["kurtosis"].is_null(),
            "{backend}: {m}"
        );
        assert_eq!(m["variance"], 0.0, "{backend}");
        let se = &v["result"]["moment_standard_errors"];
        assert!(se[2].is_null() && se[3].is_null(), "{backend}: {se}");
        // A point mass has no density: the PDF file has its header and no rows (it used to have
        // one bin of 4.5e307 per mm).
        let pdf = std::fs::read_to_string(d.join(backend).join("pdf.csv")).unwrap();
        assert_eq!(pdf, "w_mm,density_per_mm\n", "{backend}");
        seen.push(backend);
    }
    assert!(seen.contains(&"cpu"));
    // The comparison skips undefined moments in the MRE: M1 and M2 agree exactly.
    let j = d.join("compare.json");
    let o = run(&[
        "compare",
        "--model",
        s(&f),
        "--points",
        "5",
        "--draws",
        "20000",
        "--backend",
        "cpu",
        "--quiet",
        "--json",
        s(&j),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(!text.contains("NaN") && text.contains("n/a"), "{text}");
    for a in json(&j)["amcs"].as_array().unwrap() {
        assert_eq!(a[2], 0.0, "MRE {a}");
    }
}

/// Every command on every robot: for each preset other than the TX60, `calibrate --preset`
/// gives a model with σ (tool included); `points`, `fk`, `amcs`, `mcs`, `sensitivity`, `tail`,
/// `export` run on it; `simulate --preset` writes sweeps that `identify --nominal` reads back;
/// `plan --preset` plans with its default target. Each must succeed with finite numbers; small
/// settings keep it fast (CPU backend).
#[test]
fn every_command_runs_on_every_preset() {
    let dir = tmpdir("every-preset");
    let ok = |args: &[&str]| -> String {
        let o = run(args);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
        let out = stdout(&o);
        assert!(
            !out.contains("NaN") && !out.contains("inf"),
            "{args:?}: {out}"
        );
        out
    };
    for preset in ["ur5e", "ur10e", "irb2400", "kr6r700sixx", "iiwa14", "panda"] {
        let p = |name: &str| dir.join(format!("{preset}-{name}"));
        let model = p("model.toml");
        let m = model.to_str().unwrap();
        let cal = ok(&[
            "calibrate",
            "--preset",
            preset,
            "--runs",
            "3",
            "--step",
            "10",
            "-o",
            m,
        ]);
        assert!(cal.contains("wrote"), "{preset}: {cal}");
        let text = std::fs::read_to_string(&model).unwrap();
        assert!(
            text.contains("tool_sigma"),
            "{preset}: the tool's spread is estimated"
        );
        // The KR 6's base transform carries over to the calibrated model.
        assert_eq!(
            text.contains("base = {"),
            preset == "kr6r700sixx",
            "{preset}"
        );
        let pts = ok(&["points", "5", "--model", m]);
        assert_eq!(pts.lines().count(), 6, "{preset}: {pts}");
        let q = p("q.csv");
        std::fs::write(&q, &pts).unwrap();
        let fk = ok(&["fk", "--model", m, "--points-file", q.to_str().unwrap()]);
        assert_eq!(fk.lines().count(), 6, "{preset}: {fk}");
        let common = ["--model", m, "--points", "10", "--backend", "cpu"];
        let amcs = ok(&[&["amcs", "--delta", "0.05"][..], &common].concat());
        assert!(amcs.contains("draws"), "{preset}: {amcs}");
        ok(&[&["mcs", "--draws", "20000"][..], &common].concat());
        let sens = ok(&[
            &["sensitivity", "--draws", "256", "--bootstrap", "100"][..],
            &common,
        ]
        .concat());
        assert!(
            sens.contains("tool"),
            "{preset}: tool inputs ranked: {sens}"
        );
        ok(&[
            &["tail", "--threshold", "0.5", "--samples-per-level", "500"][..],
            &common,
        ]
        .concat());
        let urdf = p("out.urdf");
        ok(&["export", "--model", m, "--urdf", urdf.to_str().unwrap()]);
        let sweeps = p("sweeps.csv");
        ok(&[
            "simulate",
            "--preset",
            preset,
            "--runs",
            "2",
            "--step",
            "10",
            "-o",
            sweeps.to_str().unwrap(),
        ]);
        let nominal = p("nominal.toml");
        std::fs::write(&nominal, ok(&["model", "--preset", preset])).unwrap();
        let id = p("identified.toml");
        ok(&[
            "identify",
            sweeps.to_str().unwrap(),
            "--nominal",
            nominal.to_str().unwrap(),
            "-o",
            id.to_str().unwrap(),
        ]);
        assert!(
            std::fs::read_to_string(&id).unwrap().contains("tool_sigma"),
            "{preset}"
        );
        // plan with its default target: the preset's tool0 is a rounding error off the flange
        // axis, which would hide joint 5, so the off-axis default is taken.
        let design = p("design.csv");
        ok(&[
            "plan",
            "--preset",
            preset,
            "--poses",
            "20",
            "--candidates",
            "400",
            "--draws",
            "20000",
            "--tracker-sigma",
            "0.01",
            "--backend",
            "cpu",
            "--out",
            design.to_str().unwrap(),
        ]);
        assert_eq!(
            std::fs::read_to_string(&design).unwrap().lines().count(),
            21,
            "{preset}"
        );
    }
}
