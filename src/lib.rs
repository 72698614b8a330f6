//! # gpu-amcs
//!
//! How reliably does a calibrated industrial robot hit its targets? This facade gathers the
//! workspace's libraries under one name: everything of [`gpu_amcs_core`] (model, sampling, the
//! CPU evaluator, the Monte Carlo drivers, identification, import/export, reports) at the top
//! level, the wgpu evaluator as [`gpu`] when the `gpu` feature (on by default) is enabled, and
//! [`backends`], the evaluator factory this build has.
//!
//! ```
//! use gpu_amcs::engine::{BackendChoice, Problem, Reference};
//! use gpu_amcs::mc::{run_amcs, AmcsOptions};
//!
//! let model = gpu_amcs::kinematics::tx60();
//! let points = gpu_amcs::points::generate(&model, 10, &Default::default(), 1).unwrap();
//! let problem = Problem::new(model, &points, &Reference::Calibrated, 2025).unwrap();
//! let (mut ev, _note) = gpu_amcs::backends()
//!     .make_evaluator(problem, BackendChoice::Cpu, None)
//!     .unwrap();
//! let result = run_amcs(ev.as_mut(), &AmcsOptions::default(), None).unwrap();
//! assert!(result.converged);
//! ```
#![warn(missing_docs)]

pub use gpu_amcs_core::*;

/// The wgpu evaluator (the `gpu-amcs-gpu` crate).
#[cfg(feature = "gpu")]
pub use gpu_amcs_gpu as gpu;

/// The evaluator factory of this build: the CPU and the wgpu evaluator with the `gpu` feature,
/// the CPU alone without it.
pub fn backends() -> &'static dyn engine::Backends {
    #[cfg(feature = "gpu")]
    {
        &gpu_amcs_gpu::WgpuBackends
    }
    #[cfg(not(feature = "gpu"))]
    {
        &engine::CpuOnly
    }
}
