//! The problem every backend evaluates: model, test points, reference positions and seed.
//!
//! The reference position of test point j is `P_ref,j` of paper eq. 12: by default the position
//! the calibrated model predicts (FK with its own parameter values), optionally that of a nominal
//! (design) model, which adds the systematic error of an uncalibrated robot (docs/METHOD.md §3).
//!
//! The nominal reference is where the design geometry would put *the same target*: the nominal
//! model's joint parameters with the analysed model's tool. A nominal model is usually a preset
//! without a tracker target (tool `[0, 0, 0]`), while every identified model carries the target
//! it was measured with; using the nominal model's own tool would add the tool offset (tens of
//! mm) to every error.

use super::joint_errors::{JointErrorDraws, TermDraw};
use super::{DiscrepancyDraws, SecondTerm};
use crate::discrepancy::size::SIZE_DRAWS;
use crate::discrepancy::{Discrepancy, DiscrepancyUse};
use crate::kinematics::{position, Block, Joints, RobotModel};
use crate::sampling::{ParamSampler, SamplerError};

/// What the errors are measured against.
#[derive(Clone, Debug)]
pub enum Reference {
    /// The model's own parameter values (the calibrated model).
    Calibrated,
    /// Another (nominal) model's joint parameters, with the analysed model's tool.
    Nominal(Box<RobotModel>),
}

impl Reference {
    /// How reports name the reference of an analysis of `model`: `"calibrated model"`,
    /// `"nominal model (NAME)"`, or, when the nominal model's own tool differs from the model's,
    /// `"nominal model (NAME) with the model's tool [x, y, z]"` (mm).
    pub fn label(&self, model: &RobotModel) -> String {
        match self {
            Reference::Calibrated => "calibrated model".to_string(),
            Reference::Nominal(n) if n.tool == model.tool => format!("nominal model ({})", n.name),
            Reference::Nominal(n) => {
                let [x, y, z] = model.tool;
                format!(
                    "nominal model ({}) with the model's tool [{x:.3}, {y:.3}, {z:.3}]",
                    n.name
                )
            }
        }
    }
}

/// Errors setting up a problem.
#[derive(Debug, thiserror::Error)]
pub enum ProblemError {
    /// No test points.
    #[error("no test points: at least one is needed")]
    NoPoints,
    /// A value of the model is out of range (see [`RobotModel::check`]).
    #[error("model {model}: {field}: {message}")]
    Model {
        /// The model's name.
        model: String,
        /// The field, as the model file spells it.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// A test point is outside the joint limits or not finite.
    #[error("test point {index}: {message}")]
    BadPoint {
        /// 1-based row.
        index: usize,
        /// What is wrong.
        message: String,
    },
    /// The nominal model of a nominal reference has another number of joints than the model.
    #[error("the nominal model {nominal} has {nominal_joints} joints, the model {model} has {model_joints}")]
    NominalJoints {
        /// The nominal model's name.
        nominal: String,
        /// Its joints.
        nominal_joints: usize,
        /// The model's name.
        model: String,
        /// Its joints.
        model_joints: usize,
    },
    /// The test points' backlash sides do not fit them ([`Problem::set_known_sides`]).
    #[error("approach sides: {0}")]
    Sides(String),
    /// The parameter distribution is unusable.
    #[error(transparent)]
    Sampler(#[from] SamplerError),
}

/// The draws of `model`'s discrepancy term for `usage`: none without a term, and none for the
/// robot when every draw of the term's size is measurement noise ([`Discrepancy::drawn`]).
/// Each draw scales the radii by its draw of the size ([`Discrepancy::draw_factors`]); a
/// compensated model's term is drawn at each of `points` (radians) with its predictive σ there.
/// Where `centre` marks points at the centre of the backlash's gaps (a model with a term for
/// unknown sides, sides known at the other points), those draw the term for unknown sides
/// instead ([`SecondTerm`]), the others the model's own term (none: nothing there).
///
/// [`Discrepancy::drawn`]: crate::discrepancy::Discrepancy::drawn
/// [`Discrepancy::draw_factors`]: crate::discrepancy::Discrepancy::draw_factors
fn discrepancy_draws(
    model: &RobotModel,
    points: &[Joints],
    usage: DiscrepancyUse,
    seed: u64,
    centre: &[bool],
) -> Option<DiscrepancyDraws> {
    let drawn = |d: &&Discrepancy| usage == DiscrepancyUse::Measured || d.drawn();
    let own = model.discrepancy.as_ref().filter(drawn);
    if !centre.iter().any(|&c| c) {
        return own.map(|d| {
            DiscrepancyDraws::new(d.radii().to_vec(), d.draw_factors(usage), seed)
                .with_scales(d.point_scales(points))
        });
    }
    let unknown = model.sides_unknown_term().filter(drawn);
    if own.is_none() && unknown.is_none() {
        return None;
    }
    // A missing term draws radius 0: the error stays the chain's.
    let table = |d: Option<&Discrepancy>| match d {
        Some(d) => (
            d.radii().to_vec(),
            d.draw_factors(usage),
            d.point_scales(points),
        ),
        None => (vec![0.0], vec![0.0; SIZE_DRAWS], Vec::new()),
    };
    let (radii, factors, own_scales) = table(own);
    let (second_radii, second_factors, second_scales) = table(unknown);
    let scales = if own_scales.is_empty() && second_scales.is_empty() {
        Vec::new()
    } else {
        let at = |s: &[f64], j: usize| s.get(j).copied().unwrap_or(1.0);
        (0..points.len())
            .map(|j| {
                if centre[j] {
                    at(&second_scales, j)
                } else {
                    at(&own_scales, j)
                }
            })
            .collect()
    };
    Some(
        DiscrepancyDraws::new(radii, factors, seed)
            .with_scales(scales)
            .with_second(SecondTerm {
                radii: second_radii,
                factors: second_factors,
                at: centre.to_vec(),
            }),
    )
}

/// Model + test points + reference + seed.
#[derive(Clone, Debug)]
pub struct Problem {
    /// The model whose parameter spread is analysed.
    pub model: RobotModel,
    /// Joint configurations of the test points, radians (one angle per joint of the model).
    pub points: Vec<Joints>,
    /// The joint angles (radians) the model's mean chain stands at for each test point: the
    /// commanded angles plus the mean deflections of the model's joint errors
    /// ([`RobotModel::chain_angles`]); the points themselves for a geometric model.
    pub chain_points: Vec<Joints>,
    /// Reference position of each test point, mm.
    pub reference: Vec<[f64; 3]>,
    /// Parameter sampler (mean = model values, seed).
    pub sampler: ParamSampler,
    /// The seed of the run.
    pub seed: u64,
    /// The model's discrepancy term as this run draws it at every test point (counter draws;
    /// [`crate::discrepancy`]); `None` when the model has none or the analysis leaves it out.
    pub discrepancy: Option<DiscrepancyDraws>,
    /// The model's joint errors as this run draws them ([`JointErrorDraws`]); `None` for a
    /// geometric model or one whose joint errors carry no uncertainty (their mean deflections
    /// are in [`Self::chain_points`] either way).
    pub joint_errors: Option<JointErrorDraws>,
    /// The model as given, while [`Self::model`] is its prediction for backlash sides not known
    /// ([`RobotModel::with_sides_unknown`]): until [`Self::set_known_sides`] gives every
    /// point's sides. `None` for a model without a term for unknown sides.
    pub sided: Option<Box<RobotModel>>,
    /// The (test point, joint with a gap) pairs whose side was given, of how many, at the points
    /// whose sides are not all given, for a model with a term for unknown sides: they are not
    /// used (those points stand at the centre of the gaps, [`JointErrorDraws::set_centre`]).
    pub sides_unused: Option<(usize, usize)>,
    /// How the discrepancy term is drawn; `None` when it is left out.
    discrepancy_use: Option<DiscrepancyUse>,
}

impl Problem {
    /// Builds a problem from test points in degrees (checked against the model's limits). The
    /// model is checked as a model file is ([`RobotModel::check`]).
    ///
    /// # Errors
    ///
    /// [`ProblemError::Model`] when the model fails its checks, [`ProblemError::NominalJoints`] for
    /// a nominal reference with another number of joints, [`ProblemError::NoPoints`] for no
    /// test points, [`ProblemError::BadPoint`] for a test point that is not finite or outside the
    /// joint limits, and [`ProblemError::Sampler`] when the covariance has no Cholesky factor on
    /// the free parameters.
    ///
    /// # Examples
    ///
    /// The TX60 at three test points; the CPU evaluator's `w` of each draw is the largest of
    /// that draw's point errors, as [`Problem::point_errors_at`] computes them:
    ///
    /// ```
    /// use gpu_amcs_core::engine::{CpuEvaluator, Evaluator, Problem, ProblemError, Reference};
    /// use gpu_amcs_core::kinematics::tx60;
    ///
    /// let model = tx60();
    /// let points = [
    ///     [0.0, 10.0, 80.0, 0.0, 30.0, 0.0],
    ///     [20.0, -10.0, 90.0, 10.0, 45.0, 5.0],
    ///     [-30.0, 0.0, 100.0, 0.0, -20.0, 90.0],
    /// ];
    /// let problem = Problem::new(model.clone(), &points, &Reference::Calibrated, 2025)?;
    /// assert_eq!(problem.n_points(), 3);
    /// // The calibrated reference is the model's own prediction: no error at the mean.
    /// assert!(problem.point_errors(&model.params).iter().all(|&e| e == 0.0));
    ///
    /// let mut ev = CpuEvaluator::new(problem.clone());
    /// let mut w = [0.0; 4];
    /// let mut per_point = [0.0; 4 * 3];
    /// ev.evaluate(10, &mut w, Some(&mut per_point))?; // draws 10 … 13
    /// for (i, k) in (10..14).enumerate() {
    ///     let s = &problem.sampler;
    ///     let e = problem.point_errors_at(&s.draw(k), &s.tool_deltas(k));
    ///     let max = e.iter().cloned().fold(0.0, f64::max);
    ///     assert!((w[i] - max).abs() < 1e-9, "draw {k}: {} vs {max}", w[i]);
    ///     for j in 0..3 {
    ///         assert!((per_point[i * 3 + j] - e[j]).abs() < 1e-9);
    ///     }
    /// }
    ///
    /// // A point outside the joint limits is refused, naming its row.
    /// let far = [[0.0, 0.0, 0.0, 0.0, 0.0, 1000.0]];
    /// let err = Problem::new(model, &far, &Reference::Calibrated, 2025).unwrap_err();
    /// assert!(matches!(err, ProblemError::BadPoint { index: 1, .. }));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn new<P: AsRef<[f64]>>(
        model: RobotModel,
        points_deg: &[P],
        reference: &Reference,
        seed: u64,
    ) -> Result<Self, ProblemError> {
        model.check().map_err(|e| ProblemError::Model {
            model: model.name.clone(),
            field: e.field,
            message: e.message,
        })?;
        if let Reference::Nominal(n) = reference {
            if n.joints() != model.joints() {
                return Err(ProblemError::NominalJoints {
                    nominal: n.name.clone(),
                    nominal_joints: n.joints(),
                    model: model.name.clone(),
                    model_joints: model.joints(),
                });
            }
        }
        if points_deg.is_empty() {
            return Err(ProblemError::NoPoints);
        }
        for (i, q) in points_deg.iter().enumerate() {
            model
                .check_limits(q.as_ref())
                .map_err(|message| ProblemError::BadPoint {
                    index: i + 1,
                    message,
                })?;
        }
        let points: Vec<Joints> = points_deg
            .iter()
            .map(|q| q.as_ref().iter().map(|v| v.to_radians()).collect())
            .collect();
        // Sides are not known until given: a model with a term for that predicts without them.
        let (model, sided) = match model.with_sides_unknown() {
            Some(centre) => (centre, Some(Box::new(model))),
            None => (model, None),
        };
        let chain_points: Vec<Joints> = points.iter().map(|q| model.chain_angles(q)).collect();
        // The calibrated reference is where the calibrated model puts the target (with its
        // joint errors at the payload during calibration: a task payload that differs bends the
        // robot away from it), the nominal one where the design geometry would, at the commanded
        // angles.
        let reference = points
            .iter()
            .map(|q| match reference {
                Reference::Calibrated => position(
                    &model.params,
                    &model.tool,
                    &model.calibrated_chain_angles(q),
                ),
                Reference::Nominal(n) => position(&n.params, &model.tool, q),
            })
            .collect();
        let sampler = ParamSampler::new(&model, seed)?;
        let discrepancy = discrepancy_draws(&model, &points, DiscrepancyUse::Robot, seed, &[]);
        let joint_errors = JointErrorDraws::new(&model, &points, seed)?;
        Ok(Problem {
            joint_errors,
            discrepancy,
            sided,
            sides_unused: None,
            discrepancy_use: Some(DiscrepancyUse::Robot),
            model,
            points,
            chain_points,
            reference,
            sampler,
            seed,
        })
    }

    /// The problem without the model's discrepancy term: the parameters' uncertainty alone
    /// (what the reliability was before the term; for comparisons and the self-checks).
    pub fn without_discrepancy(mut self) -> Problem {
        self.discrepancy = None;
        self.discrepancy_use = None;
        self
    }

    /// The problem drawing the model's discrepancy term for `usage` (the default is
    /// [`DiscrepancyUse::Robot`]); nothing changes for a model without one.
    pub fn with_discrepancy_use(mut self, usage: DiscrepancyUse) -> Problem {
        self.discrepancy =
            discrepancy_draws(&self.model, &self.points, usage, self.seed, self.centre());
        self.discrepancy_use = Some(usage);
        self
    }

    /// Per test point whether it stands at the centre of the backlash's gaps while the sides
    /// are known at other points ([`JointErrorDraws::set_centre`]); empty when none does.
    pub fn centre(&self) -> &[bool] {
        self.joint_errors
            .as_ref()
            .map_or(&[], |t| t.centre.as_slice())
    }

    /// Number of test points m.
    pub fn n_points(&self) -> usize {
        self.points.len()
    }

    /// Per-point errors `e_j` of one parameter vector, straight from [`position`] (slow; for
    /// tests and spot checks).
    pub fn point_errors(&self, params: &[f64]) -> Vec<f64> {
        self.point_errors_at(params, &[0.0; 3])
    }

    /// `e_j` at every test point of the robot's inputs `mean + d` ([`crate::kinematics::InputSpace::robot`]
    /// offsets: the parameters, then the tool) with the joint errors' draw `term`, straight
    /// from [`position`] in f64: the geometric inputs moved by the draw's `A δβ`, each joint
    /// turned further by its offset at each point. Returns their maximum `w`. The exact point
    /// form of the base frame (the tail analysis evaluates a model with joint errors by it);
    /// without joint errors only `d` acts.
    pub fn errors_with_joint_errors(&self, d: &[f64], term: &TermDraw, e: &mut [f64]) -> f64 {
        let space = self.model.layout().robot();
        let mut moved = d.to_vec();
        if let Some(t) = &self.joint_errors {
            t.shift_each(term, |block, k, v| {
                if let Some(i) = space.index(block, k) {
                    moved[i] += v;
                }
            });
        }
        let at = |b: Block| space.range(b).map_or(0, |r| r.start);
        let m = &self.model;
        let params: Vec<f64> = (m.params.iter().enumerate())
            .map(|(i, p)| p + moved[at(Block::Joints) + i])
            .collect();
        let tool: [f64; 3] = std::array::from_fn(|i| m.tool[i] + moved[at(Block::Tool) + i]);
        let mut w = 0.0f64;
        for (j, ((q, r), ej)) in (self.chain_points.iter().zip(&self.reference))
            .zip(e.iter_mut())
            .enumerate()
        {
            let q = match &self.joint_errors {
                Some(t) => {
                    let o = t.offsets(term, j);
                    q.iter().zip(o.iter()).map(|(a, b)| a + b).collect()
                }
                None => *q,
            };
            let p = position(&params, &tool, &q);
            *ej = ((p[0] - r[0]).powi(2) + (p[1] - r[1]).powi(2) + (p[2] - r[2]).powi(2)).sqrt();
            w = w.max(*ej);
        }
        w
    }

    /// Fixes the backlash sides known at the test points (`sides[j][i]`: +1, −1, or 0 for
    /// drawn; [`JointErrorDraws::set_known_sides`]). A problem predicting for unknown sides
    /// ([`Self::sided`]) turns to the model as given when `sides` give every side of some
    /// point: the points whose sides are not all given stand at the centre of the gaps and draw
    /// the term for unknown sides there ([`JointErrorDraws::set_centre`], counted in
    /// [`Self::sides_unused`]); when no point's are all given it stays as it is.
    ///
    /// # Errors
    ///
    /// [`ProblemError::Model`] naming `joint_errors.backlash_deg` when the model draws no
    /// backlash, [`ProblemError::Sides`] for a count or a value out of place.
    pub fn set_known_sides(
        &mut self,
        sides: &[crate::kinematics::Joints],
    ) -> Result<(), ProblemError> {
        if let Some(sided) = self.sided.take() {
            // The sides checked as the model as given draws them; the problem is left as it
            // was unless every point's are given.
            let checked =
                JointErrorDraws::new(&sided, &self.points, self.seed).and_then(|mut t| {
                    match t.as_mut().filter(|t| t.backlash) {
                        Some(d) => d
                            .set_known_sides(sides)
                            .map(|_| t)
                            .map_err(ProblemError::Sides),
                        None => Ok(t),
                    }
                });
            let t = match checked {
                Ok(t) => t,
                Err(e) => {
                    self.sided = Some(sided);
                    return Err(e);
                }
            };
            let complete: Vec<bool> = sides.iter().map(|s| sided.sides_complete(s)).collect();
            // No point with every side given (or nothing drawn): the centre stays everywhere.
            let mut t = match t {
                Some(t) if complete.iter().any(|&c| c) => t,
                t => {
                    self.sides_unused = t.as_ref().map(|t| t.sides_known());
                    self.sided = Some(sided);
                    return Ok(());
                }
            };
            // The points whose sides are not all given stand at the centre of the gaps and
            // draw the term for unknown sides; the sides given there are not used.
            if !complete.iter().all(|&c| c) {
                let unused = t.sides_known_where(|j| !complete[j]);
                t.set_centre(complete.iter().map(|c| !c).collect())
                    .map_err(ProblemError::Sides)?;
                self.sides_unused = Some(unused);
            } else {
                self.sides_unused = None;
            }
            self.joint_errors = Some(t);
            self.model = *sided;
            self.discrepancy = (self.discrepancy_use).and_then(|u| {
                discrepancy_draws(&self.model, &self.points, u, self.seed, self.centre())
            });
            return Ok(());
        }
        let Some(t) = self.joint_errors.as_mut().filter(|t| t.backlash) else {
            return Err(ProblemError::Model {
                model: self.model.name.clone(),
                field: "joint_errors.backlash_deg".into(),
                message: "is not there: the test points' approach sides change nothing without a backlash".into(),
            });
        };
        t.set_known_sides(sides).map_err(ProblemError::Sides)
    }

    /// [`Self::set_known_sides`] for a prediction that knows them: the calibrated reference
    /// moved too, to where the model puts the target with each known side's turn
    /// ([`RobotModel::side_turns`]), so that a draw's error is its distance from that
    /// prediction (a validation against poses whose approach sides were recorded; docs/METHOD.md
    /// §19.5). For a problem built with [`Reference::Calibrated`].
    ///
    /// # Errors
    ///
    /// As [`Self::set_known_sides`].
    pub fn predict_known_sides(&mut self, sides: &[Joints]) -> Result<(), ProblemError> {
        self.set_known_sides(sides)?;
        let m = &self.model;
        // Points at the centre of the gaps are predicted there, whatever sides they gave.
        let centre = self.joint_errors.as_ref().map_or(&[][..], |t| &t.centre);
        for (j, ((r, q), s)) in (self.reference.iter_mut().zip(&self.points).zip(sides)).enumerate()
        {
            let mut chain = m.calibrated_chain_angles(q);
            if let Some(t) = m
                .side_turns(s)
                .filter(|_| !centre.get(j).copied().unwrap_or(false))
            {
                for (a, d) in chain.iter_mut().zip(t.iter()) {
                    *a += d;
                }
            }
            *r = position(&m.params, &m.tool, &chain);
        }
        Ok(())
    }

    /// [`Self::point_errors`] with the tool point moved by `tool_offset` (mm, flange frame).
    pub fn point_errors_at(&self, params: &[f64], tool_offset: &[f64; 3]) -> Vec<f64> {
        let tool: [f64; 3] = std::array::from_fn(|k| self.model.tool[k] + tool_offset[k]);
        self.chain_points
            .iter()
            .zip(&self.reference)
            .map(|(q, r)| {
                let p = position(params, &tool, q);
                ((p[0] - r[0]).powi(2) + (p[1] - r[1]).powi(2) + (p[2] - r[2]).powi(2)).sqrt()
            })
            .collect()
    }
}
