//! Bad requests get one line and exit code 2 before any work, and outputs are all-or-nothing:
//! oversized runs are refused up front, thread pools that cannot start are named, output paths
//! are checked before the computation, and a write that fails midway or a termination leaves
//! neither outputs nor temporary files.

use crate::common;

use common::*;
use std::time::{Duration, Instant};

const CPU: [&str; 3] = ["-q", "--backend", "cpu"];

fn with_cpu<'a>(args: &[&'a str]) -> Vec<&'a str> {
    let mut v = args.to_vec();
    v.extend(CPU);
    v
}

#[test]
fn threads_that_cannot_start_are_named() {
    fails_naming(&with_cpu(&["--threads", "0"]), "--threads");
    fails_naming(&with_cpu(&["--threads", "100000"]), "--threads");
    // 4000 threads reserve about 8 GB of stacks: over a 1 GB address-space limit the pool
    // cannot start (this holds for root too, unlike a process-count limit).
    let d = tmpdir("threads");
    let o = sh(
        &d,
        "ulimit -v 1000000 && exec \"$BIN\" -q --backend cpu --points 5 --threads 4000",
    );
    assert_fails_naming(&o, "--threads", "--threads 4000 under ulimit -v");
}

#[test]
fn oversized_runs_are_refused_before_allocating() {
    let max = u64::MAX.to_string();
    for (args, what) in [
        (vec!["--batch", &max, "--max-draws", &max], "--max-draws"),
        (
            vec!["--batch", "4000000000", "--max-draws", "8000000000"],
            "--max-draws",
        ),
        (
            vec![
                "mcs",
                "--points",
                "50000",
                "--per-point",
                "--draws",
                "100000",
            ],
            "--per-point",
        ),
        // 10^12 values would not fit, so mcs summarises (bounded memory); under 1 MiB not even
        // one chunk and the histogram's reserve fit.
        (
            vec!["mcs", "--draws", "1000000000000", "--memory-limit", "1M"],
            "--memory-limit",
        ),
        (
            vec!["--points", "100000", "--memory-limit", "1M"],
            "--points",
        ),
        (vec!["--memory-limit", "lots"], "--memory-limit"),
    ] {
        let start = Instant::now();
        fails_naming(&with_cpu(&args), what);
        assert!(
            start.elapsed() < Duration::from_secs(5),
            "{args:?}: refused only after {:?}",
            start.elapsed()
        );
    }
    let d = tmpdir("oversized");
    // The number of points of a points file is known once it is read: checked then.
    let pts = arg(&d, "p2000.csv");
    let o = run(&["points", "2000", "-o", &pts]);
    assert!(o.status.success(), "{}", stderr(&o));
    fails_leaving_nothing(
        &d,
        &with_cpu(&[
            "mcs",
            "--per-point",
            "--points-file",
            &pts,
            "--memory-limit",
            "1G",
            "--json",
            &arg(&d, "r.json"),
        ]),
        "--per-point",
    );
    fails_leaving_nothing(
        &d,
        &["points", "4000000000", "-o", &arg(&d, "p.csv")],
        "points",
    );
    fails_leaving_nothing(
        &d,
        &["simulate", "--step", "0.000001", "-o", &arg(&d, "s.csv")],
        "--step",
    );
    fails_leaving_nothing(
        &d,
        &["simulate", "--runs", "100000000", "-o", &arg(&d, "s.csv")],
        "--runs",
    );
    fails_leaving_nothing(
        &d,
        &["calibrate", "--runs", "100000000", "-o", &arg(&d, "m.toml")],
        "--runs",
    );
    fails_leaving_nothing(
        &d,
        &["study", "--mcs-draws", "1000000000000", "-o", &arg(&d, "s")],
        "--mcs-draws",
    );
}

/// An output that exists and is not a regular file (a FIFO here, `/dev/null` in use) is written
/// in place, not replaced by a regular file through a rename.
#[test]
fn special_file_outputs_are_written_in_place() {
    let d = tmpdir("fifo");
    let o = sh(
        &d,
        "mkfifo p && { cat p > got & } && \"$BIN\" points 3 -o p; s=$?; wait; \
         test -p p && echo fifo-kept; exit $s",
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("fifo-kept"), "the FIFO was replaced");
    let got = std::fs::read_to_string(d.join("got")).unwrap();
    assert_eq!(got.lines().count(), 4, "{got}");
}

#[test]
fn output_paths_are_checked_before_the_computation() {
    let d = tmpdir("early");
    std::fs::write(d.join("f"), "a file").unwrap();
    let ok = arg(&d, "ok.json");
    let under_file = arg(&d, "f/svgd");
    let start = Instant::now();
    fails_leaving_nothing(
        &d,
        &with_cpu(&["--json", &ok, "--svg", &under_file]),
        "--svg",
    );
    fails_leaving_nothing(
        &d,
        &with_cpu(&["mcs", "--draws", "10000000", "--json", &arg(&d, "f/x.json")]),
        "--json",
    );
    fails_leaving_nothing(&d, &["study", "--quick", "--out", &arg(&d, "f")], "--out");
    assert!(
        start.elapsed() < Duration::from_secs(5),
        "refused only after {:?}",
        start.elapsed()
    );
    let same = arg(&d, "out/same");
    fails_leaving_nothing(
        &d,
        &with_cpu(&["--json", &same, "--csv", &same]),
        "same file",
    );
    let s = arg(&d, "s.csv");
    fails_leaving_nothing(
        &d,
        &["simulate", "--out", &s, "--truth-out", &s],
        "--truth-out",
    );
    let c = arg(&d, "c.md");
    fails_leaving_nothing(
        &d,
        &with_cpu(&["compare", "--json", &c, "--markdown", &c]),
        "--markdown",
    );
    // A JSON report where the CSV directory will write its CDF.
    fails_leaving_nothing(
        &d,
        &with_cpu(&["--json", &arg(&d, "c/cdf.csv"), "--csv", &arg(&d, "c")]),
        "same file",
    );
}

#[test]
fn inputs_inside_an_output_directory_are_protected() {
    let d = tmpdir("inside");
    let p = d.join("out/p");
    std::fs::create_dir_all(&p).unwrap();
    let input = p.join("cdf.csv");
    let o = run(&["points", "5", "-o", input.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let before = std::fs::read_to_string(&input).unwrap();
    fails_leaving_nothing(
        &d,
        &with_cpu(&[
            "--points-file",
            input.to_str().unwrap(),
            "--csv",
            p.to_str().unwrap(),
        ]),
        "--points-file",
    );
    assert_eq!(std::fs::read_to_string(&input).unwrap(), before);
}

#[test]
fn a_write_failing_midway_leaves_no_output_and_no_temp_file() {
    // A file size limit of 4 blocks: the JSON and the small CSVs fit, the SVG plots do not.
    let d = tmpdir("efbig");
    let o = sh(
        &d,
        "ulimit -f 4 && exec \"$BIN\" -q --backend cpu --points 10 \
         --json r.json --csv csv --svg svg",
    );
    assert_fails_naming(&o, "cannot write", "write over ulimit -f");
    assert_eq!(tree(&d), Vec::<String>::new(), "left behind");
}

/// Starts `args` (writing into `d`), checks that its first stderr line starts with `first`,
/// terminates it and checks that it exits with 128 + 15 and leaves nothing in `d`.
fn announces_then_terminates(d: &std::path::Path, args: &[&str], first: &str) {
    use std::io::{BufRead, BufReader};
    let mut child = bin()
        .args(args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(child.stderr.take().unwrap()).lines();
    let line = lines.next().expect("no estimate line").unwrap();
    assert!(line.starts_with(first), "{line}");
    let status = signal(&mut child, "TERM");
    assert_eq!(status.code(), Some(143), "{status:?}");
    assert_eq!(tree(d), Vec::<String>::new());
}

/// A long run says how long up front, and SIGTERM during it leaves no file (exit 128 + 15).
#[test]
fn long_runs_say_so_and_termination_leaves_nothing() {
    let d = tmpdir("term");
    // 2·10^6 draws × 5000 points: minutes on any machine, 32 MB of values.
    let (json, csv) = (arg(&d, "x.json"), arg(&d, "csv"));
    let args = [
        "mcs",
        "--backend",
        "cpu",
        "--points",
        "5000",
        "--draws",
        "2000000",
        "--json",
        &json,
        "--csv",
        &csv,
    ];
    announces_then_terminates(&d, &args, "MCS: estimated ~");
}

#[test]
fn flags_that_would_be_ignored_are_errors() {
    fails_naming(&with_cpu(&["--adapter", "no-such-gpu"]), "--adapter");
    fails_naming(
        &["-q", "--backend", "auto", "--adapter", "no-such-gpu"],
        "--adapter",
    );
    fails_naming(
        &with_cpu(&["--nominal", "/nonexistent/nominal.toml"]),
        "--reference nominal",
    );
}

#[test]
fn messages_name_the_right_flag_and_number() {
    fails_naming(&with_cpu(&["compare", "--deltas=-1"]), "--deltas");
    let o = run(&with_cpu(&["--coverage", "0.9999"]));
    assert_fails_naming(&o, "--batch", "--coverage 0.9999");
    assert!(stderr(&o).contains("= 1000000 "), "{}", stderr(&o));
    fails_naming(&with_cpu(&["--coverage", "abc"]), "--coverage");
    fails_naming(&["validate"], "--model");
    let help = stdout(&run(&["--help"]));
    // The box's default comes from the robot's reach; the help shows the TX60's.
    for default in ["250,0,200 for the TX60]", "900,1200,800 for the TX60]"] {
        assert!(help.contains(default), "help lacks {default}");
    }
    // What the help shows as the default is accepted as written.
    let o = run(&["points", "2", "--box-center", "250,0,200"]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// A cause the message already holds is printed once.
#[test]
fn causes_are_not_repeated() {
    for args in [
        vec!["--model", "/nonexistent/m.toml"],
        vec!["identify", "/nonexistent/s.csv"],
        vec!["fk", "--points-file", "/nonexistent/p.csv"],
        vec!["simulate", "--truth", "/nonexistent/t.toml"],
    ] {
        let o = run(&args);
        assert_fails_naming(&o, "/nonexistent/", &format!("{args:?}"));
        let e = stderr(&o);
        assert_eq!(e.matches("os error").count(), 1, "{args:?}: {e}");
    }
}

/// A study stopped before it finishes leaves no output directory (its files are written at the
/// end, all or none).
#[test]
fn interrupted_study_leaves_nothing() {
    let d = tmpdir("study-int");
    let mut child = bin()
        .args([
            "study",
            "--quick",
            "--quiet",
            "--backend",
            "cpu",
            "--out",
            &arg(&d, "s"),
        ])
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(1500));
    let status = signal(&mut child, "INT");
    assert_eq!(status.code(), Some(130), "{status:?}");
    assert_eq!(tree(&d), Vec::<String>::new());
}

/// A reader that stops early (`| head -1`) ends the run quietly, as with any command-line tool:
/// no panic message, and the files the run wrote before printing are complete.
#[test]
fn a_closed_stdout_is_not_a_panic() {
    let d = tmpdir("sigpipe");
    let o = sh(
        &d,
        "\"$BIN\" calibrate --runs 3 -o cal.toml | head -1 >/dev/null; \
         \"$BIN\" simulate --runs 2 -o s.csv 2>/dev/null; \
         \"$BIN\" identify s.csv -o id.toml --verbose | head -1 >/dev/null; \
         \"$BIN\" model | head -1 >/dev/null",
    );
    let err = stderr(&o);
    assert!(!err.contains("panicked"), "{err}");
    assert!(!err.contains("Broken pipe"), "{err}");
    let written = std::fs::read_to_string(d.join("cal.toml")).unwrap();
    assert!(gpu_amcs::kinematics::RobotModel::from_toml(&written, "cal.toml").is_ok());
    let written = std::fs::read_to_string(d.join("id.toml")).unwrap();
    assert!(gpu_amcs::kinematics::RobotModel::from_toml(&written, "id.toml").is_ok());
    assert_eq!(
        tree(&d),
        vec!["cal.toml".to_string(), "id.toml".into(), "s.csv".into()]
    );
}

/// stdout on a full disk (`> /dev/full`) is one line, `error: stdout: No space left on device`,
/// and exit code 2, in every command that prints: no panic (exit 101). Files the command writes
/// are renamed into place before anything is printed, so they are whole.
#[test]
fn stdout_on_a_full_disk_is_one_line_not_a_panic() {
    if !std::path::Path::new("/dev/full").exists() {
        eprintln!("stdout_on_a_full_disk_is_one_line_not_a_panic: skipped, no /dev/full");
        return;
    }
    let d = tmpdir("dev-full");
    let pts = d.join("pts.csv");
    std::fs::write(&pts, "q1,q2,q3,q4,q5,q6\n0,30,30,0,35,0\n10,20,40,5,30,0\n").unwrap();
    let pts = pts.to_str().unwrap();
    let shard = d.join("s0.json");
    let o = run(&[
        "mcs",
        "--draws",
        "2000",
        "--points",
        "3",
        "--shard",
        "0/1",
        "--summary-out",
        shard.to_str().unwrap(),
        "-q",
        "--backend",
        "cpu",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let urdf = d.join("r.urdf");
    let o = run(&[
        "export",
        "--preset",
        "ur5e",
        "--urdf",
        urdf.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let imported = d.join("r.toml");
    let commands: Vec<Vec<&str>> = vec![
        vec!["--points", "3", "--backend", "cpu"],
        vec![
            "mcs",
            "--points",
            "3",
            "--draws",
            "2000",
            "--backend",
            "cpu",
        ],
        vec![
            "compare",
            "--points",
            "3",
            "--draws",
            "2000",
            "--backend",
            "cpu",
        ],
        vec!["points", "5"],
        vec!["fk", "--points-file", pts],
        vec!["model", "--list"],
        vec!["model", "--preset", "tx60"],
        vec![
            "tail",
            "--points",
            "3",
            "--threshold",
            "0.2",
            "--backend",
            "cpu",
        ],
        vec![
            "sensitivity",
            "--points",
            "3",
            "--draws",
            "1024",
            "--backend",
            "cpu",
        ],
        vec![
            "map",
            "--plane",
            "xz",
            "--at",
            "0",
            "--cells",
            "4,4",
            "--draws",
            "200",
            "--backend",
            "cpu",
        ],
        vec!["merge", shard.to_str().unwrap()],
        vec![
            "import",
            urdf.to_str().unwrap(),
            "--out",
            imported.to_str().unwrap(),
        ],
    ];
    for args in commands {
        let _ = std::fs::remove_file(&imported);
        let full = std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap();
        let o = bin().args(&args).stdout(full).output().unwrap();
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert_eq!(
            stderr(&o).trim_end(),
            "error: stdout: No space left on device",
            "{args:?}"
        );
    }
}

/// Under an address-space limit (`ulimit -v`, as Slurm and containers set it) the default memory
/// limit is what that limit leaves: a run too large for it summarises (mcs) or is refused with
/// one line naming the limit, never an allocation abort (exit 134).
#[test]
fn the_default_memory_limit_follows_the_address_space_limit() {
    let d = tmpdir("rlimit-as");
    // 3·10^7 draws keep 458 MiB of values, far over 80 % of what ~195 MiB of address space
    // leaves: summary mode, exit 0, and the note names the limit's source.
    let o = sh(
        &d,
        "ulimit -v 200000 && exec \"$BIN\" mcs --backend cpu --points 5 --draws 30000000 --json r.json",
    );
    let out = String::from_utf8_lossy(&o.stdout);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{out}\n{err}");
    assert!(
        out.contains("summary mode") && out.contains("RLIMIT_AS"),
        "{out}"
    );
    // A map that needs 415 MiB (259 MB peak without the limit) is refused up front.
    let map = sh(
        &d,
        "ulimit -v 300000 && exec \"$BIN\" map --backend cpu -q --plane xz --at 0 \
         --cells 150,150 --draws 2000",
    );
    let err = String::from_utf8_lossy(&map.stderr);
    assert_eq!(map.status.code(), Some(2), "{err}");
    assert!(
        err.contains("memory limit") && err.contains("RLIMIT_AS") && !err.contains("panicked"),
        "{err}"
    );
}

/// Starts `args` (writing into `out`, which does not exist yet), waits until one of its
/// temporary files exists, sends `sig`, and checks that nothing is left of `out`. Returns
/// whether the signal arrived while temporary files existed (false when the run finished
/// first).
fn signal_while_writing(d: &std::path::Path, args: &[String], sig: (&str, i32)) -> bool {
    let out = d.join("out");
    assert!(!out.exists());
    let mut child = bin()
        .args(args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    let caught = loop {
        if tree(&out).iter().any(|f| f.contains(".tmp")) {
            break true;
        }
        if child.try_wait().unwrap().is_some() || t0.elapsed() > Duration::from_secs(120) {
            break false;
        }
        std::thread::yield_now();
    };
    if !caught {
        let _ = child.kill();
        let _ = child.wait();
        let _ = std::fs::remove_dir_all(&out);
        return false;
    }
    let status = signal(&mut child, sig.0);
    if status.success() {
        // Finished its renames before the signal arrived: complete outputs, nothing partial.
        assert!(
            !tree(&out).iter().any(|f| f.contains(".tmp")),
            "{:?}",
            tree(&out)
        );
        let _ = std::fs::remove_dir_all(&out);
        return false;
    }
    assert_eq!(status.code(), Some(128 + sig.1), "{status:?}");
    // All or nothing: a signal that arrives during the renames waits for them, so the reports
    // may all be in place; never a temporary file, never some reports without the others.
    let left = tree(&out);
    assert!(
        !left.iter().any(|f| f.contains(".tmp")),
        "SIG{} left {left:?}",
        sig.0
    );
    if out.exists() {
        for whole in ["r.json", "csv/map.csv"] {
            assert!(
                left.iter().any(|f| f == whole),
                "SIG{} left {left:?}",
                sig.0
            );
        }
        let _ = std::fs::remove_dir_all(&out);
    }
    true
}

/// SIGTERM, SIGINT and SIGHUP while `map` and `merge` write their reports (a 3-D map's 50 SVG
/// files, a 33 MB JSON and an 8 MB CSV) leave no temporary file and none of the directories the
/// run created: the signal waits for the file being written, removes every temporary file and
/// created directory, and exits with 128 + the signal number.
#[test]
fn signals_while_reports_are_written_leave_nothing() {
    let d = tmpdir("sig-writers");
    let p = |name: &str| d.join(name).display().to_string();
    let map = |extra: &[&str]| -> Vec<String> {
        let mut v: Vec<String> = [
            "map",
            "--backend",
            "cpu",
            "-q",
            "--cells",
            "25,25,25",
            "--draws",
            "200",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        v.extend(extra.iter().map(|s| s.to_string()));
        v
    };
    for k in 0..2 {
        let o = bin()
            .args(map(&[
                "--shard",
                &format!("{k}/2"),
                "--summary-out",
                &p(&format!("s{k}.json")),
            ]))
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let reports = |cmd: Vec<String>| -> Vec<String> {
        let mut v = cmd;
        for (flag, name) in [
            ("--json", "out/r.json"),
            ("--csv", "out/csv"),
            ("--svg", "out/svg"),
        ] {
            v.push(flag.into());
            v.push(p(name));
        }
        v
    };
    let merge = reports(vec![
        "merge".into(),
        "-q".into(),
        p("s0.json"),
        p("s1.json"),
    ]);
    let map_run = reports(map(&[]));
    let sigs = [("TERM", 15), ("INT", 2), ("HUP", 1)];
    // Merges are quick (every signal once at least); a map run repeats its inverse kinematics.
    let (want, mut caught) = ([3, 2], [0, 0]);
    for attempt in 0..6 {
        for (i, args) in [&merge, &map_run].into_iter().enumerate() {
            if caught[i] < want[i] && signal_while_writing(&d, args, sigs[attempt % 3]) {
                caught[i] += 1;
            }
        }
        if caught == want {
            break;
        }
    }
    eprintln!(
        "signals caught while writing: merge {}, map {}",
        caught[0], caught[1]
    );
    assert!(caught.iter().all(|&c| c >= 1), "{caught:?}");
    let _ = std::fs::remove_dir_all(&d);
}

/// The messages of issue "hardening round 2", each as the user meets it: a branching URDF on an
/// analysis command takes tool0 and says so; overflowing inputs are refused, never reported as
/// "inf mm"; huge numbers print as people write them; a free-orientation map that reaches
/// nothing does not advise freeing the orientation; a map of one draw is refused.
#[test]
fn messages_say_what_to_do_and_print_numbers_as_written() {
    let urdf = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/irb2400.urdf");
    // ROS-Industrial's tree (tool0 and base below base_link): the tip is tool0, and a note says
    // so.
    let o = run(&with_cpu(&["mcs", "--model", urdf, "--draws", "2000"]));
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("tip link 'tool0' (named tool0)"),
        "{}",
        stderr(&o)
    );
    let d = tmpdir("messages");
    std::fs::write(
        d.join("m.csv"),
        "q1,q2,q3,q4,q5,q6,x,y,z\n0,0,0,0,0,0,1e308,-1.7e308,1e308\n",
    )
    .unwrap();
    std::fs::write(d.join("tx60.toml"), stdout(&run(&["model"]))).unwrap();
    let o = run(&[
        "validate",
        "--model",
        &arg(&d, "tx60.toml"),
        &arg(&d, "m.csv"),
    ]);
    assert_fails_naming(
        &o,
        "line 2: column x = 1e308 is beyond",
        "overflowing measurement",
    );
    assert!(!stdout(&o).contains("inf"), "{}", stdout(&o));
    let o = run(&[
        "sensitivity",
        "--backend",
        "cpu",
        "--points",
        "3",
        "--draws",
        "1024",
        "--thresholds",
        "1e300",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("1[w ≥ 1e300 mm]"), "{}", stdout(&o));
    let far = [
        "map",
        "--plane",
        "xy",
        "--at",
        "0",
        "--box-center",
        "9000,0,0",
        "--box-size",
        "10,10,10",
    ];
    let o = run(&with_cpu(&[&far[..], &["--free-orientation"]].concat()));
    assert_fails_naming(&o, "into the arm's reach", "free-orientation map");
    assert!(
        !stderr(&o).contains("free the orientation"),
        "{}",
        stderr(&o)
    );
    let o = run(&with_cpu(&far));
    assert_fails_naming(&o, "free the orientation", "fixed-orientation map");
    let o = run(&with_cpu(&[
        "map", "--plane", "xz", "--at", "0", "--draws", "1",
    ]));
    assert_fails_naming(&o, "at least 20 are needed", "map --draws 1");
    // Sizes in any case.
    let o = run(&with_cpu(&["--points", "3", "--memory-limit", "1gb"]));
    assert!(o.status.success(), "{}", stderr(&o));
}

/// Runs `args` and returns (exit code, stderr, peak resident memory in bytes), the peak from
/// the kernel's accounting of this one child (`wait4`).
#[cfg(target_os = "linux")]
fn run_measuring_peak(args: &[&str]) -> (i32, String, u64) {
    use std::io::Read;
    let mut child = bin()
        .args(args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut err = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    let mut status = 0;
    // SAFETY: a zeroed rusage is a valid value for wait4 to overwrite.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: waits for our own child and writes only the two values given.
    let pid = unsafe { libc::wait4(child.id() as i32, &mut status, 0, &mut usage) };
    assert_eq!(pid, child.id() as i32);
    let code = if libc::WIFEXITED(status) {
        libc::WEXITSTATUS(status)
    } else {
        -1
    };
    // Already reaped by wait4: this only lets the handle go (ECHILD is expected).
    let _ = child.wait();
    (code, err, usage.ru_maxrss as u64 * 1024)
}

/// The map's memory estimate bounds what it really keeps, reports included: a map run under
/// a limit just above its estimate succeeds and its peak resident memory, less the process's
/// own (the peak of a 3 × 3 map with the same reports: code, thread stacks, allocator arenas),
/// stays under that limit; just below, it is refused before any work.
#[cfg(target_os = "linux")]
#[test]
fn the_map_stays_within_its_memory_estimate() {
    let d = tmpdir("map-peak");
    let reports = [
        "--json",
        &arg(&d, "m.json"),
        "--csv",
        &arg(&d, "csv"),
        "--svg",
        &arg(&d, "svg"),
        "--html",
        &arg(&d, "html"),
    ];
    let tiny = [
        &[
            "map",
            "--backend",
            "cpu",
            "-q",
            "--plane",
            "xz",
            "--at",
            "0",
        ][..],
        &["--cells", "3,3", "--draws", "20"],
        &reports,
    ]
    .concat();
    let (code, err, process) = run_measuring_peak(&tiny);
    assert_eq!(code, 0, "{err}");
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    for grid in [
        &[
            "--plane", "xz", "--at", "0", "--cells", "60,60", "--draws", "400",
        ][..],
        &["--cells", "20,20,20", "--draws", "50"],
    ] {
        let base = [&["map", "--backend", "cpu", "-q"][..], grid, &reports].concat();
        let o = run(&[&base[..], &["--memory-limit", "1K"]].concat());
        let e = stderr(&o);
        let needed = e
            .split("needs ")
            .nth(1)
            .and_then(|r| r.split(" MiB").next())
            .and_then(|x| x.parse::<f64>().ok())
            .unwrap_or_else(|| panic!("no estimate in: {e}"));
        let limit_mib = needed.ceil() as u64 + 1;
        let limit = format!("{limit_mib}M");
        let (code, err, peak) =
            run_measuring_peak(&[&base[..], &["--memory-limit", &limit]].concat());
        assert_eq!(code, 0, "{err}");
        eprintln!(
            "{grid:?}: estimate {needed} MiB, peak {:.1} MiB, of which the process's own {:.1} MiB",
            peak as f64 / 1048576.0,
            process as f64 / 1048576.0
        );
        assert!(
            peak.saturating_sub(process) <= limit_mib << 20,
            "peak {peak} B (the process's own {process} B) over the {limit} limit"
        );
        let below = format!("{}M", (needed.floor() as u64).saturating_sub(1).max(1));
        let o = run(&[&base[..], &["--memory-limit", &below]].concat());
        assert_fails_naming(&o, "memory limit", "just below the estimate");
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
    }
}

/// A long sensitivity analysis says so up front (before its evaluation), and termination then
/// leaves nothing.
#[test]
fn a_long_sensitivity_analysis_says_so() {
    let d = tmpdir("sens-long");
    // 2^20 base samples at 1000 points: minutes on any machine.
    let json = arg(&d, "s.json");
    let args = [
        "sensitivity",
        "--backend",
        "cpu",
        "--points",
        "1000",
        "--draws",
        "1048576",
        "--json",
        &json,
    ];
    announces_then_terminates(&d, &args, "sensitivity: estimated ~");
}
