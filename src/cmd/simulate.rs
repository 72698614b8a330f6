//! `simulate`: calibration data of a virtual robot measured by a laser tracker: circle-point
//! sweeps, or with `--poses N` the target at N random (or given) configurations, in the
//! tracker's own frame.

use super::outputs::Outputs;
use super::Run;
use crate::cmd::args::{three_values, FactorArgs, MemoryArgs};
use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use gpu_amcs::memory::Estimate;
use gpu_amcs::simulate::{
    random_placement, simulate_poses_sided, Experiment, NonGeometricSetting, NonGeometricSizes,
    TrackerNoise,
};
use std::path::PathBuf;

/// Where the robot base stands in the tracker's frame.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlacementArg {
    /// A seeded random placement 1.5–4 m from the tracker, any heading, tilted up to ±10°.
    Random,
    /// The tracker frame is the robot base frame.
    Base,
}

/// The true robot's errors beyond geometry (issue 33), shared by `simulate` and `calibrate`.
#[derive(Args, Debug, Clone, Default)]
pub struct NonGeometricArgs {
    /// Joint compliance of the true robot under gravity and payload, as a scale S in 0–10 (0:
    /// rigid joints; 1: a 60 kg-class arm, 1–5·10⁻⁶ rad/(N·m) per joint drawn from
    /// --robot-seed, link masses of a TX60-class arm scaled to the robot's size: plausible, not
    /// published).
    #[arg(long, default_value_t = 0.0, value_name = "S")]
    pub compliance: f64,
    /// Gear harmonics of the true robot (once and twice per joint turn), as a scale S in 0–10
    /// (0: none; 1: amplitudes of 0.002–0.01° drawn from --robot-seed, random phases).
    #[arg(long, default_value_t = 0.0, value_name = "S")]
    pub harmonics: f64,
    /// Payload at the target, kg (0–1000), bending the compliant joints (needs --compliance);
    /// with --poses a list carried in turn, pose k the k-th (poses at two payloads tell a
    /// joint's compliance from a harmonic of the same shape); the file's payload_kg column
    /// records each.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "0",
        value_name = "KG[,KG...]"
    )]
    pub payload_kg: Vec<f64>,
    /// Gear backlash of the true robot as a scale S in 0–10 (0: none; 1: gaps of 0.05, 0.03,
    /// 0.02, 0.01, 0.02, 0.02° on joints 1–6, plausible for a 60 kg-class arm): each joint
    /// stands half its gap beyond the commanded angle on the side it arrived from, taken from
    /// the order of the poses (or a --points-file's s1..sn); the file's s1..sn columns record
    /// the sides. Pose data only (--poses).
    #[arg(long, default_value_t = 0.0, value_name = "S")]
    pub backlash: f64,
}

impl NonGeometricArgs {
    /// Whether any error beyond geometry is asked for.
    pub fn any(&self) -> bool {
        !self.sizes().is_geometric()
    }

    fn sizes(&self) -> NonGeometricSizes {
        NonGeometricSizes {
            compliance: self.compliance,
            harmonics: self.harmonics,
            payload_kg: self.payload_kg.first().copied().unwrap_or(0.0),
            backlash: self.backlash,
        }
    }

    /// The payloads the poses carry in turn (one: every pose).
    pub fn payloads(&self) -> &[f64] {
        &self.payload_kg
    }

    /// Gives `exp`'s true robot these errors, drawn from `robot_seed`; an error names the flag.
    /// Several payloads need `poses` (sweeps are measured at one).
    pub fn apply(&self, exp: &mut Experiment, robot_seed: u64, poses: bool) -> Result<()> {
        if self.backlash != 0.0 && !poses {
            bail!(
                "--backlash: simulated for pose data (simulate --poses): along a sweep's arc every point arrives from the same side"
            );
        }
        if self.payload_kg.len() > 1 && !poses {
            bail!(
                "--payload-kg: several payloads are carried pose by pose: they need --poses (sweeps are measured at one payload)"
            );
        }
        // Every payload of the list within range (the robot is drawn with the first).
        for &kg in self.payload_kg.iter().skip(1) {
            NonGeometricSizes {
                payload_kg: kg,
                ..self.sizes()
            }
            .check()
            .map_err(|e| anyhow::anyhow!("--payload-kg: {e}"))?;
        }
        exp.set_nongeometric(&self.sizes(), robot_seed)
            .map_err(|e| {
                let flag = match e.setting {
                    NonGeometricSetting::Compliance => "--compliance",
                    NonGeometricSetting::Harmonics => "--harmonics",
                    NonGeometricSetting::Payload => "--payload-kg",
                    NonGeometricSetting::Backlash => "--backlash",
                };
                anyhow::anyhow!("{flag}: {e}")
            })?;
        if self.payload_kg.iter().any(|&kg| kg > 0.0) && self.compliance == 0.0 {
            bail!(
                "--payload-kg: the payload acts only through the joints' compliance: give --compliance too"
            );
        }
        Ok(())
    }
}

/// Bytes a simulated pose keeps beside its CSV line: its configuration and the pose itself.
const POSE_BYTES: u64 = (std::mem::size_of::<gpu_amcs::kinematics::Joints>()
    + std::mem::size_of::<gpu_amcs::identify::PosePoint>()) as u64;

/// Bytes of one pose's CSV line at most: up to 24 characters per number (`-0.00012345678901234`
/// and a comma), one per joint, three for the position and three for stated σ.
fn pose_line_bytes(joints: u64) -> u64 {
    24 * (joints + 6)
}

/// `simulate` options.
#[derive(Args, Debug, Clone)]
pub struct SimulateArgs {
    #[command(flatten)]
    pub factors: FactorArgs,
    /// Write the data CSV to FILE (default: stdout).
    #[arg(long, short, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Also write the true robot's model file (with its placement as `base`).
    #[arg(long, value_name = "FILE")]
    pub truth_out: Option<PathBuf>,
    /// Measure the target at N random configurations within the joint limits (pose data: one
    /// run, q1..qn,x,y,z) instead of circle-point sweeps (whose settings --runs, --range,
    /// --step, --speed and --start then do not apply).
    #[arg(long, value_name = "N", conflicts_with_all = ["runs", "range", "step", "speed", "start"])]
    pub poses: Option<usize>,
    /// With --poses: the configurations to measure at (CSV of q1..qn, degrees) instead of random
    /// ones; N must be its number of rows.
    #[arg(long, value_name = "FILE", requires = "poses")]
    pub points_file: Option<PathBuf>,
    /// Where the robot base stands in the tracker's frame (default: --truth's own `base` when it
    /// has one, else random for --poses and base for sweeps, as the factor study uses).
    #[arg(long, value_enum)]
    pub placement: Option<PlacementArg>,
    /// Target on the flange, mm (default: the design target 30,-20,80 of the sweep simulation;
    /// replaced by --truth's).
    #[arg(long, value_delimiter = ',', value_name = "X,Y,Z")]
    pub target: Option<Vec<f64>>,
    /// With --poses: a further reflector on the tool, flange frame, mm, measured at every pose
    /// after the target (repeat the flag for more, up to 7): the file gets a target column
    /// (T1 the target, T2, …), as trackers that measure several reflectors write it.
    #[arg(long, value_delimiter = ',', value_name = "X,Y,Z", requires = "poses", action = clap::ArgAction::Append, num_args = 1, allow_hyphen_values = true)]
    pub other_target: Vec<f64>,
    /// With --poses: plain tracker noise σ per coordinate, mm, instead of the AT960 model.
    #[arg(long, value_name = "MM", requires = "poses")]
    pub tracker_sigma: Option<f64>,
    #[command(flatten)]
    pub nongeometric: NonGeometricArgs,
    #[command(flatten)]
    pub memory: MemoryArgs,
}

impl Run for SimulateArgs {
    fn run(self) -> Result<()> {
        let a = self;
        let mut inputs = a.factors.inputs();
        inputs.extend(a.points_file.as_deref().map(|p| ("--points-file", p)));
        let mut outputs = Outputs::new(inputs);
        outputs.file("--out", a.out.as_deref())?;
        outputs.file("--truth-out", a.truth_out.as_deref())?;
        let (mut exp, f) = a.factors.experiment()?;
        a.nongeometric
            .apply(&mut exp, a.factors.robot_seed, a.poses.is_some())?;
        if let Some(t) = &a.target {
            let t = three_values("--target", "x, y, z in mm", t)?;
            if t.iter().any(|v| v.abs() > 1e5) {
                bail!("--target: x, y, z must be within ±100 m");
            }
            exp.truth.tool = t;
            exp.nominal.tool = exp.truth.tool;
        }
        let poses = a.poses.is_some();
        // A true robot read with --truth keeps its own placement unless one is asked for.
        let placement = match (a.placement, exp.truth.base) {
            (None, Some(b)) if a.factors.truth.is_some() => Some(b),
            (p, _) => match p.unwrap_or(if poses {
                PlacementArg::Random
            } else {
                PlacementArg::Base
            }) {
                PlacementArg::Random => Some(random_placement(a.factors.seed)),
                PlacementArg::Base => None,
            },
        };
        exp.placement = placement;
        let mut truth = exp.truth.clone();
        if let Some(b) = placement {
            truth.base = Some(b);
        }
        let (text, what) = match a.poses {
            Some(n) => {
                // The configurations, the simulated poses and their CSV text are all kept
                // until the output is written: sized before any of them is made.
                let others = other_targets(&a.other_target)?;
                let joints = exp.truth.joints() as u64;
                // each further reflector is one more row of a pose
                let line = pose_line_bytes(joints) * (1 + others.len() as u64);
                a.memory.check(
                    &Estimate::new(
                        format!("{n} poses"),
                        "use fewer --poses, or raise --memory-limit",
                    )
                    .plus(&[n as u64, POSE_BYTES * (1 + others.len() as u64) + line]),
                )?;
                // A points file's sides (a plan with an approach side writes them) fix where a
                // robot with backlash stands; without, they follow from the poses' order.
                let sides = match &a.points_file {
                    Some(p) => gpu_amcs::points::read_sides(p, exp.truth.joints())
                        .with_context(|| format!("--points-file {}", p.display()))?,
                    None => None,
                };
                let configs = match &a.points_file {
                    Some(p) => {
                        let c = gpu_amcs::points::read_csv(p, exp.truth.joints())
                            .with_context(|| format!("--points-file {}", p.display()))?;
                        if c.len() != n {
                            bail!(
                                "--poses: {n} poses, but --points-file {} holds {} configurations: give --poses {}",
                                p.display(),
                                c.len(),
                                c.len()
                            );
                        }
                        c
                    }
                    None => {
                        if n == 0 || n > 10_000_000 {
                            bail!("--poses: {n} is not a number of poses in 1–10000000");
                        }
                        gpu_amcs::simulate::random_poses(&exp.truth, n, a.factors.seed)
                    }
                };
                for (i, q) in configs.iter().enumerate() {
                    exp.truth.check_limits(q).map_err(|m| {
                        anyhow::anyhow!("--points-file: configuration {}: {m}", i + 1)
                    })?;
                }
                let noise = match a.tracker_sigma {
                    Some(s) if s.is_finite() && s >= 0.0 => TrackerNoise::Isotropic(s),
                    Some(s) => bail!("--tracker-sigma: {s} is not a non-negative number of mm"),
                    None => TrackerNoise::Tracker(exp.tracker),
                };
                let b = placement.unwrap_or(gpu_amcs::kinematics::BaseTransform {
                    xyz: [0.0; 3],
                    rpy: [0.0; 3],
                });
                let data = simulate_poses_sided(
                    &exp.truth,
                    exp.nongeometric.as_ref(),
                    &configs,
                    sides.as_deref(),
                    a.nongeometric.payloads(),
                    &b,
                    &noise,
                    a.factors.seed,
                );
                // Reserved up front: a vector doubling its way to the size would need half as
                // much again at its last step.
                let mut buf = Vec::new();
                buf.try_reserve_exact((configs.len() as u64).saturating_mul(line) as usize)
                    .map_err(|_| {
                        anyhow::anyhow!(
                            "--poses: the CSV text of {} poses does not fit in memory; use fewer",
                            configs.len()
                        )
                    })?;
                let mut data = data;
                gpu_amcs::simulate::add_other_targets(
                    &mut data,
                    &exp.truth,
                    exp.nongeometric.as_ref(),
                    &others,
                    &b,
                    &noise,
                    a.factors.seed,
                );
                gpu_amcs::identify::write_poses(&data, &mut buf)?;
                let each = if others.is_empty() {
                    String::new()
                } else {
                    format!(" ({} reflectors each)", others.len() + 1)
                };
                (
                    String::from_utf8(buf).context("pose CSV")?,
                    format!("{} poses{each}", configs.len()),
                )
            }
            None => {
                a.memory.check(&a.factors.sweep_estimate(Estimate::new(
                    format!("{} runs of sweeps at a {}° step", f.runs, f.step_deg),
                    "use fewer --runs or a larger --step, or raise --memory-limit",
                )))?;
                let data = exp.sweeps(&f, a.factors.seed);
                let mut buf = Vec::new();
                gpu_amcs::identify::write_sweeps(&data, &mut buf)?;
                let text = String::from_utf8(buf).context("sweep CSV")?;
                let lines = text.lines().count() - 1;
                (
                    text,
                    format!(
                        "{} runs × {} sweeps ({lines} points)",
                        f.runs,
                        exp.truth.joints()
                    ),
                )
            }
        };
        outputs.stage_file("--truth-out", truth.to_toml())?;
        let frame = match &placement {
            None => "the robot base frame".to_string(),
            Some(b) => format!(
                "a tracker frame, robot base {:.2} m from the tracker",
                (b.xyz[0].powi(2) + b.xyz[1].powi(2) + b.xyz[2].powi(2)).sqrt() / 1000.0
            ),
        };
        match &a.out {
            Some(o) => {
                outputs.stage_file("--out", text)?;
                outputs.commit()?;
                eprintln!("wrote {what} in {frame} to {}", o.display());
            }
            None => {
                outputs.commit()?;
                crate::cmd::stdout::print(&text)?;
            }
        }
        if a.nongeometric.any() && a.truth_out.is_some() {
            eprintln!("note: --truth-out holds the true robot's geometry only: its compliance and harmonics are drawn again from --robot-seed with the same --compliance and --harmonics");
        }
        Ok(())
    }
}

/// The further reflectors of `--other-target` (three numbers each, at most seven, each within
/// ±100 m like `--target`).
fn other_targets(values: &[f64]) -> Result<Vec<[f64; 3]>> {
    if !values.len().is_multiple_of(3) {
        bail!(
            "--other-target needs three numbers x,y,z (mm) per reflector, got {}",
            values.len()
        );
    }
    let others: Vec<[f64; 3]> = values
        .chunks(3)
        .map(|c| three_values("--other-target", "x, y, z in mm", c))
        .collect::<Result<_>>()?;
    let most = gpu_amcs::identify::chain_fit::MAX_TARGETS - 1;
    if others.len() > most {
        bail!(
            "--other-target: {} reflectors besides the target; a fit takes at most {most}",
            others.len()
        );
    }
    if others.iter().flatten().any(|v| v.abs() > 1e5) {
        bail!("--other-target: x, y, z must be within ±100 m");
    }
    Ok(others)
}
