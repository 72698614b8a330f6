//! The paper's factor study (§3.2–3.4, docs/METHOD.md §5) on a virtual TX60: for each of the five
//! calibration factors over the paper's levels, a repeated simulated calibration, then MCS and
//! AMCS at two tolerances for 10 and 50 test points, and AMCS with the full parameter covariance.
//!
//! [`settings`] holds the factors, levels and effort; [`runner`] runs the study; [`tables`]
//! writes Tables 1 and 2 (and the correlation and accuracy tables) beside the paper's; [`figures`]
//! draws Figs. 4–9 as SVG; [`findings`] turns the numbers into the `STUDY.md` text; [`ranking`]
//! ranks the parameters by their Sobol indices at the baseline calibration and measures which
//! factor reduces the top ones' σ.
//! [`write_outputs`] writes everything into a directory.
//!
//! ```no_run
//! use gpu_amcs_core::engine::CpuOnly;
//! use gpu_amcs_core::study::{run_study, write_outputs, StudySettings};
//! let result = run_study(&StudySettings::quick(), &CpuOnly, None).unwrap();
//! write_outputs(&result, std::path::Path::new("study-out")).unwrap();
//! ```

pub mod figures;
pub mod findings;
pub mod ranking;
pub mod runner;
pub mod settings;
pub mod tables;

pub use runner::{run_study, run_study_on, LevelResult, StudyError, StudyResult};
pub use settings::{Factor, StudySettings};

/// The files of a study: `(name, contents)`.
pub fn output_files(s: &StudyResult) -> Vec<(String, String)> {
    use tables::*;
    let mut files = vec![
        ("STUDY.md".to_string(), findings::findings(s)),
        ("table1.md".into(), markdown(&table1_rows(s))),
        ("table1.csv".into(), csv(&table1_rows(s))),
        ("table2.md".into(), markdown(&table2_rows(s))),
        ("table2.csv".into(), csv(&table2_rows(s))),
        ("correlation.md".into(), markdown(&correlation_rows(s))),
        ("correlation.csv".into(), csv(&correlation_rows(s))),
        ("accuracy.md".into(), markdown(&accuracy_rows(s))),
        ("accuracy.csv".into(), csv(&accuracy_rows(s))),
        ("ranking.md".into(), ranking_markdown(&s.ranking)),
        ("ranking.csv".into(), csv(&ranking::rows(&s.ranking))),
        (
            "paper_tables.md".into(),
            format!(
                "Table 1\n\n{}\nTable 2\n\n{}",
                paper_table1(),
                paper_table2()
            ),
        ),
        (
            "study.json".into(),
            serde_json::to_string_pretty(s).unwrap_or_else(|e| format!("{{\"error\": \"{e}\"}}")),
        ),
    ];
    files.extend(figures::figures(s));
    files
}

/// Writes [`output_files`] into `dir` (created if needed).
///
/// # Errors
///
/// [`StudyError::Report`] when `dir` cannot be created or a file cannot be written.
pub fn write_outputs(s: &StudyResult, dir: &std::path::Path) -> Result<(), StudyError> {
    crate::report::write_files(dir, &output_files(s))?;
    Ok(())
}

/// `ranking.md`: the parameters by total index, then the factor levels' effect on the top ones.
fn ranking_markdown(r: &ranking::ParameterRanking) -> String {
    format!(
        "Parameters by total Sobol index of w (baseline calibration, N = {}, {} evaluations)\n\n{}\n\
         σ of the top parameters at each factor level, over the baseline (best level in bold)\n\n{}",
        r.sensitivity.analysis.draws,
        r.sensitivity.analysis.evaluations,
        tables::markdown(&ranking::parameter_rows(r)),
        tables::markdown(&ranking::rows(r))
    )
}
