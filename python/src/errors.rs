//! Errors as Python exceptions: one line, the Python argument named where the command line
//! names its flag.

use gpu_amcs_core::mc::{McError, Setting};
use pyo3::exceptions::PyValueError;
use pyo3::PyErr;

/// The error and its causes on one line, each cause once (a cause whose text the line already
/// holds is skipped), as the command line prints them.
pub fn one_line(e: &(dyn std::error::Error + 'static)) -> String {
    let mut line = String::new();
    let mut cur = Some(e);
    while let Some(c) = cur {
        let text = c
            .to_string()
            .split_whitespace()
            .collect::<Vec<_>>()
            .join(" ");
        if !text.is_empty() && !line.contains(&text) {
            if !line.is_empty() {
                line.push_str(": ");
            }
            line.push_str(&text);
        }
        cur = c.source();
    }
    line
}

/// A `ValueError` carrying `message`.
pub fn value_error(message: impl Into<String>) -> PyErr {
    PyValueError::new_err(message.into())
}

/// A `ValueError` for a library error, its chain on one line.
pub fn lib_error(e: impl std::error::Error + 'static) -> PyErr {
    value_error(one_line(&e))
}

/// A `ValueError` for a library error about the argument `arg`: `"arg: error"`.
pub fn arg_error(arg: &str, e: impl std::error::Error + 'static) -> PyErr {
    value_error(format!("{arg}: {}", one_line(&e)))
}

/// The keyword argument of `mcs`/`amcs` that sets a driver setting (the command line's flag).
pub fn keyword(s: Setting) -> Option<&'static str> {
    Some(match s {
        Setting::CoverageProbability => "coverage",
        Setting::Thresholds => "thresholds",
        Setting::Tolerance => "delta",
        Setting::SignificantDigits => "ndig",
        Setting::BatchSize => "batch",
        Setting::MaxDraws => "max_draws",
        Setting::Draws => "draws",
        Setting::Chunk => return None,
    })
}

/// A driver error with the keyword added to a setting's name, as the command line adds the flag.
pub fn driver_error(e: McError) -> PyErr {
    match e {
        McError::Setting { field, message } => match keyword(field) {
            Some(k) => value_error(format!("{field} ({k}): {message}")),
            None => value_error(format!("{field}: {message}")),
        },
        other => lib_error(other),
    }
}
