//! The shape checks of the whole-chain identification's data, before any fit.

use super::{ChainState, MeasuredPoint};
use crate::identify::IdentifyError;
use crate::kinematics::RobotModel;

/// Checks the shapes of the data: some points, each with one angle per joint of `nominal`, and
/// a `start` with `nominal`'s number of parameters.
pub(super) fn check_points(
    points: &[MeasuredPoint],
    nominal: &RobotModel,
    start: Option<ChainState>,
) -> Result<(), IdentifyError> {
    if points.is_empty() {
        return Err(IdentifyError::NoData("no measured points".into()));
    }
    let lay = nominal.layout();
    if let Some(p) = points.iter().find(|p| p.q_deg.len() != lay.joints()) {
        return Err(IdentifyError::JointCount(format!(
            "line {}: {} joint angles, the nominal model {} has {} joints",
            p.line,
            p.q_deg.len(),
            nominal.name,
            lay.joints()
        )));
    }
    if let Some(s) = start.filter(|s| s.params.len() != lay.n_params()) {
        return Err(IdentifyError::JointCount(format!(
            "the start has {} parameters, the nominal model {} has {}",
            s.params.len(),
            nominal.name,
            lay.n_params()
        )));
    }
    Ok(())
}

/// Refuses data with too few distinct poses for the `free` inputs: each pose gives three
/// equations, and at least one more than the inputs is needed (poses measured more than once
/// count once).
///
/// # Errors
///
/// [`IdentifyError::NoData`] saying how many poses there are and how many are needed.
pub(super) fn check_pose_count(points: &[MeasuredPoint], free: usize) -> Result<(), IdentifyError> {
    let mut seen = std::collections::HashSet::new();
    for p in points {
        // + 0.0 makes −0 and 0 the same angle
        seen.insert(
            p.q_deg
                .iter()
                .map(|v| (v + 0.0).to_bits())
                .collect::<Vec<u64>>(),
        );
    }
    let (n, need) = (seen.len(), free / 3 + 1);
    if n < need {
        return Err(IdentifyError::NoData(format!(
            "{n} distinct pose(s) (rows with the same joint angles are one pose) give {} equations for the {free} quantities the fit identifies: at least {need} distinct poses are needed, and 30–60 spread over the joint ranges are usual",
            3 * n
        )));
    }
    Ok(())
}
