//! Reports of a run: a readable table for the terminal, JSON with stable field names, CSV files
//! of the curves, Markdown tables and SVG plots of the curves the paper draws (PDF of w, the
//! reliability curve, the convergence of the four fluctuation indices), and one self-contained
//! HTML page that holds them all ([`html`]).
//!
//! Every analysis says once what it writes by implementing [`Report`] ([`outputs`]): a run and a
//! comparison here ([`run`]), sensitivity indices, tail probabilities and maps in their files
//! below; the identification and the factor study, which build on this module, in theirs
//! (`identify::IdentifyReports`, `study::StudyResult`). This module depends on the result types
//! of `mc`, `engine`, `map` and `kinematics` only; nothing it uses depends on it.
//!
//! One file per format; [`write_atomic`] writes a file so that an interrupted or failed run never
//! leaves a half-written file behind.

pub mod csv;
pub mod html;
pub mod json;
pub mod map;
pub mod markdown;
pub mod outputs;
pub mod run;
pub mod sensitivity;
pub mod svg;
pub mod tail;
pub mod text;

pub use outputs::{Layout, Report, INDEX};

use crate::kinematics::RobotModel;
use crate::mc::McResult;
use serde::Serialize;
use std::path::Path;

/// What was analysed, next to the result.
#[derive(Clone, Debug, Serialize)]
pub struct RunReport {
    /// Model name.
    pub model: String,
    /// Number of test points m.
    pub points: usize,
    /// `"calibrated"` or `"nominal: NAME"`.
    pub reference: String,
    /// Seed of the parameter draws.
    pub seed: u64,
    /// Notes for the reader (e.g. the CPU fallback).
    pub notes: Vec<String>,
    /// The Monte Carlo result.
    pub result: McResult,
}

/// The paper's Table 2 for one model: MCS against two AMCS tolerances.
#[derive(Clone, Debug, Serialize)]
pub struct Comparison {
    /// Model name.
    pub model: String,
    /// Number of test points.
    pub points: usize,
    /// Seed.
    pub seed: u64,
    /// The MCS baseline.
    pub mcs: McResult,
    /// `(δ, AMCS result, maximum relative error of M1–M4 against MCS in %)`.
    pub amcs: Vec<(f64, McResult, f64)>,
    /// What the reader should know: about the model ([`model_notes`]) and the backend.
    pub notes: Vec<String>,
}

/// Maximum relative error of M1–M4 of `r` against `base`, in percent (the paper's MRE), over
/// the moments defined in both (see [`crate::mc::Moments::max_relative_error`]).
pub fn max_relative_error(r: &McResult, base: &McResult) -> f64 {
    r.moments.max_relative_error(&base.moments)
}

/// Errors writing reports.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// A file could not be written.
    #[error("cannot write {path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The OS error.
        source: std::io::Error,
    },
}

/// Writes `contents` to `path` through a temporary file in the same directory and a rename.
///
/// # Errors
///
/// [`ReportError::Io`] when the temporary file cannot be written or renamed (no such directory,
/// no permission, disk full); the temporary file is removed.
pub fn write_atomic(path: &Path, contents: &str) -> Result<(), ReportError> {
    let err = |source| ReportError::Io {
        path: path.display().to_string(),
        source,
    };
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = dir.join(format!(".{name}.tmp{}", std::process::id()));
    std::fs::write(&tmp, contents)
        .and_then(|()| std::fs::rename(&tmp, path))
        .map_err(|e| {
            // A write that failed midway (disk full, file size limit) leaves no temporary file.
            let _ = std::fs::remove_file(&tmp);
            err(e)
        })
}

/// Creates `dir` (and parents) and writes each `(file name, contents)` into it atomically.
///
/// # Errors
///
/// [`ReportError::Io`] when `dir` cannot be created or a file cannot be written
/// ([`write_atomic`]); the files written before stay.
pub fn write_files(dir: &Path, files: &[(String, String)]) -> Result<(), ReportError> {
    std::fs::create_dir_all(dir).map_err(|source| ReportError::Io {
        path: dir.display().to_string(),
        source,
    })?;
    for (name, contents) in files {
        write_atomic(&dir.join(name), contents)?;
    }
    Ok(())
}

/// What a report should say about the analysed model beyond its name
/// ([`RobotModel::report_notes`]). The command line and the Python package put these first among
/// a run report's notes.
pub fn model_notes(m: &RobotModel) -> Vec<String> {
    m.report_notes()
}
