//! The search for a plan's design: greedy D-optimal (rank-3 updates of the inverse), then the
//! exchange on the task's own figure with common random numbers (see the module docs of
//! [`super`]).

use super::geometry::Geometry;
use super::{PlanError, PlanOptions, SearchTrace};
use crate::kinematics::Layout;
use nalgebra::{Cholesky, DMatrix, SymmetricEigen};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

/// Swaps per design pose judged by q95 after the screen.
pub(super) const JUDGED: usize = 8;

/// Greedy D-optimal order of `n` poses out of `pool` (indices into the geometry's candidates),
/// starting from `start` (may be empty); `tick` is told the share of the poses chosen.
pub(super) fn greedy(
    g: &Geometry,
    pool: &[usize],
    start: &[usize],
    n: usize,
    tick: &dyn Fn(f64),
) -> Vec<usize> {
    let p = g.p();
    // A tiny ridge makes the empty design invertible; it is far below one pose's information.
    let mut m = DMatrix::<f64>::identity(p, p) * 1e-9;
    for &i in start {
        m += &g.info[i];
    }
    let mut pinv = match Cholesky::new(m) {
        Some(c) => c.inverse(),
        None => return start.to_vec(),
    };
    let mut chosen: Vec<usize> = start.to_vec();
    let mut used = vec![false; g.cand.len()];
    for &i in start {
        used[i] = true;
    }
    while chosen.len() < n {
        let best = pool
            .par_iter()
            .filter(|&&c| !used[c])
            .map(|&c| {
                let j = &g.cand[c];
                let s = DMatrix::<f64>::identity(3, 3) + j * &pinv * j.transpose();
                (s.determinant().max(f64::MIN_POSITIVE).ln(), c)
            })
            .max_by(|a, b| a.0.total_cmp(&b.0).then(b.1.cmp(&a.1)));
        let Some((_, c)) = best else {
            break;
        };
        let j = &g.cand[c];
        let pj = &pinv * j.transpose();
        let s = DMatrix::<f64>::identity(3, 3) + j * &pj;
        if let Some(si) = s.try_inverse() {
            pinv -= &pj * si * pj.transpose();
        }
        used[c] = true;
        chosen.push(c);
        tick(chosen.len() as f64 / n.max(1) as f64);
    }
    chosen
}

/// The search's first step: the greedy D-optimal design of `poses` poses out of every
/// candidate, and its q95 (units of σ); `tick` is told the share of the poses chosen.
///
/// # Errors
///
/// [`PlanError::NotIdentifiable`] when that design leaves the information singular, or when
/// some inputs (named from `free` in `lay`'s measured inputs) move the target together.
pub(super) fn initial_design(
    g: &Geometry,
    poses: usize,
    free: &[usize],
    lay: Layout,
    tick: &dyn Fn(f64),
) -> Result<(Vec<usize>, f64), PlanError> {
    let p = g.p();
    let all: Vec<usize> = (0..g.cand.len()).collect();
    let dopt = greedy(g, &all, &[], poses, tick);
    let m = g.information(&dopt);
    if dopt.len() < poses || Cholesky::new(m.clone()).is_none() {
        return Err(PlanError::NotIdentifiable(format!(
            "{} poses chosen from {} candidates leave the {p} inputs' information singular",
            dopt.len(),
            g.cand.len()
        )));
    }
    check_separated(&m, free, lay)?;
    let greedy_q95 = g.q95(&m);
    Ok((dopt, greedy_q95))
}

/// Directions the best design `m` still barely sees: inputs the candidates cannot separate.
///
/// # Errors
///
/// [`PlanError::NotIdentifiable`] naming the inputs of the direction `m` barely sees, when its
/// smallest eigenvalue is below 1e-12 of its largest.
fn check_separated(m: &DMatrix<f64>, free: &[usize], lay: Layout) -> Result<(), PlanError> {
    let eig = SymmetricEigen::new(m.clone());
    let top = eig.eigenvalues.max();
    if let Some((k, lo)) = eig
        .eigenvalues
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))
        .filter(|(_, lo)| **lo < top * 1e-12)
    {
        let v = eig.eigenvectors.column(k);
        let mut names: Vec<(f64, String)> = free
            .iter()
            .enumerate()
            .map(|(a, &i)| (v[a].abs(), lay.measured().name(i)))
            .filter(|(x, _)| *x > 0.1)
            .collect();
        names.sort_by(|a, b| b.0.total_cmp(&a.0));
        return Err(PlanError::NotIdentifiable(format!(
            "{} move the target together (condition {:.1e}): this target does not separate them \
             (one on the flange origin or on the last joint's axis never does); place it elsewhere \
             on the flange",
            names
                .iter()
                .map(|n| n.1.as_str())
                .collect::<Vec<_>>()
                .join(", "),
            (top / lo.max(f64::MIN_POSITIVE)).sqrt()
        )));
    }
    Ok(())
}

/// The search's second step, the exchange on q95 with common random numbers, from the greedy
/// design `dopt` of q95 `greedy_q95` (units of σ): per design pose, `swaps` candidates are
/// screened by the task points' expected squared errors (smooth, no Monte Carlo noise), the best
/// few are judged by q95, and the best of those replaces the pose if q95 falls. Judging few swaps
/// on the noisy figure keeps the search from choosing designs for their luck on the draws.
/// Returns the design and how the search went; `tick` is told the share of the most passes
/// done (a search that ends early jumps to the end).
pub(super) fn exchange(
    g: &Geometry,
    dopt: &[usize],
    greedy_q95: f64,
    o: &PlanOptions,
    rng: &mut ChaCha8Rng,
    tick: &dyn Fn(f64),
) -> (Vec<usize>, SearchTrace) {
    let mut design = dopt.to_vec();
    let mut current = greedy_q95;
    let (mut passes, mut tried, mut accepted) = (0, 0, 0);
    for _ in 0..o.passes {
        passes += 1;
        let mut improved = false;
        for pos in 0..design.len() {
            let m = g.information(&design);
            let pool = swap_pool(g.cand.len(), &design, o.swaps, rng);
            let base = &m - &g.info[design[pos]];
            let (judged, best) = best_swap(g, &base, &pool);
            tried += judged;
            if let Some((q, c)) = best {
                if q < current * (1.0 - 1e-6) {
                    design[pos] = c;
                    current = q;
                    accepted += 1;
                    improved = true;
                }
            }
            tick(
                ((passes - 1) * design.len() + pos + 1) as f64
                    / (o.passes * design.len()).max(1) as f64,
            );
        }
        if !improved {
            break;
        }
    }
    let trace = SearchTrace {
        greedy_q95_mm: greedy_q95 * o.sigma_mm,
        passes,
        swaps_tried: tried,
        swaps_accepted: accepted,
    };
    (design, trace)
}

/// The candidates (of `candidates`) a swap of one pose of `design` may bring in: every one not
/// in the design when there are at most `swaps` of them, else `swaps` drawn from `rng` (repeats
/// allowed).
fn swap_pool(
    candidates: usize,
    design: &[usize],
    swaps: usize,
    rng: &mut ChaCha8Rng,
) -> Vec<usize> {
    let mut in_design = vec![false; candidates];
    for &i in design {
        in_design[i] = true;
    }
    let free_left = candidates - design.len();
    if swaps >= free_left {
        (0..candidates).filter(|&c| !in_design[c]).collect()
    } else {
        (0..swaps)
            .map(|_| loop {
                let c = rng.random_range(0..candidates);
                if !in_design[c] {
                    break c;
                }
            })
            .collect()
    }
}

/// The best swap into the design less one pose (information `base`) from `pool`: the
/// [`JUDGED`] best by the screen, judged by q95. Returns how many were judged and the best one's
/// q95 and candidate.
fn best_swap(g: &Geometry, base: &DMatrix<f64>, pool: &[usize]) -> (usize, Option<(f64, usize)>) {
    let mut screened: Vec<(f64, usize)> = pool
        .par_iter()
        .map(|&c| (g.screen(&(base + &g.info[c])), c))
        .collect();
    screened.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    screened.truncate(JUDGED);
    let best = screened
        .par_iter()
        .map(|&(_, c)| (g.q95(&(base + &g.info[c])), c))
        .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    (screened.len(), best)
}
