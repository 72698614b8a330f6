//! Property tests of the parsers as a user meets them: random and mutated model files, points
//! CSV files and flag values never panic; a run either succeeds and writes its output, or exits
//! with code 2, one stderr line and no file left behind. The binary is spawned per case, so the
//! case counts are modest.

use crate::common;

use common::*;
use proptest::prelude::*;
use std::path::Path;
use std::process::Output;

/// Bytes a mutation inserts: the syntax of TOML and CSV, digits, and troublesome words.
const PIECES: &[&str] = &[
    "0",
    "1",
    "-",
    ".",
    "e",
    "9",
    ",",
    "=",
    "\"",
    "[",
    "]",
    "{",
    "}",
    "\n",
    "\r\n",
    " ",
    "#",
    "nan",
    "inf",
    "-inf",
    "1e400",
    "18446744073709551615",
    "é",
    "\u{0}",
    "theta",
    "sigma",
];

/// Either a success that wrote `out` and nothing else, or exit 2 with one line and no files
/// but `keep`.
fn check(o: &Output, dir: &Path, keep: &str, out: &str, label: &str) {
    let e = stderr(o);
    assert!(!e.contains("panicked"), "{label}: panic: {e}");
    let mut left = tree(dir);
    left.retain(|f| f != keep);
    if o.status.success() {
        assert_eq!(left, vec![out.to_string()], "{label}: files after success");
    } else {
        assert_eq!(
            o.status.code(),
            Some(2),
            "{label}: exit {:?}: {e}",
            o.status
        );
        assert_eq!(e.trim().lines().count(), 1, "{label}: not one line: {e}");
        assert!(left.is_empty(), "{label}: left {left:?} after an error");
    }
}

/// Applies `(position, delete length, inserted pieces)` edits to `text` (on char boundaries).
fn mutate(text: &str, edits: &[(usize, usize, Vec<usize>)]) -> String {
    let mut chars: Vec<char> = text.chars().collect();
    for (pos, del, ins) in edits {
        let at = pos % (chars.len() + 1);
        let end = (at + del).min(chars.len());
        let piece: String = ins.iter().map(|i| PIECES[i % PIECES.len()]).collect();
        chars.splice(at..end, piece.chars());
    }
    chars.into_iter().collect()
}

fn edits() -> impl Strategy<Value = Vec<(usize, usize, Vec<usize>)>> {
    prop::collection::vec(
        (
            any::<usize>(),
            0usize..8,
            prop::collection::vec(any::<usize>(), 0..4),
        ),
        1..4,
    )
}

fn value() -> impl Strategy<Value = String> {
    prop_oneof![
        prop::collection::vec(prop::sample::select(&PIECES[..12]), 0..6).prop_map(|v| v.concat()),
        prop::sample::select(PIECES).prop_map(str::to_string),
        (-5i64..100_000).prop_map(|v| v.to_string()),
        (-2.0f64..2.0).prop_map(|v| v.to_string()),
    ]
    // A command-line argument cannot hold a NUL byte.
    .prop_map(|v| v.replace('\0', ""))
}

fn model_text() -> String {
    stdout(&run(&["model"]))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn mutated_model_files(e in edits()) {
        let d = tmpdir("fuzz-model");
        let text = mutate(&model_text(), &e);
        std::fs::write(d.join("m.toml"), &text).unwrap();
        let o = run(&["points", "2", "--model", &arg(&d, "m.toml"), "-o", &arg(&d, "p.csv")]);
        check(&o, &d, "m.toml", "p.csv", &format!("model edits {e:?}"));
    }

    #[test]
    fn mutated_points_files(e in edits()) {
        let d = tmpdir("fuzz-points");
        let good = "q1,q2,q3,q4,q5,q6\n0,10,20,0,30,0\n10,-20,30,5,-40,90\n";
        let text = mutate(good, &e);
        std::fs::write(d.join("p.csv"), &text).unwrap();
        let o = run(&[
            "mcs", "-q", "--backend", "cpu", "--draws", "200", "--coverage", "0.5",
            "--points-file", &arg(&d, "p.csv"), "--json", &arg(&d, "r.json"),
        ]);
        check(&o, &d, "p.csv", "r.json", &format!("points edits {e:?}: {text:?}"));
    }

    #[test]
    fn random_mcs_flag_values(
        flag in prop::sample::select(&[
            "--coverage", "--draws", "--thresholds", "--box-center", "--box-size", "--points",
            "--seed", "--memory-limit", "--points-seed",
        ][..]),
        v in value(),
    ) {
        let d = tmpdir("fuzz-mcs");
        let set = format!("{flag}={v}");
        let o = run(&[
            "mcs", "-q", "--backend", "cpu", "--draws", "200", "--coverage", "0.5",
            "--points", "3", "--memory-limit", "64M", &set, "--json", &arg(&d, "r.json"),
        ]);
        check(&o, &d, "", "r.json", &set);
    }

    #[test]
    fn random_amcs_flag_values(
        flag in prop::sample::select(&[
            "--delta", "--ndig", "--batch", "--max-draws", "--coverage", "--thresholds",
        ][..]),
        v in value(),
    ) {
        let d = tmpdir("fuzz-amcs");
        let set = format!("{flag}={v}");
        let mut args = vec![
            "-q", "--backend", "cpu", "--points", "3", "--coverage", "0.5", "--batch", "1000",
            "--max-draws", "4000", "--memory-limit", "64M",
        ];
        let json = arg(&d, "r.json");
        args.extend([set.as_str(), "--json", &json]);
        let o = run(&args);
        check(&o, &d, "", "r.json", &set);
    }
}
