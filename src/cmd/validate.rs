//! `validate`: positioning accuracy of a model against measured positions.

use super::args::load_model;
use super::outputs::Outputs;
use super::reports::{write_reports, ReportFlags};
use super::Run;
use anyhow::{Context, Result};
use clap::Args;
use gpu_amcs::kinematics::RobotModel;
use std::path::PathBuf;

/// `validate` options.
#[derive(Args, Debug, Clone)]
pub struct ValidateArgs {
    /// Measured positions: q1..qn,x,y,z (one column per joint of the model; degrees, mm).
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
    /// ISO 9283: the rows are cycles at test poses (rows sharing one commanded configuration are
    /// one pose); report each pose's accuracy AP and repeatability RP = l̄ + 3 S_l.
    #[arg(long)]
    pub iso9283: bool,
    /// With --iso9283: the certificate Pr[AP ≤ MM] at each pose and at all of them, from the
    /// model's uncertainty.
    #[arg(long, value_name = "MM", requires = "iso9283")]
    pub spec: Option<f64>,
    /// Draws of the certificate's Monte Carlo run.
    #[arg(long, default_value_t = 100_000, value_name = "N", requires = "spec")]
    pub draws: u64,
    /// Draws per pose of the predictive check (is the model's predicted error distribution
    /// honest at these poses?); 0 leaves the check out.
    #[arg(long, default_value_t = 20_000, value_name = "N")]
    pub check_draws: usize,
    /// Seed of the predictive check.
    #[arg(long, default_value_t = 2025, value_name = "SEED")]
    pub seed: u64,
    /// With --iso9283: the report files (JSON, CSV, SVG, HTML).
    #[command(flatten)]
    pub reports: ReportFlags,
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
        if a.iso9283 {
            return iso9283(&a, &model, &m, frame);
        }
        if let Some(flag) = a.reports.given() {
            anyhow::bail!("{flag}: only validate --iso9283 writes report files");
        }
        let v =
            identify::validate_in(&model, &m, nominal.as_ref(), frame).map_err(|e| match e {
                // The library names the line; the file is named here.
                identify::IdentifyError::OutsideLimits { .. } => {
                    anyhow::anyhow!("{}: {e} of model {}", a.measured.display(), model.name)
                }
                e => e.into(),
            })?;
        let mut text = identify::render_validation(&v);
        text.push_str(&format!("frame: {}\n", frame_words(frame)));
        if a.check_draws > 0 && m.len() >= 2 {
            let check =
                identify::predictive::predictive_check(&model, &m, frame, a.check_draws, a.seed)
                    .context("predictive check")?;
            text.push_str(&check.render());
        }
        crate::cmd::stdout::print(&text)?;
        Ok(())
    }
}

/// The frame of the measurements, in words.
fn frame_words(frame: gpu_amcs::identify::Placement) -> &'static str {
    match frame {
        gpu_amcs::identify::Placement::Identify => "measurement (the model's placement applies)",
        gpu_amcs::identify::Placement::Known => "robot base",
    }
}

/// `validate --iso9283`: the ISO 9283 figures of the measured cycles and, with `--spec`, the
/// certificate at their poses.
fn iso9283(
    a: &ValidateArgs,
    model: &RobotModel,
    m: &[gpu_amcs::identify::validate::Measurement],
    frame: gpu_amcs::identify::Placement,
) -> Result<()> {
    use gpu_amcs::iso9283;
    let mut outputs = Outputs::new([
        ("MEASURED.csv", a.measured.as_path()),
        ("--model", a.model.as_path()),
    ]);
    a.reports
        .declare(&mut outputs, &iso9283::PoseReport::planned_layout())?;
    if let Some(spec) = a.spec {
        if !(spec.is_finite() && spec > 0.0) {
            anyhow::bail!("--spec: {spec} is not a length > 0 (mm)");
        }
    }
    let figures =
        iso9283::pose_figures(model, m, frame).with_context(|| a.measured.display().to_string())?;
    let certificate = match a.spec {
        Some(spec) => {
            let poses: Vec<_> = figures.iter().map(|f| f.q_deg).collect();
            Some(
                iso9283::certificate(model, &poses, spec, frame, a.draws, 2025)
                    .context("--spec")?,
            )
        }
        None => None,
    };
    let report = iso9283::PoseReport {
        model_name: model.name.clone(),
        frame: frame_words(frame).into(),
        poses: figures,
        certificate,
    };
    let settings = vec![
        (
            "measured cycles".to_string(),
            a.measured.display().to_string(),
        ),
        ("model file".to_string(), a.model.display().to_string()),
    ];
    write_reports(outputs, &report, &a.reports, &settings)
}
