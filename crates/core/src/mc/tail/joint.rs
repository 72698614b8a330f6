//! The model's joint errors (compliance, gear harmonics, payload; docs/METHOD.md §19) in the
//! standard-normal space of the tail analysis.
//!
//! A draw of the joint errors is a linear map of its own standard normals
//! ([`JointErrorDraws::draw_from_normals`]: `δβ = L z` for the free coefficients, `δm = σ_m z_p`
//! for the payload; a model with backlash adds two whose `⌊Φ(z)·2³²⌋` are the words of its
//! sides), so they join the state as `p + 1` (or `p + 3`) more coordinates after the parameters'
//! and before the discrepancy term's, and subset simulation's chains move them like the others:
//! a tail driven by a soft joint or a heavy payload is found as one driven by the geometry is.
//!
//! Each row is evaluated by the exact f64 point form on the CPU — the geometric inputs moved by
//! the draw's `A δβ`, each joint turned further at each point, forward kinematics from
//! [`crate::kinematics::position`] — in the base frame ([`Problem::errors_with_joint_errors`])
//! or with the drawn base placement ([`PlacementEvaluator::errors_with_joint_errors`]). The
//! kernels' offset rows keep the joint errors at their mean, so a tail of such a model does not
//! go through them; the run says so in its backend.

use rayon::prelude::*;

use super::TailError;
use crate::engine::{BackendInfo, JointErrorDraws, PlacementEvaluator, PlacementSpread, Problem};

/// The joint errors' normals of a state and the exact evaluation of its rows.
pub(super) struct JointSpace {
    draws: JointErrorDraws,
    rows: ExactRows,
}

/// The exact point form of the problem's frame.
enum ExactRows {
    /// The base frame: offsets of the robot's inputs.
    Base(Box<Problem>),
    /// The measurement frame: offsets of the robot's inputs and the placement.
    Placed(Box<PlacementEvaluator>),
}

impl JointSpace {
    /// The joint errors of `problem` (`None` when its model draws none).
    pub(super) fn new(problem: &Problem) -> Result<Option<JointSpace>, TailError> {
        let Some(draws) = problem.joint_errors.clone() else {
            return Ok(None);
        };
        let rows = match PlacementSpread::of(problem)? {
            Some(spread) => {
                ExactRows::Placed(Box::new(PlacementEvaluator::new(problem.clone(), spread)))
            }
            None => ExactRows::Base(Box::new(problem.clone())),
        };
        Ok(Some(JointSpace { draws, rows }))
    }

    /// Normals the joint errors add to a state: one per free coefficient and the payload's, and
    /// two for the backlash's sides when the model has backlash
    /// ([`JointErrorDraws::state_normals`]).
    pub(super) fn dim(&self) -> usize {
        self.draws.state_normals()
    }

    /// What evaluates the rows, in the run's report.
    pub(super) fn backend() -> BackendInfo {
        BackendInfo {
            backend: "cpu".into(),
            adapter: "rayon f64, exact point form (the model's joint errors)".into(),
            driver: format!("{} threads", rayon::current_num_threads()),
        }
    }

    /// Per-point errors `e` (rows of `m`) of the offset rows `offsets` (rows of the problem's
    /// offset width) with the joint errors of the states `u` (rows of `stride` normals, the
    /// joint errors' [`Self::dim`] of them starting at `at`), in parallel.
    pub(super) fn errors(
        &self,
        offsets: &[f64],
        width: usize,
        u: (&[f64], usize, usize),
        e: &mut [f64],
    ) {
        let (z, stride, at) = u;
        let m = e.len() / (offsets.len() / width).max(1);
        let dim = self.dim();
        e.par_chunks_mut(m.max(1))
            .zip(offsets.par_chunks(width))
            .zip(z.par_chunks(stride))
            .for_each(|((ei, d), zi)| {
                let term = self.draws.draw_from_normals(&zi[at..at + dim]);
                match &self.rows {
                    ExactRows::Base(p) => p.errors_with_joint_errors(d, &term, ei),
                    ExactRows::Placed(ev) => ev.errors_with_joint_errors(d, &term, ei),
                };
            });
    }
}
