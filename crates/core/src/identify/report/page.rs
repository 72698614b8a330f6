//! The page of an identification ([`IdentifyReports::page`](crate::report::Report::page)) and
//! its circle-fit residual figure.

use super::{IdentifyReports, JOINTS_CSV, RESIDUALS_SVG};
use crate::identify::chain_outputs::chain_sections;
use crate::kinematics::{ParamKind, MAX_JOINTS};
use crate::report::html::pages::{add_settings, link_all};
use crate::report::html::{Figure, Page, Table};
use crate::report::svg::{LinePlot, Series};

/// The circle-fit RMS residual per joint: the largest and the mean over the runs (the one run's
/// when there is one).
pub(super) fn residual_plot(r: &IdentifyReports) -> LinePlot {
    let n = r.runs.len().max(1) as f64;
    let per_joint = |f: &dyn Fn(&[f64]) -> f64| -> Vec<(f64, f64)> {
        (0..MAX_JOINTS)
            .filter_map(|j| {
                let v: Vec<f64> = r
                    .runs
                    .iter()
                    .filter_map(|run| run.joints.get(j).map(|x| x.rms_residual_mm))
                    .collect();
                (!v.is_empty()).then(|| ((j + 1) as f64, f(&v)))
            })
            .collect()
    };
    let largest = per_joint(&|v| v.iter().copied().fold(f64::NEG_INFINITY, f64::max));
    let series = if r.runs.len() > 1 {
        vec![
            Series {
                name: "largest over the runs".into(),
                points: largest,
                dashed: false,
            },
            Series {
                name: "mean over the runs".into(),
                points: per_joint(&|v| v.iter().sum::<f64>() / n),
                dashed: true,
            },
        ]
    } else {
        vec![Series {
            name: "the run".into(),
            points: largest,
            dashed: false,
        }]
    };
    LinePlot {
        title: format!("Circle-fit RMS residual per joint — {}", r.nominal),
        x_label: "joint".into(),
        y_label: "RMS residual (mm)".into(),
        series,
        log_y: false,
    }
}

/// The page of an identification: the runs, the fits, the identified parameters and the figure.
/// The circle fits, their parameter tables and their figure appear only for sweeps: pose data
/// go straight to the whole-chain fit, and the page then opens with it.
pub(super) fn identify_page(
    r: &IdentifyReports,
    settings: &[(String, String)],
    files: &[(String, String)],
) -> Page {
    let mut page = Page::new(&format!("Identification against {}", r.nominal));
    let sweeps = r.runs.iter().any(|run| !run.joints.is_empty());
    page.summary("runs", &r.runs.len().to_string());
    for w in r.runs.iter().flat_map(|run| &run.warnings) {
        page.note(&w.to_string());
    }
    let method = r.runs.first().map_or("-", |x| x.method.name());
    if sweeps {
        let worst = r
            .runs
            .iter()
            .flat_map(|run| run.joints.iter().map(|j| j.rms_residual_mm))
            .fold(f64::NEG_INFINITY, f64::max);
        page.summary("circle fit", method)
            .summary("largest circle-fit RMS residual", &format!("{worst:.5} mm"));
        page.paragraph(
            "Each run's sweeps move one joint at a time; a circle fitted to the tracker's points \
             gives the joint's axis line, consecutive axes give the MDH parameters and the last \
             joint's sweep the tool point. The values are in joints.csv and runs.csv.",
        );
        circle_fits_section(&mut page, r);
        parameters_section(&mut page, r);
        figures_section(&mut page, r, worst);
    } else {
        page.summary("data", "poses (whole-chain fit)");
    }
    chain_sections(&mut page, &r.labelled(), &r.nominal);
    page.setting("nominal model", &r.nominal);
    add_settings(&mut page, settings);
    if sweeps {
        page.setting("circle fit", method);
    }
    // Without sweeps the circle-fit files hold no rows (joints.csv) or no points (the figure).
    let shown: Vec<(String, String)> = files
        .iter()
        .filter(|(name, _)| sweeps || (name != RESIDUALS_SVG && name != JOINTS_CSV))
        .cloned()
        .collect();
    link_all(&mut page, &shown);
    page
}

/// The page's "Circle fits" section: the fit of each joint's sweep, per run.
fn circle_fits_section(page: &mut Page, r: &IdentifyReports) {
    page.heading("Circle fits");
    let mut rows = Vec::new();
    for (i, run) in r.runs.iter().enumerate() {
        for j in &run.joints {
            rows.push(vec![
                r.label(i),
                j.joint.to_string(),
                j.points.to_string(),
                format!("{:.2}", j.arc_span_deg),
                format!("{:.4}", j.radius_mm),
                format!("{:.5}", j.rms_residual_mm),
                format!("{:.5}", j.max_residual_mm),
            ]);
        }
    }
    page.table(Table::new(
        "Circle fit of each joint's sweep, per run",
        &[
            "run",
            "joint",
            "points (count)",
            "arc (deg)",
            "radius (mm)",
            "RMS residual (mm)",
            "largest residual (mm)",
        ],
        rows,
    ));
}

/// The page's "Identified parameters" section: the MDH parameters per run and joint, then the
/// tool point and the measured J1 axis per run.
fn parameters_section(page: &mut Page, r: &IdentifyReports) {
    page.heading("Identified parameters");
    let mut rows = Vec::new();
    for (i, run) in r.runs.iter().enumerate() {
        for j in &run.joints {
            let mut row = vec![r.label(i), j.joint.to_string()];
            for k in 0..ParamKind::ALL.len() {
                row.push(format!(
                    "{:.4} ({:+.4})",
                    j.identified[k],
                    j.identified[k] - j.nominal[k]
                ));
            }
            row.push(j.fixed.kind().name().to_string());
            rows.push(row);
        }
    }
    page.table(Table::new(
        "MDH parameters per run and joint: identified (identified − nominal)",
        &[
            "run", "joint", "θ (deg)", "d (mm)", "a (mm)", "α (deg)", "β (deg)", "fixed",
        ],
        rows,
    ));
    page.table(Table::new(
        "Tool point in the flange frame and the measured J1 axis against base z, per run",
        &[
            "run",
            "tool x (mm)",
            "tool y (mm)",
            "tool z (mm)",
            "J1 tilt (deg)",
            "J1 offset (mm)",
        ],
        r.runs
            .iter()
            .enumerate()
            .map(|(i, run)| {
                vec![
                    r.label(i),
                    format!("{:.4}", run.tool_mm[0]),
                    format!("{:.4}", run.tool_mm[1]),
                    format!("{:.4}", run.tool_mm[2]),
                    format!("{:.4}", run.j1_tilt_deg),
                    format!("{:.4}", run.j1_offset_mm),
                ]
            })
            .collect(),
    ));
}

/// The page's "Figures" section: the circle-fit residual per joint (`worst` the largest, mm).
fn figures_section(page: &mut Page, r: &IdentifyReports, worst: f64) {
    page.heading("Figures");
    let plot = residual_plot(r);
    page.figure(Figure::from_svg(
        RESIDUALS_SVG,
        &plot.render(),
        &format!(
            "The circle-fit RMS residual (mm) of each joint's sweep against the joint number, {}; \
             the largest is {worst:.5} mm. The values are in joints.csv.",
            if r.runs.len() > 1 {
                "the largest and the mean over the runs"
            } else {
                "of the one run"
            }
        ),
    ));
}
