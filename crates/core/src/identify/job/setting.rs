//! The errors of an [`super::IdentifyJob`]: which setting is at fault ([`IdentifySetting`]), and why
//! no model came ([`IdentifyJobError`]).

use crate::identify::IdentifyError;

/// The settings of an [`super::IdentifyJob`] its errors name; a front end maps each to its own name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum IdentifySetting {
    /// [`super::IdentifyJob::tracker_sigma_mm`].
    TrackerSigma,
    /// [`super::IdentifyJob::tracker_mpe`].
    TrackerMpe,
    /// [`super::IdentifyJob::tracker_at_mm`].
    TrackerAt,
    /// The draws of [`crate::identify::UncertaintyMethod::MonteCarlo`].
    McDraws,
    /// [`super::IdentifyJob::method`] (sweeps only).
    Fit,
    /// [`super::IdentifyJob::refine`] (sweeps only).
    Refine,
    /// [`super::IdentifyJob::memory`]: the data need more memory than it allows.
    Memory,
    /// [`super::IdentifyJob::columns`]: the map does not fit the data file.
    Columns,
    /// [`super::IdentifyJob::harmonic_orders`].
    HarmonicOrders,
}

/// Why an identification job gave no model.
#[derive(Debug, thiserror::Error)]
pub enum IdentifyJobError {
    /// A setting cannot be used; the message says why (without naming the setting, which the
    /// front end does).
    #[error("{message}")]
    Setting {
        /// The setting at fault.
        setting: IdentifySetting,
        /// What is wrong.
        message: String,
    },
    /// The job is strict and the results look implausible; no model.
    #[error("{} implausible result(s): {}", warnings.len(), warnings.join("; "))]
    Strict {
        /// The warnings, one line per joint and kind of problem.
        warnings: Vec<String>,
    },
    /// Reading, checking or fitting the data failed.
    #[error(transparent)]
    Identify(#[from] IdentifyError),
}
