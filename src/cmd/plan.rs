//! `plan`: choose the poses to measure for a calibration and predict the reliability they give
//! at the task points, before the tracker is switched on (the library's `PlanJob`).

use super::args::{thread_pool, three_values, ProblemArgs};
use super::flags::job_error;
use super::outputs::Outputs;
use super::progress::Bars;
use super::reports::{problem_rows, write_reports, ReportFlags};
use super::Run;
use anyhow::{bail, Result};
use clap::Args;
use gpu_amcs::job::{JobError, PlanJob, PlanTask};
use gpu_amcs::plan::program::ProgramFormat;
use gpu_amcs::plan::{self, KeepOut, Plan, PlanError, PlanField, TrackerSite, Workcell};
use std::path::PathBuf;

/// The library's default plan thresholds (`gpu_amcs::plan::DEFAULT_THRESHOLDS_MM`) as one
/// `--threshold` value.
static PLAN_THRESHOLDS: std::sync::LazyLock<String> =
    std::sync::LazyLock::new(|| super::args::comma_list(&gpu_amcs::plan::DEFAULT_THRESHOLDS_MM));

/// `plan` options.
#[derive(Args, Debug, Clone)]
#[command(
    mut_arg("json", |a| a.help("Write the plan as JSON to FILE")),
    mut_arg("csv", |a| a.help("Write plan_compare.csv and plan_curve.csv into DIR")),
    mut_arg("svg", |a| a.help("Write plan_curve.svg (q95 of w against the number of poses) into DIR")),
    mut_arg("reference", |a| a.hide(true)),
    mut_arg("nominal", |a| a.hide(true)),
    mut_arg("frame", |a| a.hide(true))
)]
pub struct PlanArgs {
    /// The nominal robot (--model/--preset) and the task points (--points/--points-file), where
    /// the reliability is wanted.
    #[command(flatten)]
    pub problem: ProblemArgs,
    /// Poses to measure.
    #[arg(long, default_value_t = 30, value_name = "N")]
    pub poses: usize,
    /// Tracker noise per coordinate, mm (1σ).
    #[arg(
        long,
        default_value_t = 0.01,
        value_name = "MM",
        allow_hyphen_values = true
    )]
    pub tracker_sigma: f64,
    /// Where the tracker stands, mm, in the model's measurement frame (its base frame for a
    /// model without `base`): candidates must face it and lie within its range, so it must
    /// stand within --tracker-range of some pose of the target.
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "X,Y,Z",
        allow_hyphen_values = true
    )]
    pub tracker_at: Option<Vec<f64>>,
    /// With --tracker-at: the tracker's range, mm (at most 100000: 100 m).
    #[arg(
        long,
        default_value_t = 20_000.0,
        value_name = "MM",
        requires = "tracker_at"
    )]
    pub tracker_range: f64,
    /// With --tracker-at: largest angle between the target's facing direction (the flange z
    /// axis) and the line to the tracker, degrees.
    #[arg(
        long,
        default_value_t = 60.0,
        value_name = "DEG",
        requires = "tracker_at"
    )]
    pub max_incidence: f64,
    /// The target on the flange, mm (default: the model's tool when it is at least 1 mm off the
    /// last joint's axis, else 30,-20,80 as `simulate` uses).
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "X,Y,Z",
        allow_hyphen_values = true
    )]
    pub target: Option<Vec<f64>>,
    /// Thresholds L (mm) of the predicted reliability R(L) = Pr[w < L].
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "MM,...",
        default_value = PLAN_THRESHOLDS.as_str(),
        allow_hyphen_values = true
    )]
    pub threshold: Vec<f64>,
    /// Candidate configurations to choose from.
    #[arg(long, default_value_t = 2000, value_name = "M")]
    pub candidates: usize,
    /// Draws of the engine's Monte Carlo of the planned model at the task points.
    #[arg(long, default_value_t = 100_000, value_name = "N")]
    pub draws: usize,
    /// Plan for the ISO 9283 test poses P1–P5 (as `points --iso9283` places them, tool
    /// pointing down) instead of task points; the text and page then give each pose's
    /// Pr[AP_j ≤ L], the certificate.
    #[arg(long, conflicts_with = "points_file")]
    pub iso9283: bool,
    /// Write the design (q1..qn in degrees, in visiting order) to FILE.
    #[arg(long, short, value_name = "FILE")]
    pub out: PathBuf,
    /// The floor's height, mm, in the model's measurement frame (its base frame for a model
    /// without `base`; z up): no moving link's capsule may reach below it (default: no floor).
    #[arg(long, value_name = "Z", allow_hyphen_values = true)]
    pub floor: Option<f64>,
    /// A box no link may reach into, mm, corners x0,y0,z0,x1,y1,z1 in the measurement frame
    /// (repeatable).
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "X0,Y0,Z0,X1,Y1,Z1",
        allow_hyphen_values = true,
        action = clap::ArgAction::Append
    )]
    pub keep_out: Vec<f64>,
    /// Let the arm's links pass through each other (no self-collision check).
    #[arg(long)]
    pub no_self_collision: bool,
    /// Radius of every link's capsule, mm (default: 15 % of each link's length, 20 … 50 mm; at
    /// most half the arm's length between its base column and its last link, beyond which the
    /// self-collision check would compare no two links).
    #[arg(long, value_name = "MM")]
    pub link_radius: Option<f64>,
    /// Write the design as a robot program to FILE: URScript (.script), RAPID (.mod) or KRL
    /// (.src), by the extension or --program-format.
    #[arg(long, value_name = "FILE")]
    pub program: Option<PathBuf>,
    /// The robot program's language, when FILE's extension does not say it.
    #[arg(long, value_name = "FORMAT", requires = "program", value_parser = ["urscript", "rapid", "krl"])]
    pub program_format: Option<String>,
    /// With --program: seconds to wait at each pose for the tracker's measurement.
    #[arg(long, default_value_t = 2.0, value_name = "S", requires = "program")]
    pub settle: f64,
    /// Make every joint arrive at each pose moving in this direction (from an approach pose 2°
    /// short of it on that side, which the candidates must reach too), so that gear backlash is
    /// engaged the same way at every pose: the program gets the approach moves and --out the
    /// sides s1..sn a pose file records.
    #[arg(long, value_name = "SIDE", value_parser = ["positive", "negative"])]
    pub approach: Option<String>,
    #[command(flatten)]
    pub reports: ReportFlags,
}

/// The flag of a plan setting.
fn flag(f: PlanField) -> &'static str {
    match f {
        PlanField::Poses => "--poses",
        PlanField::Candidates => "--candidates",
        PlanField::Sigma => "--tracker-sigma",
        PlanField::Tracker => "--tracker-at",
        PlanField::TrackerRange => "--tracker-range",
        PlanField::MaxIncidence => "--max-incidence",
        PlanField::Thresholds => "--threshold",
        PlanField::Search => "--draws",
        PlanField::TaskPoints => "--points-file",
        PlanField::Target => "--target",
        PlanField::Floor => "--floor",
        PlanField::KeepOut => "--keep-out",
        PlanField::LinkRadius => "--link-radius",
        PlanField::SelfCollision => "--no-self-collision",
        PlanField::Program => "--program",
        PlanField::Approach => "--approach",
    }
}

fn plan_error(e: PlanError, iso9283: bool) -> anyhow::Error {
    match e {
        PlanError::Setting {
            field: PlanField::TaskPoints,
            message,
        } if iso9283 => {
            anyhow::anyhow!("the ISO 9283 test poses (--iso9283): {message} (--floor, --keep-out)")
        }
        PlanError::Setting { field, message } => {
            anyhow::anyhow!("{} ({}): {message}", field, flag(field))
        }
        PlanError::Unused {
            field,
            needs,
            message,
        } => {
            let needs: Vec<&str> = needs.into_iter().map(flag).collect();
            anyhow::anyhow!(
                "{} ({}): {message} ({})",
                field,
                flag(field),
                needs.join(", ")
            )
        }
        PlanError::NotIdentifiable(m) => anyhow::anyhow!(
            "the candidates do not identify the model (--target, --candidates): {m}"
        ),
        other => other.into(),
    }
}

/// `--nominal` without `--reference nominal` (which the job refuses, with `--frame base`): the
/// spec has no place for a nominal model the reference does not use, so the job never sees it.
fn refuse_nominal(p: &super::args::ProblemArgs) -> Result<()> {
    if p.nominal.is_some() && p.reference == super::args::ReferenceArg::Calibrated {
        bail!("--nominal: plan predicts the planned calibration's error against its own model; the robot to plan for is --model or --preset");
    }
    Ok(())
}

impl Run for PlanArgs {
    fn run(self) -> Result<()> {
        let a = self;
        refuse_nominal(&a.problem)?;
        a.problem.check()?;
        let mut outputs = Outputs::new(a.problem.inputs());
        outputs.file("--out", Some(&a.out))?;
        outputs.file("--program", a.program.as_deref())?;
        a.reports.declare(&mut outputs, &Plan::planned_layout())?;
        let program_format = program_format(&a)?;
        let workcell = workcell(&a)?;
        let target = a
            .target
            .as_deref()
            .map(|t| three_values("--target", "x, y, z in mm", t))
            .transpose()?;
        let tracker_at = a
            .tracker_at
            .as_deref()
            .map(|t| three_values("--tracker-at", "x, y, z in mm", t))
            .transpose()?;
        // The plan's steps under one bar, then the prediction's draws under another.
        let bars = Bars::new(a.reports.quiet, |label| match label {
            "plan prediction" => ("plan prediction", "draws", false),
            _ => ("plan", "steps", false),
        });
        let job = PlanJob {
            setup: a.problem.setup(&bars)?,
            task: if a.iso9283 {
                PlanTask::Iso9283
            } else {
                PlanTask::Points
            },
            poses: a.poses,
            candidates: a.candidates,
            sigma_mm: a.tracker_sigma,
            tracker: tracker_at.map(|t| TrackerSite {
                position_mm: t,
                range_mm: a.tracker_range,
                max_incidence_deg: a.max_incidence,
            }),
            thresholds: a.threshold.clone(),
            target,
            workcell,
            draws: a.draws,
            approach: a.approach.as_deref().and_then(plan::Approach::from_name),
        };
        let error = |e| job_plan_error(e, a.iso9283);
        job.check().map_err(error)?;
        let pool = thread_pool(a.problem.threads)?;
        let outcome = pool.install(|| job.run(gpu_amcs::backends()));
        bars.finish();
        let outcome = outcome.map_err(error)?;
        let rows = problem_rows(&a.problem, &outcome.analysed);
        let plan = outcome.plan;
        outputs.stage_file("--out", plan.design_csv())?;
        if let (Some(path), Some(format)) = (&a.program, program_format) {
            let name = path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
            let text = plan::program::robot_program(&plan, format, &name, a.settle)
                .map_err(|e| plan_error(e, false))?;
            outputs.stage_file("--program", text)?;
        }
        write_reports(outputs, &plan, &a.reports, &rows)
    }
}

/// A plan job's error: the plan's own with their flags, the rest as any job's.
fn job_plan_error(e: JobError, iso9283: bool) -> anyhow::Error {
    match e {
        JobError::Plan(e) => plan_error(e, iso9283),
        e => job_error(e),
    }
}

/// The robot program's language: --program-format, else the extension of --program's file.
fn program_format(a: &PlanArgs) -> Result<Option<ProgramFormat>> {
    let Some(path) = &a.program else {
        return Ok(None);
    };
    let named = a
        .program_format
        .as_deref()
        .or_else(|| path.extension().and_then(|e| e.to_str()));
    match named.and_then(ProgramFormat::from_extension) {
        Some(f) => Ok(Some(f)),
        None => bail!(
            "--program: {} does not end in .script (URScript), .mod (RAPID) or .src (KRL); give --program-format",
            path.display()
        ),
    }
}

/// The workcell of --floor, --keep-out (six numbers a box), --no-self-collision and
/// --link-radius (its figures are the job's to check).
fn workcell(a: &PlanArgs) -> Result<Workcell> {
    if !a.keep_out.len().is_multiple_of(6) {
        bail!(
            "--keep-out: each box is six numbers x0,y0,z0,x1,y1,z1 (mm), got {} numbers",
            a.keep_out.len()
        );
    }
    Ok(Workcell {
        floor_mm: a.floor,
        keep_out: a
            .keep_out
            .chunks(6)
            .map(|c| KeepOut::between([c[0], c[1], c[2], c[3], c[4], c[5]]))
            .collect(),
        self_collision: !a.no_self_collision,
        link_radius_mm: a.link_radius,
    })
}
