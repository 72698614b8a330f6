//! Reports of a calibration plan ([`Plan`]): the terminal summary, the JSON document (the plan's
//! own serde form), the comparison and the curve as CSV, the curve as SVG and the HTML page.

use super::{DesignFigures, Plan};
use crate::report::html::pages::{add_settings, link_all};
use crate::report::html::{Figure, Page, Table};
use crate::report::svg::{LinePlot, Series};
use crate::report::text::fmt_g;
use crate::report::{Layout, Report};
use std::fmt::Write;

/// Task points up to which the text and the page show each point's reliability.
const CERTIFICATE_POINTS: usize = 10;

/// The JSON document in a report directory.
const JSON: &str = "plan.json";
/// The three designs side by side.
const COMPARE_CSV: &str = "plan_compare.csv";
/// The predicted figures against the number of poses.
const CURVE_CSV: &str = "plan_curve.csv";
/// The same as a figure.
const CURVE_SVG: &str = "plan_curve.svg";

impl Plan {
    /// The files of a plan's report, before it runs.
    pub fn planned_layout() -> Layout {
        Layout::new(JSON, &[COMPARE_CSV, CURVE_CSV], &[CURVE_SVG], &[])
    }

    /// The design as CSV: `q1..qn` (one column per joint) in degrees, one pose a line, in
    /// visiting order; for a plan with an approach side ([`Plan::approach`]) also the sides
    /// `s1..sn` a pose file records (the measured positions added as `x,y,z` make it one).
    pub fn design_csv(&self) -> String {
        let n = self.nominal.joints();
        let mut names = joint_names(n);
        if self.approach.is_some() {
            names.extend((1..=n).map(|j| format!("s{j}")));
        }
        let mut s = names.join(",");
        s.push('\n');
        for q in &self.design_deg {
            let mut row: Vec<String> = q.iter().map(|v| format!("{v:.6}")).collect();
            if let Some(a) = self.approach {
                row.extend(std::iter::repeat_n(format!("{}", a.sign()), n));
            }
            let _ = writeln!(s, "{}", row.join(","));
        }
        s
    }
}

impl Report for Plan {
    fn layout(&self) -> Layout {
        Self::planned_layout()
    }

    fn text(&self) -> String {
        render_text(self)
    }

    fn json(&self) -> String {
        let mut s = serde_json::to_string_pretty(self)
            .unwrap_or_else(|e| format!("{{\"error\": \"{e}\"}}"));
        s.push('\n');
        s
    }

    fn csv(&self) -> Vec<(String, String)> {
        vec![
            (COMPARE_CSV.to_string(), render_compare_csv(self)),
            (CURVE_CSV.to_string(), render_curve_csv(self)),
        ]
    }

    fn svg(&self) -> Vec<(String, String)> {
        vec![(CURVE_SVG.to_string(), curve_plot(self).render())]
    }

    fn page(&self, settings: &[(String, String)], files: &[(String, String)]) -> String {
        plan_page(self, settings, files).render()
    }
}

/// The three designs: name and figures.
fn designs(p: &Plan) -> [(String, &DesignFigures); 3] {
    [
        ("planned".to_string(), &p.planned),
        ("log-det (D-optimal)".to_string(), &p.log_det_design),
        (
            format!("random (median of {})", p.random_designs),
            &p.random_median,
        ),
    ]
}

fn compare_header(p: &Plan) -> Vec<String> {
    let mut h = vec![
        "design".to_string(),
        "q95 of w (mm)".to_string(),
        "RMS at task points (mm)".to_string(),
    ];
    h.extend(p.thresholds.iter().map(|t| format!("R({} mm)", fmt_g(*t))));
    h.extend(["log det".into(), "O1".into(), "condition".into()]);
    h
}

fn compare_rows(p: &Plan) -> Vec<Vec<String>> {
    designs(p)
        .iter()
        .map(|(name, f)| {
            let mut r = vec![
                name.clone(),
                format!("{:.5}", f.q95_mm),
                format!("{:.5}", f.rms_mm),
            ];
            r.extend(f.reliability.iter().map(|v| format!("{v:.4}")));
            r.extend([
                format!("{:.3}", f.log_det),
                format!("{:.4}", f.o1),
                format!("{:.2}", f.condition),
            ]);
            r
        })
        .collect()
}

/// The terminal summary: the set-up, the engine's prediction, the comparison with other designs
/// and the curve against the number of poses.
pub fn render_text(p: &Plan) -> String {
    let mut s = String::new();
    text_setup(&mut s, p);
    if let Some(pr) = &p.prediction {
        text_prediction(&mut s, pr);
    }
    text_comparison(&mut s, p);
    if let (Some(first), Some(last)) = (p.curve.first(), p.curve.last()) {
        let _ = writeln!(
            s,
            "\nq95 of w against poses: {} poses {:.5} mm … {} poses {:.5} mm",
            first.poses, first.q95_mm, last.poses, last.q95_mm
        );
    }
    s
}

/// The model, tracker, design and identified inputs.
fn text_setup(s: &mut String, p: &Plan) {
    let _ = writeln!(s, "Calibration plan");
    let _ = writeln!(
        s,
        "model      {}  |  {} task points  |  target on the flange ({}, {}, {}) mm",
        p.model_name,
        p.task_points,
        fmt_g(p.target_mm[0]),
        fmt_g(p.target_mm[1]),
        fmt_g(p.target_mm[2])
    );
    let tracker = match &p.tracker {
        Some(t) => format!(
            "at ({}, {}, {}) mm, range {} mm, incidence ≤ {}°",
            fmt_g(t.position_mm[0]),
            fmt_g(t.position_mm[1]),
            fmt_g(t.position_mm[2]),
            fmt_g(t.range_mm),
            fmt_g(t.max_incidence_deg)
        ),
        None => "anywhere (no visibility limit)".to_string(),
    };
    let _ = writeln!(
        s,
        "tracker    σ = {} mm per coordinate, {tracker}",
        fmt_g(p.sigma_mm)
    );
    let _ = writeln!(
        s,
        "design     {} poses of {} candidates ({} drawn), joint travel {:.0}° in visiting order ({:.0}° as chosen), {:.2} s",
        p.design_deg.len(),
        p.candidates,
        p.candidates_drawn,
        p.travel_deg,
        p.travel_unordered_deg,
        p.seconds
    );
    text_workcell(s, p);
    let _ = writeln!(
        s,
        "identified {} inputs: {}",
        p.identified.len(),
        p.identified.join(" ")
    );
}

/// The workcell and the controller's limits: what the candidates respected and what they
/// refused.
fn text_workcell(s: &mut String, p: &Plan) {
    let w = &p.workcell;
    let mut parts = Vec::new();
    if let Some(f) = w.floor_mm {
        parts.push(format!("floor z = {} mm", fmt_g(f)));
    }
    if !w.keep_out.is_empty() {
        parts.push(format!("{} keep-out boxes", w.keep_out.len()));
    }
    parts.push(if w.self_collision {
        match w.link_radius_mm {
            Some(r) => format!("self-collision (link capsules {} mm)", fmt_g(r)),
            None => "self-collision (link capsules 20 … 50 mm)".to_string(),
        }
    } else {
        "no self-collision check".to_string()
    });
    let r = &p.rejected;
    let _ = writeln!(
        s,
        "workcell   {}; refused {} below the floor, {} in keep-out boxes, {} into the arm",
        parts.join(", "),
        r.floor,
        r.keep_out,
        r.self_collision
    );
    if let Some(n) = &p.limits_note {
        let _ = writeln!(s, "limits     {n}");
    }
}

/// The engine's Monte Carlo of the planned model at the task points (with the per-point
/// certificate for few points).
fn text_prediction(s: &mut String, pr: &super::Prediction) {
    let _ = writeln!(
        s,
        "\npredicted at the task points ({} draws of the planned model, {}):",
        pr.draws, pr.backend.backend
    );
    let _ = writeln!(
        s,
        "  mean of w {:.5} mm, 95 % quantile of w {:.5} mm",
        pr.mean_mm, pr.q95_mm
    );
    for r in &pr.reliability {
        let _ = writeln!(
            s,
            "  R({} mm) = {:.4}   [{:.4}, {:.4}]",
            fmt_g(r.threshold),
            r.r,
            r.ci_low,
            r.ci_high
        );
    }
    if pr.per_point.len() <= CERTIFICATE_POINTS {
        let _ = writeln!(
            s,
            "  per task point (for ISO 9283 poses: Pr[AP_j ≤ L], the certificate):"
        );
        for (j, rows) in pr.per_point.iter().enumerate() {
            let cells: Vec<String> = rows
                .iter()
                .map(|r| format!("L = {}: {:.4}", fmt_g(r.threshold), r.r))
                .collect();
            let _ = writeln!(s, "    P{}  {}", j + 1, cells.join("   "));
        }
    }
}

/// The table of the planned, log-det and random designs, and the bound.
fn text_comparison(s: &mut String, p: &Plan) {
    let _ = writeln!(
        s,
        "\ncompared (linearised, the same {} draws for every design):",
        crate::plan::EVAL_DRAWS
    );
    let header = compare_header(p);
    let rows = compare_rows(p);
    let widths: Vec<usize> = (0..header.len())
        .map(|c| {
            rows.iter()
                .map(|r| r[c].chars().count())
                .chain(std::iter::once(header[c].chars().count()))
                .max()
                .unwrap_or(0)
        })
        .collect();
    for r in std::iter::once(&header).chain(rows.iter()) {
        let cells: Vec<String> = r
            .iter()
            .zip(&widths)
            .enumerate()
            .map(|(c, (v, w))| {
                if c == 0 {
                    format!("{v:<w$}")
                } else {
                    format!("{v:>w$}")
                }
            })
            .collect();
        let _ = writeln!(s, "  {}", cells.join("  "));
    }
    let _ = writeln!(s, "  {}", bound_sentence(p));
}

/// What the bound of Method §17 says about this plan.
fn bound_sentence(p: &Plan) -> String {
    format!(
        "no design of {} of these candidates can bring the RMS at the task points below {:.5} mm \
         (the planned design is {:.1} % above it)",
        p.design_deg.len(),
        p.rms_bound_mm,
        100.0 * (p.planned.rms_mm / p.rms_bound_mm - 1.0)
    )
}

fn render_compare_csv(p: &Plan) -> String {
    crate::report::csv::table(&compare_header(p), &compare_rows(p))
}

fn render_curve_csv(p: &Plan) -> String {
    let mut s = String::from("poses,q95_mm");
    for t in &p.thresholds {
        let _ = write!(s, ",R_{}", fmt_g(*t));
    }
    s.push('\n');
    for c in &p.curve {
        let _ = write!(s, "{},{:.6}", c.poses, c.q95_mm);
        for r in &c.reliability {
            let _ = write!(s, ",{r:.6}");
        }
        s.push('\n');
    }
    s
}

/// q95 of w against the number of poses, with the random designs' median as a level.
fn curve_plot(p: &Plan) -> LinePlot {
    let pts: Vec<(f64, f64)> = p.curve.iter().map(|c| (c.poses as f64, c.q95_mm)).collect();
    let (x0, x1) = (
        pts.first().map_or(0.0, |v| v.0),
        pts.last().map_or(1.0, |v| v.0),
    );
    LinePlot {
        title: "Predicted 95 % quantile of w against the number of poses".into(),
        x_label: "poses measured".into(),
        y_label: "q95 of w (mm)".into(),
        series: vec![
            Series {
                name: "planned design, first n poses".into(),
                points: pts,
                dashed: false,
            },
            Series {
                name: format!("random designs of {} poses (median)", p.design_deg.len()),
                points: vec![(x0, p.random_median.q95_mm), (x1, p.random_median.q95_mm)],
                dashed: true,
            },
        ],
        log_y: false,
    }
}

/// The page of a plan, linking `files`.
fn plan_page(p: &Plan, settings: &[(String, String)], files: &[(String, String)]) -> Page {
    let mut page = Page::new("Calibration plan");
    page_summary(&mut page, p);
    page_per_point(&mut page, p);
    page_designs(&mut page, p);
    add_settings(&mut page, settings);
    page.setting("tracker noise σ", &format!("{} mm", fmt_g(p.sigma_mm)))
        .setting("candidates", &p.candidates.to_string())
        .setting("identified inputs", &p.identified.join(" "));
    if let Some(pr) = &p.prediction {
        page.backend(&pr.backend);
    }
    link_all(&mut page, files);
    page
}

/// The page's summary: poses, q95 and RMS of the designs, the predicted reliabilities.
fn page_summary(page: &mut Page, p: &Plan) {
    page.summary("poses", &p.design_deg.len().to_string())
        .summary("q95 of w, planned", &format!("{:.5} mm", p.planned.q95_mm))
        .summary(
            "q95 of w, random designs",
            &format!("{:.5} mm", p.random_median.q95_mm),
        )
        .summary(
            "RMS at task points, planned",
            &format!("{:.5} mm", p.planned.rms_mm),
        )
        .summary(
            "RMS at task points, any design (bound)",
            &format!("≥ {:.5} mm", p.rms_bound_mm),
        );
    if let Some(pr) = &p.prediction {
        for r in &pr.reliability {
            page.summary(
                &format!("predicted R({} mm)", fmt_g(r.threshold)),
                &format!("{:.4} [{:.4}, {:.4}]", r.r, r.ci_low, r.ci_high),
            );
        }
    }
}

/// The per-task-point table (the certificate at ISO 9283 poses), for few task points.
fn page_per_point(page: &mut Page, p: &Plan) {
    if let Some(pr) = p
        .prediction
        .as_ref()
        .filter(|pr| pr.per_point.len() <= CERTIFICATE_POINTS)
    {
        page.heading("Per task point");
        let mut header = vec!["point".to_string()];
        header.extend(
            p.thresholds
                .iter()
                .map(|t| format!("Pr[e_j < {} mm]", fmt_g(*t))),
        );
        let h: Vec<&str> = header.iter().map(String::as_str).collect();
        page.table(Table::new(
            "The predicted probability that each task point's error stays below L; at ISO 9283 test poses, that pose accuracy AP_j meets L (the certificate)",
            &h,
            pr.per_point
                .iter()
                .enumerate()
                .map(|(j, rows)| {
                    std::iter::once(format!("P{}", j + 1))
                        .chain(rows.iter().map(|r| format!("{:.4} [{:.4}, {:.4}]", r.r, r.ci_low, r.ci_high)))
                        .collect()
                })
                .collect(),
        ));
    }
}

/// The designs compared, the poses in visiting order and the curve against the poses.
fn page_designs(page: &mut Page, p: &Plan) {
    page.heading("Designs compared");
    let header = compare_header(p);
    let h: Vec<&str> = header.iter().map(String::as_str).collect();
    page.table(Table::new(
        "The planned design, the log-det design and random designs of the same size: linearised predictions on one set of draws; information figures of the column-scaled Jacobian",
        &h,
        compare_rows(p),
    ));
    page.paragraph(&format!("{}.", bound_sentence(p)));
    page.heading("Poses in visiting order");
    let header_q: Vec<String> = std::iter::once("#".to_string())
        .chain(joint_names(p.nominal.joints()))
        .collect();
    page.table(Table::new(
        "Joint angles (degrees), as design.csv holds them",
        &header_q.iter().map(String::as_str).collect::<Vec<_>>(),
        p.design_deg
            .iter()
            .enumerate()
            .map(|(k, q)| {
                std::iter::once((k + 1).to_string())
                    .chain(q.iter().map(|v| format!("{v:.3}")))
                    .collect()
            })
            .collect(),
    ));
    page.heading("Figures");
    let svg = curve_plot(p).render();
    page.figure(Figure::from_svg(
        CURVE_SVG,
        &svg,
        "The predicted 95 % quantile of w at the task points when only the first n poses of the \
         design (in its own D-optimal order) are measured, against n; the dashed level is the \
         median of random designs of the full size.",
    ));
}

/// The column names `q1` … `qn` of `n` joints' angles.
fn joint_names(n: usize) -> Vec<String> {
    (1..=n).map(|j| format!("q{j}")).collect()
}
