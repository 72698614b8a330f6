//! Crude Monte Carlo of the tail probabilities ([`super::TailMethod::MonteCarlo`]), for
//! comparison with subset simulation.

use super::space::Model;
use super::{TailError, TailEstimate, TailOptions, TailOutcome};

/// Crude Monte Carlo on the counter draws `0, 1, …`.
pub(super) fn crude_mc(
    m: &mut Model,
    opts: &TailOptions,
) -> Result<(TailOutcome, Vec<TailEstimate>), TailError> {
    let ls = &opts.thresholds;
    let mut counts = vec![0u64; ls.len()];
    let mut w = vec![0.0; opts.batch_size];
    let cov = |c: u64, n: u64| {
        let p = c as f64 / n as f64;
        (c > 0).then(|| ((1.0 - p) / c as f64).sqrt())
    };
    let outcome = loop {
        let n = m.evaluations;
        let reached = n > 0
            && counts
                .iter()
                .all(|&c| cov(c, n).is_some_and(|d| d <= opts.target_cov));
        if reached {
            break TailOutcome::TargetReached;
        }
        if n >= opts.max_evaluations {
            break TailOutcome::EvaluationCapReached;
        }
        let k = (opts.max_evaluations - n).min(opts.batch_size as u64) as usize;
        m.eval.evaluate(n, &mut w[..k], None)?;
        m.account(&w[..k])?;
        for (c, &l) in counts.iter_mut().zip(ls) {
            *c += w[..k].iter().filter(|&&v| v >= l).count() as u64;
        }
    };
    let n = m.evaluations;
    let est = counts
        .iter()
        .zip(ls)
        .map(|(&c, &l)| TailEstimate::new(l, c as f64 / n as f64, cov(c, n), cov(c, n)))
        .collect();
    Ok((outcome, est))
}
