//! `identify`: MDH parameters, target and placement from laser-tracker data (sweeps or poses, in
//! any measurement frame), with the covariance the data produce.

use super::args::{load_model, MemoryArgs};
use super::outputs::Outputs;
use super::progress::Progress;
use super::reports::stage_reports;
use super::Run;
use crate::cmd::reports::ReportFlags;
use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use gpu_amcs::identify::{
    CircleFitMethod, IdentifyJob, IdentifyReports, IdentifySetting, JointErrorFit, Placement,
    UncertaintyMethod,
};
use gpu_amcs::kinematics::RobotModel;
use gpu_amcs::presets::{preset, PRESETS};
use gpu_amcs::progress::ProgressHook;
use gpu_amcs::report::Report;
use std::path::{Path, PathBuf};

/// Circle model of the identification.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum FitArg {
    /// Circle through the points with each point's angle known from the commanded joint angle.
    Commanded,
    /// Plain point-cloud circle fit (plane, algebraic circle, geometric refinement).
    PointCloud,
}

/// How the covariance is obtained.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum UncertaintyArg {
    /// s²(JᵀWJ)⁻¹ at the solution.
    Linearised,
    /// The sample covariance of --mc-draws re-identifications of synthetic data.
    Montecarlo,
}

/// When joint compliance and gear harmonics are fitted with the geometry.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum BeyondArg {
    /// Never: the geometry alone.
    Off,
    /// When the geometric fit shows a lack of fit (or the noise is not stated); kept when they
    /// predict left-out poses better.
    Auto,
    /// Always checked; kept when they predict left-out poses better.
    On,
    /// Always fitted and kept (for --payload-kg on data that do not show the compliance).
    Keep,
    /// Always checked and reported; the model keeps the geometry alone (several runs get this
    /// for on and keep: their mean model holds no joint errors).
    Check,
}

/// `identify` options.
#[derive(Args, Debug, Clone)]
#[command(
    mut_arg("json", |a| a.help(
        "Write every run's identification (circle fits, parameters, tool point, warnings) as \
         JSON to FILE"
    )),
    mut_arg("csv", |a| a.help(
        "Write joints.csv (per run and joint: circle fit and parameters) and runs.csv (per run: \
         tool point, J1 axis, warnings) into DIR"
    )),
    mut_arg("svg", |a| a.help("Write residuals.svg (circle-fit RMS residual per joint) into DIR")),
    mut_arg("quiet", |a| a.help("Print only warnings and errors"))
)]
#[command(group(clap::ArgGroup::new("noise").args(["tracker_sigma", "tracker_mpe"])))]
pub struct IdentifyArgs {
    /// Tracker data CSV, told apart by the header: sweeps (joint,q1..qn,x,y,z) or poses
    /// (q1..qn,x,y,z, optionally sx,sy,sz, payload_kg, and target (several reflectors per pose,
    /// fitted together; the first is the model's tool) with mount = tool|base (reflectors on the
    /// base follow tracker drift); n = the model's joints); either may have a run column;
    /// degrees and mm, in any measurement frame.
    #[arg(value_name = "DATA.csv")]
    pub sweeps: PathBuf,
    /// The data file's columns as a tracker or robot log exported them: ours=theirs[:unit],...
    /// (e.g. q1=A1:rad,...,x=X:m,y=Y:m,z=Z:m); units mm, cm, m, in, um; deg, rad; kg, g, lb.
    /// Unnamed columns keep their names.
    #[arg(long, value_name = "MAP")]
    pub columns: Option<String>,
    /// The data file's field delimiter, one character (e.g. ';' or tab), when not a comma.
    #[arg(long, value_name = "CHAR")]
    pub delimiter: Option<String>,
    /// The data are in the robot's base frame (J1 along z): do not identify the placement.
    #[arg(long)]
    pub base_known: bool,
    /// Fix these parameters at their nominal values, by name: theta1…beta6, tool_x…tool_z,
    /// base_x, base_y, base_z, base_roll, base_pitch, base_yaw.
    #[arg(long, value_delimiter = ',', value_name = "NAME,...")]
    pub fix: Vec<String>,
    /// Tracker noise: σ per coordinate, mm (default: the data's sx,sy,sz columns, else estimated
    /// from the residuals).
    #[arg(long, value_name = "MM")]
    pub tracker_sigma: Option<f64>,
    /// Tracker noise from its MPE: A,B[,R] = ±(A µm + B µm/m · distance) across the line of
    /// sight and ±R µm along it (default R = 10), each MPE taken as 2σ; e.g. 15,6 for an
    /// AT960-class tracker. The tracker stands at the data frame's origin (see --tracker-at).
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "A,B[,R]",
        allow_hyphen_values = true
    )]
    pub tracker_mpe: Option<Vec<f64>>,
    /// Tracker position in the data's frame, mm, for --tracker-mpe (default: the origin, where a
    /// tracker's own frame has it).
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "X,Y,Z",
        requires = "tracker_mpe",
        allow_hyphen_values = true
    )]
    pub tracker_at: Option<Vec<f64>>,
    /// How the parameters' covariance is obtained: linearised s²(JᵀWJ)⁻¹, or the spread of
    /// Monte Carlo re-identifications of synthetic data drawn around the fit.
    #[arg(long, value_enum, default_value_t = UncertaintyArg::Linearised)]
    pub uncertainty: UncertaintyArg,
    /// Number of Monte Carlo re-identifications for --uncertainty montecarlo (10 to 10000).
    #[arg(long, default_value_t = 200, value_name = "K")]
    pub mc_draws: usize,
    /// Seed of the Monte Carlo re-identification.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Leave out the compensation (the Gaussian process over the joint configuration fitted to
    /// the residuals, kept when it predicts held-out poses better; docs "Honest on a real
    /// robot"). Data with several runs never get one (their mean model has none).
    #[arg(long)]
    pub no_compensation: bool,
    /// Fit joint compliance under gravity (default link masses) and gear harmonics (once and
    /// twice per turn) with the geometry: by default (auto) when the geometric fit shows a lack
    /// of fit, kept in the model when they predict left-out poses better (the report says
    /// which and why). A bare --beyond-geometry means on; off, on and keep choose explicitly.
    #[arg(
        long,
        value_enum,
        value_name = "WHEN",
        num_args = 0..=1,
        require_equals = true,
        default_value_t = BeyondArg::Auto,
        default_missing_value = "on"
    )]
    pub beyond_geometry: BeyondArg,
    /// Per joint, the gear harmonics fitted beyond geometry: orders 1 to N (0, 1 or 2; 0 for
    /// none), one value per joint, e.g. 2,2,1,0,0,0; every joint whose gravity torque varies
    /// keeps its compliance. Default: the data choose per joint the orders and the compliance
    /// (backward elimination by Akaike's criterion: a term goes while dropping it lowers
    /// χ² + 2·coefficients).
    #[arg(long, value_name = "N,N,...", value_delimiter = ',')]
    pub harmonic_orders: Option<Vec<u8>>,
    /// Write the identified model (TOML) to FILE.
    #[arg(long, short, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Nominal model giving the structure and conventions (default: the preset): a model file
    /// or a robot description (.urdf, DH table .csv, UR calibration .yaml).
    #[arg(long, value_name = "FILE")]
    pub nominal: Option<PathBuf>,
    /// Built-in nominal model used when --nominal is not given [default: tx60].
    #[arg(long, value_name = "NAME")]
    pub preset: Option<String>,
    /// Circle model.
    #[arg(long, value_enum, default_value_t = FitArg::Commanded)]
    pub fit: FitArg,
    /// Use the data alone: no prior towards the nominal geometry.
    #[arg(long)]
    pub no_prior: bool,
    /// Skip the least-squares refinement over all sweep points (sweeps in the base frame only;
    /// the model then has no covariance of its own).
    #[arg(long)]
    pub no_refine: bool,
    /// With several runs, write the full sample covariance of the parameters instead of
    /// independent σ.
    #[arg(long)]
    pub covariance: bool,
    /// Fail (exit 2, no model file) when a result looks implausible or the data cannot identify
    /// the parameters: a fit RMS residual above 0.05 mm, a parameter more than 5 mm / 2° from
    /// nominal, a J1 axis away from base z, rank deficiency, a condition number above 100,
    /// residuals inconsistent with the stated noise.
    #[arg(long)]
    pub strict: bool,
    /// Print every run's per-joint fit and parameter tables instead of a summary.
    #[arg(long, short, conflicts_with = "quiet")]
    pub verbose: bool,
    #[command(flatten)]
    pub reports: ReportFlags,
    #[command(flatten)]
    pub memory: MemoryArgs,
}

impl Run for IdentifyArgs {
    fn run(self) -> Result<()> {
        let a = self;
        use gpu_amcs::identify::{self, IdentifyJobError};
        let mut inputs = vec![("the data file", a.sweeps.as_path())];
        inputs.extend(a.nominal.as_deref().map(|n| ("--nominal", n)));
        let mut outputs = Outputs::new(inputs);
        outputs.file("--out", a.out.as_deref())?;
        a.reports
            .declare(&mut outputs, &IdentifyReports::planned_layout())?;
        let preset = a.preset.as_deref().unwrap_or(DEFAULT_PRESET);
        let nominal = load_model(a.nominal.as_deref(), preset).context("--nominal")?;
        // Where a preset does not fit the data, the refusal says which presets do.
        let hint = |nominal: &RobotModel| match a.nominal {
            Some(_) => None,
            None => preset_hint(&a.sweeps, nominal, a.preset.is_none()),
        };
        let mut job = a.job(nominal.clone());
        job.columns = column_map(a.columns.as_deref(), a.delimiter.as_deref())?;
        a.check_memory(&job)?;
        // Data from a pipe are sized by the job once read.
        job.memory = Some(a.memory.budget()?);
        // In per cent of the work: several runs report their steps as shares of the whole.
        let bar = std::sync::Arc::new(Progress::new(a.reports.quiet, "identify", "%"));
        let listener = bar.clone();
        job.progress = ProgressHook::new(move |label: &str, done, total| {
            listener.set_message(label);
            listener.update(done.min(total) * 100 / total.max(1), 100);
        });
        let result = job.run();
        bar.finish();
        let outcome = match result {
            Ok(o) => o,
            Err(IdentifyJobError::Strict { warnings }) => {
                for w in &warnings {
                    eprintln!("warning: {w}");
                }
                bail!(
                    "--strict: {} implausible result(s) (warnings above); no model written",
                    warnings.len()
                );
            }
            Err(IdentifyJobError::Setting { setting, message }) => {
                bail!("{}: {message}", setting_flag(setting))
            }
            Err(IdentifyJobError::Identify(e)) => match hint(&nominal) {
                Some(h) => bail!("{e} ({h})"),
                None => return Err(e.into()),
            },
        };
        // stdout is built first and printed after the model file is written, so a reader that
        // stops early (`| head`) cannot cost the file.
        let quiet = a.reports.quiet;
        let mut text = String::new();
        if a.verbose {
            for id in &outcome.runs {
                text.push_str(&identify::render_identify_report(&id.report));
                text.push('\n');
            }
        } else if !quiet {
            text.push_str(&outcome.reports.text());
        }
        for w in &outcome.warnings {
            eprintln!("warning: {w}");
        }
        if !quiet {
            text.push_str(&outcome.note);
            text.push('\n');
        }
        outputs.stage_file("--out", outcome.file_text.clone())?;
        let yes_no = |b: bool| if b { "yes" } else { "no" }.to_string();
        let rows = [
            ("data file".to_string(), a.sweeps.display().to_string()),
            (
                "frame".to_string(),
                identify::frame_label(outcome.chain.placement).to_string(),
            ),
            ("noise".to_string(), outcome.chain.noise.describe()),
            (
                "prior towards the nominal geometry".to_string(),
                yes_no(!a.no_prior),
            ),
            ("whole-chain refinement".to_string(), yes_no(!a.no_refine)),
        ];
        stage_reports(&mut outputs, &outcome.reports, &rows)?;
        outputs.commit()?;
        if let (Some(o), false) = (&a.out, quiet) {
            text.push_str(&format!("wrote {}\n", o.display()));
        }
        crate::cmd::stdout::print(&text)?;
        Ok(())
    }
}

/// The preset `identify` takes as the nominal model when neither --nominal nor --preset is
/// given.
const DEFAULT_PRESET: &str = "tx60";

/// What to pass when the preset `nominal` (the default one when `defaulted`) does not take the
/// data's rows (their joint count or a joint limit): the presets that do, else --nominal. `None`
/// when it takes them (the refusal is about something else) or the data cannot be read again (a
/// pipe).
fn preset_hint(data: &Path, nominal: &RobotModel, defaulted: bool) -> Option<String> {
    let d = gpu_amcs::identify::read_tracker_data(data).ok()?;
    let fits = |m: &RobotModel| gpu_amcs::identify::check_tracker_data(&d, m, "").is_ok();
    if fits(nominal) {
        return None;
    }
    let which = if defaulted {
        format!(
            "the nominal model is the built-in {} when neither --nominal nor --preset is given",
            nominal.name
        )
    } else {
        format!("the nominal model is the preset {}", nominal.name)
    };
    let names: Vec<&str> = PRESETS
        .iter()
        .copied()
        .filter(|p| preset(p).is_ok_and(|m| fits(&m)))
        .collect();
    Some(match names.first() {
        Some(first) => format!(
            "{which}; {} these data: pass --preset {first}, or --nominal FILE with your robot's model",
            match names.len() {
                1 => format!("the preset {first} takes"),
                _ => format!("the presets {} take", names.join(", ")),
            }
        ),
        None => format!(
            "{which}; no preset takes these data: pass --nominal FILE with your robot's model (a model file, URDF, DH table or UR calibration file)"
        ),
    })
}

/// The flag of a setting an identification names in its errors.
fn setting_flag(s: IdentifySetting) -> &'static str {
    match s {
        IdentifySetting::TrackerSigma => "--tracker-sigma",
        IdentifySetting::TrackerMpe => "--tracker-mpe",
        IdentifySetting::TrackerAt => "--tracker-at",
        IdentifySetting::McDraws => "--mc-draws",
        IdentifySetting::Fit => "--fit",
        IdentifySetting::Refine => "--no-refine",
        IdentifySetting::Memory => "--memory-limit",
        IdentifySetting::Columns => "--columns",
        IdentifySetting::HarmonicOrders => "--harmonic-orders",
    }
}

/// The length of the data file and its number of lines (an upper bound on its rows), counted
/// without keeping the text; `None` for what is not a regular file (a pipe gives its bytes only
/// once, to the identification).
fn data_size(path: &Path) -> Option<(u64, u64)> {
    use std::io::Read;
    let meta = std::fs::metadata(path).ok()?;
    if !meta.is_file() {
        return None;
    }
    let mut f = std::fs::File::open(path).ok()?;
    let mut buf = vec![0u8; 1 << 16];
    let (mut lines, mut last) = (0u64, b'\n');
    loop {
        match f.read(&mut buf) {
            Ok(0) => break,
            Ok(k) => {
                lines += buf[..k].iter().filter(|&&b| b == b'\n').count() as u64;
                last = buf[k - 1];
            }
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(_) => return None,
        }
    }
    // A last line without its newline counts too.
    Some((meta.len(), lines + u64::from(last != b'\n')))
}

/// The column map of `--columns` and `--delimiter` (a delimiter alone maps nothing).
pub fn column_map(
    columns: Option<&str>,
    delimiter: Option<&str>,
) -> Result<Option<gpu_amcs::identify::ColumnMap>> {
    use gpu_amcs::identify::{ColumnMap, ColumnMapSetting};
    ColumnMap::from_settings(columns, delimiter).map_err(|(setting, message)| {
        let flag = match setting {
            ColumnMapSetting::Map => "--columns",
            ColumnMapSetting::Delimiter => "--delimiter",
        };
        anyhow::anyhow!("{flag}: {message}")
    })
}

impl IdentifyArgs {
    /// Sizes the identification from the data file's rows before reading it: the fit, the lack
    /// of fit and its compensation (naming --memory-limit), then the Monte Carlo
    /// re-identifications (naming --mc-draws).
    fn check_memory(&self, job: &IdentifyJob) -> Result<()> {
        use gpu_amcs::memory::Estimate;
        let Some((bytes, rows)) = data_size(&self.sweeps) else {
            return Ok(());
        };
        let threads = rayon::current_num_threads() as u64;
        let what = format!("identifying the {rows} lines of {}", self.sweeps.display());
        self.memory.check(&job.memory_estimate(
            rows,
            bytes,
            threads,
            false,
            Estimate::new(
                what.clone(),
                "identify a subset of the rows, or raise --memory-limit",
            ),
        ))?;
        if self.uncertainty == UncertaintyArg::Montecarlo {
            self.memory.check(&job.memory_estimate(
                rows,
                bytes,
                threads,
                true,
                Estimate::new(
                    format!(
                        "{what} with {} Monte Carlo re-identifications",
                        self.mc_draws
                    ),
                    "use fewer --mc-draws (or --uncertainty linearised), or raise --memory-limit",
                ),
            ))?;
        }
        Ok(())
    }

    /// The library's job of the flags.
    fn job(&self, nominal: RobotModel) -> IdentifyJob {
        IdentifyJob {
            placement: if self.base_known {
                Placement::Known
            } else {
                Placement::Identify
            },
            fix: self.fix.clone(),
            tracker_sigma_mm: self.tracker_sigma,
            tracker_mpe: self.tracker_mpe.clone(),
            tracker_at_mm: self.tracker_at.clone(),
            uncertainty: match self.uncertainty {
                UncertaintyArg::Linearised => UncertaintyMethod::Linearised,
                UncertaintyArg::Montecarlo => UncertaintyMethod::MonteCarlo {
                    draws: self.mc_draws,
                },
            },
            seed: self.seed,
            method: match self.fit {
                FitArg::Commanded => CircleFitMethod::CommandedAngles,
                FitArg::PointCloud => CircleFitMethod::PointCloud,
            },
            prior: !self.no_prior,
            refine: !self.no_refine,
            covariance: self.covariance,
            strict: self.strict,
            compensate: !self.no_compensation,
            beyond_geometry: match self.beyond_geometry {
                BeyondArg::Off => JointErrorFit::Off,
                BeyondArg::Auto => JointErrorFit::Auto,
                BeyondArg::On => JointErrorFit::On,
                BeyondArg::Keep => JointErrorFit::Keep,
                BeyondArg::Check => JointErrorFit::Check,
            },
            harmonic_orders: self.harmonic_orders.clone(),
            ..IdentifyJob::new(self.sweeps.clone(), nominal)
        }
    }
}
