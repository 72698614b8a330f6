//! Which joint-error terms the data need (docs/METHOD.md §19): per joint the compliance and the
//! harmonic orders, dropped one at a time while Akaike's criterion falls.
//!
//! The fit with every term gives the Jacobian `J` of the whitened residuals (prior rows
//! included) and the residuals `r` at its solution. A model without the terms `D` is, to first
//! order, the least-squares solution from `r − J_D β_D` over the remaining columns `K`:
//! `r_K = (I − J_K (J_KᵀJ_K)⁻¹ J_Kᵀ)(r − J_D β_D)`, and its leave-one-out errors are
//! `W⁻¹ (I − H_ii)⁻¹ r_K,i` with the leverage blocks of `J_K` (the formula of [`super::loo_rms`]).
//! The coefficients enter the positions almost linearly (deflections of 1e-4 rad), so this is
//! the refit's to a few parts in 10⁴; each candidate costs one small solve instead of a fit.
//!
//! Backward elimination by Akaike's criterion, `AIC = χ² + 2k` (`k` the coefficients kept):
//! the residual sum of squares `S` (whitened) grows by `ΔS` when a term's `d` coefficients go;
//! in units of the residual variance of the fit with every term, `s² = S_all / (N − p_all)`
//! (`N` the equations, three a pose), the criterion changes by `χ² − 2d` with `χ² = ΔS / s²`.
//! Of the terms that can go (a compliance; a joint's highest harmonic order, so that the orders
//! a joint keeps are 1..m) the one that lowers the criterion most goes while one lowers it.
//! Against a test at 1 % (a term goes while `P(χ²_d ≥ χ²) ≥ 1 %`, so `χ²` below 6.6 or 9.2
//! rather than 2 or 4; docs/METHOD.md §19 has both measured): on 24 simulated TX60s with every
//! term the test dropped weak terms the robots have and left a held-out RMS 1.473× a geometric
//! robot's (Akaike 1.439×, every term kept 1.423×); on 24 with harmonics on J1–J3 only the test
//! kept exactly those on 22 and reached 1.243× (Akaike kept spurious wrist harmonics on 11 of
//! them: 1.310×; every term 1.423×). A term the robot lacks has `χ²` above `2d` in 14–16 %
//! of draws, so on a geometric robot forced through the fit (the check runs by default only on
//! a lack of fit) a few spurious terms stay. The leave-one-out RMS of each model is reported
//! beside.

use super::{Observation, PER_JOINT};
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use serde::Serialize;

/// A group of coefficients of one joint, kept or dropped together.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Term {
    /// The compliance `k`.
    Compliance,
    /// The first harmonic, `sin q, cos q`.
    FirstHarmonic,
    /// The second harmonic, `sin 2q, cos 2q`.
    SecondHarmonic,
}

impl Term {
    const ALL: [Term; 3] = [Term::Compliance, Term::FirstHarmonic, Term::SecondHarmonic];

    /// The term's coefficients' offsets within a joint's `k, a1, b1, a2, b2`.
    fn offsets(self) -> std::ops::Range<usize> {
        match self {
            Term::Compliance => 0..1,
            Term::FirstHarmonic => 1..3,
            Term::SecondHarmonic => 3..5,
        }
    }

    /// The term of coefficient offset `k` within a joint.
    fn of(k: usize) -> Term {
        match k {
            0 => Term::Compliance,
            1 | 2 => Term::FirstHarmonic,
            _ => Term::SecondHarmonic,
        }
    }

    /// Its name in reports.
    pub fn label(self) -> &'static str {
        match self {
            Term::Compliance => "compliance",
            Term::FirstHarmonic => "1st harmonic",
            Term::SecondHarmonic => "2nd harmonic",
        }
    }
}

/// A term's `χ²`, the change of Akaike's criterion without it, and the leave-one-out RMS of the
/// model without it (which model: [`TermSelection`] says).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct TermScore {
    /// The joint, 1-based.
    pub joint: usize,
    /// The term.
    pub term: Term,
    /// `χ²`: the growth of the residual sum of squares without the term, in units of the
    /// residual variance of the fit with every term.
    pub chi2: f64,
    /// The change of Akaike's criterion without the term, `χ² − 2d` (`d` its coefficients): the
    /// term that lowers it most goes while one lowers it.
    pub aic_change: f64,
    /// Leave-one-out RMS (3-D) without the term, mm.
    pub loo_rms_mm: f64,
}

/// Which terms the fit beyond geometry kept per joint, and why.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TermSelection {
    /// Whether the data chose them (`false`: the harmonic orders were set, and every joint
    /// whose torque varies has its compliance).
    pub by_data: bool,
    /// Per joint: the harmonic orders kept are 1 to this (0: none).
    pub harmonic_orders: Vec<u8>,
    /// Per joint: whether the compliance is fitted.
    pub compliance: Vec<bool>,
    /// Whether the terms were judged in a fit that also held a backlash gap per joint (the
    /// backlash checked on poses); the figures below are then of fits with the gaps.
    pub with_gaps: bool,
    /// Leave-one-out RMS (3-D) with every term that was a candidate, mm.
    pub loo_rms_all_mm: f64,
    /// The terms dropped, in the order they went, each with its `χ²` against the terms left
    /// before it went, and the leave-one-out RMS once it had gone (first order in the
    /// coefficients, at the fit with every term).
    pub dropped: Vec<TermScore>,
    /// The terms that could have gone next, each with its `χ²` (none lowering Akaike's
    /// criterion) and the leave-one-out RMS without it.
    pub kept: Vec<TermScore>,
}

impl TermSelection {
    /// The terms as fitted with orders set (or every candidate): no selection.
    pub(super) fn fixed(extras: &[usize], joints: usize, loo_rms_mm: f64) -> TermSelection {
        let (orders, compliance) = kept_terms(extras, joints);
        TermSelection {
            by_data: false,
            with_gaps: false,
            harmonic_orders: orders,
            compliance,
            loo_rms_all_mm: loo_rms_mm,
            dropped: Vec::new(),
            kept: Vec::new(),
        }
    }

    /// One line for the report.
    pub fn sentence(&self) -> String {
        let per_joint: Vec<String> = (0..self.harmonic_orders.len())
            .map(|j| {
                let h = match self.harmonic_orders[j] {
                    0 => "no harmonics".to_string(),
                    1 => "1st harmonic".to_string(),
                    m => format!("harmonics 1–{m}"),
                };
                let k = if self.compliance[j] {
                    ", compliance"
                } else {
                    ""
                };
                format!("J{} {h}{k}", j + 1)
            })
            .collect();
        if !self.by_data {
            return format!("terms as set: {}", per_joint.join("; "));
        }
        let list = |v: &[TermScore]| {
            v.iter()
                .map(|s| {
                    format!(
                        "J{} {} χ² {:.1}, ΔAIC {:+.1}, {:.4} mm without",
                        s.joint,
                        s.term.label(),
                        s.chi2,
                        s.aic_change,
                        s.loo_rms_mm
                    )
                })
                .collect::<Vec<_>>()
                .join(", ")
        };
        format!(
            "terms chosen by Akaike's criterion (a term goes while dropping it lowers χ² + 2·coefficients{}; leave-one-out RMS with all {:.4} mm): {}; dropped {}; kept {}",
            if self.with_gaps {
                ", judged with the backlash gaps in the fit"
            } else {
                ""
            },
            self.loo_rms_all_mm,
            per_joint.join("; "),
            if self.dropped.is_empty() {
                "none".to_string()
            } else {
                list(&self.dropped)
            },
            if self.kept.is_empty() {
                "none".to_string()
            } else {
                list(&self.kept)
            }
        )
    }
}

/// Per joint the highest harmonic order and whether the compliance is among the coefficient
/// indices `extras`.
fn kept_terms(extras: &[usize], joints: usize) -> (Vec<u8>, Vec<bool>) {
    let has = |j: usize, t: Term| t.offsets().any(|k| extras.contains(&(PER_JOINT * j + k)));
    (
        (0..joints)
            .map(|j| {
                if has(j, Term::SecondHarmonic) {
                    2
                } else {
                    u8::from(has(j, Term::FirstHarmonic))
                }
            })
            .collect(),
        (0..joints).map(|j| has(j, Term::Compliance)).collect(),
    )
}

/// The leave-one-out RMS (3-D, mm) of the least-squares solution over the columns of `jac`
/// (whitened residuals, the points' three rows first, then prior rows) whose residuals are `r`,
/// and the covariance of its inputs; `None` for a singular information matrix or leverage.
pub(super) fn loo_linear(
    obs: &[Observation],
    jac: &DMatrix<f64>,
    r: &[f64],
) -> Option<(f64, DMatrix<f64>)> {
    let cov = (jac.transpose() * jac).try_inverse()?;
    let mut sum = 0.0;
    for (i, o) in obs.iter().enumerate() {
        let ji = jac.rows(3 * i, 3);
        let hd = (ji * &cov) * ji.transpose();
        let h = Matrix3::from_fn(|a, b| hd[(a, b)]);
        let free_inv = (Matrix3::identity() - h).try_inverse()?;
        let w_inv = o.whiten.try_inverse()?;
        let z = Vector3::new(r[3 * i], r[3 * i + 1], r[3 * i + 2]);
        sum += (w_inv * free_inv * z).norm_squared();
    }
    Some(((sum / obs.len().max(1) as f64).sqrt(), cov))
}

/// The fit with every candidate term, to first order: its Jacobian over the free inputs (`geo`
/// geometric, then the coefficients `extras`), its residuals and the coefficients' values.
pub(super) struct Linearised<'a> {
    pub obs: &'a [Observation],
    pub jac: &'a DMatrix<f64>,
    pub r: &'a [f64],
    pub geo: usize,
    pub extras: &'a [usize],
    pub beta: &'a [f64],
}

impl Linearised<'_> {
    /// The residuals of the least-squares solution with only the coefficients `kept` (indices
    /// into `extras`), and the Jacobian's columns it has.
    fn solve(&self, kept: &[bool]) -> Option<(DVector<f64>, DMatrix<f64>)> {
        let mut r = DVector::from_column_slice(self.r);
        let mut cols: Vec<usize> = (0..self.geo).collect();
        for (k, &keep) in kept.iter().enumerate() {
            let c = self.geo + k;
            if keep {
                cols.push(c);
            } else {
                r -= self.jac.column(c) * self.beta[self.extras[k]];
            }
        }
        let jk = self.jac.select_columns(&cols);
        let delta = (jk.transpose() * &jk)
            .cholesky()?
            .solve(&(jk.transpose() * &r));
        Some((r - &jk * delta, jk))
    }

    /// The residual sum of squares (whitened, prior rows included) and the leave-one-out RMS
    /// with only the coefficients `kept`.
    fn score(&self, kept: &[bool]) -> Option<(f64, f64)> {
        let (r, jk) = self.solve(kept)?;
        let loo = loo_linear(self.obs, &jk, r.as_slice())?.0;
        Some((r.norm_squared(), loo))
    }

    /// Backward elimination over the terms of `joints` joints (module docs): the coefficients
    /// kept (a subset of `extras`) and the selection's report; `None` when a fit cannot be
    /// evaluated.
    pub(super) fn select(&self, joints: usize) -> Option<(Vec<usize>, TermSelection)> {
        let mut kept = vec![true; self.extras.len()];
        let term_of = |k: usize| {
            let i = self.extras[k];
            (i / PER_JOINT, Term::of(i % PER_JOINT))
        };
        let present = |kept: &[bool], j: usize, t: Term| {
            (0..kept.len()).any(|k| kept[k] && term_of(k) == (j, t))
        };
        let (mut rss, all) = self.score(&kept)?;
        let equations = 3 * self.obs.len();
        let s2 = rss
            / equations
                .saturating_sub(self.geo + self.extras.len())
                .max(1) as f64;
        let mut dropped = Vec::new();
        let last = loop {
            let mut scores = Vec::new();
            for j in 0..joints {
                for t in Term::ALL {
                    // A joint's first harmonic goes only after its second.
                    let nested =
                        t == Term::FirstHarmonic && present(&kept, j, Term::SecondHarmonic);
                    if !present(&kept, j, t) || nested {
                        continue;
                    }
                    let without: Vec<bool> = (0..kept.len())
                        .map(|k| kept[k] && term_of(k) != (j, t))
                        .collect();
                    let d = (0..kept.len())
                        .filter(|&k| kept[k] && term_of(k) == (j, t))
                        .count();
                    // The residual sum of squares decides; the leave-one-out RMS, which only
                    // the report shows, is computed below for the terms it lists (the same
                    // figures, at a fraction of the cost).
                    let r = self.solve(&without)?.0.norm_squared();
                    scores.push((
                        r,
                        without,
                        TermScore {
                            joint: j + 1,
                            term: t,
                            chi2: (r - rss) / s2,
                            aic_change: (r - rss) / s2 - 2.0 * d as f64,
                            loo_rms_mm: f64::NAN,
                        },
                    ));
                }
            }
            let best = scores
                .iter()
                .enumerate()
                .min_by(|a, b| a.1 .2.aic_change.total_cmp(&b.1 .2.aic_change))
                .map(|(k, _)| k);
            match best {
                Some(k) if scores[k].2.aic_change < 0.0 => {
                    let (r, without, mut b) = scores.swap_remove(k);
                    b.loo_rms_mm = self.score(&without)?.1;
                    kept = without;
                    rss = r;
                    dropped.push(b);
                }
                _ => {
                    break scores
                        .into_iter()
                        .map(|(_, without, mut b)| {
                            b.loo_rms_mm = self.score(&without)?.1;
                            Some(b)
                        })
                        .collect::<Option<Vec<_>>>()?
                }
            }
        };
        let extras: Vec<usize> = (0..kept.len())
            .filter(|&k| kept[k])
            .map(|k| self.extras[k])
            .collect();
        let (orders, compliance) = kept_terms(&extras, joints);
        Some((
            extras,
            TermSelection {
                by_data: true,
                with_gaps: false,
                harmonic_orders: orders,
                compliance,
                loo_rms_all_mm: all,
                dropped,
                kept: last,
            },
        ))
    }
}
