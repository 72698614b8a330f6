//! Leaving out a group of observations at a time: the check's cross-validation on data whose
//! points are not independent samples of the workspace (the points of one sweep lie on one
//! circle, each between measured neighbours).
//!
//! For a linear model fitted by least squares, the residuals of a group `G` predicted by the fit
//! without it are `(I − H_GG)⁻¹ r_G`, with `H_GG = J_G Σ J_Gᵀ` the group's block of the hat
//! matrix (`Σ = (JᵀJ)⁻¹`, whitened rows): exact for a linear model, the linearisation at the
//! solution otherwise, as the one-point form of the check.

use super::Observation;
use nalgebra::{DMatrix, DMatrixView, DVector, Matrix3, Vector3};
use std::ops::Range;

/// What `groups` leave out, in words: "each point" when empty.
pub(super) fn describe(groups: &[Range<usize>]) -> String {
    if groups.is_empty() {
        "each point".into()
    } else {
        format!("each of {} runs of consecutive points", groups.len())
    }
}

/// The RMS (3-D, per point, in the observations' units) of the residuals each group of
/// `groups` (ranges of observation indices) would show when left out, from the whitened
/// Jacobian rows `j` (3 per observation), the covariance `cov` of the free inputs and the
/// whitened residuals `r` (prior rows after the observations' are ignored). `None` when a
/// group's `I − H_GG` is singular (the rest cannot predict it).
pub(super) fn leave_group_out_rms(
    obs: &[Observation],
    j: &DMatrixView<'_, f64>,
    cov: &DMatrix<f64>,
    r: &[f64],
    groups: &[Range<usize>],
) -> Option<f64> {
    use rayon::prelude::*;
    let sums: Vec<Option<f64>> = groups
        .par_iter()
        .map(|g| {
            let rows = 3 * g.len();
            let jg = j.rows(3 * g.start, rows);
            let h = jg * cov * jg.transpose();
            let free = DMatrix::identity(rows, rows) - h;
            let z = DVector::from_column_slice(&r[3 * g.start..3 * g.end]);
            let e = free.lu().solve(&z)?;
            let mut sum = 0.0;
            for (k, o) in obs[g.clone()].iter().enumerate() {
                let w_inv: Matrix3<f64> = o.whiten.try_inverse()?;
                sum += (w_inv * Vector3::new(e[3 * k], e[3 * k + 1], e[3 * k + 2])).norm_squared();
            }
            sum.is_finite().then_some(sum)
        })
        .collect();
    let mut total = 0.0;
    for s in sums {
        total += s?;
    }
    let count: usize = groups.iter().map(|g| g.len()).sum();
    Some((total / count.max(1) as f64).sqrt())
}

/// What the cross-validated check beyond geometry leaves out at a time.
///
/// Each point alone tells how well a model predicts a new pose when the points are poses spread
/// over the workspace. The points of a sweep are not: each lies between measured neighbours on
/// the same circle, so a term that follows the sweep's own angle predicts it from them while it
/// may predict a pose elsewhere worse. Leaving out an arc of each sweep at a time asks the model
/// to extrapolate along the joint's turn instead.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum HeldOut {
    /// One point at a time.
    #[default]
    Points,
    /// Runs of consecutive points, by their lengths in the points' order (which must add up to
    /// the number of points; otherwise each point alone).
    Groups(Vec<usize>),
}

impl HeldOut {
    /// The groups as ranges of point indices for `count` points; empty for one point at a time.
    pub fn ranges(&self, count: usize) -> Vec<std::ops::Range<usize>> {
        match self {
            HeldOut::Groups(lengths) if lengths.iter().sum::<usize>() == count => {
                let mut start = 0;
                lengths
                    .iter()
                    .filter(|&&l| l > 0)
                    .map(|&l| {
                        start += l;
                        start - l..start
                    })
                    .collect()
            }
            _ => Vec::new(),
        }
    }

    /// Each sweep of `lengths` points cut into `arcs` arcs of consecutive points (as equal as
    /// the count allows).
    pub fn sweep_arcs(lengths: &[usize], arcs: usize) -> HeldOut {
        let arcs = arcs.max(1);
        HeldOut::Groups(
            lengths
                .iter()
                .flat_map(|&l| {
                    let k = arcs.min(l.max(1));
                    (0..k).map(move |a| (a + 1) * l / k - a * l / k)
                })
                .filter(|&l| l > 0)
                .collect(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::Joints;
    use rand::{Rng, SeedableRng};

    /// The formula against refitting without each group, for a linear model (where it is exact):
    /// whitened rows with a per-point scale, groups of 1 to 7 points.
    #[test]
    fn leaving_a_group_out_equals_refitting_without_it() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let (points, p) = (40, 6);
        let scale: Vec<f64> = (0..points).map(|_| rng.random_range(0.5..2.0)).collect();
        let x = DMatrix::from_fn(3 * points, p, |_, _| rng.random_range(-1.0..1.0));
        let y = DVector::from_fn(3 * points, |_, _| rng.random_range(-1.0..1.0));
        // whitened rows: W = diag(s) per point
        let w = DMatrix::from_fn(3 * points, 3 * points, |r, c| {
            if r == c {
                scale[r / 3]
            } else {
                0.0
            }
        });
        let (j, yw) = (&w * &x, &w * &y);
        let cov = (j.transpose() * &j).try_inverse().unwrap();
        let beta = &cov * j.transpose() * &yw;
        let r: Vec<f64> = (&j * &beta - &yw).iter().copied().collect();
        let obs: Vec<Observation> = (0..points)
            .map(|i| Observation {
                q: Joints::from_fn(6, |_| 0.0),
                p: [0.0; 3],
                whiten: Matrix3::identity() * scale[i],
                payload_kg: 0.0,
                target: 0,
                sides: None,
            })
            .collect();
        let held = HeldOut::Groups(vec![1, 7, 4, 4, 3, 6, 5, 2, 8]);
        let groups = held.ranges(points);
        assert_eq!(groups.len(), 9);
        let rms = leave_group_out_rms(&obs, &j.rows(0, 3 * points), &cov, &r, &groups).unwrap();
        // refit without each group, predict it, in the data's own units (unwhitened)
        let mut sum = 0.0;
        for g in &groups {
            let keep: Vec<usize> = (0..3 * points)
                .filter(|row| !(3 * g.start..3 * g.end).contains(row))
                .collect();
            let jk = j.select_rows(&keep);
            let yk = yw.select_rows(&keep);
            let b = (jk.transpose() * &jk).try_inverse().unwrap() * jk.transpose() * yk;
            for row in 3 * g.start..3 * g.end {
                let e = (x.row(row) * &b)[(0, 0)] - y[row];
                sum += e * e;
            }
        }
        let refit = (sum / points as f64).sqrt();
        assert!(
            (rms - refit).abs() < 1e-12 * refit,
            "formula {rms} against refitting {refit}"
        );
        // each point alone is a different (smaller) figure: the groups matter
        let single = HeldOut::Groups(vec![1; points]).ranges(points);
        let one = leave_group_out_rms(&obs, &j.rows(0, 3 * points), &cov, &r, &single).unwrap();
        assert!(one < rms, "one point at a time {one} against groups {rms}");
    }

    #[test]
    fn sweeps_are_cut_into_arcs_of_consecutive_points() {
        assert_eq!(
            HeldOut::sweep_arcs(&[10, 2, 0, 7], 3),
            HeldOut::Groups(vec![3, 3, 4, 1, 1, 2, 2, 3])
        );
        let ranges = HeldOut::sweep_arcs(&[10, 2, 0, 7], 3).ranges(19);
        assert_eq!(ranges.first(), Some(&(0..3)));
        assert_eq!(ranges.last(), Some(&(16..19)));
        // lengths that do not add up to the points: each point alone
        assert!(HeldOut::Groups(vec![3, 3]).ranges(7).is_empty());
        assert!(HeldOut::Points.ranges(7).is_empty());
    }
}
