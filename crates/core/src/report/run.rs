//! A run ([`RunReport`]) and a comparison ([`Comparison`]) as [`Report`]s: the text, JSON, CSV,
//! Markdown and SVG writers of this module, and their pages ([`super::html::run`],
//! [`super::html::comparison`]).

use super::html::comparison::{comparison_csv, comparison_page, comparison_plots};
use super::html::run::run_page;
use super::{csv, json, markdown, svg, text, Comparison, Layout, Report, RunReport};

/// The JSON document of a run in a report directory.
const RUN_JSON: &str = "report.json";
/// The JSON document of a comparison in a report directory.
const COMPARISON_JSON: &str = "comparison.json";
/// The table of a comparison.
const COMPARISON_CSV: &str = "comparison.csv";
/// The Markdown table of a comparison.
const COMPARISON_MD: &str = "comparison.md";

impl RunReport {
    /// The files of a run's report, before it runs (the trace and the single-point table are
    /// written only when the run has them).
    pub fn planned_layout() -> Layout {
        Layout::new(RUN_JSON, &csv::NAMES, &svg::RUN_PLOTS, &[])
    }
}

impl Report for RunReport {
    fn layout(&self) -> Layout {
        Self::planned_layout()
    }

    fn text(&self) -> String {
        text::render(self)
    }

    fn json(&self) -> String {
        json::render_run(self)
    }

    fn csv(&self) -> Vec<(String, String)> {
        csv::files(self)
    }

    fn svg(&self) -> Vec<(String, String)> {
        svg::run_plots(self)
    }

    fn page(&self, settings: &[(String, String)], files: &[(String, String)]) -> String {
        run_page(self, settings, files).render()
    }
}

impl Comparison {
    /// The files of a comparison's report, before it runs.
    pub fn planned_layout() -> Layout {
        Layout::new(
            COMPARISON_JSON,
            &[COMPARISON_CSV],
            &svg::COMPARISON_PLOTS,
            &[COMPARISON_MD],
        )
    }
}

impl Report for Comparison {
    fn layout(&self) -> Layout {
        Self::planned_layout()
    }

    fn text(&self) -> String {
        text::render_comparison(self)
    }

    fn json(&self) -> String {
        json::render_comparison(self)
    }

    fn csv(&self) -> Vec<(String, String)> {
        vec![(COMPARISON_CSV.to_string(), comparison_csv(self))]
    }

    fn svg(&self) -> Vec<(String, String)> {
        comparison_plots(self)
            .into_iter()
            .map(|(name, plot)| (name, plot.render()))
            .collect()
    }

    fn other(&self) -> Vec<(String, String)> {
        vec![(COMPARISON_MD.to_string(), markdown::render_comparison(self))]
    }

    fn page(&self, settings: &[(String, String)], files: &[(String, String)]) -> String {
        comparison_page(self, settings, files).render()
    }
}
