//! `gpu_amcs.sensitivity`, `gpu_amcs.tail` and `gpu_amcs.map`: the command line's analyses of
//! the same names, with its defaults, its library calls and its reports: `to_dict()` /
//! `to_json()` are the document `--json` writes, `to_text()` the table it prints, `to_csv()` /
//! `to_pandas()` the CSV `--csv` writes.
//!
//! Each builds the library's job (`SensitivityJob`, `TailJob`, `MapJob`) from its keywords and
//! wraps what it gives.

use crate::arrays::numbers;
use crate::errors::{job_error, sensitivity_error, tail_error, value_error};
use crate::model::PyModel;
use crate::problem::problem_function;
use gpu_amcs_core::job::{MapJob, MapSettings, SensitivityJob, TailJob};
use gpu_amcs_core::map::{MapResult, Plane};
use gpu_amcs_core::mc::sensitivity::{SensitivityOptions, SensitivityResult};
use gpu_amcs_core::mc::tail::{TailMethod, TailOptions, TailResult};
use gpu_amcs_core::spec::{ModelSource, DEFAULT_PRESET};
use pyo3::prelude::*;

/// `json` parsed by Python's `json` module: a dict of plain values.
pub(crate) fn parse_json<'py>(py: Python<'py>, json: String) -> PyResult<Bound<'py, PyAny>> {
    py.import("json")?.call_method1("loads", (json,))
}

/// A CSV document as a pandas DataFrame (`gpu_amcs._interop.frame`): an `ImportError` saying
/// how to install pandas when it is missing.
pub fn frame<'py>(py: Python<'py>, csv: String) -> PyResult<Bound<'py, PyAny>> {
    py.import("gpu_amcs._interop")?
        .call_method1("frame", (csv,))
}

/// Sobol indices of w (`gpu_amcs.sensitivity`).
#[pyclass(module = "gpu_amcs", name = "SensitivityResult", frozen)]
pub struct PySensitivityResult {
    result: SensitivityResult,
    notes: Vec<String>,
}

impl crate::reports::PyReport for PySensitivityResult {
    fn report(&self) -> &dyn gpu_amcs_core::report::Report {
        &self.result
    }
}

crate::report_class!(PySensitivityResult, text, {
    /// First-order indices of w by input name.
    #[getter]
    fn first_order(&self) -> Vec<(String, f64)> {
        let w = self.result.w();
        w.inputs
            .iter()
            .map(|i| (i.name.clone(), i.first_order.value))
            .collect()
    }

    /// Total indices of w by input name.
    #[getter]
    fn total(&self) -> Vec<(String, f64)> {
        let w = self.result.w();
        w.inputs
            .iter()
            .map(|i| (i.name.clone(), i.total.value))
            .collect()
    }

    /// Notes on the backend choice (the command line prints them to stderr).
    #[getter]
    fn notes(&self) -> Vec<String> {
        self.notes.clone()
    }

    fn __repr__(&self) -> String {
        format!(
            "gpu_amcs.SensitivityResult(model='{}', inputs={}, backend='{}')",
            self.result.model,
            self.result.parameters.len(),
            self.result.backend.backend
        )
    }
});

problem_function! {
    /// Sobol sensitivity indices of w (`gpu-amcs sensitivity`): first-order and total indices
    /// of every free input, per joint and per kind, from `draws` base samples (a power of 2),
    /// with `bootstrap` resamples (seed `bootstrap_seed`) for the 95 % intervals; `thresholds`
    /// (mm) adds the indices of the failure indicators 1[w ≥ l_c]. Problem arguments as `mcs`.
    /// Returns a `SensitivityResult`.
    text_signature = "(model=None, *, draws=8192, bootstrap=300, bootstrap_seed=1, thresholds=(), preset=None, points=50, q_deg=None, points_file=None, points_seed=1, box_center=None, box_size=None, seed=2025, reference='calibrated', nominal=None, backend='auto', adapter=None, memory_limit=None, frame='measurement', discrepancy=True, payload_kg=None, payload_sigma_kg=0.0, payload_com=None, sides=None)";
    fn sensitivity(
        draws: usize = 1 << 13,
        bootstrap: usize = 300,
        bootstrap_seed: u64 = 1,
        thresholds: Option<Bound<'py, PyAny>> = None
    ) -> PySensitivityResult |py, problem| {
        let options = SensitivityOptions {
            draws,
            bootstrap,
            bootstrap_seed,
            thresholds: numbers(thresholds.as_ref(), "thresholds", "mm")?.unwrap_or_default(),
            ..SensitivityOptions::default()
        };
        options.check().map_err(sensitivity_error)?;
        let spec = problem.spec()?;
        let job = SensitivityJob {
            setup: spec.setup(problem.budget()?),
            options,
        };
        let outcome = spec.run(py, || job.run(crate::backends()))?;
        Ok(PySensitivityResult {
            result: outcome.result,
            notes: outcome.notes,
        })
    }
}

/// Tail probabilities Pr[w ≥ L] (`gpu_amcs.tail`).
#[pyclass(module = "gpu_amcs", name = "TailResult", frozen)]
pub struct PyTailResult {
    result: TailResult,
    notes: Vec<String>,
}

impl crate::reports::PyReport for PyTailResult {
    fn report(&self) -> &dyn gpu_amcs_core::report::Report {
        &self.result
    }
}

crate::report_class!(PyTailResult, text, {
    /// The thresholds L, mm.
    #[getter]
    fn thresholds(&self) -> Vec<f64> {
        self.result.estimates.iter().map(|e| e.threshold).collect()
    }

    /// P_f = Pr[w ≥ L] at each threshold.
    #[getter]
    fn p_f(&self) -> Vec<f64> {
        self.result.estimates.iter().map(|e| e.p_f).collect()
    }

    /// The reliability index β = −Φ⁻¹(P_f) at each threshold (`None` where P_f is 0 or 1).
    #[getter]
    fn beta(&self) -> Vec<Option<f64>> {
        self.result.estimates.iter().map(|e| e.beta).collect()
    }

    /// Evaluations of w made.
    #[getter]
    fn evaluations(&self) -> u64 {
        self.result.evaluations
    }

    /// Notes on the backend choice (the command line prints them to stderr).
    #[getter]
    fn notes(&self) -> Vec<String> {
        self.notes.clone()
    }

    fn __repr__(&self) -> String {
        format!(
            "gpu_amcs.TailResult(thresholds={:?}, p_f={:?}, evaluations={})",
            self.thresholds(),
            self.p_f(),
            self.result.evaluations
        )
    }
});

problem_function! {
    /// Tail probabilities P_f = Pr[w ≥ L] and β down to 1e-9 (`gpu-amcs tail`) at the
    /// thresholds `threshold` (mm; a number or a sequence), by subset simulation
    /// (`method="subset"`, `samples_per_level` per level, level probability `p0`) or crude
    /// Monte Carlo (`method="mc"`), to a coefficient of variation `cov`, at most
    /// `max_evaluations` evaluations of w. Problem arguments as `mcs`. Returns a `TailResult`.
    text_signature = "(model=None, *, threshold=None, cov=0.1, method='subset', max_evaluations=5000000, samples_per_level=1000, p0=0.1, preset=None, points=50, q_deg=None, points_file=None, points_seed=1, box_center=None, box_size=None, seed=2025, reference='calibrated', nominal=None, backend='auto', adapter=None, memory_limit=None, frame='measurement', discrepancy=True, payload_kg=None, payload_sigma_kg=0.0, payload_com=None, sides=None)";
    fn tail(
        threshold: Option<Bound<'py, PyAny>> = None,
        cov: f64 = 0.1,
        method: String = "subset".to_string(),
        max_evaluations: u64 = 5_000_000,
        samples_per_level: usize = 1000,
        p0: f64 = 0.1
    ) -> PyTailResult |py, problem| {
        let method = match method.as_str() {
            "subset" => TailMethod::Subset,
            "mc" => TailMethod::MonteCarlo,
            other => {
                return Err(value_error(format!(
                    "method: unknown method '{other}' (expected \"subset\" or \"mc\")"
                )))
            }
        };
        let options = TailOptions {
            method,
            thresholds: numbers(threshold.as_ref(), "threshold", "mm")?.unwrap_or_default(),
            target_cov: cov,
            max_evaluations,
            samples_per_level,
            p0,
            ..TailOptions::default()
        };
        options.check().map_err(tail_error)?;
        let spec = problem.spec()?;
        let job = TailJob {
            setup: spec.setup(problem.budget()?),
            options,
        };
        let outcome = spec.run(py, || job.run(crate::backends()))?;
        Ok(PyTailResult {
            result: outcome.result,
            notes: outcome.notes,
        })
    }
}

/// A workspace reliability map (`gpu_amcs.map`).
#[pyclass(module = "gpu_amcs", name = "MapResult", frozen)]
pub struct PyMapResult {
    result: MapResult,
    notes: Vec<String>,
}

impl crate::reports::PyReport for PyMapResult {
    fn report(&self) -> &dyn gpu_amcs_core::report::Report {
        &self.result
    }
}

crate::report_class!(PyMapResult, text, {
    /// Cells reached by the inverse kinematics.
    #[getter]
    fn reached(&self) -> usize {
        self.result.reached
    }

    /// Cells of the grid.
    #[getter]
    fn cells(&self) -> usize {
        self.result.cells.len()
    }

    /// Multi-point R(l_c) over the reached cells, as (threshold, R) pairs.
    #[getter]
    fn reliability(&self) -> Vec<(f64, f64)> {
        self.result
            .multi_point
            .iter()
            .map(|r| (r.threshold, r.r))
            .collect()
    }

    /// Notes on the backend choice (the command line prints them to stderr).
    #[getter]
    fn notes(&self) -> Vec<String> {
        self.notes.clone()
    }

    fn __repr__(&self) -> String {
        format!(
            "gpu_amcs.MapResult(model='{}', cells={}, reached={}, draws={})",
            self.result.model,
            self.result.cells.len(),
            self.result.reached,
            self.result.draws
        )
    }
});

/// Workspace reliability map (`gpu-amcs map`): R_j, e_j and the Jacobian condition per cell of
/// a plane slice (`plane` "xy"/"xz"/"yz" at `at` mm, `cells` NX,NY, default 50,50) or a 3-D
/// grid (`cells` NX,NY,NZ, default 10,10,10) spanning the box `box_center`/`box_size` (mm; by
/// default the robot's own). Each cell's configuration is found by inverse kinematics with the
/// flange orientation `orientation` (roll, pitch, yaw in degrees; default the tool pointing
/// down; `free_orientation=True` for position only), nearest `reference_q` (degrees), from
/// `ik_seeds` extra seeds; then `draws` parameter draws (seed `seed`) are evaluated at all
/// reached cells, with reliabilities at `thresholds` (mm; a number or a sequence). Returns a
/// `MapResult`.
#[pyfunction(name = "map")]
#[pyo3(signature = (model = None, *, preset = None, box_center = None, box_size = None,
    plane = None, at = None, cells = None, orientation = None, free_orientation = false,
    reference_q = None, ik_seeds = 0, draws = 10_000,
    thresholds = None, seed = 2025, backend = "auto".to_string(), adapter = None,
    memory_limit = None),
    text_signature = "(model=None, *, preset=None, box_center=None, box_size=None, plane=None, at=None, cells=None, orientation=None, free_orientation=False, reference_q=None, ik_seeds=0, draws=10000, thresholds=(0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8), seed=2025, backend='auto', adapter=None, memory_limit=None)")]
#[allow(clippy::too_many_arguments)]
pub fn workspace_map<'py>(
    py: Python<'py>,
    model: Option<PyRef<'py, PyModel>>,
    preset: Option<String>,
    box_center: Option<[f64; 3]>,
    box_size: Option<[f64; 3]>,
    plane: Option<String>,
    at: Option<f64>,
    cells: Option<Vec<usize>>,
    orientation: Option<Vec<f64>>,
    free_orientation: bool,
    reference_q: Option<Vec<f64>>,
    ik_seeds: usize,
    draws: u64,
    thresholds: Option<Bound<'py, PyAny>>,
    seed: u64,
    backend: String,
    adapter: Option<String>,
    memory_limit: Option<Bound<'py, PyAny>>,
) -> PyResult<PyMapResult> {
    if orientation.is_some() && free_orientation {
        return Err(value_error(
            "orientation and free_orientation exclude each other: give one",
        ));
    }
    let plane = plane
        .map(|p| match p.as_str() {
            "xy" => Ok(Plane::Xy),
            "xz" => Ok(Plane::Xz),
            "yz" => Ok(Plane::Yz),
            other => Err(value_error(format!(
                "plane: unknown plane '{other}' (expected \"xy\", \"xz\" or \"yz\")"
            ))),
        })
        .transpose()?;
    let mut job = MapJob::new(match &model {
        Some(m) => ModelSource::Model(Box::new(m.model.clone())),
        None => ModelSource::Preset(preset.unwrap_or_else(|| DEFAULT_PRESET.to_string())),
    });
    job.grid = MapSettings {
        plane,
        at,
        cells,
        orientation,
        free_orientation,
        reference_q,
        ik_seeds,
        box_center,
        box_size,
    };
    job.draws = draws;
    if let Some(t) = numbers(thresholds.as_ref(), "thresholds", "mm")? {
        job.thresholds = t;
    }
    job.seed = seed;
    job.backend = crate::model::backend(&backend)?;
    job.adapter = adapter;
    job.memory = crate::problem::memory_budget(memory_limit.as_ref())?;
    let outcome = py
        .detach(|| job.run(crate::backends()))
        .map_err(job_error)?;
    Ok(PyMapResult {
        result: outcome.result,
        notes: outcome.notes,
    })
}
