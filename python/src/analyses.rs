//! `gpu_amcs.sensitivity`, `gpu_amcs.tail` and `gpu_amcs.map`: the command line's analyses of
//! the same names, with its defaults, its library calls and its reports: `to_dict()` /
//! `to_json()` are the document `--json` writes, `to_text()` the table it prints, `to_csv()` /
//! `to_pandas()` the CSV `--csv` writes.
//!
//! Over 600 lines: three analyses with the same shape (keywords → options → driver → report); one file keeps them parallel.

use crate::arrays::numbers;
use crate::errors::{arg_error, lib_error, value_error};
use crate::model::PyModel;
use crate::problem::{check_estimate, keyword, problem_function, BYTES_PER_POINT};
use gpu_amcs_core::engine::{Problem, Reference};
use gpu_amcs_core::kinematics::Joints;
use gpu_amcs_core::map::{
    self, default_reference_deg, tool_down_rpy_deg, Evaluation, Grid, MapError, MapResult,
    MapSetting, MapSpec, Plane, Timings,
};
use gpu_amcs_core::mc::sensitivity::{
    run_sensitivity, SensitivityError, SensitivityOptions, SensitivityResult, SensitivitySetting,
};
use gpu_amcs_core::mc::tail::{
    run_tail, TailError, TailMethod, TailOptions, TailResult, TailSetting,
};
use gpu_amcs_core::spec::{self, GeneratedPoints, ModelSource, DEFAULT_PRESET};
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

/// A setting error `"field (keyword): message"`, as the command line's `"field (--flag): …"`.
fn setting_error(field: impl std::fmt::Display, kw: Option<&str>, message: &str) -> PyErr {
    match kw {
        Some(k) => value_error(format!("{field} ({k}): {message}")),
        None => value_error(format!("{field}: {message}")),
    }
}

/// A sensitivity error with the keyword that sets its field.
fn sensitivity_error(e: SensitivityError) -> PyErr {
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
fn tail_error(e: TailError) -> PyErr {
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
fn map_error(e: MapError) -> PyErr {
    match e {
        MapError::Setting { field, message } => {
            let kw = match field {
                MapSetting::Cells => "cells",
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
    text_signature = "(model=None, *, draws=8192, bootstrap=300, bootstrap_seed=1, thresholds=(), preset=None, points=50, q_deg=None, points_file=None, points_seed=1, box_center=None, box_size=None, seed=2025, reference='calibrated', nominal=None, backend='auto', adapter=None, memory_limit=None, frame='measurement', discrepancy=True, payload_kg=None, payload_sigma_kg=0.0, payload_com=None)";
    fn sensitivity(
        draws: usize = 1 << 13,
        bootstrap: usize = 300,
        bootstrap_seed: u64 = 1,
        thresholds: Option<Bound<'py, PyAny>> = None
    ) -> PySensitivityResult |py, problem| {
        let opts = SensitivityOptions {
            draws,
            bootstrap,
            bootstrap_seed,
            thresholds: numbers(thresholds.as_ref(), "thresholds", "mm")?.unwrap_or_default(),
            ..SensitivityOptions::default()
        };
        opts.check().map_err(sensitivity_error)?;
        let spec = problem.spec()?;
        let budget = problem.budget()?;
        let estimate = |m: u64| {
            check_estimate(
                &budget,
                &opts
                    .memory_estimate("use fewer draws")
                    .plus(&[m, BYTES_PER_POINT]),
            )
        };
        spec.check(&estimate)?;
        let built = spec.build(&estimate)?;
        let evaluators = spec.evaluators();
        let (result, notes) = py.detach(|| -> PyResult<_> {
            let (mut ev, notes) = evaluators.make(built.problem.clone())?;
            let problem = evaluators.problem(built.problem);
            let r = run_sensitivity(&problem, ev.as_mut(), &opts).map_err(sensitivity_error)?;
            Ok((r, notes))
        })?;
        Ok(PySensitivityResult { result, notes })
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
    text_signature = "(model=None, *, threshold=None, cov=0.1, method='subset', max_evaluations=5000000, samples_per_level=1000, p0=0.1, preset=None, points=50, q_deg=None, points_file=None, points_seed=1, box_center=None, box_size=None, seed=2025, reference='calibrated', nominal=None, backend='auto', adapter=None, memory_limit=None, frame='measurement', discrepancy=True, payload_kg=None, payload_sigma_kg=0.0, payload_com=None)";
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
        let opts = TailOptions {
            method,
            thresholds: numbers(threshold.as_ref(), "threshold", "mm")?.unwrap_or_default(),
            target_cov: cov,
            max_evaluations,
            samples_per_level,
            p0,
            ..TailOptions::default()
        };
        opts.check().map_err(tail_error)?;
        let spec = problem.spec()?;
        let budget = problem.budget()?;
        let estimate = |m: u64| {
            check_estimate(
                &budget,
                &opts
                    .memory_estimate("use fewer samples_per_level")
                    .plus(&[m, BYTES_PER_POINT]),
            )
        };
        spec.check(&estimate)?;
        let built = spec.build(&estimate)?;
        let evaluators = spec.evaluators();
        let (result, notes) = py.detach(|| -> PyResult<_> {
            let (mut ev, notes) = evaluators.make(built.problem.clone())?;
            let problem = evaluators.problem(built.problem);
            let r = run_tail(ev.as_mut(), &problem, &opts, None).map_err(tail_error)?;
            Ok((r, notes))
        })?;
        Ok(PyTailResult { result, notes })
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

/// `v` as `N` numbers, or an error naming `name` and `what` they are.
fn exactly<const N: usize>(v: &[f64], name: &str, what: &str) -> PyResult<[f64; N]> {
    <[f64; N]>::try_from(v).map_err(|_| {
        value_error(format!(
            "{name} needs {N} numbers ({what}), got {}",
            v.len()
        ))
    })
}

/// The map's grid from `plane`, `at` and `cells` (the command line's `--plane`, `--at`,
/// `--cells`, with the same defaults).
fn grid(plane: Option<&str>, at: Option<f64>, cells: Option<Vec<usize>>) -> PyResult<Grid> {
    Ok(match (plane, at) {
        (Some(p), Some(at)) => {
            let plane = match p {
                "xy" => Plane::Xy,
                "xz" => Plane::Xz,
                "yz" => Plane::Yz,
                other => {
                    return Err(value_error(format!(
                        "plane: unknown plane '{other}' (expected \"xy\", \"xz\" or \"yz\")"
                    )))
                }
            };
            let cells = cells.unwrap_or_else(|| vec![50, 50]);
            let [nx, ny] = <[usize; 2]>::try_from(cells.as_slice()).map_err(|_| {
                value_error(format!(
                    "cells needs two counts NX,NY for a plane, got {}",
                    cells.len()
                ))
            })?;
            Grid::Plane {
                plane,
                at,
                cells: [nx, ny],
            }
        }
        (Some(_), None) => {
            return Err(value_error(
                "plane needs at (the plane's position along its normal, mm)",
            ))
        }
        (None, Some(_)) => return Err(value_error("at needs plane=\"xy\", \"xz\" or \"yz\"")),
        (None, None) => {
            let cells = cells.unwrap_or_else(|| vec![10, 10, 10]);
            let c = <[usize; 3]>::try_from(cells.as_slice()).map_err(|_| {
                value_error(format!(
                    "cells needs three counts NX,NY,NZ for a 3-D grid (or give plane), got {}",
                    cells.len()
                ))
            })?;
            Grid::Volume { cells: c }
        }
    })
}

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
    let thresholds = numbers(thresholds.as_ref(), "thresholds", "mm")?
        .unwrap_or_else(|| gpu_amcs_core::mc::DEFAULT_THRESHOLDS_MM.to_vec());
    map::check_run(&thresholds, draws).map_err(map_error)?;
    let source = match &model {
        Some(m) => ModelSource::Model(Box::new(m.model.clone())),
        None => ModelSource::Preset(preset.unwrap_or_else(|| DEFAULT_PRESET.to_string())),
    };
    let model = source
        .load()
        .map_err(|e| arg_error(keyword(source.field()), e))?;
    let grid = grid(plane.as_deref(), at, cells)?;
    let orientation_rpy_deg = match (orientation, free_orientation) {
        (Some(_), true) => {
            return Err(value_error(
                "orientation and free_orientation exclude each other: give one",
            ))
        }
        (None, true) => None,
        (Some(o), false) => Some(exactly::<3>(
            &o,
            "orientation",
            "roll,pitch,yaw in degrees",
        )?),
        (None, false) => Some(tool_down_rpy_deg(&model)),
    };
    let reference_q_deg = match reference_q {
        Some(q) => {
            let n = model.joints();
            if q.len() != n {
                return Err(value_error(format!(
                    "reference_q needs {n} numbers (q1..q{n} in degrees, one per joint of the \
                     model), got {}",
                    q.len()
                )));
            }
            Joints::from_slice(&q)
        }
        None => default_reference_deg(&model),
    };
    let workspace = GeneratedPoints {
        box_center,
        box_size,
        ..GeneratedPoints::default()
    }
    .workspace(&model);
    let mspec = MapSpec {
        grid,
        workspace,
        orientation_rpy_deg,
        reference_q_deg,
        ik_seeds,
    };
    mspec.check(&model).map_err(map_error)?;
    let n = mspec.n_cells();
    let needed = map::memory_estimate(n, n, draws, map::batch_size(n, draws));
    let budget = crate::problem::memory_budget(memory_limit.as_ref())?;
    check_estimate(&budget, &needed).map_err(|e| value_error(format!("draws, cells: {e}")))?;
    let backend = crate::model::backend(&backend)?;
    spec::backend_choice(backend, adapter.as_deref())
        .map_err(|e| arg_error(keyword(e.field), e.kind))?;
    let (result, notes) = py.detach(|| -> PyResult<_> {
        let t0 = std::time::Instant::now();
        let solutions = mspec.solve(&model).map_err(map_error)?;
        let ik_seconds = t0.elapsed().as_secs_f64();
        let points = map::test_points(&solutions);
        let problem = Problem::new(model.clone(), &points, &Reference::Calibrated, seed)
            .map_err(|e| arg_error("reached configurations", e))?;
        let (mut ev, notes) =
            spec::make_evaluator(crate::backends(), problem, backend, adapter.as_deref())
                .map_err(|e| arg_error(keyword(e.field), e.kind))?;
        let t1 = std::time::Instant::now();
        let errors = map::evaluate_cells(
            ev.as_mut(),
            draws,
            map::batch_size(points.len(), draws),
            &thresholds,
            None,
        )
        .map_err(map_error)?;
        let timings = Timings {
            ik_seconds,
            eval_seconds: t1.elapsed().as_secs_f64(),
        };
        let eval = Evaluation::new(errors.cells, errors.w, &thresholds);
        let result = MapResult::new(
            &model.name,
            &mspec,
            seed,
            solutions,
            eval,
            ev.info(),
            timings,
        )
        .of_model(&model);
        Ok((result, notes))
    })?;
    Ok(PyMapResult { result, notes })
}
