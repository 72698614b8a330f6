//! The evaluator seam: for a batch of parameter vectors compute the maximum point error
//! `w_k = max_j e_j(μ_k)` (paper eqs. 12 and 17, `docs/METHOD.md §3`) and, on request, every
//! `e_j`.
//!
//! # The seam
//!
//! The Monte Carlo drivers in [`crate::mc`] see only the [`Evaluator`] trait, so they cannot
//! tell which backend produced a batch. A backend implements three things: [`Evaluator::info`],
//! [`Evaluator::n_points`] and [`Evaluator::eval_draws`]; the provided [`Evaluator::evaluate`]
//! checks the caller's buffers once for every backend and then calls `eval_draws`, so a backend
//! never sees a mismatched slice. [`cpu::CpuEvaluator`] (rayon, f64) is the reference; the `gpu-amcs-gpu` crate
//! runs the same draws through a WGSL compute shader; [`FnEvaluator`] wraps any scalar function
//! of a Philox stream, for testing the drivers on models with known answers. Backends are
//! chosen by [`BackendChoice`] through a [`Backends`] implementation.
//!
//! A new backend (a SIMD CPU or a CUDA evaluator, say) writes its own `eval_draws` (and
//! `eval_offsets`) and, if it computes in f32, reuses the deviation-form constants of
//! [`deviation`] (`docs/METHOD.md §7`), which carry the error
//! budget of that formulation.
//!
//! # Two ways to say which parameter vectors
//!
//! * **Counter draws** ([`Evaluator::evaluate`]): draws `first … first + n − 1` of the run's
//!   Philox stream (`docs/METHOD.md §6`), generated inside the
//!   backend, so a batch costs no host-to-device traffic. This is what AMCS and MCS use.
//! * **Explicit offsets** ([`Evaluator::evaluate_offsets`]): an `n ×` [`InputSpace::robot`] row-major
//!   matrix of deviations `δ = μ − μ̄` from the model's values, in internal units (mm,
//!   radians): the 30 parameters, then the tool point's x, y, z in the flange frame (mm). This is the extension point for methods whose parameter vectors are not i.i.d.
//!   draws: pick-freeze matrices for Sobol indices, MCMC states for subset simulation, extra
//!   uncertainty sources. Row `i` equal to
//!   [`ParamSampler::deltas`](crate::sampling::ParamSampler::deltas) of draw `k` gives what
//!   `evaluate` gives for draw `k`. The provided method checks the matrix (shape, finite
//!   entries, angular offsets within [`MAX_ANGLE_OFFSET`]) and calls the backend's
//!   [`Evaluator::eval_offsets`]. Both paths share the kinematics code of each backend (in Rust
//!   and in WGSL); only the source of `δ` differs. A backend without offset support (the
//!   scalar [`FnEvaluator`], whose model has no parameter vector) keeps the default, which
//!   returns [`EngineError::OffsetsUnsupported`].
//! * **Pick-freeze rows** ([`Evaluator::evaluate_pick_freeze`]): the matrices A, B and
//!   A_B^(S) of a Sobol design ([`crate::mc::sensitivity`]) described by a [`PickFreeze`]
//!   request: base samples `first … first + count − 1` and one mask of standard normals per
//!   matrix. Row `r` of a matrix takes normal `i` from draw `b_first + r` where the mask has bit
//!   `i`, from draw `first + r` elsewhere
//!   ([`ParamSampler::pick_freeze_deltas`](crate::sampling::ParamSampler::pick_freeze_deltas)),
//!   so the rows are generated inside the backend from the counter streams like draws are:
//!   nothing of size rows × inputs is built on the host or uploaded to a device. Mask 0 gives
//!   what `evaluate` gives for draw `first + r`. Backends without it (the scalar
//!   [`FnEvaluator`]) return [`EngineError::PickFreezeUnsupported`].

pub mod backend;
pub mod cpu;
pub mod deviation;
pub mod discrepancy;
pub mod joint_errors;
mod pick_freeze;
pub mod placement;
mod problem;

pub use backend::{cpu_evaluator, BackendChoice, Backends, CpuOnly};
pub use cpu::CpuEvaluator;
pub use discrepancy::{DiscrepancyDraws, SecondTerm, DISCREPANCY_STREAM};
pub use joint_errors::{
    JointErrorDraws, TermGroup, TermPacking, BACKLASH_MASK, BACKLASH_STREAM, JOINT_ERRORS_MASK,
    JOINT_ERROR_STREAM,
};
pub use pick_freeze::{PickFreeze, DISCREPANCY_MASK};
pub use placement::{Frame, PlacementEvaluator, PlacementSpread};
pub use problem::{Problem, ProblemError, Reference};

use crate::kinematics::{InputSpace, Layout};
use crate::sampling::Philox;

/// Largest accepted angular offset (θ, α, β) in an offset matrix, radians: a quarter turn.
/// Offsets are deviations of a calibrated model, orders of magnitude smaller; the bound keeps
/// every backend inside the range where its small-angle formulation holds its error budget
/// (see [`deviation`]).
pub const MAX_ANGLE_OFFSET: f64 = std::f64::consts::FRAC_PI_2;

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
    /// An offset matrix whose length is not `rows ×` [`Evaluator::offset_width`] for the
    /// requested rows.
    #[error(
        "offset matrix has {got} entries, expected {expected} ({rows} rows of {} inputs)",
        expected / (*rows).max(1)
    )]
    OffsetsShape {
        /// Rows requested (the length of the output `w`).
        rows: usize,
        /// Entries needed.
        expected: usize,
        /// Entries given.
        got: usize,
    },
    /// An offset that is not finite, or an angular offset beyond [`MAX_ANGLE_OFFSET`].
    #[error("offset matrix row {row}, parameter {param}: {message}")]
    BadOffset {
        /// 0-based row.
        row: usize,
        /// Input name, e.g. `theta2` (1-based joint) or `tool_x`.
        param: String,
        /// What is wrong.
        message: String,
    },
    /// The evaluator has no offset path.
    #[error("the {evaluator} evaluator cannot evaluate explicit parameter offsets")]
    OffsetsUnsupported {
        /// Which evaluator.
        evaluator: String,
    },
    /// The evaluator cannot generate pick-freeze rows.
    #[error("the {evaluator} evaluator cannot generate pick-freeze rows")]
    PickFreezeUnsupported {
        /// Which evaluator.
        evaluator: String,
    },
    /// The model's uncertain placement cannot be drawn as asked (not positive definite, or on
    /// an evaluator that does not draw it).
    #[error("base placement: {0}")]
    Placement(String),
    /// A pick-freeze request that does not describe valid rows.
    #[error("pick-freeze request: {0}")]
    PickFreezeRequest(String),
    /// The GPU backend failed.
    #[error("GPU evaluator: {0}")]
    Gpu(String),
    /// A GPU was asked for and the program was built without the GPU backend.
    #[error("built without the GPU backend: only the CPU backend is available")]
    NoGpuBackend,
}

/// Evaluates the maximum point error of batches of parameter vectors (see the module docs).
///
/// Callers use the provided [`Evaluator::evaluate`] and [`Evaluator::evaluate_offsets`], which
/// check their arguments; backends implement [`Evaluator::eval_draws`] and, optionally,
/// [`Evaluator::eval_offsets`], which may assume checked arguments.
pub trait Evaluator: Send {
    /// Backend description.
    fn info(&self) -> BackendInfo;
    /// Number of test points m (1 for a scalar model).
    fn n_points(&self) -> usize;

    /// Backend part of [`Evaluator::evaluate`]: `per_point`, when given, has `w.len() · m`
    /// entries.
    ///
    /// # Errors
    ///
    /// The backend's failure, e.g. [`EngineError::Gpu`] when the device fails (the CPU evaluator
    /// does not fail).
    fn eval_draws(
        &mut self,
        first: u64,
        w: &mut [f64],
        per_point: Option<&mut [f64]>,
    ) -> Result<(), EngineError>;

    /// How the inputs of the evaluated model are laid out (its joint count); the default, for
    /// evaluators without a robot model, is the six-joint layout.
    fn layout(&self) -> Layout {
        Layout::SIX
    }

    /// The inputs of a row of [`Evaluator::evaluate_offsets`]: the robot's
    /// ([`InputSpace::robot`]), or those and the placement ([`InputSpace::measured`]) for an
    /// evaluator that draws the model's uncertain base placement (x, y, z in mm and roll, pitch,
    /// yaw in radians after the other inputs).
    fn offset_space(&self) -> InputSpace {
        self.layout().robot()
    }

    /// Entries per row of [`Evaluator::evaluate_offsets`]: the length of
    /// [`Evaluator::offset_space`].
    fn offset_width(&self) -> usize {
        self.offset_space().len()
    }

    /// Backend part of [`Evaluator::evaluate_offsets`]: `offsets` has `w.len() ·`
    /// [`Evaluator::offset_width`] finite entries with angular offsets within [`MAX_ANGLE_OFFSET`], and `per_point`, when
    /// given, `w.len() · m`. The default: [`EngineError::OffsetsUnsupported`].
    ///
    /// # Errors
    ///
    /// [`EngineError::OffsetsUnsupported`] from this default; a backend's own failure, e.g.
    /// [`EngineError::Gpu`].
    fn eval_offsets(
        &mut self,
        offsets: &[f64],
        w: &mut [f64],
        per_point: Option<&mut [f64]>,
    ) -> Result<(), EngineError> {
        let _ = (offsets, w, per_point);
        Err(EngineError::OffsetsUnsupported {
            evaluator: self.info().adapter,
        })
    }

    /// Backend part of [`Evaluator::evaluate_pick_freeze`]: `request` is checked and `w` has
    /// [`PickFreeze::rows`] entries. The default: [`EngineError::PickFreezeUnsupported`].
    ///
    /// # Errors
    ///
    /// [`EngineError::PickFreezeUnsupported`] from this default; a backend's own failure, e.g.
    /// [`EngineError::Gpu`] or [`EngineError::PickFreezeRequest`] for a request too large for the
    /// backend.
    fn eval_pick_freeze(&mut self, request: &PickFreeze, w: &mut [f64]) -> Result<(), EngineError> {
        let _ = (request, w);
        Err(EngineError::PickFreezeUnsupported {
            evaluator: self.info().adapter,
        })
    }

    /// Fills `w[s · count + r]` with `w` of row `r` of matrix `s` of a pick-freeze request (see
    /// [`PickFreeze`]).
    ///
    /// # Errors
    ///
    /// [`EngineError::PickFreezeRequest`] for masks with bits beyond the draw's normals or draw
    /// indices past 2⁶⁴, [`EngineError::BufferSize`] when `w` does not have [`PickFreeze::rows`]
    /// entries, [`EngineError::PickFreezeUnsupported`] for an evaluator without pick-freeze rows,
    /// and the backend's own failure (e.g. [`EngineError::Gpu`]).
    fn evaluate_pick_freeze(
        &mut self,
        request: &PickFreeze,
        w: &mut [f64],
    ) -> Result<(), EngineError> {
        request.check()?;
        if w.len() != request.rows() {
            return Err(EngineError::BufferSize {
                expected: request.rows(),
                got: w.len(),
            });
        }
        self.eval_pick_freeze(request, w)
    }

    /// Fills `w[i]` with `w` of draw `first + i` (mm) and, if given, `per_point[i·m + j]` with
    /// `e_j` of that draw.
    ///
    /// # Errors
    ///
    /// [`EngineError::BufferSize`] when `per_point` is given and does not hold `w.len() · m`
    /// entries; the backend's own failure, e.g. [`EngineError::Gpu`] when the device fails.
    fn evaluate(
        &mut self,
        first: u64,
        w: &mut [f64],
        per_point: Option<&mut [f64]>,
    ) -> Result<(), EngineError> {
        check_buffers(self.n_points(), w, per_point.as_deref())?;
        self.eval_draws(first, w, per_point)
    }

    /// Fills `w[i]` with `w` of the parameter vector and tool point `μ̄ + offsets[i·W ..][..W]`
    /// (μ̄ the model's values; mm and radians; for six joints entries 30–32 move the tool point
    /// in the flange frame, and with [`InputSpace::measured`] rows entries 33–38 the base
    /// placement; 35–37 and 38–43 for seven joints) and, if given,
    /// `per_point[i·m + j]` with its `e_j`. W is [`Evaluator::offset_width`].
    ///
    /// # Errors
    ///
    /// [`EngineError::OffsetsShape`] when `offsets` does not hold `w.len() · W` entries,
    /// [`EngineError::BadOffset`] for a non-finite entry or an angular offset beyond
    /// [`MAX_ANGLE_OFFSET`], [`EngineError::BufferSize`] for a `per_point` of the wrong length,
    /// [`EngineError::OffsetsUnsupported`] for an evaluator without an offset path, and the
    /// backend's own failure (e.g. [`EngineError::Gpu`]).
    fn evaluate_offsets(
        &mut self,
        offsets: &[f64],
        w: &mut [f64],
        per_point: Option<&mut [f64]>,
    ) -> Result<(), EngineError> {
        check_offsets(self.offset_space(), offsets, w.len())?;
        check_buffers(self.n_points(), w, per_point.as_deref())?;
        self.eval_offsets(offsets, w, per_point)
    }
}

/// Checks the output lengths of an evaluation: `per_point` must hold `m` entries per `w`.
fn check_buffers(m: usize, w: &[f64], per_point: Option<&[f64]>) -> Result<(), EngineError> {
    match per_point {
        Some(e) if e.len() != w.len() * m => Err(EngineError::BufferSize {
            expected: w.len() * m,
            got: e.len(),
        }),
        _ => Ok(()),
    }
}

/// Checks an offset matrix of `rows` rows: its length, finiteness, and the angle bound.
fn check_offsets(space: InputSpace, offsets: &[f64], rows: usize) -> Result<(), EngineError> {
    let width = space.len();
    let expected = rows * width;
    if offsets.len() != expected {
        return Err(EngineError::OffsetsShape {
            rows,
            expected,
            got: offsets.len(),
        });
    }
    for (x, &v) in offsets.iter().enumerate() {
        let (row, p) = (x / width, x % width);
        let angle = space.is_angle(p);
        let message = if !v.is_finite() {
            format!("{v} is not finite")
        } else if angle && v.abs() > MAX_ANGLE_OFFSET {
            format!("angular offset {v} rad exceeds {MAX_ANGLE_OFFSET:.4} rad (a quarter turn)")
        } else {
            continue;
        };
        return Err(EngineError::BadOffset {
            row,
            param: space.name(p),
            message,
        });
    }
    Ok(())
}

/// An evaluator for a scalar model `y = f(gen, k)` of draw `k`, where `gen` is the run's Philox
/// generator: for testing the Monte Carlo drivers on models with known distributions (e.g. the
/// additive model of GUM S1 §9.2). It has no parameter vector, so
/// [`Evaluator::evaluate_offsets`] returns [`EngineError::OffsetsUnsupported`].
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
    fn eval_draws(
        &mut self,
        first: u64,
        w: &mut [f64],
        per_point: Option<&mut [f64]>,
    ) -> Result<(), EngineError> {
        use rayon::prelude::*;
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{ALL_NORMALS, MAX_NORMALS};
    const L6: Layout = Layout::SIX;
    const NP: usize = L6.n_params();
    const NU: usize = 33;
    const NB: usize = 39;

    fn scalar() -> FnEvaluator<impl Fn(&Philox, u64) -> f64 + Send + Sync> {
        FnEvaluator::new(1, |_: &Philox, k: u64| k as f64)
    }

    #[test]
    fn evaluate_checks_buffers_before_the_backend() {
        let mut ev = scalar();
        let mut w = vec![0.0; 4];
        let mut e = vec![0.0; 3];
        match ev.evaluate(0, &mut w, Some(&mut e)) {
            Err(EngineError::BufferSize { expected, got }) => assert_eq!((expected, got), (4, 3)),
            r => panic!("expected a buffer-size error, got {r:?}"),
        }
        assert_eq!(w, [0.0; 4], "nothing is written on error");
        let mut e = vec![0.0; 4];
        ev.evaluate(10, &mut w, Some(&mut e)).unwrap();
        assert_eq!(w, [10.0, 11.0, 12.0, 13.0]);
        assert_eq!(e, w);
    }

    #[test]
    fn scalar_evaluator_has_no_offset_path() {
        let mut ev = scalar();
        let mut w = vec![0.0; 2];
        let r = ev.evaluate_offsets(&[0.0; 2 * NU], &mut w, None);
        assert!(
            matches!(r, Err(EngineError::OffsetsUnsupported { .. })),
            "{r:?}"
        );
    }

    #[test]
    fn pick_freeze_requests_are_checked() {
        let masks = [0, ALL_NORMALS, 1 << 3];
        let ok = PickFreeze {
            first: 10,
            b_first: 1 << 63,
            count: 4,
            masks: &masks,
        };
        assert_eq!(ok.rows(), 12);
        assert_eq!(ok.row(9), (11, (1 << 63) + 1, 1 << 3));
        assert!(ok.check().is_ok());
        let wide = [1u64 << MAX_NORMALS];
        let r = PickFreeze { masks: &wide, ..ok }.check();
        assert!(
            matches!(&r, Err(EngineError::PickFreezeRequest(m)) if m.contains("matrix 0")),
            "{r:?}"
        );
        let r = PickFreeze {
            b_first: u64::MAX - 2,
            ..ok
        }
        .check();
        assert!(
            matches!(&r, Err(EngineError::PickFreezeRequest(m)) if m.contains("rows of B")),
            "{r:?}"
        );
        let mut ev = scalar();
        let mut w = vec![0.0; 11];
        assert!(matches!(
            ev.evaluate_pick_freeze(&ok, &mut w),
            Err(EngineError::BufferSize {
                expected: 12,
                got: 11
            })
        ));
        let mut w = vec![0.0; 12];
        assert!(matches!(
            ev.evaluate_pick_freeze(&ok, &mut w),
            Err(EngineError::PickFreezeUnsupported { .. })
        ));
    }

    #[test]
    fn offset_matrices_are_checked() {
        assert!(check_offsets(L6.robot(), &[0.0; 3 * NU], 3).is_ok());
        match check_offsets(L6.robot(), &[0.0; 3 * NU - 1], 3) {
            Err(EngineError::OffsetsShape {
                rows,
                expected,
                got,
            }) => assert_eq!((rows, expected, got), (3, 99, 98)),
            r => panic!("{r:?}"),
        }
        let mut m = vec![0.0; 2 * NU];
        m[NU + NP + 2] = f64::NAN; // row 1, tool z
        match check_offsets(L6.robot(), &m, 2) {
            Err(EngineError::BadOffset { row, param, .. }) => {
                assert_eq!((row, param.as_str()), (1, "tool_z"))
            }
            r => panic!("{r:?}"),
        }
        m[NU + NP + 2] = 2.0; // a tool offset is a length: no angle bound
        m[NU + 7] = f64::NAN; // row 1, a of joint 2
        match check_offsets(L6.robot(), &m, 2) {
            Err(EngineError::BadOffset { row, param, .. }) => {
                assert_eq!((row, param.as_str()), (1, "a2"))
            }
            r => panic!("{r:?}"),
        }
        m[NU + 7] = 1e3; // lengths have no bound
        assert!(check_offsets(L6.robot(), &m, 2).is_ok());
        m[3] = -2.0; // α1 beyond a quarter turn
        match check_offsets(L6.robot(), &m, 2) {
            Err(EngineError::BadOffset {
                row,
                param,
                message,
            }) => {
                assert_eq!((row, param.as_str()), (0, "alpha1"));
                assert!(message.contains("exceeds"), "{message}");
            }
            r => panic!("{r:?}"),
        }
        m[3] = f64::INFINITY;
        assert!(matches!(
            check_offsets(L6.robot(), &m, 2),
            Err(EngineError::BadOffset { .. })
        ));
        // Rows with the placement: 39 entries, the base's angles bounded, its lengths not.
        let mut p = vec![0.0; 2 * NB];
        assert!(check_offsets(L6.measured(), &p, 2).is_ok());
        assert!(check_offsets(L6.robot(), &p, 2).is_err());
        p[NB + NU] = 500.0; // row 1, base x
        assert!(check_offsets(L6.measured(), &p, 2).is_ok());
        p[NB + NU + 5] = 2.0; // row 1, base yaw
        match check_offsets(L6.measured(), &p, 2) {
            Err(EngineError::BadOffset { row, param, .. }) => {
                assert_eq!((row, param.as_str()), (1, "base_yaw"))
            }
            r => panic!("{r:?}"),
        }
    }
}
