//! Where a [`RobotModel`] puts the target: the angles its chain stands at (commanded plus the
//! joint errors' mean deflections, at the task or the calibration payload), the position they
//! give, with the compensation and the placement when asked, and the turns of recorded backlash
//! sides (docs/METHOD.md §19).

use super::RobotModel;
use crate::kinematics::Joints;

impl RobotModel {
    /// Tool-point position (mm) at joint angles `q` (radians) in the description's frame: the
    /// MDH chain's [`crate::kinematics::position`] at the angles the joints stand at
    /// ([`RobotModel::chain_angles`]: `q` itself for a geometric model), then the
    /// [`RobotModel::base`] transform. No compensation.
    pub fn world_position(&self, q: &[f64]) -> [f64; 3] {
        self.predicted_position(q, None, false, true)
    }

    /// Tool-point position (mm) at `q` (radians) in the robot base frame with the compensation's
    /// correction added (the MDH chain's position when the model has none): where the
    /// calibrated robot is predicted to be (docs/METHOD.md §18.1).
    pub fn compensated_position(&self, q: &[f64]) -> [f64; 3] {
        self.predicted_position(q, None, true, false)
    }

    /// [`RobotModel::compensated_position`] in the description's frame (the
    /// [`RobotModel::base`] transform applied), as [`RobotModel::world_position`].
    pub fn compensated_world_position(&self, q: &[f64]) -> [f64; 3] {
        self.predicted_position(q, None, true, true)
    }

    /// Where the model puts the target when commanded to `q` (rad): its chain angles
    /// ([`Self::chain_angles`]) each turned further by `turns` (rad, per joint; e.g. the
    /// backlash's [`Self::side_turns`]), plus the compensation's correction at `q` when
    /// `compensate` (and the model has one), in the description's frame (the [`Self::base`]
    /// transform applied) when `world`. [`Self::world_position`], [`Self::compensated_position`]
    /// and [`Self::compensated_world_position`] are this without turns.
    pub fn predicted_position(
        &self,
        q: &[f64],
        turns: Option<&Joints>,
        compensate: bool,
        world: bool,
    ) -> [f64; 3] {
        let mut chain = self.chain_angles(q);
        if let Some(t) = turns {
            for (a, d) in chain.iter_mut().zip(t.iter()) {
                *a += d;
            }
        }
        let mut p = crate::kinematics::position(&self.params, &self.tool, &chain);
        if let Some(d) = self.discrepancy.as_ref().filter(|_| compensate) {
            let q_deg: Vec<f64> = q.iter().map(|v| v.to_degrees()).collect();
            let c = d.correction_mm(&q_deg);
            for k in 0..3 {
                p[k] += c[k];
            }
        }
        match (&self.base, world) {
            (Some(b), true) => b.apply(p),
            _ => p,
        }
    }

    /// The turns (rad) of a model with backlash whose joints arrived from `sides` (per joint 1:
    /// moving positive, −1, 0: not known): `s_j h_j`, with `h_j` the turn the analyses draw
    /// ([`crate::kinematics::Backlash::half_spread`]; docs/METHOD.md §19.5), 0 where the side
    /// is not known. `None` for a model without backlash or sides that turn nothing.
    pub fn side_turns(&self, sides: &[f64]) -> Option<Joints> {
        let b = self.joint_errors.as_ref()?.backlash.as_ref()?;
        if !b.acts() || sides.len() != self.joints() {
            return None;
        }
        let t = Joints::from_fn(sides.len(), |j| sides[j] * b.half_spread(j));
        t.iter().any(|&v| v != 0.0).then_some(t)
    }

    /// Whether `sides` (per joint 1, −1, or 0: not known) give the side of every joint with a
    /// backlash gap; true for a model without backlash.
    pub fn sides_complete(&self, sides: &[f64]) -> bool {
        match self.joint_errors.as_ref().and_then(|e| e.backlash.as_ref()) {
            None => true,
            Some(b) => {
                sides.len() == self.joints()
                    && (0..sides.len()).all(|j| b.half_spread(j) == 0.0 || sides[j] != 0.0)
            }
        }
    }

    /// The term of [`Self::with_sides_unknown`]: the backlash's term for unknown sides when some
    /// joint has a gap; `None` otherwise.
    pub fn sides_unknown_term(&self) -> Option<&crate::discrepancy::Discrepancy> {
        let b = self.joint_errors.as_ref()?.backlash.as_ref()?;
        b.sides_unknown.as_ref().filter(|_| b.acts())
    }

    /// The model as it predicts where the backlash's sides are not known, when it has a term
    /// for that ([`crate::kinematics::Backlash::sides_unknown`]): each joint at the centre of
    /// its gap (the backlash left out, nothing drawn for it) and that term as its discrepancy,
    /// which holds the hysteresis the calibration data showed (docs/METHOD.md §19.5). `None`
    /// for a model without such a term or whose gaps are all zero.
    pub fn with_sides_unknown(&self) -> Option<RobotModel> {
        let term = self.sides_unknown_term()?.clone();
        let mut m = self.clone();
        m.discrepancy = Some(term);
        if let Some(e) = m.joint_errors.as_mut() {
            e.backlash = None;
        }
        Some(m)
    }

    /// The joint angles (rad) the model's chain stands at when commanded to `q` (rad): `q` plus
    /// the mean deflections of its [`crate::kinematics::JointErrors`] (compliance at the task
    /// payload, gear harmonics), `q` itself for a geometric model.
    pub fn chain_angles(&self, q: &[f64]) -> Joints {
        match &self.joint_errors {
            Some(e) => e.actual_angles(&self.params, q),
            None => q.iter().copied().collect(),
        }
    }

    /// The model predicting with a known payload of `mass_kg` (its centre of mass kept, no
    /// spread): the robot at that payload and the calibrated prediction at it too, as a
    /// controller that is told the payload predicts (validation against poses measured with
    /// it). `None` for a model without joint errors or already at that payload (the model
    /// itself serves).
    pub fn knowing_payload(&self, mass_kg: f64) -> Option<RobotModel> {
        let e = self.joint_errors.as_ref()?;
        if e.payload.mass_kg == mass_kg
            && e.calibration_payload.mass_kg == mass_kg
            && e.payload.sigma_kg == 0.0
        {
            return None;
        }
        let mut m = self.clone();
        if let Some(e) = m.joint_errors.as_mut() {
            e.payload.mass_kg = mass_kg;
            e.payload.sigma_kg = 0.0;
            e.calibration_payload.mass_kg = mass_kg;
            e.calibration_payload.com_mm = e.payload.com_mm;
        }
        Some(m)
    }

    /// The joint angles (rad) at `q` (rad) of the model as calibrated: with the mean deflections
    /// at the payload during calibration (what a controller given this model predicts without
    /// knowing the task payload); `q` itself for a geometric model.
    pub fn calibrated_chain_angles(&self, q: &[f64]) -> Joints {
        match &self.joint_errors {
            Some(e) => e.angles_with(&self.params, q, &e.calibration_payload),
            None => q.iter().copied().collect(),
        }
    }
}
