//! Built-in robot models.
//!
//! The Staubli TX60 table of METHOD.md §1: it reproduces the public ROS-Industrial TX60 chain
//! (joint origins 375, 290, 20 lateral, 310, 70 mm), so at q = 0 the flange centre is at
//! (0, 20, 1045) mm. Its default uncertainty is a plausible laser-tracker calibration:
//! σ = 0.02 mm on every free length and σ = 0.005° on every free angle, the order of the AT960's
//! ±(15 µm + 6 µm/m) MPE propagated through a circle-point fit (README, "Default uncertainty").

use super::model::{param_index, FixedParam, ParamKind, RobotModel, Uncertainty, JOINTS, N_PARAMS};

/// Names of the built-in presets.
pub const PRESETS: &[&str] = &["tx60"];

/// σ of a free length in the default uncertainty, mm.
const SIGMA_LENGTH_MM: f64 = 0.02;
/// σ of a free angle in the default uncertainty, degrees.
const SIGMA_ANGLE_DEG: f64 = 0.005;

/// The Staubli TX60 with its default uncertainty; tool point at the flange centre.
pub fn tx60() -> RobotModel {
    // θ, d, a, α, β (deg, mm)
    let table: [[f64; 5]; JOINTS] = [
        [0.0, 375.0, 0.0, -90.0, 0.0],
        [-90.0, 0.0, 290.0, 0.0, 0.0],
        [90.0, 20.0, 0.0, 90.0, 0.0],
        [0.0, 310.0, 0.0, -90.0, 0.0],
        [0.0, 0.0, 0.0, 90.0, 0.0],
        [0.0, 70.0, 0.0, 0.0, 0.0],
    ];
    let fixed = [
        FixedParam::Beta,
        FixedParam::D, // J2 ∥ J3
        FixedParam::Beta,
        FixedParam::Beta,
        FixedParam::Beta,
        FixedParam::Beta,
    ];
    let mut params = [0.0; N_PARAMS];
    let mut sigma = [0.0; N_PARAMS];
    for j in 0..JOINTS {
        for (k, kind) in ParamKind::ALL.iter().enumerate() {
            let i = param_index(j, *kind);
            params[i] = table[j][k] * kind.to_internal();
            let is_fixed = matches!(
                (fixed[j], kind),
                (FixedParam::D, ParamKind::D) | (FixedParam::Beta, ParamKind::Beta)
            );
            sigma[i] = if is_fixed {
                0.0
            } else if kind.is_angle() {
                SIGMA_ANGLE_DEG.to_radians()
            } else {
                SIGMA_LENGTH_MM
            };
        }
    }
    RobotModel {
        name: "Staubli TX60".into(),
        params,
        fixed,
        limits_deg: [
            (-180.0, 180.0),
            (-127.5, 127.5),
            (-142.5, 142.5),
            (-270.0, 270.0),
            (-122.5, 132.5),
            (-270.0, 270.0),
        ],
        tool: [0.0, 0.0, 0.0],
        uncertainty: Uncertainty::Independent(sigma),
    }
}

/// A preset by name.
pub fn preset(name: &str) -> Result<RobotModel, super::ModelError> {
    match name.to_ascii_lowercase().as_str() {
        "tx60" => Ok(tx60()),
        _ => Err(super::ModelError::UnknownPreset(name.to_string())),
    }
}
