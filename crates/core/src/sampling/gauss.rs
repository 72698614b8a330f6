//! Standard normals from any seeded `rand` generator: the noise of the simulators
//! (`crate::simulate`) and of tests, which need no counter-based reproducibility across
//! backends (the parameter draws do: [`super::Philox`]).

use rand::Rng;

/// One standard normal draw (Box–Muller).
pub fn standard_normal(rng: &mut impl Rng) -> f64 {
    let u1: f64 = 1.0 - rng.random::<f64>(); // (0, 1]
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}
