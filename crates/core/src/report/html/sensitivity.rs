//! The page of a Sobol sensitivity analysis: the headline numbers, the index tables of w (and of
//! each failure indicator) per group and parameter, and the bar charts.

use super::pages::{add_settings, link_all, mm};
use super::{Figure, Page, Table};
use crate::mc::sensitivity::{Quantity, SensitivityResult};
use crate::report::sensitivity::{render_svg, GROUPS_SVG};
use crate::report::text::{fmt_g, NA};

fn estimate_cells(e: &crate::mc::sensitivity::Estimate) -> [String; 3] {
    let o = |v: Option<f64>| v.map_or(NA.to_string(), |x| format!("{x:.4}"));
    [format!("{:.4}", e.value), o(e.ci_low), o(e.ci_high)]
}

/// The page of a sensitivity analysis, linking `files`.
pub fn sensitivity_page(
    r: &SensitivityResult,
    settings: &[(String, String)],
    files: &[(String, String)],
) -> Page {
    let charts = render_svg(r);
    let a = &r.analysis;
    let mut page = Page::new(&format!("Sobol sensitivity of w — {}", r.model));
    page.summary("base samples N", &a.draws.to_string())
        .summary("evaluations of w", &a.evaluations.to_string())
        .summary("uncertain parameters", &a.dimension.to_string())
        .summary("test points", &r.points.to_string());
    if let Some(q) = a.quantities.first() {
        page.summary("mean of w", &mm(q.mean))
            .summary("standard deviation of w", &mm(q.variance.max(0.0).sqrt()));
        if let Some(top) = q
            .inputs
            .iter()
            .filter(|i| i.total.value.is_finite())
            .max_by(|x, y| x.total.value.total_cmp(&y.total.value))
        {
            page.summary(
                "largest total index",
                &format!("{} ({:.3})", top.name, top.total.value),
            );
        }
        if let Some(n) = &q.note {
            page.note(n);
        }
    }
    if !r.skipped_parameters.is_empty() {
        page.note(&format!(
            "Parameters without spread, left out: {}",
            r.skipped_parameters.join(", ")
        ));
    }
    let head = [
        "name",
        "first order S (1)",
        "S 95 % CI low (1)",
        "S 95 % CI high (1)",
        "total S_T (1)",
        "S_T 95 % CI low (1)",
        "S_T 95 % CI high (1)",
    ];
    for q in &a.quantities {
        let what = match q.quantity {
            Quantity::Value => "w".to_string(),
            Quantity::Exceedance { threshold } => {
                format!("the failure indicator 1[w ≥ {} mm]", fmt_g(threshold))
            }
        };
        page.heading(&format!("Indices of {what}"));
        for (level, rows) in [("group", &q.groups), ("parameter", &q.inputs)] {
            page.table(Table::new(
                &format!("Sobol indices of {what} per {level}, with 95 % bootstrap intervals"),
                &head,
                rows.iter()
                    .map(|i| {
                        let mut row = vec![i.name.clone()];
                        row.extend(estimate_cells(&i.first_order));
                        row.extend(estimate_cells(&i.total));
                        row
                    })
                    .collect(),
            ));
        }
    }
    page.heading("Figures");
    for (name, text) in &charts {
        let level = if name == GROUPS_SVG {
            "group"
        } else {
            "parameter (the largest total indices)"
        };
        page.figure(Figure::from_svg(
            name,
            text,
            &format!(
                "Horizontal bars of the first-order and total Sobol indices of w per {level}, with \
                 their 95 % bootstrap intervals as error bars; the numbers are in the tables above \
                 and in indices.csv."
            ),
        ));
    }
    page.setting("model", &r.model);
    add_settings(&mut page, settings);
    page.setting("test points", &r.points.to_string())
        .setting("seed of the draws", &r.seed.to_string())
        .setting("bootstrap resamples", &a.bootstrap_resamples.to_string())
        .setting("bootstrap seed", &a.bootstrap_seed.to_string())
        .backend(&r.backend);
    link_all(&mut page, files);
    page
}
