//! A plan's progress ([`PlanOptions::progress`]): its steps, each weighted by the work it does
//! for the plan's numbers of candidates, poses and inputs, told to the hook as
//! [`PLAN_STEPS`]ths of the whole, so that a listener's remaining time holds from the first
//! step to the last.

use super::PlanOptions;
use crate::progress::ProgressHook;
use std::sync::atomic::{AtomicU64, Ordering};

/// The steps a plan's progress counts in all: the hook's `total`.
pub const PLAN_STEPS: u64 = 1000;

/// A step of the plan, in the order it runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Step {
    /// Drawing the candidate configurations.
    Candidates,
    /// Their Jacobians.
    Jacobians,
    /// The greedy D-optimal design.
    Greedy,
    /// The exchange on q95.
    Exchange,
    /// The random designs compared with.
    Random,
    /// The approximate-design bound.
    Bound,
    /// The curve against the number of poses, the covariance and the visiting order.
    Curve,
}

impl Step {
    const ALL: [Step; 7] = [
        Step::Candidates,
        Step::Jacobians,
        Step::Greedy,
        Step::Exchange,
        Step::Random,
        Step::Bound,
        Step::Curve,
    ];

    fn label(self) -> &'static str {
        match self {
            Step::Candidates => "drawing candidates",
            Step::Jacobians => "candidate Jacobians",
            Step::Greedy => "greedy D-optimal design",
            Step::Exchange => "exchange on q95",
            Step::Random => "random designs",
            Step::Bound => "design bound",
            Step::Curve => "curve and order",
        }
    }
}

/// The plan's steps and their weights; reports only ever grow.
pub(super) struct Steps<'a> {
    hook: &'a ProgressHook,
    /// Each step's share of the work, summing to 1.
    share: [f64; 7],
    /// The last count reported.
    done: AtomicU64,
}

impl<'a> Steps<'a> {
    /// The steps of a plan of `o` over `p` free inputs and `task` task points, reported to
    /// `o.progress`. Each step's weight is its time in nanoseconds on two cores as its
    /// operations predict it, fitted to plans of 2000 … 100000 candidates of a six-joint arm
    /// (27 inputs, 50 task points; within a factor of two of each step's time). A step that
    /// ends early (the exchange without improvement, the bound at its tolerance) jumps to the
    /// next.
    pub(super) fn new(o: &'a PlanOptions, p: usize, task: usize) -> Self {
        let m = o.candidates as f64;
        let (p, n, task) = (p as f64, o.poses as f64, task as f64);
        // w over K normal vectors: a 3·task × p by p × K product.
        let w = |k: usize| 0.05 * 3.0 * task * p * k as f64;
        // One design's figures: three p × p factorisations and w on the figures' vectors.
        let figures = 1.5 * p * p * p + w(super::EVAL_DRAWS);
        // Per candidate found: its draws (with refusals), singularity and workcell checks.
        let candidates = 1600.0 * m;
        // Per candidate and input: two predictions of the chain.
        let jacobians = 380.0 * m * p;
        // Per pose chosen and candidate: a 3 × p by p × p product.
        let greedy = 2.4 * n * m * p * p;
        // Per pass and pose: a factorisation per screened swap and q95 of the judged few.
        let exchange = o.passes as f64
            * n
            * (0.3 * o.swaps as f64 * (p * p * p + task * p * p)
                + super::search::JUDGED as f64 * w(o.search_draws)
                + m);
        let random = o.random_designs as f64 * figures;
        // Per iteration (at most): the weighted products over every candidate's rows.
        let bound = 2.0 * super::compare::BOUND_ITERATIONS as f64 * m * p * p;
        let curve = n * (figures + n * p * p);
        let weights = [
            candidates, jacobians, greedy, exchange, random, bound, curve,
        ];
        let sum: f64 = weights.iter().sum();
        Steps {
            hook: &o.progress,
            share: weights.map(|x| x / sum),
            done: AtomicU64::new(0),
        }
    }

    /// Reports that `fraction` (0 … 1) of `step` is done.
    pub(super) fn at(&self, step: Step, fraction: f64) {
        let k = Step::ALL.iter().position(|s| *s == step).unwrap_or(0);
        let before: f64 = self.share[..k].iter().sum();
        let x = before + self.share[k] * fraction.clamp(0.0, 1.0);
        let count = ((x * PLAN_STEPS as f64).floor() as u64).min(PLAN_STEPS);
        let last = self.done.fetch_max(count, Ordering::Relaxed);
        self.hook.report(step.label(), count.max(last), PLAN_STEPS);
    }

    /// Reports the plan done.
    pub(super) fn finish(&self) {
        self.done.store(PLAN_STEPS, Ordering::Relaxed);
        self.hook.report("done", PLAN_STEPS, PLAN_STEPS);
    }
}
