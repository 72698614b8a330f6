//! The report of measured ISO 9283 cycles ([`PoseReport`]): the terminal table, the JSON
//! document, the figures and the certificate as CSV, AP and RP per pose as SVG, and the HTML
//! page.

use super::{render, render_certificate, Certificate, PoseFigures};
use crate::report::html::pages::{add_settings, link_all};
use crate::report::html::{Figure, Page, Table};
use crate::report::svg::{LinePlot, Series};
use crate::report::text::fmt_g;
use crate::report::{Layout, Report};
use std::fmt::Write;

/// The JSON document in a report directory.
const JSON: &str = "iso9283.json";
/// AP and RP per pose.
const POSES_CSV: &str = "iso9283_poses.csv";
/// The certificate per pose and over all of them.
const CERTIFICATE_CSV: &str = "iso9283_certificate.csv";
/// AP and RP per pose as a figure.
const POSES_SVG: &str = "iso9283_ap_rp.svg";

/// The ISO 9283 figures of one measurement file and, when a specification was given, the
/// certificate at its poses.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PoseReport {
    /// The model the commanded positions come from.
    pub model_name: String,
    /// The frame of the measurements, in words.
    pub frame: String,
    /// AP and RP per pose.
    pub poses: Vec<PoseFigures>,
    /// `Pr[AP_j ≤ spec]` from the model's uncertainty, when asked for.
    pub certificate: Option<Certificate>,
}

impl PoseReport {
    /// The files of the report, before it runs.
    pub fn planned_layout() -> Layout {
        Layout::new(JSON, &[POSES_CSV, CERTIFICATE_CSV], &[POSES_SVG], &[])
    }
}

impl Report for PoseReport {
    fn layout(&self) -> Layout {
        Self::planned_layout()
    }

    fn text(&self) -> String {
        let mut s = render(&self.poses);
        if let Some(c) = &self.certificate {
            s.push_str(&render_certificate(c));
        }
        s
    }

    fn json(&self) -> String {
        let mut s = serde_json::to_string_pretty(self)
            .unwrap_or_else(|e| format!("{{\"error\": \"{e}\"}}"));
        s.push('\n');
        s
    }

    fn csv(&self) -> Vec<(String, String)> {
        let mut v = vec![(POSES_CSV.to_string(), poses_csv(&self.poses))];
        if let Some(c) = &self.certificate {
            v.push((CERTIFICATE_CSV.to_string(), certificate_csv(c)));
        }
        v
    }

    fn svg(&self) -> Vec<(String, String)> {
        vec![(POSES_SVG.to_string(), plot(self).render())]
    }

    fn page(&self, settings: &[(String, String)], files: &[(String, String)]) -> String {
        page(self, settings, files).render()
    }
}

/// One row per pose: the figures, the commanded angles `q1` … `qn` (one column per joint of the
/// model, `n` = 4 to 7) and the pose's first line.
fn poses_csv(poses: &[PoseFigures]) -> String {
    let joints = poses.first().map_or(0, |f| f.q_deg.len());
    let mut s = String::from("pose,cycles,AP_mm,AP_x_mm,AP_y_mm,AP_z_mm,l_mean_mm,S_l_mm,RP_mm,");
    for j in 1..=joints {
        let _ = write!(s, "q{j},");
    }
    s.push_str("first_line\n");
    for f in poses {
        let _ = write!(s, "P{},{}", f.pose, f.cycles);
        for v in f.values() {
            let _ = write!(s, ",{v:.9}");
        }
        for q in f.q_deg {
            let _ = write!(s, ",{q}");
        }
        let _ = writeln!(s, ",{}", f.first_line);
    }
    s
}

fn certificate_csv(c: &Certificate) -> String {
    let mut s = String::from("pose,spec_mm,probability,ci_low,ci_high\n");
    let rows = c
        .per_pose
        .iter()
        .enumerate()
        .map(|(j, r)| (format!("P{}", j + 1), r))
        .chain(std::iter::once(("all".to_string(), &c.all)));
    for (name, r) in rows {
        let _ = writeln!(
            s,
            "{name},{},{:.6},{:.6},{:.6}",
            fmt_g(c.spec_mm),
            r.r,
            r.ci_low,
            r.ci_high
        );
    }
    s
}

/// AP and RP against the pose number, with the specification as a level.
fn plot(r: &PoseReport) -> LinePlot {
    let series = |name: &str, f: &dyn Fn(&PoseFigures) -> f64| Series {
        name: name.into(),
        points: r.poses.iter().map(|p| (p.pose as f64, f(p))).collect(),
        dashed: false,
    };
    let mut s = vec![
        series("AP (pose accuracy)", &|p| p.ap_mm),
        series("RP (pose repeatability)", &|p| p.rp_mm),
    ];
    if let Some(c) = &r.certificate {
        let n = r.poses.len().max(1) as f64;
        s.push(Series {
            name: format!("specification {} mm", fmt_g(c.spec_mm)),
            points: vec![(1.0, c.spec_mm), (n, c.spec_mm)],
            dashed: true,
        });
    }
    LinePlot {
        title: format!("ISO 9283 pose accuracy and repeatability, {}", r.model_name),
        x_label: "pose (P1, P2, …)".into(),
        y_label: "mm".into(),
        series: s,
        log_y: false,
    }
}

fn page(r: &PoseReport, settings: &[(String, String)], files: &[(String, String)]) -> Page {
    let mut page = Page::new("ISO 9283 pose accuracy and repeatability");
    let worst = |f: &dyn Fn(&PoseFigures) -> f64| {
        r.poses
            .iter()
            .map(|p| (f(p), p.pose))
            .max_by(|a, b| a.0.total_cmp(&b.0))
    };
    page.summary("poses", &r.poses.len().to_string());
    if let Some((v, j)) = worst(&|p| p.ap_mm) {
        page.summary("largest AP", &format!("{v:.4} mm (P{j})"));
    }
    if let Some((v, j)) = worst(&|p| p.rp_mm) {
        page.summary("largest RP", &format!("{v:.4} mm (P{j})"));
    }
    if let Some(c) = &r.certificate {
        page.summary(
            &format!("Pr[AP ≤ {} mm at every pose]", fmt_g(c.spec_mm)),
            &format!("{:.4} [{:.4}, {:.4}]", c.all.r, c.all.ci_low, c.all.ci_high),
        );
    }
    page.heading("Per pose");
    page.table(Table::new(
        "Pose accuracy AP = |x̄ − x_c| (barycentre of the cycles against the commanded position) and pose repeatability RP = l̄ + 3 S_l, positions only, mm",
        &[
            "pose", "cycles", "AP", "AP_x", "AP_y", "AP_z", "l̄", "S_l", "RP",
        ],
        r.poses
            .iter()
            .map(|p| {
                let mut row = vec![format!("P{}", p.pose), p.cycles.to_string()];
                row.extend(p.values().iter().map(|v| format!("{v:.4}")));
                row
            })
            .collect(),
    ));
    if let Some(c) = &r.certificate {
        page.heading("Certificate");
        page.table(Table::new(
            &format!(
                "The probability that a robot calibrated with this model's uncertainty meets AP ≤ {} mm, from {} Monte Carlo draws, with 95 % binomial intervals",
                fmt_g(c.spec_mm),
                c.draws
            ),
            &["pose", "probability", "interval"],
            c.per_pose
                .iter()
                .enumerate()
                .map(|(j, v)| (format!("P{}", j + 1), v))
                .chain(std::iter::once(("all poses".to_string(), &c.all)))
                .map(|(name, v)| {
                    vec![
                        name,
                        format!("{:.4}", v.r),
                        format!("[{:.4}, {:.4}]", v.ci_low, v.ci_high),
                    ]
                })
                .collect(),
        ));
    }
    page.heading("Figures");
    page.figure(Figure::from_svg(
        POSES_SVG,
        &plot(r).render(),
        "AP and RP of each test pose; the dashed level is the specification of the certificate.",
    ));
    add_settings(&mut page, settings);
    page.setting("model", &r.model_name)
        .setting("frame of the measurements", &r.frame);
    link_all(&mut page, files);
    page
}
