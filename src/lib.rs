//! gpu-amcs: positioning-accuracy reliability of calibrated robots by adaptive Monte Carlo.
pub mod kinematics;
