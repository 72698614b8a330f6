//! Errors as Python exceptions: one line, the Python argument named where the command line
//! names its flag (`job_error` for every analysis's job).

use gpu_amcs_core::job::{JobError, JobSetting, MemoryCheck};
use gpu_amcs_core::map::{MapError, MapSetting};
use gpu_amcs_core::mc::sensitivity::{SensitivityError, SensitivitySetting};
use gpu_amcs_core::mc::tail::{TailError, TailSetting};
use gpu_amcs_core::mc::{McError, Setting};
use gpu_amcs_core::memory::{LimitSource, MemoryError};
use gpu_amcs_core::plan::{PlanError, PlanField};
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

/// A setting error `"field (keyword): message"`, as the command line's `"field (--flag): …"`.
pub fn setting_error(field: impl std::fmt::Display, kw: Option<&str>, message: &str) -> PyErr {
    match kw {
        Some(k) => value_error(format!("{field} ({k}): {message}")),
        None => value_error(format!("{field}: {message}")),
    }
}

/// A sensitivity error with the keyword that sets its field.
pub fn sensitivity_error(e: SensitivityError) -> PyErr {
    match e {
        SensitivityError::Setting { field, message } => {
            let kw = match field {
                SensitivitySetting::Draws => Some("draws"),
                SensitivitySetting::Bootstrap => Some("bootstrap"),
                SensitivitySetting::Thresholds => Some("thresholds"),
                SensitivitySetting::Chunk => None,
            };
            setting_error(field, kw, &message)
        }
        other => lib_error(other),
    }
}

/// A tail error with the keyword that sets its field.
pub fn tail_error(e: TailError) -> PyErr {
    match e {
        TailError::Setting { field, message } => {
            let kw = match field {
                TailSetting::Thresholds => Some("threshold"),
                TailSetting::TargetCov => Some("cov"),
                TailSetting::MaxEvaluations => Some("max_evaluations"),
                TailSetting::SamplesPerLevel => Some("samples_per_level"),
                TailSetting::P0 => Some("p0"),
                TailSetting::ProposalSpread | TailSetting::BatchSize => None,
            };
            setting_error(field, kw, &message)
        }
        other => lib_error(other),
    }
}

/// A map error with the keyword that sets its field.
pub fn map_error(e: MapError) -> PyErr {
    match e {
        MapError::Setting { field, message } => {
            let kw = match field {
                MapSetting::Cells => "cells",
                MapSetting::Plane => "plane",
                MapSetting::PlanePosition => "at",
                MapSetting::Workspace => "box_center/box_size",
                MapSetting::Orientation => "orientation",
                MapSetting::ReferenceConfiguration => "reference_q",
                MapSetting::IkSeeds => "ik_seeds",
                MapSetting::Thresholds => "thresholds",
                MapSetting::Draws => "draws",
            };
            setting_error(field, Some(kw), &message)
        }
        other => lib_error(other),
    }
}

/// The keyword of a plan setting.
fn plan_keyword(f: PlanField) -> &'static str {
    match f {
        PlanField::Poses => "poses",
        PlanField::Candidates => "candidates",
        PlanField::Sigma => "tracker_sigma",
        PlanField::Tracker => "tracker_at",
        PlanField::TrackerRange => "tracker_range",
        PlanField::MaxIncidence => "max_incidence",
        PlanField::Thresholds => "threshold",
        PlanField::Search => "draws",
        PlanField::TaskPoints => "q_deg",
        PlanField::Target => "target",
        PlanField::Floor => "floor",
        PlanField::KeepOut => "keep_out",
        PlanField::LinkRadius => "link_radius",
        PlanField::SelfCollision => "self_collision",
        PlanField::Program => "program",
        PlanField::Approach => "approach",
    }
}

/// A plan error with the keyword that sets its field.
pub fn plan_error(e: PlanError) -> PyErr {
    match e {
        PlanError::Setting { field, message } => {
            value_error(format!("{field} ({}): {message}", plan_keyword(field)))
        }
        PlanError::Unused {
            field,
            needs,
            message,
        } => {
            let needs: Vec<&str> = needs.into_iter().map(plan_keyword).collect();
            value_error(format!(
                "{field} ({}): {message} ({})",
                plan_keyword(field),
                needs.join(", ")
            ))
        }
        PlanError::NotIdentifiable(m) => value_error(format!(
            "the candidates do not identify the model (target, candidates): {m}"
        )),
        other => value_error(other.to_string()),
    }
}

/// What to change when a job's memory estimate `check` does not fit, in keywords.
fn memory_advice(check: MemoryCheck, library: &str) -> String {
    match check {
        MemoryCheck::Amcs => "lower max_draws or batch, use fewer points or per_point=False",
        MemoryCheck::Mcs => "use fewer draws (or amcs), fewer points or per_point=False",
        MemoryCheck::McsSummary => "use fewer points or per_point=False",
        MemoryCheck::Compare => "use fewer draws or points",
        MemoryCheck::Sensitivity => "use fewer draws",
        MemoryCheck::Tail => "use fewer samples_per_level",
        MemoryCheck::Map { .. } => library,
        MemoryCheck::PlanSearch => "use fewer candidates",
        MemoryCheck::PlanPrediction => "use fewer draws",
    }
    .to_string()
}

/// A memory refusal as a `ValueError`: `memory_limit` named when the limit was given.
pub fn memory_error(e: MemoryError) -> PyErr {
    match e {
        MemoryError::TooLarge {
            source_of_limit: LimitSource::User,
            ..
        } => value_error(format!("memory_limit: {}", one_line(&e))),
        e => lib_error(e),
    }
}

/// A job error as a `ValueError` naming the keyword (a spec's own: `Spec::job_error`, which
/// knows whether the nominal model came from `preset`).
pub fn job_error(e: JobError) -> PyErr {
    match e {
        JobError::Spec(e) => arg_error(crate::problem::keyword(e.field), e.kind),
        JobError::Memory { check, error } => {
            let advice = memory_advice(check, error.advice());
            let e = memory_error(error.with_advice(advice));
            match check {
                MemoryCheck::Map { .. } => value_error(format!("draws, cells: {e}")),
                _ => e,
            }
        }
        JobError::Setting { setting, message } => {
            let kw = match setting {
                JobSetting::Shard => "shard",
                JobSetting::Task => "iso9283",
                JobSetting::Reference => "reference",
                JobSetting::Frame => "frame",
            };
            value_error(format!("{kw}: {message}"))
        }
        JobError::Run(e) => driver_error(e),
        JobError::Sensitivity(e) => sensitivity_error(e),
        JobError::Tail(e) => tail_error(e),
        JobError::Map(e) => map_error(e),
        JobError::Plan(e) => plan_error(e),
        JobError::Reached(e) => arg_error("reached configurations", e),
        e @ JobError::Summary(_) => lib_error(e),
    }
}
