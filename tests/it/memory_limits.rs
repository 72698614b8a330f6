//! Issue 35, item 4: the commands that allocate in proportion to a flag honour the address-space
//! limit (`ulimit -v`, as Slurm and containers set it) and `--memory-limit`: an estimate before
//! the work, and a refusal of one line naming the flag to change (exit 2, nothing written)
//! instead of an allocation abort (exit 134) or a run past the limit.

use crate::common::{assert_fails_naming, sh, stderr, tmpdir, tree};
use crate::hardening_round3::{identified_model, iso_cycles};
use std::path::Path;
use std::process::Output;

/// Runs `args` (after `$BIN`) in `dir` under an address-space limit of `kib` KiB.
fn under_ulimit(dir: &Path, kib: u64, args: &str) -> Output {
    sh(dir, &format!("ulimit -v {kib} && exec \"$BIN\" {args}"))
}

/// Runs `args` (after `$BIN`) in `dir` with no limit of its own.
fn unlimited(dir: &Path, args: &str) -> Output {
    sh(dir, &format!("exec \"$BIN\" {args}"))
}

/// A refusal naming `flag` and the limit `source` ("RLIMIT_AS" or "as given"), leaving `dir`
/// as it was.
fn refused(dir: &Path, o: &Output, flag: &str, source: &str, label: &str) {
    assert_fails_naming(o, flag, label);
    let e = stderr(o);
    assert!(
        e.contains("memory limit") && e.contains(source),
        "{label}: {e}"
    );
    assert!(tree(dir).is_empty(), "{label}: left {:?}", tree(dir));
}

/// `simulate --poses` keeps every pose and its CSV line: 10^6 poses under a 300 MB address
/// space aborted in the CSV writer (exit 134); 2·10^6 poses ran to 700 MB past
/// `--memory-limit 100M`.
#[test]
fn simulate_poses_honour_the_limits() {
    let d = tmpdir("mem-simulate");
    let o = under_ulimit(&d, 300_000, "simulate --poses 1000000 -o sim.csv");
    refused(&d, &o, "--poses", "RLIMIT_AS", "simulate under ulimit -v");
    let o = unlimited(
        &d,
        "simulate --poses 2000000 --memory-limit 100M -o sim.csv",
    );
    refused(&d, &o, "--poses", "as given", "simulate --memory-limit");
    // What fits still runs under the same limit.
    let o = under_ulimit(&d, 300_000, "simulate --poses 1000 -o sim.csv");
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(
        std::fs::read_to_string(d.join("sim.csv"))
            .unwrap()
            .lines()
            .count(),
        1001
    );
}

/// `plan --candidates` keeps a p × p information matrix per candidate: 3·10^5 candidates
/// under a 1 GB address space aborted (exit 134); `--draws 10^7` kept 80 MB of draws and 52 MB
/// of per-point errors past `--memory-limit 60M`.
#[test]
fn plan_honours_the_limits() {
    let d = tmpdir("mem-plan");
    let o = under_ulimit(&d, 1_000_000, "plan -q --candidates 300000 -o p.csv");
    refused(&d, &o, "--candidates", "RLIMIT_AS", "plan under ulimit -v");
    let o = unlimited(&d, "plan -q --draws 10000000 --memory-limit 60M -o p.csv");
    refused(&d, &o, "--draws", "as given", "plan --memory-limit");
}

/// `validate --iso9283 --spec` keeps every draw of the certificate: 10^8 draws under a 500 MB
/// address space aborted (exit 134), and validate took no `--memory-limit`; `--draws 0` blamed
/// `--spec`, and `--check-draws` had no cap.
#[test]
fn validate_honours_the_limits_and_caps_its_draws() {
    let d = tmpdir("mem-validate");
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let (truth, model) = identified_model(&d);
    let cycles = iso_cycles(&d, None, &truth, 30);
    let out = tmpdir("mem-validate-out");
    let json = s(&out.join("iso.json"));
    let iso = format!(
        "validate --model {} {} --iso9283 --spec 0.05 --json {json}",
        s(&model),
        s(&cycles)
    );
    let o = under_ulimit(&out, 500_000, &format!("{iso} --draws 100000000"));
    refused(&out, &o, "--draws", "RLIMIT_AS", "validate under ulimit -v");
    let o = unlimited(&out, &format!("{iso} --draws 10000000 --memory-limit 50M"));
    refused(&out, &o, "--draws", "as given", "validate --memory-limit");
    for (flags, flag) in [
        ("--draws 0", "--draws"),
        ("--draws 1000000000", "--draws"),
        ("--check-draws 100000000", "--check-draws"),
    ] {
        let o = unlimited(&out, &format!("{iso} {flags}"));
        assert_fails_naming(&o, flag, flags);
        assert!(tree(&out).is_empty(), "{flags}: left {:?}", tree(&out));
    }
    // What fits still runs under the same limit.
    let o = under_ulimit(&out, 500_000, &format!("{iso} --draws 20000"));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

/// `study --points` keeps every test point set and copies the largest into two evaluators:
/// 10^6 points under a 200 MB address space aborted (exit 134).
#[test]
fn study_points_honour_the_limits() {
    let d = tmpdir("mem-study");
    let o = under_ulimit(
        &d,
        200_000,
        "study -q --quick --factors range --points 1000000 --mcs-draws 2000 -o st",
    );
    refused(&d, &o, "--points", "RLIMIT_AS", "study under ulimit -v");
    let o = unlimited(
        &d,
        "study -q --quick --factors range --points 100000 --mcs-draws 2000 --memory-limit 50M -o st",
    );
    refused(&d, &o, "--points", "as given", "study --memory-limit");
}
