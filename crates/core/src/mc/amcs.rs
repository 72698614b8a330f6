//! Adaptive Monte Carlo, GUM Supplement 1 (JCGM 101:2008) §7.9, as the paper's §2.2 uses it.
//!
//! Batches of H draws are evaluated until, for the mean, the standard uncertainty and both ends
//! of the coverage interval, twice the standard deviation of the h batch estimates about their
//! average (`s = √(Σ_r (y_r − ȳ)² / (h(h−1)))`, paper eq. 21) is at most the numerical tolerance
//! δ. δ is given directly in mm, or derived each round from u(w) of all draws so far and a number
//! of significant digits `ndig` (§7.9.2: u = c·10^l with c an ndig-digit integer, δ = ½·10^l).
//! The results come from all h·H values. A cap on the draws ends the run as "not converged".

use super::result::{
    batch_estimates, min_draws, Accumulator, BatchTrace, McError, McResult, Method, Progress,
    RunSettings, Setting,
};
use crate::engine::Evaluator;

/// The numerical tolerance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Tolerance {
    /// δ in mm.
    Delta(f64),
    /// Significant decimal digits of u(w) (GUM S1 §7.9.2).
    Ndig(u32),
}

/// AMCS settings.
#[derive(Clone, Debug, PartialEq)]
pub struct AmcsOptions {
    /// δ or ndig.
    pub tolerance: Tolerance,
    /// Batch size H (GUM S1 uses M = max(100/(1−p), 10^4); the paper 10^4).
    pub batch_size: u64,
    /// Cap on total draws.
    pub max_draws: u64,
    /// p, interval kind, thresholds, per-point.
    pub settings: RunSettings,
}

impl Default for AmcsOptions {
    fn default() -> Self {
        AmcsOptions {
            tolerance: Tolerance::Delta(0.01),
            batch_size: 10_000,
            max_draws: 10_000_000,
            settings: RunSettings::default(),
        }
    }
}

impl AmcsOptions {
    /// Checks every setting; errors name the setting.
    ///
    /// # Errors
    ///
    /// [`McError::Setting`] naming the first setting out of range: the coverage probability or
    /// thresholds ([`RunSettings::check`]), a tolerance that is not a positive number of mm,
    /// significant digits outside 1–12, a batch size below 100/(1 − p) (GUM S1 §7.9.2), or a draw
    /// cap below two batches.
    pub fn check(&self) -> Result<(), McError> {
        self.settings.check()?;
        match self.tolerance {
            Tolerance::Delta(d) if !(d.is_finite() && d > 0.0) => {
                return Err(McError::Setting {
                    field: Setting::Tolerance,
                    message: format!("must be a positive number of mm, got {d}"),
                })
            }
            Tolerance::Ndig(n) if !(1..=12).contains(&n) => {
                return Err(McError::Setting {
                    field: Setting::SignificantDigits,
                    message: format!("must be 1 to 12, got {n}"),
                })
            }
            _ => {}
        }
        let p = self.settings.coverage_probability;
        let min_h = min_draws(p);
        if self.batch_size < min_h {
            return Err(McError::Setting {
                field: Setting::BatchSize,
                message: format!(
                    "must be at least 100/(1 − p) = {min_h} for p = {p} (GUM S1 §7.9.2), got {}",
                    self.batch_size
                ),
            });
        }
        let two = self.batch_size.saturating_mul(2);
        if self.max_draws < two {
            return Err(McError::Setting {
                field: Setting::MaxDraws,
                message: format!(
                    "must allow at least two batches (≥ {two}), got {}",
                    self.max_draws
                ),
            });
        }
        Ok(())
    }
}

/// δ from u and ndig (GUM S1 §7.9.2).
pub fn delta_from_ndig(u: f64, ndig: u32) -> f64 {
    if u.is_nan() || u <= 0.0 {
        return f64::INFINITY;
    }
    let l = u.log10().floor() - f64::from(ndig) + 1.0;
    0.5 * 10f64.powf(l)
}

fn spread(v: &[f64]) -> f64 {
    let h = v.len() as f64;
    let mean = v.iter().sum::<f64>() / h;
    (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (h * (h - 1.0))).sqrt()
}

/// Runs the adaptive procedure on `eval`.
///
/// # Errors
///
/// [`McError::Setting`] for a setting out of range ([`AmcsOptions::check`]), [`McError::Engine`]
/// when the evaluator fails, and [`McError::NonFinite`] for a draw whose maximum point error is not
/// finite.
///
/// # Examples
///
/// The adaptive procedure on the CPU evaluator, with the TX60 at five test points:
///
/// ```
/// use gpu_amcs_core::engine::{CpuEvaluator, Problem, Reference};
/// use gpu_amcs_core::mc::{run_amcs, AmcsOptions, Tolerance};
///
/// let model = gpu_amcs_core::kinematics::tx60();
/// let points = gpu_amcs_core::points::generate(&model, 5, &Default::default(), 1)?;
/// let problem = Problem::new(model, &points, &Reference::Calibrated, 2025)?;
/// let opts = AmcsOptions {
///     tolerance: Tolerance::Delta(0.01), // the numerical tolerance δ of GUM S1 §7.9, mm
///     batch_size: 10_000,
///     ..AmcsOptions::default()
/// };
/// let result = run_amcs(&mut CpuEvaluator::new(problem), &opts, None)?;
/// assert!(result.converged);
/// assert_eq!(result.draws % opts.batch_size, 0);
/// println!("w = {:.4} mm, R(0.2 mm) = {:.4}", result.estimate, result.reliability[1].r);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn run_amcs(
    eval: &mut dyn Evaluator,
    opts: &AmcsOptions,
    progress: Option<Progress>,
) -> Result<McResult, McError> {
    opts.check()?;
    let h_size = opts.batch_size as usize;
    let p = opts.settings.coverage_probability;
    let kind = opts.settings.interval;
    let mut acc = Accumulator::new(
        eval,
        opts.settings.clone(),
        opts.max_draws.min(opts.batch_size.saturating_mul(100)),
    )?;
    let mut est: [Vec<f64>; 4] = Default::default();
    let mut trace = Vec::new();
    // Running sums about the first batch's mean, for the pooled u(w) in ndig mode.
    let (mut shift, mut s1, mut s2, mut n) = (0.0, 0.0, 0.0, 0.0);
    let mut converged = false;
    let mut delta;
    loop {
        let batch = acc.add_batch(h_size)?;
        let e = batch_estimates(batch, p, kind);
        if est[0].is_empty() {
            shift = e[0];
        }
        for x in batch {
            s1 += x - shift;
            s2 += (x - shift) * (x - shift);
        }
        n += batch.len() as f64;
        for k in 0..4 {
            est[k].push(e[k]);
        }
        let h = est[0].len();
        delta = match opts.tolerance {
            Tolerance::Delta(d) => d,
            Tolerance::Ndig(nd) => {
                delta_from_ndig(((s2 - s1 * s1 / n) / (n - 1.0)).max(0.0).sqrt(), nd)
            }
        };
        let fluct: [f64; 4] = if h >= 2 {
            std::array::from_fn(|k| 2.0 * spread(&est[k]))
        } else {
            [f64::NAN; 4]
        };
        trace.push(BatchTrace {
            h,
            draws: (h * h_size) as u64,
            mean: e[0],
            std_uncertainty: e[1],
            low: e[2],
            high: e[3],
            fluctuation: fluct,
            delta,
        });
        if let Some(cb) = progress {
            cb((h * h_size) as u64, opts.max_draws);
        }
        if h >= 2 && fluct.iter().all(|f| *f <= delta) {
            converged = true;
            break;
        }
        if ((h + 1) * h_size) as u64 > opts.max_draws {
            break;
        }
    }
    let mut result = acc.finish(Method::Amcs, opts.batch_size, converged, Some(delta), trace);
    if let Tolerance::Ndig(n) = opts.tolerance {
        result.ndig = Some(n);
    }
    Ok(result)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ndig_delta() {
        // GUM S1 §7.9.2 style: u = 0.0712, ndig = 2 → c = 71, l = −3, δ = 0.0005.
        assert!((delta_from_ndig(0.0712, 2) - 0.0005).abs() < 1e-15);
        assert!((delta_from_ndig(2.0, 2) - 0.05).abs() < 1e-15);
        assert!((delta_from_ndig(9.99, 1) - 0.5).abs() < 1e-15);
    }

    #[test]
    fn spread_formula() {
        // values 1,2,3: mean 2, Σ = 2, h(h−1) = 6 → √(1/3)
        assert!((spread(&[1.0, 2.0, 3.0]) - (1.0f64 / 3.0).sqrt()).abs() < 1e-15);
    }
}
