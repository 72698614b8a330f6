//! The problem keywords every analysis on test points shares (`mcs`, `amcs`, `sensitivity`,
//! `tail`), turned into the library's [`ProblemSpec`] and built by it: the same model, test
//! points, reference, seed and backend as the command line's flags give, with the same errors,
//! naming the Python keyword where the command line names its flag.

use crate::arrays;
use crate::errors::{arg_error, value_error};
use crate::model::{self, PyModel};
use gpu_amcs_core::engine::{Evaluator, Frame, Problem};
use gpu_amcs_core::job::{JobError, Setup};
use gpu_amcs_core::memory::{Estimate, MemoryBudget};
use gpu_amcs_core::spec::{
    self, BuiltProblem, GeneratedPoints, ModelSource, PointsSource, ProblemSpec, ReferenceSource,
    SpecError, SpecField, DEFAULT_PRESET,
};
use pyo3::prelude::*;
use std::path::PathBuf;

/// The Python keyword that sets each field of a [`ProblemSpec`] (the command line's flag,
/// spelled as a keyword; given configurations are `q_deg`).
pub fn keyword(field: SpecField) -> &'static str {
    match field {
        SpecField::Model => "model",
        SpecField::Preset => "preset",
        SpecField::Points => "points",
        SpecField::PointsSeed => "points_seed",
        SpecField::BoxCenter => "box_center",
        SpecField::BoxSize => "box_size",
        SpecField::PointsFile => "points_file",
        SpecField::Configurations => "q_deg",
        SpecField::Reference => "reference",
        SpecField::Nominal => "nominal",
        SpecField::Seed => "seed",
        SpecField::Backend => "backend",
        SpecField::Adapter => "adapter",
        SpecField::Discrepancy => "discrepancy",
        SpecField::Payload => "payload_kg",
        SpecField::Sides => "sides",
    }
}

/// The problem keywords, as the functions receive them.
pub struct ProblemKw<'py> {
    pub model: Option<PyRef<'py, PyModel>>,
    pub preset: Option<String>,
    pub points: usize,
    pub q_deg: Option<Bound<'py, PyAny>>,
    pub points_file: Option<PathBuf>,
    pub points_seed: u64,
    pub box_center: Option<[f64; 3]>,
    pub box_size: Option<[f64; 3]>,
    pub seed: u64,
    pub reference: String,
    pub nominal: Option<PyRef<'py, PyModel>>,
    pub backend: String,
    pub adapter: Option<String>,
    pub memory_limit: Option<Bound<'py, PyAny>>,
    /// "measurement" or "base": the frame of the targets (the command line's `--frame`).
    pub frame: String,
    /// Draw the model's discrepancy term (`False`: the command line's `--no-discrepancy`).
    pub discrepancy: bool,
    /// The payload at the task, kg (the command line's `--payload-kg`; `None`: the model's).
    pub payload_kg: Option<f64>,
    /// Its standard uncertainty, kg.
    pub payload_sigma_kg: f64,
    /// Its centre of mass in the flange frame, mm (`None`: the model's).
    pub payload_com: Option<[f64; 3]>,
    /// The backlash sides at the configurations `q_deg` (m × n of 1, −1, 0; the command line's
    /// points-file columns `s1..sn`).
    pub sides: Option<Bound<'py, PyAny>>,
}

/// The reference from the keywords `reference` and `nominal`; without `nominal`, a nominal
/// reference is the preset `default_preset` gives (the one asked for, else the one the model
/// came from), else the library's choice ([`ReferenceSource::Nominal`]`(None)`: the preset the
/// analysed model's name says it is, or an error naming `nominal`). The flag: whether the
/// nominal model is that preset.
pub fn reference_source(
    kind: &str,
    nominal: Option<&PyModel>,
    default_preset: impl FnOnce() -> Option<String>,
) -> PyResult<(ReferenceSource, bool)> {
    match (kind, nominal) {
        ("calibrated", None) => Ok((ReferenceSource::Calibrated, false)),
        ("calibrated", Some(_)) => Err(value_error(
            "nominal is used only with reference=\"nominal\"",
        )),
        ("nominal", Some(n)) => Ok((
            ReferenceSource::Nominal(Some(ModelSource::Model(Box::new(n.model.clone())))),
            false,
        )),
        ("nominal", None) => Ok(match default_preset() {
            Some(name) => (
                ReferenceSource::Nominal(Some(ModelSource::Preset(name))),
                true,
            ),
            // The library takes the preset the model is (by its name) or refuses, naming the
            // nominal field: another robot's geometry would be a wrong reference.
            None => (ReferenceSource::Nominal(None), false),
        }),
        (other, _) => Err(value_error(format!(
            "reference: unknown reference '{other}' (expected \"calibrated\" or \"nominal\")"
        ))),
    }
}

/// The spec of an evaluation of the in-memory `model` at the configurations `q` (degrees, one
/// angle per joint of the model) on `backend`, with seed 0 (`Model.max_error`, which gives its own parameter rows).
pub fn given_points(
    model: &PyModel,
    q: Vec<gpu_amcs_core::kinematics::Joints>,
    reference: &str,
    nominal: Option<&PyModel>,
    backend: gpu_amcs_core::engine::BackendChoice,
) -> PyResult<Spec> {
    let (reference, nominal_from_preset) =
        reference_source(reference, nominal, || model.preset.clone())?;
    Ok(Spec {
        spec: ProblemSpec {
            model: ModelSource::Model(Box::new(model.model.clone())),
            points: PointsSource::Given(q),
            reference,
            seed: 0,
            backend,
            adapter: None,
            discrepancy: true,
            payload: None,
            sides: None,
        },
        nominal_from_preset,
        // Parameter rows carry the 5n + 3 inputs (no placement): the robot's own frame.
        frame: Frame::Base,
    })
}

/// A spec from the keywords, and how to name its errors.
pub struct Spec {
    /// The library's description of the problem.
    pub spec: ProblemSpec,
    /// Whether the nominal model is the default one, from `preset` (its errors name `preset`).
    nominal_from_preset: bool,
    /// The frame of the targets: the measurement frame draws a model's uncertain placement.
    pub frame: Frame,
}

impl Spec {
    /// A spec error as a `ValueError` naming the keyword.
    pub fn error(&self, e: SpecError) -> PyErr {
        spec_error(e, self.nominal_from_preset)
    }

    /// A job error as a `ValueError` naming the keyword (a spec field as [`Self::error`]).
    pub fn job_error(&self, e: JobError) -> PyErr {
        match e {
            JobError::Spec(e) => self.error(e),
            e => crate::errors::job_error(e),
        }
    }

    /// Runs a job on this spec without the GIL: what it gives, or its error naming the keyword.
    pub fn run<T: Send>(
        &self,
        py: Python<'_>,
        job: impl FnOnce() -> Result<T, JobError> + Send,
    ) -> PyResult<T> {
        py.detach(job).map_err(|e| self.job_error(e))
    }

    /// The setup of a job on this spec within `memory`, heard by nobody.
    pub fn setup(&self, memory: MemoryBudget) -> Setup {
        Setup {
            memory,
            frame: self.frame,
            ..Setup::new(self.spec.clone())
        }
    }

    /// Builds the problem ([`ProblemSpec::build_problem`]) and checks the memory of its points
    /// by `estimate`.
    pub fn build(&self, estimate: &dyn Fn(u64) -> PyResult<()>) -> PyResult<BuiltProblem> {
        let built = self.spec.build_problem().map_err(|e| self.error(e))?;
        estimate(built.problem.n_points() as u64)?;
        Ok(built)
    }

    /// What builds the evaluator without the GIL ([`Evaluators::make`]).
    pub fn evaluators(&self) -> Evaluators {
        Evaluators {
            backend: self.spec.backend,
            adapter: self.spec.adapter.clone(),
            frame: self.frame,
        }
    }
}

/// The backend and adapter of a spec, to build its evaluator where the GIL is released.
pub struct Evaluators {
    backend: gpu_amcs_core::engine::BackendChoice,
    adapter: Option<String>,
    frame: Frame,
}

impl Evaluators {
    /// The evaluator of `problem` in the spec's frame and the notes on the choice (and on the
    /// frame, for a model with an uncertain placement).
    pub fn make(&self, problem: Problem) -> PyResult<(Box<dyn Evaluator>, Vec<String>)> {
        spec::make_frame_evaluator(
            crate::backends(),
            problem,
            self.backend,
            self.adapter.as_deref(),
            self.frame,
        )
        .map_err(|e| spec_error(e, false))
    }
}

/// The frame from the `frame` keyword.
pub fn frame(name: &str) -> PyResult<Frame> {
    match name {
        "measurement" => Ok(Frame::Measurement),
        "base" => Ok(Frame::Base),
        other => Err(value_error(format!(
            "frame: unknown frame '{other}' (expected \"measurement\" or \"base\")"
        ))),
    }
}

/// A spec error as a `ValueError`: `"keyword: cause"`.
fn spec_error(e: SpecError, nominal_from_preset: bool) -> PyErr {
    let k = match e.field {
        SpecField::Nominal if nominal_from_preset => "preset",
        f => keyword(f),
    };
    arg_error(k, e.kind)
}

/// The memory budget of a call: `memory_limit` (bytes as an int, or a size such as "500M" or
/// "2GiB") when given, else 80 % of the smallest of the available memory, the address space
/// left under the process's `RLIMIT_AS` and the cgroup's room.
pub fn memory_budget(memory_limit: Option<&Bound<'_, PyAny>>) -> PyResult<MemoryBudget> {
    let Some(obj) = memory_limit else {
        return Ok(MemoryBudget::new(None));
    };
    let bytes = if let Ok(text) = obj.extract::<String>() {
        gpu_amcs_core::memory::parse_size(&text)
            .map_err(|e| value_error(format!("memory_limit: {e}")))?
    } else {
        match obj.extract::<i128>() {
            Ok(b) if (1..=i128::from(u64::MAX)).contains(&b) => b as u64,
            Ok(b) => {
                return Err(value_error(format!(
                    "memory_limit: {b} is not a size (at least 1 byte)"
                )))
            }
            Err(_) => {
                return Err(value_error(
                    "memory_limit: expected a number of bytes or a size such as \"500M\"",
                ))
            }
        }
    };
    Ok(MemoryBudget::new(Some(bytes)))
}

/// Checks that an estimate fits `budget`.
pub fn check_estimate(budget: &MemoryBudget, e: &Estimate) -> PyResult<()> {
    budget.check(e).map_err(crate::errors::memory_error)
}

impl ProblemKw<'_> {
    /// The memory budget the `memory_limit` keyword gives.
    pub fn budget(&self) -> PyResult<MemoryBudget> {
        memory_budget(self.memory_limit.as_ref())
    }
}

impl ProblemKw<'_> {
    /// The spec these keywords give.
    pub fn spec(&self) -> PyResult<Spec> {
        let backend = model::backend(&self.backend)?;
        let model = match &self.model {
            Some(m) => ModelSource::Model(Box::new(m.model.clone())),
            None => ModelSource::Preset(
                self.preset
                    .clone()
                    .unwrap_or_else(|| DEFAULT_PRESET.to_string()),
            ),
        };
        if self.sides.is_some() && self.q_deg.is_none() {
            return Err(value_error(
                "sides: belong to the configurations q_deg (a points_file gives its own in s1..sn columns)",
            ));
        }
        let mut sides = None;
        let points = match (&self.q_deg, &self.points_file) {
            (Some(_), Some(_)) => {
                return Err(value_error(
                    "q_deg and points_file exclude each other: give one",
                ))
            }
            (Some(q), None) => {
                // One column per joint of the model (the preset's, when no model is given).
                let joints = match &self.model {
                    Some(m) => m.model.joints(),
                    None => model
                        .load()
                        .map_err(|e| arg_error(keyword(model.field()), e))?
                        .joints(),
                };
                if let Some(sd) = &self.sides {
                    sides = Some(arrays::joint_rows(sd, "sides", joints)?.0);
                }
                PointsSource::Given(arrays::joint_rows(q, "q_deg", joints)?.0)
            }
            (None, Some(f)) => PointsSource::File(f.clone()),
            (None, None) => PointsSource::Generate(GeneratedPoints {
                count: self.points,
                seed: self.points_seed,
                box_center: self.box_center,
                box_size: self.box_size,
            }),
        };
        let default_preset = || {
            self.preset
                .clone()
                .or_else(|| self.model.as_ref().and_then(|m| m.preset.clone()))
        };
        let (reference, nominal_from_preset) =
            reference_source(&self.reference, self.nominal.as_deref(), default_preset)?;
        Ok(Spec {
            spec: ProblemSpec {
                model,
                points,
                reference,
                seed: self.seed,
                backend,
                adapter: self.adapter.clone(),
                discrepancy: self.discrepancy,
                payload: match self.payload_kg {
                    Some(mass_kg) => Some(gpu_amcs_core::spec::PayloadSpec {
                        mass_kg,
                        sigma_kg: self.payload_sigma_kg,
                        com_mm: self.payload_com,
                    }),
                    None if self.payload_sigma_kg != 0.0 || self.payload_com.is_some() => {
                        return Err(pyo3::exceptions::PyValueError::new_err(
                            "payload_sigma_kg and payload_com need payload_kg",
                        ))
                    }
                    None => None,
                },
                sides,
            },
            nominal_from_preset,
            frame: frame(&self.frame)?,
        })
    }
}

/// Defines a function on a problem: its own keyword arguments, then the problem keywords every
/// such function shares (the command line's flags, spelled as keywords, with their defaults),
/// gathered into a [`ProblemKw`] for `$body`.
///
/// `text_signature` is the signature `help()` and `inspect.signature` show: every keyword with
/// its default as Python writes it (PyO3 shows `...` for a default that is not a plain literal,
/// such as a list of thresholds). It must list the same keywords in the same order, ending with
/// the problem keywords: `preset=None, points=50, q_deg=None, points_file=None, points_seed=1,
/// box_center=None, box_size=None, seed=2025, reference='calibrated', nominal=None,
/// backend='auto', adapter=None, memory_limit=None, frame='measurement', discrepancy=True,
/// payload_kg=None, payload_sigma_kg=0.0, payload_com=None, sides=None`.
/// `python/tests/test_signatures.py` checks the defaults and that every keyword shown is taken;
/// `mypy.stubtest` (in `.ci/run`) that `gpu_amcs/_gpu_amcs.pyi` agrees.
macro_rules! problem_function {
    ($(#[$doc:meta])* text_signature = $sig:literal;
        fn $name:ident($($arg:ident: $ty:ty = $default:expr),*)
        -> $ret:ty |$py:ident, $problem:ident| $body:block) => {
        $(#[$doc])*
        #[pyfunction]
        #[pyo3(signature = (model = None, *, $($arg = $default,)* preset = None, points = 50,
            q_deg = None, points_file = None, points_seed = 1,
            box_center = None, box_size = None, seed = 2025,
            reference = "calibrated".to_string(), nominal = None,
            backend = "auto".to_string(), adapter = None, memory_limit = None,
            frame = "measurement".to_string(), discrepancy = true, payload_kg = None,
            payload_sigma_kg = 0.0, payload_com = None, sides = None),
            text_signature = $sig)]
        #[allow(clippy::too_many_arguments)]
        pub fn $name<'py>(
            $py: ::pyo3::Python<'py>,
            model: Option<::pyo3::PyRef<'py, $crate::model::PyModel>>,
            $($arg: $ty,)*
            preset: Option<String>,
            points: usize,
            q_deg: Option<::pyo3::Bound<'py, ::pyo3::PyAny>>,
            points_file: Option<::std::path::PathBuf>,
            points_seed: u64,
            box_center: Option<[f64; 3]>,
            box_size: Option<[f64; 3]>,
            seed: u64,
            reference: String,
            nominal: Option<::pyo3::PyRef<'py, $crate::model::PyModel>>,
            backend: String,
            adapter: Option<String>,
            memory_limit: Option<::pyo3::Bound<'py, ::pyo3::PyAny>>,
            frame: String,
            discrepancy: bool,
            payload_kg: Option<f64>,
            payload_sigma_kg: f64,
            payload_com: Option<[f64; 3]>,
            sides: Option<::pyo3::Bound<'py, ::pyo3::PyAny>>,
        ) -> ::pyo3::PyResult<$ret> {
            let $problem = $crate::problem::ProblemKw {
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
                memory_limit,
                frame,
                discrepancy,
                payload_kg,
                payload_sigma_kg,
                payload_com,
                sides,
            };
            $body
        }
    };
}

pub(crate) use problem_function;
