//! `study`: the paper's factor study on a virtual TX60, written all or nothing into a directory.

use super::args::{sweeps_estimate, BYTES_PER_DRAW, BYTES_PER_POINT};
use super::flags::simulate_error;
use super::outputs::Outputs;
use super::progress::Progress;
use super::reports::{model_source, stage_reports};
use super::Run;
use crate::cmd::args::{BackendArgs, DeltasArgs, MemoryArgs, ModelArgs};
use crate::cmd::reports::ReportFlags;
use anyhow::Result;
use clap::Args;
use gpu_amcs::memory::Estimate;
use gpu_amcs::report::Report;
use gpu_amcs::study::StudyResult;
use std::path::PathBuf;

/// `study` options.
#[derive(Args, Debug, Clone)]
#[command(
    mut_arg("json", |a| a.help("Write study.json (every level's results) to FILE")),
    mut_arg("csv", |a| a.help("Write the tables (Tables 1–2, correlation, accuracy, ranking) as CSV into DIR")),
    mut_arg("svg", |a| a.help("Write the figures (Figs. 4–9) into DIR")),
    mut_arg("quiet", |a| a.help("No progress bar and no summary on stdout"))
)]
pub struct StudyArgs {
    /// Output directory (tables, figures, STUDY.md, study.json).
    #[arg(long, short, default_value = "study-out", value_name = "DIR")]
    pub out: PathBuf,
    /// Reduced study (2–3 levels per factor, 10 runs, MCS 10^5): about a minute.
    #[arg(long)]
    pub quick: bool,
    /// Factors to vary (default: all).
    #[arg(long, value_delimiter = ',', value_name = "NAME,...")]
    pub factors: Option<Vec<String>>,
    /// Calibration runs at the baseline (default 20, --quick 10).
    #[arg(long, value_name = "R")]
    pub runs: Option<usize>,
    /// MCS draws (default 10^6, --quick 10^5).
    #[arg(long, value_name = "N")]
    pub mcs_draws: Option<u64>,
    /// Numbers of test points.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "10,50",
        value_name = "N,..."
    )]
    pub points: Vec<usize>,
    #[command(flatten)]
    pub deltas: DeltasArgs,
    /// Seed of the simulated true robot.
    #[arg(long, default_value_t = 2025, value_name = "SEED")]
    pub robot_seed: u64,
    /// Seed of the calibration runs.
    #[arg(long, default_value_t = 1, value_name = "SEED")]
    pub seed: u64,
    #[command(flatten)]
    pub backend: BackendArgs,
    #[command(flatten)]
    pub reports: ReportFlags,
    #[command(flatten)]
    pub memory: MemoryArgs,
    /// Also calibrate the study's robot given joint compliance and gear harmonics of each size S
    /// (0–10, both alike; 1: a 60 kg-class arm, as simulate --compliance S --harmonics S), at
    /// the baseline from the circle-point sweeps and from random poses, each run identified with
    /// the geometry alone and with joint errors (identify's auto): beyond.csv and beyond.md give
    /// the accuracy before calibration, after the geometric one and with the full model.
    #[arg(long, value_delimiter = ',', value_name = "S,...")]
    pub joint_errors: Option<Vec<f64>>,
    /// Poses per calibration run of the pose calibrations of --joint-errors.
    #[arg(long, default_value_t = 200, value_name = "N")]
    pub joint_error_poses: usize,
    /// The robot studied (its nominal model; the simulator perturbs it).
    #[command(flatten)]
    pub model: ModelArgs,
}

impl Run for StudyArgs {
    fn run(self) -> Result<()> {
        let a = self;
        let model = a.model.load()?;
        let mut outputs = Outputs::new(a.model.model.as_deref().map(|p| ("--model", p)));
        // Every file of the study but the page, under any name: the --html directory may be
        // this one (its copies of the files are then the same files, written once).
        outputs.dir("--out", Some(&a.out), Vec::new())?;
        use gpu_amcs::study::{self, Factor, StudySettings};
        let mut s = if a.quick {
            StudySettings::quick()
        } else {
            StudySettings::default()
        };
        if let Some(r) = a.runs {
            s.baseline.runs = r;
        }
        if let Some(n) = a.mcs_draws {
            s.mcs_draws = n;
        }
        if let Some(fs) = &a.factors {
            s.factors = fs
            .iter()
            .map(|n| {
                Factor::ALL
                    .into_iter()
                    .find(|f| f.name().eq_ignore_ascii_case(n.trim()))
                    .ok_or_else(|| {
                        anyhow::anyhow!(
                            "--factors: unknown factor '{n}' (repeatability, range, step, speed, start)"
                        )
                    })
            })
            .collect::<Result<_>>()?;
        }
        s.point_counts = a.points.clone();
        s.deltas = a.deltas.deltas.clone();
        s.robot_seed = a.robot_seed;
        s.workspace = gpu_amcs::points::WorkspaceBox::for_robot(&model);
        s.calibration_seed = a.seed;
        s.joint_errors = a.joint_errors.clone().map(|sizes| study::JointErrorStudy {
            poses: a.joint_error_poses,
            ..study::JointErrorStudy::new(sizes)
        });
        let (backend, adapter) = a.backend.choice()?;
        s.backend = backend;
        s.adapter = adapter.map(str::to_owned);
        s.check().map_err(simulate_error)?;
        a.reports
            .declare(&mut outputs, &StudyResult::planned_layout(&s))?;
        // The test point sets are kept for the whole study, and each is copied into the two
        // evaluators (independent and correlated) of its level.
        let all_points: u64 = s.point_counts.iter().map(|&m| m as u64).sum();
        let most_points = s.point_counts.iter().max().map_or(0, |&m| m as u64);
        let e = Estimate::new(
            format!(
                "a study with {} MCS draws, {} calibration runs and {all_points} test points",
                s.mcs_draws, s.baseline.runs
            ),
            "lower --mcs-draws, --runs or --points, or raise --memory-limit",
        )
        .plus(&[s.mcs_draws, BYTES_PER_DRAW])
        .plus(&[all_points, BYTES_PER_POINT])
        .plus(&[most_points, 2, BYTES_PER_POINT]);
        a.memory.check(&sweeps_estimate(e, &s.baseline))?;
        let bar = Progress::new(a.reports.quiet, "study", "steps");
        let cb = |done: u64, total: u64, msg: &str| {
            bar.update(done, total);
            bar.set_message(msg);
        };
        let exp = gpu_amcs::simulate::Experiment::for_robot(model, s.robot_seed);
        let result = study::run_study_on(&exp, &s, gpu_amcs::backends(), Some(&cb))?;
        bar.finish();
        outputs.stage_dir("--out", result.files())?;
        let rows = [("model source".to_string(), model_source(&a.model))];
        stage_reports(&mut outputs, &result, &rows)?;
        outputs.commit()?;
        if !a.reports.quiet {
            crate::cmd::stdout::println(&format!(
                "{}; wrote {}",
                result.text().trim_end(),
                a.out.display()
            ))?;
        }
        Ok(())
    }
}
