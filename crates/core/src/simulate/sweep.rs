//! Circle-point sweeps of a simulated robot (the measurement plan of paper §1.3 / §3).
//!
//! For joint `i`, every other joint stays at the home pose [`SweepPlan::home_deg`] and joint `i`
//! moves in steps of [`SweepPlan::step_deg`] over the centred fraction
//! [`SweepPlan::range_fraction`] of its measuring range (the points are placed symmetrically about
//! the range's centre). The default plan is the paper's: 2° steps over 50 % of the TX60 measuring
//! ranges, home pose at the centre of every measuring range ([`TX60_HOME_DEG`]). With the
//! off-axis tool point (30, −20, 80) mm that pose keeps the target at least ~36 mm from every
//! axis (J6's radius is fixed by the tool offset: √(30² + 20²); J1–J5 are above 100 mm).
//!
//! A plan has one home angle and one measuring range per joint. The paper's table is the
//! six-joint TX60's; for a robot with another number of joints (4 to 7) [`SweepPlan::resized`]
//! keeps the first entries and gives every further joint [`EXTRA_MEASURING_RANGE_DEG`] about a
//! home of 0°, and [`SweepPlan::within`] then fits the plan into the robot's joint limits.

use super::add_tracker_noise;
use crate::identify::{Sweep, SweepData, SweepPoint, SweepRun};
use crate::kinematics::{position, Joints, Limits, RobotModel};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// The measuring ranges of the paper (tracker target visibility) of the six TX60 joints,
/// degrees.
pub const TX60_MEASURING_RANGES_DEG: [(f64, f64); 6] = [
    (-180.0, 180.0),
    (-5.0, 127.0),
    (-5.0, 142.0),
    (-180.0, 180.0),
    (-5.0, 125.0),
    (-180.0, 180.0),
];

/// Home pose of the default plan: the centre of every measuring range, degrees.
pub const TX60_HOME_DEG: [f64; 6] = [0.0, 61.0, 68.5, 0.0, 60.0, 0.0];

/// The measuring range, degrees, that [`SweepPlan::resized`] gives a joint beyond the plan's
/// table (the seventh of a seven-axis arm: the paper's table has six joints). It is the full
/// turn of the TX60's roll joints J1, J4 and J6, centred on a home angle of 0°;
/// [`SweepPlan::within`] cuts it to the joint's limits.
pub const EXTRA_MEASURING_RANGE_DEG: (f64, f64) = (-180.0, 180.0);

/// How the sweeps are measured.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepPlan {
    /// Fraction of each joint's measuring range swept, in (0, 1].
    pub range_fraction: f64,
    /// Angle step, degrees (> 0).
    pub step_deg: f64,
    /// Pose of the joints not being swept, degrees, one per joint.
    pub home_deg: Joints,
    /// Measuring range of each joint, degrees (as many as [`Self::home_deg`]).
    pub measuring_range_deg: Limits,
}

impl Default for SweepPlan {
    /// The paper's plan of the six-joint TX60 ([`TX60_HOME_DEG`], [`TX60_MEASURING_RANGES_DEG`]).
    fn default() -> Self {
        SweepPlan {
            range_fraction: 0.5,
            step_deg: 2.0,
            home_deg: TX60_HOME_DEG.into(),
            measuring_range_deg: TX60_MEASURING_RANGES_DEG.into(),
        }
    }
}

impl SweepPlan {
    /// Number of joints the plan sweeps.
    pub fn joints(&self) -> usize {
        self.home_deg.len()
    }

    /// This plan for a robot of `joints` joints (at most [`crate::kinematics::MAX_JOINTS`]):
    /// the first `joints` home angles and measuring ranges, and for every joint beyond the
    /// plan's a home of 0° and [`EXTRA_MEASURING_RANGE_DEG`] (see the module docs). A plan of
    /// that many joints is returned unchanged.
    pub fn resized(&self, joints: usize) -> SweepPlan {
        let mut p = self.clone();
        p.home_deg = Joints::from_fn(joints, |j| self.home_deg.get(j).copied().unwrap_or(0.0));
        p.measuring_range_deg = Limits::from_fn(joints, |j| {
            self.measuring_range_deg
                .get(j)
                .copied()
                .unwrap_or(EXTRA_MEASURING_RANGE_DEG)
        });
        p
    }

    /// This plan fitted into joint limits (degrees, one `(min, max)` per joint): first
    /// [`Self::resized`] to the limits' joint count, then each measuring range cut to the limits
    /// and each home angle moved inside them, so that no commanded angle lies outside. A plan
    /// already within the limits (the TX60's) is returned unchanged.
    pub fn within(&self, limits_deg: &[(f64, f64)]) -> SweepPlan {
        let mut p = self.resized(limits_deg.len());
        for j in 0..limits_deg.len() {
            let (lo, hi) = limits_deg[j];
            let (a, b) = p.measuring_range_deg[j];
            let (a, b) = (a.max(lo), b.min(hi));
            p.measuring_range_deg[j] = if a < b { (a, b) } else { (lo, hi) };
            p.home_deg[j] = p.home_deg[j].clamp(lo, hi);
        }
        p
    }

    /// The commanded angles of joint `joint` (1-based) in its sweep, degrees, ascending. Empty for
    /// a joint outside 1–n (the plan's [`Self::joints`]) or a non-positive step or fraction.
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
        if !(1..=self.joints()).contains(&joint)
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
    pub fn sweep_configurations(&self, joint: usize) -> Vec<Joints> {
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

/// Sweeps of all joints of `truth` (six for the TX60) for `runs` repeated runs (labelled "1",
/// "2", … when `runs > 1`, unlabelled for one run), measured on `truth` with Gaussian noise of
/// `noise_sigma_mm` per coordinate, from the seed `seed`. A plan of another joint count than
/// `truth`'s is first [`SweepPlan::resized`] to it.
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
    let n = truth.joints();
    let resized;
    let plan = if plan.joints() == n {
        plan
    } else {
        resized = plan.resized(n);
        &resized
    };
    let mut line = 2u64; // line numbers as written by `write_sweeps` (header on line 1)
    let runs = (0..runs)
        .map(|r| {
            let sweeps = (1..=n)
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

    #[test]
    fn plans_for_other_joint_counts() {
        let p = SweepPlan::default();
        assert_eq!(p.resized(6), p);
        let seven = p.resized(7);
        assert_eq!(seven.joints(), 7);
        assert_eq!(&seven.home_deg[..6], &TX60_HOME_DEG);
        assert_eq!(seven.home_deg[6], 0.0);
        assert_eq!(seven.measuring_range_deg[6], EXTRA_MEASURING_RANGE_DEG);
        assert_eq!(seven.sweep_angles(7).len(), 91);
        let four = p.within(&[
            (-170.0, 170.0),
            (-90.0, 90.0),
            (-100.0, 100.0),
            (-170.0, 170.0),
        ]);
        assert_eq!(four.joints(), 4);
        assert_eq!(four.measuring_range_deg[1], (-5.0, 90.0));
        assert!(four.sweep_angles(5).is_empty());
        assert!(four.sweep_configurations(2).iter().all(|q| q.len() == 4));
    }
}
