//! What `amcs` and `mcs` share: the outputs checked before the run, the library's job run in a
//! thread pool under its progress bar, the reports written.

use super::args::thread_pool;
use super::flags::job_error;
use super::outputs::Outputs;
use super::progress::Bars;
use super::reports::{problem_rows, write_reports};
use crate::cmd::args::{OutputArgs, ProblemArgs};
use anyhow::Result;
use gpu_amcs::job::{JobError, RunOutcome};
use gpu_amcs::report::RunReport;

/// The outputs of a run, checked.
pub fn outputs(problem: &ProblemArgs, output: &OutputArgs) -> Result<Outputs> {
    let mut o = Outputs::new(problem.inputs());
    output
        .reports
        .declare(&mut o, &RunReport::planned_layout())?;
    Ok(o)
}

/// Runs `job` in the thread pool of `--threads` under `bars`, then writes the summary (to
/// `--summary-out`, when declared) and the reports.
pub fn run_and_report(
    problem: &ProblemArgs,
    output: &OutputArgs,
    mut outputs: Outputs,
    bars: &Bars,
    job: impl FnOnce() -> Result<RunOutcome, JobError> + Send,
) -> Result<RunReport> {
    let pool = thread_pool(problem.threads)?;
    let outcome = pool.install(job);
    bars.finish();
    let outcome = outcome.map_err(job_error)?;
    if let Some(s) = &outcome.summary {
        if outputs.has("--summary-out") {
            outputs.stage_file("--summary-out", s.to_json())?;
        }
    }
    let rows = problem_rows(problem, &outcome.analysed);
    write_reports(outputs, &outcome.report, &output.reports, &rows)?;
    Ok(outcome.report)
}
