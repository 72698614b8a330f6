//! The paper's factor study (§3.2–3.4, docs/METHOD.md §5) on a virtual TX60: for each of the five
//! calibration factors over the paper's levels, a repeated simulated calibration, then MCS and
//! AMCS at two tolerances for 10 and 50 test points, and AMCS with the full parameter covariance.
//!
//! [`settings`] holds the factors, levels and effort; [`runner`] runs the study; [`tables`]
//! writes Tables 1 and 2 (and the correlation and accuracy tables) beside the paper's; [`figures`]
//! draws Figs. 4–9 as SVG; [`findings`] turns the numbers into the `STUDY.md` text; [`ranking`]
//! ranks the parameters by their Sobol indices at the baseline calibration and measures which
//! factor reduces the top ones' σ.
//! The study is a [`Report`] (`report.rs`: the files by name and the page);
//! [`write_outputs`] writes everything into a directory.
//!
//! A small study (one factor, two runs per calibration, few draws) that runs in seconds; the
//! paper's is `StudySettings::default()`, the command line's `--quick` is
//! `StudySettings::quick()`:
//!
//! ```
//! use gpu_amcs_core::engine::CpuOnly;
//! use gpu_amcs_core::study::{run_study, write_outputs, Factor, StudySettings};
//! let mut settings = StudySettings::quick();
//! settings.factors = vec![Factor::Speed];
//! settings.baseline.runs = 2;
//! settings.baseline.step_deg = 10.0;
//! settings.point_counts = vec![5];
//! settings.mcs_draws = 2000;
//! settings.sensitivity_draws = 1 << 8;
//! settings.accuracy_points = 5;
//! let result = run_study(&settings, &CpuOnly, None).unwrap();
//! let dir = std::env::temp_dir().join(format!("study-doctest-{}", std::process::id()));
//! write_outputs(&result, &dir).unwrap();
//! assert!(dir.join("STUDY.md").exists());
//! std::fs::remove_dir_all(&dir).unwrap();
//! ```

pub mod beyond;
pub mod figures;
pub mod findings;
pub mod ranking;
mod report;
pub mod runner;
pub mod settings;
pub mod tables;

pub use beyond::{BeyondRow, JointErrorStudy};
pub use runner::{run_study, run_study_on, LevelResult, StudyError, StudyResult};
pub use settings::{Factor, StudySettings};

use crate::report::Report;

/// The files of a study: `(name, contents)`, as [`Report::files`] gives them (everything but the
/// page).
pub fn output_files(s: &StudyResult) -> Vec<(String, String)> {
    s.files()
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
