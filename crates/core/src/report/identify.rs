//! Terminal renderings of identification and validation results.

use crate::identify::{sweeps, AccuracyStats, IdentifyReport, Validation};
use crate::kinematics::{ParamKind, JOINTS};
use std::fmt::Write as _;

/// Formats the per-joint table of an identification for the terminal.
pub fn render_identify_report(report: &IdentifyReport) -> String {
    let mut s = String::new();
    let run = sweeps::run_label(report.run.as_deref());
    let _ = writeln!(
        s,
        "Identification{run}, {} circle fit",
        report.method.name()
    );
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
    let _ = writeln!(
        s,
        "\nParameters: identified (identified − nominal); mm and deg; [fixed] = held fixed"
    );
    let _ = writeln!(
        s,
        "{:>3} {:>24} {:>24} {:>24} {:>24} {:>24}",
        "J", "theta", "d", "a", "alpha", "beta"
    );
    for j in &report.joints {
        let mut row = format!("{:>3}", j.joint);
        for (k, kind) in ParamKind::ALL.iter().enumerate() {
            let fixed = j.fixed.kind() == *kind || j.joint == JOINTS;
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
    let t = report.tool_mm;
    let n = report.nominal_tool_mm;
    let _ = writeln!(
        s,
        "\nTool point (flange frame): ({:.4}, {:.4}, {:.4}) mm, nominal ({:.4}, {:.4}, {:.4}) mm",
        t[0], t[1], t[2], n[0], n[1], n[2]
    );
    let _ = writeln!(
        s,
        "J6: theta, d, a, alpha kept nominal; the tool point absorbs the rest."
    );
    let _ = writeln!(
        s,
        "J1 measured axis vs base z: tilt {:.4} deg, offset {:.4} mm (the model takes base z as J1's axis)",
        report.j1_tilt_deg, report.j1_offset_mm
    );
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
    let _ = writeln!(s, "Identified {runs}, {} circle fit", first.method.name());
    let _ = writeln!(
        s,
        "{:>3} {:>6} {:>9} {:>13}  worst run",
        "J", "points", "arc deg", "worst rms mm"
    );
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
    s
}

/// Formats a validation for the terminal.
pub fn render_validation(v: &Validation) -> String {
    let mut s = String::new();
    let width = v
        .nominal
        .iter()
        .map(|(n, _)| n.chars().count())
        .chain([v.model_name.chars().count(), "improvement".len()])
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
    row(&mut s, &v.model_name, &v.model);
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
