//! Backend choice (auto, gpu or cpu, and an optional adapter name) and the [`Backends`] seam
//! that builds the [`Evaluator`] a run uses, with a human note saying what it chose and why.
//! Notes name the choice and the adapter, never a command-line flag: front ends map their own
//! options onto [`BackendChoice`].
//!
//! This crate has no GPU code: [`CpuOnly`] builds the rayon CPU evaluator and answers a request
//! for the GPU with [`EngineError::NoGpuBackend`]. The `gpu-amcs-gpu` crate implements
//! [`Backends`] with the wgpu evaluator; a front end passes whichever it was built with to the
//! drivers that build evaluators themselves (the study).

use super::{CpuEvaluator, EngineError, Evaluator, Problem};

/// Which evaluator to build (serialized as `"auto"`, `"gpu"`, `"cpu"`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BackendChoice {
    /// A hardware GPU if present, else the CPU.
    #[default]
    Auto,
    /// The GPU evaluator on any adapter (software adapters included); an error if none.
    Gpu,
    /// The rayon CPU evaluator.
    Cpu,
}

impl std::str::FromStr for BackendChoice {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "auto" => Ok(Self::Auto),
            "gpu" => Ok(Self::Gpu),
            "cpu" => Ok(Self::Cpu),
            other => Err(format!(
                "unknown backend '{other}' (expected auto, gpu or cpu)"
            )),
        }
    }
}

impl std::fmt::Display for BackendChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Auto => "auto",
            Self::Gpu => "gpu",
            Self::Cpu => "cpu",
        })
    }
}

/// The evaluator returned by [`Backends::make_evaluator`] and an optional note for the user
/// about the choice (a fallback to the CPU, a software adapter).
pub type Built = (Box<dyn Evaluator>, Option<String>);

/// What a program was built with to evaluate draws: builds evaluators and lists adapters.
///
/// `Auto` takes a hardware GPU when one is present and otherwise the rayon CPU evaluator (a
/// software Vulkan device such as lavapipe is slower than rayon, so `Auto` does not pick it).
/// `Gpu` accepts any adapter, software ones included, and fails with a clear [`EngineError`]
/// when there is none.
pub trait Backends: Sync {
    /// Builds the evaluator for `choice`; `adapter` selects a GPU adapter by case-insensitive
    /// substring of its name.
    ///
    /// # Errors
    /// [`EngineError::NoGpuBackend`] when a GPU is asked for and the program has no GPU
    /// backend, [`EngineError::Gpu`] when no adapter matches or the device cannot be opened.
    fn make_evaluator(
        &self,
        problem: Problem,
        choice: BackendChoice,
        adapter: Option<&str>,
    ) -> Result<Built, EngineError>;

    /// One line per adapter: name, backend, device type and driver (empty without a GPU
    /// backend).
    fn list_adapters(&self) -> Vec<String>;

    /// Whether a GPU backend is built in.
    fn has_gpu(&self) -> bool;
}

/// The CPU alone: what a build without the GPU backend evaluates with.
#[derive(Clone, Copy, Debug, Default)]
pub struct CpuOnly;

/// The note a CPU-only build gives when `auto` falls back to the CPU.
pub const NO_GPU_BACKEND_NOTE: &str = "built without the GPU backend; using the CPU (rayon) path";

impl Backends for CpuOnly {
    fn make_evaluator(
        &self,
        problem: Problem,
        choice: BackendChoice,
        adapter: Option<&str>,
    ) -> Result<Built, EngineError> {
        match (choice, adapter) {
            (BackendChoice::Cpu, a) => Ok(cpu_evaluator(problem, a)),
            (BackendChoice::Gpu, _) | (BackendChoice::Auto, Some(_)) => {
                Err(EngineError::NoGpuBackend)
            }
            (BackendChoice::Auto, None) => Ok((
                cpu_evaluator(problem, None).0,
                Some(NO_GPU_BACKEND_NOTE.to_string()),
            )),
        }
    }

    fn list_adapters(&self) -> Vec<String> {
        Vec::new()
    }

    fn has_gpu(&self) -> bool {
        false
    }
}

/// The CPU evaluator, with a note when an adapter name was given (the CPU uses none).
pub fn cpu_evaluator(problem: Problem, adapter: Option<&str>) -> Built {
    let note = adapter.map(|a| format!("adapter '{a}' ignored: the CPU backend is in use"));
    // A model whose placement is uncertain draws it too (the evaluator sees to it).
    (Box::new(CpuEvaluator::new(problem)), note)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::Reference;

    fn problem() -> Problem {
        let model = crate::kinematics::tx60();
        let points = crate::points::generate(&model, 3, &Default::default(), 1).unwrap();
        Problem::new(model, &points, &Reference::Calibrated, 1).unwrap()
    }

    #[test]
    fn cpu_only_refuses_the_gpu_and_says_so_on_auto() {
        let b = CpuOnly;
        assert!(!b.has_gpu());
        assert!(b.list_adapters().is_empty());
        let e = b
            .make_evaluator(problem(), BackendChoice::Gpu, None)
            .err()
            .unwrap();
        assert!(matches!(e, EngineError::NoGpuBackend), "{e}");
        assert!(e.to_string().contains("built without the GPU backend"));
        let (ev, note) = b
            .make_evaluator(problem(), BackendChoice::Auto, None)
            .unwrap();
        assert_eq!(ev.info().backend, "cpu");
        assert_eq!(note.as_deref(), Some(NO_GPU_BACKEND_NOTE));
        let (_, note) = b
            .make_evaluator(problem(), BackendChoice::Cpu, Some("x"))
            .unwrap();
        assert!(note.unwrap().contains("ignored"));
    }
}
