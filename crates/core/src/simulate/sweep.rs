//! Circle-point sweeps of a simulated robot (the measurement plan of paper §1.3 / §3).
//!
//! For joint `i`, every other joint stays at the home pose [`SweepPlan::home_deg`] and joint `i`
//! moves in steps of [`SweepPlan::step_deg`] over the centred fraction
//! [`SweepPlan::range_fraction`] of its measuring range (the points are placed symmetrically about
//! the range's centre). The default plan is the paper's: 2° steps over 50 % of the TX60 measuring
//! ranges, home pose at the centre of every measuring range ([`TX60_HOME_DEG`]). With the
//! off-axis tool point (30, −20, 80) mm that pose keeps the target at least ~36 mm from every
//! axis (J6's radius is fixed by the tool offset: √(30² + 20²); J1–J5 are above 100 mm).

use super::add_tracker_noise;
use crate::identify::{Sweep, SweepData, SweepPoint, SweepRun};
use crate::kinematics::{position, RobotModel, JOINTS};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// The measuring ranges of the paper (tracker target visibility), degrees.
pub const TX60_MEASURING_RANGES_DEG: [(f64, f64); JOINTS] = [
    (-180.0, 180.0),
    (-5.0, 127.0),
    (-5.0, 142.0),
    (-180.0, 180.0),
    (-5.0, 125.0),
    (-180.0, 180.0),
];

/// Home pose of the default plan: the centre of every measuring range, degrees.
pub const TX60_HOME_DEG: [f64; JOINTS] = [0.0, 61.0, 68.5, 0.0, 60.0, 0.0];

/// How the sweeps are measured.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepPlan {
    /// Fraction of each joint's measuring range swept, in (0, 1].
    pub range_fraction: f64,
    /// Angle step, degrees (> 0).
    pub step_deg: f64,
    /// Pose of the joints not being swept, degrees.
    pub home_deg: [f64; JOINTS],
    /// Measuring range of each joint, degrees.
    pub measuring_range_deg: [(f64, f64); JOINTS],
}

impl Default for SweepPlan {
    fn default() -> Self {
        SweepPlan {
            range_fraction: 0.5,
            step_deg: 2.0,
            home_deg: TX60_HOME_DEG,
            measuring_range_deg: TX60_MEASURING_RANGES_DEG,
        }
    }
}

impl SweepPlan {
    /// This plan fitted into joint limits (degrees): each measuring range cut to the limits, and
    /// each home angle moved inside them, so that no commanded angle lies outside. A plan
    /// already within the limits (the TX60's) is returned unchanged.
    pub fn within(&self, limits_deg: &[(f64, f64); JOINTS]) -> SweepPlan {
        let mut p = self.clone();
        for j in 0..JOINTS {
            let (lo, hi) = limits_deg[j];
            let (a, b) = p.measuring_range_deg[j];
            let (a, b) = (a.max(lo), b.min(hi));
            p.measuring_range_deg[j] = if a < b { (a, b) } else { (lo, hi) };
            p.home_deg[j] = p.home_deg[j].clamp(lo, hi);
        }
        p
    }

    /// The commanded angles of joint `joint` (1-based) in its sweep, degrees, ascending. Empty for
    /// a joint outside 1–6 or a non-positive step or fraction.
    pub fn sweep_angles(&self, joint: usize) -> Vec<f64> {
        let Some(steps) = self.steps(joint) else {
            return Vec::new();
        };
        let (lo, hi) = self.measuring_range_deg[joint - 1];
        let centre = (lo + hi) / 2.0;
        let start = centre - steps as f64 * self.step_deg / 2.0;
        (0..=steps)
            .map(|k| start + k as f64 * self.step_deg)
            .collect()
    }

    /// The number of points in joint `joint`'s sweep (the length of [`Self::sweep_angles`]),
    /// without building it: for sizing a run before it allocates. Saturates at `u64::MAX`.
    pub fn sweep_len(&self, joint: usize) -> u64 {
        self.steps(joint)
            .map_or(0, |s| (s as u64).saturating_add(1))
    }

    fn steps(&self, joint: usize) -> Option<usize> {
        if !(1..=JOINTS).contains(&joint)
            || self.step_deg.is_nan()
            || self.step_deg <= 0.0
            || self.range_fraction.is_nan()
            || self.range_fraction <= 0.0
        {
            return None;
        }
        let (lo, hi) = self.measuring_range_deg[joint - 1];
        let span = (hi - lo) * self.range_fraction.min(1.0);
        Some((span / self.step_deg + 1e-9).floor() as usize)
    }

    /// The commanded configurations of joint `joint`'s sweep, degrees.
    pub fn sweep_configurations(&self, joint: usize) -> Vec<[f64; JOINTS]> {
        self.sweep_angles(joint)
            .into_iter()
            .map(|q| {
                let mut c = self.home_deg;
                c[joint - 1] = q;
                c
            })
            .collect()
    }
}

/// Sweeps of all six joints for `runs` repeated runs (labelled "1", "2", … when `runs > 1`,
/// unlabelled for one run), measured on `truth` with Gaussian noise of `noise_sigma_mm` per
/// coordinate, from the seed `seed`.
pub fn simulate_sweeps(
    truth: &RobotModel,
    plan: &SweepPlan,
    noise_sigma_mm: f64,
    runs: usize,
    seed: u64,
) -> SweepData {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    simulate_sweeps_with(truth, plan, noise_sigma_mm, runs, &mut rng)
}

/// [`simulate_sweeps`] drawing from a given generator.
pub fn simulate_sweeps_with(
    truth: &RobotModel,
    plan: &SweepPlan,
    noise_sigma_mm: f64,
    runs: usize,
    rng: &mut ChaCha8Rng,
) -> SweepData {
    let mut line = 2u64; // line numbers as written by `write_sweeps` (header on line 1)
    let runs = (0..runs)
        .map(|r| {
            let sweeps = (1..=JOINTS)
                .map(|j| Sweep {
                    joint: j,
                    points: plan
                        .sweep_configurations(j)
                        .into_iter()
                        .map(|q_deg| {
                            let p =
                                position(&truth.params, &truth.tool, &q_deg.map(f64::to_radians));
                            let point = SweepPoint {
                                q_deg,
                                position_mm: add_tracker_noise(p, noise_sigma_mm, rng),
                                line,
                            };
                            line += 1;
                            point
                        })
                        .collect(),
                })
                .collect();
            SweepRun {
                run: (runs > 1).then(|| (r + 1).to_string()),
                sweeps,
            }
        })
        .collect();
    SweepData { runs }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_plan_angles() {
        let p = SweepPlan::default();
        let a = p.sweep_angles(2); // 50 % of [-5, 127] = 66 deg around 61
        assert_eq!(a.len(), 34);
        assert!((a[0] - 28.0).abs() < 1e-12 && (a[33] - 94.0).abs() < 1e-12);
        let a = p.sweep_angles(1);
        assert_eq!(a.len(), 91);
        assert!((a[0] + 90.0).abs() < 1e-12);
        let c = p.sweep_configurations(3);
        assert!(c
            .iter()
            .all(|q| q[0] == 0.0 && q[1] == 61.0 && q[4] == 60.0));
        assert!(p.sweep_angles(7).is_empty());
    }
}
