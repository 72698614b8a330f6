//! `gpu_amcs.identify`: MDH parameters from laser-tracker sweeps (circle point method), as
//! `gpu-amcs identify` computes them: the same nominal model, options, library calls, model
//! (what `--out` writes), warnings and printed text.

use crate::errors::{arg_error, lib_error, value_error};
use crate::model::PyModel;
use gpu_amcs_core::identify::{
    self as lib, CircleFitMethod, Identification, IdentifyOptions, NominalPrior,
};
use gpu_amcs_core::kinematics::RobotModel;
use gpu_amcs_core::report::Report;
use gpu_amcs_core::spec::{ModelSource, DEFAULT_PRESET};
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
}

/// A model as a Python `Model` (not from a preset).
fn py_model(m: &RobotModel) -> PyModel {
    PyModel {
        model: m.clone(),
        preset: None,
    }
}

#[pymethods]
impl PyIdentifyResult {
    /// The identified model: one run's parameters with the nominal model's uncertainty, or the
    /// mean of several runs with their run-to-run σ (or full covariance with
    /// `covariance=True`). `model.to_toml()` is the file `gpu-amcs identify --out` writes.
    #[getter]
    fn model(&self) -> PyModel {
        py_model(&self.model)
    }

    /// The model of each run.
    #[getter]
    fn models(&self) -> Vec<PyModel> {
        self.runs.iter().map(|i| py_model(&i.model)).collect()
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

    /// The identified model file (TOML), as `--out` writes it.
    fn to_toml(&self) -> String {
        self.model.to_toml()
    }

    /// The command line's `--json` document of the identification (per run the circle fits,
    /// the identified and nominal parameters of every joint, the tool point and the warnings).
    fn to_json(&self) -> String {
        self.reports.json()
    }

    /// `to_json()` parsed: a dict of plain Python values.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        py.import("json")?.call_method1("loads", (self.to_json(),))
    }

    fn __repr__(&self) -> String {
        format!(
            "gpu_amcs.IdentifyResult(model='{}', runs={}, warnings={})",
            self.model.name,
            self.runs.len(),
            self.warnings.len()
        )
    }
}

/// Identifies the MDH parameters from laser-tracker sweeps (`gpu-amcs identify`): `sweeps` is
/// the CSV (joint,q1..q6,x,y,z, optionally a run column; degrees and mm). The nominal model
/// giving the structure is `nominal` (a `Model`, or a model file or robot description path),
/// else the preset `preset`. `fit`: "commanded" (each point's angle known from the commanded
/// joint angle) or "point-cloud"; `no_prior` uses the data alone, `no_refine` skips the
/// least-squares refinement; with several runs `covariance=True` keeps the full sample
/// covariance instead of independent σ. `strict=True` raises a `ValueError` when a result
/// looks implausible (the warnings). Returns an `IdentifyResult`.
#[pyfunction]
#[pyo3(signature = (sweeps, *, nominal = None, preset = DEFAULT_PRESET.to_string(),
    fit = "commanded".to_string(), no_prior = false, no_refine = false, covariance = false,
    strict = false))]
#[allow(clippy::too_many_arguments)]
pub fn identify(
    py: Python<'_>,
    sweeps: PathBuf,
    nominal: Option<Bound<'_, PyAny>>,
    preset: String,
    fit: String,
    no_prior: bool,
    no_refine: bool,
    covariance: bool,
    strict: bool,
) -> PyResult<PyIdentifyResult> {
    let method = match fit.as_str() {
        "commanded" => CircleFitMethod::CommandedAngles,
        "point-cloud" | "point_cloud" => CircleFitMethod::PointCloud,
        other => {
            return Err(value_error(format!(
                "fit: unknown fit '{other}' (expected \"commanded\" or \"point-cloud\")"
            )))
        }
    };
    let source = match &nominal {
        None => ModelSource::Preset(preset),
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
    let opts = IdentifyOptions {
        method,
        nominal_prior: (!no_prior).then(NominalPrior::default),
        refine: !no_refine,
    };
    let (ids, data_label) = py.detach(|| -> PyResult<_> {
        let data = lib::read_sweeps(&sweeps).map_err(lib_error)?;
        let ids = lib::identify(&data, &nominal, &opts).map_err(lib_error)?;
        Ok((ids, sweeps.display().to_string()))
    })?;
    let warnings = lib::grouped_warnings(&ids);
    if strict && !warnings.is_empty() {
        return Err(value_error(format!(
            "strict: {} implausible result(s): {}",
            warnings.len(),
            warnings.join("; ")
        )));
    }
    let (model, closing) =
        lib::identified_model(&ids, &nominal, covariance, &data_label).map_err(lib_error)?;
    let reports = lib::IdentifyReports::new(&nominal.name, &ids);
    Ok(PyIdentifyResult {
        model,
        reports,
        runs: ids,
        warnings,
        closing,
    })
}
