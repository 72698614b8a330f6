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
    // A limit given above what the address space leaves is capped by it (it aborted, 134).
    let o = under_ulimit(
        &d,
        1_000_000,
        "plan -q --candidates 300000 --memory-limit 64G -o p.csv",
    );
    refused(
        &d,
        &o,
        "--candidates",
        "RLIMIT_AS",
        "plan --memory-limit 64G under ulimit -v",
    );
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
    let o = under_ulimit(
        &out,
        500_000,
        &format!("{iso} --draws 100000000 --memory-limit 64G"),
    );
    refused(
        &out,
        &o,
        "--draws",
        "RLIMIT_AS",
        "validate --memory-limit 64G under ulimit -v",
    );
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
    let o = under_ulimit(
        &d,
        200_000,
        "study -q --quick --factors range --points 1000000 --mcs-draws 2000 --memory-limit 64G -o st",
    );
    refused(
        &d,
        &o,
        "--points",
        "RLIMIT_AS",
        "study --memory-limit 64G under ulimit -v",
    );
    let o = unlimited(
        &d,
        "study -q --quick --factors range --points 100000 --mcs-draws 2000 --memory-limit 50M -o st",
    );
    refused(&d, &o, "--points", "as given", "study --memory-limit");
}

/// `identify` of 10^5 poses keeps the whole-chain fit's 3n × p Jacobian and the lack of fit's
/// 200 draws per pose (486 MiB at its peak): under a 500 MB address space it aborted after
/// three minutes (exit 134, allocating the draws), and it took no `--memory-limit`. Now sized
/// from the file's rows before it is read.
#[test]
fn identify_honours_the_limits() {
    let data = tmpdir("mem-identify-data");
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let o = unlimited(&data, "simulate --poses 100000 -o big.csv");
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let o = unlimited(&data, "simulate --poses 300 -o small.csv");
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let (big, small) = (s(&data.join("big.csv")), s(&data.join("small.csv")));
    let out = tmpdir("mem-identify-out");
    let o = under_ulimit(&out, 500_000, &format!("identify -q {big} -o m.toml"));
    refused(
        &out,
        &o,
        "--memory-limit",
        "RLIMIT_AS",
        "identify under ulimit -v",
    );
    let o = under_ulimit(
        &out,
        500_000,
        &format!("identify -q {big} -o m.toml --memory-limit 4G"),
    );
    refused(
        &out,
        &o,
        "--memory-limit",
        "RLIMIT_AS",
        "identify --memory-limit 4G under ulimit -v",
    );
    let o = unlimited(
        &out,
        &format!("identify -q {big} -o m.toml --memory-limit 300M"),
    );
    refused(
        &out,
        &o,
        "--memory-limit",
        "as given",
        "identify --memory-limit",
    );
    // Piped data cannot be counted before they are read: they ran unsized (to 486 MiB past
    // a limit of 300M, or an abort under ulimit -v); now sized once read, before any fit.
    for (piped, label) in [
        (format!("< {big} identify -q /dev/stdin"), "stdin"),
        (format!("identify -q <(cat {big})"), "a pipe"),
    ] {
        let o = sh(
            &out,
            &format!("exec bash -c 'exec \"$BIN\" {piped} -o m.toml --memory-limit 300M'"),
        );
        refused(&out, &o, "--memory-limit", "as given", label);
        assert!(
            stderr(&o).contains("100001 lines"),
            "{label}: {}",
            stderr(&o)
        );
    }
    // Monte Carlo re-identifications too many to keep: 10^9 aborted (exit 134) collecting
    // their estimates once the fit was done.
    let mc = format!("identify -q {small} -o m.toml --uncertainty montecarlo");
    let o = under_ulimit(&out, 500_000, &format!("{mc} --mc-draws 1000000000"));
    refused(
        &out,
        &o,
        "--mc-draws",
        "RLIMIT_AS",
        "identify --mc-draws under ulimit -v",
    );
    let o = unlimited(&out, &format!("{mc} --mc-draws 18446744073709551615"));
    assert_fails_naming(&o, "--mc-draws", "--mc-draws 2^64 - 1");
    assert!(tree(&out).is_empty(), "left {:?}", tree(&out));
    // What fits still runs under the same limit.
    let o = under_ulimit(&out, 500_000, &format!("identify -q {small} -o m.toml"));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(out.join("m.toml").exists());
}

/// `merge` held every shard's text and then every parsed shard at once (4.5 times the files):
/// two map shards of 2·10^6 draws (32 MB each) aborted under a 200 MB address space (exit 134),
/// and merge took no `--memory-limit`. Now the files are read one at a time and sized from their
/// lengths before any is read.
#[test]
fn merge_of_large_map_shards_honours_the_limits() {
    let data = tmpdir("mem-merge-data");
    let s = |p: &Path| p.to_str().unwrap().to_string();
    for k in 0..2 {
        let o = unlimited(
            &data,
            &format!(
                "map -q --draws 2000000 --cells 3,3 --plane xy --at 200 --shard {k}/2 --summary-out s{k}.json"
            ),
        );
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    }
    let shards = format!("{} {}", s(&data.join("s0.json")), s(&data.join("s1.json")));
    let out = tmpdir("mem-merge-out");
    let o = under_ulimit(&out, 200_000, &format!("merge -q {shards} --json m.json"));
    refused(
        &out,
        &o,
        "--memory-limit",
        "RLIMIT_AS",
        "merge under ulimit -v",
    );
    let o = under_ulimit(
        &out,
        200_000,
        &format!("merge -q {shards} --json m.json --memory-limit 64G"),
    );
    refused(
        &out,
        &o,
        "--memory-limit",
        "RLIMIT_AS",
        "merge --memory-limit 64G under ulimit -v",
    );
    let o = unlimited(
        &out,
        &format!("merge -q {shards} --json m.json --memory-limit 100M"),
    );
    refused(
        &out,
        &o,
        "--memory-limit",
        "as given",
        "merge --memory-limit",
    );
    // What fits still runs under a larger limit.
    let o = under_ulimit(&out, 400_000, &format!("merge -q {shards} --json m.json"));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(out.join("m.json").exists());
}
