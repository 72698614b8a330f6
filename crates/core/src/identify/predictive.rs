//! Is the model's uncertainty honest against measurements it was not fitted to? The predictive
//! check of held-out data (docs/METHOD.md §18).
//!
//! For each measured pose the model predicts the distribution of the error a new measurement
//! shows, `e_j = |Δp_j(θ') + δ_j|`: the parameters' draws (with the placement in the measurement
//! frame) and the discrepancy term in its *measurement* use (noise kept), by the CPU
//! evaluator's counter draws. The check reports how often the predicted per-point 95 % bound
//! covers the observed error, and the probability integral transform `u = F_max(w_obs)` of the
//! largest observed error over random subsets of poses, the quantity a reliability R is
//! about: honest predictions give a coverage near 95 % and `u` uniform (mean ½, 1 % of subsets
//! at or above 0.99). The same figures without the term show what the parameters' uncertainty
//! alone would claim.

use super::validate::{point_errors_in, Measurement};
use super::{IdentifyError, Placement};
use crate::discrepancy::DiscrepancyUse;
use crate::engine::{CpuEvaluator, Evaluator, Frame, Problem, Reference};
use crate::kinematics::{Joints, RobotModel};
use rand::SeedableRng;
use serde::Serialize;

/// Per-point draws × points evaluated at most (memory: 8 bytes each, twice).
const MAX_CELLS: usize = 20_000_000;

/// Poses outside the bound the terminal paragraph names (the JSON has every pose).
const SHOWN_OUTSIDE: usize = 8;

/// The predictive figures of one kind of prediction.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Coverage {
    /// Fraction of poses whose observed error is at most the predicted per-point 95 % bound.
    pub coverage_95: f64,
    /// Mean PIT of the largest observed error over random subsets of poses (ideal 0.5).
    pub pit_max_mean: f64,
    /// Fraction of subsets with PIT ≥ 0.99 (ideal 0.01).
    pub pit_max_at_least_099: f64,
    /// Fraction of subsets with PIT ≥ 0.9 (ideal 0.1).
    pub pit_max_at_least_090: f64,
    /// Fraction of subsets with PIT ≤ 0.1 (ideal 0.1).
    pub pit_max_at_most_010: f64,
}

/// One held-out pose against its predicted error distribution.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PosePrediction {
    /// The pose's line in the measurement file.
    pub line: u64,
    /// Its observed error, mm.
    pub error_mm: f64,
    /// The predicted 95 % bound of its error, mm.
    pub bound_95_mm: f64,
    /// The share of predicted errors at most the observed one (its PIT: honest predictions
    /// give values spread evenly over 0–1; above 0.95 is outside the bound).
    pub pit: f64,
}

/// The predictive check of a model against held-out measurements.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PredictiveCheck {
    /// Poses.
    pub points: usize,
    /// RMS of the observed errors, mm.
    pub rms_mm: f64,
    /// Draws per pose.
    pub draws: usize,
    /// Poses per subset of the PIT of the maximum.
    pub subset: usize,
    /// Subsets drawn.
    pub subsets: usize,
    /// With the model's discrepancy term (measurement use); `None` when the model has none.
    pub with_term: Option<Coverage>,
    /// The parameters' uncertainty alone.
    pub parameters_only: Coverage,
    /// Each pose against the prediction with the discrepancy term (the parameters' alone for a
    /// model without one), in the order of the measurements.
    pub poses: Vec<PosePrediction>,
    /// Poses predicted at the centre of the backlash's gaps with the model's term for unknown
    /// sides (their sides not all recorded); 0 for a model without that term.
    pub at_centre: usize,
}

impl PredictiveCheck {
    /// One paragraph for the terminal.
    pub fn render(&self) -> String {
        let line = |c: &Coverage| {
            format!(
                "95 % bound covers {:.1} % of poses; PIT of the max over {} poses: mean {:.2}, {:.0} % ≥ 0.99, {:.0} % ≥ 0.9, {:.0} % ≤ 0.1",
                100.0 * c.coverage_95,
                self.subset,
                c.pit_max_mean,
                100.0 * c.pit_max_at_least_099,
                100.0 * c.pit_max_at_least_090,
                100.0 * c.pit_max_at_most_010
            )
        };
        let mut s = format!(
            "predictive check ({} poses, {} draws each, {} subsets; ideal: 95 %, PIT mean 0.50, 1 % ≥ 0.99):\n",
            self.points, self.draws, self.subsets
        );
        if let Some(c) = &self.with_term {
            s.push_str(&format!(
                "  with the discrepancy term (noise kept): {}\n",
                line(c)
            ));
        }
        s.push_str(&format!(
            "  parameters' uncertainty alone: {}\n",
            line(&self.parameters_only)
        ));
        if self.at_centre > 0 {
            s.push_str(&format!(
                "  {} of the {} poses without every backlash side recorded: predicted at the centre of the gaps, with the model's term for unknown sides\n",
                self.at_centre, self.points
            ));
        }
        let mut outside: Vec<&PosePrediction> = (self.poses.iter())
            .filter(|p| p.error_mm > p.bound_95_mm)
            .collect();
        if !outside.is_empty() {
            outside.sort_by(|a, b| b.pit.total_cmp(&a.pit).then(a.line.cmp(&b.line)));
            let shown: Vec<String> = (outside.iter().take(SHOWN_OUTSIDE))
                .map(|p| format!("{} ({:.3} > {:.3} mm)", p.line, p.error_mm, p.bound_95_mm))
                .collect();
            s.push_str(&format!(
                "  outside the 95 % bound{}: {} of {} poses, at line{} {}{}\n",
                if self.with_term.is_some() {
                    " with the term"
                } else {
                    ""
                },
                outside.len(),
                self.points,
                if outside.len() == 1 { "" } else { "s" },
                shown.join(", "),
                if outside.len() > SHOWN_OUTSIDE {
                    ", …"
                } else {
                    ""
                }
            ));
        }
        s
    }
}

/// The predictive check of `model` against `measurements` in `frame` (see the module text),
/// with `draws` draws (fewer when poses × draws would exceed 2·10⁷) and `seed`.
///
/// # Errors
///
/// [`IdentifyError::NoData`] for fewer than 2 measurements or a model whose problem cannot be
/// set up (joint limits, covariance), naming why.
pub fn predictive_check(
    model: &RobotModel,
    measurements: &[Measurement],
    frame: Placement,
    draws: usize,
    seed: u64,
) -> Result<PredictiveCheck, IdentifyError> {
    let n = measurements.len();
    if n < 2 {
        return Err(IdentifyError::NoData(
            "a predictive check needs at least 2 measurements".into(),
        ));
    }
    let observed = point_errors_in(model, measurements, frame);
    // Poses measured with a payload (a `payload_kg` column) are predicted with it, as their
    // observed errors are: one problem per payload, each drawing the same parameter draws
    // (keyed by the draw's index), its columns put back in the poses' order.
    // A model with a term for unknown sides predicts the poses whose sides are not all recorded
    // at the centre of the gaps with that term, the others with their sides: the problem puts
    // each point so (`Problem::set_known_sides`).
    let centre = model.sides_unknown_term().is_some();
    // the payload each group is predicted at, and its poses
    let mut groups: Vec<(Option<f64>, Vec<usize>)> = Vec::new();
    for (i, m) in measurements.iter().enumerate() {
        let payload = m
            .payload_kg
            .filter(|&kg| model.knowing_payload(kg).is_some());
        match groups.iter_mut().find(|(k, _)| *k == payload) {
            Some((_, v)) => v.push(i),
            None => groups.push((payload, vec![i])),
        }
    }
    let at_centre = if centre {
        (measurements.iter())
            .filter(|m| !m.sides.is_some_and(|s| model.sides_complete(&s)))
            .count()
    } else {
        0
    };
    let problems: Vec<(Problem, Vec<usize>)> = groups
        .into_iter()
        .map(|(kg, idx)| {
            let m = kg
                .and_then(|kg| model.knowing_payload(kg))
                .unwrap_or_else(|| model.clone());
            let q: Vec<_> = idx.iter().map(|&i| measurements[i].q_deg).collect();
            let fail = |e: crate::engine::ProblemError| {
                IdentifyError::NoData(format!("predictive check: {e}"))
            };
            let mut p = Problem::new(m, &q, &Reference::Calibrated, seed).map_err(fail)?;
            // Recorded approach sides fix a model's backlash at those poses, in the draws and
            // in the prediction (as `point_errors_in` predicts them).
            let sides: Vec<Joints> = (idx.iter())
                .map(|&i| {
                    (measurements[i].sides).unwrap_or_else(|| Joints::filled(q[0].len(), 0.0))
                })
                .collect();
            if (p.sided.is_some() || p.joint_errors.as_ref().is_some_and(|t| t.backlash))
                && sides.iter().any(|s| s.iter().any(|&v| v != 0.0))
            {
                p.predict_known_sides(&sides).map_err(fail)?;
            }
            let p = p.in_frame(match frame {
                Placement::Identify => Frame::Measurement,
                Placement::Known => Frame::Base,
            });
            Ok((p, idx))
        })
        .collect::<Result<_, IdentifyError>>()?;
    let draws = draws.clamp(100, (MAX_CELLS / n).max(100));
    let subset = 20.min(n);
    let subsets = 1000;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x005E_ED0F_C0DE);
    let picks = crate::discrepancy::random_subsets(n, subset, subsets, &mut rng);
    let coverage = |term: bool| -> Result<(Coverage, Vec<PosePrediction>), IdentifyError> {
        let mut e = vec![0.0; draws * n];
        for (p, idx) in &problems {
            let p = if term {
                p.clone().with_discrepancy_use(DiscrepancyUse::Measured)
            } else {
                p.clone().without_discrepancy()
            };
            let k = idx.len();
            let mut ev = CpuEvaluator::new(p);
            let mut w = vec![0.0; draws];
            let mut part = vec![0.0; draws * k];
            ev.evaluate(0, &mut w, Some(&mut part))
                .map_err(|e| IdentifyError::NoData(format!("predictive check: {e}")))?;
            for d in 0..draws {
                for (c, &i) in idx.iter().enumerate() {
                    e[d * n + i] = part[d * k + c];
                }
            }
        }
        let (c, per_pose) = figures(&e, draws, &observed, &picks);
        let poses = (measurements.iter().zip(&observed).zip(per_pose))
            .map(|((m, &error_mm), (bound_95_mm, pit))| PosePrediction {
                line: m.line,
                error_mm,
                bound_95_mm,
                pit,
            })
            .collect();
        Ok((c, poses))
    };
    let with_term = match model.discrepancy.is_some() || centre {
        true => Some(coverage(true)?),
        false => None,
    };
    let (parameters_only, alone) = coverage(false)?;
    let (with_term, poses) = match with_term {
        Some((c, p)) => (Some(c), p),
        None => (None, alone),
    };
    let rms_mm = (observed.iter().map(|v| v * v).sum::<f64>() / n as f64).sqrt();
    Ok(PredictiveCheck {
        at_centre,
        points: n,
        rms_mm,
        draws,
        subset,
        subsets,
        with_term,
        parameters_only,
        poses,
    })
}

/// Coverage and PIT figures of per-point errors `e` (draw-major, `draws × n`) against the
/// observed errors, over the subsets `picks`; and per point its 95 % bound and PIT.
fn figures(
    e: &[f64],
    draws: usize,
    observed: &[f64],
    picks: &[Vec<usize>],
) -> (Coverage, Vec<(f64, f64)>) {
    let n = observed.len();
    let mut inside = 0usize;
    let mut col = vec![0.0; draws];
    let mut per_point = Vec::with_capacity(n);
    for j in 0..n {
        for k in 0..draws {
            col[k] = e[k * n + j];
        }
        col.sort_by(f64::total_cmp);
        let q95 = col[((0.95 * draws as f64).ceil() as usize).clamp(1, draws) - 1];
        inside += usize::from(observed[j] <= q95);
        let below = col.partition_point(|&v| v <= observed[j]);
        per_point.push((q95, below as f64 / draws as f64));
    }
    let pits: Vec<f64> = picks
        .iter()
        .map(|s| {
            let w_obs = s.iter().map(|&j| observed[j]).fold(0.0, f64::max);
            let below = (0..draws)
                .filter(|&k| s.iter().map(|&j| e[k * n + j]).fold(0.0, f64::max) <= w_obs)
                .count();
            below as f64 / draws as f64
        })
        .collect();
    let frac =
        |f: &dyn Fn(f64) -> bool| pits.iter().filter(|&&u| f(u)).count() as f64 / pits.len() as f64;
    let c = Coverage {
        coverage_95: inside as f64 / n as f64,
        pit_max_mean: pits.iter().sum::<f64>() / pits.len() as f64,
        pit_max_at_least_099: frac(&|u| u >= 0.99),
        pit_max_at_least_090: frac(&|u| u >= 0.9),
        pit_max_at_most_010: frac(&|u| u <= 0.1),
    };
    (c, per_point)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::discrepancy::{Discrepancy, NoiseSource};
    use crate::kinematics::{position, tx60, Joints};
    use rand::Rng;

    fn gaussian(rng: &mut impl Rng) -> f64 {
        let u: f64 = 1.0 - rng.random::<f64>();
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * rng.random::<f64>()).cos()
    }

    /// A robot that is one draw of the model's parameters plus an isotropic Gaussian deviation
    /// (σ 0.05 mm per coordinate) at every pose, and a model whose term holds norms of that
    /// same distribution: the check finds the 95 % bound honest (binomial sd of the coverage
    /// over 300 poses: 1.3 %) and the parameters alone far too narrow.
    #[test]
    fn an_honest_model_passes_and_the_parameters_alone_fail() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let mut model = tx60();
        let s = 0.05;
        let norm = |rng: &mut rand_chacha::ChaCha8Rng| {
            (0..3)
                .map(|_| (s * gaussian(rng)).powi(2))
                .sum::<f64>()
                .sqrt()
        };
        model.discrepancy = Some(
            Discrepancy {
                residual_norms: (0..2000).map(|_| norm(&mut rng)).collect(),
                robot_share: 0.5,
                noise: NoiseSource::Stated,
                noise_sigma_mm: Some(0.035),
                compensation: None,
            }
            .checked()
            .unwrap(),
        );
        let sampler = crate::sampling::ParamSampler::new(&model, 99).unwrap();
        let truth = sampler.draw(7);
        let measurements: Vec<Measurement> = (0..300)
            .map(|i| {
                let q = Joints::from_fn(6, |j| {
                    let (lo, hi) = model.limits_deg[j];
                    rng.random_range(0.8 * lo..0.8 * hi)
                });
                let p = position(&truth, &model.tool, &q.map(f64::to_radians));
                Measurement {
                    payload_kg: None,
                    q_deg: q,
                    position_mm: std::array::from_fn(|k| p[k] + s * gaussian(&mut rng)),
                    line: i + 2,
                    target: None,
                    on_base: false,
                    sides: None,
                }
            })
            .collect();
        let c = predictive_check(&model, &measurements, Placement::Known, 4000, 3).unwrap();
        let with = c.with_term.as_ref().unwrap();
        assert!((with.coverage_95 - 0.95).abs() < 0.04, "{}", c.render());
        assert!((with.pit_max_mean - 0.5).abs() < 0.2, "{}", c.render());
        assert!(
            c.parameters_only.coverage_95 < with.coverage_95 - 0.2,
            "{}",
            c.render()
        );
        assert!(c.render().contains("with the discrepancy term"));
        // Each pose against the prediction with the term: in the measurements' order, its
        // observed error, and inside its bound as often as the coverage says; the PITs of an
        // honest prediction spread evenly (mean ½, a tenth below 0.1 within binomial error).
        assert_eq!(c.poses.len(), measurements.len());
        let observed = point_errors_in(&model, &measurements, Placement::Known);
        for ((p, m), o) in c.poses.iter().zip(&measurements).zip(&observed) {
            assert_eq!(p.line, m.line);
            assert_eq!(p.error_mm, *o);
            assert!(p.bound_95_mm > 0.0 && (0.0..=1.0).contains(&p.pit));
            assert_eq!(
                p.error_mm <= p.bound_95_mm,
                p.pit < 0.95 || p.error_mm == p.bound_95_mm
            );
        }
        let n = c.poses.len() as f64;
        let inside = c
            .poses
            .iter()
            .filter(|p| p.error_mm <= p.bound_95_mm)
            .count() as f64;
        assert_eq!(inside / n, with.coverage_95);
        let mean_pit = c.poses.iter().map(|p| p.pit).sum::<f64>() / n;
        let low = c.poses.iter().filter(|p| p.pit < 0.1).count() as f64 / n;
        assert!((mean_pit - 0.5).abs() < 0.05, "mean PIT {mean_pit}");
        assert!((low - 0.1).abs() < 0.06, "share below 0.1: {low}");
        let outside = c
            .poses
            .iter()
            .filter(|p| p.error_mm > p.bound_95_mm)
            .count();
        assert!(
            c.render().contains(&format!(
                "outside the 95 % bound with the term: {outside} of"
            )),
            "{}",
            c.render()
        );
        let err = predictive_check(&model, &measurements[..1], Placement::Known, 100, 1);
        assert!(err.unwrap_err().to_string().contains("at least 2"));
    }
}
