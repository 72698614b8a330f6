//! `points`: generate test points as CSV.

use super::outputs::Outputs;
use super::Run;
use crate::cmd::args::{three_values, BoxArgs, MemoryArgs, ModelArgs};
use anyhow::Result;
use clap::Args;
use gpu_amcs::memory::Estimate;
use gpu_amcs::points;
use std::path::PathBuf;

/// Bytes per generated point: six angles and their CSV line (as text and while it is built).
const BYTES_PER_POINT: u64 = 48 + 2 * 128;

/// `points` options.
#[derive(Args, Debug, Clone)]
pub struct PointsArgs {
    /// Number of test points.
    #[arg(value_name = "N", required_unless_present = "iso9283")]
    pub n: Option<usize>,
    /// Instead: the five ISO 9283 test poses P1–P5 on the diagonal plane of the largest test
    /// cube in the working space (edges parallel to the base frame; P1 at the centre, P2–P5 at
    /// 10 % of the diagonal from the corners), one flange orientation for all (default: the
    /// tool pointing down, the flange below the wrist: rpy 180,0,0, or 0,0,0 for a model whose
    /// last joint axis points into the wrist, as the KR 6 R700's). The cube is printed to
    /// stderr.
    #[arg(long, conflicts_with_all = ["n", "points_seed", "box_center", "box_size"])]
    pub iso9283: bool,
    /// With --iso9283: the flange orientation of the poses, roll,pitch,yaw in degrees.
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "R,P,Y",
        requires = "iso9283",
        allow_hyphen_values = true
    )]
    pub iso_rpy: Option<Vec<f64>>,
    /// With --iso9283: place the poses by position alone (any flange orientation).
    #[arg(long, requires = "iso9283", conflicts_with = "iso_rpy")]
    pub position_only: bool,
    #[command(flatten)]
    pub model: ModelArgs,
    /// Seed.
    #[arg(long, default_value_t = 1, value_name = "SEED")]
    pub points_seed: u64,
    #[command(flatten)]
    pub workspace: BoxArgs,
    /// Write to FILE instead of stdout.
    #[arg(long, short, value_name = "FILE")]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub memory: MemoryArgs,
}

impl Run for PointsArgs {
    fn run(self) -> Result<()> {
        let mut outputs = Outputs::new(self.model.model.as_deref().map(|m| ("--model", m)));
        outputs.file("--out", self.out.as_deref())?;
        if !self.iso9283 {
            // clap lets these through beside N (N conflicts with --iso9283).
            let flag = match (&self.iso_rpy, self.position_only) {
                (Some(_), _) => Some("--iso-rpy"),
                (None, true) => Some("--position-only"),
                (None, false) => None,
            };
            if let Some(flag) = flag {
                anyhow::bail!("{flag}: only with --iso9283 (it orients the ISO 9283 test poses; N points in a box take no orientation)");
            }
        }
        self.workspace.check()?;
        if self.iso9283 {
            let model = self.model.load()?;
            let default_rpy = self.iso_rpy.is_none() && !self.position_only;
            let rpy = match (&self.iso_rpy, self.position_only) {
                (_, true) => None,
                (Some(r), _) => Some(three_values("--iso-rpy", "roll, pitch, yaw in degrees", r)?),
                (None, false) => Some(gpu_amcs::map::tool_down_rpy_deg(&model)),
            };
            let cube = gpu_amcs::iso9283::test_cube(&model, rpy)
                .map_err(|e| anyhow::anyhow!("--iso9283: {}", e.0))?;
            let c = cube.centre_mm;
            eprintln!(
                "ISO 9283 test cube: centre ({:.1}, {:.1}, {:.1}) mm, edge {:.1} mm, {}; {}",
                c[0],
                c[1],
                c[2],
                cube.edge_mm,
                match model.base {
                    None => "base frame",
                    Some(_) => "world frame (fk's: the model's base transform applied)",
                },
                match cube.rpy_deg {
                    Some(r) => format!(
                        "flange rpy ({}, {}, {})°{}",
                        r[0],
                        r[1],
                        r[2],
                        if default_rpy && r == [0.0; 3] {
                            // The KR 6: rpy 0 is the tool down, which reads as up otherwise.
                            " (the tool pointing down: this model's last joint axis, the z axis of its flange frame, points into the wrist, so it points up)"
                        } else if default_rpy {
                            " (the tool pointing down)"
                        } else {
                            ""
                        }
                    ),
                    None => "position only".into(),
                }
            );
            for (k, p) in cube.poses_mm.iter().enumerate() {
                eprintln!("  P{}  ({:.1}, {:.1}, {:.1}) mm", k + 1, p[0], p[1], p[2]);
            }
            return outputs.write_or_print(
                "--out",
                points::to_csv_within(&cube.poses_q_deg, &model.limits_deg),
            );
        }
        let n = self.n.unwrap_or(0);
        if n > points::MAX_POINTS {
            return Err(anyhow::Error::new(points::PointsError::TooMany(n)).context("N"));
        }
        self.memory.check(
            &Estimate::new(
                format!("{n} test points"),
                "generate fewer points, or raise --memory-limit",
            )
            .plus(&[n as u64, BYTES_PER_POINT]),
        )?;
        let model = self.model.load()?;
        let bx = self.workspace.workspace(&model)?;
        let pts = points::generate(&model, n, &bx, self.points_seed)?;
        outputs.write_or_print("--out", points::to_csv_within(&pts, &model.limits_deg))
    }
}
