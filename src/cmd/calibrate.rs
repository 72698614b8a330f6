//! `calibrate`: repeated simulated calibrations → a model file with mean, σ and covariance.

use super::identify::BeyondArg;
use super::outputs::Outputs;
use super::progress::Progress;
use super::Run;
use crate::cmd::args::{FactorArgs, MemoryArgs};
use anyhow::{bail, Result};
use clap::Args;
use gpu_amcs::identify::JointErrorFit;
use gpu_amcs::kinematics::{param_index, ParamKind};
use gpu_amcs::memory::Estimate;
use gpu_amcs::points::WorkspaceBox;
use gpu_amcs::simulate;
use std::path::PathBuf;

/// Most poses per run of --poses.
const MAX_POSES: usize = 100_000;

/// `calibrate` options.
#[derive(Args, Debug, Clone)]
pub struct CalibrateArgs {
    #[command(flatten)]
    pub factors: FactorArgs,
    /// Write the calibrated model (mean, σ, full covariance) to FILE.
    #[arg(long, short, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Write independent σ only (no covariance table).
    #[arg(long)]
    pub independent: bool,
    /// Random test points for the accuracy check before/after calibration.
    #[arg(long, default_value_t = 50, value_name = "N")]
    pub accuracy_points: usize,
    #[command(flatten)]
    pub nongeometric: super::simulate::NonGeometricArgs,
    /// Identify each run also with joint compliance under gravity and gear harmonics (as
    /// identify does; the same sweeps identified with the geometry alone give the geometric
    /// calibration beside it, both evaluated at the test points). Default: auto when the
    /// simulated robot carries joint errors (--compliance, --harmonics), else off (the paper's
    /// geometric calibration), on when it carries backlash (--backlash with --poses: only the
    /// explicit check fits the gaps). A bare --beyond-geometry means on. The mean model carries
    /// the joint errors when most runs keep them, and the mean gaps when every run keeps some.
    #[arg(
        long,
        value_enum,
        value_name = "WHEN",
        num_args = 0..=1,
        require_equals = true,
        default_missing_value = "on"
    )]
    pub beyond_geometry: Option<BeyondArg>,
    /// Each run measures the target at N random configurations within the joint limits (static
    /// poses) instead of the circle-point sweeps (whose --range, --step, --speed and --start then
    /// do not apply); identified as identify identifies poses, with the geometry alone and with
    /// --beyond-geometry.
    #[arg(long, value_name = "N")]
    pub poses: Option<usize>,
    #[command(flatten)]
    pub memory: MemoryArgs,
}

impl Run for CalibrateArgs {
    fn run(self) -> Result<()> {
        let a = self;
        let mut outputs = Outputs::new(a.factors.inputs());
        outputs.file("--out", a.out.as_deref())?;
        if a.accuracy_points == 0 {
            bail!("--accuracy-points must be at least 1");
        }
        if a.nongeometric.backlash != 0.0 && a.poses.is_none() {
            bail!(
                "--backlash: simulated in pose runs (--poses N): along a sweep's arc every point arrives from the same side, so its gap is one more offset of the joint"
            );
        }
        if a.nongeometric.payload_kg.len() > 1 {
            bail!(
                "--payload-kg: each calibration run carries one payload; give one (simulate --poses N --payload-kg A,B writes pose data at several, for identify)"
            );
        }
        let (mut exp, f) = a.factors.experiment()?;
        a.nongeometric
            .apply(&mut exp, a.factors.robot_seed, a.poses.is_some())?;
        if let Some(n) = a.poses.filter(|n| !(1..=MAX_POSES).contains(n)) {
            bail!("--poses: {n} poses per run; give 1 to {MAX_POSES}");
        }
        // A sweep too short for its circle fit, named by the flags that set it (the fit itself
        // names only the run and the joint).
        let plan = exp.plan_for(&f);
        let (min, min_arc) = (
            gpu_amcs::identify::circle::MIN_POINTS as u64,
            gpu_amcs::identify::MIN_ARC_DEG,
        );
        let arc = |n: u64| n.saturating_sub(1) as f64 * f.step_deg;
        // A count that saturated (a step of 1e-300°) is no short sweep: the memory check
        // names it.
        if let Some((j, n)) = (1..=exp.nominal.joints())
            .filter(|_| a.poses.is_none())
            .map(|j| (j, plan.sweep_len(j)))
            .find(|&(_, n)| n < min || (n < u64::MAX && arc(n) < min_arc))
        {
            // Numbers as a sentence writes them (1e-300, not 300 digits).
            use gpu_amcs::number::fmt_plain;
            bail!(
                "--range {} --step {}: joint {j}'s sweep would have {n} point(s) over {}°, and its circle fit needs at least {min} over {}°: give a wider --range or a smaller --step",
                fmt_plain(a.factors.range),
                fmt_plain(a.factors.step),
                fmt_plain(arc(n)),
                fmt_plain(min_arc)
            );
        }
        a.memory.check(&a.factors.sweep_estimate(Estimate::new(
            format!(
                "{} calibration runs at a {}° step",
                f.runs,
                gpu_amcs::number::fmt_plain(f.step_deg)
            ),
            "use fewer --runs or a larger --step, or raise --memory-limit",
        )))?;
        // The bar on a terminal; the estimate on stderr when the runs take over 10 s.
        let bar = std::sync::Arc::new(Progress::new(false, "calibrate", "runs"));
        let listener = bar.clone();
        let hook = gpu_amcs::progress::ProgressHook::new(move |_: &str, done, total| {
            listener.update(done, total)
        });
        let lash = a.nongeometric.backlash != 0.0;
        let mode = match a.beyond_geometry {
            // Auto checks no gaps: a robot with backlash gets the explicit check.
            None if lash => Some(JointErrorFit::On),
            None if exp.nongeometric.is_some() => Some(JointErrorFit::Auto),
            None | Some(BeyondArg::Off) => None,
            Some(BeyondArg::Auto) => Some(JointErrorFit::Auto),
            Some(BeyondArg::On) => Some(JointErrorFit::On),
            Some(BeyondArg::Keep) => Some(JointErrorFit::Keep),
            Some(BeyondArg::Check) => Some(JointErrorFit::Check),
        };
        let what = match a.poses {
            Some(n) => simulate::RunData::Poses(n),
            None => simulate::RunData::Sweeps,
        };
        if let Some(mode) = mode.or(a.poses.map(|_| JointErrorFit::Off)) {
            let full = simulate::calibrate_full(&exp, &f, a.factors.seed, what, mode, &hook);
            bar.finish();
            return full_model(&a, &exp, &f, full?, outputs);
        }
        let cal = simulate::calibrate_with_progress(&exp, &f, a.factors.seed, &hook);
        bar.finish();
        let cal = cal?;
        let acc = simulate::accuracy_check(
            &exp,
            &cal.independent,
            a.accuracy_points,
            &WorkspaceBox::for_robot(&exp.nominal),
            a.factors.seed ^ 0x5eed,
        )?;
        // Everything printed is built first and the model file is written before any of it is
        // printed, so a reader that stops early (`| head -1`) cannot cost the file.
        let mut text = format!(
            "{} runs identified in {:.2} s ({})\n",
            f.runs, cal.seconds, cal.independent.name
        );
        push_sigmas(&mut text, &cal.independent);
        text.push_str(&gpu_amcs::identify::render_validation(&acc));
        let model = if a.independent {
            cal.independent
        } else {
            cal.correlated
        };
        outputs.stage_file("--out", model.to_toml())?;
        outputs.commit()?;
        if let Some(o) = &a.out {
            text.push_str(&format!("wrote {}\n", o.display()));
        }
        crate::cmd::stdout::print(&text)?;
        Ok(())
    }
}

/// "σ of the identified parameters" and one line per joint.
fn push_sigmas(text: &mut String, model: &gpu_amcs::kinematics::RobotModel) {
    let sig = model.param_sigmas();
    text.push_str("σ of the identified parameters (mm, deg):\n");
    for j in 0..model.joints() {
        let row: Vec<String> = ParamKind::ALL
            .iter()
            .map(|kind| {
                format!(
                    "{} {:.5}",
                    kind.name(),
                    sig[param_index(j, *kind)] / kind.to_internal()
                )
            })
            .collect();
        text.push_str(&format!("  J{}: {}\n", j + 1, row.join(", ")));
    }
}

/// The runs identified with the geometry alone and with joint errors: what the runs kept, the
/// full model's σ, and before / geometric / full at the test points; the model file is the full
/// mean model.
fn full_model(
    a: &CalibrateArgs,
    exp: &simulate::Experiment,
    f: &simulate::Factors,
    cal: simulate::FullCalibration,
    mut outputs: Outputs,
) -> Result<()> {
    let acc = simulate::accuracy_full(
        exp,
        &cal,
        a.accuracy_points,
        &WorkspaceBox::for_robot(&exp.nominal),
        a.factors.seed ^ 0x5eed,
    )?;
    let mut text = format!(
        "{} runs identified in {:.2} s ({})\n",
        f.runs, cal.full.seconds, cal.full.independent.name
    );
    text.push_str(&simulate::render_full_calibration(&cal));
    push_sigmas(&mut text, &cal.full.independent);
    text.push_str(&simulate::render_full_accuracy(&cal, &acc));
    let model = if a.independent {
        cal.full.independent
    } else {
        cal.full.correlated
    };
    outputs.stage_file("--out", model.to_toml())?;
    outputs.commit()?;
    if let Some(o) = &a.out {
        text.push_str(&format!("wrote {}\n", o.display()));
    }
    crate::cmd::stdout::print(&text)?;
    Ok(())
}
