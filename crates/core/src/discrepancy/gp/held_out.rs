//! What a fitted process leaves at poses it did not see: cross-validation with refitted
//! hyperparameters for few poses, the closed-form leave-out for many.
//!
//! Poses that are not independent samples of the workspace (the points of one sweep, each
//! between measured neighbours on one circle) are left out in groups: a cross-validation fold
//! then holds whole groups, and the closed form leaves a group `G` out at a time. For `G`'s
//! training rows `R`, with `A = K_y⁻¹ V` and `C = ([K_y⁻¹]_RR)⁻¹`, what the process without `G`
//! leaves of `V` there is `C A_R` and its covariance `C`; elsewhere in `G` the process without
//! `G` has the weights `A − [K_y⁻¹]_{·R} C A_R` and `K⁻¹` less `[K_y⁻¹]_{·R} C [K_y⁻¹]_{R·}`
//! (the inverse of a principal block by the partitioned inverse). One point per group is the
//! one-point form `[K_y⁻¹ V]_i / [K_y⁻¹]_ii`.

use super::{fit, kernel_column, predictive_sd, GpError, GpFit, CROSS_VALIDATION_LIMIT, FOLDS};
use nalgebra::{DMatrix, Vector3};
use rand::{Rng, SeedableRng};
use std::ops::Range;

/// Held-out figures of a process: per pose, what it leaves of each set of values and its
/// predictive σ there.
#[derive(Clone, Debug)]
pub struct HeldOut {
    /// Per set of values, per pose: the value minus the held-out prediction, mm.
    pub residuals: Vec<Vec<Vector3<f64>>>,
    /// Per pose, the predictive σ per coordinate of the process that did not see it, mm.
    pub sigmas: Vec<f64>,
    /// How: [`CROSS_VALIDATION`], [`LEAVE_ONE_OUT`] or their forms by groups.
    pub method: &'static str,
}

/// The method of few poses, one at a time.
pub const CROSS_VALIDATION: &str = "5-fold cross-validation";
/// The method of many poses, one at a time.
pub const LEAVE_ONE_OUT: &str = "leave-one-out";
/// The method of few poses in groups.
pub const CROSS_VALIDATION_GROUPS: &str = "5-fold cross-validation by runs of consecutive points";
/// The method of many poses in groups.
pub const LEAVE_GROUP_OUT: &str = "leaving out each run of consecutive points";

/// What a process fitted to `targets` over `configs` leaves of each of `values` at poses it did
/// not see: [`FOLDS`]-fold cross-validation with refitted hyperparameters up to
/// [`CROSS_VALIDATION_LIMIT`] poses, else the closed form at `full` (the process fitted to all
/// poses). With `groups` (ranges of pose indices; a pose in none is a group of its own) each
/// group is left out whole; empty: each pose alone.
///
/// # Errors
///
/// A fold's fit failing ([`fit`]).
pub fn held_out(
    full: &GpFit,
    configs: &[Vec<f64>],
    targets: &[Vector3<f64>],
    values: &[&[Vector3<f64>]],
    groups: &[Range<usize>],
    seed: u64,
) -> Result<HeldOut, GpError> {
    let n = configs.len();
    let units = units(n, groups);
    let grouped = units.iter().any(|u| u.len() > 1);
    if n > CROSS_VALIDATION_LIMIT {
        if !grouped {
            return Ok(HeldOut {
                residuals: values.iter().map(|v| full.loo(v)).collect(),
                sigmas: full.loo_sigmas(),
                method: LEAVE_ONE_OUT,
            });
        }
        return Ok(full.leave_groups_out(values, &units));
    }
    let mut residuals: Vec<Vec<Vector3<f64>>> = values.iter().map(|v| v.to_vec()).collect();
    let mut sigmas = vec![0.0; n];
    for (f, fold) in folds(units.len(), seed).iter().enumerate() {
        let held: Vec<usize> = fold
            .iter()
            .flat_map(|&k| units[k].iter().copied())
            .collect();
        if held.is_empty() {
            continue;
        }
        let mut is_held = vec![false; n];
        held.iter().for_each(|&i| is_held[i] = true);
        let train: Vec<usize> = (0..n).filter(|&i| !is_held[i]).collect();
        let pick = |v: &[Vector3<f64>]| train.iter().map(|&i| v[i]).collect::<Vec<_>>();
        let part = fit(
            &train
                .iter()
                .map(|&i| configs[i].clone())
                .collect::<Vec<_>>(),
            &pick(targets),
            seed.wrapping_add(f as u64 + 1),
        )?;
        for (k, v) in values.iter().enumerate() {
            let known = pick(v);
            for &i in &held {
                residuals[k][i] = v[i] - part.mean_of_values(&known, &configs[i]);
            }
        }
        for &i in &held {
            sigmas[i] = part.predictive_sigma(&configs[i]);
        }
    }
    Ok(HeldOut {
        residuals,
        sigmas,
        method: if grouped {
            CROSS_VALIDATION_GROUPS
        } else {
            CROSS_VALIDATION
        },
    })
}

/// The units (indices into `0..units`) of each of the [`FOLDS`] folds: a seeded shuffle cut
/// into runs as equal as the count allows.
fn folds(units: usize, seed: u64) -> Vec<Vec<usize>> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0xF01D_5EED);
    let mut order: Vec<usize> = (0..units).collect();
    for a in 0..units {
        let b = rng.random_range(a..units);
        order.swap(a, b);
    }
    (0..FOLDS)
        .map(|f| order[f * units / FOLDS..(f + 1) * units / FOLDS].to_vec())
        .collect()
}

/// The units left out together: each of `groups` (clipped to `0..n`, empty ones dropped) in
/// order, then every pose in none of them alone, in order.
fn units(n: usize, groups: &[Range<usize>]) -> Vec<Vec<usize>> {
    let mut covered = vec![false; n];
    let mut out: Vec<Vec<usize>> = Vec::new();
    for g in groups {
        let members: Vec<usize> = (g.start..g.end.min(n)).filter(|&i| !covered[i]).collect();
        members.iter().for_each(|&i| covered[i] = true);
        if !members.is_empty() {
            out.push(members);
        }
    }
    if out.is_empty() {
        return (0..n).map(|i| vec![i]).collect();
    }
    out.extend((0..n).filter(|&i| !covered[i]).map(|i| vec![i]));
    out
}

/// One pose of a group left out: its index, what the process without the group leaves of each
/// value set there, and its predictive σ.
type LeftAt = (usize, Vec<Vector3<f64>>, f64);

impl GpFit {
    /// The closed-form leave-out of each of `units` (pose indices; together every pose once):
    /// what the process conditioned on the other training poses leaves of each of `values`,
    /// and its predictive σ.
    fn leave_groups_out(&self, values: &[&[Vector3<f64>]], units: &[Vec<usize>]) -> HeldOut {
        use rayon::prelude::*;
        let n = self.configs.len();
        let t = self.training.len();
        let mut row_of = vec![None; n];
        for (r, &i) in self.training.iter().enumerate() {
            row_of[i] = Some(r);
        }
        let weights: Vec<DMatrix<f64>> = values
            .iter()
            .map(|v| &self.inverse * DMatrix::from_fn(t, 3, |r, c| v[self.training[r]][c]))
            .collect();
        let sf2 = self.signal_sigma * self.signal_sigma;
        let sw2 = self.white_sigma * self.white_sigma;
        let x = self.training_configs();
        // Per unit: per pose, (what it leaves of each value set, its σ).
        let per_unit: Vec<Vec<LeftAt>> = units
            .par_iter()
            .map(|unit| {
                let rows: Vec<usize> = unit.iter().filter_map(|&i| row_of[i]).collect();
                let block = DMatrix::from_fn(rows.len(), rows.len(), |a, b| {
                    self.inverse[(rows[a], rows[b])]
                });
                // C = ([K⁻¹]_RR)⁻¹; an empty R leaves the full process.
                let c = block
                    .clone()
                    .cholesky()
                    .map(|ch| ch.inverse())
                    .or_else(|| block.try_inverse())
                    .unwrap_or_else(|| DMatrix::zeros(rows.len(), rows.len()));
                let cols = DMatrix::from_fn(t, rows.len(), |r, b| self.inverse[(r, rows[b])]);
                let without: Vec<DMatrix<f64>> = weights
                    .iter()
                    .map(|a| {
                        let a_r = DMatrix::from_fn(rows.len(), 3, |b, k| a[(rows[b], k)]);
                        a - &cols * (&c * a_r)
                    })
                    .collect();
                unit.iter()
                    .map(|&i| {
                        let kq = kernel_column(&self.configs[i], &x, &self.length_scales, sf2);
                        let left: Vec<Vector3<f64>> = values
                            .iter()
                            .zip(&without)
                            .map(|(v, w)| v[i] - w.transpose() * &kq)
                            .map(|d| Vector3::new(d[0], d[1], d[2]))
                            .collect();
                        let sigma = match rows.iter().position(|&r| Some(r) == row_of[i]) {
                            Some(b) => c[(b, b)].max(0.0).sqrt(),
                            None => {
                                let p = cols.transpose() * &kq;
                                let explained = (kq.transpose() * &self.inverse * &kq)[(0, 0)]
                                    - (p.transpose() * &c * &p)[(0, 0)];
                                predictive_sd(sf2, sw2, explained)
                            }
                        };
                        (i, left, sigma)
                    })
                    .collect()
            })
            .collect();
        let mut residuals: Vec<Vec<Vector3<f64>>> = values.iter().map(|v| v.to_vec()).collect();
        let mut sigmas = vec![0.0; n];
        for (i, left, sigma) in per_unit.into_iter().flatten() {
            for (k, l) in left.into_iter().enumerate() {
                residuals[k][i] = l;
            }
            sigmas[i] = sigma;
        }
        HeldOut {
            residuals,
            sigmas,
            method: LEAVE_GROUP_OUT,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::condition_for_tests;
    use super::*;

    /// Poses along two "sweeps" (one joint turning at a time) and a few scattered ones, with a
    /// smooth field plus noise on them.
    fn data(n: usize) -> (Vec<Vec<f64>>, Vec<Vector3<f64>>) {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let configs: Vec<Vec<f64>> = (0..n)
            .map(|i| {
                let t = i as f64 / n as f64;
                match i % 3 {
                    0 => vec![2.0 * t, 0.3, -0.2],
                    1 => vec![0.1, 2.0 * t - 1.0, 0.4],
                    _ => (0..3).map(|_| rng.random_range(-1.5..1.5)).collect(),
                }
            })
            .collect();
        let targets = configs
            .iter()
            .map(|q| {
                Vector3::new(
                    (q[0] + 0.5 * q[1]).sin(),
                    q[2].cos() * q[1],
                    0.3 * q[0] * q[2],
                ) * 0.02
                    + Vector3::from_fn(|_, _| 0.002 * rng.random_range(-1.0..1.0))
            })
            .collect();
        (configs, targets)
    }

    /// The closed form against conditioning the process (same hyperparameters) on the poses
    /// outside each group: what it leaves of two value sets, and its σ, at every pose.
    #[test]
    fn leaving_a_group_out_equals_conditioning_without_it() {
        let (configs, targets) = data(48);
        let other: Vec<Vector3<f64>> = targets.iter().map(|v| v * -2.0 + Vector3::x()).collect();
        let theta = [
            0.7f64.ln(),
            0.9f64.ln(),
            1.2f64.ln(),
            0.02f64.ln(),
            0.003f64.ln(),
        ];
        let full = condition_for_tests(&configs, &targets, &theta);
        let groups = [0..10, 10..11, 20..35];
        let units = units(configs.len(), &groups);
        assert_eq!(units.len(), 3 + (48 - 26));
        let got = full.leave_groups_out(&[&targets, &other], &units);
        assert_eq!(got.method, LEAVE_GROUP_OUT);
        let mut worst: f64 = 0.0;
        for unit in &units {
            let rest: Vec<usize> = (0..48).filter(|i| !unit.contains(i)).collect();
            let part = condition_for_tests(
                &rest.iter().map(|&i| configs[i].clone()).collect::<Vec<_>>(),
                &rest.iter().map(|&i| targets[i]).collect::<Vec<_>>(),
                &theta,
            );
            for &i in unit {
                for (k, v) in [&targets, &other].iter().enumerate() {
                    let known: Vec<Vector3<f64>> = rest.iter().map(|&r| v[r]).collect();
                    let want = v[i] - part.mean_of_values(&known, &configs[i]);
                    worst = worst.max((got.residuals[k][i] - want).norm() / want.norm());
                }
                let s = part.predictive_sigma(&configs[i]);
                worst = worst.max((got.sigmas[i] - s).abs() / s);
            }
        }
        // The jitter 1e-10 σ_f² on the diagonal is left out of the predictive σ only.
        assert!(worst < 1e-7, "worst relative difference {worst:e}");
    }

    /// Groups of one pose are the one-point closed form.
    #[test]
    fn groups_of_one_are_leave_one_out() {
        let (configs, targets) = data(30);
        let theta = [0.0, 0.0, 0.0, 0.02f64.ln(), 0.003f64.ln()];
        let full = condition_for_tests(&configs, &targets, &theta);
        let got = full.leave_groups_out(&[&targets], &units(30, &[]));
        let (loo, sigmas) = (full.loo(&targets), full.loo_sigmas());
        for i in 0..30 {
            assert!((got.residuals[0][i] - loo[i]).norm() < 1e-9 * loo[i].norm());
            assert!((got.sigmas[i] - sigmas[i]).abs() < 1e-9 * sigmas[i]);
        }
    }

    /// Cross-validation by groups: each fold's process is fitted without whole groups, and
    /// what it leaves at a group's poses is that process's.
    #[test]
    fn folds_keep_groups_whole() {
        let (configs, targets) = data(60);
        let full = super::super::fit(&configs, &targets, 3).unwrap();
        let groups: Vec<Range<usize>> = (0..6).map(|g| 10 * g..10 * g + 10).collect();
        let got = held_out(&full, &configs, &targets, &[&targets], &groups, 3).unwrap();
        assert_eq!(got.method, CROSS_VALIDATION_GROUPS);
        let folds = folds(6, 3);
        let mut seen: Vec<usize> = folds.concat();
        seen.sort_unstable();
        assert_eq!(seen, (0..6).collect::<Vec<_>>());
        let (f, fold) = folds
            .iter()
            .enumerate()
            .find(|(_, f)| !f.is_empty())
            .unwrap();
        let held: Vec<usize> = fold.iter().flat_map(|&g| groups[g].clone()).collect();
        let rest: Vec<usize> = (0..60).filter(|i| !held.contains(i)).collect();
        let part = super::super::fit(
            &rest.iter().map(|&i| configs[i].clone()).collect::<Vec<_>>(),
            &rest.iter().map(|&i| targets[i]).collect::<Vec<_>>(),
            3u64.wrapping_add(f as u64 + 1),
        )
        .unwrap();
        let known: Vec<Vector3<f64>> = rest.iter().map(|&i| targets[i]).collect();
        for &i in &held {
            let want = targets[i] - part.mean_of_values(&known, &configs[i]);
            assert_eq!(got.residuals[0][i], want);
            assert_eq!(got.sigmas[i], part.predictive_sigma(&configs[i]));
        }
        // Without groups each pose is its own unit: the one-pose cross-validation.
        let alone = held_out(&full, &configs, &targets, &[&targets], &[], 3).unwrap();
        assert_eq!(alone.method, CROSS_VALIDATION);
        assert_ne!(alone.residuals[0], got.residuals[0]);
    }
}
