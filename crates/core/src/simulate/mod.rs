//! Simulation of a robot with true geometric errors measured by a laser tracker.
//!
//! [`robot`] makes a "true" robot (the nominal model with perturbed parameters, in the same MDH
//! parameterisation) and measures it at given configurations; [`sweep`] generates the
//! circle-point sweeps of the identification ([`SweepPlan`]) with Gaussian tracker noise. All
//! randomness comes from a seeded `ChaCha8Rng`, so every simulation is reproducible. The output is
//! the same [`crate::identify::SweepData`] the CSV reader returns, and it is written by the same
//! writer ([`write_sweeps`]), so real and simulated data go through one code path.
//!
//! The calibration-experiment simulator of the factor study builds on these: [`tracker`] (the
//! AT960 noise model, radial and transverse), [`factors`] (the paper's five factors and the
//! physical models behind them: repeatability, range, step, speed, start position) and
//! [`calibrate()`] (repeated simulate → identify runs → mean, σ and covariance).
//!
//! A true robot may also carry errors no geometric model holds ([`nongeometric`]: joint
//! compliance under gravity and payload, gear harmonics; issue 33), in the pose data
//! ([`simulate_poses_of`]) and in the sweeps and checks of an [`Experiment`]
//! ([`Experiment::nongeometric`]).

pub mod calibrate;
pub mod factors;
pub mod full_model;
mod full_report;
#[cfg(test)]
mod joint_counts;
pub mod nongeometric;
pub mod poses;
pub mod robot;
pub mod sweep;
pub mod tracker;

pub use crate::identify::{write_measurements, write_sweeps};
pub use calibrate::{
    accuracy_check, calibrate, calibrate_with_progress, run_seed, Calibration, Experiment,
    DESIGN_TOOL_MM,
};
pub use factors::{Factors, RobotErrorModel, SimulateError, SimulateSetting, SweepDirection};
pub use full_model::{
    accuracy_full, calibrate_full, mean_joint_errors, render_full_accuracy,
    render_full_calibration, FullAccuracy, FullCalibration, FullRun, RunAccuracy, RunData,
};
pub use nongeometric::{
    true_position, NonGeometric, NonGeometricError, NonGeometricSetting, NonGeometricSizes,
};
pub use poses::{
    add_other_targets, random_placement, random_poses, simulate_poses, simulate_poses_at,
    simulate_poses_of, simulate_poses_sided, tracker_in_base_frame, TrackerNoise,
};
pub use robot::{measure_positions, perturbed_model, random_configurations, ParameterErrors};
pub use sweep::{
    simulate_sweeps, simulate_sweeps_with, SweepPlan, TX60_HOME_DEG, TX60_MEASURING_RANGES_DEG,
};
pub use tracker::TrackerModel;

pub use crate::sampling::standard_normal;

use rand::Rng;

/// A measured position: the true one plus independent Gaussian noise of `sigma_mm` per
/// coordinate (an isotropic tracker noise model).
pub fn add_tracker_noise(p: [f64; 3], sigma_mm: f64, rng: &mut impl Rng) -> [f64; 3] {
    if sigma_mm == 0.0 {
        return p;
    }
    p.map(|v| v + sigma_mm * standard_normal(rng))
}
