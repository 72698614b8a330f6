//! `gpu_amcs.Model`: a robot model (preset, model file, TOML text or imported description) with
//! forward kinematics, the maximum point error of caller-chosen parameter rows, and the run's
//! own parameter draws. Python sees the model file's units: mm and degrees.
//!
//! A model has `n` = 4 to 7 joints; a draw has the model's `5n + 3` uncertain inputs
//! ([`InputSpace::robot`]; 33 for six joints, 38 for seven; docs/METHOD.md §14): the `5n` MDH
//! parameters, then the tool point's x, y, z (mm, flange frame). Every per-input array here
//! (`param_names`, `params`, `sigma`, `covariance`, `free`, `draws`, the columns of
//! `max_error`) follows that order, and every shape is the model's own.

use crate::arrays;
use crate::errors::{lib_error, value_error};
use gpu_amcs_core::engine::BackendChoice;
use gpu_amcs_core::identify::validate::provenance_table;
use gpu_amcs_core::kinematics::{Block, InputSpace, RobotModel, Uncertainty, MAX_ROBOT_INPUTS};
use gpu_amcs_core::memory::Estimate;
use gpu_amcs_core::presets::preset;
use gpu_amcs_core::sampling::ParamSampler;
use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

mod rows;
use rows::{columns, offsets_of};

/// Rows of `params` converted and evaluated at a time: bounds the offset buffer (8.25 MiB per
/// 2^15 rows of 33 inputs, 9.5 MiB of 38) whatever N is, and is large enough that the per-call
/// overhead of an evaluator call is negligible.
const ROWS_PER_CALL: usize = 1 << 15;

/// Factor from file units (mm, degrees) to internal units (mm, radians) of input `i` of
/// `space`.
fn unit(space: InputSpace, i: usize) -> f64 {
    space.to_internal(i)
}

/// A robot model of `n` = 4 to 7 joints: the MDH parameters `[θ, d, a, α, β]` of each joint
/// (`5n`, 30 for six joints; mm, degrees), joint limits, the tool (tracker target) and the
/// uncertainty of the `5n + 3` inputs (the parameters, then the tool's x, y, z).
#[pyclass(module = "gpu_amcs", name = "Model", frozen)]
#[derive(Clone)]
pub struct PyModel {
    /// The library's model (internal units).
    pub model: RobotModel,
    /// The preset it was made from, if any: the default nominal model.
    pub preset: Option<String>,
    /// The `[provenance]` table of the model file it came from (an identification's: the data,
    /// the fit, the frame and the nominal model), kept so that `to_toml()` writes it again.
    pub provenance: Option<String>,
}

impl PyModel {
    /// The model file text: the model, then its `[provenance]` table if it has one.
    pub fn file_text(&self) -> String {
        let mut s = self.model.to_toml();
        if let Some(p) = &self.provenance {
            s.push_str(p);
        }
        s
    }

    /// The model's values of its [`RobotModel::robot_inputs`] in file units (mm, degrees):
    /// the `5n` parameters, then the tool point.
    fn input_values(&self) -> Vec<f64> {
        let space = self.model.robot_inputs();
        (0..space.len())
            .map(|i| match space.locate(i) {
                (Block::Tool, k) => self.model.tool[k],
                _ => self.model.params[i] / unit(space, i),
            })
            .collect()
    }
}

/// The backend choice from its name.
pub fn backend(name: &str) -> PyResult<BackendChoice> {
    name.parse()
        .map_err(|e: String| value_error(format!("backend: {e}")))
}

/// Checks that `bytes` products fit the budget `memory_limit` gives
/// ([`memory_budget`](crate::problem::memory_budget)).
pub fn check_memory(
    memory_limit: Option<&Bound<'_, PyAny>>,
    what: String,
    advice: &str,
    terms: &[&[u64]],
) -> PyResult<()> {
    let e = terms
        .iter()
        .fold(Estimate::new(what, advice), |e, t| e.plus(t));
    crate::problem::check_estimate(&crate::problem::memory_budget(memory_limit)?, &e)
}

#[pymethods]
impl PyModel {
    /// A built-in model by name (`gpu_amcs.presets()`): tx60, ur5e, ur10e, irb2400.
    #[staticmethod]
    fn preset(name: &str) -> PyResult<Self> {
        Ok(PyModel {
            model: preset(name).map_err(lib_error)?,
            preset: Some(name.to_ascii_lowercase()),
            provenance: None,
        })
    }

    /// A model file (TOML, mm and degrees; README "Model file"); its `[provenance]` table, if
    /// any, is kept (`to_toml()` writes it again).
    #[staticmethod]
    fn from_file(path: PathBuf) -> PyResult<Self> {
        let model = RobotModel::from_file(&path).map_err(lib_error)?;
        let text = std::fs::read_to_string(&path).unwrap_or_default();
        Ok(PyModel {
            model,
            preset: None,
            provenance: provenance_table(&text),
        })
    }

    /// A model from the text of a model file; `origin` names it in errors.
    #[staticmethod]
    #[pyo3(signature = (text, origin = "<string>"))]
    fn from_toml(text: &str, origin: &str) -> PyResult<Self> {
        Ok(PyModel {
            model: RobotModel::from_toml(text, origin).map_err(lib_error)?,
            preset: None,
            provenance: provenance_table(text),
        })
    }

    /// Imports a robot description (URDF or xacro; also a DH table .csv/.toml or a UR
    /// calibration .yaml, chosen by extension) as `gpu-amcs import` does, with the proof that
    /// the model reproduces it. `base`/`tip` pick the URDF chain. For a .xacro file,
    /// `packages` maps package names to directories for `$(find NAME)` and `xacro_args` sets
    /// `$(arg NAME)` values. `hold_joints` maps joint names (or 1-based numbers as strings) to
    /// angles in degrees at which they are held: each hold takes one joint off the model (a
    /// seven-axis arm imports as a seven-joint model, or with one joint held as a six-axis
    /// one). The model has zero uncertainty. A tip chosen among several leaves (tool0, then
    /// flange, then the deepest leaf of the longest revolute chain) and each joint held are
    /// named in a `UserWarning`, as the command line's notes.
    #[staticmethod]
    #[pyo3(signature = (path, base = None, tip = None, name = None, packages = None, xacro_args = None, hold_joints = None))]
    #[allow(clippy::too_many_arguments)]
    fn from_urdf(
        py: Python<'_>,
        path: PathBuf,
        base: Option<String>,
        tip: Option<String>,
        name: Option<String>,
        packages: Option<std::collections::BTreeMap<String, PathBuf>>,
        xacro_args: Option<std::collections::BTreeMap<String, String>>,
        hold_joints: Option<std::collections::BTreeMap<String, f64>>,
    ) -> PyResult<Self> {
        let opts = gpu_amcs_core::import::ImportOptions {
            base,
            tip,
            name,
            packages: packages.unwrap_or_default(),
            xacro_args: xacro_args.unwrap_or_default(),
            held: hold_joints
                .unwrap_or_default()
                .into_iter()
                .map(|(joint, angle_deg)| gpu_amcs_core::import::JointHold { joint, angle_deg })
                .collect(),
        };
        let imported = gpu_amcs_core::import::import_file(&path, &opts).map_err(lib_error)?;
        for n in &imported.notes {
            let msg = std::ffi::CString::new(n.as_str())
                .map_err(|e| pyo3::exceptions::PyValueError::new_err(e.to_string()))?;
            PyErr::warn(
                py,
                &py.get_type::<pyo3::exceptions::PyUserWarning>(),
                &msg,
                1,
            )?;
        }
        Ok(PyModel {
            model: imported.model,
            preset: None,
            provenance: None,
        })
    }

    /// The model file text (TOML, mm and degrees), with the `[provenance]` table of the
    /// identification it came from (as `gpu-amcs identify --out` writes it), if it has one.
    fn to_toml(&self) -> String {
        self.file_text()
    }

    /// The model's name.
    #[getter]
    fn name(&self) -> &str {
        &self.model.name
    }

    /// The number of joints `n` (4 to 7): the model has `5n` parameters (`len(param_names) - 3`)
    /// and `5n + 3` uncertain inputs.
    #[getter]
    fn joints(&self) -> usize {
        self.model.joints()
    }

    /// Input names in order: theta1, d1, a1, alpha1, beta1, …, beta`n`, then tool_x, tool_y,
    /// tool_z (`5n + 3`: 33 for six joints, 38 for seven).
    #[getter]
    fn param_names(&self) -> Vec<String> {
        self.model.robot_inputs().names()
    }

    /// The values of the `5n + 3` inputs (mm, degrees): the `5n` parameters, then the tool
    /// point (`params[5n:]` equals `tool`; `params[30:]` for six joints).
    #[getter]
    fn params<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.input_values().into_pyarray(py)
    }

    /// Standard deviations of the `5n + 3` inputs (mm, degrees; 0 = exactly known): the
    /// parameters, then the tool's x, y, z (the model file's `tool_sigma`).
    #[getter]
    fn sigma<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        let space = self.model.robot_inputs();
        let s = self.model.input_sigmas();
        let v: Vec<f64> = (0..space.len()).map(|i| s[i] / unit(space, i)).collect();
        v.into_pyarray(py)
    }

    /// The `(5n + 3) × (5n + 3)` covariance (mm², mm·deg, deg²; 33 × 33 for six joints) of the
    /// inputs of a correlated model (a `5n × 5n` file matrix extended by the independent tool
    /// variances `tool_sigma²`), else `None`.
    #[getter]
    fn covariance<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        let space = self.model.robot_inputs();
        let nu = space.len();
        let c = self.model.full_covariance()?;
        let a = Array2::from_shape_fn((nu, nu), |(i, k)| {
            c[i * nu + k] / (unit(space, i) * unit(space, k))
        });
        Some(a.into_pyarray(py))
    }

    /// The blocks of inputs the model's own covariance covers, in order, as the model file's
    /// `[covariance] blocks` names them: `["joints"]`, `["joints", "tool"]` or `["joints",
    /// "tool", "placement"]` (an identification in a tracker frame); `None` for independent σ.
    #[getter]
    fn covariance_blocks(&self) -> Option<Vec<&'static str>> {
        self.model
            .uncertainty
            .covariance()
            .map(|c| c.space().block_names())
    }

    /// The model's discrepancy term (what the geometric model does not explain, from an
    /// identification's residuals) as a dict: `residual_norms` (mm), `robot_share`, `noise`
    /// ("stated" or "unknown"), `noise_sigma_mm`, `robot_rms_mm` and `drawn` (whether analyses
    /// of the robot draw it), and `compensation`: `None`, or a dict of the Gaussian process whose
    /// mean the model adds to its predictions (`length_scales_deg`, `signal_sigma_mm`,
    /// `white_sigma_mm`, `loo_rms_geometric_mm`, `loo_rms_compensated_mm`, `poses`); `None` for a
    /// model without a term.
    #[getter]
    fn discrepancy<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.model
            .discrepancy
            .as_ref()
            .map(|d| term_dict(py, d))
            .transpose()
    }

    /// The term of a model with backlash for test points whose sides are not all given (fitted
    /// to the residuals of the prediction at the centre of the gaps; an analysis without every
    /// point's sides draws it in place of `discrepancy` and draws no sides), as a dict like
    /// `discrepancy`'s; `None` for a model without backlash or without that term.
    #[getter]
    fn discrepancy_sides_unknown<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<Option<Bound<'py, PyDict>>> {
        let e = self.model.joint_errors.as_ref();
        e.and_then(|e| e.backlash.as_ref())
            .and_then(|b| b.sides_unknown.as_ref())
            .map(|d| term_dict(py, d))
            .transpose()
    }

    /// Indices (of the `5n + 3` inputs) with nonzero spread: the ones a sampler varies; the
    /// last three (30, 31, 32 for six joints) are the tool's x, y, z.
    #[getter]
    fn free(&self) -> Vec<usize> {
        self.model.free_inputs()
    }

    /// Tool (tracker target) in the flange frame, mm.
    #[getter]
    fn tool<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.model.tool.to_vec().into_pyarray(py)
    }

    /// Joint limits, degrees: n × 2 (min, max), one row per joint.
    #[getter]
    fn limits<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let l = &self.model.limits_deg;
        Array2::from_shape_fn((l.len(), 2), |(j, k)| if k == 0 { l[j].0 } else { l[j].1 })
            .into_pyarray(py)
    }

    /// Tool positions (mm) at joint configurations `q_deg` (m × n, degrees, one column per
    /// joint): m × 3 (for one configuration given as n angles, 3), in the description's frame (the model's base transform applied, as
    /// `gpu-amcs fk` does), with the model's compensation added when it has one
    /// (`compensation=False`: the geometric model alone, `fk --no-compensation`).
    #[pyo3(signature = (q_deg, *, compensation = true))]
    fn fk<'py>(
        &self,
        py: Python<'py>,
        q_deg: &Bound<'py, PyAny>,
        compensation: bool,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (q, single) = arrays::joint_rows(q_deg, "q_deg", self.model.joints())?;
        let model = &self.model;
        let out = py.detach(|| {
            let mut out = Array2::zeros((q.len(), 3));
            for (mut row, qj) in out.rows_mut().into_iter().zip(&q) {
                let rad = qj.map(f64::to_radians);
                let p = if compensation {
                    model.compensated_world_position(&rad)
                } else {
                    model.world_position(&rad)
                };
                row.assign(&Array1::from(p.to_vec()));
            }
            out
        });
        Ok(if single {
            out.row(0).to_owned().into_pyarray(py).into_any()
        } else {
            out.into_pyarray(py).into_any()
        })
    }

    /// The maximum point error `w = max_j ‖P(params_i, q_j) − P_ref,j‖` (mm) of each row of
    /// `params` (N × D, mm and degrees: absolute values, or offsets from the model's values
    /// with `offsets=True`) at the configurations `q_deg` (m × n, one column per joint; or n
    /// angles, one configuration): an
    /// array of N, or N × m per-point errors with `per_point=True`. The columns are the model's
    /// `5n + 3` inputs in order (the `5n` parameters, then the tool point's x, y, z in the
    /// flange frame, mm; 33 for six joints), or the `5n` parameters alone (a `5n`-column
    /// matrix: the tool stays at the model's tool), or those named by `columns` (indices
    /// 0…5n+2 or names such as "theta1", "tool_x"; the others stay at the model's values).
    /// `reference`: "calibrated" (the model's own prediction) or "nominal" (`nominal`, by
    /// default the preset the model came from, else tx60). Runs on `backend` ("auto", "cpu",
    /// "gpu") without the GIL.
    #[pyo3(signature = (params, q_deg, *, reference = "calibrated", nominal = None,
        per_point = false, backend = "auto", columns = None, offsets = false,
        memory_limit = None))]
    #[allow(clippy::too_many_arguments)]
    fn max_error<'py>(
        &self,
        py: Python<'py>,
        params: &Bound<'py, PyAny>,
        q_deg: &Bound<'py, PyAny>,
        reference: &str,
        nominal: Option<PyRef<'py, PyModel>>,
        per_point: bool,
        backend: &str,
        columns: Option<&Bound<'py, PyAny>>,
        offsets: bool,
        memory_limit: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let lay = self.model.layout();
        let space = self.model.robot_inputs();
        let (nu, np) = (space.len(), lay.n_params());
        let named = self::columns(columns, space)?;
        let (widths, shape) = match &named {
            Some(c) => (vec![c.len()], format!("(N, {})", c.len())),
            None => (vec![nu, np], format!("(N, {nu}) or (N, {np})")),
        };
        let (matrix, _) = arrays::read(params, "params", &widths, &shape, false)?;
        let (q, _) = arrays::joint_rows(q_deg, "q_deg", lay.joints())?;
        let m = q.len();
        let choice = self::backend(backend)?;
        let spec = crate::problem::given_points(self, q, reference, nominal.as_deref(), choice)?;
        let problem = spec.build(&|_| Ok(()))?.problem;
        let evaluators = spec.evaluators();
        let view = matrix.view();
        let cols = named.unwrap_or_else(|| (0..view.ncols()).collect());
        let n = view.nrows();
        check_memory(
            memory_limit,
            format!("max_error of {n} rows at {m} points"),
            "pass fewer rows per call, fewer points or per_point=False",
            &[
                &[n as u64, 8],
                &[n as u64, if per_point { m as u64 } else { 0 }, 8],
                &[ROWS_PER_CALL as u64, nu as u64, 8],
            ],
        )?;
        let mean_file = self.input_values();
        let (w, e) = py.detach(|| -> PyResult<(Vec<f64>, Vec<f64>)> {
            let mut w = vec![0.0; n];
            let mut e = vec![0.0; if per_point { n * m } else { 0 }];
            if n == 0 {
                return Ok((w, e));
            }
            let (mut ev, _) = evaluators.make(problem)?;
            let mut buf = vec![0.0; ROWS_PER_CALL.min(n) * nu];
            for first in (0..n).step_by(ROWS_PER_CALL) {
                let rows = ROWS_PER_CALL.min(n - first);
                let buf = &mut buf[..rows * nu];
                offsets_of(space, &view, &cols, &mean_file, offsets, first, buf)
                    .map_err(value_error)?;
                let pp = per_point.then(|| &mut e[first * m..(first + rows) * m]);
                ev.evaluate_offsets(buf, &mut w[first..first + rows], pp)
                    .map_err(|e| value_error(crate::errors::one_line(&e)))?;
            }
            Ok((w, e))
        })?;
        Ok(if per_point {
            Array2::from_shape_vec((n, m), e)
                .expect("n × m values")
                .into_pyarray(py)
                .into_any()
        } else {
            w.into_pyarray(py).into_any()
        })
    }

    /// The input vectors (N × (5n + 3), mm and degrees: the `5n` parameters, then the tool
    /// point; N × 33 for six joints, N × 38 for seven) of draws `first … first + n − 1` of a
    /// run with `seed`: the draws `mcs`/`amcs` evaluate (a draw is a function of the seed and
    /// its index, the same on every backend).
    #[pyo3(signature = (n, *, seed = 2025, first = 0, memory_limit = None))]
    fn draws<'py>(
        &self,
        py: Python<'py>,
        n: &Bound<'py, PyAny>,
        seed: u64,
        first: u64,
        memory_limit: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let n = match n.extract::<i128>() {
            Ok(n) if (0..=usize::MAX as i128).contains(&n) => n as usize,
            Ok(n) => {
                return Err(value_error(format!(
                    "n: {n} draws is not a count (0 or more)"
                )))
            }
            Err(_) => return Err(value_error("n: expected a whole number of draws")),
        };
        let space = self.model.robot_inputs();
        let nu = space.len();
        check_memory(
            memory_limit,
            format!("{n} parameter draws"),
            "ask for fewer draws at a time (use first)",
            &[&[n as u64, nu as u64, 8]],
        )?;
        if first.checked_add(n as u64).is_none() {
            return Err(value_error("first: first + n exceeds the draw index range"));
        }
        let sampler = ParamSampler::new(&self.model, seed).map_err(lib_error)?;
        let mean = self.input_values();
        let out = py.detach(|| {
            let mut out = Array2::zeros((n, nu));
            let mut d = [0.0; MAX_ROBOT_INPUTS];
            for (k, mut row) in out.rows_mut().into_iter().enumerate() {
                sampler.deltas(first + k as u64, &mut d);
                for i in 0..nu {
                    row[i] = mean[i] + d[i] / unit(space, i);
                }
            }
            out
        });
        Ok(out.into_pyarray(py))
    }

    /// SALib's problem dict of the uncertain inputs (`free`, or those named by `inputs`):
    /// `{"num_vars", "names", "bounds", "dists"}`, each input an independent normal with
    /// SALib's convention for `"norm"`, `bounds = [mean, standard deviation]` (mm, degrees),
    /// named as `param_names`. A model with correlated inputs is refused (SALib samples
    /// independent inputs; `gpu_amcs.sensitivity` handles correlation).
    #[pyo3(signature = (inputs = None))]
    fn salib_problem<'py>(
        slf: PyRef<'py, Self>,
        inputs: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let py = slf.py();
        py.import("gpu_amcs._interop")?
            .call_method1("salib_problem", (slf, inputs))
    }

    /// An OpenTURNS `Function` of the uncertain inputs (`columns`: names or indices; `free` by
    /// default; mm, degrees) whose one output `w` is `max_error` of the rows at the
    /// configurations `q_deg`; a whole sample is evaluated in one call. The other keywords
    /// (`reference`, `nominal`, `backend`, `offsets`) go to `max_error`. Needs openturns.
    #[pyo3(signature = (q_deg, columns = None, **kwargs))]
    fn openturns_function<'py>(
        slf: PyRef<'py, Self>,
        q_deg: Bound<'py, PyAny>,
        columns: Option<Bound<'py, PyAny>>,
        kwargs: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let py = slf.py();
        py.import("gpu_amcs._interop")?.call_method(
            "openturns_function",
            (slf, q_deg, columns),
            kwargs,
        )
    }

    fn __repr__(&self) -> String {
        let form = match self.model.uncertainty {
            Uncertainty::Independent(_) => "independent σ",
            Uncertainty::Covariance(_) => "covariance",
        };
        format!(
            "gpu_amcs.Model('{}', {} free inputs of {}, {form})",
            self.model.name,
            self.model.free_inputs().len(),
            self.model.robot_inputs().len()
        )
    }
}

/// A discrepancy term as the `discrepancy` getters give it.
fn term_dict<'py>(
    py: Python<'py>,
    d: &gpu_amcs_core::discrepancy::Discrepancy,
) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(py);
    out.set_item("residual_norms", d.residual_norms.clone())?;
    out.set_item("robot_share", d.robot_share)?;
    out.set_item("noise", d.noise.as_str())?;
    out.set_item("noise_sigma_mm", d.noise_sigma_mm)?;
    out.set_item("robot_rms_mm", d.robot_rms_mm())?;
    out.set_item("drawn", d.drawn())?;
    let compensation = match &d.compensation {
        None => None,
        Some(c) => {
            let g = PyDict::new(py);
            g.set_item("length_scales_deg", c.length_scales_deg.clone())?;
            g.set_item("signal_sigma_mm", c.signal_sigma_mm)?;
            g.set_item("white_sigma_mm", c.white_sigma_mm)?;
            g.set_item("loo_rms_geometric_mm", c.loo_rms_geometric_mm)?;
            g.set_item("loo_rms_compensated_mm", c.loo_rms_compensated_mm)?;
            g.set_item("poses", c.configurations_deg.len())?;
            Some(g)
        }
    };
    out.set_item("compensation", compensation)?;
    Ok(out)
}
