//! The candidates a plan chooses its poses from, and the checks of its settings: configurations
//! within the joint limits less a margin, away from singularities and, with a tracker, within its
//! range and incidence.

use super::{setting, PlanError, PlanField, PlanOptions, TrackerSite, MAX_TRACKER_RANGE_MM};
use crate::identify::chain_fit::{default_free, ChainState};
use crate::kinematics::{transform, Joints, RobotModel};
use crate::number::fmt_plain;
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use serde::Serialize;

/// Checks the settings `o`, the task points `task` and the target of a plan of `model`, in that
/// order; the first setting out of range is the error.
pub(super) fn check(model: &RobotModel, task: &[Joints], o: &PlanOptions) -> Result<(), PlanError> {
    check_settings(model, o)?;
    check_task(model, task)?;
    check_tracker(model, o)?;
    super::workcell::check(model, &o.workcell)?;
    check_target(model, o)
}

/// Configurations a plan's candidate draw refused for its workcell.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Rejected {
    /// A link below the floor.
    pub floor: usize,
    /// A link in a keep-out box.
    pub keep_out: usize,
    /// Links of the arm into each other.
    pub self_collision: usize,
}

/// The numbers of a plan: σ, the thresholds, the numbers of candidates and poses (more
/// coordinates than inputs to identify), the search draws, the margin and the condition bound.
fn check_settings(model: &RobotModel, o: &PlanOptions) -> Result<(), PlanError> {
    // The range identify accepts: far outside it the weights 1/σ² of the design's
    // information overflow or underflow.
    if !crate::identify::noise::sigma_in_range(o.sigma_mm) {
        return Err(setting(
            PlanField::Sigma,
            crate::identify::noise::NoiseSettingError::Sigma(o.sigma_mm).to_string(),
        ));
    }
    if let Some(t) = o.thresholds.iter().find(|t| !(t.is_finite() && **t > 0.0)) {
        return Err(setting(
            PlanField::Thresholds,
            format!("must be positive, got {t}"),
        ));
    }
    if o.candidates == 0 || o.candidates > 1_000_000 {
        return Err(setting(
            PlanField::Candidates,
            format!("must be 1 … 1000000, got {}", o.candidates),
        ));
    }
    if o.poses > o.candidates {
        return Err(setting(
            PlanField::Poses,
            format!(
                "{} poses cannot be chosen from {} candidates",
                o.poses, o.candidates
            ),
        ));
    }
    let p = default_free(&model.fixed, true).len();
    if 3 * o.poses <= p {
        return Err(setting(
            PlanField::Poses,
            format!(
                "{} poses give {} coordinates, not more than the {p} inputs to identify: at least {}",
                o.poses,
                3 * o.poses,
                p / 3 + 1
            ),
        ));
    }
    if o.search_draws < 20 || o.search_draws > 100_000 {
        return Err(setting(
            PlanField::Search,
            format!("search draws must be 20 … 100000, got {}", o.search_draws),
        ));
    }
    if !(o.margin_deg.is_finite()
        && o.margin_deg >= 0.0
        && o.max_condition.is_finite()
        && o.max_condition > 1.0)
    {
        return Err(setting(
            PlanField::Search,
            format!(
                "the joint-limit margin must be ≥ 0° and the condition bound > 1, got {}° and {}",
                o.margin_deg, o.max_condition
            ),
        ));
    }
    Ok(())
}

/// The task points: at least one, each with one angle per joint of `model`.
fn check_task(model: &RobotModel, task: &[Joints]) -> Result<(), PlanError> {
    if task.is_empty() {
        return Err(setting(PlanField::TaskPoints, "none given"));
    }
    if let Some((k, q)) = task
        .iter()
        .enumerate()
        .find(|(_, q)| q.len() != model.joints())
    {
        return Err(setting(
            PlanField::TaskPoints,
            format!(
                "point {} has {} joint angles, the model has {} joints",
                k + 1,
                q.len(),
                model.joints()
            ),
        ));
    }
    Ok(())
}

impl TrackerSite {
    /// Checks the site's own figures: a finite position, a range in (0,
    /// [`MAX_TRACKER_RANGE_MM`]] and an incidence in (0, 90]°.
    ///
    /// # Errors
    ///
    /// [`PlanError::Setting`] naming [`PlanField::Tracker`], [`PlanField::TrackerRange`] or
    /// [`PlanField::MaxIncidence`].
    pub fn check(&self) -> Result<(), PlanError> {
        if !self.position_mm.iter().all(|v| v.is_finite()) {
            return Err(setting(
                PlanField::Tracker,
                format!("{:?} must be finite", self.position_mm),
            ));
        }
        let r = self.range_mm;
        if !(r.is_finite() && r > 0.0 && r <= MAX_TRACKER_RANGE_MM) {
            return Err(setting(
                PlanField::TrackerRange,
                format!(
                    "{} is not a range in (0, {}] mm (a laser tracker measures from tens of metres at most)",
                    fmt_plain(r),
                    fmt_plain(MAX_TRACKER_RANGE_MM)
                ),
            ));
        }
        let a = self.max_incidence_deg;
        if !(a > 0.0 && a <= 90.0) {
            return Err(setting(
                PlanField::MaxIncidence,
                format!("{a} is not an angle in (0, 90] degrees"),
            ));
        }
        Ok(())
    }
}

/// The tracker, if any: its own figures ([`TrackerSite::check`]), and no farther from the
/// robot's base than its range and the farthest the target reaches from the base together
/// (farther, no pose of the target is within its range).
fn check_tracker(model: &RobotModel, o: &PlanOptions) -> Result<(), PlanError> {
    let Some(t) = &o.tracker else {
        return Ok(());
    };
    t.check()?;
    let origin = crate::identify::chain::nominal_state(model).base;
    let d = (0..3)
        .map(|k| (t.position_mm[k] - origin[k]).powi(2))
        .sum::<f64>()
        .sqrt();
    let mut arm = model.clone();
    arm.tool = o.target_mm;
    let reach = crate::map::ik::reach_bound(&arm);
    if d > t.range_mm + reach {
        let p = t.position_mm.map(fmt_plain);
        return Err(setting(
            PlanField::Tracker,
            format!(
                "({}, {}, {}) mm is {} mm from the robot's base, farther than the tracker's range ({} mm) and the farthest the target reaches from the base ({reach:.0} mm) together: no pose can be measured from there",
                p[0],
                p[1],
                p[2],
                fmt_plain(d),
                fmt_plain(t.range_mm)
            ),
        ));
    }
    Ok(())
}

/// The target on the flange: finite, and no farther from the flange than the arm reaches from
/// its base (the sum of its links' lengths and offsets): a tracker target sits on the flange or
/// a tool, and one far beyond leaves no candidate within the singularity bound.
fn check_target(model: &RobotModel, o: &PlanOptions) -> Result<(), PlanError> {
    if !o.target_mm.iter().all(|v| v.is_finite()) {
        return Err(setting(
            PlanField::Target,
            format!("{:?} must be finite", o.target_mm),
        ));
    }
    let mut arm = model.clone();
    arm.tool = [0.0; 3];
    let reach = crate::map::ik::reach_bound(&arm);
    let off = o.target_mm.iter().map(|v| v * v).sum::<f64>().sqrt();
    if off > reach {
        let t = o.target_mm.map(crate::number::fmt_plain);
        return Err(setting(
            PlanField::Target,
            format!(
                "({}, {}, {}) mm is {} mm from the flange, farther than {} reaches from its base ({reach:.0} mm): a tracker target sits on the flange or a tool",
                t[0],
                t[1],
                t[2],
                crate::number::fmt_plain(off),
                model.name
            ),
        ));
    }
    Ok(())
}

/// The target's position in the measurement frame and the direction it faces (flange z).
fn target_and_facing(
    model: &RobotModel,
    s: &ChainState,
    q_deg: &[f64],
) -> (Vector3<f64>, Vector3<f64>) {
    let q = Joints::from_fn(q_deg.len(), |j| q_deg[j].to_radians());
    let p = Vector3::from(s.predict(&q));
    let t = transform(&model.params, &q);
    let z = Vector3::new(t[0][2], t[1][2], t[2][2]);
    (p, s.rotation() * z)
}

/// The range a candidate's joint is drawn from: within `limits` (degrees) less the margin.
/// (Drawing a joint that turns more than a full turn within one turn would lose no pose, but
/// changes the candidates of every arm with such a joint; the visiting order picks the turn
/// instead.)
pub(super) fn draw_ranges(limits: &[(f64, f64)], margin_deg: f64) -> Vec<(f64, f64)> {
    limits
        .iter()
        .map(|&(lo, hi)| within_margin(lo, hi, margin_deg))
        .collect()
}

/// The limits `lo … hi` (degrees, at most ±360°) less the margin (at most a quarter of the
/// range).
pub(super) fn within_margin(lo: f64, hi: f64, margin_deg: f64) -> (f64, f64) {
    let (lo, hi) = (lo.max(-360.0), hi.min(360.0));
    let m = margin_deg.min((hi - lo) / 4.0);
    (lo + m, hi - m)
}

/// Draws the candidates: configurations within `limits` (degrees) less the margin, away from
/// singularities, clear of the workcell's floor, boxes and the arm itself and, with a tracker,
/// within its range and incidence. Returns them, how many were drawn and how many the workcell
/// refused.
pub(super) fn candidates(
    model: &RobotModel,
    s: &ChainState,
    limits: &[(f64, f64)],
    o: &PlanOptions,
    steps: &super::steps::Steps,
) -> Result<(Vec<Joints>, usize, Rejected), PlanError> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(o.seed);
    let ranges = draw_ranges(limits, o.margin_deg);
    let mut rejected = Rejected::default();
    if let Some(t) = &o.tracker {
        // A tracker within the robot's reach would be in its way (and in danger).
        let origin = Vector3::new(s.base[0], s.base[1], s.base[2]);
        let reach = (0..200)
            .map(|_| {
                let q = Joints::from_fn(ranges.len(), |j| {
                    rng.random_range(ranges[j].0..=ranges[j].1)
                });
                (target_and_facing(model, s, &q).0 - origin).norm()
            })
            .fold(0.0, f64::max);
        let d = (Vector3::from(t.position_mm) - origin).norm();
        if d < reach {
            return Err(setting(
                PlanField::Tracker,
                format!(
                    "{:?} mm is {d:.0} mm from the robot's base, within its reach (about {reach:.0} mm): the tracker must stand outside it",
                    t.position_mm
                ),
            ));
        }
    }
    let max_draws = 200 * o.candidates + 10_000;
    let mut out = Vec::with_capacity(o.candidates);
    let (mut drawn, mut unseen) = (0, 0);
    let cos_max = o
        .tracker
        .as_ref()
        .map(|t| t.max_incidence_deg.to_radians().cos());
    let report_every = (o.candidates / 200).max(1);
    while out.len() < o.candidates && drawn < max_draws {
        drawn += 1;
        let q = Joints::from_fn(ranges.len(), |j| {
            rng.random_range(ranges[j].0..=ranges[j].1)
        });
        match crate::map::ik::position_condition(model, &q.map(f64::to_radians)) {
            Some(c) if c <= o.max_condition => {}
            _ => continue,
        }
        if let (Some(t), Some(cmax)) = (&o.tracker, cos_max) {
            let (p, facing) = target_and_facing(model, s, &q);
            let to = Vector3::from(t.position_mm) - p;
            let d = to.norm();
            if d > t.range_mm || facing.dot(&to) < cmax * d {
                unseen += 1;
                continue;
            }
        }
        use super::workcell::Clash;
        // With an approach side the approach pose must be reachable too (limits, workcell).
        let pre = o.approach.map(|a| super::approach::approach_pose(&q, a));
        if let Some(p) = &pre {
            let inside = (p.iter().zip(limits)).all(|(v, &(lo, hi))| (lo..=hi).contains(v));
            if !inside {
                continue;
            }
        }
        let clash = |q: &Joints| {
            super::workcell::clash(model, s, &q.map(f64::to_radians), &o.workcell, true)
        };
        match clash(&q).or_else(|| pre.as_ref().and_then(clash)) {
            Some(Clash::Floor { .. }) => rejected.floor += 1,
            Some(Clash::KeepOut { .. }) => rejected.keep_out += 1,
            Some(Clash::SelfCollision { .. }) => rejected.self_collision += 1,
            None => {
                out.push(q);
                if out.len() % report_every == 0 {
                    steps.at(
                        super::steps::Step::Candidates,
                        out.len() as f64 / o.candidates as f64,
                    );
                }
            }
        }
    }
    if out.len() < o.candidates {
        // The setting that refused most of the draws, when one refused most of them; else the
        // number asked for.
        let field = [
            (unseen, PlanField::Tracker),
            (rejected.floor, PlanField::Floor),
            (rejected.keep_out, PlanField::KeepOut),
            (
                rejected.self_collision,
                if o.workcell.link_radius_mm.is_some() {
                    PlanField::LinkRadius
                } else {
                    PlanField::Candidates
                },
            ),
        ]
        .into_iter()
        .filter(|(n, _)| 2 * n > drawn)
        .max_by_key(|(n, _)| *n)
        .map_or(PlanField::Candidates, |(_, f)| f);
        return Err(setting(
            field,
            format!(
                "only {} of {} configurations met the limits, the singularity bound{} after {drawn} draws ({}{} below the floor, {} in a keep-out box, {} into the arm itself)",
                out.len(),
                o.candidates,
                if o.tracker.is_some() {
                    ", the tracker's range and incidence"
                } else {
                    ""
                },
                if o.tracker.is_some() {
                    format!("{unseen} out of the tracker's range or incidence, ")
                } else {
                    String::new()
                },
                rejected.floor,
                rejected.keep_out,
                rejected.self_collision
            ),
        ));
    }
    Ok((out, drawn, rejected))
}
