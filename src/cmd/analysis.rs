//! What `amcs` and `mcs` share: check the outputs and the memory, build the problem and the
//! evaluator in a thread pool, run a driver under the progress bar, write the reports.

use super::args::{thread_pool, BYTES_PER_DRAW, BYTES_PER_POINT};
use super::flags::Driver;
use super::outputs::Outputs;
use super::progress::Progress;
use super::reports::{problem_rows, write_reports};
use crate::cmd::args::{OutputArgs, ProblemArgs};
use anyhow::Result;
use gpu_amcs::engine::Evaluator;
use gpu_amcs::mc::{self, McError, McResult};
use gpu_amcs::memory::Estimate;
use gpu_amcs::report::{self, RunReport};

/// The outputs of a run, checked.
pub fn outputs(problem: &ProblemArgs, output: &OutputArgs) -> Result<Outputs> {
    let mut o = Outputs::new(problem.inputs());
    output
        .reports
        .declare(&mut o, &RunReport::planned_layout())?;
    Ok(o)
}

/// What a run is and keeps, for its label and its memory estimate.
pub struct Plan {
    /// Progress bar label.
    pub label: &'static str,
    /// Whether `draws` is a cap the run may stop short of (AMCS).
    pub capped: bool,
    /// What is sized, for the message.
    pub what: String,
    /// Draws kept (the cap for AMCS).
    pub draws: u64,
    /// Draws evaluated at a time.
    pub batch: u64,
    /// What to change when it does not fit.
    pub advice: &'static str,
}

impl Plan {
    /// `draws` values, `m` test points and, with per-point output, `batch` × m errors in the
    /// driver's buffer and as many in the evaluator's.
    pub fn estimate(&self, output: &OutputArgs, m: u64) -> Estimate {
        let e = Estimate::new(self.what.clone(), self.advice)
            .plus(&[self.draws, BYTES_PER_DRAW])
            .plus(&[m, BYTES_PER_POINT]);
        if output.per_point {
            e.plus(&[self.batch, m, 2 * 8])
        } else {
            e
        }
    }
}

/// Checks the outputs and the memory (before and, for a points file, again after reading the
/// points), runs `drive` on the problem under a progress bar and writes the reports.
pub fn run_and_report(
    problem: &ProblemArgs,
    output: &OutputArgs,
    plan: Plan,
    driver: Driver,
    drive: impl FnOnce(&mut dyn Evaluator, mc::Progress) -> Result<McResult, McError> + Send,
) -> Result<RunReport> {
    problem.check()?;
    let outputs = outputs(problem, output)?;
    let generated = match problem.points_file {
        Some(_) => 0,
        None => problem.points as u64,
    };
    problem.memory.check(&plan.estimate(output, generated))?;
    let pool = thread_pool(problem.threads)?;
    let (rep, rows) = pool.install(|| -> Result<(RunReport, Vec<(String, String)>)> {
        let built = problem.build()?;
        let m = built.problem.n_points() as u64;
        problem.memory.check(&plan.estimate(output, m))?;
        let (model, points, seed) = (
            built.problem.model.name.clone(),
            built.problem.n_points(),
            built.problem.seed,
        );
        let rows = problem_rows(problem, &built.problem);
        let model_notes = report::model_notes(&built.problem.model);
        let (mut ev, notes) = problem
            .backend
            .frame_evaluator(built.problem, problem.frame)?;
        let notes = [model_notes, notes].concat();
        let bar = Progress::new(output.reports.quiet, plan.label, "draws");
        let bar = if plan.capped { bar.capped() } else { bar };
        let result = drive(ev.as_mut(), &|done, total| bar.update(done, total));
        bar.finish();
        let rep = RunReport {
            model,
            points,
            reference: built.reference,
            seed,
            notes,
            result: result.map_err(|e| driver.error(e))?,
        };
        Ok((rep, rows))
    })?;
    write_reports(outputs, &rep, &output.reports, &rows)?;
    Ok(rep)
}
