//! Every block kind of the input space acts in every kernel: the f64 point form
//! (`PlacementEvaluator`), the f64 lanes (`CpuEvaluator`) and the WGSL shader (`GpuEvaluator`).
//! For each input of each block, an offset that moves only that input must move the per-point
//! errors exactly as forward kinematics of the perturbed model says (independent truth:
//! `RobotModel::world_position`, the matrix-free chain and the `base` transform). A block kind
//! without an application in a kernel leaves its errors at zero and fails here; a new block kind
//! does not compile here until [`perturbed`] says what it means.

use crate::common::{have_adapter, max_gap};
use gpu_amcs::engine::{
    CpuEvaluator, Evaluator, PlacementEvaluator, PlacementSpread, Problem, Reference,
};
use gpu_amcs::kinematics::{
    param_index, tx60, BaseTransform, Block, InputSpace, Joints, RobotModel, Uncertainty,
};

/// The TX60 with a tracker target and a placement 2 m away, and independent spreads on every
/// input of the widest space (`measured`) given by `sigma(i)` (0 = fixed).
fn placed_tx60(sigma: impl Fn(usize) -> f64) -> RobotModel {
    let mut m = tx60();
    m.tool = [30.0, -20.0, 80.0];
    m.base = Some(BaseTransform {
        xyz: [2000.0, 100.0, -300.0],
        rpy: [0.05, -0.02, 1.2],
    });
    let space = InputSpace::measured(6);
    let n = space.len();
    let mut c = vec![0.0; n * n];
    for i in 0..n {
        c[i * n + i] = sigma(i).powi(2);
    }
    m.tool_sigma = std::array::from_fn(|k| sigma(space.index(Block::Tool, k).unwrap()));
    m.uncertainty = Uncertainty::from_matrix(space, c);
    m
}

/// The model with input `k` of `block` moved by `delta` (internal units): what the block means,
/// written from the model's own fields, independently of any kernel.
fn perturbed(m: &RobotModel, block: Block, k: usize, delta: f64) -> RobotModel {
    let mut p = m.clone();
    match block {
        Block::Joints => p.params[k] += delta,
        Block::Tool => p.tool[k] += delta,
        Block::Placement => {
            let b = p.base.as_mut().expect("a placed model");
            if k < 3 {
                b.xyz[k] += delta;
            } else {
                b.rpy[k - 3] += delta;
            }
        }
    }
    p
}

/// `e_j` of the perturbed model against the model's own positions (the calibrated reference),
/// both in the measurement frame.
fn truth(m: &RobotModel, p: &RobotModel, pts: &[Joints]) -> Vec<f64> {
    pts.iter()
        .map(|q| {
            let q: Vec<f64> = q.iter().map(|v| v.to_radians()).collect();
            let (a, b) = (p.world_position(&q), m.world_position(&q));
            ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
        })
        .collect()
}

/// An offset that moves the end point by 0.007–0.5 mm: large against every kernel's rounding
/// (f32 deviations: ≲ 1e-5 mm), small enough for every kernel's small-offset forms.
fn step(space: InputSpace, i: usize) -> f64 {
    if space.is_angle(i) {
        2e-4
    } else {
        0.05
    }
}

#[test]
fn every_block_kind_acts_in_every_kernel() {
    let space = InputSpace::measured(6);
    assert_eq!(
        space.blocks().count(),
        Block::ALL.len(),
        "the widest offset row an evaluator takes covers every block kind"
    );
    // Every input uncertain but each joint's fixed parameter (d or β), whose σ must be 0.
    let nominal = tx60();
    let fixed: Vec<usize> = (0..6)
        .map(|j| param_index(j, nominal.fixed[j].kind()))
        .collect();
    let all = placed_tx60(|i| {
        if fixed.contains(&i) {
            0.0
        } else {
            1e-3 * step(space, i)
        }
    });
    let pts = gpu_amcs::simulate::random_poses(&all, 5, 3);
    let problem = Problem::new(all.clone(), &pts, &Reference::Calibrated, 1).unwrap();
    let spread = PlacementSpread::of(&problem)
        .unwrap()
        .expect("placement drawn");
    let mut point_form = PlacementEvaluator::new(problem.clone(), spread.clone());
    let mut gpu = have_adapter("every_block_kind_acts_in_every_kernel").then(|| {
        gpu_amcs::gpu::GpuEvaluator::new(problem.clone(), &Default::default()).expect("GPU")
    });
    let m = pts.len();
    let mut covered = Vec::new();
    for block in Block::ALL {
        for (k, i) in space.range(block).unwrap().enumerate() {
            let d = step(space, i);
            let want = truth(&all, &perturbed(&all, block, k, d), &pts);
            let moved = want.iter().cloned().fold(0.0, f64::max);
            assert!(
                moved > 2e-3,
                "{}: the step moves the end point ({moved} mm)",
                space.name(i)
            );
            let mut row = vec![0.0; space.len()];
            row[i] = d;
            // Kernel 1: the f64 point form.
            let (mut w, mut e) = (vec![0.0; 1], vec![0.0; m]);
            point_form
                .evaluate_offsets(&row, &mut w, Some(&mut e))
                .unwrap();
            assert!(max_gap(&e, &want) < 1e-9, "point form, {}", space.name(i));
            // Kernel 3: the shader (f32 deviations).
            if let Some(g) = gpu.as_mut() {
                g.evaluate_offsets(&row, &mut w, Some(&mut e)).unwrap();
                assert!(
                    max_gap(&e, &want) < 1e-4,
                    "WGSL, {}: {e:?} vs {want:?}",
                    space.name(i)
                );
            }
            // Kernel 2: the lanes, on counter draws of a model whose only spread is input i
            // (the lanes draw the placement; a fixed MDH parameter cannot carry a spread).
            let only = placed_tx60(|x| if x == i { d } else { 0.0 });
            if only.check().is_err() {
                continue;
            }
            let pb = Problem::new(only.clone(), &pts, &Reference::Calibrated, 5).unwrap();
            let drawn = |k_draw: u64| -> f64 {
                match PlacementSpread::of(&pb).unwrap() {
                    Some(sp) => sp.deltas(&gpu_amcs::sampling::Philox::new(pb.seed), k_draw)[i],
                    None => {
                        let mut o = vec![0.0; pb.sampler.n_inputs()];
                        pb.sampler.deltas(k_draw, &mut o);
                        o[i]
                    }
                }
            };
            let mut lanes = CpuEvaluator::new(pb.clone());
            let n = 8;
            let (mut w, mut e) = (vec![0.0; n], vec![0.0; n * m]);
            lanes.evaluate(0, &mut w, Some(&mut e)).unwrap();
            for draw in 0..n {
                let dk = drawn(draw as u64);
                assert!(dk != 0.0);
                let want = truth(&only, &perturbed(&only, block, k, dk), &pts);
                let got = &e[draw * m..(draw + 1) * m];
                assert!(
                    max_gap(got, &want) < 1e-9,
                    "lanes, {} draw {draw}: {got:?} vs {want:?}",
                    space.name(i)
                );
            }
            covered.push(space.name(i));
        }
    }
    // The lanes saw every block kind (the fixed parameters aside).
    for block in Block::ALL {
        let r = space.range(block).unwrap();
        assert!(
            r.clone().any(|i| covered.contains(&space.name(i))),
            "the lanes were not checked on {}",
            block.name()
        );
    }
}
