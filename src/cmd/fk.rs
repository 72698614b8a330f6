//! `fk`: forward kinematics of the configurations in a CSV.

use super::Run;
use crate::cmd::args::ModelArgs;
use anyhow::Result;
use clap::Args;
use gpu_amcs::points;
use std::path::PathBuf;

/// `fk` options.
#[derive(Args, Debug, Clone)]
pub struct FkArgs {
    /// Configurations (header q1..qn for an n-joint model, degrees).
    #[arg(long, value_name = "CSV")]
    pub points_file: PathBuf,
    #[command(flatten)]
    pub model: ModelArgs,
}

impl Run for FkArgs {
    fn run(self) -> Result<()> {
        let model = self.model.load()?;
        let pts = points::read_csv(&self.points_file, model.joints())?;
        // As every analysis: a configuration the robot cannot take is an error, not a position.
        for (i, q) in pts.iter().enumerate() {
            if let Err(m) = model.check_limits(q) {
                anyhow::bail!(
                    "--points-file: {}: configuration {}: {m}",
                    self.points_file.display(),
                    i + 1
                );
            }
        }
        let mut s = (1..=model.joints())
            .map(|j| format!("q{j},"))
            .collect::<String>();
        s.push_str("x,y,z\n");
        for q in &pts {
            let p = model.world_position(&q.map(f64::to_radians));
            let qs: Vec<String> = q.iter().map(|v| format!("{v}")).collect();
            // Shortest representation that reads back to the same f64: full precision.
            s.push_str(&format!("{},{},{},{}\n", qs.join(","), p[0], p[1], p[2]));
        }
        crate::cmd::stdout::print(&s)?;
        Ok(())
    }
}
