//! The page of a tail-probability run: `P_f` and β at each threshold, the figure and the
//! estimator's settings.

use super::pages::{add_settings, link_all};
use super::{Figure, Page, Table};
use crate::mc::tail::{TailOutcome, TailResult};
use crate::report::tail::render_svg;
use crate::report::text::{fmt_g, NA};

/// The page of a tail-probability run, linking `files`.
pub fn tail_page(
    r: &TailResult,
    settings: &[(String, String)],
    files: &[(String, String)],
) -> Page {
    let plots = render_svg(r);
    let mut page = Page::new("Tail probability of the maximum position error w");
    let o = |v: Option<f64>, f: &dyn Fn(f64) -> String| v.map_or(NA.to_string(), f);
    for e in &r.estimates {
        page.summary(
            &format!("P_f = Pr[w ≥ {} mm]", fmt_g(e.threshold)),
            &format!("{:.3e}", e.p_f),
        );
    }
    page.summary("evaluations of w", &r.evaluations.to_string())
        .summary("run time", &format!("{:.3} s", r.seconds));
    match r.outcome {
        TailOutcome::TargetReached => {}
        TailOutcome::EvaluationCapReached => {
            page.note("The evaluation cap ended the run before every estimate reached the target coefficient of variation.");
        }
        TailOutcome::LevelLimitReached => {
            page.note("The largest threshold is beyond what w reaches within the level limit of subset simulation.");
        }
    }
    page.heading("Estimates");
    page.table(Table::new(
        "Failure probability P_f = Pr[w ≥ L], its coefficient of variation and reliability index β",
        &[
            "L (mm)",
            "P_f (1)",
            "CoV (1)",
            "CoV, levels independent (1)",
            "β (1)",
        ],
        r.estimates
            .iter()
            .map(|e| {
                vec![
                    fmt_g(e.threshold),
                    format!("{:.4e}", e.p_f),
                    o(e.cov, &|x| format!("{x:.3}")),
                    o(e.cov_independent_levels, &|x| format!("{x:.3}")),
                    o(e.beta, &|x| format!("{x:.3}")),
                ]
            })
            .collect(),
    ));
    page.heading("Figures");
    for (name, text) in &plots {
        page.figure(Figure::from_svg(
            name,
            text,
            "The estimated P_f against the threshold L (mm) on a log axis, with ±2·CoV error bars, \
             and for subset simulation the level thresholds of the last run as a line; the numbers \
             are in the table above and in tail.csv.",
        ));
    }
    add_settings(&mut page, settings);
    page.setting("method", &format!("{:?}", r.method))
        .setting("target coefficient of variation", &fmt_g(r.target_cov))
        .setting("evaluation cap", &r.max_evaluations.to_string())
        .setting(
            "dimension of the standard-normal space",
            &r.dimension.to_string(),
        );
    if let Some(sub) = &r.subset {
        page.setting(
            "samples per level (pilot)",
            &sub.pilot_samples_per_level.to_string(),
        )
        .setting("level probability p0", &fmt_g(sub.p0));
    }
    page.backend(&r.backend);
    link_all(&mut page, files);
    page
}
