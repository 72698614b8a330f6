//! Monte Carlo drivers: classic MCS with a fixed number of draws (GUM S1 §7) and the adaptive
//! Monte Carlo procedure of GUM S1 §7.9 (paper §2.2, METHOD.md §4), on any [`Evaluator`].
//!
//! Both produce a [`McResult`]: all `w` values (sorted), M1–M4, the coverage interval, the
//! reliability at each threshold with a 95 % binomial interval, optional single-point
//! reliabilities (paper eq. 14) and, for AMCS, the per-batch trace of the four fluctuation indices.
//!
//! [`Evaluator`]: crate::engine::Evaluator

mod amcs;
mod mcs;
mod result;
pub mod sensitivity;
pub mod stats;
pub mod summary;
pub mod tail;

pub use amcs::{run_amcs, AmcsOptions, Tolerance};
pub use mcs::{run_mcs, McsOptions};
pub use result::{
    min_draws, BatchTrace, McError, McResult, Method, Progress, RunSettings, Setting,
    DEFAULT_THRESHOLDS_MM,
};
pub use stats::{CoverageInterval, IntervalKind, Moments, Reliability};
