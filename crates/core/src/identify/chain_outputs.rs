//! The files of a whole-chain identification: `parameters.csv` (every quantity with σ and
//! status, per run), `correlation.svg` (the identified quantities' correlation matrix as a heat
//! map), `pose_residuals.svg` (the 3-D residual of each measured point) and the page's sections.

use super::chain::ChainReport;
use super::IdentifyReport;
use crate::report::html::{escape, Figure, Page, Table};
use crate::report::svg::{LinePlot, Series};
use std::fmt::Write as _;

/// File name of the parameter table.
pub const PARAMETERS_CSV: &str = "parameters.csv";
/// File name of the correlation heat map.
pub const CORRELATION_SVG: &str = "correlation.svg";
/// File name of the per-point residual figure.
pub const POSE_RESIDUALS_SVG: &str = "pose_residuals.svg";

/// `run,name,value,sigma,sigma_monte_carlo,nominal,unit,status`, one row per quantity and run
/// (runs without a whole-chain fit have no rows).
pub fn parameters_csv(runs: &[(String, &IdentifyReport)]) -> String {
    let mut s = String::from("run,name,value,sigma,sigma_monte_carlo,nominal,unit,status\n");
    for (label, r) in runs {
        let Some(c) = &r.chain else { continue };
        for p in &c.parameters {
            let _ = writeln!(
                s,
                "{},{},{:?},{:?},{},{:?},{},{}",
                csv_cell(label),
                p.name,
                p.value,
                p.sigma,
                p.sigma_monte_carlo
                    .map(|v| format!("{v:?}"))
                    .unwrap_or_default(),
                p.nominal,
                p.unit,
                csv_cell(&p.status)
            );
        }
    }
    s
}

fn csv_cell(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// The identified quantities' names, in the order of [`ChainReport::correlation`].
pub fn identified_names(c: &ChainReport) -> Vec<&str> {
    c.parameters
        .iter()
        .filter(|p| p.status == "identified")
        .map(|p| p.name.as_str())
        .collect()
}

/// The correlation matrix as a heat map: blue −1, white 0, red +1, one cell per pair, names on
/// both axes. With no whole-chain fit, a note in the figure says so.
pub fn correlation_svg(c: Option<&ChainReport>, title: &str) -> String {
    let names = c.map(identified_names).unwrap_or_default();
    let p = names.len();
    let cell = 16.0;
    let left = 90.0;
    let top = 100.0;
    let size = cell * p as f64;
    let (w, h) = (left + size + 120.0, top + size + 30.0);
    let mut s = String::new();
    let _ = write!(
        s,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" viewBox=\"0 0 {w} {h}\" font-family=\"sans-serif\" font-size=\"10\">\
         <desc>Correlation coefficients of the identified quantities</desc>\
         <text x=\"10\" y=\"18\" font-size=\"14\">{}</text>",
        escape(title)
    );
    let Some(c) = c.filter(|_| p > 0) else {
        s.push_str(
            "<text x=\"10\" y=\"50\">no whole-chain fit in this identification</text></svg>\n",
        );
        return s;
    };
    for (i, n) in names.iter().enumerate() {
        let y = top + cell * (i as f64 + 0.7);
        let _ = write!(
            s,
            "<text x=\"{}\" y=\"{y}\" text-anchor=\"end\">{}</text>",
            left - 4.0,
            escape(n)
        );
        let x = left + cell * (i as f64 + 0.7);
        let _ = write!(
            s,
            "<text x=\"{x}\" y=\"{}\" transform=\"rotate(-60 {x} {})\">{}</text>",
            top - 4.0,
            top - 4.0,
            escape(n)
        );
    }
    for a in 0..p {
        for b in 0..p {
            let rho = c.correlation[a * p + b].clamp(-1.0, 1.0);
            let fade = |v: f64| (255.0 * (1.0 - v.abs())).round() as u8;
            let (r, g, bl) = if rho >= 0.0 {
                (255, fade(rho), fade(rho))
            } else {
                (fade(rho), fade(rho), 255)
            };
            let _ = write!(
                s,
                "<rect x=\"{}\" y=\"{}\" width=\"{cell}\" height=\"{cell}\" fill=\"rgb({r},{g},{bl})\"><title>{} / {}: {rho:+.3}</title></rect>",
                left + cell * b as f64,
                top + cell * a as f64,
                escape(names[a]),
                escape(names[b])
            );
        }
    }
    // colour key
    let kx = left + size + 20.0;
    for (k, v) in [1.0, 0.5, 0.0, -0.5, -1.0].iter().enumerate() {
        let fade = (255.0 * (1.0 - f64::abs(*v))).round() as u8;
        let fill = if *v >= 0.0 {
            format!("rgb(255,{fade},{fade})")
        } else {
            format!("rgb({fade},{fade},255)")
        };
        let y = top + 20.0 * k as f64;
        let _ = write!(
            s,
            "<rect x=\"{kx}\" y=\"{y}\" width=\"14\" height=\"14\" fill=\"{fill}\" stroke=\"#888\"/><text x=\"{}\" y=\"{}\">ρ = {v:+.1}</text>",
            kx + 18.0,
            y + 11.0
        );
    }
    s.push_str("</svg>\n");
    s
}

/// The 3-D residual of each measured point against its index, one series per run.
pub fn pose_residual_plot(runs: &[(String, &IdentifyReport)], nominal: &str) -> LinePlot {
    let series = runs
        .iter()
        .filter_map(|(label, r)| {
            r.chain.as_ref().map(|c| Series {
                name: format!("run {label}"),
                points: c
                    .residuals_mm
                    .iter()
                    .enumerate()
                    .map(|(k, v)| ((k + 1) as f64, *v))
                    .collect(),
                dashed: false,
            })
        })
        .collect();
    LinePlot {
        title: format!("Residual of each measured point — {nominal}"),
        x_label: "point (data order)".into(),
        y_label: "3-D residual (mm)".into(),
        series,
        log_y: false,
    }
}

/// The page's sections on the whole-chain fits: per run the fit and identifiability summary,
/// the quantities with σ, the warnings, and the two figures (first run's correlation).
pub fn chain_sections(page: &mut Page, runs: &[(String, &IdentifyReport)], nominal: &str) {
    let with: Vec<&(String, &IdentifyReport)> =
        runs.iter().filter(|(_, r)| r.chain.is_some()).collect();
    if with.is_empty() {
        return;
    }
    page.heading("Whole-chain fit and uncertainty");
    page.paragraph(
        "Every measured point enters one weighted least-squares fit of the placement (measurement \
         frame → robot base), the MDH parameters and the target. The covariance is s²(JᵀWJ)⁻¹ at \
         the solution (or the spread of Monte Carlo re-identifications); the identifiability \
         comes from the singular values of the column-scaled Jacobian. Values are in \
         parameters.csv and identify.json.",
    );
    let rows = with
        .iter()
        .map(|(label, r)| {
            let c = r.chain.as_ref().expect("filtered");
            let a = &c.identifiability;
            vec![
                label.clone(),
                super::frame_label(c.frame).to_string(),
                c.points.to_string(),
                format!("{:.5}", c.rms_residual_mm),
                format!("{:.5}", c.max_residual_mm),
                format!("{} of {}", a.rank, a.parameters),
                format!("{:.1}", a.condition_number),
                format!("{:.4}", a.o1),
                a.null_directions
                    .iter()
                    .map(|n| format!("{} → {}", n.combination, n.fixed))
                    .collect::<Vec<_>>()
                    .join("; "),
            ]
        })
        .collect();
    page.table(Table::new(
        "Fit and identifiability per run",
        &[
            "run",
            "frame",
            "points (count)",
            "RMS residual (mm)",
            "largest residual (mm)",
            "rank",
            "condition number",
            "O1",
            "not identifiable → fixed",
        ],
        rows,
    ));
    let (label, first) = with[0];
    let c = first.chain.as_ref().expect("filtered");
    page.heading("Lack of fit and the discrepancy term");
    page.paragraph(&c.lack_of_fit.summary());
    page.table(Table::new(
        "Measurement noise against what the geometric model does not explain, per run",
        &[
            "run",
            "standardised residual RMS (mm)",
            "noise σ per coordinate (mm)",
            "unexplained RMS (mm)",
            "discrepancy term",
            "compensation: held-out RMS geometric → compensated (mm)",
            "leave-one-out coverage of the 95 % bound",
            "the same, parameters alone",
        ],
        with.iter()
            .map(|(label, r)| {
                let l = &r.chain.as_ref().expect("filtered").lack_of_fit;
                let opt = |v: Option<f64>| v.map_or("unknown".to_string(), |v| format!("{v:.5}"));
                vec![
                    label.clone(),
                    format!("{:.5}", l.residual_rms_mm),
                    opt(l.noise_sigma_mm),
                    opt(l.unexplained_rms_mm),
                    if l.carried { "carried" } else { "none" }.to_string(),
                    compensation_cell(l.compensation.as_ref()),
                    l.loo
                        .as_ref()
                        .map_or("—".into(), |c| format!("{:.1} %", 100.0 * c.coverage_95)),
                    l.loo.as_ref().map_or("—".into(), |c| {
                        format!("{:.1} %", 100.0 * c.coverage_95_parameters_only)
                    }),
                ]
            })
            .collect(),
    ));
    page.table(Table::new(
        &format!("Identified quantities of run {label} with their standard uncertainty"),
        &["name", "value", "σ", "nominal", "unit", "status"],
        c.parameters
            .iter()
            .map(|p| {
                vec![
                    p.name.clone(),
                    format!("{:.6}", p.value),
                    format!("{:.6}", p.sigma),
                    format!("{:.6}", p.nominal),
                    p.unit.to_string(),
                    p.status.clone(),
                ]
            })
            .collect(),
    ));
    let svg = correlation_svg(
        Some(c),
        &format!("Correlation of the identified quantities — run {label}"),
    );
    page.figure(Figure::from_svg(
        CORRELATION_SVG,
        &svg,
        &format!(
            "Correlation coefficients of the {} identified quantities of run {label} (blue −1, \
             white 0, red +1); {} pair(s) exceed |ρ| = 0.9.",
            identified_names(c).len(),
            c.identifiability.correlated.len()
        ),
    ));
    let plot = pose_residual_plot(runs, nominal);
    page.figure(Figure::from_svg(
        POSE_RESIDUALS_SVG,
        &plot.render(),
        &format!(
            "The 3-D residual (mm) of each measured point in data order; run {label}: RMS {:.5} mm, \
             largest {:.5} mm.",
            c.rms_residual_mm, c.max_residual_mm
        ),
    ));
}

/// The compensation column of the lack-of-fit table.
fn compensation_cell(c: Option<&crate::discrepancy::CompensationReport>) -> String {
    match c {
        None => "not tried".into(),
        Some(c) => match (&c.not_fitted, c.loo_rms_compensated_mm) {
            (Some(why), _) => format!("not fitted: {why}"),
            (None, Some(after)) => format!(
                "{:.4} → {after:.4} ({}){}",
                c.loo_rms_geometric_mm,
                c.validation,
                if c.applied { ", applied" } else { ": not kept" }
            ),
            (None, None) => "—".into(),
        },
    }
}
