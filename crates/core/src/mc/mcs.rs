//! Classic Monte Carlo (GUM S1 §7): a fixed number of draws, evaluated in chunks so a run of
//! 10^8 draws keeps only the w values (8 bytes a draw) and one chunk's per-point buffer.

use super::result::{
    min_draws, Accumulator, McError, McResult, Method, Progress, RunSettings, Setting,
};
use crate::engine::Evaluator;

/// MCS settings.
#[derive(Clone, Debug, PartialEq)]
pub struct McsOptions {
    /// Number of draws (the paper: 10^6).
    pub draws: u64,
    /// Draws per evaluation chunk.
    pub chunk: u64,
    /// p, interval kind, thresholds, per-point.
    pub settings: RunSettings,
}

impl Default for McsOptions {
    fn default() -> Self {
        McsOptions {
            draws: 1_000_000,
            chunk: 100_000,
            settings: RunSettings::default(),
        }
    }
}

/// Runs `opts.draws` draws on `eval`.
///
/// # Errors
///
/// [`McError::Setting`] for a coverage probability or thresholds out of range
/// ([`RunSettings::check`]), fewer draws than 100/(1 − p), or a chunk of 0; [`McError::Engine`]
/// when the evaluator fails; [`McError::NonFinite`] for a draw whose maximum point error is not
/// finite.
pub fn run_mcs(
    eval: &mut dyn Evaluator,
    opts: &McsOptions,
    progress: Option<Progress>,
) -> Result<McResult, McError> {
    let min = min_draws(opts.settings.coverage_probability);
    opts.settings.check()?;
    if opts.draws < min {
        return Err(McError::Setting {
            field: Setting::Draws,
            message: format!("must be at least 100/(1 − p) = {min}, got {}", opts.draws),
        });
    }
    if opts.chunk == 0 {
        return Err(McError::Setting {
            field: Setting::Chunk,
            message: "must be positive".into(),
        });
    }
    let mut acc = Accumulator::new(eval, opts.settings.clone(), opts.draws)?;
    let mut done = 0;
    while done < opts.draws {
        let n = opts.chunk.min(opts.draws - done);
        acc.add_batch(n as usize)?;
        done += n;
        if let Some(cb) = progress {
            cb(done, opts.draws);
        }
    }
    Ok(acc.finish(Method::Mcs, opts.chunk, true, None, Vec::new()))
}
