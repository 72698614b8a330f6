//! The page of a map: the headline numbers, the multi-point and single-point reliability
//! tables, the heat maps inline, the model and settings.

use super::{grid_label, reached, reference_q, render_svgs, CSV_NAME, HTML_JSON};
use crate::map::MapResult;
use crate::report::html::{Figure, Page, Table};
use crate::report::text::fmt_g;

/// A heat map's `<title>` and `<desc>` (as [`render_svgs`] writes them): the description, and
/// the document without them, for a page that gives the figure its own.
fn split_text_alternative(svg: &str) -> (String, String) {
    match (svg.find("<title>"), svg.find("<desc>"), svg.find("</desc>")) {
        (Some(t), Some(d), Some(e)) if t < d && d < e => {
            let desc = svg[d + "<desc>".len()..e]
                .replace("&lt;", "<")
                .replace("&gt;", ">")
                .replace("&amp;", "&");
            (
                desc,
                format!("{}{}", &svg[..t], &svg[e + "</desc>".len()..]),
            )
        }
        _ => (String::new(), svg.to_string()),
    }
}

/// The page of a map; `settings` are rows only the caller knows (where the model came from).
/// It links the JSON and CSV files of its directory; the heat maps are inline.
pub fn map_page(r: &MapResult, settings: &[(String, String)], _files: &[(String, String)]) -> Page {
    let svgs = render_svgs(r);
    let mut page = Page::new(&format!("Workspace reliability map of {}", r.model));
    for n in &r.notes {
        page.note(n);
    }
    page.summary("grid", &grid_label(r))
        .summary("task", &r.spec.task())
        .summary(
            "cells reached",
            &format!("{} of {}", r.reached, r.cells.len()),
        )
        .summary("draws", &r.draws.to_string())
        .summary(
            "mean of w over the reached cells",
            &format!("{} mm", fmt_g(r.w_mean_mm)),
        )
        .summary("95 % quantile of w", &format!("{} mm", fmt_g(r.w_q95_mm)))
        .summary(
            "run time",
            &format!(
                "inverse kinematics {:.2} s, evaluation {:.2} s",
                r.timings.ik_seconds, r.timings.eval_seconds
            ),
        );
    page.paragraph(
        "Each cell is a target position; inverse kinematics on the model gives the configuration \
         nearest the reference configuration, and all reached cells are evaluated on the same \
         parameter draws. Hatched cells cannot be reached with the task's orientation within the \
         joint limits.",
    );
    page.heading("Reliability over all reached cells");
    page.table(Table::new(
        "Multi-point reliability R(l_c) = Pr[w < l_c], w = max_j e_j over the reached cells, with the 95 % Wilson interval",
        &["l_c (mm)", "R (1)", "95 % interval low (1)", "95 % interval high (1)"],
        r.multi_point
            .iter()
            .map(|x| {
                vec![
                    fmt_g(x.threshold),
                    format!("{:.6}", x.r),
                    format!("{:.6}", x.ci_low),
                    format!("{:.6}", x.ci_high),
                ]
            })
            .collect(),
    ));
    page.table(Table::new(
        "Single-point reliability R_j(l_c) = Pr[e_j < l_c] across the reached cells (paper eq. 14)",
        &[
            "l_c (mm)",
            "least R_j (1)",
            "median R_j (1)",
            "cells with R_j ≥ 0.99 (count)",
        ],
        r.thresholds
            .iter()
            .enumerate()
            .map(|(t, l)| {
                let mut v: Vec<f64> = reached(r)
                    .filter_map(|c| c.stats.as_ref().map(|s| s.reliability[t].r))
                    .collect();
                v.sort_by(f64::total_cmp);
                vec![
                    fmt_g(*l),
                    format!("{:.6}", v.first().copied().unwrap_or(0.0)),
                    format!("{:.6}", v.get(v.len() / 2).copied().unwrap_or(0.0)),
                    format!(
                        "{} of {}",
                        v.iter().filter(|&&x| x >= 0.99).count(),
                        v.len()
                    ),
                ]
            })
            .collect(),
    ));
    page.heading("Heat maps");
    for (name, svg) in &svgs {
        let (desc, body) = split_text_alternative(svg);
        let mut f = Figure::from_svg(name, &body, &desc);
        f.svg = body;
        page.figure(f);
    }
    for (n, v) in settings {
        page.setting(n, v);
    }
    let q = reference_q(r);
    page.setting("seed", &r.seed.to_string())
        .setting(
            "thresholds",
            &format!(
                "{} mm",
                r.thresholds
                    .iter()
                    .map(|l| fmt_g(*l))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        )
        .setting("reference configuration", &format!("{q} deg"))
        .setting("inverse-kinematics seeds", &r.spec.ik_seeds.to_string())
        .setting(
            "workspace box",
            &format!(
                "centre ({}) mm, edges ({}) mm",
                r.spec.workspace.center.map(fmt_g).join(", "),
                r.spec.workspace.size.map(fmt_g).join(", ")
            ),
        );
    page.backend(&r.backend);
    page.link(HTML_JSON, "every cell and the settings as JSON");
    page.link(CSV_NAME, "one row per cell as CSV");
    page
}
