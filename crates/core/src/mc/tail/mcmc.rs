//! The Markov chains of a subset level: adaptive conditional sampling and modified Metropolis
//! (see the module docs of `crate::mc::tail`).

use super::space::Model;
use super::subset::Level;
use super::{ChainProposal, TailError, TailOptions, TAIL_STREAM};

/// Target acceptance rate of [`ChainProposal::AdaptiveConditional`] (Papaioannou et al. 2015
/// §4.2, after the optimal rate of random-walk proposals in one dimension).
pub const TARGET_ACCEPTANCE: f64 = 0.44;

/// Initial scale `λ` of [`ChainProposal::AdaptiveConditional`] at the first Markov level
/// (Papaioannou et al. 2015); later levels start from the previous level's last `λ`.
pub const INITIAL_SCALE: f64 = 0.6;

/// The proposal of one Markov step of every component of one chain.
enum Step {
    /// Modified Metropolis with spread `s`.
    Metropolis(f64),
    /// Conditional sampling with `σ_k` and `ρ_k = √(1 − σ_k²)` per component.
    Conditional(Vec<(f64, f64)>),
}

impl Step {
    /// Writes the candidate from `x` with the normals `eps` and the uniforms `unif` into `row`;
    /// false when modified Metropolis rejected every component (the chain stays without an
    /// evaluation).
    fn candidate(&self, x: &[f64], eps: &[f64], unif: &[f64], row: &mut Vec<f64>) -> bool {
        row.clear();
        match self {
            Step::Metropolis(s) => {
                let mut changed = false;
                for c in 0..x.len() {
                    let xi = x[c] + s * eps[c];
                    let ratio = (0.5 * (x[c] * x[c] - xi * xi)).exp();
                    if unif[c] < ratio {
                        changed = true;
                        row.push(xi);
                    } else {
                        row.push(x[c]);
                    }
                }
                changed
            }
            Step::Conditional(sr) => {
                row.extend(
                    x.iter()
                        .zip(eps)
                        .zip(sr)
                        .map(|((x, e), (s, r))| r * x + s * e),
                );
                true
            }
        }
    }
}

/// The per-component spread `σ̂_k` of the seed rows `seeds` of `u` (`d` columns); 1 (the
/// unconditional spread) for a single seed, which has none.
fn seed_spread(u: &[f64], seeds: &[usize], d: usize) -> Vec<f64> {
    if seeds.len() < 2 {
        return vec![1.0; d];
    }
    let n = seeds.len() as f64;
    (0..d)
        .map(|c| {
            let mean = seeds.iter().map(|&i| u[i * d + c]).sum::<f64>() / n;
            let ss = seeds
                .iter()
                .map(|&i| (u[i * d + c] - mean).powi(2))
                .sum::<f64>();
            (ss / (n - 1.0)).sqrt()
        })
        .collect()
}

/// The Markov chains of level `j`, seeded by the rows `seeds` of `prev`, conditioned on
/// `w ≥ b`; returns the level and the number of moves. `scale` is the adaptive `λ` of
/// [`ChainProposal::AdaptiveConditional`], carried from level to level.
///
/// All chains take step `t` together (one evaluator batch). With the adaptive proposal every
/// chain uses the same `λ_t` at step `t`, and after the step `λ_{t+1} = λ_t exp((â_t − a*)/√t)`
/// from the step's acceptance rate `â_t` over the chains (Papaioannou et al. 2015 adapt after
/// groups of chains; here the groups are the steps, which keeps the batches `N_c` rows large).
#[allow(clippy::too_many_arguments)]
pub(super) fn mcmc_level(
    m: &mut Model,
    opts: &TailOptions,
    prev: &Level,
    seeds: &[usize],
    b: f64,
    j: usize,
    hi: u64,
    nb: u32,
    scale: &mut f64,
) -> Result<(Level, usize), TailError> {
    let (n, nc, d) = (prev.w.len(), seeds.len(), m.space.dim());
    let ns = n / nc;
    let stream = TAIL_STREAM + j as u32;
    let spread = seed_spread(&prev.u, seeds, d);
    let mut u = vec![0.0; n * d];
    let mut w = vec![0.0; n];
    for (k, &i) in seeds.iter().enumerate() {
        u[k * ns * d..][..d].copy_from_slice(&prev.u[i * d..][..d]);
        w[k * ns] = prev.w[i];
    }
    let (mut eps, mut unif) = (vec![0.0; d], vec![0.0; d]);
    let mut cand = Vec::with_capacity(nc * d);
    let mut row = Vec::with_capacity(d);
    let mut moved = Vec::with_capacity(nc);
    let mut wc = Vec::with_capacity(nc);
    let mut accepted = 0;
    for t in 1..ns {
        let step = match opts.proposal {
            ChainProposal::ModifiedMetropolis => Step::Metropolis(opts.proposal_spread),
            ChainProposal::AdaptiveConditional => Step::Conditional(
                spread
                    .iter()
                    .map(|s| {
                        let sigma = (*scale * s).min(1.0);
                        (sigma, (1.0 - sigma * sigma).sqrt())
                    })
                    .collect(),
            ),
        };
        cand.clear();
        moved.clear();
        for k in 0..nc {
            let (cur, dst) = (k * ns + t - 1, k * ns + t);
            let state = hi | dst as u64;
            m.normals(state, stream, 0, &mut eps);
            if matches!(step, Step::Metropolis(_)) {
                m.uniforms(state, stream, nb, &mut unif);
            }
            if step.candidate(&u[cur * d..][..d], &eps, &unif, &mut row) {
                cand.extend_from_slice(&row);
                moved.push(k);
            }
            // Start from the current state; overwritten below when the candidate is accepted.
            u.copy_within(cur * d..(cur + 1) * d, dst * d);
            w[dst] = w[cur];
        }
        wc.resize(moved.len(), 0.0);
        m.eval_u(&cand, &mut wc)?;
        let mut step_accepted = 0;
        for (x, &k) in moved.iter().enumerate() {
            if wc[x] >= b {
                let dst = k * ns + t;
                u[dst * d..][..d].copy_from_slice(&cand[x * d..][..d]);
                w[dst] = wc[x];
                step_accepted += 1;
            }
        }
        accepted += step_accepted;
        if matches!(step, Step::Conditional(_)) {
            let rate = step_accepted as f64 / nc as f64;
            *scale *= ((rate - TARGET_ACCEPTANCE) / (t as f64).sqrt()).exp();
        }
    }
    Ok((
        Level {
            u,
            w,
            chains: nc,
            lower: Some(b),
        },
        accepted,
    ))
}
