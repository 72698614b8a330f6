//! The subcommands: one file each, holding its arguments and its run. Shared pieces:
//! [`args`] turns argument groups into library values, [`outputs`] checks every output path
//! before any work and writes all reports or none, [`reports`] writes any library `Report` the
//! report flags ask for, [`progress`] is the one progress bar, [`flags`] gives library setting
//! errors their flag. Errors are `anyhow` here only.

pub mod amcs;
pub mod analysis;
pub mod args;
pub mod calibrate;
pub mod compare;
pub mod export;
pub mod fk;
pub mod flags;
pub mod identify;
pub mod import;
pub mod map;
pub mod mcs;
pub mod merge;
pub mod model;
pub mod outputs;
pub mod plan;
pub mod points;
pub mod progress;
pub mod reports;
pub mod sensitivity;
pub mod simulate;
pub mod stdout;
pub mod study;
pub mod tail;
pub mod targets;
pub mod validate;

/// A subcommand's arguments know how to run it.
pub trait Run {
    /// Runs the subcommand.
    fn run(self) -> anyhow::Result<()>;
}
