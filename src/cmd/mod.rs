//! The subcommands: one file each, holding its arguments and its run. Shared pieces:
//! [`args`] turns argument groups into library values, [`outputs`] checks every output path
//! before any work and writes all reports or none, [`progress`] is the one progress bar.
//! Errors are `anyhow` here only; library errors that name a setting are given the flag here.

pub mod amcs;
pub mod analysis;
pub mod args;
pub mod calibrate;
pub mod compare;
pub mod export;
pub mod fk;
pub mod flags;
pub mod html;
pub mod identify;
pub mod import;
pub mod map;
pub mod mcs;
pub mod merge;
pub mod model;
pub mod outputs;
pub mod points;
pub mod progress;
pub mod sensitivity;
pub mod simulate;
pub mod study;
pub mod tail;
pub mod validate;

use gpu_amcs::mc::{McError, Setting};

/// A subcommand's arguments know how to run it.
pub trait Run {
    /// Runs the subcommand.
    fn run(self) -> anyhow::Result<()>;
}

/// The flag that sets each driver setting, per subcommand where they differ.
#[derive(Clone, Copy, Debug, Default)]
pub struct Flags {
    /// The flag of the numerical tolerance (`--delta`, or `--deltas` in `compare`).
    pub tolerance: &'static str,
}

impl Flags {
    /// The flag names of the AMCS and MCS subcommands.
    pub const RUN: Flags = Flags {
        tolerance: "--delta",
    };

    /// The flag of a setting, if the command line sets it.
    pub fn of(&self, s: Setting) -> Option<&'static str> {
        Some(match s {
            Setting::CoverageProbability => "--coverage",
            Setting::Thresholds => "--thresholds",
            Setting::Tolerance => self.tolerance,
            Setting::SignificantDigits => "--ndig",
            Setting::BatchSize => "--batch",
            Setting::MaxDraws => "--max-draws",
            Setting::Draws => "--draws",
            Setting::Chunk => return None,
        })
    }

    /// A driver error with the flag added to a setting's name.
    pub fn error(&self, e: McError) -> anyhow::Error {
        match e {
            McError::Setting { field, message } => match self.of(field) {
                Some(flag) => anyhow::anyhow!("{field} ({flag}): {message}"),
                None => anyhow::anyhow!("{field}: {message}"),
            },
            other => other.into(),
        }
    }
}
