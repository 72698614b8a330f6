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
    /// Positions of the geometric model alone, without the model's compensation (the mean of
    /// its fitted Gaussian process, docs "Honest on a real robot").
    #[arg(long)]
    pub no_compensation: bool,
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
        let compensate = model.compensated() && !self.no_compensation;
        if compensate {
            eprintln!(
                "note: positions include the model's compensation (what its Gaussian process predicts the geometric model misses); --no-compensation gives the geometric model alone"
            );
        }
        let mut s = (1..=model.joints())
            .map(|j| format!("q{j},"))
            .collect::<String>();
        s.push_str("x,y,z\n");
        for q in &pts {
            let rad = q.map(f64::to_radians);
            let p = if compensate {
                model.compensated_world_position(&rad)
            } else {
                model.world_position(&rad)
            };
            let qs: Vec<String> = q.iter().map(|v| format!("{v}")).collect();
            // Shortest representation that reads back to the same f64: full precision.
            s.push_str(&format!("{},{},{},{}\n", qs.join(","), p[0], p[1], p[2]));
        }
        crate::cmd::stdout::print(&s)?;
        Ok(())
    }
}
