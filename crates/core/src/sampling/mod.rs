//! Reproducible random draws of the robot parameters.
//!
//! Draw `k` of a run is a pure function of `(seed, k)`: a counter-based generator
//! (Philox4x32-10, Salmon et al., SC'11, "Parallel random numbers: as easy as 1, 2, 3") keyed by
//! the seed with the draw index as counter, so the same draw comes out whichever thread, batch or
//! backend (CPU or GPU shader) computes it. Normal variates come from the Box–Muller transform;
//! correlated draws from the Cholesky factor of the covariance (GUM S1 §6.4.8.3).

mod distribution;
mod gauss;
mod matvec;
mod normal;
mod philox;

pub use distribution::{
    normals_lanes, pick_freeze_normals, ParamSampler, SamplerError, ALL_NORMALS, MAX_NORMALS,
    PARAM_STREAM,
};
pub use gauss::standard_normal;
pub(crate) use matvec::rows_times_lanes;
pub use normal::{box_muller, normals_block, uniform_open};
pub(crate) use philox::philox4x32_10_lanes;
pub use philox::{philox4x32_10, Philox};
