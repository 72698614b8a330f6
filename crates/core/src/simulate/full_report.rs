//! The text of a [`FullCalibration`]: what the runs' checks beyond geometry (and of backlash)
//! found, what the full mean model carries, and the accuracy table before calibration, after the
//! geometric one and with the full model ([`super::full_model`]).

use super::full_model::{FullAccuracy, FullCalibration, RunAccuracy};
use crate::identify::chain::BeyondGeometry;

/// "a" or "a–b" (mm, four decimals) for the range of `v`.
fn range_mm(v: impl Iterator<Item = f64>) -> String {
    let (lo, hi) = v.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
        (a.min(x), b.max(x))
    });
    if hi - lo < 5e-5 {
        format!("{lo:.4}")
    } else {
        format!("{lo:.4}–{hi:.4}")
    }
}

/// What the runs' checks beyond geometry found and what the full mean model carries, one
/// paragraph.
pub fn render_full_calibration(cal: &FullCalibration) -> String {
    let checks: Vec<&BeyondGeometry> = cal.runs.iter().filter_map(|r| r.check.as_ref()).collect();
    let runs = cal.runs.len();
    let mut s = format!(
        "Beyond geometry ({}, each run {}): ",
        cal.mode.as_str(),
        cal.data.describe()
    );
    if checks.is_empty() {
        s.push_str("no run was checked");
    } else {
        let better = checks.iter().filter(|c| c.predicts_better).count();
        let for_gaps = cal
            .runs
            .iter()
            .filter(|r| r.kept_by_mode && r.check.as_ref().is_some_and(|c| !c.predicts_better))
            .count();
        s.push_str(&format!(
            "joint compliance and gear harmonics predict left-out points better in {better} of the {} runs checked (leave-one-out RMS {} mm against {} mm for the geometry alone), kept in {} of the {runs} runs{}",
            checks.len(),
            range_mm(checks.iter().map(|c| c.loo_rms_extended_mm)),
            range_mm(checks.iter().map(|c| c.loo_rms_geometric_mm)),
            cal.kept_by_mode(),
            match for_gaps {
                0 => String::new(),
                k => format!(" ({k} of them for the backlash gaps below, which ride with them)"),
            }
        ));
    }
    let redone = cal
        .runs
        .iter()
        .filter(|r| !r.kept_by_mode && r.full.joint_errors.is_some())
        .count();
    if cal.carries_joint_errors {
        s.push_str("; the mean model carries them: the runs' mean coefficients with their run-to-run covariance, drawn independently of the geometry");
        if redone > 0 {
            s.push_str(&format!(
                " ({redone} run(s) that did not keep them identified again keeping them, so that every run's model has them)"
            ));
        }
    } else {
        s.push_str(
            "; the mean model holds the geometry alone (every run's model is its geometric one)",
        );
    }
    s.push_str(".\n");
    push_backlash(&mut s, cal, &checks);
    s
}

/// What the runs' backlash checks found and whether the mean model carries gaps, one sentence
/// (nothing when no run checked them).
fn push_backlash(s: &mut String, cal: &FullCalibration, checks: &[&BeyondGeometry]) {
    let lash: Vec<_> = checks.iter().filter_map(|c| c.backlash.as_ref()).collect();
    if lash.is_empty() {
        if checks.iter().any(|c| c.sides_unchecked) {
            s.push_str(&format!(
                "Backlash: the runs' poses record the side each joint arrived from, but the {} mode checks no gaps (the explicit check fits them), so no model carries them.\n",
                cal.mode.as_str()
            ));
        }
        return;
    }
    let kept = cal
        .runs
        .iter()
        .filter(|r| {
            r.full
                .joint_errors
                .as_ref()
                .is_some_and(|e| e.backlash.is_some())
        })
        .count();
    let better = lash.iter().filter(|b| b.predicts_better).count();
    s.push_str(&format!(
        "Backlash (each joint's side from the order of the run's poses, recorded in the data): the gaps predict left-out points better in {better} of the {} runs checked (leave-one-out RMS {} mm), kept in {kept} of the {} runs",
        lash.len(),
        range_mm(lash.iter().map(|b| b.loo_rms_mm)),
        cal.runs.len()
    ));
    let mean = cal
        .full
        .independent
        .joint_errors
        .as_ref()
        .and_then(|e| e.backlash.as_ref());
    match mean {
        Some(b) => {
            let gaps: Vec<String> = b
                .gap_rad
                .iter()
                .zip(&b.sigma_rad)
                .enumerate()
                .map(|(j, (g, u))| {
                    format!("J{} {:.4}±{:.4}", j + 1, g.to_degrees(), u.to_degrees())
                })
                .collect();
            s.push_str(&format!(
                "; the mean model carries the runs' mean gaps (°, ± the larger of their run-to-run spread and a run's σ: {}) and draws each joint's side at points whose sides are not given. The test poses below are visited in their order, and each model predicts them with the sides they were reached from.\n",
                gaps.join(", ")
            ));
        }
        None if kept > 0 => s.push_str(
            "; the mean model carries no gaps (only gaps every run kept ride with it).\n",
        ),
        None => s.push_str("; the mean model carries no gaps.\n"),
    }
}

/// The accuracy table: before calibration, then per run and for the mean models the geometric
/// and the full model's errors, and the shares.
pub fn render_full_accuracy(cal: &FullCalibration, acc: &FullAccuracy) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Positioning error at {} test poses of the true robot (mm): before calibration, geometric calibration (the same {} identified with the geometry alone), full model (with joint errors when kept)",
        acc.nominal.points,
        cal.data.describe()
    );
    let _ = writeln!(
        s,
        "{:<16} {:>9} {:>9} {:>9}   {:>9} {:>9} {:>9}   joint errors",
        "", "geometric", "", "", "full", "", ""
    );
    let _ = writeln!(
        s,
        "{:<16} {:>9} {:>9} {:>9}   {:>9} {:>9} {:>9}",
        "model", "mean", "rms", "max", "mean", "rms", "max"
    );
    let _ = writeln!(
        s,
        "{:<16} {:>9.4} {:>9.4} {:>9.4}   (before calibration: the nominal model)",
        "nominal", acc.nominal.mean_mm, acc.nominal.rms_mm, acc.nominal.max_mm
    );
    let row = |s: &mut String, name: &str, a: &RunAccuracy, kept: bool| {
        let _ = writeln!(
            s,
            "{:<16} {:>9.4} {:>9.4} {:>9.4}   {:>9.4} {:>9.4} {:>9.4}   {}",
            name,
            a.geometric.mean_mm,
            a.geometric.rms_mm,
            a.geometric.max_mm,
            a.full.mean_mm,
            a.full.rms_mm,
            a.full.max_mm,
            if kept { "carried" } else { "none" }
        );
    };
    for (k, (r, a)) in cal.runs.iter().zip(&acc.runs).enumerate() {
        row(
            &mut s,
            &format!("run {}", k + 1),
            a,
            r.full.joint_errors.is_some(),
        );
    }
    row(
        &mut s,
        &format!("mean of {}", cal.runs.len()),
        &acc.mean,
        cal.carries_joint_errors,
    );
    let _ = writeln!(
        s,
        "The geometric calibration leaves {:.1} % of the error before calibration (mean); the full model leaves {:.1} % of the geometric calibration's ({:.1} % of the error before).",
        100.0 * acc.geometric_share(),
        100.0 * acc.full_share(),
        100.0 * acc.mean.full.mean_mm / acc.nominal.mean_mm
    );
    if cal.carries_joint_errors && acc.mean.full.mean_mm > acc.mean.geometric.mean_mm {
        let _ = writeln!(
            s,
            "The joint errors these runs determine predict the test poses worse than the geometry alone: their data do not determine them over the workspace (the check on the calibration's own points does not see it; left-out points of a sweep lie between measured neighbours, with one joint moving at a time)."
        );
    }
    s
}
