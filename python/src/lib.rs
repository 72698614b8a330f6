//! Python bindings of gpu-amcs (the `gpu_amcs` package, README "From Python").
//!
//! Thin by design: every number comes from the `gpu_amcs` library (the same evaluators,
//! drivers and JSON report as the command line). This crate converts NumPy arrays, names the
//! Python argument in errors (where the command line names its flag), and releases the GIL
//! while the engine runs.

mod analyses;
mod arrays;
mod compare;
mod errors;
mod identify;
mod model;
mod planning;
mod problem;
mod reports;
mod run;
mod validate;

use pyo3::prelude::*;

/// The evaluator factory of this build: the CPU and the wgpu evaluator with the `gpu` feature
/// (on by default), the CPU alone without it.
pub(crate) fn backends() -> &'static dyn gpu_amcs_core::engine::Backends {
    #[cfg(feature = "gpu")]
    {
        &gpu_amcs_gpu::WgpuBackends
    }
    #[cfg(not(feature = "gpu"))]
    {
        &gpu_amcs_core::engine::CpuOnly
    }
}

/// GPU adapters wgpu can see, one line each (name, backend, device type, driver).
#[pyfunction]
fn adapters(py: Python<'_>) -> Vec<String> {
    py.detach(|| crate::backends().list_adapters())
}

/// Names of the built-in models (`Model.preset`).
#[pyfunction]
fn presets() -> Vec<&'static str> {
    gpu_amcs_core::presets::PRESETS.to_vec()
}

/// The extension module `gpu_amcs._gpu_amcs`; the package `gpu_amcs` re-exports it.
#[pymodule]
fn _gpu_amcs(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    // Widths of a parameter row of a six-joint model: the 30 MDH parameters, and all 33 inputs
    // (then the tool). A model of n joints has its own, 5n and 5n + 3 (`Model.joints`,
    // `len(Model.param_names)`).
    let six = gpu_amcs_core::kinematics::Layout::SIX;
    m.add("N_PARAMS", six.n_params())?;
    m.add("N_UNCERTAIN", six.robot().len())?;
    m.add_class::<model::PyModel>()?;
    m.add_class::<run::RunResult>()?;
    m.add_function(wrap_pyfunction!(run::mcs, m)?)?;
    m.add_function(wrap_pyfunction!(run::amcs, m)?)?;
    m.add_class::<compare::PyComparison>()?;
    m.add_function(wrap_pyfunction!(compare::compare, m)?)?;
    m.add_class::<analyses::PySensitivityResult>()?;
    m.add_class::<analyses::PyTailResult>()?;
    m.add_class::<analyses::PyMapResult>()?;
    m.add_function(wrap_pyfunction!(analyses::sensitivity, m)?)?;
    m.add_function(wrap_pyfunction!(analyses::tail, m)?)?;
    m.add_class::<planning::PyPlan>()?;
    m.add_function(wrap_pyfunction!(planning::plan, m)?)?;
    m.add_function(wrap_pyfunction!(analyses::workspace_map, m)?)?;
    m.add_class::<identify::PyIdentifyResult>()?;
    m.add_function(wrap_pyfunction!(identify::identify, m)?)?;
    m.add_class::<validate::PyValidation>()?;
    m.add_function(wrap_pyfunction!(validate::validate, m)?)?;
    m.add_function(wrap_pyfunction!(adapters, m)?)?;
    m.add_function(wrap_pyfunction!(presets, m)?)?;
    Ok(())
}
