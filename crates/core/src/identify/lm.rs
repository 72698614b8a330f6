//! A general Levenberg–Marquardt least-squares solver, shared by the circle fits
//! ([`super::circle`]) and the whole-chain refinement ([`super::refine`]).
//!
//! The state is any cloneable value updated through a local parametrisation `apply(state, δ)`, so
//! rotations and unit vectors stay on their manifolds; the Jacobian is taken by central
//! differences with one step per component of `δ`, its columns in parallel for large problems
//! (the same arithmetic per column, so the same bits with any thread count).

use nalgebra::{DMatrix, DVector};

/// Jacobians with at least this many entries are taken column-parallel.
const PARALLEL_SIZE: usize = 20_000;

/// Levenberg–Marquardt with a central-difference Jacobian over a local update `apply(state, δ)`.
pub(crate) fn levenberg_marquardt<S: Clone + Sync>(
    seed: S,
    steps: &[f64],
    apply: impl Fn(&S, &[f64]) -> S + Sync,
    residuals: impl Fn(&S) -> Vec<f64> + Sync,
) -> S {
    let np = steps.len();
    let cost = |r: &[f64]| r.iter().map(|v| v * v).sum::<f64>();
    let mut state = seed;
    let mut r0 = residuals(&state);
    let mut c0 = cost(&r0);
    let mut lambda = 1e-6;
    let zero = vec![0.0; np];
    for _ in 0..200 {
        let m = r0.len();
        let column = |col: usize| -> Vec<f64> {
            let h = steps[col];
            let mut d = zero.clone();
            d[col] = h;
            let rp = residuals(&apply(&state, &d));
            d[col] = -h;
            let rm = residuals(&apply(&state, &d));
            (0..m).map(|row| (rp[row] - rm[row]) / (2.0 * h)).collect()
        };
        let cols: Vec<Vec<f64>> = if m * np >= PARALLEL_SIZE {
            use rayon::prelude::*;
            (0..np).into_par_iter().map(column).collect()
        } else {
            (0..np).map(column).collect()
        };
        let j = DMatrix::<f64>::from_fn(m, np, |row, col| cols[col][row]);
        let r = DVector::from_column_slice(&r0);
        let jtj = j.transpose() * &j;
        let jtr = j.transpose() * r;
        let mut improved = false;
        while lambda < 1e12 {
            let mut a = jtj.clone();
            for i in 0..np {
                a[(i, i)] += lambda * jtj[(i, i)].max(1e-30);
            }
            let Some(delta) = a.cholesky().map(|ch| ch.solve(&(-&jtr))) else {
                lambda *= 10.0;
                continue;
            };
            let cand = apply(&state, delta.as_slice());
            let rc = residuals(&cand);
            let cc = cost(&rc);
            if cc.is_finite() && cc < c0 {
                let rel = (c0 - cc) / c0.max(1e-300);
                state = cand;
                r0 = rc;
                c0 = cc;
                lambda = (lambda / 10.0).max(1e-12);
                improved = true;
                if rel < 1e-14 {
                    return state;
                }
                break;
            }
            lambda *= 10.0;
        }
        if !improved || c0 == 0.0 {
            break;
        }
    }
    state
}
