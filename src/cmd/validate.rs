//! `validate`: positioning accuracy of a model against measured positions.

use super::args::load_model;
use super::Run;
use anyhow::{Context, Result};
use clap::Args;
use gpu_amcs::kinematics::RobotModel;
use std::path::PathBuf;

/// `validate` options.
#[derive(Args, Debug, Clone)]
pub struct ValidateArgs {
    /// Measured positions: q1..q6,x,y,z (degrees, mm).
    #[arg(value_name = "MEASURED.csv")]
    pub measured: PathBuf,
    /// Model to check (TOML).
    #[arg(long, value_name = "FILE")]
    pub model: PathBuf,
    /// Also check a nominal model (FILE, or the preset when no file is given) and report the
    /// improvement.
    #[arg(long, value_name = "FILE", num_args = 0..=1)]
    pub nominal: Option<Option<PathBuf>>,
    /// Built-in nominal model for a bare --nominal.
    #[arg(long, default_value = "tx60", value_name = "NAME")]
    pub preset: String,
    /// Frame of the measured positions: `measurement` (the tracker frame the model's placement
    /// was identified in; a nominal model is placed where the model is) or `base` (the robot's
    /// base frame). Default: the frame the model was identified in (its `[provenance]` table),
    /// else base.
    #[arg(long, value_enum, value_name = "FRAME")]
    pub frame: Option<ValidateFrame>,
}

/// The frame of the measurements.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum ValidateFrame {
    /// The measurement (tracker) frame: the model's base placement applies.
    Measurement,
    /// The robot's base frame.
    Base,
}

impl Run for ValidateArgs {
    fn run(self) -> Result<()> {
        let a = self;
        use gpu_amcs::identify;
        let model = RobotModel::from_file(&a.model)?;
        let nominal = match &a.nominal {
            None => None,
            Some(f) => Some(load_model(f.as_deref(), &a.preset).context("--nominal")?),
        };
        let m = identify::read_measurements(&a.measured)?;
        let frame = match a.frame {
            Some(ValidateFrame::Measurement) => identify::Placement::Identify,
            Some(ValidateFrame::Base) => identify::Placement::Known,
            // The frame the model was identified in, as its provenance records it.
            None => std::fs::read_to_string(&a.model)
                .ok()
                .and_then(|t| identify::provenance_frame(&t))
                .unwrap_or(identify::Placement::Known),
        };
        let v =
            identify::validate_in(&model, &m, nominal.as_ref(), frame).map_err(|e| match e {
                // The library names the line; the file is named here.
                identify::IdentifyError::OutsideLimits { .. } => {
                    anyhow::anyhow!("{}: {e} of model {}", a.measured.display(), model.name)
                }
                e => e.into(),
            })?;
        let mut text = identify::render_validation(&v);
        text.push_str(&format!(
            "frame: {}\n",
            match frame {
                identify::Placement::Identify => "measurement (the model's placement applies)",
                identify::Placement::Known => "robot base",
            }
        ));
        crate::cmd::stdout::print(&text)?;
        Ok(())
    }
}
