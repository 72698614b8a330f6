//! `gpu_amcs.plan`: the command line's `plan` (choose the poses of a calibration for the task
//! points and predict the reliability they give), with its defaults, its library calls and its
//! report: `to_dict()` / `to_json()` are the document `--json` writes, `to_text()` the summary
//! it prints, `design_csv()` the file `--out` writes.

use crate::errors::{plan_error, value_error};
use crate::problem::problem_function;
use gpu_amcs_core::job::{PlanJob, PlanTask};
use gpu_amcs_core::plan::program::{robot_program, ProgramFormat};
use gpu_amcs_core::plan::{Approach, KeepOut, Plan, TrackerSite, Workcell};
use gpu_amcs_core::report::Report;
use pyo3::prelude::*;

/// A calibration plan (`gpu_amcs.plan`).
#[pyclass(module = "gpu_amcs", name = "PlanResult", frozen)]
pub struct PyPlan {
    plan: Plan,
    notes: Vec<String>,
}

impl crate::reports::PyReport for PyPlan {
    fn report(&self) -> &dyn Report {
        &self.plan
    }
}

crate::report_class!(PyPlan, text, {
    /// The design as the command line writes it with `--out`: q1..qn in degrees (one column per
    /// joint), one pose a line, in visiting order.
    fn design_csv(&self) -> String {
        self.plan.design_csv()
    }

    /// The poses to measure, degrees (one angle per joint), in visiting order.
    #[getter]
    fn design(&self) -> Vec<Vec<f64>> {
        self.plan.design_deg.iter().map(|q| q.to_vec()).collect()
    }

    /// `(L, R(L))` predicted at the task points by the engine's Monte Carlo.
    #[getter]
    fn reliability(&self) -> Vec<(f64, f64)> {
        self.plan
            .prediction
            .as_ref()
            .map(|p| p.reliability.iter().map(|r| (r.threshold, r.r)).collect())
            .unwrap_or_default()
    }

    /// The design as a robot program (the command line's `--program`): `language` is
    /// "urscript", "rapid" or "krl" (or the file extensions "script", "mod", "src"), `name` the
    /// program's name, `settle` the seconds to wait at each pose for the tracker.
    #[pyo3(signature = (language, name = "calibration", settle = 2.0))]
    fn program(&self, language: &str, name: &str, settle: f64) -> PyResult<String> {
        let format = ProgramFormat::from_extension(language).ok_or_else(|| {
            value_error(format!(
                "language: expected urscript, rapid or krl, got {language:?}"
            ))
        })?;
        robot_program(&self.plan, format, name, settle).map_err(plan_error)
    }

    /// Notes on the backend choice (the command line prints them to stderr).
    #[getter]
    fn notes(&self) -> Vec<String> {
        self.notes.clone()
    }

    fn __repr__(&self) -> String {
        format!(
            "gpu_amcs.PlanResult(poses={}, q95_mm={:.5}, reliability={:?})",
            self.plan.design_deg.len(),
            self.plan.planned.q95_mm,
            self.reliability()
        )
    }
});

/// The workcell of the keywords `floor`, `keep_out` (boxes of six numbers x0, y0, z0, x1,
/// y1, z1 mm), `self_collision` and `link_radius`.
fn workcell(
    floor: Option<f64>,
    keep_out: Vec<Vec<f64>>,
    self_collision: bool,
    link_radius: Option<f64>,
) -> PyResult<Workcell> {
    let boxes = keep_out
        .iter()
        .enumerate()
        .map(|(i, c)| {
            if c.len() != 6 {
                return Err(value_error(format!(
                    "keep_out[{i}]: a box is six numbers x0, y0, z0, x1, y1, z1 (mm), got {}",
                    c.len()
                )));
            }
            Ok(KeepOut::between([c[0], c[1], c[2], c[3], c[4], c[5]]))
        })
        .collect::<PyResult<Vec<_>>>()?;
    Ok(Workcell {
        floor_mm: floor,
        keep_out: boxes,
        self_collision,
        link_radius_mm: link_radius,
    })
}

/// Three numbers, or `None`.
fn triple(v: Option<Vec<f64>>, name: &str) -> PyResult<Option<[f64; 3]>> {
    match v {
        None => Ok(None),
        Some(v) if v.len() == 3 => Ok(Some([v[0], v[1], v[2]])),
        Some(v) => Err(value_error(format!(
            "{name}: expected x, y, z (mm), got {} numbers",
            v.len()
        ))),
    }
}

problem_function! {
    /// Plans a calibration (`gpu-amcs plan`): `poses` poses out of `candidates` candidate
    /// configurations, for tracker noise `tracker_sigma` (mm per coordinate), the target
    /// `target` on the flange (x, y, z mm; default the model's tool unless within 1 mm of the
    /// last joint's axis, else 30, -20, 80) and, with `tracker_at` (x, y, z mm), candidates within `tracker_range`
    /// that face the tracker within `max_incidence` degrees; predicts R(L) at `threshold` (mm)
    /// with `draws` draws of the planned model at the task points (the problem's points).
    /// The workcell: `floor` (mm, z up in the measurement frame), `keep_out` (boxes of six
    /// numbers x0, y0, z0, x1, y1, z1 mm), `self_collision` and `link_radius` (mm), as the
    /// command line's `--floor`, `--keep-out`, `--no-self-collision` and `--link-radius`;
    /// `approach` ("positive" or "negative", `--approach`) the side every joint arrives at each
    /// pose from. Problem arguments as `mcs`. Returns a `PlanResult`.
    text_signature = "(model=None, *, poses=30, tracker_sigma=0.01, tracker_at=None, tracker_range=20000.0, max_incidence=60.0, target=None, threshold=(0.02, 0.03, 0.05), candidates=2000, draws=100000, floor=None, keep_out=(), self_collision=True, link_radius=None, approach=None, preset=None, points=50, q_deg=None, points_file=None, points_seed=1, box_center=None, box_size=None, seed=2025, reference='calibrated', nominal=None, backend='auto', adapter=None, memory_limit=None, frame='measurement', discrepancy=True, payload_kg=None, payload_sigma_kg=0.0, payload_com=None, sides=None)";
    fn plan(
        poses: usize = 30,
        tracker_sigma: f64 = 0.01,
        tracker_at: Option<Vec<f64>> = None,
        tracker_range: f64 = 20_000.0,
        max_incidence: f64 = 60.0,
        target: Option<Vec<f64>> = None,
        threshold: Option<Bound<'py, PyAny>> = None,
        candidates: usize = 2000,
        draws: usize = 100_000,
        floor: Option<f64> = None,
        keep_out: Vec<Vec<f64>> = Vec::new(),
        self_collision: bool = true,
        link_radius: Option<f64> = None,
        approach: Option<String> = None
    ) -> PyPlan |py, problem| {
        let spec = problem.spec()?;
        let job = PlanJob {
            setup: spec.setup(problem.budget()?),
            task: PlanTask::Points,
            poses,
            candidates,
            sigma_mm: tracker_sigma,
            tracker: triple(tracker_at, "tracker_at")?.map(|t| TrackerSite {
                position_mm: t,
                range_mm: tracker_range,
                max_incidence_deg: max_incidence,
            }),
            thresholds: crate::arrays::numbers(threshold.as_ref(), "threshold", "mm")?
                .unwrap_or_else(|| gpu_amcs_core::plan::DEFAULT_THRESHOLDS_MM.to_vec()),
            target: triple(target, "target")?,
            workcell: workcell(floor, keep_out, self_collision, link_radius)?,
            draws,
            approach: approach
                .as_deref()
                .map(|a| {
                    Approach::from_name(a).ok_or_else(|| {
                        value_error(format!(
                            "approach: expected \"positive\" or \"negative\", got {a:?}"
                        ))
                    })
                })
                .transpose()?,
        };
        let outcome = spec.run(py, || job.run(crate::backends()))?;
        Ok(PyPlan { plan: outcome.plan, notes: outcome.notes })
    }
}
