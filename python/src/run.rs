//! `gpu_amcs.mcs` and `gpu_amcs.amcs`: the command line's runs with the same defaults, the same
//! problem (model, generated or given test points, reference, seed) and the same library job
//! (`McsJob`, `AmcsJob`), so the same JSON report (`RunResult.to_dict()` is the document
//! `--json` writes). An MCS run here keeps its values (`RunResult.values`): one that would not
//! fit the memory is refused, never summarised.

use crate::errors::{driver_error, value_error};
use crate::problem::problem_function;
use gpu_amcs_core::job::{AmcsJob, McsJob, Shard, SummaryMode};
use gpu_amcs_core::mc::{AmcsOptions, IntervalKind, RunSettings, Tolerance};
use gpu_amcs_core::report::{Report, RunReport};
use numpy::{IntoPyArray, PyArray1};
use pyo3::prelude::*;

/// The result of a run: `to_dict()` / `to_json()` give the command line's JSON document;
/// `values` the w of every draw, ascending.
#[pyclass(module = "gpu_amcs", name = "RunResult", frozen)]
pub struct RunResult {
    report: RunReport,
}

impl crate::reports::PyReport for RunResult {
    fn report(&self) -> &dyn Report {
        &self.report
    }

    fn default_table(&self) -> Option<&'static str> {
        Some("reliability")
    }

    /// `to_pandas("values")`: the w of every draw (column `w_mm`, ascending).
    fn extra_frame<'py>(
        &self,
        py: Python<'py>,
        table: &str,
    ) -> Option<PyResult<Bound<'py, PyAny>>> {
        (table == "values").then(|| {
            py.import("gpu_amcs._interop")?
                .call_method1("values_frame", (self.values(py),))
        })
    }
}

crate::report_class!(RunResult, text, {
    /// The maximum point error w of every draw (mm), ascending.
    #[getter]
    fn values<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.report.result.sorted_values.clone().into_pyarray(py)
    }

    /// The estimate of w (mean of the draws), mm.
    #[getter]
    fn estimate(&self) -> f64 {
        self.report.result.estimate
    }

    /// Standard uncertainty u(w), mm.
    #[getter]
    fn std_uncertainty(&self) -> f64 {
        self.report.result.std_uncertainty
    }

    /// The coverage interval (low, high), mm.
    #[getter]
    fn coverage_interval(&self) -> (f64, f64) {
        let c = &self.report.result.coverage_interval;
        (c.low, c.high)
    }

    /// Number of draws evaluated.
    #[getter]
    fn draws(&self) -> u64 {
        self.report.result.draws
    }

    /// Whether AMCS met its tolerance (always true for MCS).
    #[getter]
    fn converged(&self) -> bool {
        self.report.result.converged
    }

    /// Notes on the run (the backend choice).
    #[getter]
    fn notes(&self) -> Vec<String> {
        self.report.notes.clone()
    }

    fn __repr__(&self) -> String {
        let r = &self.report.result;
        format!(
            "gpu_amcs.RunResult(model='{}', draws={}, estimate={:.6} mm, u={:.6} mm, backend='{}')",
            self.report.model, r.draws, r.estimate, r.std_uncertainty, r.backend.backend
        )
    }
});

/// The reporting keywords of `mcs` and `amcs` (`--coverage`, `--interval`, `--thresholds`,
/// `--per-point`), the thresholds the library's default when not given.
fn settings(
    coverage: f64,
    interval: &str,
    thresholds: Option<&Bound<'_, PyAny>>,
    per_point: bool,
) -> PyResult<RunSettings> {
    let interval = match interval {
        "shortest" => IntervalKind::Shortest,
        "symmetric" => IntervalKind::Symmetric,
        other => {
            return Err(value_error(format!(
                "interval: unknown interval '{other}' (expected \"shortest\" or \"symmetric\")"
            )))
        }
    };
    Ok(RunSettings {
        coverage_probability: coverage,
        interval,
        thresholds: crate::arrays::numbers(thresholds, "thresholds", "mm")?
            .unwrap_or_else(|| RunSettings::default().thresholds),
        per_point,
    })
}

problem_function! {
    /// Classic Monte Carlo with `draws` draws (`gpu-amcs mcs`). The model is `model` (a
    /// `Model`) or the preset `preset` (default tx60); the test points are `q_deg` (m × n
    /// degrees, one column per joint of the model), the CSV `points_file`, or `points`
    /// generated with `points_seed` in the box `box_center`/`box_size` (mm; by default the
    /// robot's own box, scaled with its reach as the command line's). Returns a `RunResult`; errors are `ValueError` naming the
    /// argument. `thresholds`: the L of R(L) (mm; a number or a sequence; default 0.1 … 0.8).
    text_signature = "(model=None, *, draws=1000000, coverage=0.95, interval='shortest', thresholds=(0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8), per_point=False, preset=None, points=50, q_deg=None, points_file=None, points_seed=1, box_center=None, box_size=None, seed=2025, reference='calibrated', nominal=None, backend='auto', adapter=None, memory_limit=None, frame='measurement', discrepancy=True, payload_kg=None, payload_sigma_kg=0.0, payload_com=None, sides=None)";
    fn mcs(
        draws: u64 = 1_000_000,
        coverage: f64 = 0.95,
        interval: String = "shortest".to_string(),
        thresholds: Option<Bound<'py, PyAny>> = None,
        per_point: bool = false
    ) -> RunResult |py, problem| {
        let settings = settings(coverage, &interval, thresholds.as_ref(), per_point)?;
        settings.check().map_err(driver_error)?;
        let spec = problem.spec()?;
        let job = McsJob {
            setup: spec.setup(problem.budget()?),
            draws,
            settings,
            summary: SummaryMode::Never,
            shard: Shard::WHOLE,
        };
        let report = spec.run(py, || job.run(crate::backends()))?.report;
        Ok(RunResult { report })
    }
}

problem_function! {
    /// Adaptive Monte Carlo, GUM S1 §7.9 (`gpu-amcs amcs`): batches of `batch` draws until
    /// twice the standard deviation of every batch estimate is within `delta` mm (default
    /// 0.01; or the tolerance from `ndig` significant digits), at most `max_draws`. Problem and
    /// reporting arguments as `mcs`.
    text_signature = "(model=None, *, delta=None, ndig=None, batch=10000, max_draws=10000000, coverage=0.95, interval='shortest', thresholds=(0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8), per_point=False, preset=None, points=50, q_deg=None, points_file=None, points_seed=1, box_center=None, box_size=None, seed=2025, reference='calibrated', nominal=None, backend='auto', adapter=None, memory_limit=None, frame='measurement', discrepancy=True, payload_kg=None, payload_sigma_kg=0.0, payload_com=None, sides=None)";
    fn amcs(
        delta: Option<f64> = None,
        ndig: Option<u32> = None,
        batch: u64 = 10_000,
        max_draws: u64 = 10_000_000,
        coverage: f64 = 0.95,
        interval: String = "shortest".to_string(),
        thresholds: Option<Bound<'py, PyAny>> = None,
        per_point: bool = false
    ) -> RunResult |py, problem| {
        let tolerance = match (delta, ndig) {
            (Some(_), Some(_)) => {
                return Err(value_error("delta and ndig exclude each other: give one"))
            }
            (_, Some(n)) => Tolerance::Ndig(n),
            (d, None) => Tolerance::Delta(d.unwrap_or(0.01)),
        };
        let options = AmcsOptions {
            tolerance,
            batch_size: batch,
            max_draws,
            settings: settings(coverage, &interval, thresholds.as_ref(), per_point)?,
        };
        options.check().map_err(driver_error)?;
        let spec = problem.spec()?;
        let job = AmcsJob {
            setup: spec.setup(problem.budget()?),
            options,
        };
        let report = spec.run(py, || job.run(crate::backends()))?.report;
        Ok(RunResult { report })
    }
}
