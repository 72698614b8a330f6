//! Backlash as analyses draw it (docs/METHOD.md §19.5): at every test point of every draw each
//! joint stands `±h_j` from where the rest of the model puts it, the side a fair coin. Checked
//! against closed forms (one joint: the chord `2ρ sin(h/2)`, the same on either side), against
//! plain forward kinematics of the drawn sides, for the frequencies of the sides, the model
//! file, the pick-freeze group, sensitivity's group and the WGSL kernel.

use crate::joint_errors::model_with_joint_errors;
use gpu_amcs::engine::discrepancy::point_word;
use gpu_amcs::engine::{
    CpuEvaluator, Evaluator, JointErrorDraws, PickFreeze, Problem, Reference, TermGroup,
    BACKLASH_STREAM,
};
use gpu_amcs::kinematics::joint_errors::Backlash;
use gpu_amcs::kinematics::{position, Block, Params, RobotModel, Uncertainty};
use gpu_amcs::sampling::Philox;

/// Gaps (deg) of a 60 kg-class arm's joints, larger at the base (the simulator's sizes).
pub(crate) const GAPS_DEG: [f64; 6] = [0.05, 0.03, 0.02, 0.01, 0.02, 0.02];

pub(crate) fn with_backlash(mut m: RobotModel, gaps_deg: &[f64], sigma_deg: f64) -> RobotModel {
    let n = m.joints();
    let e = m.joint_errors.as_mut().expect("joint errors");
    e.backlash = Some(Backlash {
        gap_rad: gaps_deg.iter().map(|g| g.to_radians()).collect(),
        sigma_rad: vec![sigma_deg.to_radians(); n],
        sides_unknown: None,
    });
    m
}

/// The joint-error tests' four points and one more near J1's far end.
pub(crate) fn points() -> Vec<[f64; 6]> {
    let mut p = crate::joint_errors::points();
    p.push([-120.0, -20.0, 120.0, 30.0, -60.0, 45.0]);
    p
}

/// A TX60 whose only uncertainty is the backlash of the joints with a gap in `gaps_deg`
/// (geometry and tool exactly known, no coefficients with spread, no payload).
pub(crate) fn only_backlash(gaps_deg: &[f64]) -> RobotModel {
    let mut m = model_with_joint_errors(0.0);
    let n = m.joints();
    m.uncertainty = Uncertainty::Independent(Params::filled(5 * n, 0.0));
    m.tool_sigma = [0.0; 3];
    let e = m.joint_errors.as_mut().unwrap();
    e.free.clear();
    e.covariance.clear();
    e.shift.clear();
    e.payload.sigma_kg = 0.0;
    with_backlash(m, gaps_deg, 0.0)
}

/// The sides of draw `k` at point `j` as the module docs define them, written out here: bit `i`
/// of `h(a ⊕ h(b + j))`, `(a, b)` of the Philox block `(k, 0, BACKLASH_STREAM)`.
fn sides(seed: u64, k: u64, j: usize, n: usize) -> Vec<f64> {
    let [a, b, _, _] = Philox::new(seed).block(k, 0, BACKLASH_STREAM);
    let w = point_word(a, b, j as u32);
    (0..n)
        .map(|i| if (w >> i) & 1 == 1 { 1.0 } else { -1.0 })
        .collect()
}

/// One joint's backlash: every draw's error at a point is the chord `2ρ sin(h/2)` of the turn
/// `±h` about the joint's axis (ρ the point's distance from it), the same on either side, so
/// `w` is that of the farthest point in every draw.
#[test]
fn one_joint_turns_every_point_by_the_chord_of_its_half_gap() {
    let gap = 0.1;
    let pb = Problem::new(
        only_backlash(&[gap, 0.0, 0.0, 0.0, 0.0, 0.0]),
        &points(),
        &Reference::Calibrated,
        4,
    )
    .unwrap();
    let h = 0.5 * f64::to_radians(gap);
    // J1's axis is the base z axis (the TX60's placement is the identity).
    let chord: Vec<f64> = (pb.reference.iter())
        .map(|r| 2.0 * r[0].hypot(r[1]) * (0.5 * h).sin())
        .collect();
    let m = pb.n_points();
    let n = 512;
    let (mut w, mut e) = (vec![0.0; n], vec![0.0; n * m]);
    CpuEvaluator::new(pb.clone())
        .evaluate(3, &mut w, Some(&mut e))
        .unwrap();
    let top = chord.iter().copied().fold(0.0, f64::max);
    for k in 0..n {
        for j in 0..m {
            assert!(
                (e[k * m + j] - chord[j]).abs() <= 1e-9,
                "draw {k} point {j}: {} against {}",
                e[k * m + j],
                chord[j]
            );
        }
        assert!((w[k] - top).abs() <= 1e-9);
    }
    assert!(top > 0.3, "{top} mm: the test sees the gap");
}

/// Two joints: each point's error is one of the four of its sides (plain forward kinematics of
/// the commanded angles plus `±h`), the one the module docs' rule gives, and over many draws
/// the four come a quarter of the time each, independently at each point.
#[test]
fn two_joints_take_the_sides_the_rule_gives_a_quarter_of_the_time_each() {
    let gaps = [0.08, 0.05, 0.0, 0.0, 0.0, 0.0];
    let seed = 11;
    let pb = Problem::new(
        only_backlash(&gaps),
        &points(),
        &Reference::Calibrated,
        seed,
    )
    .unwrap();
    let model = &pb.model;
    let h: Vec<f64> = gaps.iter().map(|g| 0.5 * f64::to_radians(*g)).collect();
    let m = pb.n_points();
    let error_of = |j: usize, s: &[f64]| -> f64 {
        let q: Vec<f64> = (0..6)
            .map(|i| pb.chain_points[j][i] + s.get(i).map_or(0.0, |s| s * h[i]))
            .collect();
        let p = position(&model.params, &model.tool, &q);
        let r = pb.reference[j];
        ((p[0] - r[0]).powi(2) + (p[1] - r[1]).powi(2) + (p[2] - r[2]).powi(2)).sqrt()
    };
    let combos = [[1.0, 1.0], [1.0, -1.0], [-1.0, 1.0], [-1.0, -1.0]];
    let n = 4000;
    let (mut w, mut e) = (vec![0.0; n], vec![0.0; n * m]);
    CpuEvaluator::new(pb.clone())
        .evaluate(100, &mut w, Some(&mut e))
        .unwrap();
    let mut counts = vec![[0usize; 4]; m];
    let mut pairs = [[0usize; 2]; 2];
    for k in 0..n {
        for j in 0..m {
            let s = sides(seed, 100 + k as u64, j, 6);
            let want = error_of(j, &s);
            assert!(
                (e[k * m + j] - want).abs() <= 1e-9,
                "draw {k} point {j}: {} against {want}",
                e[k * m + j]
            );
            let c = combos.iter().position(|c| c[..] == s[..2]).unwrap();
            counts[j][c] += 1;
        }
        // Independence across points: J1's side at points 0 and 1.
        let (a, b) = (
            sides(seed, 100 + k as u64, 0, 6),
            sides(seed, 100 + k as u64, 1, 6),
        );
        pairs[usize::from(a[0] > 0.0)][usize::from(b[0] > 0.0)] += 1;
    }
    // A quarter each: binomial σ = √(n·¼·¾) ≈ 27 of 1000; 5σ.
    for (j, c) in counts.iter().enumerate() {
        for &x in c {
            assert!(x.abs_diff(n / 4) <= 137, "point {j}: {c:?}");
        }
        // The four sides give four errors: the test tells them apart.
        let v: Vec<f64> = combos.iter().map(|s| error_of(j, s)).collect();
        for a in 0..4 {
            for b in a + 1..4 {
                assert!((v[a] - v[b]).abs() > 1e-5, "point {j}: {v:?}");
            }
        }
    }
    for r in pairs {
        for x in r {
            assert!(x.abs_diff(n / 4) <= 137, "{pairs:?}");
        }
    }
}

/// With everything else drawn too (coefficients, payload, the geometry's shift): each draw's
/// errors are plain forward kinematics with the coefficients' offsets of the same model without
/// backlash plus `±h` of the rule's sides, to rounding.
#[test]
fn the_lanes_add_the_sides_to_every_other_joint_error() {
    let seed = 5;
    let with = with_backlash(model_with_joint_errors(3.0), &GAPS_DEG, 0.002);
    let pb = Problem::new(with.clone(), &points(), &Reference::Calibrated, seed).unwrap();
    let mut without = with.clone();
    without.joint_errors.as_mut().unwrap().backlash = None;
    let pb0 = Problem::new(without, &points(), &Reference::Calibrated, seed).unwrap();
    let t0 = pb0.joint_errors.as_ref().unwrap();
    let e = with.joint_errors.as_ref().unwrap();
    let b = e.backlash.as_ref().unwrap();
    let h: Vec<f64> = (0..6)
        .map(|j| 0.5 * (b.gap_rad[j].powi(2) + b.sigma_rad[j].powi(2)).sqrt())
        .collect();
    let m = pb.n_points();
    let n = 64;
    let (mut w, mut ev) = (vec![0.0; n], vec![0.0; n * m]);
    CpuEvaluator::new(pb.clone())
        .evaluate(40, &mut w, Some(&mut ev))
        .unwrap();
    let space = pb.sampler.space();
    for k in 0..n {
        let draw = 40 + k as u64;
        let td = t0.draw(draw);
        let mut d = vec![0.0; space.len()];
        pb.sampler.deltas(draw, &mut d);
        t0.shift_each(&td, |blk, i, v| {
            if let Some(x) = space.index(blk, i) {
                d[x] += v;
            }
        });
        let params: Vec<f64> = (0..30).map(|i| pb.model.params[i] + d[i]).collect();
        let tp = space.range(Block::Tool).unwrap().start;
        let tool: [f64; 3] = std::array::from_fn(|c| pb.model.tool[c] + d[tp + c]);
        for j in 0..m {
            let o = t0.offsets(&td, j);
            let s = sides(seed, draw, j, 6);
            let q: Vec<f64> = (0..6)
                .map(|i| pb.chain_points[j][i] + o[i] + s[i] * h[i])
                .collect();
            let p = position(&params, &tool, &q);
            let r = pb.reference[j];
            let want =
                ((p[0] - r[0]).powi(2) + (p[1] - r[1]).powi(2) + (p[2] - r[2]).powi(2)).sqrt();
            assert!(
                (ev[k * m + j] - want).abs() <= 1e-10,
                "draw {k} point {j}: {} against {want}",
                ev[k * m + j]
            );
        }
    }
    // The model without backlash gives other errors: the comparison sees the sides.
    let mut w0 = vec![0.0; n];
    CpuEvaluator::new(pb0.clone())
        .evaluate(40, &mut w0, None)
        .unwrap();
    let moved = w
        .iter()
        .zip(&w0)
        .filter(|(a, b)| (*a - *b).abs() > 1e-4)
        .count();
    assert!(moved > n / 2, "{moved} of {n} draws moved");
    // The point form of the tail analysis and the scalar draw agree with the lanes.
    let t = pb.joint_errors.as_ref().unwrap();
    assert!(t.backlash && t.state_normals() == t.normals() + 2);
    let mut e1 = vec![0.0; m];
    let mut d = vec![0.0; space.len()];
    pb.sampler.deltas(41, &mut d);
    let w1 = pb.errors_with_joint_errors(&d, &t.draw(41), &mut e1);
    assert!((w1 - w[1]).abs() <= 1e-10, "{w1} {}", w[1]);
}

/// Sobol designs take the sides as their own group (`backlash`, mask bit 59): a pick-freeze row
/// with the bit takes draw b's sides and keeps draw a's everything else.
#[test]
fn the_sides_are_a_group_of_a_pick_freeze_design() {
    let seed = 8;
    let pb = Problem::new(
        with_backlash(model_with_joint_errors(3.0), &GAPS_DEG, 0.0),
        &points(),
        &Reference::Calibrated,
        seed,
    )
    .unwrap();
    let term = pb.joint_errors.as_ref().unwrap();
    assert_eq!(term.groups(), TermGroup::ALL.to_vec());
    assert_eq!(TermGroup::Backlash.mask(), 1 << 59);
    let masks = [0, TermGroup::Backlash.mask(), TermGroup::Compliance.mask()];
    let count = 16;
    let req = PickFreeze {
        first: 10,
        b_first: 1000,
        count,
        masks: &masks,
    };
    let mut ev = CpuEvaluator::new(pb.clone());
    let mut w = vec![0.0; req.rows()];
    ev.evaluate_pick_freeze(&req, &mut w).unwrap();
    let space = pb.sampler.space();
    for (s, &mask) in masks.iter().enumerate() {
        for r in 0..count {
            let (da, db) = (10 + r as u64, 1000 + r as u64);
            let by_group = TermGroup::ALL.map(|g| if mask & g.mask() != 0 { db } else { da });
            let td = term.draw_mixed(by_group);
            assert_eq!(td.sides, term.side_words(by_group[3]));
            // (the point form moves the geometry by the draw's shift itself)
            let mut d = vec![0.0; space.len()];
            pb.sampler.deltas(da, &mut d);
            let mut e = vec![0.0; pb.n_points()];
            let want = pb.errors_with_joint_errors(&d, &td, &mut e);
            let got = w[s * count + r];
            assert!(
                (got - want).abs() <= 1e-10,
                "mask {mask:#x} row {r}: {got} {want}"
            );
        }
    }
    // The backlash's bit changes the rows (draw b's sides), compliance's bit others.
    assert!(w[..count] != w[count..2 * count]);
}

/// Sensitivity reports the sides as the group `backlash`: with a gap on J1 only and nothing
/// else uncertain but a tiny geometric spread, it carries all of w's variance.
#[test]
fn sensitivity_names_the_backlash_group() {
    use gpu_amcs::mc::sensitivity::{run_sensitivity, SensitivityOptions};
    let mut m = only_backlash(&[0.1, 0.06, 0.0, 0.0, 0.0, 0.0]);
    // The paper's spread of the free parameters, a ten-thousandth of it.
    let Uncertainty::Independent(s) = model_with_joint_errors(0.0).uncertainty else {
        panic!("the TX60 has independent parameters")
    };
    m.uncertainty = Uncertainty::Independent(Params::from_fn(30, |i| 1e-4 * s[i]));
    let pb = Problem::new(m, &points(), &Reference::Calibrated, 2).unwrap();
    let o = SensitivityOptions {
        draws: 4096,
        bootstrap: 100,
        bootstrap_seed: 1,
        chunk: 1024,
        thresholds: Vec::new(),
    };
    let r = run_sensitivity(&pb, &mut CpuEvaluator::new(pb.clone()), &o).unwrap();
    let w = r.w();
    let g = (w.groups.iter())
        .find(|g| g.name == "backlash")
        .unwrap_or_else(|| panic!("no backlash group: {:?}", w.groups));
    assert!(g.total.value > 0.95, "{g:?}");
    assert!(w.variance > 0.0);
}

/// A model file keeps the backlash; bad values name their field.
#[test]
fn a_model_file_keeps_its_backlash() {
    let m = with_backlash(model_with_joint_errors(3.0), &GAPS_DEG, 0.002);
    let text = m.to_toml();
    assert!(text.contains("backlash_deg = [0.05, 0.03"), "{text}");
    let back = RobotModel::from_toml(&text, "b.toml").unwrap();
    let (a, b) = (
        m.joint_errors.unwrap().backlash.unwrap(),
        back.joint_errors.unwrap().backlash.unwrap(),
    );
    for j in 0..6 {
        assert!((a.gap_rad[j] - b.gap_rad[j]).abs() <= 1e-15);
        assert!((a.sigma_rad[j] - b.sigma_rad[j]).abs() <= 1e-15);
    }
    for (from, to, field) in [
        (
            "backlash_deg = [0.05, ",
            "backlash_deg = [",
            "joint_errors.backlash_deg",
        ),
        (
            "backlash_deg = [0.05",
            "backlash_deg = [2.5",
            "joint_errors.backlash_deg",
        ),
        (
            "backlash_sigma_deg = [0.002",
            "backlash_sigma_deg = [-0.002",
            "joint_errors.backlash_sigma_deg",
        ),
    ] {
        let bad = text.replacen(from, to, 1);
        assert_ne!(bad, text);
        let err = RobotModel::from_toml(&bad, "b.toml")
            .unwrap_err()
            .to_string();
        assert!(err.contains(field), "{from} -> {to}: {err}");
    }
    let no_gaps = text.replace("backlash_deg = [0.05, 0.03, 0.02, 0.01, 0.02, 0.02]\n", "");
    let err = RobotModel::from_toml(&no_gaps, "b.toml")
        .unwrap_err()
        .to_string();
    assert!(err.contains("backlash_sigma_deg"), "{err}");
    // Described in an analysis's notes.
    let pb = Problem::new(
        RobotModel::from_toml(&text, "b.toml").unwrap(),
        &points(),
        &Reference::Calibrated,
        1,
    )
    .unwrap();
    let _ = JointErrorDraws::new(&pb.model, &[], 1).unwrap().unwrap();
    let note = pb.model.joint_errors.as_ref().unwrap().describe();
    assert!(
        note.contains("backlash of J1, J2, J3, J4, J5, J6"),
        "{note}"
    );
}

/// The WGSL kernel draws the sides as the CPU lanes do: counter draws and pick-freeze rows
/// with the backlash's bit, within the GPU's bound of docs/METHOD.md §7 (1e-5 mm).
#[test]
fn the_gpu_draws_the_backlash_as_the_cpu() {
    if !crate::common::have_adapter("the_gpu_draws_the_backlash_as_the_cpu") {
        return;
    }
    let pb = Problem::new(
        with_backlash(model_with_joint_errors(3.0), &GAPS_DEG, 0.002),
        &points(),
        &Reference::Calibrated,
        21,
    )
    .unwrap();
    let n = 20_000;
    let (mut cpu, mut gpu, wg, (dw, de)) = crate::joint_errors::cpu_and_gpu(&pb, 500, n);
    let diff = crate::common::max_gap;
    eprintln!("backlash: max |Δw| {dw:.2e} mm, max |Δe| {de:.2e} mm");
    assert!(dw <= 1e-5 && de <= 1e-5, "{dw} {de}");
    // Without the backlash the draws differ: the comparison sees it.
    let mut plain = pb.clone();
    plain.joint_errors.as_mut().unwrap().backlash = false;
    let mut w0 = vec![0.0; n];
    CpuEvaluator::new(plain)
        .evaluate(500, &mut w0, None)
        .unwrap();
    assert!(diff(&w0, &wg) > 1e-3, "the backlash moved nothing");
    let masks = [
        0,
        TermGroup::Backlash.mask(),
        TermGroup::Backlash.mask() | 1,
    ];
    let req = PickFreeze {
        first: 5,
        b_first: 77_777,
        count: 3000,
        masks: &masks,
    };
    let dp = crate::joint_errors::pick_freeze_gap(&mut cpu, &mut gpu, &req);
    assert!(dp <= 1e-5, "pick-freeze {dp}");
    // Sides known at some points and joints.
    let mut known = pb.clone();
    let sides: Vec<gpu_amcs::kinematics::Joints> = (0..known.n_points())
        .map(|j| {
            gpu_amcs::kinematics::Joints::from_fn(6, |i| match (j + i) % 3 {
                0 => 1.0,
                1 => -1.0,
                _ => 0.0,
            })
        })
        .collect();
    known.set_known_sides(&sides).unwrap();
    let (_, _, wk, (dw, de)) = crate::joint_errors::cpu_and_gpu(&known, 500, 5000);
    assert!(dw <= 1e-5 && de <= 1e-5, "known sides: {dw} {de}");
    assert!(
        diff(&wk, &wg[..5000]) > 1e-3,
        "the known sides moved nothing"
    );
}

/// Identification keeps the gaps when they predict better: a simulated TX60 with compliance,
/// harmonics and backlash measured at 300 poses in random order (10 µm), identified with the
/// explicit check (`JointErrorFit::On`), carries gaps within 4σ of the truth, and the geometry
/// fitted to the angles corrected by each pose's side leaves far less unexplained than the
/// default (`Auto`: no backlash check) does with the same data.
#[test]
fn identification_keeps_the_gaps_that_predict_better() {
    use gpu_amcs::identify::chain::{identify_chain, ChainOptions};
    use gpu_amcs::identify::noise::NoiseModel;
    use gpu_amcs::identify::{JointErrorFit, NominalPrior};
    use gpu_amcs::kinematics::tx60;
    use gpu_amcs::simulate::{
        random_placement, random_poses, simulate_poses_of, Experiment, NonGeometric, TrackerNoise,
    };
    let seed = 2025u64;
    let truth = Experiment::tx60(seed).truth;
    let errors = NonGeometric::draw(&truth, &crate::beyond_geometry::BENT, seed);
    let commanded = random_poses(&truth, 300, seed + 1);
    let actual = crate::beyond_geometry::standing_at(&commanded, &GAPS_DEG);
    let mut data = simulate_poses_of(
        &truth,
        errors.as_ref(),
        &actual,
        &random_placement(seed),
        &TrackerNoise::Isotropic(0.01),
        seed + 2,
    );
    for (p, q) in data.runs[0].points.iter_mut().zip(&commanded) {
        p.q_deg = *q;
    }
    let points = crate::common::measured_points(&data);
    let fit = |mode: JointErrorFit| {
        let opts = ChainOptions {
            noise: NoiseModel::Isotropic { sigma_mm: 0.01 },
            beyond_geometry: mode,
            compensate: false,
            ..ChainOptions::default()
        };
        identify_chain(&points, &tx60(), None, Some(NominalPrior::default()), &opts).unwrap()
    };
    let on = fit(JointErrorFit::On);
    let auto = fit(JointErrorFit::Auto);
    let e = on.joint_errors.as_ref().expect("joint errors kept");
    let b = e.backlash.as_ref().expect("the gaps kept");
    assert!(auto.joint_errors.as_ref().unwrap().backlash.is_none());
    for j in 0..5 {
        let (g, s) = (b.gap_rad[j].to_degrees(), b.sigma_rad[j].to_degrees());
        assert!(
            (g - GAPS_DEG[j]).abs() < 4.0 * s && s < 0.005,
            "J{}: {g} ± {s} against {}",
            j + 1,
            GAPS_DEG[j]
        );
    }
    let (r_on, r_auto) = (on.report.rms_residual_mm, auto.report.rms_residual_mm);
    eprintln!("residual RMS with the gaps {r_on:.4} mm, without {r_auto:.4} mm");
    assert!(r_on < 0.3 * r_auto, "{r_on} against {r_auto}");
    // The model file keeps them.
    let model = gpu_amcs::identify::chain::chain_model(&tx60(), &on, "lashed".into());
    let back = RobotModel::from_toml(&model.to_toml(), "m.toml").unwrap();
    assert_eq!(
        back.joint_errors.unwrap().backlash.unwrap().gap_rad.len(),
        6
    );
}

/// 500 simulated poses of a TX60 with compliance and harmonics (10 µm) in random order, whose
/// joints have the gaps [`GAPS_DEG`]: each joint stands half its gap towards where it came from
/// (the commanded angles written as the measured ones less that half gap). Returns the header
/// and per pose its CSV row and the sides (none at the first pose).
pub(crate) fn simulated_backlash_poses(d: &std::path::Path) -> (String, Vec<(String, [f64; 6])>) {
    use crate::common::{arg, run_ok};
    let raw = arg(d, "raw.csv");
    run_ok(&[
        "simulate",
        "--poses",
        "500",
        "--robot-seed",
        "2025",
        "--seed",
        "3",
        "--compliance",
        "1",
        "--harmonics",
        "1",
        "--tracker-sigma",
        "0.01",
        "-o",
        &raw,
    ]);
    let text = std::fs::read_to_string(&raw).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().to_string();
    assert!(header.starts_with("q1,q2,q3,q4,q5,q6,"), "{header}");
    let mut prev: Option<Vec<f64>> = None;
    let rows = lines
        .map(|l| {
            let mut f: Vec<String> = l.split(',').map(str::to_string).collect();
            let q: Vec<f64> = f[..6].iter().map(|v| v.parse().unwrap()).collect();
            let mut sides = [0.0; 6];
            if let Some(p) = &prev {
                for j in 0..6 {
                    sides[j] = (q[j] - p[j]).signum();
                    f[j] = format!("{}", q[j] - 0.5 * GAPS_DEG[j] * sides[j]);
                }
            }
            prev = Some(q);
            (f.join(","), sides)
        })
        .collect();
    (header, rows)
}

/// The honesty of a model with backlash whether the sides are known or not, on a simulated TX60
/// whose joints have backlash (with compliance and harmonics): 500 poses in random order, each
/// joint standing half its gap towards where it came from (the commanded angles written as the
/// measured ones less that half gap), the first 300 identified, the last 200 checked by
/// `validate` without their sides. With `--beyond-geometry` the model keeps the gaps and a term
/// for unknown sides, which `validate` uses at these poses; the same model without that term
/// draws the sides instead (as a model file written before it did). Both are honest here
/// (measured: 95.x % and 95.0 %, PIT of the max 0.4x and 0.42); the default (no backlash check:
/// the discrepancy term holds it) covers 91.5 % and its max lands above the 99th percentile in
/// 20 % of the subsets.
#[test]
fn a_model_with_backlash_is_honest_whether_the_sides_are_known_or_not() {
    use crate::common::{arg, run_ok, tmpdir};
    let d = tmpdir("backlash_honesty");
    let (train, test) = (arg(&d, "train.csv"), arg(&d, "test.csv"));
    let (header, rows) = simulated_backlash_poses(&d);
    let rows: Vec<String> = rows.into_iter().map(|(r, _)| r).collect();
    let write = |path: &str, r: &[String]| {
        std::fs::write(path, format!("{header}\n{}\n", r.join("\n"))).unwrap()
    };
    write(&train, &rows[..300]);
    write(&test, &rows[300..]);
    let validate = |model: &str, tag: &str| -> (f64, f64) {
        let json = arg(&d, &format!("v-{tag}.json"));
        // (the file written below has no provenance that records the tracker frame)
        let frame = ["--frame", "measurement"];
        run_ok(
            &[
                &["validate", "--model", model, &test, "--json", &json][..],
                &frame,
            ]
            .concat(),
        );
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        let t = &v["predictive_check"]["with_term"];
        (
            t["coverage_95"].as_f64().unwrap(),
            t["pit_max_mean"].as_f64().unwrap(),
        )
    };
    let check = |mode: &str| -> (f64, f64) {
        let model = arg(&d, &format!("m-{mode}.toml"));
        run_ok(&[
            "identify",
            &train,
            &format!("--beyond-geometry={mode}"),
            "-o",
            &model,
        ]);
        validate(&model, mode)
    };
    let (centre, pit_centre) = check("on");
    // The same model without its term for unknown sides: the sides are drawn.
    let mut m = RobotModel::from_file(std::path::Path::new(&arg(&d, "m-on.toml"))).unwrap();
    let b = m.joint_errors.as_mut().and_then(|e| e.backlash.as_mut());
    assert!(b.expect("the gaps are kept").sides_unknown.take().is_some());
    std::fs::write(arg(&d, "m-drawn.toml"), m.to_toml()).unwrap();
    let (on, pit_on) = validate(&arg(&d, "m-drawn.toml"), "drawn");
    let at_centre = |tag: &str| {
        let text = std::fs::read_to_string(arg(&d, &format!("v-{tag}.json"))).unwrap();
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        v["predictive_check"]["at_centre"].as_u64().unwrap()
    };
    assert_eq!((at_centre("on"), at_centre("drawn")), (200, 0));
    let (auto, pit_auto) = check("auto");
    // URDF cannot hold the gaps: the export says so, with the largest.
    let o = crate::common::run(&[
        "export",
        "--model",
        &arg(&d, "m-on.toml"),
        "--urdf",
        &arg(&d, "on.urdf"),
    ]);
    let err = crate::common::stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("and its backlash (gaps up to 0.05"), "{err}");
    // Task points with the sides the program arrives from (s1..s6): the spread the sides gave
    // goes, the mean stays near; a value that is no side, and sides for a model without
    // backlash, are refused naming the file.
    let q = "q1,q2,q3,q4,q5,q6";
    let rows = ["0,10,80,0,30,0", "20,-40,90,10,45,5", "-30,60,100,0,-20,90"];
    let (plain_pts, sided_pts, bad_pts) =
        (arg(&d, "pts.csv"), arg(&d, "sided.csv"), arg(&d, "bad.csv"));
    std::fs::write(&plain_pts, format!("{q}\n{}\n", rows.join("\n"))).unwrap();
    let sided: Vec<String> = rows.iter().map(|r| format!("{r},1,-1,1,-1,1,-1")).collect();
    std::fs::write(
        &sided_pts,
        format!("{q},s1,s2,s3,s4,s5,s6\n{}\n", sided.join("\n")),
    )
    .unwrap();
    std::fs::write(&bad_pts, format!("{q},s2\n{},2\n", rows[0])).unwrap();
    let u = |model: &str, pts: &str| -> f64 {
        let j = arg(&d, "u.json");
        run_ok(&[
            "mcs",
            "--model",
            &arg(&d, model),
            "--points-file",
            pts,
            "--draws",
            "20000",
            "--backend",
            "cpu",
            "-q",
            "--no-discrepancy",
            "--json",
            &j,
        ]);
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&j).unwrap()).unwrap();
        v["result"]["std_uncertainty"].as_f64().unwrap()
    };
    let (u_drawn, u_known) = (u("m-drawn.toml", &plain_pts), u("m-on.toml", &sided_pts));
    // The note says which the analysis does: the term for unknown sides at points without
    // them, or at points with some but not all.
    let partial = arg(&d, "partial.csv");
    let mut part: Vec<String> = sided.clone();
    part[1] = format!("{},0,-1,1,-1,1,-1", rows[1]);
    std::fs::write(
        &partial,
        format!("{q},s1,s2,s3,s4,s5,s6\n{}\n", part.join("\n")),
    )
    .unwrap();
    let note = |pts: &str| -> String {
        let out = run_ok(&[
            "mcs",
            "--model",
            &arg(&d, "m-on.toml"),
            "--points-file",
            pts,
            "--draws",
            "2000",
            "--backend",
            "cpu",
        ]);
        let line = out.lines().find(|l| l.contains("joint errors drawn"));
        line.unwrap_or_else(|| panic!("no joint errors note: {out}"))
            .to_string()
    };
    let unknown = note(&plain_pts);
    assert!(unknown.contains("sides not known at the test points: each joint is taken at the centre of its gap, and the model's term for unknown sides"), "{unknown}");
    let some = note(&partial);
    assert!(
        some.contains("sides given in full at 2 of the 3 test points and used there; at the other 1 each joint is taken at the centre of its gap")
            && some.ends_with("(5 sides given at those points are not used)"),
        "{some}"
    );
    assert!(note(&sided_pts).ends_with("its sides given at every point"));
    eprintln!("w's standard uncertainty: sides drawn {u_drawn:.5} mm, known {u_known:.5} mm");
    assert!(u_known < 0.5 * u_drawn, "{u_known} against {u_drawn}");
    let o = crate::common::run(&[
        "mcs",
        "--model",
        &arg(&d, "m-on.toml"),
        "--points-file",
        &bad_pts,
        "--draws",
        "100",
    ]);
    let err = crate::common::stderr(&o);
    assert!(
        !o.status.success() && err.contains("s2 = '2' is not a side") && err.contains("line 2"),
        "{err}"
    );
    let o = crate::common::run(&[
        "mcs",
        "--model",
        &arg(&d, "m-auto.toml"),
        "--points-file",
        &sided_pts,
        "--draws",
        "100",
    ]);
    let err = crate::common::stderr(&o);
    assert!(!o.status.success() && err.contains("backlash"), "{err}");
    eprintln!(
        "term for unknown sides: {centre} (PIT {pit_centre}); gaps drawn: {on} (PIT {pit_on}); \
         held by the term: {auto} (PIT {pit_auto})"
    );
    // 200 poses tell coverage to ±3.1 % at 2σ around 95 %.
    for (c, pit) in [(centre, pit_centre), (on, pit_on)] {
        assert!((0.919..=0.985).contains(&c), "{c}");
        assert!((0.3..=0.65).contains(&pit), "{pit}");
    }
    assert!(auto < on && pit_auto > pit_on + 0.15, "{auto} {pit_auto}");
}

/// Sides known at the test points (`Problem::set_known_sides`): a known side turns its joint by
/// that side's `±h` in every draw, an unknown one keeps its draw. With J1's and J2's sides
/// known everywhere, every draw's errors are forward kinematics of those sides; with J1's
/// known and J2's not, J2 still takes either side half the time.
#[test]
fn known_sides_turn_their_joints_in_every_draw() {
    let gaps = [0.08, 0.05, 0.0, 0.0, 0.0, 0.0];
    let seed = 13;
    let base = Problem::new(
        only_backlash(&gaps),
        &points(),
        &Reference::Calibrated,
        seed,
    )
    .unwrap();
    let h: Vec<f64> = gaps.iter().map(|g| 0.5 * f64::to_radians(*g)).collect();
    let m = base.n_points();
    let error_of = |j: usize, s: &[f64]| -> f64 {
        let q: Vec<f64> = (0..6)
            .map(|i| base.chain_points[j][i] + s[i] * h[i])
            .collect();
        let p = position(&base.model.params, &base.model.tool, &q);
        let r = base.reference[j];
        ((p[0] - r[0]).powi(2) + (p[1] - r[1]).powi(2) + (p[2] - r[2]).powi(2)).sqrt()
    };
    let side_of = |j: usize, i: usize| if (j + i).is_multiple_of(2) { 1.0 } else { -1.0 };
    let all: Vec<gpu_amcs::kinematics::Joints> = (0..m)
        .map(|j| {
            gpu_amcs::kinematics::Joints::from_fn(6, |i| if i < 2 { side_of(j, i) } else { 0.0 })
        })
        .collect();
    let mut pb = base.clone();
    pb.set_known_sides(&all).unwrap();
    let n = 256;
    let (mut w, mut e) = (vec![0.0; n], vec![0.0; n * m]);
    CpuEvaluator::new(pb.clone())
        .evaluate(7, &mut w, Some(&mut e))
        .unwrap();
    for k in 0..n {
        for j in 0..m {
            let want = error_of(j, &[side_of(j, 0), side_of(j, 1), 0.0, 0.0, 0.0, 0.0]);
            assert!((e[k * m + j] - want).abs() <= 1e-9, "draw {k} point {j}");
        }
    }
    // The point form agrees.
    let t = pb.joint_errors.as_ref().unwrap();
    let mut e1 = vec![0.0; m];
    let d = vec![0.0; pb.sampler.space().len()];
    pb.errors_with_joint_errors(&d, &t.draw(9), &mut e1);
    assert!((e1[0] - e[0]).abs() <= 1e-9);
    // J1 known, J2 drawn.
    let j1: Vec<gpu_amcs::kinematics::Joints> = (0..m)
        .map(|j| {
            gpu_amcs::kinematics::Joints::from_fn(6, |i| if i == 0 { side_of(j, 0) } else { 0.0 })
        })
        .collect();
    let mut pb1 = base.clone();
    pb1.set_known_sides(&j1).unwrap();
    let n = 2000;
    let (mut w, mut e) = (vec![0.0; n], vec![0.0; n * m]);
    CpuEvaluator::new(pb1)
        .evaluate(7, &mut w, Some(&mut e))
        .unwrap();
    for j in 0..m {
        let plus = error_of(j, &[side_of(j, 0), 1.0, 0.0, 0.0, 0.0, 0.0]);
        let minus = error_of(j, &[side_of(j, 0), -1.0, 0.0, 0.0, 0.0, 0.0]);
        let mut up = 0;
        for k in 0..n {
            let v = e[k * m + j];
            let near = |x: f64| (v - x).abs() <= 1e-9;
            assert!(near(plus) || near(minus), "point {j}: {v} is neither side");
            up += usize::from(near(plus));
        }
        // binomial σ = √(2000·¼) ≈ 22: 5σ
        assert!(up.abs_diff(n / 2) <= 112, "point {j}: {up} of {n}");
    }
    // Wrong shapes and values are refused; a model without backlash has none to turn.
    let mut bad = all.clone();
    bad[1][0] = 0.5;
    assert!(base
        .clone()
        .set_known_sides(&bad)
        .unwrap_err()
        .to_string()
        .contains("not −1, 0 or +1"));
    assert!(base.clone().set_known_sides(&all[..2]).is_err());
    let mut plain = Problem::new(
        model_with_joint_errors(0.0),
        &points(),
        &Reference::Calibrated,
        1,
    )
    .unwrap();
    let err = plain.set_known_sides(&all).unwrap_err().to_string();
    assert!(err.contains("joint_errors.backlash_deg"), "{err}");
}
