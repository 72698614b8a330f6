//! Joint errors beyond geometry as analyses draw them (compliance, gear harmonics, payload;
//! docs/METHOD.md §19): the vectorised CPU lanes against the plain forward kinematics of each
//! drawn robot, the model file round trip, the payload's effect and the pick-freeze group.

use gpu_amcs::engine::{
    CpuEvaluator, Evaluator, PickFreeze, Problem, Reference, TermGroup, JOINT_ERRORS_MASK,
};
use gpu_amcs::kinematics::joint_errors::COEFFICIENTS_PER_JOINT;
use gpu_amcs::kinematics::{position, tx60, Block, InputSpace, JointErrors, Payload, RobotModel};

/// A TX60 with compliance of a 60 kg-class arm, harmonics of a few thousandths of a degree, a
/// 3 ± 0.5 kg payload and an uncertainty over every coefficient, correlated with a few
/// geometric inputs.
pub(crate) fn model_with_joint_errors(payload_kg: f64) -> RobotModel {
    let mut m = tx60();
    let n = m.joints();
    let nc = COEFFICIENTS_PER_JOINT * n;
    let coefficients: Vec<f64> = (0..nc)
        .map(|i| {
            let s = ((i * 7919) % 13) as f64 / 13.0 - 0.4;
            if JointErrors::is_compliance(i) {
                (1.0 + 3.0 * s.abs()) * 1e-6
            } else {
                (0.002 + 0.008 * s.abs()).to_radians() * s.signum()
            }
        })
        .collect();
    let free: Vec<usize> = (0..nc).filter(|&i| i != 0).collect(); // k1: a vertical axis
    let p = free.len();
    let sd: Vec<f64> = free
        .iter()
        .map(|&i| {
            if JointErrors::is_compliance(i) {
                0.4e-6
            } else {
                0.001f64.to_radians()
            }
        })
        .collect();
    let mut covariance = vec![0.0; p * p];
    for a in 0..p {
        for b in 0..p {
            let rho = if a == b {
                1.0
            } else if a.abs_diff(b) == 1 {
                0.3
            } else {
                0.0
            };
            covariance[a * p + b] = rho * sd[a] * sd[b];
        }
    }
    let space = InputSpace::robot(n);
    let mut shift = vec![0.0; space.len() * p];
    // θ2 moves with cos1_2, d3 with k3, tool x with k2.
    let col = |name: &str| {
        free.iter()
            .position(|&i| JointErrors::coefficient_name(i) == name)
            .unwrap()
    };
    shift[space.find("theta2").unwrap() * p + col("cos1_2")] = -0.8;
    shift[space.find("d3").unwrap() * p + col("k3")] = 2.0e4; // mm per rad/(N·m)
    shift[space.find("tool_x").unwrap() * p + col("k2")] = -1.0e4;
    m.tool = [10.0, -5.0, 60.0];
    m.joint_errors = Some(JointErrors {
        coefficients,
        links: gpu_amcs::kinematics::gravity::LinkMasses::of(&m),
        calibration_payload: Payload::NONE,
        payload: Payload {
            mass_kg: payload_kg,
            sigma_kg: 0.5,
            com_mm: [0.0, 0.0, 80.0],
        },
        free,
        covariance,
        shift_space: space,
        shift,
        backlash: None,
    });
    m
}

pub(crate) fn points() -> Vec<[f64; 6]> {
    vec![
        [0.0, 10.0, 80.0, 0.0, 30.0, 0.0],
        [20.0, -40.0, 90.0, 10.0, 45.0, 5.0],
        [-30.0, 60.0, 100.0, 0.0, -20.0, 90.0],
        [100.0, 30.0, 40.0, -60.0, 70.0, -120.0],
    ]
}

/// Draw `k`'s errors at every point by plain forward kinematics: the sampler's geometric
/// offsets moved by `A δβ`, each joint at its mean chain angle plus the draw's offset.
fn plain_errors(pb: &Problem, k: u64) -> Vec<f64> {
    let term = pb.joint_errors.as_ref().unwrap();
    let td = term.draw(k);
    let space = pb.sampler.space();
    let mut d = vec![0.0; space.len()];
    pb.sampler.deltas(k, &mut d);
    term.shift_each(&td, |b, i, v| {
        if let Some(x) = space.index(b, i) {
            d[x] += v;
        }
    });
    let n = pb.model.joints();
    let params: Vec<f64> = (0..5 * n).map(|i| pb.model.params[i] + d[i]).collect();
    let t0 = space.range(Block::Tool).unwrap().start;
    let tool: [f64; 3] = std::array::from_fn(|c| pb.model.tool[c] + d[t0 + c]);
    (0..pb.n_points())
        .map(|j| {
            let o = term.offsets(&td, j);
            let q: Vec<f64> = (0..n).map(|i| pb.chain_points[j][i] + o[i]).collect();
            let p = position(&params, &tool, &q);
            let r = pb.reference[j];
            ((p[0] - r[0]).powi(2) + (p[1] - r[1]).powi(2) + (p[2] - r[2]).powi(2)).sqrt()
        })
        .collect()
}

#[test]
fn the_lanes_draw_joint_errors_as_plain_forward_kinematics_of_each_drawn_robot() {
    let pb = Problem::new(
        model_with_joint_errors(3.0),
        &points(),
        &Reference::Calibrated,
        7,
    )
    .unwrap();
    assert!(pb.joint_errors.is_some());
    let mut ev = CpuEvaluator::new(pb.clone());
    let draws = 40;
    let mut w = vec![0.0; draws];
    let mut e = vec![0.0; draws * 4];
    ev.evaluate(100, &mut w, Some(&mut e)).unwrap();
    let mut worst = 0.0f64;
    for k in 0..draws {
        let plain = plain_errors(&pb, 100 + k as u64);
        for j in 0..4 {
            worst = worst.max((plain[j] - e[k * 4 + j]).abs());
        }
        let max = plain.iter().copied().fold(0.0, f64::max);
        assert!((w[k] - max).abs() < 1e-9);
    }
    // Both are f64 chains of ~1000 mm: rounding differs by a few 1e-13 mm.
    assert!(worst < 1e-9, "lanes vs plain FK: {worst:e} mm");

    // The term matters: without its spread (geometry alone) the errors differ.
    let mut geo = pb.clone();
    geo.joint_errors = None;
    let mut w0 = vec![0.0; draws];
    CpuEvaluator::new(geo).evaluate(100, &mut w0, None).unwrap();
    let moved = w
        .iter()
        .zip(&w0)
        .filter(|(a, b)| (*a - *b).abs() > 1e-4)
        .count();
    assert!(
        moved > draws / 2,
        "the joint errors changed only {moved} of {draws} draws"
    );
}

/// The drawn chains stand at the commanded angles plus the mean deflections with the task
/// payload; the calibrated reference is the calibrated model's prediction, with the payload
/// during calibration (none here): a task payload bends the robot away from it.
#[test]
fn the_calibrated_reference_holds_the_mean_deflections() {
    let m = model_with_joint_errors(3.0);
    let pb = Problem::new(m.clone(), &points(), &Reference::Calibrated, 1).unwrap();
    let e = m.joint_errors.as_ref().unwrap();
    for (j, q) in points().iter().enumerate() {
        let qr: Vec<f64> = q.iter().map(|v| v.to_radians()).collect();
        let defl = e.deflections(&m.params, &qr);
        // 3 kg of payload and ~1e-6 rad/(N·m) give deflections of 1e-5 to 1e-4 rad.
        assert!(defl.iter().any(|d| d.abs() > 1e-5), "{defl:?}");
        for i in 0..6 {
            assert_eq!(pb.chain_points[j][i], qr[i] + defl[i]);
        }
        let task = position(&m.params, &m.tool, &pb.chain_points[j]);
        assert_eq!(m.compensated_position(&qr), task);
        let calibrated = position(&m.params, &m.tool, &m.calibrated_chain_angles(&qr));
        assert_eq!(pb.reference[j], calibrated);
        let moved = (0..3)
            .map(|c| (task[c] - calibrated[c]).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(
            moved > 0.005,
            "point {j}: 3 kg moves the target by {moved} mm"
        );
    }
    // With the payload of the calibration the reference is the mean chain's own position.
    let m0 = model_with_joint_errors(0.0);
    let pb0 = Problem::new(m0.clone(), &points(), &Reference::Calibrated, 1).unwrap();
    for j in 0..points().len() {
        assert_eq!(
            pb0.reference[j],
            position(&m0.params, &m0.tool, &pb0.chain_points[j])
        );
    }
}

#[test]
fn a_model_file_keeps_its_joint_errors() {
    let m = model_with_joint_errors(3.0);
    let text = m.to_toml();
    assert!(text.contains("[joint_errors]"), "{text}");
    let back = RobotModel::from_toml(&text, "je.toml").unwrap();
    let (a, b) = (m.joint_errors.unwrap(), back.joint_errors.clone().unwrap());
    assert_eq!(a.free, b.free);
    let close = |x: &[f64], y: &[f64]| {
        x.len() == y.len()
            && x.iter()
                .zip(y)
                .all(|(p, q)| (p - q).abs() <= 1e-12 * p.abs().max(q.abs()).max(1e-300))
    };
    assert!(close(&a.coefficients, &b.coefficients));
    assert!(close(&a.covariance, &b.covariance));
    assert!(close(&a.shift, &b.shift));
    assert_eq!(a.payload, b.payload);
    // A bad value names its field.
    let bad = text.replace("payload_sigma_kg = 0.5", "payload_sigma_kg = -1");
    let err = RobotModel::from_toml(&bad, "je.toml")
        .unwrap_err()
        .to_string();
    assert!(err.contains("joint_errors.payload_kg"), "{err}");
    let bad = text.replace("free = [\"sin1_1\"", "free = [\"nope\"");
    let err = RobotModel::from_toml(&bad, "je.toml")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("joint_errors.free") && err.contains("nope"),
        "{err}"
    );
}

#[test]
fn a_heavier_payload_moves_the_robot_the_way_its_compliance_says() {
    let light = model_with_joint_errors(0.0);
    let heavy = model_with_joint_errors(10.0);
    let q: Vec<f64> = [0.0, 30.0, 60.0, 0.0, 30.0, 0.0]
        .iter()
        .map(|v: &f64| v.to_radians())
        .collect();
    let (a, b) = (
        light.compensated_position(&q),
        heavy.compensated_position(&q),
    );
    // Joint 2 carries the payload's torque at a ~600 mm arm: 10 kg · 9.81 · ~0.5 m ≈ 50 N·m,
    // times ~2e-6 rad/(N·m) ≈ 1e-4 rad, times ~600 mm ≈ 0.06 mm.
    let moved = (0..3).map(|c| (a[c] - b[c]).powi(2)).sum::<f64>().sqrt();
    assert!((0.01..1.0).contains(&moved), "{moved} mm");
}

/// Sobol designs take the joint errors as three groups (compliance, gear harmonics, payload):
/// a pick-freeze row takes each group's normals from draw b where its mask has the group's bit
/// (the rest from a), exactly as plain forward kinematics of that mixed draw gives.
#[test]
fn the_joint_errors_are_three_groups_of_a_pick_freeze_design() {
    let pb = Problem::new(
        model_with_joint_errors(3.0),
        &points(),
        &Reference::Calibrated,
        3,
    )
    .unwrap();
    let term = pb.joint_errors.as_ref().unwrap();
    assert_eq!(
        term.groups(),
        TermGroup::ALL[..3].to_vec(),
        "σ on all three"
    );
    let mut ev = CpuEvaluator::new(pb.clone());
    let count = 16;
    let masks = [
        0,
        TermGroup::Compliance.mask(),
        TermGroup::Harmonics.mask(),
        TermGroup::Payload.mask() | 1,
        JOINT_ERRORS_MASK,
    ];
    let req = PickFreeze {
        first: 10,
        b_first: 1000,
        count,
        masks: &masks,
    };
    let mut w = vec![0.0; req.rows()];
    ev.evaluate_pick_freeze(&req, &mut w).unwrap();
    let mut a = vec![0.0; count];
    ev.evaluate(10, &mut a, None).unwrap();
    assert_eq!(&w[..count], &a[..], "mask 0 is draw a itself");
    let space = pb.sampler.space();
    for (s, &mask) in masks.iter().enumerate() {
        for r in 0..count {
            let (da, db) = (10 + r as u64, 1000 + r as u64);
            let by_group = TermGroup::ALL.map(|g| if mask & g.mask() != 0 { db } else { da });
            let td = term.draw_mixed(by_group);
            let mut d = vec![0.0; space.len()];
            pb.sampler
                .pick_freeze_deltas(da, db, mask & gpu_amcs::sampling::ALL_NORMALS, &mut d);
            term.shift_each(&td, |b, i, v| {
                if let Some(x) = space.index(b, i) {
                    d[x] += v;
                }
            });
            let params: Vec<f64> = (0..30).map(|i| pb.model.params[i] + d[i]).collect();
            let tool: [f64; 3] = std::array::from_fn(|c| pb.model.tool[c] + d[30 + c]);
            let wmax = (0..4)
                .map(|j| {
                    let o = term.offsets(&td, j);
                    let q: Vec<f64> = (0..6).map(|i| pb.chain_points[j][i] + o[i]).collect();
                    let p = position(&params, &tool, &q);
                    let rf = pb.reference[j];
                    ((p[0] - rf[0]).powi(2) + (p[1] - rf[1]).powi(2) + (p[2] - rf[2]).powi(2))
                        .sqrt()
                })
                .fold(0.0, f64::max);
            let got = w[s * count + r];
            assert!(
                (got - wmax).abs() < 1e-9,
                "mask {mask:#x}, row {r}: {got} vs {wmax}"
            );
            if s > 0 {
                assert_ne!(got, a[r], "mask {mask:#x} moves row {r}");
            }
        }
    }
}

/// The payload what-if checked against simulated robots that carry the payload: robots of the
/// simulator with compliance and harmonics (a 60 kg-class arm's sizes), calibrated at 200
/// random poses without a payload (10 µm tracker noise, noise estimated), then asked for w
/// over 20 task poses with 5 kg at the tool point. The true w of each robot (its positions
/// with 5 kg against the calibrated model's predictions) is placed in the predicted
/// distribution of w (4000 draws): the PIT values. Honest predictions give PIT values spread
/// over (0, 1) — mean near 0.5, none in the extreme tails; predictions that left out the
/// payload's bending would put every robot at PIT ≈ 1 (the mean error grows 0.03 → 0.08 mm).
#[test]
fn the_payload_what_if_covers_robots_that_carry_the_payload() {
    use gpu_amcs::identify::chain::{chain_model, identify_chain, ChainOptions};
    use gpu_amcs::identify::NominalPrior;
    use gpu_amcs::kinematics::Joints;
    use gpu_amcs::simulate::{
        random_placement, random_poses, simulate_poses_of, true_position, Experiment, NonGeometric,
        NonGeometricSizes, TrackerNoise,
    };
    let sizes = NonGeometricSizes {
        compliance: 1.0,
        harmonics: 1.0,
        payload_kg: 0.0,
        backlash: 0.0,
    };
    let mut pits = Vec::new();
    let mut mean_w = Vec::new();
    for seed in 0..8u64 {
        let truth = Experiment::tx60(100 + seed).truth;
        let errors = NonGeometric::draw(&truth, &sizes, 100 + seed).unwrap();
        let placement = random_placement(100 + seed);
        let configs = random_poses(&truth, 200, 200 + seed);
        let data = simulate_poses_of(
            &truth,
            Some(&errors),
            &configs,
            &placement,
            &TrackerNoise::Isotropic(0.01),
            300 + seed,
        );
        let points = crate::common::measured_points(&data);
        let opts = ChainOptions {
            beyond_geometry: gpu_amcs::identify::JointErrorFit::On,
            ..ChainOptions::default()
        };
        let r =
            identify_chain(&points, &tx60(), None, Some(NominalPrior::default()), &opts).unwrap();
        assert!(
            r.report.beyond_geometry.as_ref().is_some_and(|b| b.kept),
            "robot {seed}: the joint errors were not kept"
        );
        let mut model = chain_model(&tx60(), &r, "identified".into());
        // The task: 5 kg at the tool point.
        let e = model.joint_errors.as_mut().unwrap();
        e.payload.mass_kg = 5.0;
        let task = random_poses(&truth, 20, 400 + seed);
        let loaded = NonGeometric {
            payload_kg: 5.0,
            ..errors.clone()
        };
        let base = model.base.unwrap();
        let w_true = task
            .iter()
            .map(|q| {
                let q: Joints = q.map(f64::to_radians);
                let t = placement.apply(true_position(&truth, Some(&loaded), &q));
                let p = base.apply(position(
                    &model.params,
                    &model.tool,
                    &model.calibrated_chain_angles(&q),
                ));
                (0..3).map(|c| (t[c] - p[c]).powi(2)).sum::<f64>().sqrt()
            })
            .fold(0.0, f64::max);
        let pb = Problem::new(model, &task, &Reference::Calibrated, 500 + seed).unwrap();
        let mut w = vec![0.0; 4000];
        CpuEvaluator::new(pb).evaluate(0, &mut w, None).unwrap();
        let below = w.iter().filter(|&&x| x < w_true).count() as f64 / w.len() as f64;
        mean_w.push(w.iter().sum::<f64>() / w.len() as f64);
        eprintln!(
            "robot {seed}: true w {w_true:.4} mm, predicted mean {:.4} mm, PIT {below:.3}",
            mean_w.last().unwrap()
        );
        pits.push(below);
    }
    let mean = pits.iter().sum::<f64>() / pits.len() as f64;
    let extreme = pits
        .iter()
        .filter(|&&u| !(0.005..=0.995).contains(&u))
        .count();
    eprintln!(
        "PIT mean {mean:.3}, {extreme} of {} outside [0.005, 0.995]",
        pits.len()
    );
    // Eight robots: the mean of 8 uniforms has σ 0.10; at most one robot in a 1 % tail.
    assert!((0.2..=0.8).contains(&mean), "PIT mean {mean}: {pits:?}");
    assert!(extreme <= 1, "{pits:?}");
}

/// The WGSL kernel draws the joint errors as the CPU lanes do (same normals, same shift and
/// factors; f32 deviation form): per sample within the GPU's bound of docs/METHOD.md §7 (1e-5
/// mm), for counter draws of a base-frame model and of a model identified in a tracker frame
/// (placement drawn), and for pick-freeze rows that take the joint errors from the B draw.
#[test]
fn the_gpu_draws_joint_errors_as_the_cpu() {
    use gpu_amcs::identify::chain::{chain_model, identify_chain, ChainOptions};
    use gpu_amcs::identify::NominalPrior;
    use gpu_amcs::simulate::{
        random_placement, random_poses, simulate_poses_of, Experiment, NonGeometric,
        NonGeometricSizes, TrackerNoise,
    };
    if !crate::common::have_adapter("the_gpu_draws_joint_errors_as_the_cpu") {
        return;
    }
    let sizes = NonGeometricSizes {
        compliance: 1.0,
        harmonics: 1.0,
        payload_kg: 0.0,
        backlash: 0.0,
    };
    let truth = Experiment::tx60(5).truth;
    let errors = NonGeometric::draw(&truth, &sizes, 5).unwrap();
    let placement = random_placement(5);
    let data = simulate_poses_of(
        &truth,
        Some(&errors),
        &random_poses(&truth, 150, 6),
        &placement,
        &TrackerNoise::Isotropic(0.01),
        7,
    );
    let opts = ChainOptions {
        beyond_geometry: gpu_amcs::identify::JointErrorFit::On,
        ..ChainOptions::default()
    };
    let r = identify_chain(
        &crate::common::measured_points(&data),
        &tx60(),
        None,
        Some(NominalPrior::default()),
        &opts,
    )
    .unwrap();
    let mut identified = chain_model(&tx60(), &r, "identified".into());
    identified.joint_errors.as_mut().unwrap().payload.mass_kg = 4.0;
    identified.joint_errors.as_mut().unwrap().payload.sigma_kg = 0.5;
    let task = random_poses(&truth, 25, 8);
    for (label, model, pts) in [
        (
            "base frame",
            model_with_joint_errors(3.0),
            points().iter().map(|q| q.to_vec()).collect::<Vec<_>>(),
        ),
        (
            "tracker frame",
            identified,
            task.iter().map(|q| q.to_vec()).collect(),
        ),
    ] {
        let pb = Problem::new(model, &pts, &Reference::Calibrated, 99).unwrap();
        assert!(pb.joint_errors.is_some());
        let n = 20_000;
        let (mut cpu, mut gpu, wg, (dw, de)) = cpu_and_gpu(&pb, 1000, n);
        let diff = crate::common::max_gap;
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        eprintln!(
            "{label}: max |Δw| {dw:.2e} mm, max |Δe| {de:.2e} mm, mean gpu w {:.6}",
            mean(&wg)
        );
        assert!(dw <= 1e-5 && de <= 1e-5, "{label}: {dw} {de}");
        // Without the term's spread the draws differ: the comparison sees the term.
        let mut plain = pb.clone();
        plain.joint_errors = None;
        let mut w0 = vec![0.0; n];
        CpuEvaluator::new(plain)
            .evaluate(1000, &mut w0, None)
            .unwrap();
        assert!(diff(&w0, &wg) > 1e-3, "{label}: the term moved nothing");
        // Pick-freeze rows with the joint errors from B.
        let masks = [
            0,
            JOINT_ERRORS_MASK,
            gpu_amcs::sampling::ALL_NORMALS,
            TermGroup::Compliance.mask(),
            TermGroup::Harmonics.mask() | TermGroup::Payload.mask(),
        ];
        let req = PickFreeze {
            first: 5,
            b_first: 77_777,
            count: 3000,
            masks: &masks,
        };
        let dp = pick_freeze_gap(&mut cpu, &mut gpu, &req);
        assert!(dp <= 1e-5, "{label}: pick-freeze {dp}");
    }
}

/// The CPU and GPU evaluators of `pb`, the GPU's `w` of `n` counter draws from `first`, and the
/// largest differences of `w` and of the point errors between the two.
pub(crate) fn cpu_and_gpu(
    pb: &Problem,
    first: u64,
    n: usize,
) -> (
    CpuEvaluator,
    gpu_amcs::gpu::GpuEvaluator,
    Vec<f64>,
    (f64, f64),
) {
    use gpu_amcs::gpu::{GpuEvaluator, GpuOptions};
    let m = pb.n_points();
    let mut cpu = CpuEvaluator::new(pb.clone());
    let mut gpu = GpuEvaluator::new(pb.clone(), &GpuOptions::default()).unwrap();
    let (mut wc, mut ec, mut wg, mut eg) = (
        vec![0.0; n],
        vec![0.0; n * m],
        vec![0.0; n],
        vec![0.0; n * m],
    );
    cpu.evaluate(first, &mut wc, Some(&mut ec)).unwrap();
    gpu.evaluate(first, &mut wg, Some(&mut eg)).unwrap();
    let gaps = (
        crate::common::max_gap(&wc, &wg),
        crate::common::max_gap(&ec, &eg),
    );
    (cpu, gpu, wg, gaps)
}

/// The largest difference between the CPU's and the GPU's rows of the pick-freeze request `req`.
pub(crate) fn pick_freeze_gap(
    cpu: &mut CpuEvaluator,
    gpu: &mut gpu_amcs::gpu::GpuEvaluator,
    req: &PickFreeze,
) -> f64 {
    let (mut pc, mut pg) = (vec![0.0; req.rows()], vec![0.0; req.rows()]);
    cpu.evaluate_pick_freeze(req, &mut pc).unwrap();
    gpu.evaluate_pick_freeze(req, &mut pg).unwrap();
    crate::common::max_gap(&pc, &pg)
}
