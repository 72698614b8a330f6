//! Issue 35 (hardening, round 3), items 5, 7, 9, 12 and 13: silent wrong answers and errors
//! that named the wrong thing. Each refusal is one line naming the flag (and the file and line
//! where there is one), exit 2, and nothing written; where a right answer exists, it is given.

use crate::common::{assert_fails_naming, run, stderr, stdout, tmpdir, tree};
use std::path::{Path, PathBuf};

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Runs `args` and asserts success, returning stdout.
fn ok(args: &[&str]) -> String {
    let o = run(args);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    stdout(&o)
}

/// The ISO 9283 poses of `model` (a model file, or the TX60 preset), each repeated `cycles`
/// times, measured `--tracker-sigma 0.005` in the base frame on `truth`: the cycles file.
pub(crate) fn iso_cycles(dir: &Path, model: Option<&Path>, truth: &Path, cycles: usize) -> PathBuf {
    let iso = dir.join("iso.csv");
    let mut args = vec!["points", "--iso9283", "-o", s(&iso)];
    if let Some(m) = model {
        args.extend(["--model", s(m)]);
    }
    ok(&args);
    let text = std::fs::read_to_string(&iso).unwrap();
    let mut lines = text.lines();
    let mut rep = format!("{}\n", lines.next().unwrap());
    let rows: Vec<&str> = lines.collect();
    for _ in 0..cycles {
        for r in &rows {
            rep += &format!("{r}\n");
        }
    }
    let rep_path = dir.join("repeated.csv");
    std::fs::write(&rep_path, rep).unwrap();
    let out = dir.join("cycles.csv");
    let n = (rows.len() * cycles).to_string();
    let mut args = vec![
        "simulate",
        "--poses",
        &n,
        "--points-file",
        s(&rep_path),
        "--truth",
        s(truth),
        "--placement",
        "base",
        "--tracker-sigma",
        "0.005",
        "-o",
        s(&out),
    ];
    if let Some(m) = model {
        args.extend(["--model", s(m)]);
    }
    ok(&args);
    out
}

/// The true robot of 60 simulated poses (seed 3, base frame) and the model identified from
/// them with `--base-known`, written into `dir`: `(truth.toml, model.toml)`.
pub(crate) fn identified_model(dir: &Path) -> (PathBuf, PathBuf) {
    let cal = dir.join("cal.csv");
    let truth = dir.join("truth.toml");
    let model = dir.join("model.toml");
    ok(&[
        "simulate",
        "--poses",
        "60",
        "--seed",
        "3",
        "--placement",
        "base",
        "-o",
        s(&cal),
        "--truth-out",
        s(&truth),
    ]);
    ok(&["identify", s(&cal), "-o", s(&model), "-q", "--base-known"]);
    (truth, model)
}

/// Item 5: the certificate is refused when the cycles contradict the model (positions in
/// metres: AP of hundreds of mm was certified Pr[AP ≤ 0.05 mm] = 1) or when the model carries
/// no uncertainty (certified 1 with no note); consistent cycles are still certified.
#[test]
fn the_iso9283_certificate_refuses_cycles_the_model_cannot_explain() {
    let dir = tmpdir("r3-iso-certificate");
    let (truth, model) = identified_model(&dir);
    let cycles = iso_cycles(&dir, None, &truth, 30);
    // Consistent cycles: the certificate.
    let out = ok(&[
        "validate",
        "--model",
        s(&model),
        s(&cycles),
        "--iso9283",
        "--spec",
        "0.05",
        "--draws",
        "20000",
    ]);
    assert!(out.contains("certificate: Pr[AP ≤ 0.05 mm]"), "{out}");
    // The same cycles in metres.
    let text = std::fs::read_to_string(&cycles).unwrap();
    let mut metres = String::new();
    for (k, l) in text.lines().enumerate() {
        if k == 0 {
            metres += &format!("{l}\n");
            continue;
        }
        let v: Vec<&str> = l.split(',').collect();
        let (q, p) = v.split_at(6);
        let p: Vec<String> = p
            .iter()
            .map(|x| format!("{}", x.parse::<f64>().unwrap() / 1000.0))
            .collect();
        metres += &format!("{},{}\n", q.join(","), p.join(","));
    }
    let in_metres = dir.join("cycles-m.csv");
    std::fs::write(&in_metres, metres).unwrap();
    let json = dir.join("iso.json");
    let before = tree(&dir);
    let o = run(&[
        "validate",
        "--model",
        s(&model),
        s(&in_metres),
        "--iso9283",
        "--spec",
        "0.05",
        "--draws",
        "20000",
        "--json",
        s(&json),
    ]);
    for want in ["--spec", s(&in_metres), "P1", "line 2", "AP", "metres"] {
        assert_fails_naming(&o, want, "cycles in metres");
    }
    assert_eq!(tree(&dir), before, "a refused certificate wrote files");
    // A preset without uncertainty.
    let ur5e = dir.join("ur5e.toml");
    std::fs::write(&ur5e, ok(&["model", "--preset", "ur5e"])).unwrap();
    let ur_dir = dir.join("ur");
    std::fs::create_dir_all(&ur_dir).unwrap();
    let ur_cycles = iso_cycles(&ur_dir, Some(&ur5e), &ur5e, 10);
    let o = run(&[
        "validate",
        "--model",
        s(&ur5e),
        s(&ur_cycles),
        "--iso9283",
        "--spec",
        "0.05",
    ]);
    for want in ["--spec", s(&ur5e), "no uncertainty"] {
        assert_fails_naming(&o, want, "σ = 0");
    }
    // Its figures alone are still given.
    ok(&["validate", "--model", s(&ur5e), s(&ur_cycles), "--iso9283"]);
}

/// The x, y, z of `fk`'s output rows.
fn fk_positions(args: &[&str]) -> Vec<[f64; 3]> {
    let mut a = vec!["fk"];
    a.extend(args);
    ok(&a)
        .lines()
        .skip(1)
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            let n = v.len();
            [v[n - 3], v[n - 2], v[n - 1]]
        })
        .collect()
}

/// The positions `points --iso9283` prints for P1 … P5, mm.
fn printed_poses(err: &str) -> Vec<[f64; 3]> {
    err.lines()
        .filter(|l| l.trim_start().starts_with('P'))
        .map(|l| {
            let inner = &l[l.find('(').unwrap() + 1..l.find(')').unwrap()];
            let v: Vec<f64> = inner
                .split(',')
                .map(|x| x.trim().parse().unwrap())
                .collect();
            [v[0], v[1], v[2]]
        })
        .collect()
}

/// Item 9: the ISO 9283 cube of a robot whose base transform turns its chain (the KR 6,
/// base Rx(180°)) is printed in the frame `fk` reports in, where the written poses are: the
/// centre used to be printed at z = −827 mm with fk giving +827 and the opposite y. The TX60
/// (no base transform) prints what it printed.
#[test]
fn the_iso9283_cube_is_printed_in_the_frame_fk_reports() {
    let dir = tmpdir("r3-iso-frame");
    for preset in ["kr6r700sixx", "tx60"] {
        let poses = dir.join(format!("{preset}.csv"));
        let o = run(&["points", "--iso9283", "--preset", preset, "-o", s(&poses)]);
        assert!(o.status.success(), "{}", stderr(&o));
        let printed = printed_poses(&stderr(&o));
        assert_eq!(printed.len(), 5, "{}", stderr(&o));
        let fk = fk_positions(&["--preset", preset, "--points-file", s(&poses)]);
        for (p, f) in printed.iter().zip(&fk) {
            assert!(
                (0..3).all(|k| (p[k] - f[k]).abs() < 0.06),
                "{preset}: printed {p:?}, fk {f:?}"
            );
        }
        let e = stderr(&o);
        let frame = if preset == "tx60" {
            "base frame"
        } else {
            "world frame"
        };
        assert!(e.contains(frame), "{e}");
    }
}

/// Item 12: a pilot run too small for the subset estimator (one Markov chain per level: γ = −1,
/// CoV NaN, "target CoV reached"; two or five: P_f = 0) is refused naming the flag and the
/// smallest size that works; that size runs and reaches the target.
#[test]
fn tail_refuses_too_few_samples_per_level() {
    let dir = tmpdir("r3-tail-n");
    let json = dir.join("t.json");
    for n in ["10", "20", "50"] {
        let o = run(&[
            "tail",
            "--samples-per-level",
            n,
            "--threshold",
            "0.5",
            "--backend",
            "cpu",
            "--json",
            s(&json),
        ]);
        for want in ["--samples-per-level", "N ≥ 100"] {
            assert_fails_naming(&o, want, n);
        }
        assert!(tree(&dir).is_empty(), "{n}: {:?}", tree(&dir));
    }
    let out = ok(&[
        "tail",
        "--samples-per-level",
        "100",
        "--threshold",
        "0.5",
        "--backend",
        "cpu",
    ]);
    assert!(
        out.contains("target CoV reached") && !out.contains("NaN"),
        "{out}"
    );
}

/// Item 7 (points): flags that did nothing are refused in one line: a workspace box with
/// --iso9283 (the cube is placed by its own search), --iso-rpy or --position-only without it.
#[test]
fn points_refuses_flags_it_would_ignore() {
    for (args, flag) in [
        (
            &["points", "--iso9283", "--box-center", "100,0,100"][..],
            "--box-center",
        ),
        (
            &["points", "--iso9283", "--box-size", "100,100,100"],
            "--box-size",
        ),
        (&["points", "3", "--iso-rpy", "0,0,0"], "--iso-rpy"),
        (&["points", "3", "--position-only"], "--position-only"),
        (&["points", "--iso-rpy", "0,0,0"], "--iso"),
    ] {
        assert_fails_naming(&run(args), flag, &format!("{args:?}"));
    }
}

/// Items 7 and 13 (plan): flags plan ignored (--reference, --nominal, --frame: the same R for
/// all) are refused; a tracker σ outside identify's 1e-9 … 1000 mm blamed `tool_sigma[0]`
/// (1e300) or ran (1e-300); a target 1 km off the flange blamed --candidates. Each is one line
/// naming the flag, exit 2, no design written.
#[test]
fn plan_refuses_what_it_ignored_and_names_the_right_flag() {
    let dir = tmpdir("r3-plan");
    let out = dir.join("design.csv");
    let nominal = dir.join("ur5e.toml");
    std::fs::write(&nominal, ok(&["model", "--preset", "ur5e"])).unwrap();
    let before = tree(&dir);
    for (extra, flag, also) in [
        (vec!["--reference", "nominal"], "--reference", "calibrated"),
        (vec!["--nominal", s(&nominal)], "--nominal", "--model"),
        (vec!["--frame", "base"], "--frame", "measurement"),
        (vec!["--tracker-sigma", "1e300"], "--tracker-sigma", "1e-9"),
        (
            vec!["--tracker-sigma", "1e-300"],
            "--tracker-sigma",
            "1000 mm",
        ),
        (vec!["--target", "1e6,0,0"], "--target", "flange"),
    ] {
        let mut args = vec![
            "plan",
            "--out",
            s(&out),
            "-q",
            "--draws",
            "1000",
            "--candidates",
            "300",
        ];
        args.extend(extra.iter().copied());
        let o = run(&args);
        let label = format!("{extra:?}");
        assert_fails_naming(&o, flag, &label);
        assert_fails_naming(&o, also, &label);
        assert!(!stderr(&o).contains("tool_sigma") && !stderr(&o).contains("--candidates"));
        assert_eq!(tree(&dir), before, "{label} wrote a file");
    }
}

/// Item 7 (simulate): --runs, --step and the other sweep settings did nothing with --poses, and
/// --poses 10 with a 20-row --points-file wrote 20 poses; both are refused, the matching count
/// runs.
#[test]
fn simulate_poses_refuses_sweep_settings_and_a_count_the_file_does_not_hold() {
    let dir = tmpdir("r3-simulate");
    let out = dir.join("data.csv");
    for (flag, value) in [
        ("--runs", "3"),
        ("--step", "5"),
        ("--range", "20"),
        ("--speed", "50"),
        ("--start", "pos-to-neg"),
    ] {
        let o = run(&["simulate", "--poses", "10", flag, value, "-o", s(&out)]);
        assert_fails_naming(&o, flag, flag);
        assert_fails_naming(&o, "--poses", flag);
    }
    let configs = dir.join("q.csv");
    ok(&["points", "20", "-o", s(&configs)]);
    let before = tree(&dir);
    let o = run(&[
        "simulate",
        "--poses",
        "10",
        "--points-file",
        s(&configs),
        "-o",
        s(&out),
    ]);
    for want in ["--poses", s(&configs), "20 configurations", "--poses 20"] {
        assert_fails_naming(&o, want, "10 of 20");
    }
    assert_eq!(tree(&dir), before);
    ok(&[
        "simulate",
        "--poses",
        "20",
        "--points-file",
        s(&configs),
        "-o",
        s(&out),
    ]);
    assert_eq!(std::fs::read_to_string(&out).unwrap().lines().count(), 21);
}

/// Item 13: calibrate's sweeps too short for their circle fit named no flag; two held joints
/// that leave two others about one axis blamed only the geometry; shards of another --frame
/// named only the field `model_hash`.
#[test]
fn errors_name_the_flag_that_causes_them() {
    let dir = tmpdir("r3-names");
    for (range, step) in [("1", "10"), ("1", "0.5")] {
        let o = run(&["calibrate", "--range", range, "--runs", "2", "--step", step]);
        for want in ["--range", "--step", "joint 1"] {
            assert_fails_naming(&o, want, &format!("--range {range} --step {step}"));
        }
    }
    // The LBR iiwa's DH table: joints 2 and 4 held at 0° leave joints 1 and 3 on one axis.
    let mut table = String::from(
        "convention,standard\nunits,mm-deg\nname,LBR iiwa 14 R820\ntheta,d,a,alpha,lower,upper\n",
    );
    for (d, alpha, l) in [
        (360, -90, 170),
        (0, 90, 120),
        (420, 90, 170),
        (0, -90, 120),
        (400, -90, 170),
        (0, 90, 120),
        (126, 0, 175),
    ] {
        table += &format!("0,{d},0,{alpha},-{l},{l}\n");
    }
    let iiwa = dir.join("iiwa.csv");
    std::fs::write(&iiwa, table).unwrap();
    let out = dir.join("held.toml");
    let o = run(&[
        "import",
        s(&iiwa),
        "-o",
        s(&out),
        "--hold-joint",
        "2=0",
        "--hold-joint",
        "4=0",
    ]);
    for want in ["--hold-joint 2=0, 4=0", "joint 1", "hold other joints"] {
        assert_fails_naming(&o, want, "two holds");
    }
    assert!(!out.exists());
    ok(&["import", s(&iiwa), "-o", s(&out), "--hold-joint", "3=0"]);
    // Shards of one identified model, in two frames.
    let data = dir.join("poses.csv");
    let model = dir.join("model.toml");
    ok(&["simulate", "--poses", "40", "--seed", "3", "-o", s(&data)]);
    ok(&["identify", s(&data), "-o", s(&model), "-q"]);
    let shard = |k: &str, frame: &str, name: &str| -> PathBuf {
        let p = dir.join(name);
        ok(&[
            "mcs",
            "--model",
            s(&model),
            "--draws",
            "4000",
            "--points",
            "5",
            "--backend",
            "cpu",
            "--shard",
            k,
            "--summary-out",
            s(&p),
            "--frame",
            frame,
            "-q",
        ]);
        p
    };
    let (a, b) = (
        shard("0/2", "base", "a.json"),
        shard("1/2", "measurement", "b.json"),
    );
    let o = run(&["merge", s(&a), s(&b)]);
    for want in ["--frame", s(&b), s(&a), "model as drawn"] {
        assert_fails_naming(&o, want, "frames");
    }
}

/// A six-joint arm as a xacro package: `top.xacro` includes `macro.xacro` (the macro) and
/// calls it. Returns the top file.
fn xacro_package(dir: &Path) -> PathBuf {
    let urdf = dir.join("pkg_b").join("urdf");
    std::fs::create_dir_all(&urdf).unwrap();
    let joint = |k: usize, xyz: &str, axis: &str| {
        format!(
            r#"<joint name="j{k}" type="revolute"><origin xyz="{xyz}" rpy="0 0 0"/><parent link="l{}"/><child link="l{k}"/><axis xyz="{axis}"/><limit lower="-3" upper="3" effort="0" velocity="1"/></joint>"#,
            k - 1
        )
    };
    let mut body = (0..=6)
        .map(|k| format!("<link name=\"l{k}\"/>"))
        .collect::<String>();
    for (k, xyz, axis) in [
        (1, "0 0 0.4", "0 0 1"),
        (2, "0.15 0 0", "0 1 0"),
        (3, "0 0 0.6", "0 1 0"),
        (4, "0 0 0.2", "1 0 0"),
        (5, "0.6 0 0", "0 1 0"),
        (6, "0.1 0 0", "1 0 0"),
    ] {
        body += &joint(k, xyz, axis);
    }
    let ns = "xmlns:xacro=\"http://www.ros.org/wiki/xacro\"";
    std::fs::write(
        urdf.join("macro.xacro"),
        format!("<robot {ns}><xacro:macro name=\"arm\" params=\"\">{body}</xacro:macro></robot>\n"),
    )
    .unwrap();
    let top = urdf.join("top.xacro");
    std::fs::write(
        &top,
        format!("<robot {ns} name=\"b\"><xacro:include filename=\"macro.xacro\"/><xacro:arm/></robot>\n"),
    )
    .unwrap();
    top
}

/// Item 8: `import top.xacro -o macro.xacro` (a file the xacro includes) overwrote the macro
/// with TOML and exited 0. Now any file the expansion read is refused as the output, however
/// the path is spelled: one line naming --out and the file, exit 2, nothing written.
#[test]
fn import_refuses_to_overwrite_a_file_the_xacro_included() {
    let dir = tmpdir("r3-xacro-overwrite");
    let top = xacro_package(&dir);
    let urdf = top.parent().unwrap();
    let macro_before = std::fs::read(urdf.join("macro.xacro")).unwrap();
    let spelled = urdf.join("..").join("urdf").join("macro.xacro");
    for out in [urdf.join("macro.xacro"), spelled, top.clone()] {
        let before = tree(&dir);
        let o = run(&["import", s(&top), "-o", s(&out)]);
        assert_fails_naming(&o, "--out", &format!("{out:?}"));
        assert!(
            stderr(&o).contains("macro.xacro") || out == top,
            "{}",
            stderr(&o)
        );
        assert_eq!(tree(&dir), before, "{out:?}");
        assert_eq!(
            std::fs::read(urdf.join("macro.xacro")).unwrap(),
            macro_before
        );
    }
    // Through a symbolic link to the included file, too.
    #[cfg(unix)]
    {
        let link = dir.join("link.xacro");
        std::os::unix::fs::symlink(urdf.join("macro.xacro"), &link).unwrap();
        let o = run(&["import", s(&top), "-o", s(&link)]);
        assert_fails_naming(&o, "--out", "symlink");
        assert_eq!(
            std::fs::read(urdf.join("macro.xacro")).unwrap(),
            macro_before
        );
    }
    // Any other path is written.
    let model = dir.join("b.toml");
    ok(&["import", s(&top), "-o", s(&model)]);
    assert!(std::fs::read_to_string(&model)
        .unwrap()
        .starts_with("# Imported by"));
}

/// Item 11: `mcs --draws x 2>/dev/full` panicked (exit 101) printing its usage error. With
/// stderr or stdout full or closed, a usage error still exits 2, a failed run 2, and a run that
/// succeeds 0 (its notes on stderr are lost, nothing else); never a panic.
#[cfg(target_os = "linux")]
#[test]
fn a_full_or_closed_stderr_or_stdout_never_panics() {
    let dir = tmpdir("r3-full-stderr");
    let top = xacro_package(&dir);
    let model = dir.join("m.toml");
    let cases: &[(&str, i32)] = &[
        ("$BIN mcs --draws x 2>/dev/full", 2),
        ("$BIN mcs --draws x 2>&-", 2),
        ("$BIN mcs --draws x >/dev/full 2>/dev/full", 2),
        ("$BIN mcs --model nowhere.toml 2>/dev/full", 2),
        ("$BIN fk --joints 0,0,0,0,0,0 >/dev/full 2>/dev/full", 2),
        ("$BIN fk --joints 0,0,0,0,0,0 >/dev/full 2>&-", 2),
        ("$BIN fk --joints 0,0,0,0,0,0 >&- 2>&-", 2),
        ("$BIN --help >/dev/full 2>/dev/full", 0),
        ("$BIN --version >&- 2>&-", 0),
    ];
    let import = format!(
        "$BIN import '{}' -o '{}' >/dev/null 2>/dev/full",
        s(&top),
        s(&model)
    );
    for (script, want) in cases
        .iter()
        .map(|(c, w)| (c.to_string(), *w))
        .chain([(import, 0)])
    {
        let o = crate::common::sh(&dir, &script);
        assert_eq!(o.status.code(), Some(want), "{script}: {:?}", o.status);
    }
    assert!(model.exists());
}

/// Item 13 (signals): a signal that arrived once every report was in place exited 128 + N,
/// a failure for a run that had written everything. Now the run finishes (its summary on
/// stdout, exit 0) when it can within the grace; one that cannot (its stdout blocked past the
/// grace) still ends with 128 + N, its reports complete and no temporary file left.
#[cfg(unix)]
#[test]
fn a_signal_after_every_report_is_written_does_not_fail_the_run() {
    use std::io::Read;
    use std::time::{Duration, Instant};
    let dir = tmpdir("r3-signal-committed");
    for (drain, want) in [(true, 0), (false, 128 + 15)] {
        let truth = dir.join(format!("truth-{drain}.toml"));
        // 4000 poses on stdout, far more than a pipe holds: the run blocks printing them, after
        // its --truth-out report is in place.
        let mut child = crate::common::bin()
            .args([
                "simulate",
                "--poses",
                "4000",
                "--seed",
                "5",
                "--truth-out",
                s(&truth),
            ])
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        let t0 = Instant::now();
        while !truth.exists() {
            assert!(t0.elapsed() < Duration::from_secs(60), "no --truth-out");
            std::thread::sleep(Duration::from_millis(10));
        }
        std::thread::sleep(Duration::from_millis(300));
        assert!(child.try_wait().unwrap().is_none(), "not blocked on stdout");
        let k = std::process::Command::new("kill")
            .args(["-TERM", &child.id().to_string()])
            .status()
            .unwrap();
        assert!(k.success());
        let mut out = child.stdout.take().unwrap();
        let mut text = String::new();
        if drain {
            out.read_to_string(&mut text).unwrap();
            assert_eq!(text.lines().count(), 4001, "the whole summary");
        } else {
            std::thread::sleep(Duration::from_secs(3));
        }
        let status = child.wait().unwrap();
        assert_eq!(status.code(), Some(want), "drain {drain}: {status:?}");
        assert!(truth.exists(), "the report is in place");
        assert!(
            !tree(&dir).iter().any(|f| f.contains(".tmp")),
            "{:?}",
            tree(&dir)
        );
    }
}

/// Item 10: piped data got the SHA-256 of nothing (`cat poses.csv | identify /dev/stdin`
/// recorded e3b0c442…: the file was opened twice, the second read found the pipe empty) and a
/// named pipe hung. The data are read once; the recorded checksum is the file's.
#[cfg(unix)]
#[test]
fn piped_pose_data_get_their_own_checksum() {
    let dir = tmpdir("r3-piped-data");
    // The property test's pose data (40 simulated poses).
    let cal = dir.join("cal.csv");
    std::fs::copy(crate::flag_properties::inputs().join("cal.csv"), &cal).unwrap();
    let want = gpu_amcs::identify::sha256_hex(&std::fs::read(&cal).unwrap());
    let recorded = |model: &Path| -> String {
        let text = std::fs::read_to_string(model).unwrap();
        let line = text
            .lines()
            .find(|l| l.starts_with("data_sha256"))
            .unwrap_or_else(|| panic!("no data_sha256 in {text}"))
            .to_string();
        line
    };
    let o = crate::common::sh(
        &dir,
        "cat cal.csv | timeout 60 \"$BIN\" identify /dev/stdin -q -o piped.toml",
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(recorded(&dir.join("piped.toml")).contains(&want));
    let o = crate::common::sh(
        &dir,
        "mkfifo fifo.csv && (cat cal.csv > fifo.csv &) && timeout 60 \"$BIN\" identify fifo.csv -q -o fifo.toml",
    );
    assert!(o.status.success(), "{:?}: {}", o.status, stderr(&o));
    assert!(recorded(&dir.join("fifo.toml")).contains(&want));
    ok(&["identify", s(&cal), "-q", "-o", s(&dir.join("file.toml"))]);
    assert_eq!(
        recorded(&dir.join("file.toml")),
        recorded(&dir.join("piped.toml"))
    );
}

/// What a progress hook heard: `(label, done, total)` in order.
type Heard = std::sync::Arc<std::sync::Mutex<Vec<(String, u64, u64)>>>;

/// A hook that records what it hears.
fn recording_hook() -> (gpu_amcs::progress::ProgressHook, Heard) {
    let heard: Heard = Default::default();
    let log = heard.clone();
    let hook = gpu_amcs::progress::ProgressHook::new(move |label: &str, done, total| {
        log.lock().unwrap().push((label.to_string(), done, total));
    });
    (hook, heard)
}

/// Asserts `heard` counts from the start to `total` and never back, with one total throughout.
fn counts_up_to(heard: &Heard, total: u64, what: &str) {
    let heard = heard.lock().unwrap();
    assert!(!heard.is_empty(), "{what}: no progress reported");
    assert!(heard.iter().all(|h| h.2 == total), "{what}: {heard:?}");
    assert!(
        heard.windows(2).all(|w| w[0].1 <= w[1].1),
        "{what}: went back: {heard:?}"
    );
    assert!(heard[0].1 < total / 10, "{what}: {:?}", heard[0]);
    assert_eq!(heard.last().unwrap().1, total, "{what}");
}

/// Round 4, item A: `plan --candidates 1000000` printed nothing for minutes and its bar counted
/// two steps ("eta 0s"); `validate --iso9283 --spec 0.05 --draws 100000000` ran 25 s with no
/// estimate. The plan now tells its steps, weighted by their work, from the candidates to the
/// bound (and the prediction its draws); the certificate its check's and its own draws. The
/// hook changes no result. (Timing-free: the announcement itself is tested on a plan of 200000
/// candidates, far beyond 10 s.)
#[test]
fn plans_and_certificates_report_their_progress() {
    use gpu_amcs::kinematics::Joints;
    use gpu_amcs::plan::{plan, predict_with_progress, prediction_problem, PlanOptions};
    let model = gpu_amcs::presets::preset("tx60").unwrap();
    let task: Vec<Joints> = (0..5)
        .map(|k| Joints::from_fn(6, |j| 10.0 * (k + j) as f64 - 20.0))
        .collect();
    let (hook, heard) = recording_hook();
    let o = PlanOptions {
        poses: 20,
        candidates: 400,
        search_draws: 100,
        passes: 2,
        swaps: 20,
        random_designs: 5,
        thresholds: vec![0.03],
        ..PlanOptions::default()
    };
    let quiet = plan(&model, &task, &o).unwrap();
    let heard_plan = plan(
        &model,
        &task,
        &PlanOptions {
            progress: hook,
            ..o.clone()
        },
    )
    .unwrap();
    assert_eq!(
        quiet.design_deg, heard_plan.design_deg,
        "the hook changed the plan"
    );
    counts_up_to(&heard, gpu_amcs::plan::PLAN_STEPS, "plan");
    let labels: Vec<String> = heard.lock().unwrap().iter().map(|h| h.0.clone()).collect();
    for step in [
        "drawing candidates",
        "candidate Jacobians",
        "greedy D-optimal design",
        "exchange on q95",
        "random designs",
        "design bound",
    ] {
        assert!(labels.iter().any(|l| l == step), "no '{step}': {labels:?}");
    }
    // Real steps, not two: every pose of the greedy design, every bound iteration.
    let distinct: std::collections::BTreeSet<u64> =
        heard.lock().unwrap().iter().map(|h| h.1).collect();
    assert!(distinct.len() > 50, "{distinct:?}");
    // The prediction's draws.
    let (hook, heard) = recording_hook();
    let problem = prediction_problem(&quiet, &task, 1).unwrap();
    let mut ev = gpu_amcs::engine::CpuEvaluator::new(problem);
    predict_with_progress(&mut ev, 200_000, &[0.03], &hook).unwrap();
    counts_up_to(&heard, 200_000, "prediction");
    // The certificate: the check's draws, then its own, as one count.
    let dir = tmpdir("r4-certificate-progress");
    let (truth, identified) = identified_model(&dir);
    let cycles = iso_cycles(&dir, None, &truth, 5);
    let m = gpu_amcs::kinematics::RobotModel::from_file(&identified).unwrap();
    let measured = gpu_amcs::identify::read_measurements(&cycles).unwrap();
    let frame = gpu_amcs::identify::Placement::Known;
    let figures = gpu_amcs::iso9283::pose_figures(&m, &measured, frame).unwrap();
    let (hook, heard) = recording_hook();
    let draws = 300_000;
    let c = gpu_amcs::iso9283::certify_with_progress(&m, &figures, 0.05, frame, draws, 7, &hook)
        .unwrap();
    assert_eq!(
        c,
        gpu_amcs::iso9283::certify(&m, &figures, 0.05, frame, draws, 7).unwrap()
    );
    counts_up_to(
        &heard,
        gpu_amcs::iso9283::CHECK_DRAWS + draws,
        "certificate",
    );
    let labels: Vec<String> = heard.lock().unwrap().iter().map(|h| h.0.clone()).collect();
    assert!(
        labels.iter().any(|l| l == "checking the cycles"),
        "{labels:?}"
    );
    assert!(labels.iter().any(|l| l == "certificate"), "{labels:?}");
}

/// Round 4, item A (command line): a plan of 200000 candidates (minutes on two cores, the
/// bound alone 200 passes over every candidate) says so on stderr within its first second, and
/// ends without writing its design.
#[test]
fn a_long_plan_announces_its_estimate() {
    use std::io::{BufRead, BufReader};
    let dir = tmpdir("r4-plan-estimate");
    let out = dir.join("design.csv");
    let mut child = crate::common::bin()
        .args([
            "plan",
            "--backend",
            "cpu",
            "--draws",
            "1000",
            "--candidates",
            "200000",
            "--out",
            s(&out),
        ])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(child.stderr.take().unwrap()).lines();
    let line = lines.next().expect("no estimate line").unwrap();
    let status = crate::common::signal(&mut child, "TERM");
    assert!(line.starts_with("plan: estimated ~"), "{line}");
    assert!(line.ends_with(" s for 1000 steps"), "{line}");
    assert_eq!(status.code(), Some(143), "{status:?}");
    assert_eq!(tree(&dir), Vec::<String>::new());
}

/// The model file of `preset` with its tool point replaced by `tool` (mm, flange frame).
fn preset_with_tool(dir: &Path, preset: &str, tool: [f64; 3]) -> PathBuf {
    let text = ok(&["model", "--preset", preset]);
    let text: String = text
        .lines()
        .map(|l| {
            if l.starts_with("tool = ") {
                format!("tool = [{:?}, {:?}, {:?}]\n", tool[0], tool[1], tool[2])
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    let path = dir.join(format!("{preset}-{}.toml", tool[2]));
    std::fs::write(&path, text).unwrap();
    path
}

/// The `d` of the last joint of a model file, mm.
fn last_d(model: &Path) -> f64 {
    let text = std::fs::read_to_string(model).unwrap();
    let last = text.split("[[joint]]").last().unwrap();
    last.lines()
        .find_map(|l| l.strip_prefix("d = "))
        .unwrap()
        .trim()
        .parse()
        .unwrap()
}

/// Round 4, item B: `points --iso9283` of every preset writes poses `fk` reads back (the
/// Panda's q4 sat on its limit, −176.00117550828628°, and was written −176.001176°, outside
/// it: fk refused the file) with the tool pointing down: the flange straight below the foot of
/// the last joint's axis (the point the chain reaches before the last joint's `d`), whichever
/// way that axis points. The KR 6 R700's A6 axis points into the wrist, so its tool is down at
/// rpy (0, 0, 0), its flange frame's z axis up, which the printed line now says.
#[test]
fn every_presets_iso9283_poses_read_back_with_the_tool_down() {
    let dir = tmpdir("r4-iso-tool-down");
    let list = ok(&["model", "--list"]);
    let presets: Vec<&str> = list
        .lines()
        .filter_map(|l| l.split_whitespace().next())
        .collect();
    assert!(presets.len() >= 7, "{list}");
    for preset in presets {
        let poses = dir.join(format!("{preset}.csv"));
        let o = run(&["points", "--iso9283", "--preset", preset, "-o", s(&poses)]);
        assert!(o.status.success(), "{preset}: {}", stderr(&o));
        let e = stderr(&o);
        assert!(e.contains("the tool pointing down"), "{preset}: {e}");
        let flange_model = preset_with_tool(&dir, preset, [0.0; 3]);
        let d = last_d(&flange_model);
        assert!(d.abs() > 10.0, "{preset}: d = {d}");
        let foot_model = preset_with_tool(&dir, preset, [0.0, 0.0, -d]);
        let flange = fk_positions(&["--model", s(&flange_model), "--points-file", s(&poses)]);
        let foot = fk_positions(&["--model", s(&foot_model), "--points-file", s(&poses)]);
        assert_eq!(flange.len(), 5, "{preset}");
        for (k, (f, w)) in flange.iter().zip(&foot).enumerate() {
            let down = [f[0] - w[0], f[1] - w[1], f[2] - w[2]];
            assert!(
                down[0].abs() < 1e-3 * d.abs()
                    && down[1].abs() < 1e-3 * d.abs()
                    && (down[2] + d.abs()).abs() < 1e-3 * d.abs(),
                "{preset} P{}: flange − foot of the last axis = {down:?}, not {} mm down",
                k + 1,
                d.abs()
            );
        }
        if preset == "kr6r700sixx" {
            assert!(
                e.contains("flange rpy (0, 0, 0)°") && e.contains("into the wrist"),
                "{e}"
            );
        }
    }
}

/// Round 4, items C and D: `plan --tracker-at 1e12,0,0` blamed --candidates ("only 0 of 300");
/// `--link-radius` 500 … 1e200 gave the TX60 the design of no self-collision check at all (a
/// radius above half the arm's length between its base column and its last link, 310 mm,
/// joins every link to every other), and a radius that refused every draw blamed
/// --candidates. Each is now one line naming its flag, exit 2, nothing written; 310 mm runs.
#[test]
fn plan_names_the_tracker_and_the_link_radius_it_cannot_use() {
    let dir = tmpdir("r4-plan-tracker-radius");
    let out = dir.join("design.csv");
    let before = tree(&dir);
    for (extra, flag, also) in [
        (
            vec!["--tracker-at", "1e12,0,0"],
            "--tracker-at",
            "1e12 mm from",
        ),
        (
            vec!["--tracker-at", "30000,0,0"],
            "--tracker-at",
            "range (20000 mm)",
        ),
        (
            vec!["--tracker-at", "3000,0,0", "--tracker-range", "1e30"],
            "--tracker-range",
            "100000",
        ),
        (
            vec!["--link-radius", "500"],
            "--link-radius",
            "at most 310 mm",
        ),
        (vec!["--link-radius", "1e200"], "--link-radius", "1e200 mm"),
        (
            vec![
                "--link-radius",
                "1e200",
                "--no-self-collision",
                "--floor",
                "-1000",
            ],
            "--link-radius",
            "at most 310 mm",
        ),
        (
            vec!["--link-radius", "100", "--no-self-collision"],
            "--link-radius",
            "--floor",
        ),
        (
            vec!["--link-radius", "150"],
            "--link-radius",
            "into the arm itself",
        ),
    ] {
        let mut args = vec![
            "plan",
            "--out",
            s(&out),
            "-q",
            "--draws",
            "1000",
            "--candidates",
            "300",
        ];
        args.extend(extra.iter().copied());
        let o = run(&args);
        let label = format!("{extra:?}");
        assert_fails_naming(&o, flag, &label);
        assert_fails_naming(&o, also, &label);
        assert!(
            !stderr(&o).contains("--candidates"),
            "{label}: {}",
            stderr(&o)
        );
        assert_eq!(tree(&dir), before, "{label} wrote a file");
    }
    ok(&[
        "plan",
        "--out",
        s(&out),
        "-q",
        "--draws",
        "1000",
        "--candidates",
        "300",
        "--link-radius",
        "310",
    ]);
    assert!(out.exists());
}

/// Round 4, item E: `validate` (plain, --iso9283 and with --spec) said nothing of a model file
/// whose data did not determine some parameters, which every other analysis notes; now it
/// gives the same note.
#[test]
fn validate_notes_a_model_that_was_not_fully_identified() {
    let dir = tmpdir("r4-validate-note");
    let (truth, model) = identified_model(&dir);
    let cycles = iso_cycles(&dir, None, &truth, 5);
    let text = std::fs::read_to_string(&model).unwrap();
    assert!(text.contains("[provenance]\n") && !text.contains("not_identified"));
    let partial = dir.join("partial.toml");
    std::fs::write(
        &partial,
        text.replace(
            "[provenance]\n",
            "[provenance]\nnot_identified = [\"alpha3\", \"tool_x\"]\n",
        ),
    )
    .unwrap();
    let note = format!(
        "note: --model {}: the model was not fully identified: the data did not determine 2 parameters (alpha3, tool_x)",
        s(&partial)
    );
    let mcs = run(&[
        "mcs",
        "--model",
        s(&partial),
        "--draws",
        "2000",
        "--backend",
        "cpu",
        "-q",
    ]);
    assert!(stderr(&mcs).contains(&note), "mcs: {}", stderr(&mcs));
    for extra in [
        &[][..],
        &["--iso9283"],
        &["--iso9283", "--spec", "0.05", "--draws", "20000"],
    ] {
        let mut args = vec!["validate", "--model", s(&partial), s(&cycles)];
        args.extend(extra);
        let o = run(&args);
        assert!(o.status.success(), "{extra:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(&note), "{extra:?}: {}", stderr(&o));
        // The fully identified model has no such note.
        args[2] = s(&model);
        let o = run(&args);
        assert!(
            !stderr(&o).contains("not fully identified"),
            "{}",
            stderr(&o)
        );
    }
}

/// Round 4, item F: `calibrate --range 1e-300` printed the range as a 300-digit number, and
/// `--step 1e-300` a sweep of 18446744073709551615 points "over 1.845e-281°"; plain
/// `validate`'s column-count error named no file.
#[test]
fn messages_write_numbers_plainly_and_name_the_data_file() {
    let o = run(&["calibrate", "--range", "1e-300", "--runs", "2"]);
    assert_fails_naming(&o, "--range 1e-300 --step 2", "--range 1e-300");
    assert!(!stderr(&o).contains("0.000000000"), "{}", stderr(&o));
    let o = run(&["calibrate", "--step", "1e-300", "--runs", "2"]);
    assert_fails_naming(&o, "1e-300° step", "--step 1e-300");
    assert!(
        !stderr(&o).contains("18446744073709551615"),
        "{}",
        stderr(&o)
    );
    let dir = tmpdir("r4-validate-columns");
    let data = dir.join("five-joints.csv");
    std::fs::write(&data, "q1,q2,q3,q4,q5,x,y,z\n1,2,3,4,5,300,0,400\n").unwrap();
    let model = dir.join("tx60.toml");
    std::fs::write(&model, ok(&["model", "--preset", "tx60"])).unwrap();
    for extra in [&[][..], &["--iso9283"]] {
        let mut args = vec!["validate", "--model", s(&model), s(&data)];
        args.extend(extra);
        let o = run(&args);
        for want in [s(&data), "line 2", "5 joint angles"] {
            assert_fails_naming(&o, want, &format!("{extra:?}"));
        }
    }
}

/// `calibrate` ran 1000 runs (about a minute) with no word: it now reports each run
/// identified (the CLI's bar and its `calibrate: estimated ~N s for R runs` line), counting up
/// to the runs asked for, with the same result as without a listener.
#[test]
fn calibrate_reports_each_run() {
    use gpu_amcs::progress::ProgressHook;
    use gpu_amcs::simulate::{calibrate, calibrate_with_progress, Experiment, Factors};
    use std::sync::{Arc, Mutex};
    let exp = Experiment::tx60(7);
    let f = Factors {
        runs: 6,
        step_deg: 5.0,
        ..Factors::default()
    };
    let heard = Arc::new(Mutex::new(Vec::new()));
    let sink = heard.clone();
    let hook = ProgressHook::new(move |_: &str, done, total| {
        sink.lock().unwrap().push((done, total));
    });
    let with = calibrate_with_progress(&exp, &f, 1, &hook).unwrap();
    let mut done: Vec<u64> = heard.lock().unwrap().iter().map(|h| h.0).collect();
    assert!(heard.lock().unwrap().iter().all(|h| h.1 == 6));
    done.sort_unstable();
    assert_eq!(done, [0, 1, 2, 3, 4, 5, 6]);
    let without = calibrate(&exp, &f, 1).unwrap();
    assert_eq!(with.independent.params, without.independent.params);
}
