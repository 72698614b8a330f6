//! The identified model of a whole-chain fit: the chain state and its covariance as a
//! [`RobotModel`] with the nominal model's structure and limits.

use super::{ChainResult, Placement};
use crate::identify::chain_fit::ChainState;
use crate::kinematics::{Block, InputSpace, RobotModel, Uncertainty};

/// The identified model of a chain result: `nominal`'s structure and limits with the identified
/// parameters, target and (for [`Placement::Identify`]) placement, and the covariance as the
/// model file's `[covariance]`: `(5n + 9)²` with the placement (the last six rows x, y, z, roll,
/// pitch, yaw; 39 × 39, rows 34–39, for six joints), `(5n + 3)²` (33 × 33) without; and the
/// fit's discrepancy term when it found a lack of fit.
pub fn chain_model(nominal: &RobotModel, result: &ChainResult, name: String) -> RobotModel {
    let mut model = state_model(
        nominal,
        &result.state,
        &result.covariance,
        result.report.frame,
        name,
    );
    model.discrepancy = result.discrepancy.clone();
    model.joint_errors = result.joint_errors.clone();
    model
}

/// The fit inputs a model of `frame` keeps: all of them when the placement was identified, else
/// the robot's (the placement was known).
pub(super) fn reported_space(fit: InputSpace, frame: Placement) -> InputSpace {
    match frame {
        Placement::Identify => fit,
        Placement::Known => fit.without(Block::Placement),
    }
}

/// The model of chain state `s` with `covariance` (row-major over [`ChainState::space`], internal units,
/// zero rows for inputs held fixed) in `frame`: what [`chain_model`] makes of an identification,
/// and what a calibration plan predicts before any data exist. `s` has `nominal`'s joint count.
pub fn state_model(
    nominal: &RobotModel,
    s: &ChainState,
    covariance: &[f64],
    frame: Placement,
    name: String,
) -> RobotModel {
    let fit = s.space();
    debug_assert_eq!(s.layout(), nominal.layout());
    let kept = reported_space(fit, frame);
    let cov = crate::kinematics::Covariance::new(fit, covariance.to_vec())
        .expect("a covariance of the fit inputs")
        .restricted(kept);
    let mut model = RobotModel {
        joint_errors: None,
        links: nominal.links,
        discrepancy: None,
        name,
        params: s.params,
        fixed: nominal.fixed,
        limits_deg: nominal.limits_deg,
        tool: s.tool,
        // Set from the covariance's tool block below.
        tool_sigma: [0.0; 3],
        uncertainty: Uncertainty::Independent(nominal.param_sigmas()),
        base: match frame {
            Placement::Identify => Some(crate::kinematics::BaseTransform {
                xyz: [s.base[0], s.base[1], s.base[2]],
                rpy: [s.base[3], s.base[4], s.base[5]],
            }),
            Placement::Known => nominal.base,
        },
    };
    model.set_covariance(cov);
    model
}
