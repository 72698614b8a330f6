//! gpu-amcs: positioning-accuracy reliability of calibrated robots by adaptive Monte Carlo.
pub mod engine;
pub mod kinematics;
pub mod mc;
pub mod points;
pub mod report;
pub mod sampling;
