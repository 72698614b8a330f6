//! `gpu_amcs.compare`: the command line's `compare` (MCS against AMCS at several tolerances δ,
//! the paper's Table 2 for one model) through the same library job (`CompareJob`), so the same
//! report: `to_dict()` / `to_json()` are the document `--json` writes, `to_text()` the table it
//! prints, `to_markdown()` the file `--markdown` writes.

use crate::errors::setting_error;
use crate::problem::problem_function;
use gpu_amcs_core::job::{CompareJob, JobError};
use gpu_amcs_core::mc::{McError, Setting};
use gpu_amcs_core::report::{Comparison, Report};
use pyo3::prelude::*;

/// A comparison of MCS and AMCS (`gpu_amcs.compare`).
#[pyclass(module = "gpu_amcs", name = "CompareResult", frozen)]
pub struct PyComparison {
    comparison: Comparison,
}

impl crate::reports::PyReport for PyComparison {
    fn report(&self) -> &dyn Report {
        &self.comparison
    }
}

crate::report_class!(PyComparison, text, {
    /// The table as the command line writes it with `--markdown`.
    fn to_markdown(&self) -> String {
        gpu_amcs_core::report::markdown::render_comparison(&self.comparison)
    }

    /// Draws of the MCS run.
    #[getter]
    fn mcs_draws(&self) -> u64 {
        self.comparison.mcs.draws
    }

    /// `(δ, draws, MRE %)` of each AMCS run, in the order of `deltas`: its tolerance (mm), the
    /// draws it took, and the largest relative error of its moments M1–M4 against the MCS
    /// run's.
    #[getter]
    fn amcs(&self) -> Vec<(f64, u64, f64)> {
        self.comparison
            .amcs
            .iter()
            .map(|(d, r, mre)| (*d, r.draws, *mre))
            .collect()
    }

    /// Notes on the model and the backend choice.
    #[getter]
    fn notes(&self) -> Vec<String> {
        self.comparison.notes.clone()
    }

    fn __repr__(&self) -> String {
        format!(
            "gpu_amcs.CompareResult(model='{}', mcs_draws={}, amcs={:?})",
            self.comparison.model,
            self.comparison.mcs.draws,
            self.amcs()
        )
    }
});

/// The keyword of a driver setting in `compare` (the command line's flag there); `None` for
/// the settings a comparison fixes.
fn keyword(s: Setting) -> Option<&'static str> {
    match s {
        Setting::CoverageProbability => Some("coverage"),
        Setting::Tolerance => Some("deltas"),
        Setting::BatchSize => Some("batch"),
        Setting::Draws => Some("draws"),
        Setting::Thresholds | Setting::SignificantDigits | Setting::MaxDraws | Setting::Chunk => {
            None
        }
    }
}

problem_function! {
    /// MCS against AMCS at several tolerances (`gpu-amcs compare`): an MCS run of `draws`
    /// draws, then an AMCS run per tolerance in `deltas` (mm; a number or a sequence; default
    /// 0.01, 0.02) with batches of `batch`, each
    /// capped at 10⁸ draws, all at coverage probability `coverage`; each AMCS run's moments are
    /// measured against the MCS run's. Problem arguments as `mcs` (the frame does not apply,
    /// as on the command line). Returns a `CompareResult`.
    text_signature = "(model=None, *, draws=1000000, deltas=(0.01, 0.02), batch=10000, coverage=0.95, preset=None, points=50, q_deg=None, points_file=None, points_seed=1, box_center=None, box_size=None, seed=2025, reference='calibrated', nominal=None, backend='auto', adapter=None, memory_limit=None, frame='measurement', discrepancy=True, payload_kg=None, payload_sigma_kg=0.0, payload_com=None, sides=None)";
    fn compare(
        draws: u64 = 1_000_000,
        deltas: Option<Bound<'py, PyAny>> = None,
        batch: u64 = 10_000,
        coverage: f64 = 0.95
    ) -> PyComparison |py, problem| {
        let spec = problem.spec()?;
        let mut job = CompareJob::new(spec.spec.clone());
        job.setup = spec.setup(problem.budget()?);
        job.draws = draws;
        job.batch_size = batch;
        job.coverage_probability = coverage;
        if let Some(d) = crate::arrays::numbers(deltas.as_ref(), "deltas", "mm")? {
            job.deltas = d;
        }
        let outcome = py
            .detach(|| job.run(crate::backends()))
            .map_err(|e| match e {
                JobError::Run(McError::Setting { field, message }) => {
                    setting_error(field, keyword(field), &message)
                }
                e => spec.job_error(e),
            })?;
        Ok(PyComparison { comparison: outcome.comparison })
    }
}
