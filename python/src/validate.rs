//! `gpu_amcs.validate`: the positioning accuracy of a model against measured positions, as
//! `gpu-amcs validate` computes it: both run the library's one [`run_validation`], so the frame
//! (stated, recorded in the model's `[provenance]`, or a refusal), the nominal model (the
//! model's own, a given one of the same robot, or a refusal) and its baseline are the same.

use crate::errors::{lib_error, value_error};
use crate::model::PyModel;
use gpu_amcs_core::identify::validate::{
    provenance_table, run_validation, ValidateRequest, ValidationReport,
};
use gpu_amcs_core::identify::{read_measurements, Placement};
use gpu_amcs_core::kinematics::RobotModel;
use pyo3::prelude::*;
use std::path::PathBuf;

/// A validation: its text (`to_text()`, what `gpu-amcs validate` prints) and its JSON document
/// (`to_json()`, what `--json` writes; `to_dict()` the same as a dict).
#[pyclass(module = "gpu_amcs", name = "ValidationResult", frozen)]
pub struct PyValidation {
    report: ValidationReport,
    /// The model with its discrepancy term from these errors (`term=True`).
    term_model: Option<PyModel>,
}

#[pymethods]
impl PyValidation {
    /// The text the command line prints.
    fn to_text(&self) -> String {
        self.report.text()
    }

    /// The JSON document `gpu-amcs validate --json` writes.
    fn to_json(&self) -> String {
        self.report.json()
    }

    /// The JSON document as a dict.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        py.import("json")?
            .call_method1("loads", (self.report.json(),))
    }

    /// With `term=True`: the model with its discrepancy term drawn from these poses' errors (its
    /// `to_toml()` is what `gpu-amcs validate --term-out` writes); else `None`.
    #[getter]
    fn term_model(&self) -> Option<PyModel> {
        self.term_model.clone()
    }

    /// The frame of the measurements: "measurement" or "robot base".
    #[getter]
    fn frame(&self) -> &'static str {
        match self.report.frame {
            Placement::Identify => "measurement",
            Placement::Known => "robot base",
        }
    }

    fn __repr__(&self) -> String {
        let v = &self.report.validation;
        format!(
            "gpu_amcs.ValidationResult(model='{}', points={}, rms_mm={:.4}, nominal={})",
            v.model_name,
            v.model.points,
            v.model.rms_mm,
            v.nominal
                .as_ref()
                .map_or("None".to_string(), |(n, s)| format!(
                    "('{n}', rms_mm={:.4})",
                    s.rms_mm
                ))
        )
    }
}

/// A model argument: a `Model` (its `[provenance]` kept) or the path of a model file.
fn model_arg(arg: &Bound<'_, PyAny>, what: &str) -> PyResult<(RobotModel, String, String)> {
    if let Ok(m) = arg.cast::<PyModel>() {
        let m = m.get();
        return Ok((
            m.model.clone(),
            m.file_text(),
            format!("model '{}'", m.model.name),
        ));
    }
    let path: PathBuf = arg.extract().map_err(|_| {
        value_error(format!(
            "{what}: expected a Model or the path of a model file"
        ))
    })?;
    let model = RobotModel::from_file(&path).map_err(|e| value_error(format!("{what}: {e}")))?;
    let text = std::fs::read_to_string(&path).unwrap_or_default();
    Ok((model, text, path.display().to_string()))
}

/// The positioning accuracy of `model` (a `Model` or a model file path) against the measured
/// positions in `measured` (CSV q1..qn,x,y,z; degrees, mm), as `gpu-amcs validate`. `frame`:
/// "measurement" (the tracker frame the model's placement was identified in) or "base";
/// default: the frame the model's `[provenance]` records, else the base frame — a `ValueError`
/// when the positions are far from the model there (tracker data and a model that records no
/// frame). `nominal`: `None`/`False` no comparison; `True` the model's own nominal (recorded in
/// its `[provenance]`; `preset` names one to use instead; without either, the built-in preset
/// of the model's geometry); a `Model` or a model file path. A nominal of another robot, or
/// another than the one recorded, is a `ValueError`. On measurement-frame data the nominal
/// geometry gets its own best-fit placement (and target offset, where the data determine it).
/// `check_draws` draws per pose of the predictive check (0 leaves it out), from `seed`.
/// `term=True` also gives `term_model`: the model with its discrepancy term drawn from these
/// poses' errors (at least 10 poses the model was not identified from, spread where it will be
/// used), as `--term-out` writes it.
#[pyfunction]
#[pyo3(signature = (model, measured, *, nominal = None, preset = None, frame = None,
    check_draws = 20_000, seed = 2025, term = false))]
#[allow(clippy::too_many_arguments)]
pub fn validate(
    py: Python<'_>,
    model: Bound<'_, PyAny>,
    measured: PathBuf,
    nominal: Option<Bound<'_, PyAny>>,
    preset: Option<String>,
    frame: Option<String>,
    check_draws: usize,
    seed: u64,
    term: bool,
) -> PyResult<PyValidation> {
    let (model, model_text, origin) = model_arg(&model, "model")?;
    let stated = match frame.as_deref() {
        None => None,
        Some("measurement") => Some(Placement::Identify),
        Some("base") => Some(Placement::Known),
        Some(other) => {
            return Err(value_error(format!(
                "frame: unknown frame '{other}' (expected \"measurement\" or \"base\")"
            )))
        }
    };
    let nominal = match nominal {
        None => None,
        Some(n) => match n.extract::<bool>() {
            Ok(false) => None,
            Ok(true) => Some(match &preset {
                None => None,
                Some(p) => Some(
                    gpu_amcs_core::presets::preset(p)
                        .map_err(|e| value_error(format!("preset: {e}")))?,
                ),
            }),
            Err(_) => Some(Some(model_arg(&n, "nominal")?.0)),
        },
    };
    let measurements = read_measurements(&measured).map_err(lib_error)?;
    let measured = measured.display().to_string();
    let report = py
        .detach(|| {
            run_validation(ValidateRequest {
                model: &model,
                model_text: &model_text,
                origin: &origin,
                measurements: &measurements,
                measured: &measured,
                frame: stated,
                nominal,
                check_draws,
                seed,
                term,
            })
        })
        .map_err(|e| {
            use gpu_amcs_core::identify::validate::ValidateError as E;
            match e {
                E::UnknownFrame { .. } => value_error(format!("frame: {e}")),
                E::Identify(e) => lib_error(e),
                E::Term(_) => value_error(format!("term: {e}")),
                e => value_error(format!("nominal: {e}")),
            }
        })?;
    let term_model = report.term.as_ref().map(|t| {
        let data = std::fs::read(&measured).unwrap_or_default();
        let text = t.file_text(&model_text, &measured, &data);
        PyModel {
            model: t.model.clone(),
            preset: None,
            provenance: provenance_table(&text),
        }
    });
    Ok(PyValidation { report, term_model })
}
