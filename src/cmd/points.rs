//! `points`: generate test points as CSV.

use super::outputs::Outputs;
use super::Run;
use crate::cmd::args::{BoxArgs, MemoryArgs, ModelArgs};
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
    #[arg(value_name = "N")]
    pub n: usize,
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
        self.workspace.check()?;
        if self.n > points::MAX_POINTS {
            return Err(anyhow::Error::new(points::PointsError::TooMany(self.n)).context("N"));
        }
        self.memory.check(
            &Estimate::new(
                format!("{} test points", self.n),
                "generate fewer points, or raise --memory-limit",
            )
            .plus(&[self.n as u64, BYTES_PER_POINT]),
        )?;
        let model = self.model.load()?;
        let bx = self.workspace.workspace(&model)?;
        let pts = points::generate(&model, self.n, &bx, self.points_seed)?;
        outputs.write_or_print("--out", points::to_csv(&pts))
    }
}
