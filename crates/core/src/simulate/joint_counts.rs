//! Identification of arms of four to seven joints from simulated data (circle-point sweeps,
//! the sweeps' whole-chain fit, and poses in a tracker frame): noise-free data of a known truth
//! give the truth back. Here rather than in `identify` because the data come from the
//! simulator, which builds on the identification.

use crate::identify::chain::{ChainOptions, Placement};
use crate::identify::{
    identify, identify_poses, identify_sweeps_chain, IdentifyError, IdentifyOptions,
};
use crate::kinematics::RobotModel;
use crate::kinematics::{tx60, Block, FixedParams, Limits, Params, Uncertainty};
use crate::simulate::{
    perturbed_model, random_placement, random_poses, simulate_poses, simulate_sweeps,
    ParameterErrors, SweepPlan, TrackerNoise, DESIGN_TOOL_MM,
};
use rand::SeedableRng;

/// A nominal arm of `n` joints: the TX60's first four or five joints, the TX60, or the KUKA
/// LBR iiwa 14 preset (seven joints, all axes intersecting).
fn arm(n: usize) -> RobotModel {
    let t = tx60();
    match n {
        4 | 5 => RobotModel {
            name: format!("TX60 first {n} joints"),
            params: Params::from_slice(&t.params[..5 * n]),
            fixed: FixedParams::from_slice(&t.fixed[..n]),
            limits_deg: Limits::from_slice(&t.limits_deg[..n]),
            uncertainty: Uncertainty::Independent(Params::from_slice(&t.param_sigmas()[..5 * n])),
            ..t
        },
        6 => t,
        _ => crate::presets::iiwa14(),
    }
}

fn truth(nominal: &RobotModel, seed: u64) -> RobotModel {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    perturbed_model(
        nominal,
        &ParameterErrors::default(),
        DESIGN_TOOL_MM,
        &mut rng,
    )
}

/// Largest distance between two models' target positions (base frame) at random poses.
fn worst_gap(a: &RobotModel, b: &RobotModel) -> f64 {
    random_poses(a, 50, 11)
        .iter()
        .map(|q| {
            let q = q.map(f64::to_radians);
            let (p, r) = (a.world_position(&q), b.world_position(&q));
            (0..3).map(|k| (p[k] - r[k]).powi(2)).sum::<f64>().sqrt()
        })
        .fold(0.0, f64::max)
}

/// The circle-point method (one sweep per joint) and its whole-chain refinement recover a
/// noise-free true robot of 4 to 7 joints from the default plan fitted to its limits.
#[test]
fn sweeps_identify_four_to_seven_joints() {
    for n in 4..=7 {
        let nominal = arm(n);
        let truth = truth(&nominal, n as u64);
        let plan = SweepPlan::default().within(&nominal.limits_deg);
        let data = simulate_sweeps(&truth, &plan, 0.0, 1, 3);
        assert_eq!(data.runs[0].sweeps.len(), n);
        let ids = identify(&data, &nominal, &IdentifyOptions::default())
            .unwrap_or_else(|e| panic!("{n} joints: {e}"));
        let m = &ids[0].model;
        assert_eq!(m.joints(), n);
        assert_eq!(ids[0].report.joints.len(), n);
        assert!(
            worst_gap(m, &truth) < 1e-4,
            "{n} joints: {}",
            worst_gap(m, &truth)
        );
        let chain = ChainOptions {
            placement: Placement::Known,
            ..ChainOptions::default()
        };
        let ids = identify_sweeps_chain(&data, &nominal, &IdentifyOptions::default(), &chain)
            .unwrap_or_else(|e| panic!("{n} joints: {e}"));
        assert!(worst_gap(&ids[0].model, &truth) < 1e-4, "{n} joints");
        assert_eq!(ids[0].model.uncertainty.dim(), nominal.robot_inputs().len());
        // A nominal model of another joint count is refused, not indexed out of bounds.
        let other = arm(if n == 7 { 6 } else { n + 1 });
        let e = identify(&data, &other, &IdentifyOptions::default()).unwrap_err();
        assert!(matches!(e, IdentifyError::JointCount(_)), "{e}");
    }
}

/// The pose-based whole-chain fit with the placement identified recovers a noise-free true
/// robot of 4 to 7 joints measured in a tracker frame.
#[test]
fn poses_identify_four_to_seven_joints() {
    for n in 4..=7 {
        let nominal = arm(n);
        let mut truth = truth(&nominal, 10 + n as u64);
        let placement = random_placement(n as u64);
        let configs = random_poses(&nominal, 60, 5);
        let data = simulate_poses(
            &truth,
            &configs,
            &placement,
            &TrackerNoise::Isotropic(0.0),
            1,
        );
        let ids = identify_poses(
            &data,
            &nominal,
            &IdentifyOptions::default(),
            &ChainOptions::default(),
        )
        .unwrap_or_else(|e| panic!("{n} joints: {e}"));
        let m = &ids[0].model;
        let c = ids[0].report.chain.as_ref().unwrap();
        assert!(
            c.rms_residual_mm < 1e-6,
            "{n} joints: {}",
            c.rms_residual_mm
        );
        assert_eq!(c.identifiability.joint_spans_deg.len(), n);
        assert_eq!(m.uncertainty.dim(), nominal.layout().measured().len());
        assert!(m.uncertainty.covers(Block::Placement));
        truth.base = Some(placement);
        assert!(
            worst_gap(m, &truth) < 1e-4,
            "{n} joints: {}",
            worst_gap(m, &truth)
        );
    }
}
