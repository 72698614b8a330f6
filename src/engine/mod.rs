//! The evaluator seam: for draws `[k0, k0 + n)` compute the maximum point error
//! `w_k = max_j e_j(μ_k)` (paper eqs. 12 and 17, METHOD.md §3) and, on request, every `e_j`.
//!
//! The Monte Carlo drivers in [`crate::mc`] see only the [`Evaluator`] trait, so they cannot
//! tell which backend produced a batch. [`cpu::CpuEvaluator`] (rayon, f64) is the reference;
//! [`gpu`] runs the same draws through a WGSL compute shader; [`FnEvaluator`] wraps any scalar
//! function of a Philox stream, for testing the drivers on models with known answers.

pub mod backend;
pub mod cpu;
pub mod gpu;
mod problem;

pub use backend::{list_adapters, make_evaluator, BackendChoice};
pub use cpu::CpuEvaluator;
pub use gpu::{GpuEvaluator, GpuOptions, GpuTimings};
pub use problem::{Problem, ProblemError, Reference};

use crate::sampling::Philox;

/// Which backend evaluated the draws (reported in every output).
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct BackendInfo {
    /// `"cpu"` or `"gpu"`.
    pub backend: String,
    /// Adapter (GPU name) or CPU description.
    pub adapter: String,
    /// Driver name and version, or the thread count for the CPU.
    pub driver: String,
}

/// Errors while evaluating draws.
#[derive(Debug, thiserror::Error)]
pub enum EngineError {
    /// Output slices of the wrong length.
    #[error("output buffer has {got} entries, expected {expected}")]
    BufferSize {
        /// Entries needed.
        expected: usize,
        /// Entries given.
        got: usize,
    },
    /// The GPU backend failed.
    #[error("GPU evaluator: {0}")]
    Gpu(String),
}

/// Evaluates the maximum point error for a range of draw indices.
pub trait Evaluator: Send {
    /// Backend description.
    fn info(&self) -> BackendInfo;
    /// Number of test points m (1 for a scalar model).
    fn n_points(&self) -> usize;
    /// Fills `w[i]` with `w` of draw `first + i` (mm) and, if given, `per_point[i·m + j]` with
    /// `e_j` of that draw.
    fn evaluate(
        &mut self,
        first: u64,
        w: &mut [f64],
        per_point: Option<&mut [f64]>,
    ) -> Result<(), EngineError>;
}

/// Checks the output lengths of an [`Evaluator::evaluate`] call.
pub fn check_buffers(
    m: usize,
    w: &[f64],
    per_point: Option<&&mut [f64]>,
) -> Result<(), EngineError> {
    if let Some(e) = per_point {
        if e.len() != w.len() * m {
            return Err(EngineError::BufferSize {
                expected: w.len() * m,
                got: e.len(),
            });
        }
    }
    Ok(())
}

/// An evaluator for a scalar model `y = f(gen, k)` of draw `k`, where `gen` is the run's Philox
/// generator: for testing the Monte Carlo drivers on models with known distributions (e.g. the
/// additive model of GUM S1 §9.2).
pub struct FnEvaluator<F> {
    gen: Philox,
    f: F,
}

impl<F: Fn(&Philox, u64) -> f64 + Send + Sync> FnEvaluator<F> {
    /// Wraps `f` with a generator keyed by `seed`.
    pub fn new(seed: u64, f: F) -> Self {
        FnEvaluator {
            gen: Philox::new(seed),
            f,
        }
    }
}

impl<F: Fn(&Philox, u64) -> f64 + Send + Sync> Evaluator for FnEvaluator<F> {
    fn info(&self) -> BackendInfo {
        BackendInfo {
            backend: "cpu".into(),
            adapter: "scalar test function".into(),
            driver: String::new(),
        }
    }
    fn n_points(&self) -> usize {
        1
    }
    fn evaluate(
        &mut self,
        first: u64,
        w: &mut [f64],
        per_point: Option<&mut [f64]>,
    ) -> Result<(), EngineError> {
        use rayon::prelude::*;
        check_buffers(1, w, per_point.as_ref())?;
        let (gen, f) = (&self.gen, &self.f);
        w.par_iter_mut()
            .enumerate()
            .for_each(|(i, v)| *v = f(gen, first + i as u64));
        if let Some(e) = per_point {
            e.copy_from_slice(w);
        }
        Ok(())
    }
}
