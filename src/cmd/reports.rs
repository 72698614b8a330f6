//! Writing any report: the flags of [`ReportFlags`] turned into checked outputs before the work
//! ([`ReportFlags::declare`], with the files the report's `Layout` names), and after it every
//! part of a `gpu_amcs::report::Report` the flags ask for written all or none
//! ([`write_reports`]). What an analysis writes is said once, by its `Report` in the library;
//! nothing here names an analysis. Also the model-and-settings rows of a report page that only
//! the command line knows ([`problem_rows`]).

use super::args::ProblemArgs;
use super::outputs::Outputs;
use anyhow::{bail, Result};
use clap::Args;
use gpu_amcs::job::Analysed;
use gpu_amcs::kinematics::Uncertainty;
use gpu_amcs::points::WorkspaceBox;
use gpu_amcs::report::{Layout, Report};
use std::path::PathBuf;

/// Where the reports of an analysis go: the one group of report flags every subcommand that
/// writes reports flattens (`cmd/reports.rs` declares and writes them for any
/// `gpu_amcs::report::Report`). The help texts are a run's; a subcommand whose reports are
/// other files gives its own with `#[command(mut_arg(...))]` on its arguments.
#[derive(Args, Debug, Clone, Default)]
pub struct ReportFlags {
    /// Write the report as JSON to FILE.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Write CSV files (CDF, PDF, reliability, convergence trace) into DIR.
    #[arg(long, value_name = "DIR")]
    pub csv: Option<PathBuf>,
    /// Write SVG plots (PDF, reliability curve, convergence) into DIR.
    #[arg(long, value_name = "DIR")]
    pub svg: Option<PathBuf>,
    /// Write a self-contained HTML report into DIR: index.html (summary, tables, figures, model
    /// and settings; no scripts, nothing loaded from elsewhere) and the JSON, CSV and SVG files
    /// it links to.
    #[arg(long, value_name = "DIR")]
    pub html: Option<PathBuf>,
    /// No progress bar and no table on stdout.
    #[arg(long, short)]
    pub quiet: bool,
}

/// The flags, as outputs name them.
const JSON: &str = "--json";
const CSV: &str = "--csv";
const SVG: &str = "--svg";
const HTML: &str = "--html";

impl ReportFlags {
    /// The first report flag given, for commands that write reports only in some modes.
    pub fn given(&self) -> Option<&'static str> {
        [
            (JSON, self.json.is_some()),
            (CSV, self.csv.is_some()),
            (SVG, self.svg.is_some()),
            (HTML, self.html.is_some()),
        ]
        .into_iter()
        .find(|(_, given)| *given)
        .map(|(flag, _)| flag)
    }

    /// Declares and checks the outputs these flags ask for, before any work: `--json`, and
    /// `--csv`, `--svg` and `--html` directories that may write the files `layout` names.
    pub fn declare(&self, outputs: &mut Outputs, layout: &Layout) -> Result<()> {
        for (flag, dir, names) in [(CSV, &self.csv, &layout.csv), (SVG, &self.svg, &layout.svg)] {
            if dir.is_some() && names.is_empty() {
                bail!("{flag}: this report has no such files");
            }
        }
        outputs.file(JSON, self.json.as_deref())?;
        outputs.dir(CSV, self.csv.as_deref(), layout.csv.clone())?;
        outputs.dir(SVG, self.svg.as_deref(), layout.svg.clone())?;
        outputs.dir(HTML, self.html.as_deref(), layout.html())
    }
}

/// Stages every part of `report` that was declared: the JSON document, the CSV and SVG files,
/// and the HTML directory (`settings`: the rows of its model-and-settings table only the
/// command line knows).
pub fn stage_reports(
    outputs: &mut Outputs,
    report: &dyn Report,
    settings: &[(String, String)],
) -> Result<()> {
    if outputs.has(JSON) {
        outputs.stage_file(JSON, report.json())?;
    }
    if outputs.has(CSV) {
        outputs.stage_dir(CSV, report.csv())?;
    }
    if outputs.has(SVG) {
        outputs.stage_dir(SVG, report.svg())?;
    }
    if outputs.has(HTML) {
        outputs.stage_dir(HTML, report.html(settings))?;
    }
    Ok(())
}

/// Writes the declared reports of `report` with every other staged output, all or none, then
/// prints its text unless `flags` say quiet.
pub fn write_reports(
    mut outputs: Outputs,
    report: &dyn Report,
    flags: &ReportFlags,
    settings: &[(String, String)],
) -> Result<()> {
    stage_reports(&mut outputs, report, settings)?;
    outputs.commit()?;
    if !flags.quiet {
        crate::cmd::stdout::print(&report.text())?;
    }
    Ok(())
}

/// Where the model came from: a model file or a built-in preset.
pub fn model_source(model: &super::args::ModelArgs) -> String {
    match &model.model {
        Some(p) => format!("model file {}", p.display()),
        None => format!("built-in preset {}", model.preset),
    }
}

/// The CPU threads of `--threads`.
pub fn threads_row(threads: Option<usize>) -> (String, String) {
    (
        "CPU threads".into(),
        threads.map_or("all cores".to_string(), |t| t.to_string()),
    )
}

/// Where the model and the test points came from, the uncertain parameters and the threads.
pub fn problem_rows(args: &ProblemArgs, problem: &Analysed) -> Vec<(String, String)> {
    let free = problem.model.free_inputs().len();
    let form = match problem.model.uncertainty {
        Uncertainty::Independent(_) => "independent normal",
        Uncertainty::Covariance(_) => "normal with full covariance",
    };
    let points = match &args.points_file {
        Some(p) => format!("{} from {}", problem.points, p.display()),
        None => {
            // The box the points were generated in: the flags where given, else the robot's
            // default (already checked when the problem was built).
            let b = args
                .workspace
                .workspace(&problem.model)
                .unwrap_or_else(|_| WorkspaceBox::for_robot(&problem.model));
            let v = |x: &[f64]| {
                x.iter()
                    .map(|v| v.to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            format!(
                "{} generated in the box centred at ({}) mm with edges ({}) mm, seed {}",
                problem.points,
                v(&b.center),
                v(&b.size),
                args.points_seed
            )
        }
    };
    vec![
        ("model source".into(), model_source(&args.model)),
        ("uncertain parameters".into(), format!("{free} ({form})")),
        ("test points source".into(), points),
        threads_row(args.threads),
    ]
}
