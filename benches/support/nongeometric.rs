//! Simulated TX60s with non-geometric errors, for the honesty experiment of the predicted
//! reliability (`benches/honesty.rs`, `tests/it/honesty.rs`).
//!
//! The true robot is written here, independently of the library it checks: its own forward
//! kinematics of the modified (Hayati) DH chain of docs/METHOD.md §1,
//! `T_i = Rz(θ_i + q_i)·Tz(d_i)·Tx(a_i)·Rx(α_i)·Ry(β_i)`, its own copy of the TX60 table, its own
//! rigid placement in the tracker frame, plus two errors no geometric model has:
//!
//! * joint compliance: `Δθ_i = k_i·τ_i(q)`, `τ_i` the gravity torque about joint i's axis of
//!   the links beyond it (masses [`LINK_MASS_KG`] at the middle of each link, gravity along −z
//!   of the base frame), `k_i ~ U(1, 5)·10⁻⁶ rad/(N·m) × s`;
//! * gear harmonics: `Δθ_i = A_i sin(q_i + φ_i) + B_i sin(2q_i + ψ_i)`,
//!   `A_i, B_i ~ U(0.002, 0.01)° × s`, random phases.
//!
//! [`check_fk`] compares this forward kinematics with the library's
//! (`gpu_amcs::kinematics::position`) on geometric chains: the only place the library's forward
//! kinematics touches the true robot. The library is used for what is checked: the
//! identification (the path of `gpu-amcs identify poses.csv --tracker-sigma 0.01`) and the
//! predicted reliability (`Problem` + `CpuEvaluator`, measurement frame).

use gpu_amcs::engine::{CpuEvaluator, Evaluator, Problem, Reference};
use gpu_amcs::identify::chain::{ChainOptions, TermSelection};
use gpu_amcs::identify::{
    identified_model, identify_data, IdentifyOptions, JointErrorFit, NoiseModel, PoseData,
    PosePoint, PoseRun, TrackerData,
};
use gpu_amcs::kinematics::{tx60, Joints, RobotModel};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

/// Joints of the TX60.
pub const JOINTS: usize = 6;
/// The TX60 in the MDH convention of docs/METHOD.md §1: θ, d, a, α, β per joint (deg, mm).
/// A copy of `kinematics::tx60`'s table on purpose: the generator does not take the robot from
/// the library it checks ([`check_fk`] asserts that the two agree).
const TX60_MDH: [[f64; 5]; JOINTS] = [
    [0.0, 375.0, 0.0, -90.0, 0.0],
    [-90.0, 0.0, 290.0, 0.0, 0.0],
    [90.0, 20.0, 0.0, 90.0, 0.0],
    [0.0, 310.0, 0.0, -90.0, 0.0],
    [0.0, 0.0, 0.0, 90.0, 0.0],
    [0.0, 70.0, 0.0, 0.0, 0.0],
];
/// Per joint, whether `d` is the fixed parameter (J2 ∥ J3) rather than `β`.
const D_FIXED: [bool; JOINTS] = [false, true, false, false, false, false];
/// The TX60's joint limits, degrees (docs/METHOD.md §1; a copy, as the table above).
const TX60_LIMITS_DEG: [(f64, f64); JOINTS] = [
    (-180.0, 180.0),
    (-127.5, 127.5),
    (-142.5, 142.5),
    (-270.0, 270.0),
    (-122.5, 132.5),
    (-270.0, 270.0),
];
/// Link masses, kg (link i is the body joint i turns).
pub const LINK_MASS_KG: [f64; JOINTS] = [12.0, 10.0, 6.0, 5.0, 1.5, 0.5];
/// Gravity, m/s².
const GRAVITY: f64 = 9.81;
/// Tracker noise, mm per coordinate (stated to the identification as `--tracker-sigma`).
pub const TRACKER_SIGMA_MM: f64 = 0.010;
/// Calibration poses per experiment.
pub const CALIBRATION_POSES: usize = 60;
/// Task points per experiment (w is their largest error).
pub const TASK_POINTS: usize = 20;

type V3 = [f64; 3];
type M3 = [[f64; 3]; 3];

fn mat_mul(a: &M3, b: &M3) -> M3 {
    let mut c = [[0.0; 3]; 3];
    for (i, row) in c.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    c
}

fn mat_vec(a: &M3, v: &V3) -> V3 {
    [0, 1, 2].map(|i| a[i][0] * v[0] + a[i][1] * v[1] + a[i][2] * v[2])
}

fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Distance between two points, mm.
pub fn distance(a: V3, b: V3) -> f64 {
    dot(sub(a, b), sub(a, b)).sqrt()
}

fn rot_x(t: f64) -> M3 {
    let (s, c) = t.sin_cos();
    [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]]
}

fn rot_y(t: f64) -> M3 {
    let (s, c) = t.sin_cos();
    [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]
}

fn rot_z(t: f64) -> M3 {
    let (s, c) = t.sin_cos();
    [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
}

/// A rigid transform `p ↦ r·p + t`.
#[derive(Clone, Copy, Debug)]
pub struct Rigid {
    r: M3,
    t: V3,
}

impl Rigid {
    const IDENTITY: Rigid = Rigid {
        r: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        t: [0.0; 3],
    };

    fn then(&self, next: &Rigid) -> Rigid {
        Rigid {
            r: mat_mul(&self.r, &next.r),
            t: add(mat_vec(&self.r, &next.t), self.t),
        }
    }

    fn apply(&self, p: V3) -> V3 {
        add(mat_vec(&self.r, &p), self.t)
    }
}

/// Joint i's transform `Rz(θ + q)·Tz(d)·Tx(a)·Rx(α)·Ry(β)` (`p` = θ, d, a, α, β in rad, mm).
fn joint_transform(p: &[f64; 5], q: f64) -> Rigid {
    let rz = rot_z(p[0] + q);
    Rigid {
        r: mat_mul(&rz, &mat_mul(&rot_x(p[3]), &rot_y(p[4]))),
        t: mat_vec(&rz, &[p[2], 0.0, p[1]]),
    }
}

/// Frames 0 … 6 of the chain `params` at the joint angles `q` (rad), in the base frame.
fn chain_frames(params: &[[f64; 5]; JOINTS], q: &[f64; JOINTS]) -> [Rigid; JOINTS + 1] {
    let mut f = [Rigid::IDENTITY; JOINTS + 1];
    for i in 0..JOINTS {
        f[i + 1] = f[i].then(&joint_transform(&params[i], q[i]));
    }
    f
}

/// The tool point of the geometric chain `params` (rad, mm) at `q` (rad), base frame, mm.
pub fn chain_position(params: &[[f64; 5]; JOINTS], tool: V3, q: &[f64; JOINTS]) -> V3 {
    chain_frames(params, q)[JOINTS].apply(tool)
}

/// The nominal TX60 table in radians and mm.
pub fn nominal_params() -> [[f64; 5]; JOINTS] {
    TX60_MDH.map(|row| {
        [
            row[0].to_radians(),
            row[1],
            row[2],
            row[3].to_radians(),
            row[4].to_radians(),
        ]
    })
}

/// A uniform draw in `lo..hi` with a random sign.
fn signed(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    let v = rng.random_range(lo..hi);
    if rng.random_bool(0.5) {
        v
    } else {
        -v
    }
}

/// One standard normal (Box–Muller).
fn normal(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = 1.0 - rng.random::<f64>();
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos()
}

/// A simulated TX60: geometry, tool, placement in the tracker frame, and its non-geometric
/// errors.
#[derive(Clone, Debug)]
pub struct TrueRobot {
    /// θ, d, a, α, β per joint (rad, mm).
    pub params: [[f64; 5]; JOINTS],
    /// Tracker target in the flange frame, mm.
    pub tool: V3,
    /// The base frame in the tracker frame.
    pub placement: Rigid,
    /// Joint stiffness inverse, rad/(N·m).
    pub compliance: [f64; JOINTS],
    /// A, φ, B, ψ of each joint's harmonics (rad).
    pub harmonics: [[f64; 4]; JOINTS],
}

impl TrueRobot {
    /// A random robot: every free parameter of the TX60 off by 0.1–0.3 mm or 0.01–0.03°, a
    /// target near (30, −20, 80) mm, a base turned by up to ±90° about z, tilted by up to ±2°
    /// and near (2000, 500, −300) mm in the tracker frame, and the non-geometric errors at
    /// `size` (0: a purely geometric robot). The draws do not depend on `size`, so one seed
    /// gives the same robot at every size with its non-geometric errors scaled.
    pub fn draw(size: f64, rng: &mut ChaCha8Rng) -> TrueRobot {
        let mut params = nominal_params();
        for (j, row) in params.iter_mut().enumerate() {
            for (k, v) in row.iter_mut().enumerate() {
                let fixed = if D_FIXED[j] { k == 1 } else { k == 4 };
                let length = k == 1 || k == 2;
                let e = if length {
                    signed(rng, 0.1, 0.3)
                } else {
                    signed(rng, 0.01, 0.03).to_radians()
                };
                if !fixed {
                    *v += e;
                }
            }
        }
        let tool = [30.0, -20.0, 80.0].map(|v: f64| v + rng.random_range(-1.0..1.0));
        let yaw = rng.random_range(-90.0f64..90.0).to_radians();
        let pitch = rng.random_range(-2.0f64..2.0).to_radians();
        let roll = rng.random_range(-2.0f64..2.0).to_radians();
        let t = [2000.0, 500.0, -300.0].map(|v: f64| v + rng.random_range(-100.0..100.0));
        let placement = Rigid {
            r: mat_mul(&rot_z(yaw), &mat_mul(&rot_y(pitch), &rot_x(roll))),
            t,
        };
        let compliance = [0; JOINTS].map(|_| rng.random_range(1.0..5.0) * 1e-6 * size);
        let harmonics = [0; JOINTS].map(|_| {
            let a = rng.random_range(0.002f64..0.01).to_radians() * size;
            let phi = rng.random_range(0.0..2.0 * PI);
            let b = rng.random_range(0.002f64..0.01).to_radians() * size;
            let psi = rng.random_range(0.0..2.0 * PI);
            [a, phi, b, psi]
        });
        TrueRobot {
            params,
            tool,
            placement,
            compliance,
            harmonics,
        }
    }

    /// Gravity torque about each joint's axis (N·m) of the links beyond it, at the joint
    /// angles `q` (rad): link i's mass at the middle of frames i − 1 and i (both points move
    /// with link i), gravity along −z of the base frame.
    pub fn gravity_torques(&self, q: &[f64; JOINTS]) -> [f64; JOINTS] {
        let f = chain_frames(&self.params, q);
        // Centres of mass in metres and weights in newtons.
        let centre = |i: usize| [0, 1, 2].map(|k| 0.5 * (f[i].t[k] + f[i + 1].t[k]) * 1e-3);
        let weight = |i: usize| [0.0, 0.0, -LINK_MASS_KG[i] * GRAVITY];
        std::array::from_fn(|i| {
            let origin = f[i].t.map(|v| v * 1e-3);
            let axis = [f[i].r[0][2], f[i].r[1][2], f[i].r[2][2]];
            (i..JOINTS)
                .map(|l| dot(cross(sub(centre(l), origin), weight(l)), axis))
                .sum()
        })
    }

    /// The joints' deflections (rad) at the commanded angles `q` (rad): harmonics plus
    /// compliance under the gravity torques at the angles the harmonics give.
    pub fn deflections(&self, q: &[f64; JOINTS]) -> [f64; JOINTS] {
        let harmonic: [f64; JOINTS] = std::array::from_fn(|i| {
            let [a, phi, b, psi] = self.harmonics[i];
            a * (q[i] + phi).sin() + b * (2.0 * q[i] + psi).sin()
        });
        let geared = std::array::from_fn(|i| q[i] + harmonic[i]);
        let tau = self.gravity_torques(&geared);
        std::array::from_fn(|i| harmonic[i] + self.compliance[i] * tau[i])
    }

    /// The target's true position in the tracker frame (mm) at the commanded angles `q_deg`.
    pub fn position(&self, q_deg: &[f64]) -> V3 {
        let q: [f64; JOINTS] = std::array::from_fn(|i| q_deg[i].to_radians());
        let dq = self.deflections(&q);
        let actual = std::array::from_fn(|i| q[i] + dq[i]);
        self.placement
            .apply(chain_position(&self.params, self.tool, &actual))
    }
}

/// `n` configurations (degrees) uniform in the TX60's limits without the outer 10 % of each
/// range.
pub fn configurations(n: usize, rng: &mut ChaCha8Rng) -> Vec<Joints> {
    (0..n)
        .map(|_| {
            TX60_LIMITS_DEG
                .iter()
                .map(|&(lo, hi)| {
                    let m = 0.1 * (hi - lo);
                    rng.random_range(lo + m..hi - m)
                })
                .collect()
        })
        .collect()
}

/// Checks this file's forward kinematics against the library's on the nominal TX60 and on
/// `extra` geometric chains at 200 random configurations each; panics on a difference above
/// 1e-9 mm. Returns the largest difference.
pub fn check_fk(extra: &[[[f64; 5]; JOINTS]]) -> f64 {
    let nominal = tx60();
    let mut rng = ChaCha8Rng::seed_from_u64(77);
    let mut worst: f64 = 0.0;
    let tool = [30.0, -20.0, 80.0];
    for params in std::iter::once(nominal_params()).chain(extra.iter().copied()) {
        let flat: Vec<f64> = params.iter().flatten().copied().collect();
        for q in configurations(200, &mut rng) {
            let q: [f64; JOINTS] = std::array::from_fn(|i| q[i].to_radians());
            let ours = chain_position(&params, tool, &q);
            let theirs = gpu_amcs::kinematics::position(&flat, &tool, &q);
            let d = distance(ours, theirs);
            assert!(d < 1e-9, "FK differs by {d} mm at {q:?}");
            worst = worst.max(d);
        }
    }
    // The library's preset is the table above.
    let lib: Vec<f64> = nominal.params.iter().copied().collect();
    let ours: Vec<f64> = nominal_params().iter().flatten().copied().collect();
    assert!(lib.iter().zip(&ours).all(|(a, b)| (a - b).abs() < 1e-12));
    worst
}

/// Measures `truth` at `configs` (degrees) with noise of `sigma` mm per coordinate.
pub fn measure(
    truth: &TrueRobot,
    configs: &[Joints],
    sigma: f64,
    rng: &mut ChaCha8Rng,
) -> PoseData {
    let points = configs
        .iter()
        .enumerate()
        .map(|(i, q)| PosePoint {
            payload_kg: 0.0,
            q_deg: *q,
            position_mm: truth.position(q).map(|v| v + sigma * normal(rng)),
            sigma_mm: None,
            line: i as u64 + 2,
            target: 0,
            sides: None,
        })
        .collect();
    PoseData {
        runs: vec![PoseRun { run: None, points }],
        ..Default::default()
    }
}

/// The model the library identifies from `data` as `IdentifyJob::run` does for a pose file
/// (placement identified, nominal prior, linearised covariance, seed 1) with
/// `--tracker-sigma σ` for `Some(σ)` (mm) and the noise estimated from the residuals for `None`:
/// `identify_data` then `identified_model`, without the file in between.
pub fn identify(data: PoseData, sigma_mm: Option<f64>) -> RobotModel {
    identify_with(data, sigma_mm, JointErrorFit::Auto)
}

/// [`identify`] with the joint errors fitted as `beyond` says (`--beyond-geometry`).
pub fn identify_with(data: PoseData, sigma_mm: Option<f64>, beyond: JointErrorFit) -> RobotModel {
    identify_selecting(data, sigma_mm, beyond).0
}

/// [`identify_with`], and which joint-error terms the fit beyond geometry kept (`None` when it
/// did not run).
pub fn identify_selecting(
    data: PoseData,
    sigma_mm: Option<f64>,
    beyond: JointErrorFit,
) -> (RobotModel, Option<TermSelection>) {
    let data = TrackerData::Poses(data);
    let nominal = tx60();
    let chain = ChainOptions {
        noise: NoiseModel::from_settings(sigma_mm, None, None, &data).unwrap(),
        beyond_geometry: beyond,
        ..ChainOptions::default()
    };
    let runs = identify_data(&data, &nominal, &IdentifyOptions::default(), &chain, false)
        .expect("the poses identify");
    let selection = runs[0]
        .report
        .chain
        .as_ref()
        .and_then(|c| c.beyond_geometry.as_ref())
        .map(|b| b.selection.clone());
    let model = identified_model(&runs, &nominal, false, "honesty poses")
        .unwrap()
        .0;
    (model, selection)
}

/// The errors `|p_true − p_model|` (mm) at `configs`, both in the tracker frame: the model's
/// prediction through its identified placement, with its compensation when it has one
/// (`RobotModel::compensated_world_position`, what a user of the model gets).
pub fn errors(truth: &TrueRobot, model: &RobotModel, configs: &[Joints]) -> Vec<f64> {
    errors_of(truth, configs, |q| model.compensated_world_position(q))
}

/// [`errors`] of the geometric model alone (`RobotModel::world_position`).
pub fn errors_geometric(truth: &TrueRobot, model: &RobotModel, configs: &[Joints]) -> Vec<f64> {
    errors_of(truth, configs, |q| model.world_position(q))
}

fn errors_of(
    truth: &TrueRobot,
    configs: &[Joints],
    predict: impl Fn(&[f64]) -> [f64; 3],
) -> Vec<f64> {
    configs
        .iter()
        .map(|q| {
            let rad: Vec<f64> = q.iter().map(|v| v.to_radians()).collect();
            distance(truth.position(q), predict(&rad))
        })
        .collect()
}

/// What one experiment gives.
#[derive(Clone, Copy, Debug)]
pub struct Outcome {
    /// The realised largest error over the task points, mm.
    pub w_true: f64,
    /// RMS of the errors over the task points, mm (the model's prediction, compensated when
    /// the model has a compensation).
    pub rms: f64,
    /// The same of the geometric model alone.
    pub rms_geometric: f64,
    /// Whether the identified model carries a compensation.
    pub compensated: bool,
    /// `R_pred(w_true)`: the share of the predicted draws with `w ≤ w_true`.
    pub u: f64,
    /// `u` of the prediction from the parameters' uncertainty alone (the problem without the
    /// discrepancy term: what the reliability was before the term).
    pub u_parameters: f64,
    /// The median of the predicted `w`, mm.
    pub w_median: f64,
    /// Whether the identified model's discrepancy term is drawn (a lack of fit was found
    /// against the stated noise: `Discrepancy::drawn`).
    pub discrepancy: bool,
    /// The robot's part of the term, RMS, mm (0 without one drawn).
    pub term_rms_mm: f64,
}

/// One experiment at non-geometric size `size`: a robot drawn from `seed`, identified from
/// [`CALIBRATION_POSES`] poses measured with [`TRACKER_SIGMA_MM`] noise (stated), its largest
/// error over [`TASK_POINTS`] task points, and `R_pred` there from `draws` draws of the model's
/// uncertainty (measurement frame: the placement drawn; the model's discrepancy term drawn
/// when it has one).
pub fn experiment(size: f64, seed: u64, draws: usize) -> Outcome {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let truth = TrueRobot::draw(size, &mut rng);
    let calibration = configurations(CALIBRATION_POSES, &mut rng);
    let data = measure(&truth, &calibration, TRACKER_SIGMA_MM, &mut rng);
    let task = configurations(TASK_POINTS, &mut rng);
    let model = identify(data, Some(TRACKER_SIGMA_MM));
    let e = errors(&truth, &model, &task);
    let w_true = e.iter().copied().fold(0.0, f64::max);
    let rms_of = |e: &[f64]| (e.iter().map(|v| v * v).sum::<f64>() / e.len() as f64).sqrt();
    let rms = rms_of(&e);
    let rms_geometric = rms_of(&errors_geometric(&truth, &model, &task));
    let compensated = model.compensated();
    let term = model.discrepancy.as_ref().filter(|d| d.drawn());
    let discrepancy = term.is_some();
    let term_rms_mm = term.map_or(0.0, |d| d.robot_rms_mm());
    let task_deg: Vec<Vec<f64>> = task.iter().map(|q| q.to_vec()).collect();
    let problem = Problem::new(model, &task_deg, &Reference::Calibrated, seed).unwrap();
    let draw = |problem: Problem| {
        let mut w = vec![0.0; draws];
        CpuEvaluator::new(problem)
            .evaluate(0, &mut w, None)
            .unwrap();
        w
    };
    let pit = |w: &[f64]| w.iter().filter(|&&v| v <= w_true).count() as f64 / draws as f64;
    let u_parameters = pit(&draw(problem.clone().without_discrepancy()));
    let mut w = draw(problem);
    let u = pit(&w);
    w.sort_by(f64::total_cmp);
    Outcome {
        w_true,
        rms,
        rms_geometric,
        compensated,
        u,
        u_parameters,
        w_median: w[draws / 2],
        discrepancy,
        term_rms_mm,
    }
}
