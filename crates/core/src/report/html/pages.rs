//! The HTML pages of the reports: one run (AMCS, MCS or merged shards), the MCS/AMCS comparison,
//! the factor study, the Sobol sensitivity indices and the tail probabilities. Each `*_files`
//! function returns every file of the report directory, `index.html` last: the page and the
//! JSON, CSV and SVG files it links to, so the directory is the whole report.
//!
//! `settings` are rows the caller adds to the model-and-settings table (where the model came
//! from, the number of uncertain parameters, the test points): what the library cannot know.

use super::{Figure, Page, Table};
use crate::mc::sensitivity::SensitivityResult;
use crate::mc::stats::{ecdf_grid, histogram};
use crate::mc::tail::{TailOutcome, TailResult};
use crate::mc::{McResult, Method};
use crate::report::svg::{LinePlot, Series};
use crate::report::text::{finite_or, fmt_g, NA};
use crate::report::{csv, json, markdown, svg, Comparison, RunReport};
use crate::study::StudyResult;

/// Name of the page in a report directory.
pub const INDEX: &str = "index.html";

/// A value in mm with 6 decimals (the text report's precision), or "n/a".
fn mm(v: f64) -> String {
    finite_or(v, NA, |x| format!("{x:.6} mm"))
}

/// A probability with 6 decimals, or "n/a".
fn prob(v: f64) -> String {
    finite_or(v, NA, |x| format!("{x:.6}"))
}

/// A short number list in mm: `"0.1, 0.2 mm"`.
fn mm_list(v: &[f64]) -> String {
    let s: Vec<String> = v.iter().map(|x| fmt_g(*x)).collect();
    format!("{} mm", s.join(", "))
}

fn add_settings(page: &mut Page, settings: &[(String, String)]) {
    for (n, v) in settings {
        page.setting(n, v);
    }
}

/// The link description of a file of a report directory, by its name.
fn describe_file(name: &str) -> &'static str {
    match name {
        "report.json" | "comparison.json" | "study.json" | "sensitivity.json" | "tail.json" => {
            "the full report as JSON"
        }
        "cdf.csv" => "empirical CDF of w (CSV)",
        "pdf.csv" => "histogram density of w (CSV)",
        "reliability.csv" => "reliability R(l_c) with confidence intervals (CSV)",
        "trace.csv" => "AMCS batch trace (CSV)",
        "per_point.csv" => "single-point reliabilities R_j(l_c) (CSV)",
        n if n.ends_with(".svg") => "figure (SVG)",
        n if n.ends_with(".csv") => "table (CSV)",
        n if n.ends_with(".md") => "text (Markdown)",
        _ => "file",
    }
}

/// Links every file but the page itself.
fn link_all(page: &mut Page, files: &[(String, String)]) {
    for (name, _) in files {
        if name != INDEX {
            page.link(name, describe_file(name));
        }
    }
}

/// The method, its tolerance and the run settings of `r` as settings rows.
fn run_settings(page: &mut Page, r: &McResult) {
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
            "pdf.svg" => format!(
                "Histogram density (1/mm) of w over {} draws: mean {}, from {} to {}. The values are in pdf.csv.",
                r.draws, mm(r.estimate), mm(r.min), mm(r.max)
            ),
            "reliability.svg" => format!(
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

/// Every file of a run's report directory: `report.json`, the CSV and SVG files, `index.html`.
pub fn run_files(rep: &RunReport, settings: &[(String, String)]) -> Vec<(String, String)> {
    let mut files = vec![("report.json".to_string(), json::render_run(rep))];
    files.extend(csv::files(rep));
    files.extend(svg::run_plots(rep));
    let page = run_page(rep, settings, &files).render();
    files.push((INDEX.to_string(), page));
    files
}

/// The comparison's figures: PDF and reliability of MCS and each AMCS run, overlaid.
fn comparison_plots(c: &Comparison) -> Vec<(String, LinePlot)> {
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
            "pdf.svg".into(),
            LinePlot {
                title: format!("PDF of w, MCS and AMCS — {}", c.model),
                x_label: "w (mm)".into(),
                y_label: "density (1/mm)".into(),
                series: series(|v| histogram(v, 100)),
                log_y: false,
            },
        ),
        (
            "reliability.svg".into(),
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

/// Every file of a comparison's report directory: `comparison.json`, `comparison.md`,
/// `comparison.csv`, `pdf.svg`, `reliability.svg`, `index.html`.
pub fn comparison_files(c: &Comparison, settings: &[(String, String)]) -> Vec<(String, String)> {
    let header: Vec<String> = markdown::COMPARISON_HEADER
        .iter()
        .map(|h| h.to_string())
        .collect();
    let rows = markdown::comparison_rows(c);
    let table = (header, rows);
    let plots = comparison_plots(c);
    let mut files = vec![
        ("comparison.json".to_string(), json::render_comparison(c)),
        ("comparison.md".to_string(), markdown::render_comparison(c)),
        (
            "comparison.csv".to_string(),
            crate::study::tables::csv(&table),
        ),
    ];
    files.extend(plots.iter().map(|(n, p)| (n.clone(), p.render())));
    let mut page = Page::new(&format!("MCS against AMCS — {}", c.model));
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
        let what = if name == "pdf.svg" {
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
    link_all(&mut page, &files);
    files.push((INDEX.to_string(), page.render()));
    files
}

/// The text alternative of a study figure, by its file name.
fn study_figure_description(name: &str) -> String {
    let factor = name
        .trim_end_matches(".svg")
        .split('_')
        .nth(2)
        .unwrap_or("")
        .to_string();
    if name.starts_with("fig4") {
        format!("PDF of w (density, 1/mm, against w in mm) by AMCS at the smaller δ, one curve per level of the factor {factor}; the moments are in table2.csv.")
    } else if name.starts_with("fig5") {
        format!("Reliability R_c(l_c) (against l_c in mm), one curve per level of the factor {factor}; the values at the paper's thresholds are in table1.csv.")
    } else {
        format!("The four AMCS fluctuation indices (mm, log axis) per batch at the baseline level of the factor {factor}, with δ dashed; the run stops when all four are at or below δ.")
    }
}

/// The study's page, linking `files` (the study's own output files, written beside it).
pub fn study_page(s: &StudyResult, files: &[(String, String)]) -> String {
    use crate::study::tables::{accuracy_rows, correlation_rows, table1_rows, table2_rows};
    let mut page = Page::new(&format!("Calibration factor study — virtual {}", s.robot));
    let factors: Vec<&str> = s.settings.factors.iter().map(|f| f.name()).collect();
    page.summary("factors", &factors.join(", "))
        .summary("levels", &s.levels.len().to_string())
        .summary("MCS draws per level", &s.settings.mcs_draws.to_string())
        .summary("AMCS tolerances δ", &mm_list(&s.settings.deltas))
        .summary("run time", &format!("{:.1} s", s.seconds));
    for n in &s.notes {
        page.note(n);
    }
    page.paragraph(
        "Each level of a factor is a repeated simulated calibration of the virtual robot; MCS \
         and AMCS then propagate the spread of the identified parameters to the maximum position \
         error w over the test points (STUDY.md explains the findings).",
    );
    let tables = [
        (
            "Table 1: reliability R_c(l_c) by MCS, per factor level",
            table1_rows(s),
        ),
        (
            "Table 2: moments of w by MCS and AMCS, per factor level",
            table2_rows(s),
        ),
        (
            "Correlation of the identified parameters",
            correlation_rows(s),
        ),
        ("Accuracy before and after calibration", accuracy_rows(s)),
    ];
    page.heading("Tables");
    for (caption, (h, rows)) in tables {
        let h: Vec<&str> = h.iter().map(String::as_str).collect();
        page.table(Table::new(caption, &h, rows));
    }
    page.heading("Figures");
    for (name, text) in files.iter().filter(|(n, _)| n.ends_with(".svg")) {
        page.figure(Figure::from_svg(
            name,
            text,
            &study_figure_description(name),
        ));
    }
    let st = &s.settings;
    page.setting("true robot", &s.robot)
        .setting(
            "calibration runs at the baseline",
            &st.baseline.runs.to_string(),
        )
        .setting("test point counts", &format!("{:?}", st.point_counts))
        .setting("AMCS batch size", &st.batch.to_string())
        .setting("thresholds l_c", &mm_list(&st.thresholds))
        .setting("seed of the true robot", &st.robot_seed.to_string())
        .setting(
            "seed of the calibration runs",
            &st.calibration_seed.to_string(),
        )
        .setting("seed of the draws", &st.mc_seed.to_string())
        .setting("seed of the test points", &st.points_seed.to_string())
        .setting("backend", &format!("{:?}", st.backend))
        .setting("adapter", st.adapter.as_deref().unwrap_or("any"))
        .setting("quick study", if st.quick { "yes" } else { "no" });
    link_all(&mut page, files);
    page.render()
}

fn estimate_cells(e: &crate::mc::sensitivity::Estimate) -> [String; 3] {
    let o = |v: Option<f64>| v.map_or(NA.to_string(), |x| format!("{x:.4}"));
    [format!("{:.4}", e.value), o(e.ci_low), o(e.ci_high)]
}

/// Every file of a sensitivity report directory: `sensitivity.json`, `indices.csv`, the bar
/// charts, `index.html`.
pub fn sensitivity_files(
    r: &SensitivityResult,
    settings: &[(String, String)],
) -> Vec<(String, String)> {
    use crate::report::sensitivity as rs;
    let mut files = vec![
        ("sensitivity.json".to_string(), rs::render_json(r)),
        ("indices.csv".to_string(), rs::render_csv(r)),
    ];
    let charts = rs::render_svg(r);
    files.extend(charts.iter().cloned());
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
            crate::mc::sensitivity::Quantity::Value => "w".to_string(),
            crate::mc::sensitivity::Quantity::Exceedance { threshold } => {
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
        let level = if name == "groups.svg" {
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
    link_all(&mut page, &files);
    files.push((INDEX.to_string(), page.render()));
    files
}

/// Every file of a tail report directory: `tail.json`, `tail.csv`, `tail.svg`, `index.html`.
pub fn tail_files(r: &TailResult, settings: &[(String, String)]) -> Vec<(String, String)> {
    use crate::report::tail as rt;
    let mut files = vec![
        ("tail.json".to_string(), rt::render_json(r)),
        ("tail.csv".to_string(), rt::render_csv(r)),
    ];
    let plots = rt::render_svg(r);
    files.extend(plots.iter().cloned());
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
    link_all(&mut page, &files);
    files.push((INDEX.to_string(), page.render()));
    files
}
