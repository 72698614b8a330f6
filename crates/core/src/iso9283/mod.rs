//! ISO 9283 pose accuracy and pose repeatability (position part) of measured cycles, and the
//! reliability certificate at the test poses (docs/METHOD.md §16).
//!
//! The robot visits each test pose from the same command `n` times (the standard asks for 30
//! cycles); the tracker records the attained positions `x_i`. With the commanded position `x_c`
//! (the model's forward kinematics at the commanded configuration, in the frame of the
//! measurements) and the barycentre `x̄ = (1/n) Σ x_i`:
//!
//! * **pose accuracy** `AP = |x̄ − x_c|`, with its components `AP_x = x̄ − x_c` and so on;
//! * **pose repeatability** `RP = l̄ + 3 S_l`, with `l_i = |x_i − x̄|`, `l̄ = (1/n) Σ l_i` and
//!   `S_l = √(Σ (l_i − l̄)² / (n − 1))`.
//!
//! Only positions are measured here, so the orientation parts (AP_a, AP_b, AP_c and RP_a …) are
//! not computed. The cycles of one pose are the rows of the measurement file that share one
//! commanded configuration, numbered in the order they first appear (P1, P2, …).
//!
//! **Certificate.** AP at pose `j` is, up to the average of the cycles' scatter, the calibrated
//! model's remaining error at that pose, `e_j` of the reliability analysis. So the probability
//! that a robot calibrated with this model's uncertainty meets a specification `AP_j ≤ s` is
//! `Pr[e_j ≤ s]`, and at all poses together `R(s)` with the poses as the test points: the
//! engine's own quantities, which the command line computes at the test poses.

mod certify;
mod report;

pub use certify::{
    barycentre_standard_error, certify, certify_with_progress, largest_predicted, CertifyError,
    CHECK_DRAWS, CHECK_STANDARD_ERRORS,
};
pub use report::PoseReport;

use crate::engine::CpuEvaluator;
use crate::identify::validate::Measurement;
use crate::identify::Placement;
use crate::kinematics::{Joints, RobotModel};
use crate::mc::{run_mcs, McsOptions, Reliability, RunSettings};
use crate::progress::ProgressHook;

/// Fewest cycles per pose (the standard asks for 30; two give a spread).
pub const MIN_CYCLES: usize = 2;

/// The figures of one test pose, mm.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PoseFigures {
    /// 1-based pose number, in the order the poses first appear.
    pub pose: usize,
    /// The commanded configuration, degrees (one angle per joint).
    pub q_deg: Joints,
    /// Number of cycles.
    pub cycles: usize,
    /// Commanded position (the model's forward kinematics).
    pub command_mm: [f64; 3],
    /// Barycentre of the attained positions.
    pub barycentre_mm: [f64; 3],
    /// Pose accuracy AP = |x̄ − x_c|.
    pub ap_mm: f64,
    /// Its components x̄ − x_c, ȳ − y_c, z̄ − z_c.
    pub ap_xyz_mm: [f64; 3],
    /// Mean distance l̄ of the attained positions from their barycentre.
    pub l_mean_mm: f64,
    /// Standard deviation S_l of those distances (n − 1).
    pub s_l_mm: f64,
    /// Pose repeatability RP = l̄ + 3 S_l.
    pub rp_mm: f64,
    /// Line of the pose's first cycle in the file.
    pub first_line: u64,
}

impl PoseFigures {
    /// The figures in table order: AP, AP_x, AP_y, AP_z, l̄, S_l, RP (mm).
    pub fn values(&self) -> [f64; 7] {
        [
            self.ap_mm,
            self.ap_xyz_mm[0],
            self.ap_xyz_mm[1],
            self.ap_xyz_mm[2],
            self.l_mean_mm,
            self.s_l_mm,
            self.rp_mm,
        ]
    }
}

/// Errors of the ISO 9283 figures.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum Iso9283Error {
    /// A pose has fewer cycles than [`MIN_CYCLES`].
    #[error("pose {pose} (first at line {line}) has {cycles} cycle(s): a repeatability needs at least {MIN_CYCLES} (ISO 9283 asks for 30)")]
    TooFewCycles {
        /// The pose.
        pose: usize,
        /// Its first line.
        line: u64,
        /// Its cycles.
        cycles: usize,
    },
    /// No rows.
    #[error("no measured cycles")]
    Empty,
    /// A row has another number of joint angles than the model has joints.
    #[error("line {line}: {angles} joint angles, the model {model} has {joints} joints")]
    JointCount {
        /// The row's line.
        line: u64,
        /// Its joint angles.
        angles: usize,
        /// The model's name.
        model: String,
        /// The model's joints.
        joints: usize,
    },
}

/// The AP and RP of every pose of `cycles` (the measurement file's rows, grouped by commanded
/// configuration), with the commanded positions from `model` in `frame`: the measurement frame
/// ([`Placement::Identify`], the model's placement applies) or the robot base frame.
///
/// # Errors
///
/// [`Iso9283Error::Empty`] without rows, [`Iso9283Error::JointCount`] naming the first row whose
/// joint angles are not one per joint of `model`, [`Iso9283Error::TooFewCycles`] naming a pose
/// with fewer than [`MIN_CYCLES`] cycles.
///
/// # Examples
///
/// Three cycles at each of two TX60 poses, in the base frame: the robot lands 0.1 mm off in x
/// on average, spread ±0.02 mm in y.
///
/// ```
/// use gpu_amcs_core::identify::{Measurement, Placement};
/// use gpu_amcs_core::iso9283::{pose_figures, Iso9283Error};
/// use gpu_amcs_core::kinematics::{position_deg, tx60};
///
/// let model = tx60();
/// let poses = [model.joints_at(0.0), model.joints_at(20.0)];
/// let mut cycles = Vec::new();
/// for q in poses {
///     let c = position_deg(&model.params, &model.tool, &q);
///     for dy in [0.0, 0.02, -0.02] {
///         cycles.push(Measurement {
///             payload_kg: None,
///             q_deg: q,
///             position_mm: [c[0] + 0.1, c[1] + dy, c[2]],
///             line: cycles.len() as u64 + 2,
///             target: None,
///             on_base: false,
///             sides: None,
///         });
///     }
/// }
/// let figures = pose_figures(&model, &cycles, Placement::Known)?;
/// assert_eq!(figures.len(), 2);
/// for (p, f) in figures.iter().enumerate() {
///     assert_eq!((f.pose, f.cycles), (p + 1, 3));
///     assert!((f.ap_mm - 0.1).abs() < 1e-9); // AP = |x̄ − x_c|
///     assert!((f.ap_xyz_mm[0] - 0.1).abs() < 1e-9);
///     assert!((f.l_mean_mm - 0.04 / 3.0).abs() < 1e-9); // l = 0, 0.02, 0.02
///     assert!((f.rp_mm - (f.l_mean_mm + 3.0 * f.s_l_mm)).abs() < 1e-12);
/// }
///
/// // A pose measured once has no repeatability.
/// let err = pose_figures(&model, &cycles[..4], Placement::Known).unwrap_err();
/// assert_eq!(err, Iso9283Error::TooFewCycles { pose: 2, line: 5, cycles: 1 });
/// # Ok::<(), Iso9283Error>(())
/// ```
pub fn pose_figures(
    model: &RobotModel,
    cycles: &[Measurement],
    frame: Placement,
) -> Result<Vec<PoseFigures>, Iso9283Error> {
    if cycles.is_empty() {
        return Err(Iso9283Error::Empty);
    }
    if let Some(m) = cycles.iter().find(|m| m.q_deg.len() != model.joints()) {
        return Err(Iso9283Error::JointCount {
            line: m.line,
            angles: m.q_deg.len(),
            model: model.name.clone(),
            joints: model.joints(),
        });
    }
    // Poses in order of first appearance; exact equality of the commanded angles (a robot
    // program repeats one command).
    let mut groups: Vec<(usize, Vec<&Measurement>)> = Vec::new();
    for m in cycles {
        match groups.iter_mut().find(|(_, g)| g[0].q_deg == m.q_deg) {
            Some((_, g)) => g.push(m),
            None => groups.push((groups.len() + 1, vec![m])),
        }
    }
    groups
        .into_iter()
        .map(|(pose, g)| {
            let n = g.len();
            if n < MIN_CYCLES {
                return Err(Iso9283Error::TooFewCycles {
                    pose,
                    line: g[0].line,
                    cycles: n,
                });
            }
            let q = g[0].q_deg.map(f64::to_radians);
            let command = match frame {
                Placement::Identify => model.compensated_world_position(&q),
                Placement::Known => model.compensated_position(&q),
            };
            let bary: [f64; 3] =
                std::array::from_fn(|k| g.iter().map(|m| m.position_mm[k]).sum::<f64>() / n as f64);
            let ap_xyz: [f64; 3] = std::array::from_fn(|k| bary[k] - command[k]);
            let l: Vec<f64> = g
                .iter()
                .map(|m| {
                    (0..3)
                        .map(|k| (m.position_mm[k] - bary[k]).powi(2))
                        .sum::<f64>()
                        .sqrt()
                })
                .collect();
            let l_mean = l.iter().sum::<f64>() / n as f64;
            let s_l = (l.iter().map(|v| (v - l_mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt();
            Ok(PoseFigures {
                pose,
                q_deg: g[0].q_deg,
                cycles: n,
                command_mm: command,
                barycentre_mm: bary,
                ap_mm: ap_xyz.iter().map(|v| v * v).sum::<f64>().sqrt(),
                ap_xyz_mm: ap_xyz,
                l_mean_mm: l_mean,
                s_l_mm: s_l,
                rp_mm: l_mean + 3.0 * s_l,
                first_line: g[0].line,
            })
        })
        .collect()
}

/// The reliability certificate at the test poses: for a specification `spec` (mm),
/// `Pr[AP_j ≤ spec]` at each pose and at all of them together, from the model's uncertainty by
/// Monte Carlo (`draws` draws of `seed`) with the poses as the test points.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Certificate {
    /// The specification, mm.
    pub spec_mm: f64,
    /// Draws of the Monte Carlo run.
    pub draws: u64,
    /// `Pr[AP_j ≤ spec]` per pose, with its 95 % binomial interval.
    pub per_pose: Vec<Reliability>,
    /// `Pr[AP_j ≤ spec at every pose]`.
    pub all: Reliability,
}

/// The certificate of `model`'s uncertainty at the configurations `poses` (degrees): the
/// reliability of the calibrated robot at the test poses (see the module docs). `frame` as in
/// [`pose_figures`]: in the robot base frame the model's placement uncertainty is left out.
///
/// # Errors
///
/// [`CertificateError`] when the problem cannot be built (an invalid model or pose) or the run
/// fails (e.g. a threshold that is not a positive length).
pub fn certificate(
    model: &RobotModel,
    poses: &[Joints],
    spec_mm: f64,
    frame: Placement,
    draws: u64,
    seed: u64,
) -> Result<Certificate, CertificateError> {
    certificate_with_progress(
        model,
        poses,
        spec_mm,
        frame,
        draws,
        seed,
        &ProgressHook::none(),
    )
}

/// [`certificate`], telling `progress` the draws done of `draws` chunk by chunk (label
/// `certificate`).
///
/// # Errors
///
/// As [`certificate`].
pub fn certificate_with_progress(
    model: &RobotModel,
    poses: &[Joints],
    spec_mm: f64,
    frame: Placement,
    draws: u64,
    seed: u64,
    progress: &ProgressHook,
) -> Result<Certificate, CertificateError> {
    let mut ev = CpuEvaluator::new(certify::problem(model, poses, frame, seed)?);
    let opts = McsOptions {
        draws,
        settings: RunSettings {
            thresholds: vec![spec_mm],
            per_point: true,
            ..RunSettings::default()
        },
        ..McsOptions::default()
    };
    progress.report("certificate", 0, draws);
    let tell = |done: u64, total: u64| progress.report("certificate", done, total);
    let r = run_mcs(&mut ev, &opts, Some(&tell)).map_err(|e| CertificateError(e.to_string()))?;
    Ok(Certificate {
        spec_mm,
        draws,
        per_pose: r
            .per_point_reliability
            .unwrap_or_default()
            .into_iter()
            .filter_map(|v| v.into_iter().next())
            .collect(),
        all: r.reliability[0],
    })
}

/// The certificate could not be computed.
#[derive(Debug, thiserror::Error, PartialEq)]
#[error("certificate: {0}")]
pub struct CertificateError(pub String);

/// The certificate as text.
pub fn render_certificate(c: &Certificate) -> String {
    let mut s = format!(
        "certificate: Pr[AP ≤ {} mm] from the model's uncertainty ({} draws)\n",
        crate::number::fmt_plain(c.spec_mm),
        c.draws
    );
    for (j, r) in c.per_pose.iter().enumerate() {
        s.push_str(&format!(
            "  P{:<4}{:>10.4}  [{:.4}, {:.4}]\n",
            j + 1,
            r.r,
            r.ci_low,
            r.ci_high
        ));
    }
    s.push_str(&format!(
        "  all {:>10.4}  [{:.4}, {:.4}]\n",
        c.all.r, c.all.ci_low, c.all.ci_high
    ));
    s
}

/// The figures as a table, one line per pose.
pub fn render(figures: &[PoseFigures]) -> String {
    let mut s = String::from(
        "ISO 9283 pose accuracy and repeatability (positions, mm)\n  pose  cycles        AP      AP_x      AP_y      AP_z        l̄       S_l        RP\n",
    );
    for f in figures {
        s.push_str(&format!("  P{:<4}{:>6}", f.pose, f.cycles));
        for v in f.values() {
            s.push_str(&format!("{v:>10.4}"));
        }
        s.push('\n');
    }
    s
}

#[cfg(test)]
mod tests;

/// The ISO 9283 test cube placed in a robot's working space, and its five test poses.
///
/// What the standard's public descriptions say, and what is assumed here where they are thin:
/// the cube is the largest one in the working space with its edges parallel to the robot base
/// frame (the frame of the model's joint chain; searched with its centre in the x–z half-plane
/// in front of the robot, y = 0); the poses lie
/// on the diagonal plane through the cube's corners C1 = (−,−,−), C2 = (+,−,−), C7 = (+,+,+) and
/// C8 = (−,+,+) (half-edges from the centre); P1 is the centre and P2 … P5 lie on that plane's
/// diagonals at 10 % of a diagonal's length from C1, C2, C7 and C8; every pose has one stated
/// flange orientation (default: the tool pointing down), and all eight corners must be
/// reachable with it too.
///
/// Positions and the orientation are in the world frame, the frame `fk` reports in: the robot
/// base frame moved by the model's base transform when it has one (the KR 6's turns its chain
/// upside down: Rx(180°)), as a workspace box or a map's targets are.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct TestCube {
    /// Centre, mm, world frame.
    pub centre_mm: [f64; 3],
    /// Edge length, mm.
    pub edge_mm: f64,
    /// Flange orientation of every pose (roll, pitch, yaw in degrees, world frame), `None` for
    /// position only.
    pub rpy_deg: Option<[f64; 3]>,
    /// P1 … P5, mm, world frame.
    pub poses_mm: [[f64; 3]; 5],
    /// P1 … P5 as joint angles, degrees (one angle per joint).
    pub poses_q_deg: [Joints; 5],
}

/// The corners C1, C2, C7, C8 of the test plane and P1 … P5 of a cube.
fn cube_points(c: [f64; 3], edge: f64) -> ([[f64; 3]; 8], [[f64; 3]; 5]) {
    let h = edge / 2.0;
    let corner = |sx: f64, sy: f64, sz: f64| [c[0] + sx * h, c[1] + sy * h, c[2] + sz * h];
    let all = [
        corner(-1.0, -1.0, -1.0),
        corner(1.0, -1.0, -1.0),
        corner(1.0, 1.0, -1.0),
        corner(-1.0, 1.0, -1.0),
        corner(-1.0, -1.0, 1.0),
        corner(1.0, -1.0, 1.0),
        corner(1.0, 1.0, 1.0),
        corner(-1.0, 1.0, 1.0),
    ];
    // The plane's corners C1, C2, C7, C8; 10 % of the diagonal from a corner is a fifth of the
    // way to the centre.
    let plane = [all[0], all[1], all[6], all[7]];
    let towards = |p: [f64; 3]| std::array::from_fn(|k| p[k] + 0.2 * (c[k] - p[k]));
    (
        all,
        [
            c,
            towards(plane[0]),
            towards(plane[1]),
            towards(plane[2]),
            towards(plane[3]),
        ],
    )
}

/// The IK solutions of the five poses when all eight corners and the five poses are reachable.
fn cube_solution(
    ik: &crate::map::ik::Ik,
    rotation: Option<crate::map::ik::Rot3>,
    c: [f64; 3],
    edge: f64,
) -> Option<[Joints; 5]> {
    let (corners, poses) = cube_points(c, edge);
    let solve = |p: [f64; 3]| {
        ik.solve(
            &crate::map::ik::IkTarget {
                position: p,
                rotation,
            },
            &[],
        )
    };
    if !corners.iter().all(|&p| solve(p).is_some()) {
        return None;
    }
    // Every slot is set below (a solution has one angle per joint of the model).
    let mut q = [Joints::default(); 5];
    for (k, p) in poses.iter().enumerate() {
        q[k] = solve(*p)?.q.map(f64::to_degrees);
    }
    Some(q)
}

/// Places the ISO 9283 test cube of `model` (see [`TestCube`]) with the flange orientation
/// `rpy_deg` (world frame; `None`: position only): a coarse search over centres in front of the
/// robot, the largest edge at each by bisection, then a finer search around the best centre.
///
/// # Errors
///
/// [`CertificateError`] when no cube of at least 1 mm has all its corners and poses reachable.
pub fn test_cube(
    model: &RobotModel,
    rpy_deg: Option<[f64; 3]>,
) -> Result<TestCube, CertificateError> {
    let reference = crate::map::default_reference_deg(model).map(f64::to_radians);
    let ik = crate::map::ik::Ik::new(model, reference, 0);
    let rotation = rpy_deg.map(|r| crate::map::rotation_in_base(model, r));
    let reach = crate::map::ik::reach_bound(model).max(1.0);
    let d1 = model.params[1];
    let largest = |c: [f64; 3], hi: f64, steps: usize| -> f64 {
        let (mut lo, mut hi) = (0.0, hi);
        if cube_solution(&ik, rotation, c, 1.0).is_none() {
            return 0.0;
        }
        for _ in 0..steps {
            let mid = 0.5 * (lo + hi);
            if cube_solution(&ik, rotation, c, mid).is_some() {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        lo
    };
    use rayon::prelude::*;
    let coarse: Vec<[f64; 3]> = (0..8)
        .flat_map(|i| {
            (0..9).map(move |k| {
                [
                    reach * (0.15 + 0.1 * i as f64),
                    0.0,
                    d1 + reach * (-0.4 + 0.1 * k as f64),
                ]
            })
        })
        .collect();
    let best = |centres: &[[f64; 3]], steps: usize| {
        centres
            .par_iter()
            .map(|&c| (largest(c, reach, steps), c))
            .max_by(|a, b| a.0.total_cmp(&b.0).then(b.1[0].total_cmp(&a.1[0])))
            .unwrap_or((0.0, [0.0; 3]))
    };
    // Coarse: the edge to reach/64; fine: to reach/1024.
    let (edge0, c0) = best(&coarse, 6);
    let step = 0.1 * reach;
    let fine: Vec<[f64; 3]> = (-2..=2)
        .flat_map(|i| {
            (-2..=2).map(move |k| {
                [
                    c0[0] + 0.25 * step * i as f64,
                    0.0,
                    c0[2] + 0.25 * step * k as f64,
                ]
            })
        })
        .collect();
    let (edge1, c1) = best(&fine, 10);
    let (edge, centre) = if edge1 >= edge0 {
        (edge1, c1)
    } else {
        (edge0, c0)
    };
    if edge < 1.0 {
        return Err(CertificateError(format!(
            "no test cube of 1 mm or more with every corner and pose reachable{}",
            if rpy_deg.is_some() {
                " at the stated orientation"
            } else {
                ""
            }
        )));
    }
    let q = cube_solution(&ik, rotation, centre, edge).ok_or_else(|| {
        CertificateError("the cube found is not reachable on a second solve".into())
    })?;
    let world = |p: [f64; 3]| model.base.as_ref().map_or(p, |b| b.apply(p));
    Ok(TestCube {
        centre_mm: world(centre),
        edge_mm: edge,
        rpy_deg,
        poses_mm: cube_points(centre, edge).1.map(world),
        poses_q_deg: q,
    })
}
