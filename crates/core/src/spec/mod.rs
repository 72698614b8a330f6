//! [`ProblemSpec`]: what an analysis runs on, by value: the model, the test points, the
//! reference the errors are measured from, the seed of the draws, and the backend that
//! evaluates them. Every front end (the command line, the Python package) fills one and builds
//! it here, so the [`Problem`] an analysis sees, the evaluator chosen for it and the errors about
//! either are the same everywhere.
//!
//! Errors are [`SpecError`]s naming the [`SpecField`] at fault (never a command-line flag or a
//! Python keyword); a front end maps each field to its own option name with one exhaustive
//! match and puts that name before the cause.
//!
//! A spec serializes (serde) with the field names of [`SpecField::path`], an in-memory model as
//! its model-file text:
//!
//! ```
//! use gpu_amcs_core::spec::{ProblemSpec, SpecField};
//!
//! let spec = ProblemSpec::default(); // the command line's defaults: tx60, 50 generated points
//! let built = spec.build_problem().unwrap();
//! assert_eq!(built.problem.n_points(), 50);
//! assert_eq!(built.reference, "calibrated model");
//! assert_eq!(SpecField::at_path("points.generate.box_size"), Some(SpecField::BoxSize));
//! ```

mod error;
#[cfg(test)]
mod tests;

mod model_source;
mod nominal;
mod sides;

pub use error::{SpecError, SpecErrorKind, SpecField};
pub use model_source::{is_description, ModelSource};

use crate::engine::{
    BackendChoice, Backends, Evaluator, Frame, PlacementSpread, Problem, ProblemError, Reference,
};
use crate::kinematics::{Joints, RobotModel};
use crate::points::{self, PointsError, WorkspaceBox, MAX_POINTS};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// The preset a spec uses when none is named: the model of [`ProblemSpec::default`] and the
/// nominal model of a nominal reference without one.
pub const DEFAULT_PRESET: &str = "tx60";

/// Where the test points come from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PointsSource {
    /// Generated: seeded configurations whose tool point lies in a workspace box.
    Generate(GeneratedPoints),
    /// A CSV file with header `q1..qn` (degrees), one column per joint of the model (`q1..q6`
    /// for a six-axis arm).
    File(PathBuf),
    /// Given configurations, degrees, one angle per joint of the model (a configuration of
    /// another length is refused when the problem is built).
    Given(Vec<Joints>),
}

/// Generated test points ([`points::generate`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GeneratedPoints {
    /// How many, 1 to [`MAX_POINTS`].
    pub count: usize,
    /// Seed of the configurations.
    pub seed: u64,
    /// Centre of the workspace box, mm; `None`: the robot's ([`WorkspaceBox::for_robot`]).
    pub box_center: Option<[f64; 3]>,
    /// Edge lengths of the workspace box, mm; `None`: the robot's.
    pub box_size: Option<[f64; 3]>,
}

impl Default for GeneratedPoints {
    /// 50 points with seed 1 in the robot's own box (the command line's defaults).
    fn default() -> Self {
        GeneratedPoints {
            count: 50,
            seed: 1,
            box_center: None,
            box_size: None,
        }
    }
}

impl GeneratedPoints {
    /// The workspace box for `model`: each of centre and size as given, else the robot's
    /// default ([`WorkspaceBox::for_robot`]).
    pub fn workspace(&self, model: &RobotModel) -> WorkspaceBox {
        let default = WorkspaceBox::for_robot(model);
        WorkspaceBox {
            center: self.box_center.unwrap_or(default.center),
            size: self.box_size.unwrap_or(default.size),
        }
    }
}

/// What the errors are measured from ([`Reference`]).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ReferenceSource {
    /// The position the analysed model itself predicts.
    #[default]
    Calibrated,
    /// A nominal (design) model's position; `None`: the preset the analysed model is (asked for,
    /// or by the model's name), else an error ([`SpecErrorKind::NoNominal`]): another robot's
    /// design geometry would be a wrong reference.
    Nominal(Option<ModelSource>),
}

/// Model, test points, reference, seed and backend of an analysis (see the module docs).
///
/// # Examples
///
/// The TX60 preset at ten generated test points, built with the CPU backend; the evaluator
/// computes the maximum point error `w` of the first draws:
///
/// ```
/// use gpu_amcs_core::engine::{BackendChoice, CpuOnly};
/// use gpu_amcs_core::spec::{GeneratedPoints, ModelSource, PointsSource, ProblemSpec, SpecField};
///
/// let spec = ProblemSpec {
///     model: ModelSource::Preset("tx60".into()),
///     points: PointsSource::Generate(GeneratedPoints {
///         count: 10,
///         seed: 1,
///         ..GeneratedPoints::default()
///     }),
///     seed: 7,
///     backend: BackendChoice::Cpu,
///     ..ProblemSpec::default()
/// };
/// let mut built = spec.build(&CpuOnly)?;
/// assert_eq!(built.problem.n_points(), 10);
/// assert_eq!(built.problem.seed, 7);
/// assert_eq!(built.reference, "calibrated model");
/// assert_eq!(built.evaluator.info().backend, "cpu");
///
/// let mut w = [0.0; 4];
/// built.evaluator.evaluate(0, &mut w, None)?;
/// // The TX60 preset has a parameter spread: every draw misses its targets a little.
/// assert!(w.iter().all(|&v| v.is_finite() && v > 0.0));
///
/// // The points are seeded: building the spec again gives the same ones.
/// assert_eq!(spec.build_problem()?.problem.points, built.problem.points);
///
/// // An error names the field at fault.
/// let unknown = ProblemSpec {
///     model: ModelSource::Preset("no-such-robot".into()),
///     ..spec.clone()
/// };
/// assert_eq!(unknown.build_problem().unwrap_err().field, SpecField::Preset);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ProblemSpec {
    /// The analysed model.
    pub model: ModelSource,
    /// The test points.
    pub points: PointsSource,
    /// What the errors are measured from.
    pub reference: ReferenceSource,
    /// Seed of the parameter draws.
    pub seed: u64,
    /// Which evaluator.
    pub backend: BackendChoice,
    /// GPU adapter (case-insensitive part of its name); needs the gpu or auto backend, and
    /// with auto asks for that GPU.
    pub adapter: Option<String>,
    /// Draw the model's discrepancy term ([`crate::discrepancy`]) at every test point (the
    /// default); `false` leaves it out: the parameters' uncertainty alone.
    pub discrepancy: bool,
    /// The payload at the task, for a model that carries joint compliance
    /// ([`crate::kinematics::JointErrors`]); `None` keeps the model's own (by default the one
    /// during its calibration).
    pub payload: Option<PayloadSpec>,
    /// The backlash sides the robot arrives at given configurations from, one row per
    /// configuration (`sides[j][i]`: `1` joint `i` moving positive, `-1`, `0` not known, drawn);
    /// only with [`PointsSource::Given`] (a points file gives its own in `s1..sn` columns) and a
    /// model with backlash ([`Problem::set_known_sides`]). `None`: every side drawn.
    pub sides: Option<Vec<Joints>>,
}

/// A payload at the task: mass with its standard uncertainty, and optionally its centre of mass.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PayloadSpec {
    /// Mass, kg.
    pub mass_kg: f64,
    /// Standard uncertainty of the mass, kg.
    #[serde(default)]
    pub sigma_kg: f64,
    /// Centre of mass in the flange frame, mm; `None` keeps the model's.
    #[serde(default)]
    pub com_mm: Option<[f64; 3]>,
}

impl PayloadSpec {
    /// `model` with this payload at the task.
    ///
    /// # Errors
    ///
    /// A message when the model carries no joint compliance (a payload changes nothing it
    /// predicts) or a value is out of range (mass and σ 0–10000 kg, centre within 100 m).
    pub fn apply(&self, model: &mut crate::kinematics::RobotModel) -> Result<(), String> {
        let name = model.name.clone();
        let Some(e) = model.joint_errors.as_mut() else {
            return Err(format!("the model '{name}' carries no joint compliance (identify it with the check beyond geometry), so a payload changes nothing it predicts"));
        };
        let ok = |v: f64| (0.0..=1e4).contains(&v);
        if !ok(self.mass_kg) || !ok(self.sigma_kg) {
            return Err(format!(
                "payload {} kg with σ {} kg: both must lie within 0 to 10000 kg",
                self.mass_kg, self.sigma_kg
            ));
        }
        if let Some(c) = self
            .com_mm
            .filter(|c| c.iter().any(|v| !v.is_finite() || v.abs() > 1e5))
        {
            return Err(format!(
                "payload centre of mass {c:?} mm: must be finite, within 100 m"
            ));
        }
        e.payload = crate::kinematics::Payload {
            mass_kg: self.mass_kg,
            sigma_kg: self.sigma_kg,
            com_mm: self.com_mm.unwrap_or(e.payload.com_mm),
        };
        Ok(())
    }
}

impl Default for ProblemSpec {
    /// The command line's defaults: the TX60 preset, 50 generated points (seed 1) in its own
    /// box, the calibrated reference, seed 2025, the auto backend.
    fn default() -> Self {
        ProblemSpec {
            model: ModelSource::Preset(DEFAULT_PRESET.to_string()),
            points: PointsSource::Generate(GeneratedPoints::default()),
            reference: ReferenceSource::Calibrated,
            seed: 2025,
            backend: BackendChoice::Auto,
            adapter: None,
            discrepancy: true,
            payload: None,
            sides: None,
        }
    }
}

/// The problem of a spec and how reports name its reference.
#[derive(Clone, Debug)]
pub struct BuiltProblem {
    /// Model, points, reference and seed.
    pub problem: Problem,
    /// `"calibrated model"` or `"nominal model (NAME)"` ([`Reference::label`]).
    pub reference: String,
    /// What loading the model chose on the user's behalf (the tip link of a description).
    pub notes: Vec<String>,
}

/// A spec built: the problem, its reference label, and the evaluator for it.
pub struct Built {
    /// Model, points, reference and seed (a copy of the evaluator's).
    pub problem: Problem,
    /// `"calibrated model"` or `"nominal model (NAME)"`.
    pub reference: String,
    /// The evaluator of the problem.
    pub evaluator: Box<dyn Evaluator>,
    /// What was chosen and why (a fallback to the CPU, a software adapter), if anything.
    pub notes: Vec<String>,
}

/// The backend and adapter to build: an adapter name needs a backend that can use it, and with
/// `auto` asks for that GPU (an error when none matches, not a silent CPU fallback).
///
/// # Errors
/// [`SpecErrorKind::AdapterWithCpu`] (field [`SpecField::Adapter`]) for an adapter with the CPU
/// backend.
pub fn backend_choice(
    backend: BackendChoice,
    adapter: Option<&str>,
) -> Result<(BackendChoice, Option<&str>), SpecError> {
    match (backend, adapter) {
        (BackendChoice::Cpu, Some(a)) => Err(SpecError::new(
            SpecField::Adapter,
            SpecErrorKind::AdapterWithCpu(a.to_string()),
        )),
        (BackendChoice::Auto, Some(a)) => Ok((BackendChoice::Gpu, Some(a))),
        (b, a) => Ok((b, a)),
    }
}

/// Builds the evaluator of `problem` on `backend` (and `adapter`) from `backends`; the notes say
/// what was chosen and why.
///
/// # Errors
/// Those of [`backend_choice`], and the [`EngineError`](crate::engine::EngineError) of a backend that cannot be built
/// (no adapter matches, no GPU backend in this build), naming [`SpecField::Adapter`] when an
/// adapter was given, else [`SpecField::Backend`].
pub fn make_evaluator(
    backends: &dyn Backends,
    problem: Problem,
    backend: BackendChoice,
    adapter: Option<&str>,
) -> Result<(Box<dyn Evaluator>, Vec<String>), SpecError> {
    let (choice, adapter) = backend_choice(backend, adapter)?;
    let field = if adapter.is_some() {
        SpecField::Adapter
    } else {
        SpecField::Backend
    };
    let (ev, note) = backends
        .make_evaluator(problem, choice, adapter)
        .map_err(|e| SpecError::new(field, e))?;
    Ok((ev, note.into_iter().collect()))
}

/// [`make_evaluator`] for an analysis whose test points' targets are in `frame`: with
/// [`Frame::Measurement`] and a model whose placement is uncertain (a 39 × 39 covariance) both
/// backends draw the placement too (docs/METHOD.md §2.8); with [`Frame::Base`] it is left out
/// (the model's 33 × 33 block). A note says which.
///
/// # Errors
/// Those of [`make_evaluator`]; [`SpecField::Backend`] when the covariance with the placement
/// has no Cholesky factor.
pub fn make_frame_evaluator(
    backends: &dyn Backends,
    mut problem: Problem,
    backend: BackendChoice,
    adapter: Option<&str>,
    frame: Frame,
) -> Result<(Box<dyn Evaluator>, Vec<String>), SpecError> {
    let uncertain = problem.model.base_uncertain();
    problem = problem.in_frame(frame);
    if uncertain {
        PlacementSpread::of(&problem).map_err(|e| SpecError::new(SpecField::Backend, e))?;
    }
    let term = problem
        .discrepancy
        .as_ref()
        .and(problem.model.discrepancy.as_ref())
        .map(|d| d.describe());
    let joint_errors = match (&problem.joint_errors, &problem.model.joint_errors) {
        (Some(_), Some(e)) => Some(e.describe() + &sides::note(&problem)),
        (None, Some(e)) if problem.sided.is_some() => Some(e.describe() + &sides::note(&problem)),
        _ => None,
    };
    let mixed = problem.centre().iter().any(|&c| c);
    let (ev, mut notes) = make_evaluator(backends, problem, backend, adapter)?;
    if let Some(t) = term {
        notes.push(if mixed {
            format!("{t}: drawn at the test points whose backlash sides are given")
        } else {
            format!("{t}: drawn at every test point")
        });
    }
    notes.extend(joint_errors);
    if uncertain {
        notes.push(match frame {
            Frame::Base => format!(
                "frame: {}: the model's placement uncertainty is left out",
                frame.label(false)
            ),
            Frame::Measurement => format!("frame: {}", frame.label(true)),
        });
    }
    Ok((ev, notes))
}

impl ProblemSpec {
    /// Checks what needs no file: the number of generated points and the adapter against the
    /// backend.
    ///
    /// # Errors
    /// [`SpecField::Points`] for more than [`MAX_POINTS`] generated points, and the errors of
    /// [`backend_choice`].
    pub fn check(&self) -> Result<(), SpecError> {
        if let PointsSource::Generate(g) = &self.points {
            if g.count > MAX_POINTS {
                return Err(SpecError::new(
                    SpecField::Points,
                    PointsError::TooMany(g.count),
                ));
            }
        }
        self.backend_choice()?;
        Ok(())
    }

    /// The backend and adapter to build ([`backend_choice`]).
    ///
    /// # Errors
    /// Those of [`backend_choice`].
    pub fn backend_choice(&self) -> Result<(BackendChoice, Option<&str>), SpecError> {
        backend_choice(self.backend, self.adapter.as_deref())
    }

    /// The number of test points when it is known without reading a file (generated or given).
    pub fn known_points(&self) -> Option<usize> {
        match &self.points {
            PointsSource::Generate(g) => Some(g.count),
            PointsSource::Given(q) => Some(q.len()),
            PointsSource::File(_) => None,
        }
    }

    /// The analysed model.
    ///
    /// # Errors
    /// Those of [`ModelSource::load`], naming [`SpecField::Preset`] or [`SpecField::Model`].
    pub fn load_model(&self) -> Result<RobotModel, SpecError> {
        self.load_model_noted().map(|(m, _)| m)
    }

    /// [`Self::load_model`] with the notes of [`ModelSource::load_noted`].
    ///
    /// # Errors
    /// As [`Self::load_model`].
    pub fn load_model_noted(&self) -> Result<(RobotModel, Vec<String>), SpecError> {
        self.model
            .load_noted()
            .map_err(|kind| SpecError::new(self.model.field(), kind))
    }

    /// The test points (degrees, one angle per joint of `model`) for `model`: generated in the
    /// workspace box for `model`, read from the points file (one column per joint of `model`),
    /// or the given ones.
    ///
    /// # Errors
    /// Generated points: [`SpecField::BoxSize`] or [`SpecField::BoxCenter`] for a box that is
    /// empty or not finite, [`SpecField::Points`] for a count out of range or a box out of reach.
    /// A points file: [`SpecField::PointsFile`] when it cannot be read or parsed.
    pub fn load_points(&self, model: &RobotModel) -> Result<Vec<Joints>, SpecError> {
        match &self.points {
            PointsSource::Generate(g) => {
                let bx = g.workspace(model);
                let own = WorkspaceBox::for_robot(model);
                if g.box_size.is_none() && !own.size.iter().all(|s| *s > 0.0) {
                    // The robot's own box is empty: the model's lengths are wrong (in metres in
                    // a millimetre file, typically), not a box the user gave.
                    return Err(SpecError::new(
                        SpecField::Model,
                        PointsError::BadBox(format!(
                            "the robot's own box is empty (size {:?} mm) because the arm reaches \
                             only {} mm beyond joint 1: are its lengths in metres? Give the box's \
                             centre and size, or correct the model's units",
                            own.size,
                            crate::number::fmt_plain(points::reach_mm(model))
                        )),
                    ));
                }
                points::generate(model, g.count, &bx, g.seed).map_err(|e| {
                    let field = match e {
                        PointsError::BadBox(_)
                            if !bx.size.iter().all(|s| s.is_finite() && *s > 0.0) =>
                        {
                            SpecField::BoxSize
                        }
                        PointsError::BadBox(_) => SpecField::BoxCenter,
                        _ => SpecField::Points,
                    };
                    SpecError::new(field, e)
                })
            }
            PointsSource::File(f) => points::read_csv(f, model.joints())
                .map_err(|e| SpecError::new(SpecField::PointsFile, e)),
            PointsSource::Given(q) => Ok(q.clone()),
        }
    }

    /// What the errors of an analysis of `model` (the analysed model, as loaded) are measured
    /// from. A nominal reference without its own nominal model uses the preset the model is: the
    /// preset asked for, else the preset `model`'s name says it came from
    /// ([`crate::presets::preset_named`]: a model file the preset printed, or one identified or
    /// calibrated from it).
    ///
    /// # Errors
    /// Those of [`ModelSource::load`] for the nominal model, naming [`SpecField::Nominal`];
    /// [`SpecErrorKind::NoNominal`], naming [`SpecField::Nominal`], when the nominal model is not
    /// given and `model` is no preset; [`SpecErrorKind::NominalJoints`], naming
    /// [`SpecField::Nominal`], when it has another number of joints than `model`, and
    /// [`SpecErrorKind::NominalOtherRobot`] when its flanges lie more than
    /// [`crate::identify::validate::OTHER_ROBOT_MM`] RMS from `model`'s over the joint ranges.
    pub fn load_reference(&self, model: &RobotModel) -> Result<Reference, SpecError> {
        match &self.reference {
            ReferenceSource::Calibrated => Ok(Reference::Calibrated),
            ReferenceSource::Nominal(source) => {
                let default;
                let source = match source {
                    Some(s) => s,
                    None => {
                        let name = match &self.model {
                            ModelSource::Preset(name) => name.clone(),
                            _ => crate::presets::preset_named(&model.name)
                                .ok_or_else(|| {
                                    SpecError::new(
                                        SpecField::Nominal,
                                        SpecErrorKind::NoNominal {
                                            model: model.name.clone(),
                                        },
                                    )
                                })?
                                .to_string(),
                        };
                        default = ModelSource::Preset(name);
                        &default
                    }
                };
                let nominal = source
                    .load()
                    .map_err(|kind| SpecError::new(SpecField::Nominal, kind))?;
                nominal::check_same_robot(
                    &nominal,
                    source.describe(),
                    model,
                    self.model.describe(),
                )?;
                Ok(Reference::Nominal(Box::new(nominal)))
            }
        }
    }

    /// Checks the spec, reads the model, the points and the nominal model, and builds the
    /// problem.
    ///
    /// # Errors
    /// Those of [`check`](Self::check), [`load_model`](Self::load_model),
    /// [`load_points`](Self::load_points) and [`load_reference`](Self::load_reference), then the
    /// problem's: [`ProblemError`]s about the test points (none, one outside the joint limits)
    /// name where the points came from ([`SpecField::Points`], [`SpecField::PointsFile`] with
    /// the file, [`SpecField::Configurations`]); the model's own (its checks, its covariance)
    /// name the model.
    pub fn build_problem(&self) -> Result<BuiltProblem, SpecError> {
        self.check()?;
        let (mut model, notes) = self.load_model_noted()?;
        if let Some(p) = &self.payload {
            p.apply(&mut model)
                .map_err(|m| SpecError::new(SpecField::Payload, SpecErrorKind::Payload(m)))?;
        }
        let pts = self.load_points(&model)?;
        let reference = self.load_reference(&model)?;
        let label = reference.label(&model);
        let model_field = self.model.field();
        let problem = Problem::new(model, &pts, &reference, self.seed).map_err(|e| {
            let about_points = matches!(e, ProblemError::NoPoints | ProblemError::BadPoint { .. });
            match (&self.points, about_points) {
                (PointsSource::File(f), true) => SpecError::new(
                    SpecField::PointsFile,
                    SpecErrorKind::PointsFile {
                        path: f.clone(),
                        source: e,
                    },
                ),
                (PointsSource::Generate(_), true) => SpecError::new(SpecField::Points, e),
                (PointsSource::Given(_), true) => SpecError::new(SpecField::Configurations, e),
                (_, false) if matches!(e, ProblemError::NominalJoints { .. }) => {
                    SpecError::new(SpecField::Nominal, e)
                }
                (_, false) => SpecError::new(model_field, e),
            }
        })?;
        // A points file may give the backlash sides the robot arrives at them from.
        let mut problem = problem;
        if let PointsSource::File(f) = &self.points {
            sides::apply_file_sides(&mut problem, f)?;
        }
        if let Some(given) = &self.sides {
            sides::apply_given_sides(&mut problem, &self.points, given)?;
        }
        let mut notes = notes;
        let problem = if self.discrepancy {
            problem
        } else {
            if problem
                .model
                .discrepancy
                .as_ref()
                .is_some_and(|d| d.drawn())
            {
                notes.push("model discrepancy left out on request: the reliability covers the parameters' uncertainty alone and is optimistic by what the model does not explain".into());
            }
            problem.without_discrepancy()
        };
        Ok(BuiltProblem {
            problem,
            reference: label,
            notes,
        })
    }

    /// The evaluator of `problem` (built from this spec) on the spec's backend and adapter
    /// ([`make_evaluator`]).
    ///
    /// # Errors
    /// Those of [`make_evaluator`].
    pub fn evaluator(
        &self,
        problem: Problem,
        backends: &dyn Backends,
    ) -> Result<(Box<dyn Evaluator>, Vec<String>), SpecError> {
        make_evaluator(backends, problem, self.backend, self.adapter.as_deref())
    }

    /// [`build_problem`](Self::build_problem), then [`evaluator`](Self::evaluator) on a copy of
    /// the problem. Front ends that check memory between the two call them in turn.
    ///
    /// # Errors
    /// Those of [`build_problem`](Self::build_problem) and [`evaluator`](Self::evaluator).
    pub fn build(&self, backends: &dyn Backends) -> Result<Built, SpecError> {
        let built = self.build_problem()?;
        let (evaluator, notes) = self.evaluator(built.problem.clone(), backends)?;
        Ok(Built {
            problem: built.problem,
            reference: built.reference,
            evaluator,
            notes,
        })
    }
}
