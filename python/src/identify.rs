//! `gpu_amcs.identify`: MDH parameters from laser-tracker sweeps (circle point method), as
//! `gpu-amcs identify` computes them: the same nominal model, options, library calls, model
//! (what `--out` writes), warnings and printed text.

use crate::errors::{arg_error, lib_error, value_error};
use crate::model::PyModel;
use gpu_amcs_core::identify::{
    self as lib, noise::NoiseSetting, ChainOptions, CircleFitMethod, Identification,
    IdentifyOptions, NoiseModel, NominalPrior, Placement, UncertaintyMethod,
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
    /// The model file the command line writes (the model and its provenance).
    file_text: String,
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

    /// The identified model file (TOML), as `--out` writes it: the model, then its
    /// `[provenance]` (data file and SHA-256, points, residuals, rank, condition, noise, frame).
    fn to_toml(&self) -> String {
        self.file_text.clone()
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
/// full sample covariance. `strict=True` raises a `ValueError` for the warnings. Returns an
/// `IdentifyResult` whose `to_toml()` is the model file the command writes and whose
/// `to_dict()` is its `--json` document.
#[pyfunction]
#[pyo3(signature = (data, *, nominal = None, preset = DEFAULT_PRESET.to_string(),
    base_known = false, fix = Vec::new(), tracker_sigma = None, tracker_mpe = None,
    tracker_at = None, uncertainty = "linearised".to_string(), mc_draws = 200, seed = 1,
    fit = "commanded".to_string(), no_prior = false, no_refine = false, covariance = false,
    strict = false))]
#[allow(clippy::too_many_arguments)]
pub fn identify(
    py: Python<'_>,
    data: PathBuf,
    nominal: Option<Bound<'_, PyAny>>,
    preset: String,
    base_known: bool,
    fix: Vec<String>,
    tracker_sigma: Option<f64>,
    tracker_mpe: Option<Vec<f64>>,
    tracker_at: Option<Vec<f64>>,
    uncertainty: String,
    mc_draws: usize,
    seed: u64,
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
    let uncertainty = match uncertainty.as_str() {
        "linearised" | "linearized" => UncertaintyMethod::Linearised,
        "montecarlo" | "monte-carlo" | "monte_carlo" => {
            if mc_draws < 10 {
                return Err(value_error(
                    "mc_draws: at least 10 re-identifications are needed for a covariance",
                ));
            }
            UncertaintyMethod::MonteCarlo { draws: mc_draws }
        }
        other => {
            return Err(value_error(format!(
                "uncertainty: unknown method '{other}' (expected \"linearised\" or \"montecarlo\")"
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
    let (ids, data_label, bytes) = py.detach(|| -> PyResult<_> {
        let origin = data.display().to_string();
        let tracker = lib::read_tracker_data(&data).map_err(lib_error)?;
        lib::check_tracker_data(&tracker, &nominal, &origin).map_err(lib_error)?;
        let noise = NoiseModel::from_settings(
            tracker_sigma,
            tracker_mpe.as_deref(),
            tracker_at.as_deref(),
            &tracker,
        )
        .map_err(|e| {
            let name = match e.setting() {
                NoiseSetting::Sigma => "tracker_sigma",
                NoiseSetting::Mpe => "tracker_mpe",
                NoiseSetting::Position => "tracker_at",
            };
            value_error(format!("{name}: {e}"))
        })?;
        let chain = ChainOptions {
            placement: if base_known {
                Placement::Known
            } else {
                Placement::Identify
            },
            fix,
            noise,
            uncertainty,
            seed,
        };
        let ids =
            lib::identify_data(&tracker, &nominal, &opts, &chain, no_refine).map_err(lib_error)?;
        let bytes = std::fs::read(&data).unwrap_or_default();
        Ok((ids, origin, bytes))
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
    let file_text = lib::model_file_text(&model, &ids, &data_label, &bytes);
    let reports = lib::IdentifyReports::new(&nominal.name, &ids);
    Ok(PyIdentifyResult {
        model,
        file_text,
        reports,
        runs: ids,
        warnings,
        closing,
    })
}
