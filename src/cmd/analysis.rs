//! What `amcs` and `mcs` share: check the outputs and the memory, build the problem and the
//! evaluator in a thread pool, run a driver under the progress bar, write the reports.

use super::args::{thread_pool, BYTES_PER_DRAW};
use super::outputs::{Outputs, CSV_NAMES, SVG_NAMES};
use super::progress::Progress;
use super::Flags;
use crate::cli::{OutputArgs, ProblemArgs};
use anyhow::Result;
use gpu_amcs::engine::Evaluator;
use gpu_amcs::mc::{self, McError, McResult};
use gpu_amcs::memory::Estimate;
use gpu_amcs::report::{self, RunReport};

/// The outputs of a run, checked.
pub fn outputs(problem: &ProblemArgs, output: &OutputArgs) -> Result<Outputs> {
    let mut o = Outputs::new(problem.inputs());
    o.file("--json", output.json.as_deref())?;
    o.dir("--csv", output.csv.as_deref(), CSV_NAMES)?;
    o.dir("--svg", output.svg.as_deref(), SVG_NAMES)?;
    Ok(o)
}

/// What a run keeps: `draws` values (the cap for AMCS), the test points and, with per-point
/// output, `batch` × m errors in the driver's buffer and as many in the evaluator's.
pub fn estimate(
    problem: &ProblemArgs,
    output: &OutputArgs,
    what: String,
    draws: u64,
    batch: u64,
    advice: &str,
) -> Estimate {
    let e = Estimate::new(what, advice).plus(&[draws, BYTES_PER_DRAW]);
    let e = problem.points_estimate(e);
    if output.per_point {
        let m = match problem.points_file {
            Some(_) => 1,
            None => problem.points as u64,
        };
        e.plus(&[batch, m, 2 * 8])
    } else {
        e
    }
}

/// Runs `drive` on the problem under a progress bar and writes the reports.
pub fn run_and_report(
    problem: &ProblemArgs,
    output: &OutputArgs,
    label: &str,
    capped: bool,
    flags: Flags,
    drive: impl FnOnce(&mut dyn Evaluator, mc::Progress) -> Result<McResult, McError> + Send,
) -> Result<RunReport> {
    let mut outputs = outputs(problem, output)?;
    let pool = thread_pool(problem.threads)?;
    let rep = pool.install(|| -> Result<RunReport> {
        let built = problem.build()?;
        let (model, points, seed) = (
            built.problem.model.name.clone(),
            built.problem.n_points(),
            built.problem.seed,
        );
        let (mut ev, notes) = problem.backend.evaluator(built.problem)?;
        let bar = Progress::new(output.quiet, label, "draws");
        let bar = if capped { bar.capped() } else { bar };
        let result = drive(ev.as_mut(), &|done, total| bar.update(done, total));
        bar.finish();
        Ok(RunReport {
            model,
            points,
            reference: built.reference,
            seed,
            notes,
            result: result.map_err(|e| flags.error(e))?,
        })
    })?;
    outputs.stage_file("--json", report::json::render_run(&rep))?;
    outputs.stage_dir("--csv", report::csv::files(&rep))?;
    outputs.stage_dir("--svg", report::svg::run_plots(&rep))?;
    outputs.commit()?;
    if !output.quiet {
        print!("{}", report::text::render(&rep));
    }
    Ok(rep)
}
