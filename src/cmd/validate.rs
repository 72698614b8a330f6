//! `validate`: positioning accuracy of a model against measured positions.

use super::args::{load_model, MemoryArgs, BYTES_PER_DRAW, BYTES_PER_POINT};
use super::outputs::Outputs;
use super::progress::Progress;
use super::reports::{write_reports, ReportFlags};
use super::Run;
use anyhow::{Context, Result};
use clap::Args;
use gpu_amcs::kinematics::RobotModel;
use gpu_amcs::memory::Estimate;
use gpu_amcs::progress::ProgressHook;
use std::path::PathBuf;
use std::sync::Arc;

/// `validate` options.
#[derive(Args, Debug, Clone)]
pub struct ValidateArgs {
    /// Measured positions: q1..qn,x,y,z (one column per joint of the model; degrees, mm).
    #[arg(value_name = "MEASURED.csv")]
    pub measured: PathBuf,
    /// The measured file's columns as a tracker or robot log exported them, as for identify:
    /// ours=theirs[:unit],... (e.g. q1=A1:rad,...,x=X:m); units mm, cm, m, in, um; deg, rad; kg,
    /// g, lb.
    #[arg(long, value_name = "MAP")]
    pub columns: Option<String>,
    /// The measured file's field delimiter, one character (e.g. ';' or tab), when not a comma.
    #[arg(long, value_name = "CHAR")]
    pub delimiter: Option<String>,
    /// Model to check (TOML).
    #[arg(long, value_name = "FILE")]
    pub model: PathBuf,
    /// Also check a nominal model and report the improvement. Bare: the model file's own
    /// nominal (recorded in its [provenance] by identify), else --preset, else the built-in
    /// preset of the model's geometry. A nominal of another robot, or another than the one the
    /// model file records, is refused. On measurement-frame data the nominal geometry gets its
    /// own best-fit placement (and target offset, where the data determine it).
    #[arg(long, value_name = "FILE", num_args = 0..=1)]
    pub nominal: Option<Option<PathBuf>>,
    /// Built-in nominal model for a bare --nominal (checked against the model file's own).
    #[arg(long, value_name = "NAME")]
    pub preset: Option<String>,
    /// Frame of the measured positions: `measurement` (the tracker frame the model's placement
    /// was identified in) or `base` (the robot's base frame). Default: the frame the model was
    /// identified in (its `[provenance]` table), else base — refused when the positions are far
    /// from the model there (data in a tracker frame and a model file that records no frame).
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
    /// Draws of the certificate's Monte Carlo run (2000 … 100000000).
    #[arg(long, default_value_t = 100_000, value_name = "N", requires = "spec")]
    pub draws: u64,
    /// Draws per pose of the predictive check (is the model's predicted error distribution
    /// honest at these poses?), at most 1000000; 0 leaves the check out.
    #[arg(long, default_value_t = 20_000, value_name = "N")]
    pub check_draws: usize,
    /// Seed of the predictive check.
    #[arg(long, default_value_t = 2025, value_name = "SEED")]
    pub seed: u64,
    /// Also write the model with its discrepancy term drawn from these poses' errors to FILE (at
    /// least 10 poses, which the model was not identified from, spread where it will be used:
    /// the term then holds what its own data could not show, e.g. a model from sweeps alone).
    #[arg(long, value_name = "FILE", conflicts_with = "iso9283")]
    pub term_out: Option<PathBuf>,
    /// With --iso9283: the report files (JSON, CSV, SVG, HTML).
    #[command(flatten)]
    pub reports: ReportFlags,
    #[command(flatten)]
    pub memory: MemoryArgs,
}

/// Most draws of the certificate's run (`--draws`).
const MAX_DRAWS: u64 = 100_000_000;

/// Most draws per pose of the predictive check (`--check-draws`).
const MAX_CHECK_DRAWS: usize = 1_000_000;

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
        use gpu_amcs::identify::{self, validate as v};
        if a.check_draws > MAX_CHECK_DRAWS {
            anyhow::bail!(
                "--check-draws: must be 0 … {MAX_CHECK_DRAWS}, got {}",
                a.check_draws
            );
        }
        let model = RobotModel::from_file(&a.model)?;
        let model_text = std::fs::read_to_string(&a.model).unwrap_or_default();
        let origin = a.model.display().to_string();
        let measured = a.measured.display().to_string();
        let m = match super::identify::column_map(a.columns.as_deref(), a.delimiter.as_deref())? {
            None => identify::read_measurements(&a.measured)?,
            Some(map) => {
                let (text, origin) = identify::read_data_text(&a.measured)?;
                let text = map.apply(&text, &origin).context("--columns")?;
                identify::parse_measurements(text.as_bytes(), &origin)?
            }
        };
        // As every analysis of a model file: parameters its data did not determine rest on
        // their prior σ, and the figures that depend on them say so.
        if let Some(note) =
            identify::chain::not_identified_note(&identify::chain::not_identified(&model_text))
        {
            eprintln!("note: --model {origin}: {note}");
        }
        let stated = a.frame.map(|f| match f {
            ValidateFrame::Measurement => identify::Placement::Identify,
            ValidateFrame::Base => identify::Placement::Known,
        });
        if a.iso9283 {
            // Rows of several reflectors: the cycles are the model's own reflector's.
            let (m, target) = v::choose_target(
                &m,
                v::provenance_target(&model_text).as_deref(),
                &origin,
                &measured,
            )
            .map_err(cli_error)?;
            if let Some(t) = target.filter(|t| t.left_out > 0) {
                eprintln!(
                    "note: the cycles of '{}', the model's own reflector ({} rows of other reflectors left out)",
                    t.label, t.left_out
                );
            }
            // A model with a placement and no recorded frame may be either frame's: refused
            // where the base frame does not fit. Without a placement, the base frame.
            let recorded = identify::provenance_frame(&model_text);
            let frame = match (stated, recorded, model.base) {
                (None, None, Some(_)) => {
                    v::choose_frame(&model, &origin, None, None, &m, &measured)
                        .map_err(cli_error)?
                        .0
                }
                (s, r, _) => s.or(r).unwrap_or(identify::Placement::Known),
            };
            return iso9283(&a, &model, &m, frame);
        }
        let mut outputs = Outputs::new([
            ("MEASURED.csv", a.measured.as_path()),
            ("--model", a.model.as_path()),
        ]);
        if let Some(flag) = a.reports.given().filter(|f| *f != "--json") {
            anyhow::bail!(
                "{flag}: only validate --iso9283 writes report files (validate writes --json)"
            );
        }
        outputs.file("--json", a.reports.json.as_deref())?;
        outputs.file("--term-out", a.term_out.as_deref())?;
        // A bare --nominal is the model file's own nominal unless --preset names one.
        let nominal = match (&a.nominal, &a.preset) {
            (None, _) => None,
            (Some(None), None) => Some(None),
            (Some(file), preset) => Some(Some(
                load_model(file.as_deref(), preset.as_deref().unwrap_or_default())
                    .context("--nominal")?,
            )),
        };
        // The library names the line; the file is named here.
        if let Some(row) = m.iter().find(|r| r.q_deg.len() != model.joints()) {
            anyhow::bail!(
                "{measured}: line {}: {} joint angles, the model {} has {} joints",
                row.line,
                row.q_deg.len(),
                model.name,
                model.joints()
            );
        }
        let report = v::run_validation(v::ValidateRequest {
            model: &model,
            model_text: &model_text,
            origin: &origin,
            measurements: &m,
            measured: &measured,
            frame: stated,
            nominal,
            check_draws: a.check_draws,
            seed: a.seed,
            term: a.term_out.is_some(),
        })
        .map_err(|e| match e {
            // The library names the line; the file is named here.
            v::ValidateError::Identify(identify::IdentifyError::OutsideLimits { .. }) => {
                anyhow::anyhow!("{measured}: {e} of model {}", model.name)
            }
            e => cli_error(e),
        })?;
        outputs.stage_file("--json", report.json())?;
        if let Some(t) = &report.term {
            let data = std::fs::read(&a.measured).unwrap_or_default();
            outputs.stage_file("--term-out", t.file_text(&model_text, &measured, &data))?;
        }
        outputs.commit()?;
        if !a.reports.quiet {
            crate::cmd::stdout::print(&report.text())?;
        }
        Ok(())
    }
}

/// A validation error with the flag that settles it.
fn cli_error(e: gpu_amcs::identify::validate::ValidateError) -> anyhow::Error {
    use gpu_amcs::identify::validate::ValidateError as E;
    match e {
        E::UnknownFrame { .. } => anyhow::anyhow!("{e} (--frame measurement or --frame base)"),
        E::Identify(e) => e.into(),
        E::Term(_) => anyhow::anyhow!("--term-out: {e}"),
        e => anyhow::anyhow!("--nominal: {e}"),
    }
}

/// Draws of the certificate's run evaluated at a time (the library's default chunk), each
/// keeping its per-pose errors.
const CERTIFICATE_CHUNK: u64 = 100_000;

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
        // The certificate's run keeps every draw's w: its number is checked here, where the
        // flag is known, and sized against the memory once the poses are known.
        let min =
            gpu_amcs::mc::min_draws(gpu_amcs::mc::RunSettings::default().coverage_probability);
        if a.draws < min || a.draws > MAX_DRAWS {
            anyhow::bail!("--draws: must be {min} … {MAX_DRAWS}, got {}", a.draws);
        }
    }
    let figures =
        iso9283::pose_figures(model, m, frame).with_context(|| a.measured.display().to_string())?;
    let certificate = match a.spec {
        Some(spec) => Some({
            let poses = figures.len() as u64;
            a.memory.check(
                &Estimate::new(
                    format!("a certificate of {} draws", a.draws),
                    "use fewer --draws, or raise --memory-limit",
                )
                .plus(&[a.draws, BYTES_PER_DRAW])
                .plus(&[poses, BYTES_PER_POINT])
                .plus(&[a.draws.min(CERTIFICATE_CHUNK), poses, 2 * 8]),
            )?;
            // The check's and the certificate's draws under one bar, which announces a long
            // estimate.
            let bar = Arc::new(Progress::new(
                a.reports.quiet,
                "ISO 9283 certificate",
                "draws",
            ));
            let listener = bar.clone();
            let hook = ProgressHook::new(move |label: &str, done, total| {
                listener.set_message(label);
                listener.update(done, total);
            });
            let c =
                iso9283::certify_with_progress(model, &figures, spec, frame, a.draws, 2025, &hook)
                    .map_err(|e| {
                        let file = match e {
                            iso9283::CertifyError::NoUncertainty { .. } => &a.model,
                            _ => &a.measured,
                        };
                        anyhow::anyhow!("--spec: {}: {e}", file.display())
                    });
            bar.finish();
            c?
        }),
        None => None,
    };
    let report = iso9283::PoseReport {
        model_name: model.name.clone(),
        frame: gpu_amcs::identify::validate::frame_words(frame).into(),
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
