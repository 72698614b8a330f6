//! The tail analysis of a model with joint errors (compliance, gear harmonics, payload; Method
//! §19): its rows' exact point form against the CPU lanes (a second implementation) in the base
//! and the measurement frame, and subset simulation against crude Monte Carlo over the engine's
//! own counter draws, with a contrast that shows the joint errors drive the tail.

use crate::common::max_gap;
use gpu_amcs::engine::{
    CpuEvaluator, Evaluator, PlacementEvaluator, PlacementSpread, Problem, Reference,
    JOINT_ERROR_STREAM,
};
use gpu_amcs::kinematics::gravity::LinkMasses;
use gpu_amcs::kinematics::joint_errors::COEFFICIENTS_PER_JOINT;
use gpu_amcs::kinematics::{
    tx60, BaseTransform, Block, InputSpace, JointErrors, Payload, RobotModel, Uncertainty,
};
use gpu_amcs::mc::tail::{run_tail, TailMethod, TailOptions, TailOutcome, TailResult};
use gpu_amcs::sampling::{normals_block, Philox};

/// A TX60 with compliance on joints 2 and 3 and harmonics on joint 1 (all uncertain), a
/// 6 ± 2 kg payload, and the geometry correlated with them; `sigma_scale` scales the joint
/// errors' covariance (0: the mean alone, nothing of them drawn).
fn with_joint_errors(mut m: RobotModel, sigma_scale: f64) -> RobotModel {
    let n = m.joints();
    let at = |joint: usize, c: usize| COEFFICIENTS_PER_JOINT * joint + c;
    let mut coefficients = vec![0.0; COEFFICIENTS_PER_JOINT * n];
    coefficients[at(1, 0)] = 2e-6;
    coefficients[at(2, 0)] = 3e-6;
    coefficients[at(0, 1)] = 0.004f64.to_radians();
    let free = vec![at(0, 1), at(0, 2), at(1, 0), at(2, 0)];
    let s = [0.004f64.to_radians(), 0.004f64.to_radians(), 1.0e-6, 1.5e-6];
    let p = s.len();
    let covariance = (0..p * p)
        .map(|i| {
            if i / p == i % p {
                (sigma_scale * s[i / p]).powi(2)
            } else {
                0.0
            }
        })
        .collect();
    let space = InputSpace::robot(n);
    let mut shift = vec![0.0; space.len() * p];
    shift[space.find("theta2").unwrap() * p + 1] = -0.8;
    shift[space.find("tool_x").unwrap() * p + 2] = -1.0e4;
    m.joint_errors = Some(JointErrors {
        coefficients,
        links: LinkMasses::of(&m),
        calibration_payload: Payload::NONE,
        payload: Payload {
            mass_kg: 6.0,
            sigma_kg: 2.0 * sigma_scale,
            com_mm: [0.0, 20.0, 60.0],
        },
        free,
        covariance,
        shift_space: space,
        shift,
        backlash: None,
    });
    m
}

/// The TX60 with its base placement uncertain too (the measurement frame: 39 inputs).
fn placed(mut m: RobotModel) -> RobotModel {
    m.base = Some(BaseTransform {
        xyz: [2000.0, 100.0, -300.0],
        rpy: [0.05, -0.02, 1.2],
    });
    let sigmas = m.param_sigmas();
    let space = InputSpace::measured(6);
    let n = space.len();
    let mut c = vec![0.0; n * n];
    for i in 0..n {
        // The parameters' σ, a certain tool (its σ stays 0), then the placement's.
        let s = match (sigmas.get(i), space.locate(i).0) {
            (Some(&s), _) => s,
            (None, Block::Tool) => 0.0,
            (None, _) if space.is_angle(i) => 2e-5,
            (None, _) => 0.02,
        };
        c[i * n + i] = s * s;
    }
    m.uncertainty = Uncertainty::from_matrix(space, c);
    m
}

fn problem(m: RobotModel, points: usize, seed: u64) -> Problem {
    let pts = gpu_amcs::simulate::random_poses(&m, points, 5);
    Problem::new(m, &pts, &Reference::Calibrated, seed).unwrap()
}

/// The exact point form the tail evaluates rows by equals the CPU lanes' counter draws (deviation
/// form in lanes; their joint errors from the same normals) in both frames: ~1e-11 mm of
/// rounding against errors of 0.01–1 mm.
#[test]
fn exact_rows_equal_the_lanes_in_both_frames() {
    for (frame, m) in [
        ("base", with_joint_errors(tx60(), 1.0)),
        ("measurement", placed(with_joint_errors(tx60(), 1.0))),
    ] {
        let pb = problem(m, 9, 4);
        let terms = pb.joint_errors.clone().expect("joint errors drawn");
        let mut lanes = CpuEvaluator::new(pb.clone());
        let spread = PlacementSpread::of(&pb).unwrap();
        assert_eq!(spread.is_some(), frame == "measurement");
        let m = pb.n_points();
        let mut worst = 0.0f64;
        for k in [0u64, 3, 77, 1 << 35] {
            let term = terms.draw(k);
            // The tail moves the normals of a draw as coordinates: the draw from them is the
            // draw's own, bit for bit.
            let gen = Philox::new(pb.seed);
            let z: Vec<f64> = (0..terms.normals().div_ceil(4))
                .flat_map(|b| normals_block(&gen, k, b as u32, JOINT_ERROR_STREAM))
                .collect();
            let again = terms.draw_from_normals(&z);
            assert_eq!((again.beta, again.mass), (term.beta, term.mass), "draw {k}");
            let mut exact = vec![0.0; m];
            let w_exact = match &spread {
                None => {
                    let mut d = vec![0.0; pb.sampler.n_inputs()];
                    pb.sampler.deltas(k, &mut d);
                    pb.errors_with_joint_errors(&d, &term, &mut exact)
                }
                Some(sp) => {
                    let gen = Philox::new(pb.seed);
                    let d = sp.deltas(&gen, k);
                    PlacementEvaluator::new(pb.clone(), sp.clone()).errors_with_joint_errors(
                        &d[..sp.space.len()],
                        &term,
                        &mut exact,
                    )
                }
            };
            let mut w = [0.0];
            let mut e = vec![0.0; m];
            lanes.evaluate(k, &mut w, Some(&mut e)).unwrap();
            worst = worst.max(max_gap(&exact, &e));
            assert!((w_exact - w[0]).abs() < 1e-9, "{frame} draw {k}");
            assert!(
                exact.iter().all(|&v| v > 1e-4),
                "{frame}: errors of substance"
            );
        }
        eprintln!("{frame} frame: exact rows vs lanes, worst {worst:.2e} mm");
        assert!(worst < 1e-9, "{frame}: {worst}");
    }
}

fn subset(l: f64, target: f64) -> TailOptions {
    TailOptions {
        thresholds: vec![l],
        samples_per_level: 1000,
        target_cov: target,
        max_evaluations: 2_000_000,
        ..TailOptions::default()
    }
}

fn run(pb: &Problem, opts: &TailOptions) -> TailResult {
    run_tail(&mut CpuEvaluator::new(pb.clone()), pb, opts, None).unwrap()
}

/// Subset simulation, whose chains move the joint errors' normals and evaluate rows by the exact
/// point form, against crude Monte Carlo over the engine's counter draws (which draw the joint
/// errors in the lanes): within 3 combined standard deviations (each side's own CoV) at a
/// threshold of P_f ≈ 2e-3. The same threshold with the joint errors' spread left out
/// (their mean kept) has a far smaller P_f: the joint errors drive this tail, so a tail that
/// left them out would fail the comparison.
#[test]
fn subset_simulation_with_joint_errors_agrees_with_crude_monte_carlo() {
    for (frame, m) in [
        ("base", with_joint_errors(tx60(), 1.0)),
        ("measurement", placed(with_joint_errors(tx60(), 1.0))),
    ] {
        // The threshold: the 40th largest of 2·10^4 counter draws of another seed.
        let mut w = vec![0.0; 20_000];
        CpuEvaluator::new(problem(m.clone(), 12, 7))
            .evaluate(0, &mut w, None)
            .unwrap();
        w.sort_by(|a, b| b.total_cmp(a));
        let l = w[39];
        let pb = problem(m.clone(), 12, 8);
        let ss = run(&pb, &subset(l, 0.1));
        let mc = run(
            &pb,
            &TailOptions {
                method: TailMethod::MonteCarlo,
                ..subset(l, 0.1)
            },
        );
        let (a, b) = (&ss.estimates[0], &mc.estimates[0]);
        let (da, db) = (a.cov.unwrap() * a.p_f, b.cov.unwrap() * b.p_f);
        eprintln!(
            "{frame} frame, l = {l:.4} mm: subset {:.3e} ± {da:.1e} ({} evaluations, dimension {}), \
             crude MC {:.3e} ± {db:.1e} ({} draws), {:.2} combined σ apart",
            a.p_f,
            ss.evaluations,
            ss.dimension,
            b.p_f,
            mc.evaluations,
            (a.p_f - b.p_f).abs() / da.hypot(db)
        );
        assert_eq!(ss.outcome, TailOutcome::TargetReached);
        assert!((a.p_f - b.p_f).abs() <= 3.0 * da.hypot(db));
        assert!(ss.backend.adapter.contains("exact point form"));

        let mean_only = problem(with_mean_only(&m), 12, 8);
        assert!(mean_only.joint_errors.is_none(), "nothing of them drawn");
        let without = run(&mean_only, &subset(l, 0.1));
        let p0 = without.estimates[0].p_f;
        eprintln!("{frame} frame: the joint errors' spread left out: P_f {p0:.3e}");
        // The state: the same parameters' normals, then the 4 coefficients' and the payload's.
        assert_eq!(ss.dimension, without.dimension + 5);
        assert!(p0 < 0.2 * a.p_f, "{p0} vs {}", a.p_f);
    }
}

/// `m` with the joint errors' mean and no spread.
fn with_mean_only(m: &RobotModel) -> RobotModel {
    let mut m = m.clone();
    let je = m.joint_errors.as_mut().unwrap();
    je.covariance.iter_mut().for_each(|c| *c = 0.0);
    je.free.clear();
    je.covariance.clear();
    je.shift.clear();
    je.payload.sigma_kg = 0.0;
    m
}
