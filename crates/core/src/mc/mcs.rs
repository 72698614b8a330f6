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

impl McsOptions {
    /// Checks the settings: [`RunSettings::check`], at least 100/(1 − p) draws, a chunk of
    /// at least one draw.
    ///
    /// # Errors
    ///
    /// [`McError::Setting`] naming the setting out of range.
    pub fn check(&self) -> Result<(), McError> {
        let min = min_draws(self.settings.coverage_probability);
        self.settings.check()?;
        if self.draws < min {
            return Err(McError::Setting {
                field: Setting::Draws,
                message: format!("must be at least 100/(1 − p) = {min}, got {}", self.draws),
            });
        }
        if self.chunk == 0 {
            return Err(McError::Setting {
                field: Setting::Chunk,
                message: "must be positive".into(),
            });
        }
        Ok(())
    }
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
///
/// # Examples
///
/// Ten thousand draws on the CPU evaluator, with the TX60 at five test points:
///
/// ```
/// use gpu_amcs_core::engine::{CpuEvaluator, Problem, Reference};
/// use gpu_amcs_core::mc::{run_mcs, McsOptions, RunSettings};
///
/// let model = gpu_amcs_core::kinematics::tx60();
/// let points = gpu_amcs_core::points::generate(&model, 5, &Default::default(), 1)?;
/// let problem = Problem::new(model, &points, &Reference::Calibrated, 2025)?;
/// let opts = McsOptions {
///     draws: 10_000,
///     chunk: 5_000,
///     settings: RunSettings {
///         thresholds: vec![0.1, 0.2],
///         ..RunSettings::default()
///     },
/// };
/// let result = run_mcs(&mut CpuEvaluator::new(problem), &opts, None)?;
/// assert_eq!(result.draws, 10_000);
/// let ci = &result.coverage_interval;
/// assert!(ci.low <= result.estimate && result.estimate <= ci.high);
/// assert!(result.reliability[0].r <= result.reliability[1].r);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn run_mcs(
    eval: &mut dyn Evaluator,
    opts: &McsOptions,
    progress: Option<Progress>,
) -> Result<McResult, McError> {
    opts.check()?;
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
