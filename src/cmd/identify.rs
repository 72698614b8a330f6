//! `identify`: MDH parameters from laser-tracker sweeps (circle point method).

use super::args::load_model;
use super::outputs::Outputs;
use super::reports::stage_reports;
use super::Run;
use crate::cmd::reports::ReportFlags;
use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use gpu_amcs::identify::IdentifyReports;
use gpu_amcs::report::Report;
use std::path::PathBuf;

/// Circle model of the identification.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum FitArg {
    /// Circle through the points with each point's angle known from the commanded joint angle.
    Commanded,
    /// Plain point-cloud circle fit (plane, algebraic circle, geometric refinement).
    PointCloud,
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
pub struct IdentifyArgs {
    /// Sweeps CSV: joint,q1..q6,x,y,z (optionally a run column); degrees and mm.
    #[arg(value_name = "SWEEPS.csv")]
    pub sweeps: PathBuf,
    /// Write the identified model (TOML) to FILE.
    #[arg(long, short, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Nominal model giving the structure and conventions (default: the preset): a model file
    /// or a robot description (.urdf, DH table .csv, UR calibration .yaml).
    #[arg(long, value_name = "FILE")]
    pub nominal: Option<PathBuf>,
    /// Built-in nominal model used when --nominal is not given.
    #[arg(long, default_value = "tx60", value_name = "NAME")]
    pub preset: String,
    /// Circle model.
    #[arg(long, value_enum, default_value_t = FitArg::Commanded)]
    pub fit: FitArg,
    /// Use the data alone: no prior towards the nominal geometry.
    #[arg(long)]
    pub no_prior: bool,
    /// Skip the least-squares refinement over all sweep points.
    #[arg(long)]
    pub no_refine: bool,
    /// With several runs, write the full sample covariance of the parameters instead of
    /// independent σ.
    #[arg(long)]
    pub covariance: bool,
    /// Fail (exit 2, no model file) when a result looks implausible: a fit RMS residual above
    /// 0.05 mm, a parameter more than 5 mm / 2° from nominal, a J1 axis away from base z.
    #[arg(long)]
    pub strict: bool,
    /// Print every run's per-joint fit and parameter tables instead of a summary.
    #[arg(long, short, conflicts_with = "quiet")]
    pub verbose: bool,
    #[command(flatten)]
    pub reports: ReportFlags,
}

impl Run for IdentifyArgs {
    fn run(self) -> Result<()> {
        let a = self;
        use gpu_amcs::identify::{self, CircleFitMethod, IdentifyOptions, NominalPrior};
        let mut inputs = vec![("the sweeps file", a.sweeps.as_path())];
        inputs.extend(a.nominal.as_deref().map(|n| ("--nominal", n)));
        let mut outputs = Outputs::new(inputs);
        outputs.file("--out", a.out.as_deref())?;
        a.reports
            .declare(&mut outputs, &IdentifyReports::planned_layout())?;
        let nominal = load_model(a.nominal.as_deref(), &a.preset).context("--nominal")?;
        let data = identify::read_sweeps(&a.sweeps)?;
        let opts = IdentifyOptions {
            method: match a.fit {
                FitArg::Commanded => CircleFitMethod::CommandedAngles,
                FitArg::PointCloud => CircleFitMethod::PointCloud,
            },
            nominal_prior: (!a.no_prior).then(NominalPrior::default),
            refine: !a.no_refine,
        };
        let ids = identify::identify(&data, &nominal, &opts)?;
        let reports = IdentifyReports::new(&nominal.name, &ids);
        // stdout is built first and printed after the model file is written, so a reader that
        // stops early (`| head`) cannot cost the file.
        let quiet = a.reports.quiet;
        let mut text = String::new();
        if a.verbose {
            for id in &ids {
                text.push_str(&identify::render_identify_report(&id.report));
                text.push('\n');
            }
        } else if !quiet {
            text.push_str(&reports.text());
        }
        let warnings = identify::grouped_warnings(&ids);
        for w in &warnings {
            eprintln!("warning: {w}");
        }
        if a.strict && !warnings.is_empty() {
            bail!(
                "--strict: {} implausible result(s) (warnings above); no model written",
                warnings.len()
            );
        }
        let mut say = |line: String| {
            if !quiet {
                text.push_str(&line);
                text.push('\n');
            }
        };
        let (model, note) = identify::identified_model(
            &ids,
            &nominal,
            a.covariance,
            &a.sweeps.display().to_string(),
        )?;
        say(note);
        outputs.stage_file("--out", model.to_toml())?;
        let yes_no = |b: bool| if b { "yes" } else { "no" }.to_string();
        let rows = [
            ("sweeps file".to_string(), a.sweeps.display().to_string()),
            (
                "prior towards the nominal geometry".to_string(),
                yes_no(!a.no_prior),
            ),
            ("whole-chain refinement".to_string(), yes_no(!a.no_refine)),
        ];
        stage_reports(&mut outputs, &reports, &rows)?;
        outputs.commit()?;
        if let Some(o) = &a.out {
            say(format!("wrote {}", o.display()));
        }
        crate::cmd::stdout::print(&text)?;
        Ok(())
    }
}
