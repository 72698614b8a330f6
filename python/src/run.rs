//! `gpu_amcs.mcs` and `gpu_amcs.amcs`: the command line's runs with the same defaults, the same
//! problem (model, generated or given test points, reference, seed), the same drivers and the
//! same JSON report (`RunResult.to_dict()` is the document `--json` writes).

use crate::arrays;
use crate::errors::{arg_error, driver_error, lib_error, value_error};
use crate::model::{self, PyModel};
use gpu_amcs_core::kinematics::JOINTS;
use gpu_amcs_core::mc::{
    self, AmcsOptions, IntervalKind, McResult, McsOptions, RunSettings, Tolerance,
};
use gpu_amcs_core::points::{self, WorkspaceBox};
use gpu_amcs_core::presets::preset;
use gpu_amcs_core::report::{self, RunReport};
use numpy::{IntoPyArray, PyArray1};
use pyo3::prelude::*;
use std::path::PathBuf;

/// Bytes kept per draw: its value, and as much again for the growth of the value vector (as
/// the command line estimates).
const BYTES_PER_DRAW: u64 = 16;
/// Bytes kept per test point: configuration in degrees and radians, reference position and
/// bookkeeping, with room to spare (as the command line estimates).
const BYTES_PER_POINT: u64 = 256;

/// The result of a run: `to_dict()` / `to_json()` give the command line's JSON document;
/// `values` the w of every draw, ascending.
#[pyclass(module = "gpu_amcs", name = "RunResult", frozen)]
pub struct RunResult {
    report: RunReport,
}

#[pymethods]
impl RunResult {
    /// The JSON document the command line writes with `--json` (same fields, same values).
    fn to_json(&self) -> String {
        report::json::render_run(&self.report)
    }

    /// `to_json()` parsed: a dict of plain Python values.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        py.import("json")?.call_method1("loads", (self.to_json(),))
    }

    /// The text table the command line prints.
    fn to_text(&self) -> String {
        report::text::render(&self.report)
    }

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
}

/// What `mcs` and `amcs` share: the problem and the reporting settings, under the command
/// line's flag names spelled as Python keywords.
struct Common<'py> {
    model: Option<PyRef<'py, PyModel>>,
    preset: Option<String>,
    points: usize,
    q_deg: Option<Bound<'py, PyAny>>,
    points_file: Option<PathBuf>,
    points_seed: u64,
    box_center: Option<[f64; 3]>,
    box_size: Option<[f64; 3]>,
    seed: u64,
    reference: String,
    nominal: Option<PyRef<'py, PyModel>>,
    backend: String,
    adapter: Option<String>,
    coverage: f64,
    interval: String,
    thresholds: Vec<f64>,
    per_point: bool,
}

/// A built run: the problem's pieces and the evaluator's choice, ready to drive.
struct Built {
    problem: gpu_amcs_core::engine::Problem,
    reference: String,
    choice: gpu_amcs_core::engine::BackendChoice,
    adapter: Option<String>,
    settings: RunSettings,
}

impl Common<'_> {
    /// Reads the model and points, checks everything and the memory of `draws` draws
    /// evaluated `batch` at a time.
    fn build(self, what: String, draws: u64, batch: u64, advice: &str) -> PyResult<Built> {
        let interval = match self.interval.as_str() {
            "shortest" => IntervalKind::Shortest,
            "symmetric" => IntervalKind::Symmetric,
            other => {
                return Err(value_error(format!(
                    "interval: unknown interval '{other}' (expected \"shortest\" or \"symmetric\")"
                )))
            }
        };
        let settings = RunSettings {
            coverage_probability: self.coverage,
            interval,
            thresholds: self.thresholds,
            per_point: self.per_point,
        };
        settings.check().map_err(driver_error)?;
        let choice = model::backend(&self.backend)?;
        let choice = match (choice, &self.adapter) {
            (gpu_amcs_core::engine::BackendChoice::Cpu, Some(a)) => {
                return Err(value_error(format!(
                "adapter '{a}' needs backend=\"gpu\" or \"auto\": the CPU backend uses no adapter"
            )))
            }
            (gpu_amcs_core::engine::BackendChoice::Auto, Some(_)) => {
                gpu_amcs_core::engine::BackendChoice::Gpu
            }
            (c, _) => c,
        };
        let (by_array, by_file) = (self.q_deg.is_some(), self.points_file.is_some());
        if by_array && by_file {
            return Err(value_error(
                "q_deg and points_file exclude each other: give one",
            ));
        }
        // Generated points are counted before any work; given ones once read.
        let m_known = if by_array || by_file {
            0
        } else {
            self.points as u64
        };
        let estimate = |m: u64| {
            model::check_memory(
                what.clone(),
                advice,
                &[
                    &[draws, BYTES_PER_DRAW],
                    &[m, BYTES_PER_POINT],
                    &[batch, m, if self.per_point { 16 } else { 0 }],
                ],
            )
        };
        estimate(m_known)?;
        let (robot, holder) = match &self.model {
            Some(m) => (m.model.clone(), Some(&**m)),
            None => {
                let name = self.preset.as_deref().unwrap_or("tx60");
                (preset(name).map_err(|e| arg_error("preset", e))?, None)
            }
        };
        let pts: Vec<[f64; JOINTS]> = match (&self.q_deg, &self.points_file) {
            (Some(q), _) => arrays::joint_rows(q, "q_deg")?,
            (None, Some(f)) => points::read_csv(f).map_err(lib_error)?,
            (None, None) => {
                // Each of centre and size as given, else the robot's own box (as the command
                // line's --box-center/--box-size).
                let default = WorkspaceBox::for_robot(&robot);
                let bx = WorkspaceBox {
                    center: self.box_center.unwrap_or(default.center),
                    size: self.box_size.unwrap_or(default.size),
                };
                points::generate(&robot, self.points, &bx, self.points_seed)
                    .map_err(|e| arg_error("points", e))?
            }
        };
        estimate(pts.len() as u64)?;
        let nominal_default = || match holder {
            Some(h) => h.default_nominal(self.preset.as_deref()),
            None => {
                preset(self.preset.as_deref().unwrap_or("tx60")).map_err(|e| arg_error("preset", e))
            }
        };
        let reference =
            model::reference(&self.reference, self.nominal.as_deref(), nominal_default)?;
        let label = reference.label(&robot);
        let points_arg = match (&self.q_deg, &self.points_file) {
            (Some(_), _) => "q_deg".to_string(),
            (None, Some(f)) => format!("points_file {}", f.display()),
            (None, None) => "test points".to_string(),
        };
        let problem = model::problem(robot, &pts, &reference, self.seed, &points_arg)?;
        Ok(Built {
            problem,
            reference: label,
            choice,
            adapter: self.adapter,
            settings,
        })
    }
}

impl Built {
    /// Runs `drive` on the problem's evaluator without the GIL and assembles the report as the
    /// command line does.
    fn run(
        self,
        py: Python<'_>,
        drive: impl FnOnce(
                &mut dyn gpu_amcs_core::engine::Evaluator,
                RunSettings,
            ) -> Result<McResult, mc::McError>
            + Send,
    ) -> PyResult<RunResult> {
        let (model, points, seed) = (
            self.problem.model.name.clone(),
            self.problem.n_points(),
            self.problem.seed,
        );
        let settings = self.settings;
        // The CLI's notes first: what the report says about the model (an uncertain tool).
        let model_notes = gpu_amcs_core::report::model_notes(&self.problem.model);
        let (choice, adapter, problem) = (self.choice, self.adapter, self.problem);
        let (result, notes) = py.detach(|| -> PyResult<(McResult, Vec<String>)> {
            let (mut ev, note) = crate::backends()
                .make_evaluator(problem, choice, adapter.as_deref())
                .map_err(|e| {
                    arg_error(
                        if adapter.is_some() {
                            "adapter"
                        } else {
                            "backend"
                        },
                        e,
                    )
                })?;
            let result = drive(ev.as_mut(), settings).map_err(driver_error)?;
            Ok((result, model_notes.into_iter().chain(note).collect()))
        })?;
        Ok(RunResult {
            report: RunReport {
                model,
                points,
                reference: self.reference,
                seed,
                notes,
                result,
            },
        })
    }
}

/// Draws per evaluation chunk of an MCS run of `draws` draws (the command line's chunk, so the
/// trace and the values are the same).
fn mcs_chunk(draws: u64) -> u64 {
    100_000.min(draws.max(1))
}

/// Defines a run function (`mcs`, `amcs`): its own keyword arguments, then the problem and
/// reporting arguments every run shares (the command line's flags, spelled as keywords, with
/// their defaults), gathered into a [`Common`] for `$body`.
macro_rules! run_function {
    ($(#[$doc:meta])* fn $name:ident($($arg:ident: $ty:ty = $default:tt),*)
        |$py:ident, $common:ident| $body:block) => {
        $(#[$doc])*
        #[pyfunction]
        #[pyo3(signature = (model = None, *, $($arg = $default,)* preset = None, points = 50,
            q_deg = None, points_file = None, points_seed = 1,
            box_center = None, box_size = None, seed = 2025,
            reference = "calibrated".to_string(), nominal = None,
            backend = "auto".to_string(), adapter = None, coverage = 0.95,
            interval = "shortest".to_string(),
            thresholds = vec![0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8], per_point = false))]
        #[allow(clippy::too_many_arguments)]
        pub fn $name<'py>(
            $py: Python<'py>,
            model: Option<PyRef<'py, PyModel>>,
            $($arg: $ty,)*
            preset: Option<String>,
            points: usize,
            q_deg: Option<Bound<'py, PyAny>>,
            points_file: Option<PathBuf>,
            points_seed: u64,
            box_center: Option<[f64; 3]>,
            box_size: Option<[f64; 3]>,
            seed: u64,
            reference: String,
            nominal: Option<PyRef<'py, PyModel>>,
            backend: String,
            adapter: Option<String>,
            coverage: f64,
            interval: String,
            thresholds: Vec<f64>,
            per_point: bool,
        ) -> PyResult<RunResult> {
            let $common = Common {
                model,
                preset,
                points,
                q_deg,
                points_file,
                points_seed,
                box_center,
                box_size,
                seed,
                reference,
                nominal,
                backend,
                adapter,
                coverage,
                interval,
                thresholds,
                per_point,
            };
            $body
        }
    };
}

run_function! {
    /// Classic Monte Carlo with `draws` draws (`gpu-amcs mcs`). The model is `model` (a
    /// `Model`) or the preset `preset` (default tx60); the test points are `q_deg` (m × 6
    /// degrees), the CSV `points_file`, or `points` generated with `points_seed` in the box
    /// `box_center`/`box_size` (mm; by default the robot's own box, scaled with its reach as
    /// the command line's). Returns a `RunResult`; errors are `ValueError` naming the
    /// argument.
    fn mcs(draws: u64 = 1_000_000) |py, common| {
        let chunk = mcs_chunk(draws);
        let built = common.build(
            format!("MCS with {draws} draws"),
            draws,
            chunk,
            "use fewer draws (or amcs), fewer points or per_point=False",
        )?;
        built.run(py, move |ev, settings| {
            let opts = McsOptions {
                draws,
                chunk,
                settings,
            };
            mc::run_mcs(ev, &opts, None)
        })
    }
}

run_function! {
    /// Adaptive Monte Carlo, GUM S1 §7.9 (`gpu-amcs amcs`): batches of `batch` draws until
    /// twice the standard deviation of every batch estimate is within `delta` mm (default
    /// 0.01; or the tolerance from `ndig` significant digits), at most `max_draws`. Problem and
    /// reporting arguments as `mcs`.
    fn amcs(
        delta: Option<f64> = None,
        ndig: Option<u32> = None,
        batch: u64 = 10_000,
        max_draws: u64 = 10_000_000
    ) |py, common| {
        let tolerance = match (delta, ndig) {
            (Some(_), Some(_)) => {
                return Err(value_error("delta and ndig exclude each other: give one"))
            }
            (_, Some(n)) => Tolerance::Ndig(n),
            (d, None) => Tolerance::Delta(d.unwrap_or(0.01)),
        };
        let mut opts = AmcsOptions {
            tolerance,
            batch_size: batch,
            max_draws,
            settings: RunSettings {
                coverage_probability: common.coverage,
                interval: IntervalKind::Shortest,
                thresholds: common.thresholds.clone(),
                per_point: common.per_point,
            },
        };
        opts.check().map_err(driver_error)?;
        let built = common.build(
            format!("AMCS with up to {max_draws} draws"),
            max_draws,
            batch,
            "lower max_draws or batch, use fewer points or per_point=False",
        )?;
        built.run(py, move |ev, settings| {
            opts.settings = settings;
            mc::run_amcs(ev, &opts, None)
        })
    }
}
