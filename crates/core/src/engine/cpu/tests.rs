//! Tests of the CPU evaluator against direct forward kinematics and across its paths.

use super::*;
const NP: usize = 30;
const NU: usize = 33;
use crate::engine::Reference;
use crate::kinematics::tx60;

fn problem() -> Problem {
    let pts = [
        [10.0, -20.0, 30.0, 40.0, 50.0, 60.0],
        [-100.0, 45.0, 90.0, -30.0, 20.0, 10.0],
        [0.0; 6],
    ];
    Problem::new(tx60(), &pts, &Reference::Calibrated, 42).unwrap()
}

/// A base transform moves both the analysed and the reference positions rigidly, so the
/// errors the evaluator computes in the base frame equal those of the positions in the
/// description's frame (KUKA KR 6 with its base Rx(180°); f64 rounding of 1000 mm values
/// through one rotation, 1e-9 mm).
#[test]
fn errors_are_invariant_to_the_base_transform() {
    let mut m = crate::presets::kr6r700sixx();
    assert!(m.base.is_some());
    let mut s = crate::kinematics::Params::filled(NP, 0.0);
    for (i, v) in s.iter_mut().enumerate() {
        if m.fixed[i / 5].kind() != crate::kinematics::param_kind(i) {
            *v = if crate::kinematics::param_kind(i).is_angle() {
                1e-4
            } else {
                0.02
            };
        }
    }
    m.uncertainty = crate::kinematics::Uncertainty::Independent(s);
    m.tool_sigma = [0.01; 3];
    let pts = [[10.0, -20.0, 30.0, 40.0, 50.0, 60.0], [0.0; 6]];
    let pb = Problem::new(m.clone(), &pts, &Reference::Calibrated, 3).unwrap();
    let mut ev = CpuEvaluator::new(pb.clone());
    let (mut w, mut e) = (vec![0.0; 9], vec![0.0; 18]);
    ev.evaluate(0, &mut w, Some(&mut e)).unwrap();
    for k in 0..9 {
        let mut drawn = m.clone();
        drawn.params = pb.sampler.draw(k as u64);
        let t = pb.sampler.tool_deltas(k as u64);
        drawn.tool = std::array::from_fn(|c| m.tool[c] + t[c]);
        for (j, q) in pb.points.iter().enumerate() {
            let (a, b) = (drawn.world_position(q), m.world_position(q));
            let d = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
            assert!(
                (d - e[k * 2 + j]).abs() < 1e-9,
                "{k} {j}: {d} vs {}",
                e[k * 2 + j]
            );
            assert!(d > 1e-3);
        }
    }
}

/// A tool spread: every draw's errors equal direct forward kinematics of the drawn
/// parameters with the drawn tool point (f64 throughout; 1e-10 mm covers the series and
/// summation order), and the tool's offset changes them.
#[test]
fn tool_spread_matches_direct_forward_kinematics() {
    let mut m = tx60();
    m.tool = [40.0, -10.0, 120.0];
    m.tool_sigma = [0.01, 0.02, 0.005];
    let pts = [[10.0, -20.0, 30.0, 40.0, 50.0, 60.0], [0.0; 6]];
    let pb = Problem::new(m, &pts, &Reference::Calibrated, 9).unwrap();
    let mut ev = CpuEvaluator::new(pb.clone());
    let n = 21;
    let (mut w, mut e) = (vec![0.0; n], vec![0.0; 2 * n]);
    ev.evaluate(77, &mut w, Some(&mut e)).unwrap();
    for i in 0..n {
        let k = 77 + i as u64;
        let (params, tool) = (pb.sampler.draw(k), pb.sampler.tool_deltas(k));
        let direct = pb.point_errors_at(&params, &tool);
        let without = pb.point_errors(&params);
        for j in 0..2 {
            assert!((direct[j] - e[i * 2 + j]).abs() < 1e-10, "{i} {j}");
            assert!((without[j] - e[i * 2 + j]).abs() > 1e-6, "{i} {j}");
        }
    }
}

#[test]
fn matches_direct_forward_kinematics() {
    let pb = problem();
    let mut ev = CpuEvaluator::new(pb.clone());
    let n = 37; // not a multiple of the lane count
    let mut w = vec![0.0; n];
    let mut e = vec![0.0; n * 3];
    ev.evaluate(1000, &mut w, Some(&mut e)).unwrap();
    for i in 0..n {
        let direct = pb.point_errors(&pb.sampler.draw(1000 + i as u64));
        for j in 0..3 {
            assert!((direct[j] - e[i * 3 + j]).abs() < 1e-10, "{i} {j}");
        }
        let wmax = direct.iter().cloned().fold(0.0, f64::max);
        assert!((wmax - w[i]).abs() < 1e-10);
    }
}

#[test]
fn batch_split_and_simd_do_not_change_results() {
    let mut ev = CpuEvaluator::new(problem());
    let mut all = vec![0.0; 1000];
    ev.evaluate(0, &mut all, None).unwrap();
    let mut parts = vec![0.0; 1000];
    ev.evaluate(0, &mut parts[..333], None).unwrap();
    ev.evaluate(333, &mut parts[333..], None).unwrap();
    assert_eq!(all, parts);
    if ev.avx2 {
        ev.avx2 = false; // the portable kernel must give the same bits
        let mut other = vec![0.0; 1000];
        ev.evaluate(0, &mut other, None).unwrap();
        assert_eq!(all, other);
    }
}

/// Rows equal to the sampler's own offsets give the bits of the counter draws, per point
/// too, for any row count (not a multiple of the lane or task size).
#[test]
fn offset_rows_of_the_draws_equal_the_draws() {
    let pb = problem();
    let mut ev = CpuEvaluator::new(pb.clone());
    let (first, n, m) = (5_000u64, 2 * CHUNK + 13, 3);
    let mut rows = vec![0.0; n * NU];
    for (i, row) in rows.chunks_exact_mut(NU).enumerate() {
        let mut d = [0.0; NU];
        pb.sampler.deltas(first + i as u64, &mut d);
        row.copy_from_slice(&d);
    }
    let (mut w1, mut e1) = (vec![0.0; n], vec![0.0; n * m]);
    let (mut w2, mut e2) = (vec![0.0; n], vec![0.0; n * m]);
    ev.evaluate(first, &mut w1, Some(&mut e1)).unwrap();
    ev.evaluate_offsets(&rows, &mut w2, Some(&mut e2)).unwrap();
    assert_eq!(w1, w2);
    assert_eq!(e1, e2);
    let mut w3 = vec![0.0; n];
    ev.evaluate_offsets(&rows, &mut w3, None).unwrap();
    assert_eq!(w1, w3);
}

/// Pick-freeze rows equal the offset rows of the sampler's pick-freeze offsets, to the
/// bit, for matrices that straddle lane blocks and tasks; mask 0 gives the draws.
#[test]
fn pick_freeze_rows_equal_their_offset_rows() {
    use crate::engine::PickFreeze;
    use crate::sampling::ALL_NORMALS;
    let pb = problem();
    let mut ev = CpuEvaluator::new(pb.clone());
    let masks = [0, ALL_NORMALS, 1 << 5, (1 << 12) | (1 << 17), 0xff_0000];
    let request = PickFreeze {
        first: (1 << 32) - 100, // the draw index carries into the high word
        b_first: (1 << 63) + (1 << 32) - 100,
        count: CHUNK + 5,
        masks: &masks,
    };
    let n = request.rows();
    let mut rows = vec![0.0; n * NU];
    for (r, row) in rows.chunks_exact_mut(NU).enumerate() {
        let (a, b, m) = request.row(r);
        let mut d = [0.0; NU];
        pb.sampler.pick_freeze_deltas(a, b, m, &mut d);
        row.copy_from_slice(&d);
    }
    let (mut w1, mut w2) = (vec![0.0; n], vec![0.0; n]);
    ev.evaluate_pick_freeze(&request, &mut w1).unwrap();
    ev.evaluate_offsets(&rows, &mut w2, None).unwrap();
    assert_eq!(w1, w2);
    let mut wa = vec![0.0; request.count];
    ev.evaluate(request.first, &mut wa, None).unwrap();
    assert_eq!(w1[..request.count], wa[..]);
    ev.evaluate(request.b_first, &mut wa, None).unwrap();
    assert_eq!(w1[request.count..2 * request.count], wa[..]);
    assert_ne!(w1[2 * request.count..3 * request.count], wa[..]);
}

/// A large angular offset (beyond the series range) against direct forward kinematics.
#[test]
fn large_offsets_match_direct_forward_kinematics() {
    let pb = problem();
    let mut ev = CpuEvaluator::new(pb.clone());
    let mut rows = vec![0.0; 2 * NU];
    rows[5] = 0.3; // θ2, rad
    rows[NU + 13] = -0.02; // α3, rad
    rows[NU + 7] = 1.5; // a2, mm
    rows[NU + NP + 1] = -0.7; // tool y, mm
    let (mut w, mut e) = (vec![0.0; 2], vec![0.0; 6]);
    ev.evaluate_offsets(&rows, &mut w, Some(&mut e)).unwrap();
    for (i, row) in rows.chunks_exact(NU).enumerate() {
        let params: [f64; NP] = std::array::from_fn(|p| pb.sampler.mean[p] + row[p]);
        let tool = std::array::from_fn(|k| row[NP + k]);
        let direct = pb.point_errors_at(&params, &tool);
        for j in 0..3 {
            assert!((direct[j] - e[i * 3 + j]).abs() < 1e-9, "{i} {j}");
        }
        assert!(w[i] > 1.0, "the offsets move the tool by over a millimetre");
    }
}

/// A model with a discrepancy term: every counter draw's point errors are the kinematic errors
/// of direct forward kinematics with the term's `(r, c)` of that draw and point applied
/// (`crate::discrepancy`), and offset rows (which have no draw) leave it out.
#[test]
fn discrepancy_term_matches_its_point_form() {
    let mut m = tx60();
    m.discrepancy = Some(
        crate::discrepancy::Discrepancy {
            residual_norms: (0..25).map(|i| 0.01 * f64::from(i)).collect(),
            robot_share: 0.64,
            noise: crate::discrepancy::NoiseSource::Stated,
            noise_sigma_mm: Some(0.01),
            compensation: None,
        }
        .checked()
        .unwrap(),
    );
    let pts = [
        [10.0, -20.0, 30.0, 40.0, 50.0, 60.0],
        [-100.0, 45.0, 90.0, -30.0, 20.0, 10.0],
        [0.0; 6],
    ];
    let pb = Problem::new(m, &pts, &Reference::Calibrated, 42).unwrap();
    let dd = pb.discrepancy.clone().expect("the model's term is drawn");
    assert!((dd.radii()[24] - 0.24).abs() < 1e-15);
    // the draws' sizes: around √0.64 = 0.8 of the norms
    assert!(
        (dd.factors()[128] - 0.8).abs() < 0.1,
        "{}",
        dd.factors()[128]
    );
    let mut ev = CpuEvaluator::new(pb.clone());
    let n = 37;
    let (mut w, mut e) = (vec![0.0; n], vec![0.0; n * 3]);
    ev.evaluate(5000, &mut w, Some(&mut e)).unwrap();
    let mut moved = 0;
    for i in 0..n {
        let k = 5000 + i as u64;
        let kin = pb.point_errors(&pb.sampler.draw(k));
        for j in 0..3 {
            let want = dd.apply(kin[j], k, j);
            assert!((want - e[i * 3 + j]).abs() < 1e-10, "draw {k} point {j}");
            moved += usize::from((want - kin[j]).abs() > 1e-6);
        }
        let wmax = e[i * 3..i * 3 + 3].iter().cloned().fold(0.0, f64::max);
        assert_eq!(wmax, w[i]);
    }
    assert!(moved > n * 3 / 2, "the term moved only {moved} errors");
    // Without the term: the kinematic errors again.
    let mut plain = CpuEvaluator::new(pb.clone().without_discrepancy());
    plain.evaluate(5000, &mut w, Some(&mut e)).unwrap();
    let kin = pb.point_errors(&pb.sampler.draw(5000));
    assert!((kin[1] - e[1]).abs() < 1e-10);
}

/// Pick-freeze rows of a model with a discrepancy term take the term from the row's `b` draw
/// where the mask has `DISCREPANCY_MASK`, else from `a`: mask 0 gives counter draw `a`, all
/// bits counter draw `b`, the term's bit alone draw `a`'s kinematics with draw `b`'s term.
#[test]
fn pick_freeze_rows_take_the_term_by_its_bit() {
    use crate::engine::{PickFreeze, DISCREPANCY_MASK};
    use crate::sampling::ALL_NORMALS;
    let mut m = tx60();
    m.discrepancy = Some(
        crate::discrepancy::Discrepancy {
            residual_norms: (1..=20).map(|i| 0.004 * f64::from(i)).collect(),
            robot_share: 1.0,
            noise: crate::discrepancy::NoiseSource::Unknown,
            compensation: None,
            noise_sigma_mm: None,
        }
        .checked()
        .unwrap(),
    );
    let pts = [[10.0, -20.0, 30.0, 40.0, 50.0, 60.0], [0.0; 6]];
    let pb = Problem::new(m, &pts, &Reference::Calibrated, 9).unwrap();
    let dd = pb.discrepancy.clone().unwrap();
    let mut ev = CpuEvaluator::new(pb.clone());
    let count = 11;
    let (first, b_first) = (100u64, 5000u64);
    let masks = [0, ALL_NORMALS | DISCREPANCY_MASK, DISCREPANCY_MASK];
    let request = PickFreeze {
        first,
        b_first,
        count,
        masks: &masks,
    };
    let mut w = vec![0.0; request.rows()];
    ev.evaluate_pick_freeze(&request, &mut w).unwrap();
    let mut draws = vec![0.0; count];
    for (s, start) in [(0, first), (1, b_first)] {
        ev.evaluate(start, &mut draws, None).unwrap();
        assert_eq!(&w[s * count..(s + 1) * count], &draws[..], "matrix {s}");
    }
    for r in 0..count {
        let (a, b) = (first + r as u64, b_first + r as u64);
        let kin = pb.point_errors(&pb.sampler.draw(a));
        let want = (0..2).map(|j| dd.apply(kin[j], b, j)).fold(0.0, f64::max);
        assert!((w[2 * count + r] - want).abs() < 1e-10, "row {r}");
    }
}
