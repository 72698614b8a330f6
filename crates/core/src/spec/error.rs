//! The fields of a [`ProblemSpec`](super::ProblemSpec) and the errors that name them.

use crate::engine::{EngineError, ProblemError};
use crate::import::ImportError;
use crate::kinematics::ModelError;
use crate::points::PointsError;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// A field of a [`ProblemSpec`](super::ProblemSpec), as errors name it. Front ends map each to their own option
/// name (an exhaustive match keeps the maps complete).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SpecField {
    /// The analysed model, from a file or in memory ([`ProblemSpec::model`](super::ProblemSpec::model)).
    Model,
    /// The analysed model as a preset ([`ModelSource::Preset`](super::ModelSource::Preset)).
    Preset,
    /// The number of generated test points ([`GeneratedPoints::count`](super::GeneratedPoints::count)).
    Points,
    /// The seed of the generated test points ([`GeneratedPoints::seed`](super::GeneratedPoints::seed)).
    PointsSeed,
    /// The workspace box centre ([`GeneratedPoints::box_center`](super::GeneratedPoints::box_center)).
    BoxCenter,
    /// The workspace box size ([`GeneratedPoints::box_size`](super::GeneratedPoints::box_size)).
    BoxSize,
    /// A points file ([`PointsSource::File`](super::PointsSource::File)).
    PointsFile,
    /// Given configurations ([`PointsSource::Given`](super::PointsSource::Given)).
    Configurations,
    /// The reference ([`ProblemSpec::reference`](super::ProblemSpec::reference)).
    Reference,
    /// The nominal model of a nominal reference ([`ReferenceSource::Nominal`](super::ReferenceSource::Nominal)).
    Nominal,
    /// The seed of the parameter draws ([`ProblemSpec::seed`](super::ProblemSpec::seed)).
    Seed,
    /// The backend ([`ProblemSpec::backend`](super::ProblemSpec::backend)).
    Backend,
    /// The GPU adapter ([`ProblemSpec::adapter`](super::ProblemSpec::adapter)).
    Adapter,
    /// Whether the model's discrepancy term is drawn ([`ProblemSpec::discrepancy`](super::ProblemSpec::discrepancy)).
    Discrepancy,
    /// The payload at the task ([`ProblemSpec::payload`](super::ProblemSpec::payload)).
    Payload,
    /// The backlash sides at given configurations ([`ProblemSpec::sides`](super::ProblemSpec::sides)).
    Sides,
}

impl SpecField {
    /// Every field.
    pub const ALL: [SpecField; 16] = [
        SpecField::Model,
        SpecField::Preset,
        SpecField::Points,
        SpecField::PointsSeed,
        SpecField::BoxCenter,
        SpecField::BoxSize,
        SpecField::PointsFile,
        SpecField::Configurations,
        SpecField::Reference,
        SpecField::Nominal,
        SpecField::Seed,
        SpecField::Backend,
        SpecField::Adapter,
        SpecField::Discrepancy,
        SpecField::Payload,
        SpecField::Sides,
    ];

    /// The field's name in messages, e.g. `points_file`.
    pub fn name(self) -> &'static str {
        match self {
            SpecField::Model => "model",
            SpecField::Preset => "preset",
            SpecField::Points => "points",
            SpecField::PointsSeed => "points_seed",
            SpecField::BoxCenter => "box_center",
            SpecField::BoxSize => "box_size",
            SpecField::PointsFile => "points_file",
            SpecField::Configurations => "configurations",
            SpecField::Reference => "reference",
            SpecField::Nominal => "nominal",
            SpecField::Seed => "seed",
            SpecField::Backend => "backend",
            SpecField::Adapter => "adapter",
            SpecField::Discrepancy => "discrepancy",
            SpecField::Payload => "payload",
            SpecField::Sides => "sides",
        }
    }

    /// Where the field lives in a serialized spec: object keys joined by dots, e.g.
    /// `points.generate.box_size`. Keys below it (the variants of a model source) belong to it.
    pub fn path(self) -> &'static str {
        match self {
            SpecField::Model => "model",
            SpecField::Preset => "model.preset",
            SpecField::Points => "points.generate.count",
            SpecField::PointsSeed => "points.generate.seed",
            SpecField::BoxCenter => "points.generate.box_center",
            SpecField::BoxSize => "points.generate.box_size",
            SpecField::PointsFile => "points.file",
            SpecField::Configurations => "points.given",
            SpecField::Reference => "reference",
            SpecField::Nominal => "reference.nominal",
            SpecField::Seed => "seed",
            SpecField::Backend => "backend",
            SpecField::Adapter => "adapter",
            SpecField::Discrepancy => "discrepancy",
            SpecField::Payload => "payload",
            SpecField::Sides => "sides",
        }
    }

    /// The field a dotted key path of a serialized spec belongs to: the field whose
    /// [`path`](Self::path) is the longest that equals `path` or contains it below itself;
    /// `None` for a key no field covers.
    pub fn at_path(path: &str) -> Option<SpecField> {
        SpecField::ALL
            .into_iter()
            .filter(|f| {
                let p = f.path();
                path == p
                    || path
                        .strip_prefix(p)
                        .is_some_and(|rest| rest.starts_with('.'))
            })
            .max_by_key(|f| f.path().len())
    }
}

impl std::fmt::Display for SpecField {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// What went wrong with a field of a spec.
#[derive(Debug, thiserror::Error)]
pub enum SpecErrorKind {
    /// A model could not be read or is invalid, or a preset is unknown.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// A robot description could not be imported.
    #[error(transparent)]
    Import(#[from] ImportError),
    /// Test points could not be generated or read.
    #[error(transparent)]
    Points(#[from] PointsError),
    /// The problem could not be set up (model checks, test points outside the limits).
    #[error(transparent)]
    Problem(#[from] ProblemError),
    /// A test point of a points file is unusable: the file, then the point.
    #[error("{path}: {source}", path = .path.display())]
    PointsFile {
        /// The points file.
        path: PathBuf,
        /// What is wrong with the point.
        source: ProblemError,
    },
    /// A nominal reference without a nominal model, for an analysed model that is no preset
    /// (by name): its design geometry is unknown, and another robot's would be wrong.
    #[error("the model '{model}' is not a preset and has no nominal model: name one")]
    NoNominal {
        /// The analysed model's name.
        model: String,
    },
    /// The nominal model of a nominal reference has another number of joints than the analysed
    /// model: it is another robot, and its positions cannot be computed at the model's
    /// configurations.
    #[error("the nominal model {nominal} has {nominal_joints} joints and the model {model} has {model_joints}: the nominal model must be the same robot")]
    NominalJoints {
        /// Where the nominal model came from ([`ModelSource::describe`](super::ModelSource::describe)).
        nominal: String,
        /// Its joints.
        nominal_joints: usize,
        /// Where the analysed model came from.
        model: String,
        /// Its joints.
        model_joints: usize,
    },
    /// The nominal model's geometry is another robot's: its flanges lie far from the model's.
    #[error("the nominal model {nominal} is another robot than the model {model}: their flanges are {gap_mm:.1} mm RMS apart over the joint ranges (calibration moves a flange by millimetres); the nominal model must be the robot's own nominal geometry")]
    NominalOtherRobot {
        /// Where the nominal model came from.
        nominal: String,
        /// Where the analysed model came from.
        model: String,
        /// RMS distance of the flange centres, mm.
        gap_mm: f64,
    },
    /// A payload for a model without joint compliance, or out of range.
    #[error("{0}")]
    Payload(String),
    /// An adapter was named for the CPU backend.
    #[error("'{0}' needs the gpu or auto backend: the CPU backend uses no adapter")]
    AdapterWithCpu(String),
    /// The evaluator could not be built.
    #[error(transparent)]
    Engine(#[from] EngineError),
}

/// An error of a [`ProblemSpec`](super::ProblemSpec): the field at fault and what is wrong with it.
#[derive(Debug, thiserror::Error)]
#[error("{field}: {kind}")]
pub struct SpecError {
    /// The field at fault.
    pub field: SpecField,
    /// What is wrong.
    #[source]
    pub kind: SpecErrorKind,
}

impl SpecError {
    /// An error of `field`.
    pub fn new(field: SpecField, kind: impl Into<SpecErrorKind>) -> SpecError {
        SpecError {
            field,
            kind: kind.into(),
        }
    }
}
