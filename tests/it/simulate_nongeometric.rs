//! Simulated robots with errors beyond geometry (issue 33): the library's simulator
//! (`simulate::nongeometric`) against the independent reference of
//! `benches/support/nongeometric.rs` on the same parameters, the geometric simulator unchanged
//! at size 0 (library and CLI), the flags' checks, and the effect the issue is about: a
//! geometric calibration of a robot with compliance and harmonics leaves a held-out error far
//! above a geometric robot's.

// honesty.rs holds its own copy, private to it.
#[path = "../../benches/support/nongeometric.rs"]
#[allow(dead_code, clippy::duplicate_mod)]
mod reference;

use crate::common::{arg, fails_naming, run, stderr, tmpdir};
use gpu_amcs::identify::chain::TermSelection;
use gpu_amcs::identify::{JointErrorFit, PoseData};
use gpu_amcs::kinematics::{tx60, Capped, Joints, RobotModel};
use gpu_amcs::simulate::{
    random_placement, random_poses, simulate_poses, simulate_poses_of, true_position, Experiment,
    Factors, NonGeometric, NonGeometricSizes, TrackerNoise,
};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use reference::{chain_position, configurations, distance, TrueRobot, LINK_MASS_KG};

/// The reference robot as the library's model and non-geometric errors (same parameters).
fn library_robot(truth: &TrueRobot) -> (RobotModel, NonGeometric) {
    let mut model = tx60();
    for (j, row) in truth.params.iter().enumerate() {
        for (k, v) in row.iter().enumerate() {
            model.params[5 * j + k] = *v;
        }
    }
    model.tool = truth.tool;
    let errors = NonGeometric {
        compliance: Joints::from_slice(&truth.compliance),
        harmonics: Capped::from_slice(&truth.harmonics),
        links: gpu_amcs::kinematics::gravity::LinkMasses::at_midpoints(Joints::from_slice(
            &LINK_MASS_KG,
        )),
        payload_kg: 0.0,
        backlash_deg: gpu_amcs::kinematics::Joints::filled(6, 0.0),
    };
    (model, errors)
}

/// The library's gravity torques, deflections and positions equal the reference's on the same
/// robots (sizes 1 and 5, 100 configurations each): torques to 1e-9 N·m, deflections to 1e-12
/// rad, base-frame positions to 1e-9 mm, and the tracker-frame positions' pairwise distances
/// (the reference's placement is its own) to 1e-9 mm.
#[test]
fn library_matches_the_reference() {
    // The default masses on the TX60 are the reference's.
    let masses = gpu_amcs::simulate::nongeometric::default_link_masses(&tx60());
    for (a, b) in masses.iter().zip(LINK_MASS_KG) {
        assert!((a - b).abs() < 1e-12, "{masses:?}");
    }
    let mut worst = [0.0f64; 3];
    for (seed, size) in [(1u64, 1.0), (2, 1.0), (3, 5.0)] {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let truth = TrueRobot::draw(size, &mut rng);
        let (model, errors) = library_robot(&truth);
        let configs = configurations(100, &mut rng);
        let mut ours_tracker = Vec::new();
        for q_deg in &configs {
            let q: [f64; 6] = std::array::from_fn(|i| q_deg[i].to_radians());
            let (tau_ref, tau) = (
                truth.gravity_torques(&q),
                errors.gravity_torques(&model, &q),
            );
            let (dq_ref, dq) = (truth.deflections(&q), errors.deflections(&model, &q));
            for i in 0..6 {
                worst[0] = worst[0].max((tau_ref[i] - tau[i]).abs());
                worst[1] = worst[1].max((dq_ref[i] - dq[i]).abs());
            }
            let actual: [f64; 6] = std::array::from_fn(|i| q[i] + dq_ref[i]);
            let p_ref = chain_position(&truth.params, truth.tool, &actual);
            let p = true_position(&model, Some(&errors), &q);
            worst[2] = worst[2].max(distance(p_ref, p));
            ours_tracker.push((truth.position(q_deg), p));
        }
        for w in ours_tracker.windows(2) {
            let d_ref = distance(w[0].0, w[1].0);
            let d = distance(w[0].1, w[1].1);
            assert!((d_ref - d).abs() < 1e-9, "{d_ref} vs {d}");
        }
        // Sizes 1 and 5 deflect the joints by up to a few hundredths of a degree: the errors
        // are not zero.
        let big = configs
            .iter()
            .map(|q| {
                let q: Vec<f64> = q.iter().map(|v| v.to_radians()).collect();
                errors
                    .deflections(&model, &q)
                    .iter()
                    .fold(0.0f64, |m, v| m.max(v.abs()))
            })
            .fold(0.0, f64::max);
        assert!(
            big > 1e-5 * size,
            "seed {seed}: largest deflection {big} rad"
        );
    }
    eprintln!(
        "largest differences: torque {:.1e} N·m, deflection {:.1e} rad, position {:.1e} mm",
        worst[0], worst[1], worst[2]
    );
    assert!(
        worst[0] < 1e-9 && worst[1] < 1e-12 && worst[2] < 1e-9,
        "{worst:?}"
    );
}

/// Size 0 is the geometric simulator: no errors are drawn, and the pose data and sweeps are
/// those of the geometric robot bit for bit.
#[test]
fn size_zero_is_the_geometric_simulator() {
    let truth = Experiment::tx60(5).truth;
    assert!(NonGeometric::draw(&truth, &NonGeometricSizes::none(), 5).is_none());
    // A payload without compliance moves nothing.
    let payload = NonGeometricSizes {
        payload_kg: 5.0,
        ..NonGeometricSizes::none()
    };
    assert!(NonGeometric::draw(&truth, &payload, 5).is_none());
    let configs = random_poses(&truth, 30, 4);
    let b = random_placement(4);
    let noise = TrackerNoise::Isotropic(0.01);
    let old = simulate_poses(&truth, &configs, &b, &noise, 9);
    let new = simulate_poses_of(&truth, None, &configs, &b, &noise, 9);
    assert_eq!(format!("{old:?}"), format!("{new:?}"));
    // The same positions as the forward kinematics of the true geometry, exactly.
    let exact = simulate_poses(&truth, &configs, &b, &TrackerNoise::Isotropic(0.0), 9);
    for (p, q) in exact.runs[0].points.iter().zip(&configs) {
        let want = b.apply(gpu_amcs::kinematics::position_deg(
            &truth.params,
            &truth.tool,
            q,
        ));
        assert_eq!(p.position_mm, want);
    }
    let mut exp = Experiment::tx60(5);
    let f = Factors {
        runs: 2,
        step_deg: 10.0,
        ..Factors::default()
    };
    let before = exp.sweeps(&f, 3);
    exp.set_nongeometric(&NonGeometricSizes::none(), 5).unwrap();
    assert_eq!(format!("{before:?}"), format!("{:?}", exp.sweeps(&f, 3)));
    let sizes = NonGeometricSizes {
        compliance: 1.0,
        harmonics: 1.0,
        payload_kg: 2.0,
        backlash: 0.0,
    };
    exp.set_nongeometric(&sizes, 5).unwrap();
    assert_ne!(format!("{before:?}"), format!("{:?}", exp.sweeps(&f, 3)));
    let bad = NonGeometricSizes {
        compliance: -1.0,
        ..sizes
    };
    assert!(exp.set_nongeometric(&bad, 5).is_err());
}

/// The CLI: no flags and explicit zeros write the same bytes (pose data and sweeps); sizes of 1
/// change the data by micrometres to tenths of a millimetre; bad values fail naming the flag.
#[test]
fn cli_flags_default_to_the_geometric_robot_and_are_checked() {
    let dir = tmpdir("simulate-nongeometric");
    let poses = ["simulate", "--poses", "40", "--tracker-sigma", "0"];
    let sweeps = ["simulate", "--runs", "2", "--step", "10"];
    let zeros = ["--compliance", "0", "--harmonics", "0", "--payload-kg", "0"];
    for base in [&poses[..], &sweeps[..]] {
        let plain = run(base);
        assert!(plain.status.success(), "{}", stderr(&plain));
        let with_zeros = run(&[base, &zeros[..]].concat());
        assert_eq!(plain.stdout, with_zeros.stdout, "{base:?}");
        let ones = ["--compliance", "1", "--harmonics", "1", "--payload-kg", "3"];
        let bent = run(&[base, &ones[..]].concat());
        assert!(bent.status.success(), "{}", stderr(&bent));
        assert_ne!(plain.stdout, bent.stdout, "{base:?}");
    }
    let out = arg(&dir, "p.csv");
    for (flag, value) in [
        ("--compliance", "11"),
        ("--compliance", "nan"),
        ("--harmonics", "-1"),
        ("--harmonics", "inf"),
        ("--payload-kg", "2000"),
    ] {
        fails_naming(&["simulate", "--poses", "5", flag, value, "-o", &out], flag);
    }
    // A payload bends only compliant joints.
    fails_naming(
        &["simulate", "--poses", "5", "--payload-kg", "5", "-o", &out],
        "--payload-kg",
    );
    fails_naming(
        &["calibrate", "--runs", "2", "--harmonics", "12"],
        "--harmonics",
    );
    assert!(!std::path::Path::new(&out).exists());
}

/// RMS of the held-out errors (mm) of the model identified (with identify's defaults for pose
/// data, a stated σ of 10 µm and the joint errors fitted as `beyond` says) from `n` poses of a
/// TX60 with non-geometric errors `sizes`, over 100 noise-free held-out poses.
fn held_out_rms(
    sizes: &NonGeometricSizes,
    robot_seed: u64,
    n: usize,
    beyond: JointErrorFit,
) -> f64 {
    let truth = Experiment::tx60(robot_seed).truth;
    let errors = NonGeometric::draw(&truth, sizes, robot_seed);
    held_out(errors.as_ref(), robot_seed, n, beyond).0
}

/// [`held_out_rms`] of robot `robot_seed` with the non-geometric errors `errors`, and which
/// joint-error terms the fit beyond geometry kept (`None` when it did not run).
pub(crate) fn held_out(
    errors: Option<&NonGeometric>,
    robot_seed: u64,
    n: usize,
    beyond: JointErrorFit,
) -> (f64, Option<TermSelection>) {
    let truth = Experiment::tx60(robot_seed).truth;
    let placement = random_placement(robot_seed);
    let configs = random_poses(&truth, n, robot_seed + 1);
    let data: PoseData = simulate_poses_of(
        &truth,
        errors,
        &configs,
        &placement,
        &TrackerNoise::Isotropic(0.010),
        robot_seed + 2,
    );
    let (model, selection) = reference::identify_selecting(data, Some(0.010), beyond);
    let held = random_poses(&truth, 100, robot_seed + 3);
    let sum: f64 = held
        .iter()
        .map(|q| {
            let q: Vec<f64> = q.iter().map(|v| v.to_radians()).collect();
            let p = placement.apply(true_position(&truth, errors, &q));
            let m = model.compensated_world_position(&q);
            distance(p, m).powi(2)
        })
        .sum();
    ((sum / held.len() as f64).sqrt(), selection)
}

/// The robots the ratios below average over: 24, so that the mean's standard error (0.03, one
/// robot's ratio scattering by 0.15) tells 1.45× from 1.5×.
pub(crate) const ROBOTS: std::ops::Range<u64> = 100..124;

/// The held-out RMS (mm) of identify's defaults on the purely geometric robot of each seed of
/// [`ROBOTS`] (200 poses, 10 µm): the denominator of the ratios here and in
/// `tests/it/harmonic_orders.rs`, computed once for both.
pub(crate) fn geometric_robots() -> &'static [f64] {
    use rayon::prelude::*;
    static RMS: std::sync::OnceLock<Vec<f64>> = std::sync::OnceLock::new();
    RMS.get_or_init(|| {
        ROBOTS
            .into_par_iter()
            .map(|seed| held_out(None, seed, 200, JointErrorFit::Auto).0)
            .collect()
    })
}

/// Mean and standard deviation of `v`.
pub(crate) fn mean_sd(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, var.sqrt())
}

/// The motivating figure in small: with compliance and harmonics at size 1, a
/// geometric calibration (`--beyond-geometry=off`) from 200 poses measured with 10 µm noise
/// leaves a held-out RMS at least 3× a geometric robot's (16–17× on these seeds); identify's
/// defaults find the lack of fit, fit and keep the joint errors: 1.75× and 1.57× here (seed
/// 2025 keeps its J6 second harmonic, χ² 7.0 against Akaike's 4; a test at 1 % dropped it and
/// left 2.07×). The 1.5× is a mean over robots:
/// `identify_defaults_come_within_1_5x_of_a_geometric_robot`.
#[test]
fn geometric_calibration_leaves_most_of_the_nongeometric_error() {
    let one = NonGeometricSizes {
        compliance: 1.0,
        harmonics: 1.0,
        payload_kg: 0.0,
        backlash: 0.0,
    };
    let mut ratios = Vec::new();
    for seed in [2025u64, 7] {
        let geometric = held_out_rms(&NonGeometricSizes::none(), seed, 200, JointErrorFit::Auto);
        let bent = held_out_rms(&one, seed, 200, JointErrorFit::Off);
        let full = held_out_rms(&one, seed, 200, JointErrorFit::Auto);
        eprintln!(
            "seed {seed}: held-out RMS {geometric:.4} mm geometric robot; with compliance and harmonics {bent:.4} mm geometric calibration ({:.1}×), {full:.4} mm identify's defaults ({:.2}×)",
            bent / geometric,
            full / geometric
        );
        assert!(bent > 3.0 * geometric, "seed {seed}: {bent} vs {geometric}");
        assert!(full < 2.2 * geometric, "seed {seed}: {full} vs {geometric}");
        ratios.push(full / geometric);
    }
    assert!(ratios.iter().sum::<f64>() / 2.0 < 1.9, "{ratios:?}");
}

/// The target: with 10 µm noise and 200 random poses, identify's defaults (the joint
/// errors fitted, their terms chosen per joint by Akaike's criterion, and kept; the compensation
/// when it predicts better) on a TX60 with compliance and harmonics at size 1 come within 1.5×
/// of a purely geometric robot's held-out RMS at the same poses. One robot's ratio scatters by
/// 0.15 (standard deviation over these 24: 1.20–1.73×), so four robots cannot tell 1.5× from
/// 1.6×; the mean over 24 has a standard error of 0.03. Measured 1.439× (sd 0.154); with every
/// term kept 1.423×, with the terms chosen by a test at 1 % instead 1.473× (the test drops
/// weak terms these robots have, and their bias costs more than their variance: on every one
/// of the 24 Akaike's criterion does as well or better, by 0.035 on average, standard error
/// 0.012). √(53/27) = 1.40× is what 26 more coefficients cost by their count alone, the
/// leverage of new poses the rest.
#[test]
fn identify_defaults_come_within_1_5x_of_a_geometric_robot() {
    use rayon::prelude::*;
    let one = NonGeometricSizes {
        compliance: 1.0,
        harmonics: 1.0,
        payload_kg: 0.0,
        backlash: 0.0,
    };
    let geometric = geometric_robots();
    let seeds: Vec<u64> = ROBOTS.collect();
    let ratios: Vec<f64> = seeds
        .into_par_iter()
        .zip(geometric)
        .map(|(seed, g)| {
            let truth = Experiment::tx60(seed).truth;
            let errors = NonGeometric::draw(&truth, &one, seed);
            held_out(errors.as_ref(), seed, 200, JointErrorFit::Auto).0 / g
        })
        .collect();
    let (mean, sd) = mean_sd(&ratios);
    eprintln!(
        "held-out RMS over a geometric robot's: {:?}, mean {mean:.3}, sd {sd:.3}",
        ratios.iter().map(|r| format!("{r:.2}")).collect::<Vec<_>>()
    );
    assert!(mean < 1.5, "{mean}: {ratios:?}");
}
