//! Backend choice (auto, gpu or cpu, and an optional adapter name): builds the [`Evaluator`] a
//! run uses and says, in a human note, what it chose and why. Notes name the choice and the
//! adapter, never a command-line flag: the CLI maps its flags onto [`BackendChoice`].
//!
//! `Auto` takes a hardware GPU when one is present and otherwise the rayon CPU evaluator (a
//! software Vulkan device such as lavapipe is slower than rayon, so `Auto` does not pick it).
//! `Gpu` accepts any Vulkan / Metal / DX12 adapter, software ones included, and fails with a
//! clear [`EngineError::Gpu`] when there is none.

use super::gpu::{self, GpuEvaluator, GpuOptions};
use super::{CpuEvaluator, EngineError, Evaluator, Problem};

/// Which evaluator to build.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
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

/// Builds the evaluator for `choice`; `adapter` selects a GPU adapter by case-insensitive
/// substring of its name. The string, when present, is a note for the user about the choice
/// (e.g. a fallback to the CPU).
pub fn make_evaluator(
    problem: Problem,
    choice: BackendChoice,
    adapter: Option<&str>,
) -> Result<(Box<dyn Evaluator>, Option<String>), EngineError> {
    match choice {
        BackendChoice::Cpu => {
            let note = adapter.map(|a| format!("adapter '{a}' ignored: the CPU backend is in use"));
            Ok((Box::new(CpuEvaluator::new(problem)), note))
        }
        BackendChoice::Gpu => {
            let opts = GpuOptions {
                adapter: adapter.map(str::to_owned),
                ..GpuOptions::default()
            };
            let ev = GpuEvaluator::new(problem, &opts)?;
            let note = ev.info().adapter;
            let is_cpu = gpu::adapters().iter().any(|a| a.is_cpu && a.name == note);
            let note = is_cpu.then(|| {
                format!("GPU backend on a software adapter ({note}): expect CPU-like speed")
            });
            Ok((Box::new(ev), note))
        }
        BackendChoice::Auto => {
            let wanted = match adapter {
                Some(_) => true,
                None => gpu::hardware_adapter_present(),
            };
            if !wanted {
                let soft: Vec<String> = gpu::adapters()
                    .into_iter()
                    .filter(|a| a.is_cpu)
                    .map(|a| a.name)
                    .collect();
                let note = if soft.is_empty() {
                    "no GPU adapter found; using the CPU (rayon) path".to_string()
                } else {
                    format!(
                        "no hardware GPU adapter found (software adapter {} present: \
                         the gpu backend uses it); using the CPU (rayon) path",
                        soft.join(", ")
                    )
                };
                return Ok((Box::new(CpuEvaluator::new(problem)), Some(note)));
            }
            let opts = GpuOptions {
                adapter: adapter.map(str::to_owned),
                hardware_only: adapter.is_none(),
                ..GpuOptions::default()
            };
            match GpuEvaluator::new(problem.clone(), &opts) {
                Ok(ev) => Ok((Box::new(ev), None)),
                Err(e) => Ok((
                    Box::new(CpuEvaluator::new(problem)),
                    Some(format!("{e}; using the CPU (rayon) path")),
                )),
            }
        }
    }
}

/// One line per adapter: name, backend, device type and driver.
pub fn list_adapters() -> Vec<String> {
    gpu::adapters()
        .into_iter()
        .map(|a| {
            format!(
                "{} [{}, {}{}] driver: {}",
                a.name,
                a.backend,
                a.device_type,
                if a.is_cpu { ", software" } else { "" },
                a.driver
            )
        })
        .collect()
}
