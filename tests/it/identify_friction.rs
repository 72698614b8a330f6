//! `identify` on a new user's data (issue 34): the HTML report of pose data shows only the
//! sections that apply (no circle fits, no "-inf"), and data the default TX60 cannot take are
//! refused with what to pass instead.

use crate::common::{run, stderr, tmpdir};
use std::path::{Path, PathBuf};

/// Runs `line` (split at spaces) and asserts success.
fn ok(line: &str) {
    let args: Vec<&str> = line.split(' ').collect();
    let o = run(&args);
    assert!(o.status.success(), "{line}: {}", stderr(&o));
}

/// `dir/name` as a string (scratch paths have no spaces).
fn at(dir: &Path, name: &str) -> String {
    let p: PathBuf = dir.join(name);
    p.to_str().unwrap().to_string()
}

/// The page of a pose identification opens with the whole-chain fit: no circle-fit summary
/// (it read "largest circle-fit RMS residual -inf mm"), no empty circle-fit or MDH tables, no
/// empty figure and no link to the empty circle-fit files; the page of sweeps keeps them.
#[test]
fn identify_page_shows_the_sections_of_its_data() {
    let d = tmpdir("identify-page-sections");
    ok(&format!(
        "simulate --poses 40 --seed 5 -o {}",
        at(&d, "poses.csv")
    ));
    ok(&format!(
        "identify {} -q -o {} --html {}",
        at(&d, "poses.csv"),
        at(&d, "m.toml"),
        at(&d, "poses-report")
    ));
    let page = std::fs::read_to_string(d.join("poses-report/index.html")).unwrap();
    for absent in [
        "inf mm",
        "circle-fit",
        "Circle fit",
        "MDH parameters per run and joint",
        "J1 tilt",
        "./residuals.svg",
        "./joints.csv",
    ] {
        assert!(!page.contains(absent), "pose page shows '{absent}'");
    }
    for present in [
        "poses (whole-chain fit)",
        "Whole-chain fit and uncertainty",
        "pose_residuals.svg",
        "parameters.csv",
    ] {
        assert!(page.contains(present), "pose page lacks '{present}'");
    }
    // The circle-fit files are still written (the report's files are planned before the run).
    assert!(d.join("poses-report/residuals.svg").exists());

    ok(&format!("simulate --runs 2 -o {}", at(&d, "sweeps.csv")));
    ok(&format!(
        "identify {} -q -o {} --html {}",
        at(&d, "sweeps.csv"),
        at(&d, "s.toml"),
        at(&d, "sweeps-report")
    ));
    let page = std::fs::read_to_string(d.join("sweeps-report/index.html")).unwrap();
    for present in [
        "largest circle-fit RMS residual",
        "Circle fits",
        "MDH parameters per run and joint",
        "./residuals.svg",
        "./joints.csv",
    ] {
        assert!(page.contains(present), "sweep page lacks '{present}'");
    }
    assert!(!page.contains("inf mm"), "sweep page: an infinite residual");
}

/// Data the default nominal (TX60) cannot take — a UR5e's angles past its limits, a
/// seven-joint arm — are refused naming the presets that take them; an explicit preset that
/// does not fit names them too; data the TX60 takes are identified as before.
#[test]
fn identify_says_what_to_pass_where_the_tx60_default_does_not_fit() {
    let d = tmpdir("identify-default-nominal");
    let ur = at(&d, "ur.csv");
    ok(&format!(
        "simulate --preset ur5e --poses 40 --seed 3 -o {ur}"
    ));
    let o = run(&["identify", &ur, "-o", &at(&d, "m.toml")]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert_eq!(e.trim_end().lines().count(), 1, "{e}");
    for part in [
        "outside the joint limits",
        "built-in Staubli TX60 when neither --nominal nor --preset is given",
        "the presets ur5e, ur10e take these data",
        "--preset ur5e",
        "--nominal FILE",
    ] {
        assert!(e.contains(part), "lacks '{part}': {e}");
    }
    assert!(!d.join("m.toml").exists());

    let o = run(&["identify", &ur, "--preset", "irb2400"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains(
            "the nominal model is the preset ABB IRB 2400; the presets ur5e, ur10e take these data"
        ),
        "{}",
        stderr(&o)
    );

    let iiwa = at(&d, "iiwa.csv");
    ok(&format!(
        "simulate --preset iiwa14 --poses 40 --seed 3 -o {iiwa}"
    ));
    let o = run(&["identify", &iiwa]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("the preset iiwa14 takes these data: pass --preset iiwa14"),
        "{}",
        stderr(&o)
    );
    ok(&format!("identify {iiwa} --preset iiwa14 -q"));
}
