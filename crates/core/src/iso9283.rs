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

use crate::engine::{CpuEvaluator, Problem, Reference};
use crate::identify::validate::Measurement;
use crate::identify::Placement;
use crate::kinematics::{position, RobotModel, JOINTS};
use crate::mc::{run_mcs, McsOptions, Reliability, RunSettings};

/// Fewest cycles per pose (the standard asks for 30; two give a spread).
pub const MIN_CYCLES: usize = 2;

/// The figures of one test pose, mm.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PoseFigures {
    /// 1-based pose number, in the order the poses first appear.
    pub pose: usize,
    /// The commanded configuration, degrees.
    pub q_deg: [f64; JOINTS],
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
}

/// The AP and RP of every pose of `cycles` (the measurement file's rows, grouped by commanded
/// configuration), with the commanded positions from `model` in `frame`: the measurement frame
/// ([`Placement::Identify`], the model's placement applies) or the robot base frame.
///
/// # Errors
///
/// [`Iso9283Error::Empty`] without rows, [`Iso9283Error::TooFewCycles`] naming a pose with fewer
/// than [`MIN_CYCLES`] cycles.
pub fn pose_figures(
    model: &RobotModel,
    cycles: &[Measurement],
    frame: Placement,
) -> Result<Vec<PoseFigures>, Iso9283Error> {
    if cycles.is_empty() {
        return Err(Iso9283Error::Empty);
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
                Placement::Identify => model.world_position(&q),
                Placement::Known => position(&model.params, &model.tool, &q),
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
    poses: &[[f64; JOINTS]],
    spec_mm: f64,
    frame: Placement,
    draws: u64,
    seed: u64,
) -> Result<Certificate, CertificateError> {
    let mut problem = Problem::new(model.clone(), poses, &Reference::Calibrated, seed)
        .map_err(|e| CertificateError(e.to_string()))?;
    if frame == Placement::Known {
        problem = problem.without_placement();
    }
    let mut ev = CpuEvaluator::new(problem);
    let opts = McsOptions {
        draws,
        settings: RunSettings {
            thresholds: vec![spec_mm],
            per_point: true,
            ..RunSettings::default()
        },
        ..McsOptions::default()
    };
    let r = run_mcs(&mut ev, &opts, None).map_err(|e| CertificateError(e.to_string()))?;
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
        s.push_str(&format!(
            "  P{:<4}{:>6}{:>10.4}{:>10.4}{:>10.4}{:>10.4}{:>10.4}{:>10.4}{:>10.4}\n",
            f.pose,
            f.cycles,
            f.ap_mm,
            f.ap_xyz_mm[0],
            f.ap_xyz_mm[1],
            f.ap_xyz_mm[2],
            f.l_mean_mm,
            f.s_l_mm,
            f.rp_mm
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::tx60;

    fn cycle(q: [f64; JOINTS], p: [f64; 3], line: u64) -> Measurement {
        Measurement {
            q_deg: q,
            position_mm: p,
            line,
        }
    }

    /// Known answers worked by hand. Pose 1: 30 cycles on a circle of radius 0.02 mm around the
    /// command moved by (0.03, −0.04, 0): barycentre = centre, so AP = 0.05 and AP_x = 0.03; every
    /// l_i = 0.02, so S_l = 0 and RP = 0.02. Pose 2: 4 cycles at ±0.01 and ±0.03 mm along x
    /// around the command: AP = 0, l = (0.01, 0.01, 0.03, 0.03), l̄ = 0.02, S_l = √(4·0.0001/3),
    /// RP = 0.02 + 3·0.011547 = 0.054641.
    #[test]
    fn known_offset_and_spread_give_the_hand_figures() {
        let m = tx60();
        let q1 = [10.0, -20.0, 90.0, 0.0, 30.0, 0.0];
        let q2 = [-30.0, 10.0, 70.0, 20.0, -40.0, 60.0];
        let c1 = position(&m.params, &m.tool, &q1.map(f64::to_radians));
        let c2 = position(&m.params, &m.tool, &q2.map(f64::to_radians));
        let mut rows = Vec::new();
        for i in 0..30 {
            let t = i as f64 * std::f64::consts::TAU / 30.0;
            rows.push(cycle(
                q1,
                [
                    c1[0] + 0.03 + 0.02 * t.cos(),
                    c1[1] - 0.04 + 0.02 * t.sin(),
                    c1[2],
                ],
                2 + 2 * i,
            ));
            if i < 4 {
                let dx = [0.01, -0.01, 0.03, -0.03][i as usize];
                rows.push(cycle(q2, [c2[0] + dx, c2[1], c2[2]], 3 + 2 * i));
            }
        }
        let f = pose_figures(&m, &rows, Placement::Known).unwrap();
        assert_eq!(f.len(), 2);
        assert_eq!((f[0].pose, f[0].cycles, f[1].cycles), (1, 30, 4));
        assert!((f[0].ap_mm - 0.05).abs() < 1e-12, "{}", f[0].ap_mm);
        assert!((f[0].ap_xyz_mm[0] - 0.03).abs() < 1e-12);
        assert!((f[0].ap_xyz_mm[1] + 0.04).abs() < 1e-12);
        assert!((f[0].rp_mm - 0.02).abs() < 1e-12, "{}", f[0].rp_mm);
        assert!(f[0].s_l_mm < 1e-12);
        assert!(f[1].ap_mm < 1e-12);
        assert!((f[1].l_mean_mm - 0.02).abs() < 1e-12);
        let s = (4.0 * 1e-4 / 3.0f64).sqrt();
        assert!((f[1].s_l_mm - s).abs() < 1e-12);
        assert!((f[1].rp_mm - (0.02 + 3.0 * s)).abs() < 1e-12);
        assert_eq!(f[1].first_line, 3);
        // A pose with one cycle has no repeatability.
        let one = [rows[0].clone(), rows[2].clone(), cycle(q2, c2, 99)];
        assert_eq!(
            pose_figures(&m, &one, Placement::Known),
            Err(Iso9283Error::TooFewCycles {
                pose: 2,
                line: 99,
                cycles: 1
            })
        );
        assert_eq!(
            pose_figures(&m, &[], Placement::Known),
            Err(Iso9283Error::Empty)
        );
    }

    /// A tool point uncertain in x alone (σ = 0.01 mm) moves every pose by the same |δx|: at
    /// s = 0.0196 mm (1.96 σ) each pose and all five together have Pr = 0.95 within the
    /// binomial interval.
    #[test]
    fn certificate_of_a_tool_spread_has_its_closed_form() {
        let mut m = tx60();
        m.uncertainty = crate::kinematics::Uncertainty::Independent([0.0; 30]);
        m.tool_sigma = [0.01, 0.0, 0.0];
        let poses = [
            [10.0, -20.0, 90.0, 0.0, 30.0, 0.0],
            [-30.0, 10.0, 70.0, 20.0, -40.0, 60.0],
            [40.0, 0.0, 100.0, -10.0, 50.0, 0.0],
        ];
        let c = certificate(&m, &poses, 0.0196, Placement::Known, 100_000, 7).unwrap();
        assert_eq!(c.per_pose.len(), 3);
        for r in c.per_pose.iter().chain([&c.all]) {
            assert!((r.ci_low..=r.ci_high).contains(&0.95), "{r:?}");
            assert!((r.r - 0.95).abs() < 0.004, "{r:?}");
        }
        assert!(render_certificate(&c).contains("all"));
    }
}
