//! The terminal renderings of identification and validation: one run
//! ([`render_identify_report`]), all runs ([`render_identify_summary`]) and a validation
//! ([`render_validation`]).

use crate::identify::{sweeps, AccuracyStats, IdentifyReport, Validation};
use crate::kinematics::ParamKind;
use std::fmt::Write as _;

/// Formats the per-joint table of an identification for the terminal.
pub fn render_identify_report(report: &IdentifyReport) -> String {
    let mut s = String::new();
    let run = sweeps::run_label(report.run.as_deref());
    if report.joints.is_empty() {
        let _ = writeln!(s, "Identification{run}, pose data");
        if let Some(c) = &report.chain {
            s.push_str(&crate::identify::render_chain_report(c));
        }
        return s;
    }
    let _ = writeln!(
        s,
        "Identification{run}, {} circle fit",
        report.method.name()
    );
    write_fit_table(&mut s, report);
    write_parameter_table(&mut s, report);
    // The last joint (J6 of a six-axis arm) keeps its nominal parameters.
    let last = report.joints.len();
    let t = report.tool_mm;
    let n = report.nominal_tool_mm;
    let _ = writeln!(
        s,
        "\nTool point (flange frame): ({:.4}, {:.4}, {:.4}) mm, nominal ({:.4}, {:.4}, {:.4}) mm",
        t[0], t[1], t[2], n[0], n[1], n[2]
    );
    let _ = writeln!(
        s,
        "J{last}: theta, d, a, alpha kept nominal; the tool point absorbs the rest."
    );
    let _ = writeln!(
        s,
        "J1 measured axis vs base z: tilt {:.4} deg, offset {:.4} mm (the model takes base z as J1's axis)",
        report.j1_tilt_deg, report.j1_offset_mm
    );
    if let Some(c) = &report.chain {
        let _ = writeln!(s);
        s.push_str(&crate::identify::render_chain_report(c));
    }
    s
}

/// Formats a short summary of the runs of an identification for the terminal: the number of runs,
/// and per joint its points, arc and the worst circle-fit RMS residual over the runs (with the
/// run it came from), and the mean identified tool point. [`render_identify_report`] gives the
/// full detail of one run.
pub fn render_identify_summary<'a>(
    reports: impl IntoIterator<Item = &'a IdentifyReport>,
) -> String {
    let reports: Vec<&IdentifyReport> = reports.into_iter().collect();
    let mut s = String::new();
    let Some(first) = reports.first() else {
        return s;
    };
    let n = reports.len();
    let runs = if n == 1 {
        "1 run".to_string()
    } else {
        format!("{n} runs")
    };
    if first.joints.is_empty() {
        let _ = writeln!(s, "Identified {runs} from pose data");
    } else {
        let _ = writeln!(s, "Identified {runs}, {} circle fit", first.method.name());
    }
    write_worst_fits(&mut s, &reports);
    let mut tool = [0.0; 3];
    for r in &reports {
        for (t, v) in tool.iter_mut().zip(&r.tool_mm) {
            *t += v / n as f64;
        }
    }
    let _ = writeln!(
        s,
        "Tool point (flange frame){}: ({:.4}, {:.4}, {:.4}) mm",
        if n == 1 { "" } else { ", mean of the runs" },
        tool[0],
        tool[1],
        tool[2]
    );
    write_chains_summary(&mut s, &reports);
    if !first.joints.is_empty() {
        s.push_str(SWEEPS_SEE_ALONG_THEM);
    }
    s
}

/// What sweeps cannot show (docs/METHOD.md §18.1): measured on a purely geometric simulated
/// TX60 at the paper's baseline, the 95 % bound of the 20 runs' model covered 57 % of 200
/// random poses.
const SWEEPS_SEE_ALONG_THEM: &str = "Sweeps show what the model misses along them, not what an \
     error repeated in every run (backlash, lost motion under gravity) does to poses elsewhere: \
     before trusting the reliability there, measure some poses spread over the workspace, \
     check the model against them and draw its discrepancy term from their errors (on a \
     simulated TX60 at the paper's baseline its 95 % bound covered 57 % of such poses, 97.5 % \
     with the term from 60 others).\n";

/// The circle fit of each joint's sweep, a line per joint.
fn write_fit_table(s: &mut String, report: &IdentifyReport) {
    let _ = writeln!(
        s,
        "{:>3} {:>6} {:>9} {:>11} {:>10} {:>10} {:>10}",
        "J", "points", "arc deg", "radius mm", "rms mm", "max mm", "axis∠ deg"
    );
    for j in &report.joints {
        let angle = j
            .axis_angle_deg
            .map(|a| format!("{a:.4}"))
            .unwrap_or_else(|| "-".into());
        let _ = writeln!(
            s,
            "{:>3} {:>6} {:>9.2} {:>11.4} {:>10.5} {:>10.5} {:>10}",
            j.joint,
            j.points,
            j.arc_span_deg,
            j.radius_mm,
            j.rms_residual_mm,
            j.max_residual_mm,
            angle
        );
    }
}

/// The identified parameters of each joint (and their change from nominal), a line per joint.
fn write_parameter_table(s: &mut String, report: &IdentifyReport) {
    let _ = writeln!(
        s,
        "\nParameters: identified (identified − nominal); mm and deg; [fixed] = held fixed"
    );
    let _ = writeln!(
        s,
        "{:>3} {:>24} {:>24} {:>24} {:>24} {:>24}",
        "J", "theta", "d", "a", "alpha", "beta"
    );
    // One entry per joint: the last (J6 of a six-axis arm) keeps its nominal parameters.
    let last = report.joints.len();
    for j in &report.joints {
        let mut row = format!("{:>3}", j.joint);
        for (k, kind) in ParamKind::ALL.iter().enumerate() {
            let fixed = j.fixed.kind() == *kind || j.joint == last;
            let cell = if fixed {
                format!("{:.4} [fixed]", j.identified[k])
            } else {
                format!(
                    "{:.4} ({:+.4})",
                    j.identified[k],
                    j.identified[k] - j.nominal[k]
                )
            };
            let _ = write!(row, " {cell:>24}");
        }
        let _ = writeln!(s, "{row}");
    }
}

/// Per joint of the first run: its points and arc, and the worst circle-fit RMS residual over
/// the runs with the run it came from.
fn write_worst_fits(s: &mut String, reports: &[&IdentifyReport]) {
    let Some(first) = reports.first() else {
        return;
    };
    if !first.joints.is_empty() {
        let _ = writeln!(
            s,
            "{:>3} {:>6} {:>9} {:>13}  worst run",
            "J", "points", "arc deg", "worst rms mm"
        );
    }
    for (j, joint) in first.joints.iter().enumerate() {
        let worst = reports
            .iter()
            .filter_map(|r| {
                r.joints
                    .get(j)
                    .map(|jr| (jr.rms_residual_mm, r.run.as_deref()))
            })
            .max_by(|a, b| a.0.total_cmp(&b.0));
        let (rms, run) = worst.unwrap_or((joint.rms_residual_mm, None));
        let _ = writeln!(
            s,
            "{:>3} {:>6} {:>9.2} {:>13.5}  {}",
            joint.joint,
            joint.points,
            joint.arc_span_deg,
            rms,
            run.unwrap_or("-")
        );
    }
}

/// The whole-chain fits of the runs that have one: the one fit's summary, or the ranges over
/// several.
fn write_chains_summary(s: &mut String, reports: &[&IdentifyReport]) {
    let chains: Vec<&crate::identify::ChainReport> =
        reports.iter().filter_map(|r| r.chain.as_ref()).collect();
    match chains.as_slice() {
        [] => {}
        [one] => s.push_str(&crate::identify::render_chain_summary(one)),
        many => {
            let range = |f: &dyn Fn(&crate::identify::ChainReport) -> f64| {
                let v: Vec<f64> = many.iter().map(|c| f(c)).collect();
                (
                    v.iter().copied().fold(f64::INFINITY, f64::min),
                    v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
                )
            };
            let (k0, k1) = range(&|c| c.identifiability.condition_number);
            let (r0, r1) = range(&|c| c.rms_residual_mm);
            let ranks = many
                .iter()
                .map(|c| c.identifiability.rank)
                .min()
                .unwrap_or(0);
            let _ = writeln!(
                s,
                "Whole-chain fit of each run: {} points, {}, rank ≥ {ranks} of {}, condition number {k0:.1}–{k1:.1}, residual RMS {r0:.4}–{r1:.4} mm (each run's own covariance in identify.json)",
                many[0].points,
                crate::identify::frame_label(many[0].frame),
                many[0].identifiability.parameters
            );
        }
    }
}

/// Formats a validation for the terminal.
pub fn render_validation(v: &Validation) -> String {
    let mut s = String::new();
    let width = v
        .nominal
        .iter()
        .map(|(n, _)| n.chars().count())
        .chain([
            v.model_name.chars().count()
                + if v.geometric.is_some() {
                    " (without compensation)".len()
                } else {
                    0
                },
            "improvement".len(),
        ])
        .max()
        .unwrap_or(0);
    let _ = writeln!(s, "Positioning error over {} points (mm)", v.model.points);
    let _ = writeln!(
        s,
        "{:<width$} {:>10} {:>10} {:>10}",
        "model", "mean", "rms", "max"
    );
    let row = |s: &mut String, name: &str, a: &AccuracyStats| {
        let _ = writeln!(
            s,
            "{:<width$} {:>10.4} {:>10.4} {:>10.4}",
            name, a.mean_mm, a.rms_mm, a.max_mm
        );
    };
    if let Some((name, n)) = &v.nominal {
        row(&mut s, name, n);
    }
    if let Some(g) = &v.geometric {
        row(
            &mut s,
            &format!("{} (without compensation)", v.model_name),
            g,
        );
        row(&mut s, &format!("{} (compensated)", v.model_name), &v.model);
    } else {
        row(&mut s, &v.model_name, &v.model);
    }
    if let Some([m, r, x]) = v.improvement_percent() {
        let _ = writeln!(
            s,
            "{:<width$} {:>9.1}% {:>9.1}% {:>9.1}%",
            "improvement", m, r, x
        );
    }
    if let (Some(own), Some((name, _))) = (v.nominal_tool_replaced, &v.nominal) {
        let _ = writeln!(
            s,
            "note: {name}'s tool point ({:.4}, {:.4}, {:.4}) mm is another target than the \
             measured one; its errors use {}'s tool instead",
            own[0], own[1], own[2], v.model_name
        );
    }
    s
}
