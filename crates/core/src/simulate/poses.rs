//! Pose measurements of a simulated robot in a tracker's own frame: the target measured at
//! random configurations (or given ones), with the tracker standing somewhere else than the
//! robot base (docs/METHOD.md §2.4).
//!
//! The tracker frame's origin is the tracker. [`random_placement`] draws where the robot base
//! stands in it (1.5–4 m away, any heading, tilted up to ±10°, ±0.5 m in height): the
//! `p_tracker = B · p_base` of the model's `base` field. [`simulate_poses`] measures the true
//! robot's target there with the AT960 noise model of [`super::tracker`] (radial and transverse
//! about the line of sight from the tracker), or with a plain σ per coordinate.

use super::nongeometric::{true_position, NonGeometric};
use super::tracker::TrackerModel;
use crate::identify::{PoseData, PosePoint, PoseRun};
use crate::kinematics::{BaseTransform, Joints, RobotModel};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// How the tracker's measurements are perturbed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TrackerNoise {
    /// The AT960 model (MPE-based, radial and transverse) with the tracker at the measurement
    /// frame's origin.
    Tracker(TrackerModel),
    /// A plain σ per coordinate, mm.
    Isotropic(f64),
}

impl TrackerNoise {
    /// A reading of the true position `p` (mm, tracker frame, the tracker at its origin).
    fn measure(&self, p: [f64; 3], rng: &mut ChaCha8Rng) -> [f64; 3] {
        match self {
            TrackerNoise::Tracker(t) => TrackerModel {
                position_mm: [0.0; 3],
                ..*t
            }
            .measure(p, rng),
            TrackerNoise::Isotropic(s) => super::add_tracker_noise(p, *s, rng),
        }
    }
}

/// A seeded random placement of the robot base in a tracker's frame: 1.5–4 m from the tracker
/// horizontally, any heading and yaw, roll and pitch within ±10°, height ±500 mm.
pub fn random_placement(seed: u64) -> BaseTransform {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x0074_7261_636b_6572);
    let r = rng.random_range(1500.0..4000.0);
    let heading = rng.random_range(-std::f64::consts::PI..std::f64::consts::PI);
    let tilt = 10f64.to_radians();
    BaseTransform {
        xyz: [
            r * heading.cos(),
            r * heading.sin(),
            rng.random_range(-500.0..500.0),
        ],
        rpy: [
            rng.random_range(-tilt..tilt),
            rng.random_range(-tilt..tilt),
            rng.random_range(-std::f64::consts::PI..std::f64::consts::PI),
        ],
    }
}

/// The ChaCha stream the measurement noise of [`simulate_poses`] is drawn from.
pub const NOISE_STREAM: u64 = 0x006e_6f69_7365;

/// Measures `truth`'s target at `configs` (degrees, one angle per joint of `truth`) from a
/// tracker whose frame holds the robot
/// base at `placement`: the true position `placement · P(θ, t, q)` plus noise. One run, line
/// numbers as [`crate::identify::write_poses`] writes them.
///
/// The noise is drawn from stream [`NOISE_STREAM`] of the ChaCha generator seeded by `seed`, so
/// it is independent of configurations drawn by [`random_poses`] from the same seed (which uses
/// stream 0): with one stream for both, Box–Muller turned each pose's own joint-angle uniforms
/// into its noise, a smooth function of the configuration that a compensation then "predicted".
pub fn simulate_poses(
    truth: &RobotModel,
    configs: &[Joints],
    placement: &BaseTransform,
    noise: &TrackerNoise,
    seed: u64,
) -> PoseData {
    simulate_poses_of(truth, None, configs, placement, noise, seed)
}

/// [`simulate_poses`] of a true robot that also carries the non-geometric errors `errors`
/// (compliance under gravity and payload, gear harmonics: [`super::nongeometric`]); `None` is
/// [`simulate_poses`] itself, bit for bit.
pub fn simulate_poses_of(
    truth: &RobotModel,
    errors: Option<&NonGeometric>,
    configs: &[Joints],
    placement: &BaseTransform,
    noise: &TrackerNoise,
    seed: u64,
) -> PoseData {
    simulate_poses_at(truth, errors, configs, &[], placement, noise, seed)
}

/// [`simulate_poses_of`] with the robot carrying `payloads_kg` in turn, pose `k` the payload
/// `payloads_kg[k % len]` (each pose's file row records it): poses at two payloads tell a
/// joint's compliance from a harmonic of the same shape (docs/METHOD.md §19). Empty: the
/// payload of `errors`, as [`simulate_poses_of`] (the same bits); a geometric robot (`errors`
/// `None`) records the payloads, which move nothing.
pub fn simulate_poses_at(
    truth: &RobotModel,
    errors: Option<&NonGeometric>,
    configs: &[Joints],
    payloads_kg: &[f64],
    placement: &BaseTransform,
    noise: &TrackerNoise,
    seed: u64,
) -> PoseData {
    simulate_poses_sided(
        truth,
        errors,
        configs,
        None,
        payloads_kg,
        placement,
        noise,
        seed,
    )
}

/// [`simulate_poses_at`] with, for a robot with backlash, the side each joint arrives at pose
/// `k` from `sides[k]` (1 moving positive, −1, 0 no turn; a plan with an approach side gives
/// them), or, without, from the configurations' order (the direction each joint moved from the
/// previous pose; none at the first). Such a robot's joints stand half their gap beyond the
/// commanded angles on that side, and each pose records its sides (`s1..sn`). Without backlash
/// the sides change nothing and are not recorded: [`simulate_poses_at`], bit for bit.
#[allow(clippy::too_many_arguments)]
pub fn simulate_poses_sided(
    truth: &RobotModel,
    errors: Option<&NonGeometric>,
    configs: &[Joints],
    sides: Option<&[Joints]>,
    payloads_kg: &[f64],
    placement: &BaseTransform,
    noise: &TrackerNoise,
    seed: u64,
) -> PoseData {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(NOISE_STREAM);
    let backlash = errors.is_some_and(NonGeometric::has_backlash);
    let side_of = |k: usize| -> Joints {
        if let Some(s) = sides.and_then(|s| s.get(k)) {
            return *s;
        }
        let q = &configs[k];
        Joints::from_fn(q.len(), |j| match k {
            0 => 0.0,
            _ => {
                let d = q[j] - configs[k - 1][j];
                if d == 0.0 {
                    0.0
                } else {
                    d.signum()
                }
            }
        })
    };
    let points = configs
        .iter()
        .enumerate()
        .map(|(k, q)| {
            let payload_kg = match payloads_kg {
                [] => errors.map_or(0.0, |e| e.payload_kg),
                list => list[k % list.len()],
            };
            let carrying = errors.map(|e| NonGeometric {
                payload_kg,
                ..e.clone()
            });
            let rad = q.map(f64::to_radians);
            let (p, sides) = match carrying.as_ref().filter(|_| backlash) {
                Some(e) => {
                    let s = side_of(k);
                    let at = e.sided_angles(truth, &rad, &s);
                    (
                        crate::kinematics::position(&truth.params, &truth.tool, &at),
                        Some(s),
                    )
                }
                None => (true_position(truth, carrying.as_ref(), &rad), None),
            };
            let p = placement.apply(p);
            let position_mm = noise.measure(p, &mut rng);
            PosePoint {
                payload_kg,
                q_deg: *q,
                position_mm,
                sigma_mm: None,
                line: k as u64 + 2,
                target: 0,
                sides,
            }
        })
        .collect();
    PoseData {
        runs: vec![PoseRun { run: None, points }],
        ..Default::default()
    }
}

/// The ChaCha stream the noise of the other targets of [`add_other_targets`] is drawn from.
pub const OTHER_TARGETS_STREAM: u64 = 0x006f_7468_6572;

/// Adds to `data` (poses of `truth` as [`simulate_poses_at`] made them, seeded by `seed`) the
/// readings of further reflectors on the tool at `others` (flange frame, mm) at each pose, as a
/// tracker that measures several reflectors per pose records them: after each pose's row, one
/// row per other reflector, every row labelled (`T1` the tool, `T2`, …), lines renumbered. The
/// arm stands where it stood for the tool's reading (its joint errors bend it under the
/// payload at the tool); their noise comes from stream [`OTHER_TARGETS_STREAM`], so the tool's
/// rows keep their bits. Nothing changes for `others` empty.
pub fn add_other_targets(
    data: &mut PoseData,
    truth: &RobotModel,
    errors: Option<&NonGeometric>,
    others: &[[f64; 3]],
    placement: &BaseTransform,
    noise: &TrackerNoise,
    seed: u64,
) {
    if others.is_empty() {
        return;
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(OTHER_TARGETS_STREAM);
    let mut line = 2;
    for run in &mut data.runs {
        let mut rows = Vec::with_capacity(run.points.len() * (1 + others.len()));
        for p in &run.points {
            let q = p.q_deg.map(f64::to_radians);
            let carrying = errors.map(|e| NonGeometric {
                payload_kg: p.payload_kg,
                ..e.clone()
            });
            let actual = match &carrying {
                None => q,
                Some(e) => {
                    // The arm stands where it stood for the tool's reading, backlash included.
                    match &p.sides {
                        Some(s) => e.sided_angles(truth, &q, s),
                        None => e.actual_angles(truth, &q),
                    }
                }
            };
            rows.push(PosePoint { line, ..p.clone() });
            line += 1;
            for (k, offset) in others.iter().enumerate() {
                let x =
                    placement.apply(crate::kinematics::position(&truth.params, offset, &actual));
                let position_mm = noise.measure(x, &mut rng);
                rows.push(PosePoint {
                    position_mm,
                    line,
                    target: k as u8 + 1,
                    ..p.clone()
                });
                line += 1;
            }
        }
        run.points = rows;
    }
    data.targets = (1..=others.len() + 1).map(|k| format!("T{k}")).collect();
}

/// `n` configurations uniform within `model`'s joint limits, seeded (degrees, one angle per
/// joint).
pub fn random_poses(model: &RobotModel, n: usize, seed: u64) -> Vec<Joints> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    super::random_configurations(&model.limits_deg, n, &mut rng)
}

/// The tracker's position in the robot base frame for a placement (the tracker stands at the
/// measurement frame's origin): `placement⁻¹ · 0`.
pub fn tracker_in_base_frame(placement: &BaseTransform) -> [f64; 3] {
    let v = placement.isometry().inverse() * nalgebra::Point3::origin();
    [v.x, v.y, v.z]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::tx60;

    #[test]
    fn placements_are_far_and_reproducible() {
        for seed in 0..50 {
            let p = random_placement(seed);
            let d = (p.xyz[0].powi(2) + p.xyz[1].powi(2)).sqrt();
            assert!((1500.0..4000.0).contains(&d));
            assert!(p.rpy[0].abs() <= 0.175 && p.rpy[1].abs() <= 0.175);
            assert_eq!(p, random_placement(seed));
        }
        assert_ne!(random_placement(1), random_placement(2));
    }

    #[test]
    fn noise_free_poses_are_the_placed_truth() {
        let mut m = tx60();
        m.tool = [30.0, -20.0, 80.0];
        let b = random_placement(3);
        let qs = [Joints::from([10.0, -20.0, 90.0, 30.0, 40.0, -50.0])];
        let d = simulate_poses(&m, &qs, &b, &TrackerNoise::Isotropic(0.0), 1);
        m.base = Some(b);
        let want = m.world_position(&qs[0].map(f64::to_radians));
        let got = d.runs[0].points[0].position_mm;
        for k in 0..3 {
            assert!((got[k] - want[k]).abs() < 1e-9);
        }
        let t = tracker_in_base_frame(&b);
        let back = b.apply(t);
        assert!(back.iter().all(|v| v.abs() < 1e-9));
    }

    /// Noise drawn with the seed of the configurations is not a function of them: each
    /// coordinate's noise regressed on (1, sin q_j, cos q_j) of its own pose explains what
    /// 13 regressors explain of 400 independent draws (R² about 0.03), not the half it explained
    /// when noise and configurations shared one stream.
    #[test]
    fn noise_is_independent_of_configurations_from_the_same_seed() {
        let m = tx60();
        let b = random_placement(3);
        let n = 400;
        for seed in [1, 7] {
            let qs = random_poses(&m, n, seed);
            let exact = simulate_poses(&m, &qs, &b, &TrackerNoise::Isotropic(0.0), seed);
            let noisy = simulate_poses(&m, &qs, &b, &TrackerNoise::Isotropic(0.01), seed);
            let x = nalgebra::DMatrix::from_fn(n, 13, |i, c| {
                let q = qs[i][c.div_ceil(2) % 6].to_radians();
                match c {
                    0 => 1.0,
                    c if c % 2 == 1 => q.sin(),
                    _ => q.cos(),
                }
            });
            for k in 0..3 {
                let e = nalgebra::DVector::from_fn(n, |i, _| {
                    noisy.runs[0].points[i].position_mm[k] - exact.runs[0].points[i].position_mm[k]
                });
                let fit = x.clone().svd(true, true).solve(&e, 1e-12).unwrap();
                let left = (&e - &x * fit).norm_squared();
                let mean = e.mean();
                let total = e.iter().map(|v| (v - mean).powi(2)).sum::<f64>();
                let r2 = 1.0 - left / total;
                assert!(r2 < 0.12, "seed {seed}, coordinate {k}: R² {r2:.3}");
            }
        }
    }
}
