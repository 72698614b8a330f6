//! The page of one run (AMCS, MCS or merged shards): the headline numbers, the moments and
//! reliability tables, the figures and the run's settings.

use super::pages::{add_settings, link_all, mm, mm_list, prob};
use super::{Figure, Page, Table};
use crate::mc::{McResult, Method};
use crate::report::svg;
use crate::report::text::{finite_or, fmt_g, NA};
use crate::report::RunReport;

/// The method, its tolerance and the run settings of `r` as settings rows.
pub(crate) fn run_settings(page: &mut Page, r: &McResult) {
    page.setting(
        "method",
        match r.method {
            Method::Mcs => "Monte Carlo (MCS)",
            Method::Amcs => "adaptive Monte Carlo (AMCS, GUM S1 §7.9)",
        },
    );
    if let Some(d) = r.numerical_tolerance {
        page.setting("numerical tolerance δ", &mm(d));
    }
    if let Some(n) = r.ndig {
        page.setting("significant digits ndig", &n.to_string());
    }
    page.setting("draws", &r.draws.to_string())
        .setting(
            "batches × batch size",
            &format!("{} × {}", r.batches, r.batch_size),
        )
        .setting(
            "coverage probability p",
            &fmt_g(r.settings.coverage_probability),
        )
        .setting("coverage interval", &format!("{:?}", r.settings.interval))
        .setting("thresholds l_c", &mm_list(&r.settings.thresholds))
        .setting("run time", &format!("{:.3} s", r.seconds))
        .backend(&r.backend);
}

/// The page of one run.
pub fn run_page(
    rep: &RunReport,
    settings: &[(String, String)],
    files: &[(String, String)],
) -> Page {
    let r = &rep.result;
    let method = match r.method {
        Method::Mcs => "MCS",
        Method::Amcs => "AMCS",
    };
    let mut page = Page::new(&format!(
        "Positioning-accuracy reliability ({method}) — {}",
        rep.model
    ));
    let p = r.settings.coverage_probability;
    page.summary("mean of w", &mm(r.estimate))
        .summary("standard uncertainty u(w)", &mm(r.std_uncertainty))
        .summary(
            &format!("{} % coverage interval of w", fmt_g(100.0 * p)),
            &format!(
                "[{}, {}] mm",
                finite_or(r.coverage_interval.low, NA, |x| format!("{x:.6}")),
                finite_or(r.coverage_interval.high, NA, |x| format!("{x:.6}"))
            ),
        )
        .summary("draws", &r.draws.to_string())
        .summary("test points", &rep.points.to_string())
        .summary("run time", &format!("{:.3} s", r.seconds));
    if r.method == Method::Amcs {
        page.summary(
            "status",
            if r.converged {
                "converged"
            } else {
                "NOT converged (draw cap reached)"
            },
        );
    }
    for n in &rep.notes {
        page.note(n);
    }
    page.heading("Maximum position error w = max_j e_j");
    let m = &r.moments;
    let se = &r.moment_standard_errors;
    let opt4 = |v: Option<f64>| v.map_or(NA.to_string(), |x| format!("{x:.4}"));
    let sef = |v: f64| finite_or(v, NA, |x| format!("{x:.1e}"));
    page.table(Table::new(
        "Moments of w with their standard errors",
        &["moment", "value", "standard error"],
        vec![
            vec!["M1 mean (mm)".into(), format!("{:.6}", m.mean), sef(se[0])],
            vec![
                "M2 variance (mm²)".into(),
                format!("{:.6e}", m.variance),
                sef(se[1]),
            ],
            vec!["M3 skewness (1)".into(), opt4(m.skewness), sef(se[2])],
            vec!["M4 kurtosis (1)".into(), opt4(m.kurtosis), sef(se[3])],
            vec![
                "minimum (mm)".into(),
                format!("{:.6}", r.min),
                String::new(),
            ],
            vec![
                "maximum (mm)".into(),
                format!("{:.6}", r.max),
                String::new(),
            ],
        ],
    ));
    page.table(Table::new(
        "Reliability R(l_c) = Pr[w < l_c] with its 95 % binomial (Wilson) confidence interval",
        &["l_c (mm)", "R (1)", "95 % CI low (1)", "95 % CI high (1)"],
        r.reliability
            .iter()
            .map(|x| {
                vec![
                    fmt_g(x.threshold),
                    prob(x.r),
                    prob(x.ci_low),
                    prob(x.ci_high),
                ]
            })
            .collect(),
    ));
    if let Some(pp) = &r.per_point_reliability {
        let head: Vec<String> = std::iter::once("point j".to_string())
            .chain(
                r.settings
                    .thresholds
                    .iter()
                    .map(|t| format!("R_j({} mm)", fmt_g(*t))),
            )
            .collect();
        let head: Vec<&str> = head.iter().map(String::as_str).collect();
        page.table(Table::new(
            "Single-point reliability R_j(l_c) = Pr[e_j < l_c] (paper eq. 14)",
            &head,
            pp.iter()
                .enumerate()
                .map(|(j, row)| {
                    std::iter::once((j + 1).to_string())
                        .chain(row.iter().map(|x| format!("{:.4}", x.r)))
                        .collect()
                })
                .collect(),
        ));
    }
    page.heading("Figures");
    for (name, text) in svg::run_plots(rep) {
        let description = match name.as_str() {
            svg::PDF_SVG => format!(
                "Histogram density (1/mm) of w over {} draws: mean {}, from {} to {}. The values are in pdf.csv.",
                r.draws, mm(r.estimate), mm(r.min), mm(r.max)
            ),
            svg::RELIABILITY_SVG => format!(
                "Empirical reliability R(l_c) = Pr[w < l_c], rising from 0 at {} to 1 at {}; \
                 {} % of the draws lie in [{}, {}] mm. The values are in cdf.csv and reliability.csv.",
                mm(r.min),
                mm(r.max),
                fmt_g(100.0 * p),
                fmt_g(r.coverage_interval.low),
                fmt_g(r.coverage_interval.high)
            ),
            _ => format!(
                "The four fluctuation indices (2s of the batch estimates of the mean of w, u(w) and \
                 the interval ends, mm) per batch on a log axis, with the tolerance δ dashed; the run \
                 {} after {} batches. The values are in trace.csv.",
                if r.converged { "converged" } else { "stopped unconverged" },
                r.batches
            ),
        };
        page.figure(Figure::from_svg(&name, &text, &description));
    }
    page.setting("model", &rep.model);
    add_settings(&mut page, settings);
    page.setting("test points", &rep.points.to_string())
        .setting("reference", &rep.reference)
        .setting("seed of the draws", &rep.seed.to_string());
    run_settings(&mut page, r);
    link_all(&mut page, files);
    page
}
