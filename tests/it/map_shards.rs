//! Shards of a workspace reliability map (`map --shard K/N --summary-out FILE`, then `merge`):
//! a map split into 1, 3 or 7 shards merges to the one-run map bit for bit (JSON apart from the
//! timings, CSV byte for byte), whatever the order of the files; a Slurm array task is the shard
//! its index names; the merge refuses shards of another seed, a missing or duplicated shard, a
//! truncated or edited file and a map shard mixed with an mcs summary, in one line naming the
//! file; a shard's memory estimate counts only its own cells, so a map over the limit of one
//! process runs in shards.

use crate::common;

use common::{arg, assert_fails_naming, bin, fails_leaving_nothing, have_adapter, run, tmpdir};
use gpu_amcs::engine::{BackendChoice, Problem, Reference};
use gpu_amcs::kinematics::{tx60, Joints};
use gpu_amcs::map::shard::{self, MapShard};
use gpu_amcs::map::{
    batch_size, default_reference_deg, evaluate, evaluate_cells, memory_estimate, test_points,
    tool_down_rpy_deg, Grid, MapResult, MapSpec, Plane, Timings,
};
use gpu_amcs::mc::summary::Provenance;
use gpu_amcs::points::WorkspaceBox;
use std::path::Path;

/// The map every test splits: TX60, a 12 × 10 xz plane through the base, 2000 draws, CPU.
const MAP: [&str; 14] = [
    "map",
    "--plane",
    "xz",
    "--at",
    "0",
    "--cells",
    "12,10",
    "--draws",
    "2000",
    "--thresholds",
    "0.05,0.1,0.15",
    "--backend",
    "cpu",
    "-q",
];

/// A JSON report without its timings.
fn untimed(path: &Path) -> serde_json::Value {
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let t = v["map"]["timings"].take();
    assert!(t["eval_seconds"].is_number(), "{path:?} has no timings");
    v
}

/// Runs shard `k` of `n` of [`MAP`] (with `extra` flags) into `out`.
fn shard_run(k: usize, n: usize, out: &str, extra: &[&str]) {
    let s = format!("{k}/{n}");
    let o = run(&[&MAP[..], extra, &["--shard", &s, "--summary-out", out]].concat());
    assert!(o.status.success(), "{}", common::stderr(&o));
}

/// Merges `files` (in that order) into `json` and `csv`.
fn merge(files: &[String], json: &str, csv: &str) {
    let mut a = vec!["merge", "-q", "--json", json, "--csv", csv];
    a.extend(files.iter().map(String::as_str));
    let o = run(&a);
    assert!(o.status.success(), "{}", common::stderr(&o));
}

#[test]
fn one_three_and_seven_shards_merge_to_the_one_run_map() {
    let d = tmpdir("map-shards");
    let p = |name: &str| arg(&d, name);
    let o = run(&[&MAP[..], &["--json", &p("one.json"), "--csv", &p("one")]].concat());
    assert!(o.status.success(), "{}", common::stderr(&o));
    let one = untimed(&d.join("one.json"));
    let reached = one["map"]["reached"].as_u64().unwrap();
    // Some cells are unreachable, so the shards' ranges of reached cells are not the grid's.
    assert!(reached > 20 && reached < 120, "{reached}");
    let one_csv = std::fs::read_to_string(d.join("one/map.csv")).unwrap();
    for n in [1, 3, 7] {
        let files: Vec<String> = (0..n).map(|k| p(&format!("n{n}-{k}.json"))).collect();
        for (k, f) in files.iter().enumerate() {
            shard_run(k, n, f, &[]);
        }
        // Reversed and rotated: the order on the command line does not matter.
        let mut reversed = files.clone();
        reversed.reverse();
        let mut rotated = files.clone();
        rotated.rotate_left(n / 2);
        for (tag, order) in [("r", &reversed), ("o", &rotated)] {
            let (json, csv) = (p(&format!("m{n}{tag}.json")), p(&format!("m{n}{tag}")));
            merge(order, &json, &csv);
            assert_eq!(untimed(Path::new(&json)), one, "{n} shards, order {tag}");
            let merged_csv = std::fs::read_to_string(Path::new(&csv).join("map.csv")).unwrap();
            assert_eq!(merged_csv, one_csv, "{n} shards, order {tag}: CSV");
        }
        // Both orders give the same file, timings included.
        assert_eq!(
            std::fs::read_to_string(p(&format!("m{n}r.json"))).unwrap(),
            std::fs::read_to_string(p(&format!("m{n}o.json"))).unwrap()
        );
    }
    // A Slurm array task (indices 1..3) without --shard is shard 1 of 3.
    let o = bin()
        .args(MAP)
        .args(["--summary-out", &p("slurm.json")])
        .env("SLURM_ARRAY_TASK_ID", "2")
        .env("SLURM_ARRAY_TASK_MIN", "1")
        .env("SLURM_ARRAY_TASK_COUNT", "3")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", common::stderr(&o));
    let shard_of = |f: &str| {
        let mut v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(p(f)).unwrap()).unwrap();
        let t = v["timings"].take();
        assert!(t.is_object());
        v.as_object_mut().unwrap().remove("float_bits");
        common::without_checksum(v)
    };
    assert_eq!(shard_of("slurm.json"), shard_of("n3-1.json"));
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn merge_refuses_foreign_missing_duplicated_corrupt_and_mixed_files() {
    let d = tmpdir("map-shards-bad");
    let p = |name: &str| arg(&d, name);
    for k in 0..3 {
        shard_run(k, 3, &p(&format!("s{k}.json")), &[]);
    }
    shard_run(1, 3, &p("seed7.json"), &["--seed", "7"]);
    shard_run(1, 3, &p("coarse.json"), &["--thresholds", "0.05,0.1"]);
    let o = run(&[
        "mcs",
        "--points",
        "5",
        "--draws",
        "2000",
        "--backend",
        "cpu",
        "-q",
        "--shard",
        "0/1",
        "--summary-out",
        &p("mcs.json"),
    ]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    let text = std::fs::read_to_string(p("s1.json")).unwrap();
    std::fs::write(p("truncated.json"), &text[..text.len() / 2]).unwrap();
    // One statistic changed in its readable number: the number and its bits disagree.
    let at = text.find("\"mean_mm\":0.").unwrap() + "\"mean_mm\":0.".len();
    let mut edited = text.clone();
    let digit = if &text[at..at + 1] == "9" { "1" } else { "9" };
    edited.replace_range(at..at + 1, digit);
    std::fs::write(p("edited.json"), common::reseal(&edited)).unwrap();
    // The same edit without a new checksum, and one hex digit of w changed: the content
    // checksum refuses both before reading anything else.
    std::fs::write(p("digit.json"), &edited).unwrap();
    let w0 = text.find("\"w_bits\":\"").unwrap() + "\"w_bits\":\"".len() + 15;
    let mut w_digit = text.clone();
    let d15 = if &text[w0..w0 + 1] == "0" { "1" } else { "0" };
    w_digit.replace_range(w0..w0 + 1, d15);
    std::fs::write(p("w_digit.json"), &w_digit).unwrap();
    // A w bit pattern that is not a finite non-negative error, and one digit too few.
    let w_at = text.find("\"w_bits\":\"").unwrap() + "\"w_bits\":\"".len();
    let mut bad_w = text.clone();
    bad_w.replace_range(w_at..w_at + 16, &format!("{:016x}", f64::NAN.to_bits()));
    std::fs::write(p("nan.json"), common::reseal(&bad_w)).unwrap();
    let mut short_w = text.clone();
    short_w.remove(w_at);
    std::fs::write(p("short.json"), common::reseal(&short_w)).unwrap();
    let out = p("out.json");
    let cases: &[(&[&str], &str)] = &[
        (
            &["s0.json", "seed7.json", "s2.json"],
            "seed7.json: field `seed` is 7",
        ),
        (
            &["s0.json", "coarse.json", "s2.json"],
            "coarse.json: field `thresholds`",
        ),
        (&["s0.json", "s2.json"], "s2.json: reached cells ["),
        (&["s0.json", "s2.json"], "missing"),
        (&["s0.json", "s1.json"], "s1.json: reached cells ["),
        (
            &["s0.json", "s1.json", "s1.json", "s2.json"],
            "s1.json: reached cells [",
        ),
        (&["s0.json", "s1.json", "s1.json", "s2.json"], "overlap"),
        (
            &["s0.json", "truncated.json", "s2.json"],
            "truncated.json: not a summary",
        ),
        (
            &["s0.json", "edited.json", "s2.json"],
            "edited.json: not a summary: field `float_bits`",
        ),
        (
            &["s0.json", "digit.json", "s2.json"],
            "digit.json: not a summary: content checksum mismatch (edited or corrupted)",
        ),
        (
            &["s0.json", "w_digit.json", "s2.json"],
            "w_digit.json: not a summary: content checksum mismatch (edited or corrupted)",
        ),
        (
            &["s0.json", "nan.json", "s2.json"],
            "nan.json: not a summary: field `w_bits`",
        ),
        (
            &["s0.json", "short.json", "s2.json"],
            "short.json: not a summary: not 16 hex digits",
        ),
        (
            &["s0.json", "mcs.json", "s2.json"],
            "mcs.json: an mcs summary, but",
        ),
        (&["mcs.json", "s0.json"], "s0.json: a map shard, but"),
    ];
    for (files, what) in cases {
        let mut a: Vec<String> = vec!["merge".into(), "--json".into(), out.clone()];
        a.extend(files.iter().map(|f| p(f)));
        let refs: Vec<&str> = a.iter().map(String::as_str).collect();
        fails_leaving_nothing(&d, &refs, what);
    }
    // The shard flags: K < N, no more shards than reached cells, a file to write, no reports.
    let o = run(&[&MAP[..], &["--shard", "3/3", "--summary-out", &out]].concat());
    assert_fails_naming(&o, "--shard", "shard 3/3");
    let o = run(&[&MAP[..], &["--shard", "0/119", "--summary-out", &out]].concat());
    assert_fails_naming(&o, "leave some empty", "119 shards");
    let o = run(&[&MAP[..], &["--shard", "0/3"]].concat());
    assert_fails_naming(&o, "--summary-out", "--shard alone");
    let o = run(&[
        &MAP[..],
        &[
            "--shard",
            "0/3",
            "--summary-out",
            &out,
            "--json",
            &p("j.json"),
        ],
    ]
    .concat());
    assert_fails_naming(&o, "--json", "--summary-out with --json");
    assert!(!Path::new(&out).exists());
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_shard_needs_memory_for_its_own_cells_only() {
    // The estimate: a shard keeps the errors of its cells (× draws), not of the grid's.
    let (cells, draws) = (120usize, 2000u64);
    let bytes = |e: usize| {
        memory_estimate(cells, e, draws, batch_size(e, draws))
            .bytes
            .unwrap()
    };
    let (whole, third) = (bytes(cells), bytes(cells / 3));
    assert_eq!(
        whole - third,
        (cells - cells / 3) as u64 * draws * 8 + 2000 * (cells - cells / 3) as u64 * 16,
        "the difference is the errors and the batch of the cells a shard leaves out"
    );
    // Whole: 6.1 MiB with its JSON report, over a 3 MiB limit; the refusal says how many
    // shards (which write summaries only) fit.
    let d = tmpdir("map-shards-memory");
    let p = |name: &str| arg(&d, name);
    fails_leaving_nothing(
        &d,
        &[
            &MAP[..],
            &["--memory-limit", "3M", "--json", &p("one.json")],
        ]
        .concat(),
        "split it into 2 or more shards (--shard K/2",
    );
    // A third of the cells fits: the shards run under the limit that refused the whole map and
    // merge to the map one unlimited run gives.
    let files: Vec<String> = (0..3).map(|k| p(&format!("s{k}.json"))).collect();
    for (k, f) in files.iter().enumerate() {
        shard_run(k, 3, f, &["--memory-limit", "3M"]);
    }
    merge(&files, &p("m.json"), &p("m"));
    let o = run(&[&MAP[..], &["--json", &p("one.json")]].concat());
    assert!(o.status.success(), "{}", common::stderr(&o));
    assert_eq!(untimed(&d.join("m.json")), untimed(&d.join("one.json")));
    // Too many cells for one shard of any split: no shard count is offered.
    let o = run(&[&MAP[..], &["--memory-limit", "10K", "--json", &p("x.json")]].concat());
    assert_fails_naming(&o, "raise the memory limit", "10K");
    assert!(!common::stderr(&o).contains("--shard"));
    let _ = std::fs::remove_dir_all(&d);
}

/// The library path on `backend`: shards written as JSON, read back and merged, against one
/// evaluation of all reached cells (whole results compared, timings set alike).
fn library_shards_match(backend: BackendChoice, n: usize) {
    let m = tx60();
    let spec = MapSpec {
        grid: Grid::Plane {
            plane: Plane::Xy,
            at: 287.3,
            cells: [9, 7],
        },
        workspace: WorkspaceBox {
            center: [251.7, -3.3, 310.1],
            size: [777.7, 913.1, 500.3],
        },
        orientation_rpy_deg: Some(tool_down_rpy_deg(&m)),
        reference_q_deg: default_reference_deg(&m),
        ik_seeds: 8,
    };
    let (seed, draws, thresholds) = (11, 1500u64, [0.04, 0.08]);
    let sol = spec.solve(&m).unwrap();
    let points = test_points(&sol);
    let r = points.len();
    assert!(r > n, "{r}");
    let pb = |pts: &[Joints]| Problem::new(m.clone(), pts, &Reference::Calibrated, seed).unwrap();
    let (mut ev, _) = gpu_amcs::backends()
        .make_evaluator(pb(&points), backend, None)
        .unwrap();
    let info = ev.info();
    let eval = evaluate(ev.as_mut(), draws, 700, &thresholds, None).unwrap();
    let one = MapResult::new(
        &m.name,
        &spec,
        seed,
        sol.clone(),
        eval,
        info,
        Timings::default(),
    );
    let prov = Provenance::new(&pb(&points), "calibrated model", draws, 0, draws);
    let mut named = Vec::new();
    for k in 0..n {
        let (first, end) = (k * r / n, (k + 1) * r / n);
        let (mut ev, _) = gpu_amcs::backends()
            .make_evaluator(pb(&points[first..end]), backend, None)
            .unwrap();
        // A batch unlike the one run's: the draws do not depend on it.
        let errors = evaluate_cells(ev.as_mut(), draws, 333, &thresholds, None).unwrap();
        let s = MapShard::new(
            prov.clone(),
            [k as u64, n as u64],
            &spec,
            &thresholds,
            &sol,
            (first, end),
            errors,
            ev.info(),
            Timings::default(),
        );
        let file = format!("shard{k}.json");
        named.push((
            file.clone(),
            MapShard::from_json(&s.to_json(), &file).unwrap(),
        ));
        assert_eq!(named[k].1, s, "shard {k} reads back to the bit");
    }
    named.reverse();
    let merged = shard::merge(&named).unwrap();
    assert_eq!(merged, one, "{backend:?}, {n} shards");
}

#[test]
fn library_shards_read_back_exactly_and_merge_to_one_evaluation() {
    library_shards_match(BackendChoice::Cpu, 5);
}

#[test]
fn gpu_shards_merge_to_the_gpu_run() {
    if !have_adapter("gpu_shards_merge_to_the_gpu_run") {
        return;
    }
    library_shards_match(BackendChoice::Gpu, 4);
}
