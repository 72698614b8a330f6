//! Issue 35 (hardening, round 3), the property test of its "Done means": flag values — σ,
//! counts, draws, thresholds from 1e-300 to 1e300, 0, negative, NaN, inf, empty, non-numbers —
//! given to `identify`, `plan`, `simulate` and `validate` on small inputs never panic (exit 101)
//! or abort (134): the run exits 0, or 2 with exactly one `error:` line that names the flag and
//! nothing written. The binary is spawned per case, so the case counts are modest.
//!
//! A value no setting could take (not a number, NaN, ±inf, zero or negative) must be refused
//! naming its own flag; a well-formed value may be refused naming another flag it conflicts
//! with (`--candidates 3` with `--poses 12`). Counts are drawn up to what runs in about a second
//! (a count beyond that is item 4's: an estimate and a cap); each case is stopped after
//! [`CASE_LIMIT`].

use crate::common::{assert_fails_naming, run, stderr, tmpdir, tree};
use proptest::prelude::*;
use std::path::{Path, PathBuf};
use std::process::Output;
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// The longest a case may run.
const CASE_LIMIT: Duration = Duration::from_secs(30);

/// Refusals that name another flag than the one at fault (issue 35, item 13): `(command,
/// flag)`. The test still holds them to exit 0 or 2 and one error line naming a flag. None is
/// left: plan's `--tracker-range` and `--max-incidence` were blamed on `--tracker-at`, and
/// `validate --iso9283 --draws 0` on `--spec` ([`the_flag_at_fault_is_named`]).
const KNOWN_WRONG_FLAG: &[(&str, &str)] = &[];

/// The refusals once listed in [`KNOWN_WRONG_FLAG`] name their own flag.
#[test]
fn the_flag_at_fault_is_named() {
    let d = tmpdir("flag-at-fault");
    let out = d.join("plan.csv");
    let out = out.to_str().unwrap();
    for (flag, v) in [
        ("--tracker-range", "-1"),
        ("--tracker-range", "NaN"),
        ("--tracker-range", "0"),
        ("--max-incidence", "0"),
        ("--max-incidence", "91"),
        ("--max-incidence", "inf"),
    ] {
        let o = run(&[
            "plan",
            "-q",
            "-o",
            out,
            "--tracker-at",
            "3000,0,500",
            flag,
            v,
        ]);
        assert_fails_naming(&o, flag, &format!("plan {flag} {v}"));
        assert!(tree(&d).is_empty(), "plan {flag} {v} left {:?}", tree(&d));
    }
}

/// A value no setting could take: not a number, NaN, ±inf (or beyond f64), zero or negative.
fn malformed(v: &str) -> bool {
    v.trim()
        .parse::<f64>()
        .map_or(true, |x| !x.is_finite() || x <= 0.0)
}

/// The value as a count, when it is one.
fn count(v: &str) -> Option<f64> {
    v.trim().parse::<f64>().ok().filter(|x| x.is_finite())
}

/// Values as a hostile user types them.
const VALUES: &[&str] = &[
    "0",
    "-0",
    "-1",
    "1",
    "3",
    "0.5",
    "1e-300",
    "1e300",
    "-1e300",
    "1e-155",
    "1e200",
    "1e400",
    "4.9e-324",
    "1.7976931348623157e308",
    "18446744073709551615",
    "18446744073709551616",
    "-18446744073709551615",
    "NaN",
    "nan",
    "inf",
    "-inf",
    "infinity",
    "",
    " ",
    "x",
    "1,2",
    "0x10",
    "1_000",
    "١",
];

fn value() -> impl Strategy<Value = String> {
    prop_oneof![
        3 => prop::sample::select(VALUES).prop_map(str::to_string),
        2 => (-300i32..=300, prop::bool::ANY)
            .prop_map(|(e, neg)| format!("{}1e{e}", if neg { "-" } else { "" })),
        1 => (0u64..100_000).prop_map(|v| v.to_string()),
    ]
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The shared inputs, made once: pose data (`cal.csv`), the model identified from them
/// (`model.toml`) and five ISO 9283 cycles of that model measured on the truth (`cycles.csv`).
pub(crate) fn inputs() -> &'static PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let d = tmpdir("flag-properties-inputs");
        let ok = |args: &[&str]| {
            let o = run(args);
            assert!(o.status.success(), "{args:?}: {}", stderr(&o));
        };
        let (cal, truth, model) = (
            d.join("cal.csv"),
            d.join("truth.toml"),
            d.join("model.toml"),
        );
        ok(&[
            "simulate",
            "--poses",
            "40",
            "--seed",
            "3",
            "--placement",
            "base",
            "-o",
            s(&cal),
            "--truth-out",
            s(&truth),
        ]);
        ok(&["identify", s(&cal), "-o", s(&model), "-q"]);
        crate::hardening_round3::iso_cycles(&d, Some(&model), &truth, 5);
        d
    })
}

/// Runs `base` with `flag=value` (or the value inside `template`, `{}` marking it) writing into
/// a fresh scratch directory `out/`, and checks the promise.
fn check(base: &[&str], flag: &str, template: &str, v: &str, name: &str) {
    let d = tmpdir(name);
    let out = d.join("out");
    std::fs::create_dir(&out).unwrap();
    let set = format!("{flag}={}", template.replace("{}", v));
    // The base's own setting of `flag`, if any, gives way to the value under test.
    let mut args: Vec<String> = Vec::new();
    let mut skip = false;
    for a in base {
        if std::mem::take(&mut skip) {
            continue;
        }
        if *a == flag {
            skip = true;
            continue;
        }
        args.push(
            a.replace("OUT", s(&out))
                .replace("IN/", &format!("{}/", s(inputs()))),
        );
    }
    args.push(set.clone());
    let argv: Vec<&str> = args.iter().map(String::as_str).collect();
    let label = format!("{argv:?}");
    let mut child = crate::common::bin()
        .args(&argv)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if t0.elapsed() > CASE_LIMIT {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{label}: still running after {CASE_LIMIT:?}");
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    let o = child.wait_with_output().unwrap();
    let strict = malformed(v) && !KNOWN_WRONG_FLAG.contains(&(argv[0], flag));
    promise(&o, if strict { flag } else { "--" }, &out, &label);
    let _ = std::fs::remove_dir_all(&d);
}

/// Exit 0, or 2 with exactly one `error:` line naming `flag` (`--`: any flag) and nothing in
/// `out`.
fn promise(o: &Output, flag: &str, out: &Path, label: &str) {
    let e = stderr(o);
    assert!(!e.contains("panicked"), "{label}: panic: {e}");
    match o.status.code() {
        Some(0) => {}
        Some(2) => {
            let errors: Vec<&str> = e.lines().filter(|l| l.starts_with("error:")).collect();
            assert_eq!(errors.len(), 1, "{label}: not one error line: {e}");
            assert!(
                errors[0].contains(flag),
                "{label}: error does not name {flag}: {e}"
            );
            assert!(tree(out).is_empty(), "{label}: left {:?}", tree(out));
        }
        other => panic!("{label}: exit {other:?} ({:?}): {e}", o.status),
    }
}

/// `(flag, template)`: the value alone (`{}`), or inside a list.
type Flag = (&'static str, &'static str);

/// The largest count of `flag` a case runs with (larger ones are skipped: item 4).
fn cap(command: &str, flag: &str) -> f64 {
    match (command, flag) {
        ("identify", "--mc-draws") => 40.0,
        ("plan", "--candidates") => 3000.0,
        ("plan", "--draws") => 2e5,
        ("plan", "--poses" | "--points") => 200.0,
        ("simulate", "--poses") => 1e4,
        ("simulate", "--runs") => 50.0,
        ("validate", "--check-draws") => 5000.0,
        ("validate", "--draws") => 2e5,
        _ => f64::INFINITY,
    }
}

/// Whether the case `command flag=v` runs within the caps.
fn affordable(command: &str, flag: &str, v: &str) -> bool {
    count(v).is_none_or(|x| x <= cap(command, flag))
}

const IDENTIFY: &[Flag] = &[
    ("--tracker-sigma", "{}"),
    ("--tracker-mpe", "{},6"),
    ("--tracker-mpe", "15,{}"),
    ("--tracker-mpe", "15,6,{}"),
    ("--mc-draws", "{}"),
    ("--seed", "{}"),
];

const PLAN: &[Flag] = &[
    ("--tracker-sigma", "{}"),
    ("--tracker-range", "{}"),
    ("--max-incidence", "{}"),
    ("--threshold", "{}"),
    ("--threshold", "0.05,{}"),
    ("--candidates", "{}"),
    ("--draws", "{}"),
    ("--poses", "{}"),
    ("--points", "{}"),
    ("--target", "{},0,50"),
    ("--seed", "{}"),
    ("--memory-limit", "{}"),
];

const SIMULATE: &[(&str, &str, bool)] = &[
    ("--poses", "{}", true),
    ("--tracker-sigma", "{}", true),
    ("--target", "30,{},80", true),
    ("--seed", "{}", true),
    ("--runs", "{}", false),
    ("--range", "{}", false),
    ("--step", "{}", false),
    ("--speed", "{}", false),
    ("--robot-seed", "{}", false),
    ("--memory-limit", "{}", false),
];

const VALIDATE: &[(&str, &str, bool)] = &[
    ("--spec", "{}", true),
    ("--draws", "{}", true),
    ("--check-draws", "{}", true),
    ("--check-draws", "{}", false),
    ("--seed", "{}", true),
    ("--seed", "{}", false),
];

proptest! {
    #![proptest_config(ProptestConfig { cases: 32, ..ProptestConfig::default() })]

    #[test]
    fn identify_flag_values(f in prop::sample::select(IDENTIFY), v in value()) {
        prop_assume!(affordable("identify", f.0, &v));
        let mut base = vec!["identify", "IN/cal.csv", "-q", "-o", "OUT/m.toml"];
        if f.0 == "--mc-draws" {
            base.extend(["--uncertainty", "montecarlo"]);
        }
        check(&base, f.0, f.1, &v, "flag-properties-identify");
    }

    #[test]
    fn plan_flag_values(f in prop::sample::select(PLAN), v in value()) {
        prop_assume!(affordable("plan", f.0, &v));
        let mut base = vec![
            "plan", "-q", "--backend", "cpu", "--points", "5", "--poses", "12", "--candidates",
            "150", "--draws", "2000", "--memory-limit", "256M", "--out", "OUT/design.csv",
        ];
        if matches!(f.0, "--tracker-range" | "--max-incidence") {
            base.extend(["--tracker-at", "-2500,0,500"]);
        }
        check(&base, f.0, f.1, &v, "flag-properties-plan");
    }

    #[test]
    fn simulate_flag_values(f in prop::sample::select(SIMULATE), v in value()) {
        prop_assume!(affordable("simulate", f.0, &v));
        let base: Vec<&str> = if f.2 {
            vec!["simulate", "--poses", "15", "--memory-limit", "256M", "-o", "OUT/p.csv"]
        } else {
            vec![
                "simulate", "--runs", "2", "--step", "10", "--memory-limit", "256M", "-o",
                "OUT/s.csv",
            ]
        };
        check(&base, f.0, f.1, &v, "flag-properties-simulate");
    }

    #[test]
    fn validate_flag_values(f in prop::sample::select(VALIDATE), v in value()) {
        prop_assume!(affordable("validate", f.0, &v));
        let mut base = vec![
            "validate", "IN/cycles.csv", "--model", "IN/model.toml", "--check-draws", "500",
            "--json", "OUT/v.json",
        ];
        if f.2 {
            base.extend(["--iso9283", "--spec", "0.05", "--draws", "2000"]);
        }
        check(&base, f.0, f.1, &v, "flag-properties-validate");
    }
}

/// Found by `plan_flag_values`: a tracker σ of 10 mm gave the planned model a joint σ beyond
/// a model's 10° limit, refused as the model's fault without naming a flag. The planned
/// model's uncertainty is the noise's doing: `--tracker-sigma` is named.
#[test]
fn a_tracker_sigma_too_large_for_the_planned_model_is_named() {
    let d = tmpdir("plan-sigma-too-large");
    let out = d.join("design.csv");
    for sigma in ["10", "11", "500"] {
        let o = run(&[
            "plan",
            "-q",
            "--backend",
            "cpu",
            "--points",
            "5",
            "--poses",
            "12",
            "--candidates",
            "150",
            "--draws",
            "2000",
            "--tracker-sigma",
            sigma,
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_fails_naming(&o, "--tracker-sigma", &format!("--tracker-sigma {sigma}"));
        assert!(tree(&d).is_empty(), "{sigma}: left {:?}", tree(&d));
    }
}
