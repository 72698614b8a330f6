//! A simulated robot with true geometric errors, and its measurement by a tracker.
//!
//! [`perturbed_model`] perturbs every free parameter of a nominal model (θ, a, α always; d where
//! β is fixed, β where d is fixed) by a random sign times a magnitude uniform in
//! [½, 1] × the given size, so every free parameter is off by a known order — the "true" robot
//! the identification must recover, in the same parameterisation as the nominal model.

use super::add_tracker_noise;
use crate::identify::Measurement;
use crate::kinematics::{param_index, position, Joints, ParamKind, RobotModel};
use rand::Rng;

/// Sizes of the parameter errors of a simulated robot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParameterErrors {
    /// Size of a length error, mm.
    pub length_mm: f64,
    /// Size of an angle error, degrees.
    pub angle_deg: f64,
}

impl Default for ParameterErrors {
    /// Tenths of a mm and hundredths of a degree: 0.3 mm, 0.03°.
    fn default() -> Self {
        ParameterErrors {
            length_mm: 0.3,
            angle_deg: 0.03,
        }
    }
}

/// The nominal model with every free parameter perturbed (see the module docs) and the given tool
/// point; the uncertainty is copied from the nominal.
pub fn perturbed_model(
    nominal: &RobotModel,
    errors: &ParameterErrors,
    tool: [f64; 3],
    rng: &mut impl Rng,
) -> RobotModel {
    let mut m = nominal.clone();
    m.name = format!("{} (simulated true robot)", nominal.name);
    m.tool = tool;
    for j in 0..nominal.joints() {
        for kind in ParamKind::ALL {
            if nominal.fixed[j].kind() == kind {
                continue;
            }
            let size = if kind.is_angle() {
                errors.angle_deg.to_radians()
            } else {
                errors.length_mm
            };
            let sign = if rng.random::<bool>() { 1.0 } else { -1.0 };
            m.params[param_index(j, kind)] += sign * size * rng.random_range(0.5..=1.0);
        }
    }
    m
}

/// `n` configurations uniform within `limits_deg` (one `(min, max)` per joint), degrees.
pub fn random_configurations(
    limits_deg: &[(f64, f64)],
    n: usize,
    rng: &mut impl Rng,
) -> Vec<Joints> {
    (0..n)
        .map(|_| {
            Joints::from_fn(limits_deg.len(), |j| {
                let (lo, hi) = limits_deg[j];
                lo + (hi - lo) * rng.random::<f64>()
            })
        })
        .collect()
}

/// Measures `truth` at the configurations (degrees, one angle per joint of `truth`) with Gaussian
/// noise `sigma_mm` per coordinate.
pub fn measure_positions(
    truth: &RobotModel,
    configs: &[Joints],
    sigma_mm: f64,
    rng: &mut impl Rng,
) -> Vec<Measurement> {
    configs
        .iter()
        .enumerate()
        .map(|(k, q)| Measurement {
            payload_kg: None,
            q_deg: *q,
            position_mm: add_tracker_noise(
                position(&truth.params, &truth.tool, &q.map(f64::to_radians)),
                sigma_mm,
                rng,
            ),
            line: k as u64 + 2,
            target: None,
            on_base: false,
            sides: None,
        })
        .collect()
}
