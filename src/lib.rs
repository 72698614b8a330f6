//! gpu-amcs: positioning-accuracy reliability of calibrated robots by adaptive Monte Carlo.
pub mod identify;
pub mod kinematics;
pub mod simulate;
