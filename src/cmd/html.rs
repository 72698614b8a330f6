//! `--html DIR`: what the subcommands share to write a report directory (the page is built by
//! `gpu_amcs::report::html`): the names a report directory may hold, declared before the work,
//! and the model-and-settings rows only the command line knows (where the model and the test
//! points came from).

use super::outputs::Outputs;
use crate::cli::{HtmlArgs, ProblemArgs};
use anyhow::Result;
use gpu_amcs::engine::Problem;
use gpu_amcs::kinematics::Uncertainty;
use std::path::Path;

/// The flag of the report directory.
pub const FLAG: &str = "--html";

/// The files of a run's report directory (`report::html::pages::run_files`).
pub const RUN_NAMES: &[&str] = &[
    "index.html",
    "report.json",
    "cdf.csv",
    "pdf.csv",
    "reliability.csv",
    "trace.csv",
    "per_point.csv",
    "pdf.svg",
    "reliability.svg",
    "convergence.svg",
];

/// The files of a comparison's report directory.
pub const COMPARE_NAMES: &[&str] = &[
    "index.html",
    "comparison.json",
    "comparison.md",
    "comparison.csv",
    "pdf.svg",
    "reliability.svg",
];

/// The files of a sensitivity report directory.
pub const SENSITIVITY_NAMES: &[&str] = &[
    "index.html",
    "sensitivity.json",
    "indices.csv",
    "indices.svg",
    "groups.svg",
];

/// The files of a tail report directory.
pub const TAIL_NAMES: &[&str] = &["index.html", "tail.json", "tail.csv", "tail.svg"];

impl HtmlArgs {
    /// Declares the report directory (when given) that may write `names`.
    pub fn declare(&self, outputs: &mut Outputs, names: &'static [&'static str]) -> Result<()> {
        outputs.dir(FLAG, self.html.as_deref(), names)
    }
}

/// Whether the directories `a` and `b` are one (as far as they exist, links resolved).
pub fn same_dir(a: &Path, b: &Path) -> bool {
    let place = |p: &Path| {
        std::fs::canonicalize(p)
            .or_else(|_| std::path::absolute(p))
            .unwrap_or_else(|_| p.to_path_buf())
    };
    place(a) == place(b)
}

/// Where the model and the test points came from, the uncertain parameters and the threads.
pub fn problem_rows(args: &ProblemArgs, problem: &Problem) -> Vec<(String, String)> {
    let model_source = match &args.model.model {
        Some(p) => format!("model file {}", p.display()),
        None => format!("built-in preset {}", args.model.preset),
    };
    let free = problem.model.free_params().len();
    let form = match problem.model.uncertainty {
        Uncertainty::Independent(_) => "independent normal",
        Uncertainty::Covariance(_) => "normal with full covariance",
    };
    let points = match &args.points_file {
        Some(p) => format!("{} from {}", problem.n_points(), p.display()),
        None => {
            let v = |x: &[f64]| {
                x.iter()
                    .map(|v| v.to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            format!(
                "{} generated in the box centred at ({}) mm with edges ({}) mm, seed {}",
                problem.n_points(),
                v(&args.workspace.box_center),
                v(&args.workspace.box_size),
                args.points_seed
            )
        }
    };
    vec![
        ("model source".into(), model_source),
        ("uncertain parameters".into(), format!("{free} ({form})")),
        ("test points source".into(), points),
        (
            "CPU threads".into(),
            args.threads
                .map_or("all cores".to_string(), |t| t.to_string()),
        ),
    ]
}
