//! The page of an MCS/AMCS comparison (the paper's Table 2 for one model) and its overlaid
//! figures and table.

use super::pages::{add_settings, link_all, mm};
use super::run::run_settings;
use super::{Figure, Page, Table};
use crate::mc::stats::{ecdf_grid, histogram};
use crate::mc::McResult;
use crate::report::svg::{LinePlot, Series, PDF_SVG, RELIABILITY_SVG};
use crate::report::text::{finite_or, fmt_g, NA};
use crate::report::{csv, markdown, Comparison};

/// The comparison's figures: PDF and reliability of MCS and each AMCS run, overlaid.
pub fn comparison_plots(c: &Comparison) -> Vec<(String, LinePlot)> {
    let runs: Vec<(String, &McResult)> = std::iter::once(("MCS".to_string(), &c.mcs))
        .chain(
            c.amcs
                .iter()
                .map(|(d, r, _)| (format!("AMCS δ = {} mm", fmt_g(*d)), r)),
        )
        .collect();
    let series = |f: fn(&[f64]) -> Vec<(f64, f64)>| {
        runs.iter()
            .map(|(name, r)| Series {
                name: name.clone(),
                points: f(&r.sorted_values),
                dashed: false,
            })
            .collect()
    };
    vec![
        (
            PDF_SVG.into(),
            LinePlot {
                title: format!("PDF of w, MCS and AMCS — {}", c.model),
                x_label: "w (mm)".into(),
                y_label: "density (1/mm)".into(),
                series: series(|v| histogram(v, 100)),
                log_y: false,
            },
        ),
        (
            RELIABILITY_SVG.into(),
            LinePlot {
                title: format!("Reliability R(l_c), MCS and AMCS — {}", c.model),
                x_label: "threshold l_c (mm)".into(),
                y_label: "R = Pr[w < l_c]".into(),
                series: series(|v| ecdf_grid(v, 400)),
                log_y: false,
            },
        ),
    ]
}

/// The comparison's table (the paper's Table 2 block): header and rows.
fn comparison_table(c: &Comparison) -> (Vec<String>, Vec<Vec<String>>) {
    let header: Vec<String> = markdown::COMPARISON_HEADER
        .iter()
        .map(|h| h.to_string())
        .collect();
    (header, markdown::comparison_rows(c))
}

/// `comparison.csv`: the comparison's table.
pub fn comparison_csv(c: &Comparison) -> String {
    let (header, rows) = comparison_table(c);
    csv::table(&header, &rows)
}

/// The comparison's page, linking `files`.
pub fn comparison_page(
    c: &Comparison,
    settings: &[(String, String)],
    files: &[(String, String)],
) -> Page {
    let table = comparison_table(c);
    let plots = comparison_plots(c);
    let mut page = Page::new(&format!("MCS against AMCS — {}", c.model));
    for n in &c.notes {
        page.note(n);
    }
    let worst = c
        .amcs
        .iter()
        .map(|(_, _, e)| *e)
        .filter(|e| e.is_finite())
        .fold(f64::NAN, f64::max);
    page.summary("MCS mean of w", &mm(c.mcs.estimate))
        .summary("MCS draws", &c.mcs.draws.to_string())
        .summary(
            "AMCS draws",
            &c.amcs
                .iter()
                .map(|(d, r, _)| format!("{} (δ = {} mm)", r.draws, fmt_g(*d)))
                .collect::<Vec<_>>()
                .join(", "),
        )
        .summary(
            "largest MRE of M1–M4",
            &finite_or(worst, NA, |x| format!("{x:.3} %")),
        )
        .summary("test points", &c.points.to_string());
    for (d, r, _) in &c.amcs {
        if !r.converged {
            page.note(&format!(
                "AMCS with δ = {} mm did not converge within its draw cap.",
                fmt_g(*d)
            ));
        }
    }
    page.heading("The paper's Table 2 for this model");
    let head: Vec<&str> = table.0.iter().map(String::as_str).collect();
    page.table(Table::new(
        "Moments M1–M4 of w by MCS and AMCS, and the maximum relative error (MRE) of AMCS against MCS",
        &head,
        table.1.clone(),
    ));
    page.heading("Figures");
    for (name, plot) in &plots {
        let what = if name == PDF_SVG {
            "Histogram densities (1/mm) of w"
        } else {
            "Empirical reliability curves R(l_c) = Pr[w < l_c]"
        };
        let curves: Vec<&str> = plot.series.iter().map(|s| s.name.as_str()).collect();
        page.figure(Figure {
            file: Some(name.clone()),
            title: plot.title.clone(),
            description: format!(
                "{what} of the MCS run (mean {}) and each AMCS run, overlaid: {}. The curves \
                 agree where AMCS reproduces MCS; the numbers are in comparison.csv.",
                mm(c.mcs.estimate),
                curves.join(", ")
            ),
            svg: plot.render(),
        });
    }
    page.setting("model", &c.model);
    add_settings(&mut page, settings);
    page.setting("test points", &c.points.to_string())
        .setting("seed of the draws", &c.seed.to_string());
    run_settings(&mut page, &c.mcs);
    link_all(&mut page, files);
    page
}
