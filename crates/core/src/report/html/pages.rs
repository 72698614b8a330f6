//! What the report pages share: number formats, the settings rows the caller adds, and the links
//! to the files of a report directory. The pages themselves live with their reports
//! ([`super::run`], [`super::comparison`], [`super::sensitivity`], [`super::tail`], the map's in
//! `report::map`, the study's and the identification's in their modules); each is the `page` of
//! a [`Report`](crate::report::Report), which puts it in a directory with the JSON, CSV and SVG
//! files it links to, so the directory is the whole report.
//!
//! `settings` are rows the caller adds to the model-and-settings table (where the model came
//! from, the number of uncertain parameters, the test points): what the library cannot know.

use super::Page;
use crate::report::text::{finite_or, fmt_g, NA};
use crate::report::INDEX;

/// A value in mm with 6 decimals (the text report's precision), or "n/a".
pub fn mm(v: f64) -> String {
    finite_or(v, NA, |x| format!("{x:.6} mm"))
}

/// A probability with 6 decimals, or "n/a".
pub fn prob(v: f64) -> String {
    finite_or(v, NA, |x| format!("{x:.6}"))
}

/// A short number list in mm: `"0.1, 0.2 mm"`.
pub fn mm_list(v: &[f64]) -> String {
    let s: Vec<String> = v.iter().map(|x| fmt_g(*x)).collect();
    format!("{} mm", s.join(", "))
}

/// Adds the caller's rows to the model-and-settings table.
pub fn add_settings(page: &mut Page, settings: &[(String, String)]) {
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
        n if n.ends_with(".json") => "the full report as JSON",
        n if n.ends_with(".csv") => "table (CSV)",
        n if n.ends_with(".md") => "text (Markdown)",
        _ => "file",
    }
}

/// Links every file but the page itself.
pub fn link_all(page: &mut Page, files: &[(String, String)]) {
    for (name, _) in files {
        if name != INDEX {
            page.link(name, describe_file(name));
        }
    }
}
