//! The reports of identification and validation: terminal renderings of one run
//! ([`render_identify_report`]), of all runs ([`render_identify_summary`]) and of a validation
//! ([`render_validation`]); and [`IdentifyReports`], the runs of one identification as a
//! [`Report`] (JSON, CSV tables, the residual figure and the page).

use super::chain_outputs::{
    chain_sections, correlation_svg, parameters_csv, pose_residual_plot, CORRELATION_SVG,
    PARAMETERS_CSV, POSE_RESIDUALS_SVG,
};
use super::{sweeps, AccuracyStats, Identification, IdentifyReport, Validation};
use crate::kinematics::{ParamKind, MAX_JOINTS};
use crate::report::html::pages::{add_settings, link_all};
use crate::report::html::{Figure, Page, Table};
use crate::report::svg::{LinePlot, Series};
use crate::report::{Layout, Report};
use std::fmt::Write as _;

/// Formats the per-joint table of an identification for the terminal.
pub fn render_identify_report(report: &IdentifyReport) -> String {
    let mut s = String::new();
    let run = sweeps::run_label(report.run.as_deref());
    if report.joints.is_empty() {
        let _ = writeln!(s, "Identification{run}, pose data");
        if let Some(c) = &report.chain {
            s.push_str(&super::render_chain_report(c));
        }
        return s;
    }
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
        s.push_str(&super::render_chain_report(c));
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
    let chains: Vec<&super::ChainReport> =
        reports.iter().filter_map(|r| r.chain.as_ref()).collect();
    match chains.as_slice() {
        [] => {}
        [one] => s.push_str(&super::render_chain_summary(one)),
        many => {
            let range = |f: &dyn Fn(&super::ChainReport) -> f64| {
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
                super::frame_label(many[0].frame),
                many[0].identifiability.parameters
            );
        }
    }
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

/// The runs of one identification, as a [`Report`]: the text is [`render_identify_summary`].
#[derive(Clone, Debug, PartialEq)]
pub struct IdentifyReports {
    /// Name of the nominal model identified against.
    pub nominal: String,
    /// One report per run, in order.
    pub runs: Vec<IdentifyReport>,
}

impl IdentifyReports {
    /// The reports of `ids`, identified against the model named `nominal`.
    pub fn new(nominal: &str, ids: &[Identification]) -> IdentifyReports {
        IdentifyReports {
            nominal: nominal.to_string(),
            runs: ids.iter().map(|i| i.report.clone()).collect(),
        }
    }

    /// The files of an identification's report, before it runs.
    pub fn planned_layout() -> Layout {
        Layout::new(
            "identify.json",
            &[JOINTS_CSV, RUNS_CSV, PARAMETERS_CSV],
            &[RESIDUALS_SVG, CORRELATION_SVG, POSE_RESIDUALS_SVG],
            &[],
        )
    }

    /// Every run with its label.
    fn labelled(&self) -> Vec<(String, &IdentifyReport)> {
        self.runs
            .iter()
            .enumerate()
            .map(|(i, r)| (self.label(i), r))
            .collect()
    }

    /// The run's label: its name, or its number from 1 when the data had no `run` column.
    fn label(&self, i: usize) -> String {
        self.runs[i]
            .run
            .clone()
            .unwrap_or_else(|| (i + 1).to_string())
    }
}

/// Per run and joint: the circle fit and the identified parameters.
const JOINTS_CSV: &str = "joints.csv";
/// Per run: the tool point, the J1 axis and the warnings.
const RUNS_CSV: &str = "runs.csv";
/// The circle-fit RMS residual per joint.
const RESIDUALS_SVG: &str = "residuals.svg";

/// The parameters `[θ, d, a, α, β]` as a JSON object.
fn params_json(v: &[f64; 5]) -> serde_json::Value {
    let mut m = serde_json::Map::new();
    for (kind, x) in ParamKind::ALL.iter().zip(v) {
        m.insert(kind.name().to_string(), serde_json::json!(x));
    }
    serde_json::Value::Object(m)
}

/// A CSV cell that may hold a comma or a quote.
fn quoted(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

impl Report for IdentifyReports {
    fn layout(&self) -> Layout {
        Self::planned_layout()
    }

    fn text(&self) -> String {
        render_identify_summary(&self.runs)
    }

    fn json(&self) -> String {
        let runs: Vec<serde_json::Value> = self
            .runs
            .iter()
            .enumerate()
            .map(|(i, r)| {
                let joints: Vec<serde_json::Value> = r
                    .joints
                    .iter()
                    .map(|j| {
                        serde_json::json!({
                            "joint": j.joint,
                            "points": j.points,
                            "arc_span_deg": j.arc_span_deg,
                            "radius_mm": j.radius_mm,
                            "rms_residual_mm": j.rms_residual_mm,
                            "max_residual_mm": j.max_residual_mm,
                            "axis_angle_deg": j.axis_angle_deg,
                            "identified": params_json(&j.identified),
                            "nominal": params_json(&j.nominal),
                            "fixed": j.fixed,
                        })
                    })
                    .collect();
                let mut v = serde_json::json!({
                    "run": self.label(i),
                    "method": r.method.name(),
                    "joints": joints,
                    "tool_mm": r.tool_mm,
                    "nominal_tool_mm": r.nominal_tool_mm,
                    "j1_tilt_deg": r.j1_tilt_deg,
                    "j1_offset_mm": r.j1_offset_mm,
                    "warnings": r.warnings.iter().map(|w| w.to_string()).collect::<Vec<_>>(),
                });
                if let (Some(c), Some(o)) = (&r.chain, v.as_object_mut()) {
                    if r.joints.is_empty() {
                        o.insert("method".into(), serde_json::json!("poses"));
                    }
                    o.insert(
                        "chain".into(),
                        serde_json::to_value(c).unwrap_or(serde_json::Value::Null),
                    );
                }
                v
            })
            .collect();
        let v = serde_json::json!({
            "tool": "gpu-amcs",
            "version": env!("CARGO_PKG_VERSION"),
            "schema_version": 1,
            "identify": { "nominal": self.nominal, "runs": runs },
        });
        serde_json::to_string_pretty(&v).unwrap_or_default() + "\n"
    }

    fn csv(&self) -> Vec<(String, String)> {
        let mut joints = String::from(
            "run,joint,points,arc_span_deg,radius_mm,rms_residual_mm,max_residual_mm,\
             axis_angle_deg,fixed",
        );
        for kind in ParamKind::ALL {
            let _ = write!(joints, ",{0},{0}_nominal", kind.name());
        }
        joints.push('\n');
        let mut runs = String::from(
            "run,method,tool_x_mm,tool_y_mm,tool_z_mm,j1_tilt_deg,j1_offset_mm,warnings\n",
        );
        for (i, r) in self.runs.iter().enumerate() {
            let run = quoted(&self.label(i));
            for j in &r.joints {
                let angle = j.axis_angle_deg.map(|a| a.to_string()).unwrap_or_default();
                let _ = write!(
                    joints,
                    "{run},{},{},{},{},{},{},{angle},{}",
                    j.joint,
                    j.points,
                    j.arc_span_deg,
                    j.radius_mm,
                    j.rms_residual_mm,
                    j.max_residual_mm,
                    j.fixed.kind().name()
                );
                for k in 0..ParamKind::ALL.len() {
                    let _ = write!(joints, ",{},{}", j.identified[k], j.nominal[k]);
                }
                joints.push('\n');
            }
            let warnings: Vec<String> = r.warnings.iter().map(|w| w.to_string()).collect();
            let _ = writeln!(
                runs,
                "{run},{},{},{},{},{},{},{}",
                r.method.name(),
                r.tool_mm[0],
                r.tool_mm[1],
                r.tool_mm[2],
                r.j1_tilt_deg,
                r.j1_offset_mm,
                quoted(&warnings.join("; "))
            );
        }
        vec![
            (JOINTS_CSV.into(), joints),
            (RUNS_CSV.into(), runs),
            (PARAMETERS_CSV.into(), parameters_csv(&self.labelled())),
        ]
    }

    fn svg(&self) -> Vec<(String, String)> {
        let runs = self.labelled();
        let first = runs
            .iter()
            .find_map(|(l, r)| r.chain.as_ref().map(|c| (l, c)));
        vec![
            (RESIDUALS_SVG.into(), residual_plot(self).render()),
            (
                CORRELATION_SVG.into(),
                correlation_svg(
                    first.map(|(_, c)| c),
                    &format!(
                        "Correlation of the identified quantities — {}",
                        first.map_or("-".to_string(), |(l, _)| format!("run {l}"))
                    ),
                ),
            ),
            (
                POSE_RESIDUALS_SVG.into(),
                pose_residual_plot(&runs, &self.nominal).render(),
            ),
        ]
    }

    fn page(&self, settings: &[(String, String)], files: &[(String, String)]) -> String {
        identify_page(self, settings, files).render()
    }
}

/// The circle-fit RMS residual per joint: the largest and the mean over the runs (the one run's
/// when there is one).
fn residual_plot(r: &IdentifyReports) -> LinePlot {
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
fn identify_page(
    r: &IdentifyReports,
    settings: &[(String, String)],
    files: &[(String, String)],
) -> Page {
    let mut page = Page::new(&format!("Identification against {}", r.nominal));
    let worst = r
        .runs
        .iter()
        .flat_map(|run| run.joints.iter().map(|j| j.rms_residual_mm))
        .fold(f64::NEG_INFINITY, f64::max);
    let method = r.runs.first().map_or("-", |x| x.method.name());
    page.summary("runs", &r.runs.len().to_string())
        .summary("circle fit", method)
        .summary("largest circle-fit RMS residual", &format!("{worst:.5} mm"));
    for w in r.runs.iter().flat_map(|run| &run.warnings) {
        page.note(&w.to_string());
    }
    page.paragraph(
        "Each run's sweeps move one joint at a time; a circle fitted to the tracker's points gives \
         the joint's axis line, consecutive axes give the MDH parameters and the last joint's \
         sweep the tool point. The values are in joints.csv and runs.csv.",
    );
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
    chain_sections(&mut page, &r.labelled(), &r.nominal);
    page.setting("nominal model", &r.nominal);
    add_settings(&mut page, settings);
    page.setting("circle fit", method);
    link_all(&mut page, files);
    page
}
