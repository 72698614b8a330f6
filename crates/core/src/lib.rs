//! # gpu-amcs
//!
//! How reliably does a calibrated industrial robot hit its targets? gpu-amcs estimates the
//! probability that the end-effector's position error stays under a threshold at every one of m
//! test points (the *positioning-accuracy reliability* of Wen et al., after GUM Supplement 1):
//! the robot's 5n geometric (MDH) parameters (n = 4 to 7 joints; 30 for a six-axis arm) are
//! drawn from their calibrated distribution, the forward kinematics is evaluated at every test
//! point, and the maximum point error `w = max_j ‖P(μ, q_j) − P_ref,j‖` is summarised by classic
//! or adaptive Monte Carlo.
//!
//! ## Data flow
//! ```text
//! model (TOML) ─┐
//! test points ──┼─▶ engine::Problem ─▶ Evaluator (CPU rayon f64 | GPU WGSL f32) ─▶ w_k
//! seed ─────────┘        draws are Philox(seed, k): the same on every backend
//!                                                   │ batches of H
//!                                                   ▼
//!                             mc::run_amcs / mc::run_mcs ─▶ McResult ─▶ report::{text,json,csv,svg}
//! ```
//!
//! ## Example
//! ```
//! use gpu_amcs_core::engine::{CpuEvaluator, Problem, Reference};
//! use gpu_amcs_core::mc::{run_amcs, AmcsOptions};
//!
//! let model = gpu_amcs_core::kinematics::tx60();
//! let points = gpu_amcs_core::points::generate(&model, 10, &Default::default(), 1).unwrap();
//! let problem = Problem::new(model, &points, &Reference::Calibrated, 2025).unwrap();
//! let result = run_amcs(&mut CpuEvaluator::new(problem), &AmcsOptions::default(), None).unwrap();
//! assert!(result.converged);
//! println!("R(0.2 mm) = {:.4}", result.reliability[1].r);
//! ```
//!
//! Lane kernels index several structure-of-arrays buffers with one loop variable, which is what
//! vectorises, hence the crate-wide `needless_range_loop` allowance.
#![warn(missing_docs)]
#![warn(clippy::missing_errors_doc)]
#![allow(clippy::needless_range_loop)]

pub mod digest;
pub mod discrepancy;
pub mod engine;
pub mod identify;
pub mod import;
pub mod input;
pub mod iso9283;
pub mod job;
pub mod kinematics;
pub mod map;
pub mod mc;
pub mod memory;
pub mod normal;
pub mod number;
pub mod plan;
pub mod points;
pub mod presets;
pub mod progress;
pub mod report;
pub mod sampling;
pub mod simulate;
pub mod spec;
pub mod study;
