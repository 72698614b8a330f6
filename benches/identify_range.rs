//! Held-out positioning error of the identified model against the joint range swept, for both
//! circle fits (paper §3 "joint range" factor).
//!
//! For each range fraction (10, 25, 50, 75, 100 % of the TX60 measuring ranges, 2° step, σ = 10 µm
//! per coordinate tracker noise) and each fit, `ROBOTS` simulated robots (perturbed TX60, tool
//! (30, −20, 80) mm) are identified and each identified model is evaluated at 100 random held-out
//! configurations within the joint limits against the true robot. Printed: mean and worst (over
//! robots) of the held-out RMS error, and the nominal model's RMS for reference. Also the time per
//! identification. Rows: the plain circle-point fits (point cloud, commanded angles), each with
//! the nominal-geometry prior (`NominalPrior::default()`: 0.1°, 1 mm), and the commanded-angle fit
//! followed by the whole-chain refinement without and with the prior (the last row is
//! `IdentifyOptions::default()`). Run with `cargo bench --bench identify_range`.

use gpu_amcs::identify::{accuracy, identify, CircleFitMethod, IdentifyOptions, NominalPrior};
use gpu_amcs::kinematics::tx60;
use gpu_amcs::simulate::{
    measure_positions, perturbed_model, random_configurations, simulate_sweeps, ParameterErrors,
    SweepPlan,
};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::time::Instant;

const ROBOTS: u64 = 20;
const SIGMA_MM: f64 = 0.010;
const TOOL: [f64; 3] = [30.0, -20.0, 80.0];

fn main() {
    let nominal = tx60();
    let mut nominal_rms = Vec::new();
    println!(
        "held-out RMS error (mm) over 100 random configurations, {ROBOTS} simulated robots, σ = {} µm, 2° step",
        SIGMA_MM * 1e3
    );
    println!(
        "{:>7} {:>18} {:>6} {:>7} {:>10} {:>10} {:>10} {:>12}",
        "range", "fit", "prior", "refine", "mean RMS", "worst RMS", "mean max", "ms / ident"
    );
    for fraction in [0.10, 0.25, 0.50, 0.75, 1.00] {
        for (method, prior, refine) in [
            (CircleFitMethod::PointCloud, None, false),
            (CircleFitMethod::CommandedAngles, None, false),
            (
                CircleFitMethod::PointCloud,
                Some(NominalPrior::default()),
                false,
            ),
            (
                CircleFitMethod::CommandedAngles,
                Some(NominalPrior::default()),
                false,
            ),
            (CircleFitMethod::CommandedAngles, None, true),
            (
                CircleFitMethod::CommandedAngles,
                Some(NominalPrior::default()),
                true,
            ),
        ] {
            let plan = SweepPlan {
                range_fraction: fraction,
                ..SweepPlan::default()
            };
            let (mut sum, mut worst, mut sum_max, mut secs) = (0.0, 0.0f64, 0.0, 0.0);
            for seed in 0..ROBOTS {
                let mut rng = ChaCha8Rng::seed_from_u64(1000 + seed);
                let truth = perturbed_model(&nominal, &ParameterErrors::default(), TOOL, &mut rng);
                let held_out = measure_positions(
                    &truth,
                    &random_configurations(&nominal.limits_deg, 100, &mut rng),
                    0.0,
                    &mut rng,
                );
                if fraction == 0.10 && method == CircleFitMethod::PointCloud && prior.is_none() {
                    // The nominal geometry with the true tool point: what no calibration gives.
                    let mut n = nominal.clone();
                    n.tool = TOOL;
                    nominal_rms.push(accuracy(&n, &held_out).rms_mm);
                }
                let data = simulate_sweeps(&truth, &plan, SIGMA_MM, 1, 2000 + seed);
                let t = Instant::now();
                let id = identify(
                    &data,
                    &nominal,
                    &IdentifyOptions {
                        method,
                        nominal_prior: prior,
                        refine,
                    },
                );
                secs += t.elapsed().as_secs_f64();
                match id {
                    Ok(id) => {
                        let a = accuracy(&id[0].model, &held_out);
                        sum += a.rms_mm;
                        sum_max += a.max_mm;
                        worst = worst.max(a.rms_mm);
                    }
                    Err(e) => {
                        println!("{fraction}: {e}");
                        worst = f64::INFINITY;
                    }
                }
            }
            let n = ROBOTS as f64;
            println!(
                "{:>6.0}% {:>18} {:>6} {:>7} {:>10.4} {:>10.4} {:>10.4} {:>12.2}",
                fraction * 100.0,
                method.name(),
                if prior.is_some() { "yes" } else { "no" },
                if refine { "yes" } else { "no" },
                sum / n,
                worst,
                sum_max / n,
                secs / n * 1e3
            );
        }
    }
    let n = nominal_rms.len() as f64;
    println!(
        "nominal model: mean RMS {:.4} mm (min {:.4}, max {:.4})",
        nominal_rms.iter().sum::<f64>() / n,
        nominal_rms.iter().cloned().fold(f64::INFINITY, f64::min),
        nominal_rms.iter().cloned().fold(0.0, f64::max)
    );
}
