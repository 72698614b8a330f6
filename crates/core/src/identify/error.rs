//! The errors of reading sweep and measurement data and identifying a model.
//!
//! Each message is one self-contained line: a variant that wraps a lower-level error prints it in
//! its own text and does not also expose it as [`std::error::Error::source`], so a caller that
//! prints the whole chain (as `anyhow`'s `{:#}` does) shows every cause once.

use super::circle::CircleFitError;
use crate::kinematics::mdh::GeometryError;

/// Errors reading sweep or measurement data and identifying a model. Every variant about a sweep
/// names the joint (and the run, when the file has a `run` column).
#[derive(Debug, thiserror::Error)]
pub enum IdentifyError {
    /// A file could not be read or written.
    #[error("{path}: {cause}")]
    Io {
        /// The path given.
        path: String,
        /// The OS error (part of the message, not a separate source).
        cause: std::io::Error,
    },
    /// The file could not be read, is not UTF-8 or is too large.
    #[error(transparent)]
    Read(#[from] crate::input::ReadError),
    /// A malformed CSV row: wrong number of fields, a field that is not a (finite) number, a
    /// joint number outside 1–n (n the number of `q` columns). Fix the named line.
    #[error("{origin}: line {line}: {message}")]
    Csv {
        /// The file.
        origin: String,
        /// 1-based line number.
        line: u64,
        /// What is wrong.
        message: String,
    },
    /// The header lacks a required column.
    #[error("{origin}: missing column '{column}' (the header must have {expected})")]
    MissingColumn {
        /// The file.
        origin: String,
        /// The missing column.
        column: &'static str,
        /// All required columns.
        expected: String,
    },
    /// The file has a header but no data rows.
    #[error("{origin}: no data rows")]
    Empty {
        /// The file.
        origin: String,
    },
    /// A run has no sweep of a joint.
    #[error("joint {joint}{run}: no sweep of this joint (every joint of the model needs one)")]
    MissingJoint {
        /// 1-based joint.
        joint: usize,
        /// " (run X)" or "".
        run: String,
    },
    /// A non-swept joint differs from the sweep's home pose (two joints moving).
    #[error("joint {joint} sweep{run}: line {line}: joint {other} moved too (q{other} = {value} deg, the sweep's home is {home} deg); only the swept joint may move")]
    OtherJointMoved {
        /// The swept joint.
        joint: usize,
        /// " (run X)" or "".
        run: String,
        /// The line of the offending row.
        line: u64,
        /// The other joint that moved.
        other: usize,
        /// Its value in that row.
        value: f64,
        /// Its value in the sweep's first row.
        home: f64,
    },
    /// The circle fit of a joint failed (too few points, collinear, arc too short, radius too
    /// small).
    #[error("joint {joint} sweep{run}: {cause}")]
    Fit {
        /// The swept joint.
        joint: usize,
        /// " (run X)" or "".
        run: String,
        /// Why the fit failed (part of the message, not a separate source).
        cause: CircleFitError,
    },
    /// The measured axes cannot be turned into this joint's parameters.
    #[error("joint {joint}: {message}")]
    Geometry {
        /// 1-based joint.
        joint: usize,
        /// What is wrong.
        message: String,
    },
    /// A measurement's commanded angles are outside the model's joint limits.
    #[error("line {line}: {message}")]
    OutsideLimits {
        /// The measurement's line.
        line: u64,
        /// Which joint, its value and the limits.
        message: String,
    },
    /// The data (or a second model) have another number of joints than the model; the message
    /// names the line or model and both counts.
    #[error("{0}")]
    JointCount(String),
    /// Nothing to evaluate.
    #[error("{0}")]
    NoData(String),
    /// The harmonic orders per joint of [`super::chain::ChainOptions::harmonic_orders`] do not
    /// fit the model; the message says why.
    #[error("harmonic orders: {0}")]
    HarmonicOrders(String),
}

impl From<GeometryError> for IdentifyError {
    fn from(e: GeometryError) -> Self {
        IdentifyError::Geometry {
            joint: e.joint,
            message: e.message,
        }
    }
}
