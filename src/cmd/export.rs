//! `export`: a model as URDF and/or as a UR calibration file.

use super::outputs::Outputs;
use super::Run;
use crate::cmd::args::ModelArgs;
use anyhow::{Context, Result};
use clap::Args;
use gpu_amcs::import::export;
use std::path::PathBuf;

/// `export` options.
#[derive(Args, Debug, Clone)]
#[command(group(clap::ArgGroup::new("target").required(true).multiple(true).args(["urdf", "ur_calibration"])))]
pub struct ExportArgs {
    #[command(flatten)]
    pub model: ModelArgs,
    /// Write the model as URDF to FILE.
    #[arg(long, value_name = "FILE")]
    pub urdf: Option<PathBuf>,
    /// Write the model as a UR calibration file (YAML) to FILE.
    #[arg(long, value_name = "FILE")]
    pub ur_calibration: Option<PathBuf>,
    /// Robot name in the URDF (default: the model's name).
    #[arg(long, value_name = "NAME")]
    pub name: Option<String>,
}

impl Run for ExportArgs {
    fn run(self) -> Result<()> {
        let a = self;
        let mut outputs = Outputs::new(a.model.model.as_deref().map(|m| ("--model", m)));
        outputs.file("--urdf", a.urdf.as_deref())?;
        outputs.file("--ur-calibration", a.ur_calibration.as_deref())?;
        let model = a.model.load()?;
        // Build everything before writing anything.
        if a.ur_calibration.is_some() {
            let text = export::to_ur_calibration(&model).context("--ur-calibration")?;
            outputs.stage_file("--ur-calibration", text)?;
        }
        if a.urdf.is_some() {
            outputs.stage_file("--urdf", export::to_urdf(&model, a.name.as_deref()))?;
        }
        outputs.commit()?;
        // UR's file is the arm in its own base frame: a base other than the REP-103 turn UR's
        // description adds itself is where the arm stands, and belongs in the description.
        if let (Some(_), Some(b)) = (&a.ur_calibration, model.base) {
            let ur_turn = b.xyz == [0.0; 3]
                && b.rpy[0].abs() < 1e-12
                && b.rpy[1].abs() < 1e-12
                && (b.rpy[2].abs() - std::f64::consts::PI).abs() < 1e-12;
            if !ur_turn {
                eprintln!(
                    "note: --ur-calibration: the model's base transform is not part of UR's kinematics file (it starts at the arm's own base frame); place the arm in its description"
                );
            }
        }
        Ok(())
    }
}
