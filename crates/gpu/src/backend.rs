//! [`WgpuBackends`]: the [`Backends`] of a build with the GPU backend. `Auto` takes a hardware
//! GPU when one is present and otherwise the rayon CPU evaluator (a software Vulkan device
//! such as lavapipe is slower than rayon, so `Auto` does not pick it); `Gpu` accepts any
//! Vulkan / Metal / DX12 adapter, software ones included, and fails with a clear
//! [`EngineError::Gpu`] when there is none. Notes name the choice and the adapter, never a
//! command-line flag.

use super::{adapters, hardware_adapter_present, GpuEvaluator, GpuOptions};
use gpu_amcs_core::engine::backend::{cpu_evaluator, Built};
use gpu_amcs_core::engine::{BackendChoice, Backends, EngineError, Evaluator, Problem};

/// The CPU and the wgpu evaluator.
#[derive(Clone, Copy, Debug, Default)]
pub struct WgpuBackends;

impl Backends for WgpuBackends {
    fn make_evaluator(
        &self,
        problem: Problem,
        choice: BackendChoice,
        adapter: Option<&str>,
    ) -> Result<Built, EngineError> {
        make_evaluator(problem, choice, adapter)
    }

    fn list_adapters(&self) -> Vec<String> {
        list_adapters()
    }

    fn has_gpu(&self) -> bool {
        true
    }
}

/// Builds the evaluator for `choice` (see [`Backends::make_evaluator`]).
///
/// # Errors
/// [`EngineError::Gpu`] when `choice` is [`BackendChoice::Gpu`] and no adapter matches or the
/// device cannot be opened. `Auto` falls back to the CPU with a note instead.
pub fn make_evaluator(
    problem: Problem,
    choice: BackendChoice,
    adapter: Option<&str>,
) -> Result<Built, EngineError> {
    match choice {
        BackendChoice::Cpu => Ok(cpu_evaluator(problem, adapter)),
        BackendChoice::Gpu => {
            let opts = GpuOptions {
                adapter: adapter.map(str::to_owned),
                ..GpuOptions::default()
            };
            let ev = GpuEvaluator::new(problem, &opts)?;
            let note = ev.info().adapter;
            let is_cpu = adapters().iter().any(|a| a.is_cpu && a.name == note);
            let note = is_cpu.then(|| {
                format!("GPU backend on a software adapter ({note}): expect CPU-like speed")
            });
            Ok((Box::new(ev), note))
        }
        BackendChoice::Auto => {
            let wanted = match adapter {
                Some(_) => true,
                None => hardware_adapter_present(),
            };
            if !wanted {
                let soft: Vec<String> = adapters()
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
                return Ok((cpu_evaluator(problem, None).0, Some(note)));
            }
            let opts = GpuOptions {
                adapter: adapter.map(str::to_owned),
                hardware_only: adapter.is_none(),
                ..GpuOptions::default()
            };
            match GpuEvaluator::new(problem.clone(), &opts) {
                Ok(ev) => Ok((Box::new(ev), None)),
                Err(e) => Ok((
                    cpu_evaluator(problem, None).0,
                    Some(format!("{e}; using the CPU (rayon) path")),
                )),
            }
        }
    }
}

/// One line per adapter: name, backend, device type and driver.
pub fn list_adapters() -> Vec<String> {
    adapters()
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
