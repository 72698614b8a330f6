//! The built-in Staubli TX60 model (`gpu-amcs`'s default robot). The other presets, converted
//! from published tables by the importer, are in `crate::presets`.
//!
//! The Staubli TX60 table of docs/METHOD.md §1: it reproduces the public ROS-Industrial TX60 chain
//! (joint origins 375, 290, 20 lateral, 310, 70 mm), so at q = 0 the flange centre is at
//! (0, 20, 1045) mm.
//!
//! Its default uncertainty ([`TX60_SIGMA`], independent σ per parameter) is the one the
//! calibration simulator produces at the paper's baseline settings: the virtual TX60 of
//! `simulate::Experiment::tx60(2025)` (nominal geometry perturbed by 0.3 mm / 0.03° class errors
//! from seed 2025, tool (30, −20, 80) mm, Leica AT960 tracker with MPE = 2σ at (2000, −600, 400) mm,
//! TX60 repeatability ±0.02 mm, speed/backlash models of `simulate::factors`), calibrated
//! `simulate::calibrate` with `Factors::default()` — 20 runs, 50 % of each measuring range,
//! 2° steps, 25 % speed, negative→positive — and calibration seed 1, σ = the run-to-run standard
//! deviation of the identified parameters. The numbers are baked in (no calibration at start-up);
//! the test `baked_tx60_sigma_matches_the_simulator` in `tests/it/study.rs` re-runs that calibration
//! and fails if the simulator no longer produces them. J6's θ, d, a, α are zero: the
//! identification keeps them nominal and lets the tool point absorb them (`kinematics::mdh`), so the
//! parameter model carries no spread for them; β is fixed except on J2 (J2 ∥ J3).

use super::{param_index, FixedParam, ParamKind, Params, RobotModel, Uncertainty};

/// The default σ of every parameter, `[θ (deg), d (mm), a (mm), α (deg), β (deg)]` per joint:
/// the baseline calibration of the simulator (see the module docs), 4 significant digits.
pub const TX60_SIGMA: [[f64; 5]; 6] = [
    [3.216e-3, 5.056e-3, 7.175e-3, 1.995e-3, 0.0],
    [1.664e-3, 0.0, 8.480e-3, 4.335e-3, 2.208e-3],
    [2.176e-3, 1.183e-2, 6.683e-3, 3.526e-3, 0.0],
    [1.036e-2, 8.317e-3, 6.864e-3, 4.796e-3, 0.0],
    [3.619e-3, 1.205e-2, 1.038e-2, 1.197e-2, 0.0],
    [0.0, 0.0, 0.0, 0.0, 0.0],
];

/// The Staubli TX60 with its default uncertainty; tool point at the flange centre.
pub fn tx60() -> RobotModel {
    // θ, d, a, α, β (deg, mm)
    let table: [[f64; 5]; 6] = [
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
    let mut params = Params::filled(30, 0.0);
    let mut sigma = Params::filled(30, 0.0);
    for j in 0..6 {
        for (k, kind) in ParamKind::ALL.iter().enumerate() {
            let i = param_index(j, *kind);
            params[i] = table[j][k] * kind.to_internal();
            sigma[i] = TX60_SIGMA[j][k] * kind.to_internal();
        }
    }
    RobotModel {
        joint_errors: None,
        links: None,
        discrepancy: None,
        name: "Staubli TX60".into(),
        params,
        fixed: fixed.into(),
        limits_deg: [
            (-180.0, 180.0),
            (-127.5, 127.5),
            (-142.5, 142.5),
            (-270.0, 270.0),
            (-122.5, 132.5),
            (-270.0, 270.0),
        ]
        .into(),
        tool: [0.0, 0.0, 0.0],
        tool_sigma: [0.0; 3],
        base: None,
        uncertainty: Uncertainty::Independent(sigma),
    }
}
