//! The reports of identification and validation: terminal renderings of one run
//! ([`render_identify_report`]), of all runs ([`render_identify_summary`]) and of a validation
//! ([`render_validation`]); and [`IdentifyReports`], the runs of one identification as a
//! [`Report`] (JSON, CSV tables, the residual figure and the page).
//!
//! The terminal renderings are in `text`, the page and its figure in `page`.

mod page;
mod text;

pub use text::{render_identify_report, render_identify_summary, render_validation};

use super::chain_outputs::{
    correlation_svg, parameters_csv, pose_residual_plot, CORRELATION_SVG, PARAMETERS_CSV,
    POSE_RESIDUALS_SVG,
};
use super::{Identification, IdentifyReport};
use crate::kinematics::ParamKind;
use crate::report::{Layout, Report};
use page::{identify_page, residual_plot};
use std::fmt::Write as _;

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
