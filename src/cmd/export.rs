//! `export`: a model as URDF and/or as a UR calibration file.

use super::outputs::Outputs;
use super::Run;
use crate::cmd::args::ModelArgs;
use anyhow::{Context, Result};
use clap::Args;
use gpu_amcs::identify::{provenance_frame, Placement};
use gpu_amcs::import::export::{self, ExportError, UrdfBase};
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
    /// End the UR calibration file at the flange and give the model's tool point as a separate
    /// TCP for the controller (printed, and written in the file as a comment): for a tool point
    /// off the joint-6 axis, such as the target of a model identified from tracker data.
    #[arg(long, requires = "ur_calibration")]
    pub ur_tcp: bool,
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
        // A model identified in a measurement frame has that frame's placement as its base: the
        // URDF writes it as its own joint from `world`, not in joint 1's origin.
        let measured = a
            .model
            .model
            .as_deref()
            .and_then(|f| std::fs::read_to_string(f).ok())
            .is_some_and(|t| provenance_frame(&t) == Some(Placement::Identify));
        // Build everything before writing anything.
        let mut tcp = None;
        if a.ur_calibration.is_some() {
            let text = if a.ur_tcp {
                let (text, t) =
                    export::to_ur_calibration_tcp(&model).context("--ur-calibration")?;
                tcp = Some(t);
                text
            } else {
                export::to_ur_calibration(&model).map_err(|e| match e {
                    ExportError::ToolOffAxis { .. } => {
                        anyhow::anyhow!("--ur-calibration: {e} (--ur-tcp)")
                    }
                    e => anyhow::Error::new(e).context("--ur-calibration"),
                })?
            };
            outputs.stage_file("--ur-calibration", text)?;
        }
        if a.urdf.is_some() {
            let base = if measured {
                UrdfBase::World
            } else {
                UrdfBase::FirstJoint
            };
            let text = export::to_urdf_with(&model, a.name.as_deref(), base);
            outputs.stage_file("--urdf", text)?;
        }
        outputs.commit()?;
        let mut text = String::new();
        if let Some(t) = tcp {
            let mm = t.xyz_m.map(|v| format!("{:.4}", v * 1000.0));
            text.push_str(&format!(
                "TCP (the tool point in the flange frame, not in the UR calibration file): x {} mm, y {} mm, z {} mm; URScript set_tcp({t})\n",
                mm[0], mm[1], mm[2]
            ));
        }
        if let (Some(_), true, Some(_)) = (&a.urdf, measured, model.base) {
            text.push_str(
                "URDF: the placement in the measurement frame is the fixed joint world_joint (world → base_link); tool0 is the target\n",
            );
        }
        crate::cmd::stdout::print(&text)?;
        // URDF and UR files hold geometry only: the joint errors the geometry was fitted with
        // are not in them, so a controller given the file misses their deflections.
        if let Some(e) = &model.joint_errors {
            let worst = (0..model.joints())
                .map(|j| {
                    let c = &e.coefficients[5 * j..5 * j + 5];
                    c[1].abs() + c[2].abs() + c[3].abs() + c[4].abs()
                })
                .fold(0.0, f64::max)
                .to_degrees();
            let lash = match e.backlash.as_ref() {
                Some(b) => format!(
                    ", and its backlash (gaps up to {:.4}°: the geometry was fitted to the angles corrected by each pose's side)",
                    b.gap_rad.iter().fold(0.0f64, |m, g| m.max(g.abs())).to_degrees()
                ),
                None => String::new(),
            };
            eprintln!(
                "note: the model carries joint errors beyond geometry (compliance, gear harmonics; identify kept them) that URDF and UR calibration files cannot hold: the exported geometry is the one fitted with them, and a controller given the file misses their deflections (gear harmonics up to {worst:.4}° per joint, plus the compliance under load){lash}; the model file keeps them"
            );
        }
        // The link masses: URDF holds them (<inertial>), UR's calibration file does not.
        if let (Some(_), Some(_)) = (&a.ur_calibration, &model.links) {
            eprintln!(
                "note: --ur-calibration: the model's link masses ([links]) are not part of UR's kinematics file (its description holds them)"
            );
        }
        // UR's file is the arm in its own base frame: a base other than the REP-103 turn UR's
        // description adds itself is where the arm stands, and belongs in the description.
        if let (Some(_), Some(b)) = (&a.ur_calibration, model.base) {
            let ur_turn = b.xyz == [0.0; 3]
                && b.rpy[0].abs() < 1e-12
                && b.rpy[1].abs() < 1e-12
                && (b.rpy[2].abs() - std::f64::consts::PI).abs() < 1e-12;
            if measured {
                eprintln!(
                    "note: --ur-calibration: the model's placement in the measurement frame (its base) is not part of UR's kinematics file, which starts at the arm's own base frame"
                );
            } else if !ur_turn {
                eprintln!(
                    "note: --ur-calibration: the model's base transform is not part of UR's kinematics file (it starts at the arm's own base frame); place the arm in its description"
                );
            }
        }
        Ok(())
    }
}
