//! Field → flag, in one place: which flags set each field of every library options struct the
//! command line fills ([`TABLES`]), and through those tables the flag a library setting error is
//! given ([`Driver::error`], [`sensitivity_error`], [`tail_error`], [`map_error`],
//! [`simulate_error`]).
//!
//! The library names its settings with enums (`Setting`, `SensitivitySetting`, `TailSetting`,
//! `MapSetting`, `SimulateSetting`), matched here without a wildcard, so a new setting does not
//! compile until it is given its field (and the flag is `None` only where the table says the
//! field is fixed, and why). The tests (`tests.rs`) check that every field of every struct in
//! [`TABLES`] has an entry (a field added to or renamed in a struct fails them until its table
//! has it), that every flag in the tables exists in clap's definition of their subcommands, and
//! that every setting an error can name maps to a field of its tables.

mod job;
mod spec;
mod tables;
#[cfg(test)]
mod tests;

pub use job::job_error;
pub use spec::{spec_error, spec_flag};
pub use tables::*;

use gpu_amcs::map::{MapError, MapSetting};
use gpu_amcs::mc::sensitivity::{SensitivityError, SensitivitySetting};
use gpu_amcs::mc::tail::{TailError, TailSetting};
use gpu_amcs::mc::{McError, Setting};
use gpu_amcs::simulate::{SimulateError, SimulateSetting};
use std::fmt::Display;
use Source::Flags;

/// A setting error as one line: the setting, its flag when it has one, and what is wrong.
fn named(field: impl Display, flag: Option<&str>, message: &str) -> anyhow::Error {
    match flag {
        Some(flag) => anyhow::anyhow!("{field} ({flag}): {message}"),
        None => anyhow::anyhow!("{field}: {message}"),
    }
}

/// `flag` when table `t` says it sets `field`; `None` when the field is fixed there or set by
/// other flags (the subcommand has no `flag`).
fn on(t: &Table, field: &str, flag: &'static str) -> Option<&'static str> {
    match t.fields.iter().find(|(f, _)| *f == field) {
        Some((_, Flags(flags))) => flags.contains(&flag).then_some(flag),
        Some(_) => None,
        None => {
            // A field this file misnames: the tests run every setting through here.
            debug_assert!(false, "{}: no field {field}", t.name);
            if cfg!(test) {
                panic!("{}: no field {field}", t.name);
            }
            None
        }
    }
}

/// The subcommands that run the MCS and AMCS drivers, whose settings ([`Setting`]) have
/// different flags.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Driver {
    /// `amcs` (and the default run) and `mcs` (and `merge`, which reports an `mcs` run):
    /// [`AMCS_OPTIONS`], [`MCS_OPTIONS`], [`RUN_SETTINGS`].
    Run,
    /// `compare`: [`COMPARE_AMCS`], [`COMPARE_MCS`], [`COMPARE_SETTINGS`].
    Compare,
}

impl Driver {
    /// The tables of the AMCS options, the MCS options and the run settings.
    fn tables(self) -> [&'static Table; 3] {
        match self {
            Driver::Run => [&AMCS_OPTIONS, &MCS_OPTIONS, &RUN_SETTINGS],
            Driver::Compare => [&COMPARE_AMCS, &COMPARE_MCS, &COMPARE_SETTINGS],
        }
    }

    /// The flag of a driver setting, if the subcommand has one.
    pub fn flag(self, s: Setting) -> Option<&'static str> {
        let [amcs, mcs, settings] = self.tables();
        match s {
            Setting::CoverageProbability => on(settings, "coverage_probability", "--coverage"),
            Setting::Thresholds => on(settings, "thresholds", "--thresholds"),
            Setting::Tolerance => {
                on(amcs, "tolerance", "--delta").or(on(amcs, "tolerance", "--deltas"))
            }
            Setting::SignificantDigits => on(amcs, "tolerance", "--ndig"),
            Setting::BatchSize => on(amcs, "batch_size", "--batch"),
            Setting::MaxDraws => on(amcs, "max_draws", "--max-draws"),
            Setting::Draws => on(mcs, "draws", "--draws"),
            Setting::Chunk => on(mcs, "chunk", "--chunk"),
        }
    }

    /// A driver error with the flag added to a setting's name.
    pub fn error(self, e: McError) -> anyhow::Error {
        match e {
            McError::Setting { field, message } => named(field, self.flag(field), &message),
            other => other.into(),
        }
    }
}

/// The flag of a sensitivity setting.
pub fn sensitivity(s: SensitivitySetting) -> Option<&'static str> {
    let t = &SENSITIVITY_OPTIONS;
    match s {
        SensitivitySetting::Draws => on(t, "draws", "--draws"),
        SensitivitySetting::Bootstrap => on(t, "bootstrap", "--bootstrap"),
        SensitivitySetting::Chunk => on(t, "chunk", "--chunk"),
        SensitivitySetting::Thresholds => on(t, "thresholds", "--thresholds"),
    }
}

/// A sensitivity error with the flag added to a setting's name.
pub fn sensitivity_error(e: SensitivityError) -> anyhow::Error {
    match e {
        SensitivityError::Setting { field, message } => named(field, sensitivity(field), &message),
        other => other.into(),
    }
}

/// The flag of a tail setting.
pub fn tail(s: TailSetting) -> Option<&'static str> {
    let t = &TAIL_OPTIONS;
    match s {
        TailSetting::Thresholds => on(t, "thresholds", "--threshold"),
        TailSetting::TargetCov => on(t, "target_cov", "--cov"),
        TailSetting::MaxEvaluations => on(t, "max_evaluations", "--max-evaluations"),
        TailSetting::SamplesPerLevel => on(t, "samples_per_level", "--samples-per-level"),
        TailSetting::P0 => on(t, "p0", "--p0"),
        TailSetting::ProposalSpread => on(t, "proposal_spread", "--proposal-spread"),
        TailSetting::BatchSize => on(t, "batch_size", "--batch-size"),
    }
}

/// A tail error with the flag added to a setting's name.
pub fn tail_error(e: TailError) -> anyhow::Error {
    match e {
        TailError::Setting { field, message } => named(field, tail(field), &message),
        other => other.into(),
    }
}

/// The flag of a map setting (the workspace box has two).
pub fn map(s: MapSetting) -> Option<&'static str> {
    let (spec, run) = (&MAP_SPEC, &MAP_RUN);
    match s {
        MapSetting::Cells => on(spec, "grid", "--cells"),
        MapSetting::Plane => on(spec, "grid", "--plane"),
        MapSetting::PlanePosition => on(spec, "grid", "--at"),
        MapSetting::Workspace => {
            on(spec, "workspace", "--box-center").map(|_| "--box-center/--box-size")
        }
        MapSetting::Orientation => on(spec, "orientation_rpy_deg", "--orientation"),
        MapSetting::ReferenceConfiguration => on(spec, "reference_q_deg", "--reference-q"),
        MapSetting::IkSeeds => on(spec, "ik_seeds", "--ik-seeds"),
        MapSetting::Thresholds => on(run, "thresholds", "--thresholds"),
        MapSetting::Draws => on(run, "draws", "--draws"),
    }
}

/// A map error with the flag added to a setting's name.
pub fn map_error(e: MapError) -> anyhow::Error {
    match e {
        MapError::Setting { field, message } => named(field, map(field), &message),
        other => other.into(),
    }
}

/// The flag of a simulation or study setting.
pub fn simulate(s: SimulateSetting) -> Option<&'static str> {
    let (factors, study) = (&FACTORS, &STUDY_SETTINGS);
    match s {
        SimulateSetting::Runs => on(factors, "runs", "--runs"),
        SimulateSetting::Range => on(factors, "range_fraction", "--range"),
        SimulateSetting::Step => on(factors, "step_deg", "--step"),
        SimulateSetting::Speed => on(factors, "speed_fraction", "--speed"),
        SimulateSetting::PointCounts => on(study, "point_counts", "--points"),
        SimulateSetting::McsDraws => on(study, "mcs_draws", "--mcs-draws"),
        SimulateSetting::Tolerances => on(study, "deltas", "--deltas"),
        SimulateSetting::Factors => on(study, "factors", "--factors"),
        SimulateSetting::JointErrors => on(&JOINT_ERROR_STUDY, "sizes", "--joint-errors"),
        SimulateSetting::JointErrorPoses => on(&JOINT_ERROR_STUDY, "poses", "--joint-error-poses"),
    }
}

/// A simulation or study error with the flag added to a setting's name.
pub fn simulate_error(e: SimulateError) -> anyhow::Error {
    match e {
        SimulateError::Setting { field, message } => named(field, simulate(field), &message),
        other => other.into(),
    }
}
