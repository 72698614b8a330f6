//! The study as a [`Report`]: `study.json`, Tables 1–2 and the correlation, accuracy and ranking
//! tables as CSV and Markdown, `STUDY.md` (the findings), the paper's tables, Figs. 4–9 as SVG,
//! and the page that shows them.

use super::tables::{
    accuracy_rows, correlation_rows, csv, markdown, paper_table1, paper_table2, table1_rows,
    table2_rows,
};
use super::{figures, findings, ranking, StudyResult, StudySettings};
use crate::report::html::pages::{add_settings, link_all, mm_list};
use crate::report::html::{Figure, Page, Table};
use crate::report::{Layout, Report};

/// The CSV tables, in the order [`Report::csv`] writes them.
const CSV: [&str; 5] = [
    "table1.csv",
    "table2.csv",
    "correlation.csv",
    "accuracy.csv",
    "ranking.csv",
];

/// The table of the robots with joint errors, when the study has them.
const BEYOND_CSV: &str = "beyond.csv";
/// Its Markdown.
const BEYOND_MD: &str = "beyond.md";

/// The other files, in the order [`Report::other`] writes them.
const OTHER: [&str; 7] = [
    "STUDY.md",
    "table1.md",
    "table2.md",
    "correlation.md",
    "accuracy.md",
    "ranking.md",
    "paper_tables.md",
];

impl StudyResult {
    /// The files of a study with `settings`, before it runs (the figures depend on the factors
    /// and tolerances).
    pub fn planned_layout(settings: &StudySettings) -> Layout {
        let mut layout = Layout {
            svg: figures::names(settings),
            ..Layout::new("study.json", &CSV, &[], &OTHER)
        };
        if settings.joint_errors.is_some() {
            layout.csv.push(BEYOND_CSV.into());
            layout.other.push(BEYOND_MD.into());
        }
        layout
    }
}

impl Report for StudyResult {
    fn layout(&self) -> Layout {
        Self::planned_layout(&self.settings)
    }

    fn text(&self) -> String {
        format!(
            "study finished in {:.1} s: {} levels\n",
            self.seconds,
            self.levels.len()
        )
    }

    fn json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_else(|e| format!("{{\"error\": \"{e}\"}}"))
    }

    fn csv(&self) -> Vec<(String, String)> {
        let tables = [
            csv(&table1_rows(self)),
            csv(&table2_rows(self)),
            csv(&correlation_rows(self)),
            csv(&accuracy_rows(self)),
            csv(&ranking::rows(&self.ranking)),
        ];
        let mut files: Vec<(String, String)> =
            CSV.iter().map(|n| n.to_string()).zip(tables).collect();
        if self.settings.joint_errors.is_some() {
            files.push((
                BEYOND_CSV.into(),
                csv(&super::beyond::rows(&self.beyond_geometry)),
            ));
        }
        files
    }

    fn svg(&self) -> Vec<(String, String)> {
        figures::figures(self)
    }

    fn other(&self) -> Vec<(String, String)> {
        let texts = [
            findings::findings(self),
            markdown(&table1_rows(self)),
            markdown(&table2_rows(self)),
            markdown(&correlation_rows(self)),
            markdown(&accuracy_rows(self)),
            ranking_markdown(&self.ranking),
            format!(
                "Table 1\n\n{}\nTable 2\n\n{}",
                paper_table1(),
                paper_table2()
            ),
        ];
        let mut files: Vec<(String, String)> =
            OTHER.iter().map(|n| n.to_string()).zip(texts).collect();
        if self.settings.joint_errors.is_some() {
            files.push((
                BEYOND_MD.into(),
                markdown(&super::beyond::rows(&self.beyond_geometry)),
            ));
        }
        files
    }

    fn page(&self, settings: &[(String, String)], files: &[(String, String)]) -> String {
        study_page(self, settings, files)
    }
}

/// `ranking.md`: the parameters by total index, then the factor levels' effect on the top ones.
fn ranking_markdown(r: &ranking::ParameterRanking) -> String {
    format!(
        "Parameters by total Sobol index of w (baseline calibration, N = {}, {} evaluations)\n\n{}\n\
         σ of the top parameters at each factor level, over the baseline (best level in bold)\n\n{}",
        r.sensitivity.analysis.draws,
        r.sensitivity.analysis.evaluations,
        markdown(&ranking::parameter_rows(r)),
        markdown(&ranking::rows(r))
    )
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

/// The study's page, linking `files` (the study's own files, written beside it); `settings` are
/// rows only the caller knows.
fn study_page(
    s: &StudyResult,
    settings: &[(String, String)],
    files: &[(String, String)],
) -> String {
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
    let beyond = s.settings.joint_errors.is_some().then(|| {
        (
            "Robots with joint errors: before calibration, geometric calibration, full model",
            super::beyond::rows(&s.beyond_geometry),
        )
    });
    page.heading("Tables");
    for (caption, (h, rows)) in tables.into_iter().chain(beyond) {
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
    add_settings(&mut page, settings);
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
