//! Backend choice (CPU only until the GPU evaluator lands).

use super::{CpuEvaluator, EngineError, Evaluator, Problem};

/// Which backend to use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BackendChoice {
    /// A real GPU if present, else the CPU.
    Auto,
    /// Any GPU adapter.
    Gpu,
    /// The CPU.
    Cpu,
}

/// Builds the evaluator; the string is a note for the user.
pub fn make_evaluator(
    problem: Problem,
    choice: BackendChoice,
    _adapter: Option<&str>,
) -> Result<(Box<dyn Evaluator>, Option<String>), EngineError> {
    match choice {
        BackendChoice::Gpu => Err(EngineError::Gpu("no GPU backend in this build".into())),
        BackendChoice::Auto => Ok((
            Box::new(CpuEvaluator::new(problem)),
            Some("no GPU backend; using the CPU (rayon) path".into()),
        )),
        BackendChoice::Cpu => Ok((Box::new(CpuEvaluator::new(problem)), None)),
    }
}
