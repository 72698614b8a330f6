//! `gpu_amcs.identify`: MDH parameters from laser-tracker data, as `gpu-amcs identify` computes
//! them: both run the library's one [`IdentifyJob`], so the nominal model, options, model (what
//! `--out` writes), warnings and printed text are the same.

use crate::errors::{arg_error, lib_error, value_error};
use crate::model::PyModel;
use gpu_amcs_core::identify::{
    self as lib, CircleFitMethod, Identification, IdentifyJob, IdentifyJobError, IdentifySetting,
    JointErrorFit, Placement, UncertaintyMethod,
};
use gpu_amcs_core::kinematics::RobotModel;
use gpu_amcs_core::report::Report;
use gpu_amcs_core::spec::ModelSource;
use pyo3::prelude::*;
use std::path::PathBuf;

/// The result of an identification: the model (`to_toml()` is the file `--out` writes), the
/// per-run models and reports, the warnings and the text the command line prints.
#[pyclass(module = "gpu_amcs", name = "IdentifyResult", frozen)]
pub struct PyIdentifyResult {
    model: RobotModel,
    runs: Vec<Identification>,
    warnings: Vec<String>,
    /// The report of the runs (its JSON is the command line's `--json` document).
    reports: lib::IdentifyReports,
    /// The line after the tables: the single-run note or the statistics of the runs.
    closing: String,
    /// The model file the command line writes (the model and its provenance).
    file_text: String,
}

/// A model as a Python `Model` (not from a preset), with the `[provenance]` table of
/// `file_text` (its model file: the model's TOML, then the table) when given, as written there.
fn py_model(m: &RobotModel, file_text: Option<&str>) -> PyModel {
    let own = m.to_toml();
    PyModel {
        model: m.clone(),
        preset: None,
        provenance: file_text.and_then(|t| {
            t.strip_prefix(own.as_str())
                .filter(|rest| !rest.is_empty())
                .map(str::to_string)
                .or_else(|| lib::validate::provenance_table(t))
        }),
    }
}

impl crate::reports::PyReport for PyIdentifyResult {
    fn report(&self) -> &dyn Report {
        &self.reports
    }
}

crate::report_class!(PyIdentifyResult, {
    /// The identified model: one run's parameters with the nominal model's uncertainty, or the
    /// mean of several runs with their run-to-run σ (or full covariance with
    /// `covariance=True`). `model.to_toml()` is the file `gpu-amcs identify --out` writes,
    /// its `[provenance]` (frame, nominal model) included.
    #[getter]
    fn model(&self) -> PyModel {
        py_model(&self.model, Some(&self.file_text))
    }

    /// The model of each run.
    #[getter]
    fn models(&self) -> Vec<PyModel> {
        self.runs.iter().map(|i| py_model(&i.model, None)).collect()
    }

    /// The warnings the command line prints (one line per joint and kind of problem).
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.warnings.clone()
    }

    /// The text the command line prints: the summary, or every run's per-joint tables with
    /// `verbose=True`, then the line on the model's uncertainty.
    #[pyo3(signature = (verbose = false))]
    fn to_text(&self, verbose: bool) -> String {
        let mut text = String::new();
        if verbose {
            for id in &self.runs {
                text.push_str(&lib::render_identify_report(&id.report));
                text.push('\n');
            }
        } else {
            text.push_str(&lib::render_identify_summary(
                self.runs.iter().map(|i| &i.report),
            ));
        }
        text.push_str(&self.closing);
        text.push('\n');
        text
    }

    /// The identified model file (TOML), as `--out` writes it: the model, then its
    /// `[provenance]` (data file and SHA-256, points, residuals, rank, condition, noise, frame).
    fn to_toml(&self) -> String {
        self.file_text.clone()
    }

    fn __repr__(&self) -> String {
        format!(
            "gpu_amcs.IdentifyResult(model='{}', runs={}, warnings={})",
            self.model.name,
            self.runs.len(),
            self.warnings.len()
        )
    }
});

/// The `columns` and `delimiter` keywords as a column map (a delimiter alone maps nothing).
fn column_map(
    columns: Option<&str>,
    delimiter: Option<&str>,
) -> PyResult<Option<gpu_amcs_core::identify::ColumnMap>> {
    use gpu_amcs_core::identify::{ColumnMap, ColumnMapSetting};
    ColumnMap::from_settings(columns, delimiter).map_err(|(setting, message)| {
        let keyword = match setting {
            ColumnMapSetting::Map => "columns",
            ColumnMapSetting::Delimiter => "delimiter",
        };
        value_error(format!("{keyword}: {message}"))
    })
}

/// The `beyond_geometry` keyword: a bool or one of the command line's words.
fn joint_error_fit(v: &Bound<'_, PyAny>) -> PyResult<JointErrorFit> {
    if let Ok(b) = v.extract::<bool>() {
        return Ok(if b {
            JointErrorFit::On
        } else {
            JointErrorFit::Off
        });
    }
    let word: String = v.extract().map_err(|_| {
        value_error(
            "beyond_geometry: expected True, False or one of \"auto\", \"on\", \"keep\", \"check\", \"off\"",
        )
    })?;
    match word.as_str() {
        "auto" => Ok(JointErrorFit::Auto),
        "on" => Ok(JointErrorFit::On),
        "keep" => Ok(JointErrorFit::Keep),
        "check" => Ok(JointErrorFit::Check),
        "off" => Ok(JointErrorFit::Off),
        other => Err(value_error(format!(
            "beyond_geometry: unknown mode '{other}' (expected \"auto\", \"on\", \"keep\", \"check\" or \"off\")"
        ))),
    }
}

/// Identifies the MDH parameters, target and placement from laser-tracker data
/// (`gpu-amcs identify`): `data` is the CSV, sweeps (joint,q1..qn,x,y,z) or poses
/// (q1..qn,x,y,z, optionally sx,sy,sz; one q column per joint of the nominal model, q1..q6 for
/// six joints), either optionally with a run column; degrees and mm, in
/// any measurement frame. The nominal model giving the structure is `nominal` (a `Model`, or a
/// model file or robot description path), else the preset `preset`. `base_known=True` takes the
/// data as robot-base-frame data (no placement identified). `fix`: parameter names held at their
/// nominal values (theta1…beta`n`, tool_x…, base_x…base_yaw). Noise: `tracker_sigma` (mm per
/// coordinate) or `tracker_mpe` ([A, B] or [A, B, R]: µm, µm/m, µm) with `tracker_at` (mm;
/// default the data frame's origin), else the data's sx,sy,sz or the residuals.
/// `uncertainty`: "linearised" or "montecarlo" (`mc_draws` re-identifications from `seed`).
/// Sweeps only: `fit` "commanded" or "point-cloud", `no_prior`, `no_refine` (the plain
/// circle-point result; with `base_known=True`). With several runs `covariance=True` keeps the
/// full sample covariance. `no_compensation=True` leaves out the Gaussian-process compensation
/// of a single run's residuals. `beyond_geometry` says when joint compliance and gear
/// harmonics are fitted with the geometry (the command line's `--beyond-geometry`): None or "auto"
/// (the default: when the geometric fit shows a lack of fit, kept when they predict left-out poses
/// better), "on" or True (always checked), "keep" (always kept), "check" (checked and reported, never
/// kept), "off" or False. `harmonic_orders` (one per joint, 0, 1 or 2, e.g. [2, 2, 1, 0, 0, 0];
/// the command line's `--harmonic-orders`) fits the gear harmonics of orders 1 to that per joint
/// instead of letting the data choose them. `strict=True` raises a `ValueError` for the warnings. Returns an
/// `IdentifyResult` whose `to_toml()` is the model file the command writes and whose
/// `to_dict()` is its `--json` document. `columns` maps a file as a tracker or robot log exported
/// it (the command line's `--columns`: "ours=theirs[:unit],…", e.g. "q1=A1:rad,…,x=X:m"), and
/// `delimiter` is its field delimiter (one character) when not a comma.
#[pyfunction]
// Plain literal defaults, so that help() and inspect.signature show them (PyO3 writes `...`
// for any other expression); `preset` is the command line's default (spec::DEFAULT_PRESET, which
// python/tests/test_signatures.py checks).
#[pyo3(signature = (data, *, nominal = None, preset = "tx60", base_known = false, fix = None,
    tracker_sigma = None, tracker_mpe = None, tracker_at = None, uncertainty = "linearised",
    mc_draws = 200, seed = 1, fit = "commanded", no_prior = false, no_refine = false,
    covariance = false, strict = false, no_compensation = false, beyond_geometry = None,
    harmonic_orders = None, columns = None, delimiter = None))]
#[allow(clippy::too_many_arguments)]
pub fn identify(
    py: Python<'_>,
    data: PathBuf,
    nominal: Option<Bound<'_, PyAny>>,
    preset: &str,
    base_known: bool,
    fix: Option<Vec<String>>,
    tracker_sigma: Option<f64>,
    tracker_mpe: Option<Vec<f64>>,
    tracker_at: Option<Vec<f64>>,
    uncertainty: &str,
    mc_draws: usize,
    seed: u64,
    fit: &str,
    no_prior: bool,
    no_refine: bool,
    covariance: bool,
    strict: bool,
    no_compensation: bool,
    beyond_geometry: Option<Bound<'_, PyAny>>,
    harmonic_orders: Option<Vec<u8>>,
    columns: Option<String>,
    delimiter: Option<String>,
) -> PyResult<PyIdentifyResult> {
    let columns = column_map(columns.as_deref(), delimiter.as_deref())?;
    let beyond_geometry = match &beyond_geometry {
        None => JointErrorFit::Auto,
        Some(v) => joint_error_fit(v)?,
    };
    let method = match fit {
        "commanded" => CircleFitMethod::CommandedAngles,
        "point-cloud" | "point_cloud" => CircleFitMethod::PointCloud,
        other => {
            return Err(value_error(format!(
                "fit: unknown fit '{other}' (expected \"commanded\" or \"point-cloud\")"
            )))
        }
    };
    let uncertainty = match uncertainty {
        "linearised" | "linearized" => UncertaintyMethod::Linearised,
        "montecarlo" | "monte-carlo" | "monte_carlo" => {
            UncertaintyMethod::MonteCarlo { draws: mc_draws }
        }
        other => {
            return Err(value_error(format!(
                "uncertainty: unknown method '{other}' (expected \"linearised\" or \"montecarlo\")"
            )))
        }
    };
    let source = match &nominal {
        None => ModelSource::Preset(preset.to_string()),
        Some(n) => match n.cast::<PyModel>() {
            Ok(m) => ModelSource::Model(Box::new(m.get().model.clone())),
            Err(_) => ModelSource::File(n.extract::<PathBuf>().map_err(|_| {
                value_error("nominal: expected a Model or the path of a model file")
            })?),
        },
    };
    let nominal = source.load().map_err(|e| {
        arg_error(
            if matches!(source, ModelSource::Preset(_)) {
                "preset"
            } else {
                "nominal"
            },
            e,
        )
    })?;
    let job = IdentifyJob {
        placement: if base_known {
            Placement::Known
        } else {
            Placement::Identify
        },
        fix: fix.unwrap_or_default(),
        tracker_sigma_mm: tracker_sigma,
        tracker_mpe,
        tracker_at_mm: tracker_at,
        uncertainty,
        seed,
        method,
        prior: !no_prior,
        refine: !no_refine,
        covariance,
        strict,
        compensate: !no_compensation,
        beyond_geometry,
        harmonic_orders,
        columns,
        ..IdentifyJob::new(data, nominal)
    };
    let outcome = py.detach(|| job.run()).map_err(|e| match e {
        IdentifyJobError::Setting { setting, message } => {
            value_error(format!("{}: {message}", setting_keyword(setting)))
        }
        IdentifyJobError::Strict { .. } => value_error(format!("strict: {e}")),
        IdentifyJobError::Identify(e) => lib_error(e),
    })?;
    Ok(PyIdentifyResult {
        model: outcome.model,
        file_text: outcome.file_text,
        reports: outcome.reports,
        runs: outcome.runs,
        warnings: outcome.warnings,
        closing: outcome.note,
    })
}

/// The keyword of a setting an identification names in its errors.
fn setting_keyword(s: IdentifySetting) -> &'static str {
    match s {
        IdentifySetting::TrackerSigma => "tracker_sigma",
        IdentifySetting::TrackerMpe => "tracker_mpe",
        IdentifySetting::TrackerAt => "tracker_at",
        IdentifySetting::McDraws => "mc_draws",
        IdentifySetting::Fit => "fit",
        IdentifySetting::Refine => "no_refine",
        IdentifySetting::HarmonicOrders => "harmonic_orders",
        IdentifySetting::Memory => "memory_limit",
        IdentifySetting::Columns => "columns",
    }
}
