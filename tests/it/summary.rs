//! The mergeable summary: Chan/Pébay merging against a single pass, shards of one run against
//! the single run (counts identical, moments within 1e-12, interval within the bin width h),
//! and the merge's refusals.
//!
//! Over 600 lines: each shard kind (MCS, sensitivity) needs its fixtures and its refusals beside its merges.

use gpu_amcs::engine::{CpuEvaluator, FnEvaluator, Problem, Reference};
use gpu_amcs::kinematics::tx60;
use gpu_amcs::mc::stats::coverage_interval;
use gpu_amcs::mc::summary::{merge, summarize, MomentSums, Provenance, Summary, BIN_WIDTH};
use gpu_amcs::mc::{run_mcs, IntervalKind, McResult, McsOptions, RunSettings};

fn problem(seed: u64) -> Problem {
    let m = tx60();
    let pts = gpu_amcs::points::generate(&m, 10, &Default::default(), 1).unwrap();
    Problem::new(m, &pts, &Reference::Calibrated, seed).unwrap()
}

fn rel(a: f64, b: f64) -> f64 {
    if a == b {
        0.0
    } else {
        (a - b).abs() / b.abs()
    }
}

/// Summaries of `problem` cut at `cuts` (ascending, ending at `draws`), merged.
fn sharded(pb: &Problem, draws: u64, cuts: &[u64], settings: &RunSettings) -> Summary {
    let mut named = Vec::new();
    let mut first = 0;
    for (i, &end) in cuts.iter().enumerate() {
        let mut ev = CpuEvaluator::new(pb.clone());
        let prov = Provenance::new(pb, "calibrated model", draws, 0, draws);
        let s = summarize(&mut ev, first, end, 65_536, u64::MAX, settings, prov, None).unwrap();
        named.push((format!("shard-{i}.json"), s));
        first = end;
    }
    merge(&named).unwrap()
}

#[test]
fn pairwise_merge_matches_a_single_pass() {
    // A skewed stream with a large mean (cancellation-prone for naive power sums).
    let v: Vec<f64> = (0..200_000u64)
        .map(|k| {
            let u =
                ((k.wrapping_mul(0x9e37_79b9_7f4a_7c15) >> 11) as f64 + 0.5) / (1u64 << 53) as f64;
            1000.0 + (-u.ln()).powf(1.5)
        })
        .collect();
    let whole = MomentSums::of(&v);
    for cuts in [
        vec![200_000],
        vec![1, 70_000, 200_000],
        vec![3, 10, 999, 50_000, 50_001, 123_456, 200_000],
    ] {
        let mut acc = MomentSums::default();
        let mut a = 0;
        for &b in &cuts {
            acc = acc.merge(&MomentSums::of(&v[a..b]));
            a = b;
        }
        assert_eq!(acc.n, whole.n);
        let (m, w) = (acc.moments(), whole.moments());
        assert!(rel(m.mean, w.mean) < 1e-12, "{cuts:?}");
        assert!(rel(m.variance, w.variance) < 1e-12, "{cuts:?}");
        assert!(
            rel(m.skewness.unwrap(), w.skewness.unwrap()) < 1e-12,
            "{cuts:?}"
        );
        assert!(
            rel(m.kurtosis.unwrap(), w.kurtosis.unwrap()) < 1e-12,
            "{cuts:?}"
        );
    }
}

/// The checks of a merged summary against the single run of the same draws.
fn agrees(s: &Summary, exact: &McResult) {
    let r = s.to_result();
    assert_eq!(r.draws, exact.draws);
    assert_eq!((r.min, r.max), (exact.min, exact.max));
    assert_eq!(r.reliability, exact.reliability);
    assert_eq!(r.per_point_reliability, exact.per_point_reliability);
    let (a, b) = (r.moments.as_array(), exact.moments.as_array());
    for k in 0..4 {
        assert!(rel(a[k], b[k]) < 1e-12, "M{}: {} vs {}", k + 1, a[k], b[k]);
        // Batch means over the same 20 groups: the same up to rounding.
        let (x, y) = (r.moment_standard_errors[k], exact.moment_standard_errors[k]);
        assert!(rel(x, y) < 1e-6, "SE of M{}: {x} vs {y}", k + 1);
    }
    // The same ranks, each end within h (h/2 from the bin centre, exact at min/max).
    let (ci, ce) = (r.coverage_interval, exact.coverage_interval);
    assert!((ci.low - ce.low).abs() <= BIN_WIDTH, "{ci:?} vs {ce:?}");
    assert!((ci.high - ce.high).abs() <= BIN_WIDTH, "{ci:?} vs {ce:?}");
}

#[test]
fn one_three_and_seven_shards_agree_with_the_single_run() {
    let pb = problem(11);
    let draws = 1_000_000;
    let settings = RunSettings {
        per_point: true,
        ..RunSettings::default()
    };
    let opts = McsOptions {
        draws,
        chunk: 100_000,
        settings: settings.clone(),
    };
    let exact = run_mcs(&mut CpuEvaluator::new(pb.clone()), &opts, None).unwrap();
    let one = sharded(&pb, draws, &[draws], &settings);
    let three = sharded(&pb, draws, &[1, 400_000, draws], &settings);
    let seven = sharded(
        &pb,
        draws,
        &[99_999, 100_000, 250_001, 500_000, 777_777, 900_000, draws],
        &settings,
    );
    for s in [&one, &three, &seven] {
        agrees(s, &exact);
        // Exact parts and the histogram are identical; the interval therefore too.
        assert_eq!(s.bins, one.bins);
        assert_eq!(s.below, one.below);
        assert_eq!(s.per_point_below, one.per_point_below);
        assert_eq!(s.coverage_interval(), one.coverage_interval());
    }
    assert!(one.note().contains("within h"));
}

#[test]
fn histogram_intervals_within_h_of_the_sorted_values() {
    // A scalar model spread over ~4 mm so many bins hold several values.
    let draws = 300_000;
    let f = |g: &gpu_amcs::sampling::Philox, k: u64| {
        let b = g.block(k, 0, 0);
        let u = (f64::from(b[0]) + 0.5) / 4_294_967_296.0;
        2.0 * (-u.ln()).sqrt()
    };
    for interval in [IntervalKind::Symmetric, IntervalKind::Shortest] {
        let settings = RunSettings {
            interval,
            ..RunSettings::default()
        };
        let prov = Provenance {
            version: "test".into(),
            model: "scalar".into(),
            model_hash: String::new(),
            reference: String::new(),
            points: 1,
            points_hash: String::new(),
            seed: 5,
            draws,
            first: 0,
            end: draws,
        };
        let mut ev = FnEvaluator::new(5, f);
        let s = summarize(&mut ev, 0, draws, 10_000, u64::MAX, &settings, prov, None).unwrap();
        let mut v = vec![0.0; draws as usize];
        let mut ev = FnEvaluator::new(5, f);
        use gpu_amcs::engine::Evaluator;
        ev.evaluate(0, &mut v, None).unwrap();
        v.sort_unstable_by(f64::total_cmp);
        let (ci, ce) = (s.coverage_interval(), coverage_interval(&v, 0.95, interval));
        assert!(
            (ci.low - ce.low).abs() <= BIN_WIDTH,
            "{interval:?}: {ci:?} vs {ce:?}"
        );
        assert!(
            (ci.high - ce.high).abs() <= BIN_WIDTH,
            "{interval:?}: {ci:?} vs {ce:?}"
        );
        // The curves' stand-ins are ascending and span min..max.
        let c = s.curve_values();
        assert!(c.windows(2).all(|w| w[0] <= w[1]));
        assert_eq!((c[0], c[c.len() - 1]), (v[0], v[v.len() - 1]));
    }
}

fn shards(seed: u64, cuts: &[u64]) -> Vec<(String, Summary)> {
    let pb = problem(seed);
    let draws = *cuts.last().unwrap();
    let mut first = 0;
    cuts.iter()
        .enumerate()
        .map(|(i, &end)| {
            let mut ev = CpuEvaluator::new(pb.clone());
            let prov = Provenance::new(&pb, "calibrated model", draws, 0, draws);
            let s = summarize(
                &mut ev,
                first,
                end,
                1000,
                u64::MAX,
                &RunSettings::default(),
                prov,
                None,
            )
            .unwrap();
            first = end;
            (format!("s{i}.json"), s)
        })
        .collect()
}

fn refusal(named: &[(String, Summary)], file: &str, what: &str) {
    let e = merge(named).unwrap_err().to_string();
    assert!(!e.contains('\n'), "{e}");
    assert!(e.contains(file) && e.contains(what), "{e}");
}

#[test]
fn merge_refuses_mismatches_gaps_overlaps_and_corrupt_files() {
    let good = shards(3, &[2000, 5000, 6000]);
    // A part of a run reports no batch-means standard errors, and says so.
    assert!(good[1]
        .1
        .to_result()
        .moment_standard_errors
        .iter()
        .all(|x| x.is_nan()));
    assert!(good[1].1.note().contains("not available"));
    let whole = merge(&good).unwrap();
    assert!(whole
        .to_result()
        .moment_standard_errors
        .iter()
        .all(|x| x.is_finite()));
    assert!(!whole.note().contains("not available"));
    // Any order gives the same summary.
    let mut rev = good.clone();
    rev.reverse();
    assert_eq!(merge(&rev).unwrap(), merge(&good).unwrap());

    let mut other_seed = good.clone();
    other_seed[2] = (
        "seed9.json".into(),
        shards(9, &[2000, 5000, 6000])[2].1.clone(),
    );
    refusal(&other_seed, "seed9.json", "seed");

    refusal(&good[..2], "s1.json", "missing");
    refusal(&[good[0].clone(), good[2].clone()], "s2.json", "missing");
    let mut dup = good.clone();
    dup.push(("copy.json".into(), good[1].1.clone()));
    refusal(&dup, ".json", "overlap");

    let mut settings = good.clone();
    settings[1].1.thresholds[0] = 0.15;
    refusal(&settings, "s1.json", "thresholds");

    let text = good[0].1.to_json();
    assert_eq!(Summary::from_json(&text, "a.json").unwrap(), good[0].1);
    for bad in [&text[..text.len() / 2], "{}", "[1, 2]"] {
        let e = Summary::from_json(bad, "bad.json").unwrap_err().to_string();
        assert!(
            e.starts_with("bad.json: not a summary") && !e.contains('\n'),
            "{e}"
        );
    }
    let tampered = text.replacen("\"below\":[", "\"below\":[99999999,", 1);
    let e = Summary::from_json(&common::reseal(&tampered), "t.json")
        .unwrap_err()
        .to_string();
    assert!(e.contains("t.json") && e.contains("below"), "{e}");
    // One digit of sums.mean, sums.m2 or below[0] changed: the content checksum refuses it
    // (the values stay consistent, so nothing else could).
    for field in ["\"mean\":", "\"m2\":", "\"below\":["] {
        let at = text.find(field).unwrap() + field.len();
        let digit_at = at + text[at..].find(|c: char| c.is_ascii_digit()).unwrap();
        let mut edited = text.clone();
        let d = if &text[digit_at..digit_at + 1] == "1" {
            "2"
        } else {
            "1"
        };
        edited.replace_range(digit_at..digit_at + 1, d);
        let e = Summary::from_json(&edited, "e.json")
            .unwrap_err()
            .to_string();
        assert_eq!(
            e, "e.json: not a summary: content checksum mismatch (edited or corrupted)",
            "{field}"
        );
    }
}

use crate::common;
use common::{assert_fails_naming, bin, fails_leaving_nothing, run, tmpdir};

fn json(path: &std::path::Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn cli_shards_then_merge_equal_the_single_run() {
    let d = tmpdir("summary-cli");
    let p = |name: &str| d.join(name).display().to_string();
    let base = [
        "mcs",
        "--points",
        "10",
        "--draws",
        "200000",
        "--backend",
        "cpu",
        "-q",
    ];
    for k in 0..3 {
        let shard = format!("{k}/3");
        let out = p(&format!("s{k}.json"));
        let o = run(&[&base[..], &["--shard", &shard, "--summary-out", &out]].concat());
        assert!(o.status.success(), "{}", common::stderr(&o));
    }
    // A Slurm array task (indices 1..3) without --shard: the same summary as shard 1/3.
    let o = bin()
        .args(base)
        .args(["--summary-out", &p("slurm.json")])
        .env("SLURM_ARRAY_TASK_ID", "2")
        .env("SLURM_ARRAY_TASK_MIN", "1")
        .env("SLURM_ARRAY_TASK_COUNT", "3")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", common::stderr(&o));
    let (mut a, mut b) = (json(&d.join("slurm.json")), json(&d.join("s1.json")));
    a["seconds"] = 0.into();
    b["seconds"] = 0.into();
    assert_eq!(common::without_checksum(a), common::without_checksum(b));

    let o = run(&[
        "merge",
        &p("s2.json"),
        &p("s0.json"),
        &p("s1.json"),
        "-q",
        "--json",
        &p("m.json"),
    ]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    let o = run(&[&base[..], &["--json", &p("e.json")]].concat());
    assert!(o.status.success(), "{}", common::stderr(&o));
    let (m, e) = (json(&d.join("m.json")), json(&d.join("e.json")));
    agree_as_json(&m["result"], &e["result"]);
    // A summary evaluates its draws in chunks of up to 2^20 (here one chunk per shard).
    assert_eq!(m["result"]["batch_size"], json(&d.join("s0.json"))["chunk"]);
    assert_eq!(m["result"]["batches"], 3);
    // Shards read the same histogram as one summary: here the same ranks, ends within h.
    for key in ["low", "high"] {
        let x = m["result"]["coverage_interval"][key].as_f64().unwrap();
        let y = e["result"]["coverage_interval"][key].as_f64().unwrap();
        assert!((x - y).abs() <= BIN_WIDTH, "{key}: {x} vs {y}");
    }
    assert!(m["notes"][0].as_str().unwrap().contains("histogram"));

    // Refusals: one line naming the file, exit 2, nothing written.
    std::fs::write(d.join("bad.json"), "{\"provenance\": 3").unwrap();
    let out = p("out.json");
    for (args, what) in [
        (vec![p("s0.json"), p("s1.json")], "s1.json"),
        (
            vec![p("s0.json"), p("s1.json"), p("slurm.json"), p("s2.json")],
            "overlap",
        ),
        (
            vec![p("s0.json"), p("bad.json"), p("s2.json")],
            "bad.json: not a summary",
        ),
        (vec![p("s0.json"), p("nothing.json")], "nothing.json"),
    ] {
        let mut a: Vec<&str> = vec!["merge", "--json", &out];
        a.extend(args.iter().map(String::as_str));
        fails_leaving_nothing(&d, &a, what);
    }
    let o = run(&[&base[..], &["--shard", "3/3", "--summary-out", &out]].concat());
    assert_fails_naming(&o, "--shard", "shard 3/3");
    let o = run(&[&base[..], &["--shard", "0/3"]].concat());
    assert_fails_naming(&o, "--summary-out", "--shard alone");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn summary_mode_gives_the_same_bits_with_any_thread_count() {
    // The chunk's work is split into fixed pieces done in parallel and combined in draw order;
    // the histogram's counts are integers. One, two and three threads: the same report.
    let d = tmpdir("summary-threads");
    let mut results = Vec::new();
    for threads in ["1", "2", "3"] {
        let out = d.join(format!("t{threads}.json"));
        let o = run(&[
            "mcs",
            "--points",
            "10",
            "--draws",
            "700000",
            "--backend",
            "cpu",
            "--memory-limit",
            "9M",
            "--threads",
            threads,
            "-q",
            "--json",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", common::stderr(&o));
        let mut r = json(&out)["result"].clone();
        r["seconds"] = 0.into();
        r["backend"] = 0.into();
        results.push(r);
    }
    let notes = json(&d.join("t1.json"))["notes"].clone();
    assert!(
        notes[0].as_str().unwrap().starts_with("summary mode"),
        "{notes}"
    );
    assert_eq!(results[0], results[1]);
    assert_eq!(results[0], results[2]);
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn mcs_over_the_memory_limit_runs_in_summary_mode_and_agrees_with_the_exact_run() {
    let d = tmpdir("summary-mode");
    let p = |name: &str| d.join(name).display().to_string();
    // 10^7 values would need 160 MB (16 bytes a draw): 24 MiB leaves room for one chunk, the
    // points and the ~2.4·10^5 bins of w (64 bytes each) only. With --per-point, 10^6 values
    // and the per-point buffers need 32 MB: 28 MiB holds the buffers (16 MB) and the bins;
    // that case takes the symmetric interval, whose ends are bounded.
    for (draws, per_point, limit) in [("10000000", false, "24M"), ("1000000", true, "28M")] {
        let mut base = vec![
            "mcs",
            "--points",
            "10",
            "--draws",
            draws,
            "--backend",
            "cpu",
            "-q",
        ];
        if per_point {
            base.extend(["--per-point", "--interval", "symmetric"]);
        }
        let o = run(&[&base[..], &["--json", &p("e.json")]].concat());
        assert!(o.status.success(), "{}", common::stderr(&o));
        let o = run(&[
            &base[..],
            &["--memory-limit", limit, "--json", &p("s.json")],
        ]
        .concat());
        assert!(o.status.success(), "{}", common::stderr(&o));
        let (s, e) = (json(&d.join("s.json")), json(&d.join("e.json")));
        assert_eq!(e["notes"].as_array().unwrap().len(), 0, "{}", e["notes"]);
        let note = s["notes"][0].as_str().unwrap();
        assert!(
            note.starts_with("summary mode") && note.contains(" MiB"),
            "{note}"
        );
        assert!(s["notes"][1].as_str().unwrap().contains("within h/2"));
        agree_as_json(&s["result"], &e["result"]);
        assert_eq!(
            s["result"]["per_point_reliability"]
                .as_array()
                .map(Vec::len),
            per_point.then_some(10)
        );
        std::fs::remove_file(d.join("s.json")).unwrap();
        std::fs::remove_file(d.join("e.json")).unwrap();
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// A report from a summary (`sr`) against the exact run's (`er`), as JSON.
fn agree_as_json(sr: &serde_json::Value, er: &serde_json::Value) {
    // Counts, hence R(l_c), R_j and their intervals, and min/max: identical.
    for key in [
        "draws",
        "reliability",
        "per_point_reliability",
        "min",
        "max",
        "settings",
    ] {
        assert_eq!(sr[key], er[key], "{key}");
    }
    // Moments: the same sums merged chunk by chunk instead of in one pass; 1e-12 relative
    // is ~10^4 ulps, the rounding of 10^2 Chan/Pébay merges of 10^5-value sums.
    for key in ["mean", "variance", "skewness", "kurtosis"] {
        let (x, y) = (
            sr["moments"][key].as_f64().unwrap(),
            er["moments"][key].as_f64().unwrap(),
        );
        assert!(rel(x, y) < 1e-12, "{key}: {x} vs {y}");
    }
    // Interval (module documentation of summary): symmetric, the same ranks read from bins of
    // h = 1e-6 mm, each end within h/2; shortest, the width within 2h (where two intervals tie
    // within h the ends can move further).
    let end = |r: &serde_json::Value, key: &str| r["coverage_interval"][key].as_f64().unwrap();
    if er["settings"]["interval"] == "symmetric" {
        for key in ["low", "high"] {
            let (x, y) = (end(sr, key), end(er, key));
            assert!((x - y).abs() <= BIN_WIDTH / 2.0, "{key}: {x} vs {y}");
        }
    } else {
        let width = |r| end(r, "high") - end(r, "low");
        let (x, y) = (width(sr), width(er));
        assert!((x - y).abs() <= 2.0 * BIN_WIDTH, "width: {x} vs {y}");
    }
}

#[test]
fn summary_mode_refuses_a_limit_too_small_for_its_histogram() {
    let d = tmpdir("summary-small");
    let out = d.join("r.json").display().to_string();
    let base = [
        "mcs",
        "--points",
        "10",
        "--draws",
        "1000000",
        "--backend",
        "cpu",
        "-q",
    ];
    // The up-front estimate (one chunk, the points, 65 536 reserved bins) does not fit 2 MiB.
    let args = [&base[..], &["--memory-limit", "2M", "--json", &out]].concat();
    fails_leaving_nothing(&d, &args, "--memory-limit");
    // 6 MiB fits the estimate but not the ~1.2·10^5 bins 10^6 draws occupy: refused while
    // running, naming the histogram and the flag.
    let args = [&base[..], &["--memory-limit", "6M", "--json", &out]].concat();
    fails_leaving_nothing(&d, &args, "histogram");
    let o = run(&args);
    assert_fails_naming(&o, "--memory-limit", "raise the limit");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn cli_shard_from_an_indexed_job_and_inconsistent_variables() {
    let d = tmpdir("summary-env");
    let p = |name: &str| d.join(name).display().to_string();
    let base = [
        "mcs",
        "--points",
        "5",
        "--draws",
        "30000",
        "--backend",
        "cpu",
        "-q",
    ];
    let o = run(&[
        &base[..],
        &["--shard", "2/3", "--summary-out", &p("flag.json")],
    ]
    .concat());
    assert!(o.status.success(), "{}", common::stderr(&o));
    let o = bin()
        .args(base)
        .args(["--shards", "3", "--summary-out", &p("job.json")])
        .env("JOB_COMPLETION_INDEX", "2")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", common::stderr(&o));
    let (mut a, mut b) = (json(&d.join("job.json")), json(&d.join("flag.json")));
    a["seconds"] = 0.into();
    b["seconds"] = 0.into();
    assert_eq!(common::without_checksum(a), common::without_checksum(b));
    let o = bin()
        .args(base)
        .args(["--summary-out", &p("half.json")])
        .env("SLURM_ARRAY_TASK_ID", "1")
        .env_remove("SLURM_ARRAY_TASK_COUNT")
        .output()
        .unwrap();
    assert_fails_naming(
        &o,
        "SLURM_ARRAY_TASK_COUNT",
        "half a Slurm array's variables",
    );
    assert!(!d.join("half.json").exists());
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn sensitivity_shards_merge_to_the_single_run_bit_for_bit() {
    let d = tmpdir("summary-sens");
    let p = |name: &str| d.join(name).display().to_string();
    // 4096 base samples in chunks of 1024: 4 chunks, split 1 + 1 + 2.
    let base = [
        "sensitivity",
        "--points",
        "5",
        "--draws",
        "4096",
        "--bootstrap",
        "100",
        "--thresholds",
        "0.1",
        "--backend",
        "cpu",
        "-q",
    ];
    for k in 0..2 {
        let (shard, out) = (format!("{k}/3"), p(&format!("x{k}.json")));
        let o = run(&[&base[..], &["--shard", &shard, "--summary-out", &out]].concat());
        assert!(o.status.success(), "{}", common::stderr(&o));
    }
    let o = bin()
        .args(base)
        .args(["--summary-out", &p("x2.json")])
        .env("SLURM_ARRAY_TASK_ID", "2")
        .env("SLURM_ARRAY_TASK_COUNT", "3")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", common::stderr(&o));
    let o = run(&[&base[..], &["--json", &p("one.json")]].concat());
    assert!(o.status.success(), "{}", common::stderr(&o));
    let o = run(&[
        "merge",
        &p("x2.json"),
        &p("x0.json"),
        &p("x1.json"),
        "-q",
        "--json",
        &p("merged.json"),
    ]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    // The bootstrap's sums are centred on the mean of the whole range, so the shards keep their
    // outputs (as f64 bits) and the merge runs the one analysis: the same JSON, byte for byte.
    let one = std::fs::read_to_string(d.join("one.json")).unwrap();
    assert_eq!(std::fs::read_to_string(d.join("merged.json")).unwrap(), one);
    assert!(one.contains("\"first_order\""));

    let out = p("out.json");
    // Outputs tripled (every digit of the first output changed) and one digit of a bit
    // pattern changed: the content checksum refuses both.
    let text = std::fs::read_to_string(d.join("x1.json")).unwrap();
    let at = text.find("\"a\":[").unwrap() + "\"a\":[".len();
    let end = at + text[at..].find([',', ']']).unwrap();
    let value: f64 = text[at..end].parse().unwrap();
    let mut tripled = text.clone();
    tripled.replace_range(at..end, &(3.0 * value).to_string());
    std::fs::write(d.join("tripled.json"), &tripled).unwrap();
    fails_leaving_nothing(
        &d,
        &[
            "merge",
            &p("x0.json"),
            &p("tripled.json"),
            &p("x2.json"),
            "--json",
            &out,
        ],
        "tripled.json: not a summary: content checksum mismatch (edited or corrupted)",
    );
    let _ = std::fs::remove_file(d.join("tripled.json"));
    fails_leaving_nothing(
        &d,
        &["merge", &p("x0.json"), &p("x2.json"), "--json", &out],
        "x2.json: draws [2048, 4096) leave draws [1024, 2048) missing",
    );
    let other = run(&[&base[..], &["--seed", "7", "--shard", "1/3"]].concat());
    assert_fails_naming(&other, "--summary-out", "--shard alone");
    let o = run(&[
        &base[..],
        &[
            "--seed",
            "7",
            "--shard",
            "1/3",
            "--summary-out",
            &p("seed7.json"),
        ],
    ]
    .concat());
    assert!(o.status.success(), "{}", common::stderr(&o));
    fails_leaving_nothing(
        &d,
        &[
            "merge",
            &p("x0.json"),
            &p("seed7.json"),
            &p("x2.json"),
            "--json",
            &out,
        ],
        "seed7.json: field `seed` is 7",
    );
    let o = run(&[&base[..], &["--shard", "4/5", "--summary-out", &out]].concat());
    assert_fails_naming(&o, "--shard", "5 shards of 4 chunks");
    let o = run(&[&base[..], &["--summary-out", &out, "--json", &p("j.json")]].concat());
    assert_fails_naming(&o, "--json", "--summary-out with --json");
    let _ = std::fs::remove_dir_all(&d);
}

/// Shards that ran on different backends merge, and the report says so ("mixed: cpu (2
/// shards), gpu (1)") instead of naming the first shard's backend.
#[test]
fn mixed_backend_shards_are_reported_as_mixed() {
    if !common::have_adapter("mixed_backend_shards_are_reported_as_mixed") {
        return;
    }
    let d = tmpdir("summary-mixed");
    let p = |name: &str| d.join(name).display().to_string();
    let base = ["mcs", "--points", "5", "--draws", "30000", "-q"];
    for (k, backend) in ["cpu", "gpu", "cpu"].iter().enumerate() {
        let o = run(&[
            &base[..],
            &[
                "--backend",
                backend,
                "--shard",
                &format!("{k}/3"),
                "--summary-out",
                &p(&format!("m{k}.json")),
            ],
        ]
        .concat());
        assert!(o.status.success(), "{}", common::stderr(&o));
    }
    let o = run(&[
        "merge",
        &p("m0.json"),
        &p("m1.json"),
        &p("m2.json"),
        "--json",
        &p("r.json"),
    ]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(text.contains("mixed: cpu (2 shards), gpu (1)"), "{text}");
    let v = json(&d.join("r.json"));
    let b = &v["result"]["backend"]["backend"];
    assert_eq!(b, "mixed: cpu (2 shards), gpu (1)", "{v}");
    let _ = std::fs::remove_dir_all(&d);
}

/// The text of one small mcs summary (computed once).
fn summary_text() -> &'static str {
    static TEXT: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    TEXT.get_or_init(|| shards(5, &[3000])[0].1.to_json())
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig { cases: 400, ..Default::default() })]

    /// Any change of one byte (or a deleted or inserted byte) of a shard file is refused, unless
    /// it is trailing whitespace, which leaves the content as it was.
    #[test]
    fn mutated_shard_files_are_refused(
        pos in 0usize..100_000,
        byte in 0x20u8..0x7f,
        how in 0u8..3,
    ) {
        let text = summary_text();
        let mut b = text.as_bytes().to_vec();
        let at = pos % b.len();
        match how {
            0 => b[at] = byte,
            1 => { b.remove(at); }
            _ => b.insert(at, byte),
        }
        let Ok(t) = String::from_utf8(b) else { return Ok(()); };
        let original = Summary::from_json(text, "s.json").unwrap();
        match Summary::from_json(&t, "s.json") {
            Ok(s) => {
                proptest::prop_assert_eq!(&s, &original);
                proptest::prop_assert_eq!(t.trim_end(), text.trim_end());
            }
            Err(e) => {
                let e = e.to_string();
                proptest::prop_assert!(e.starts_with("s.json: not a summary: "), "{}", e);
            }
        }
    }
}
