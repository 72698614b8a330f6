//! Sensitivity and tail probabilities in the measurement frame: the base placement's six inputs
//! are drawn with the 33 (docs/METHOD.md §2.8), checked against closed forms and against the
//! properties of the pick-freeze rows.

use gpu_amcs::engine::{CpuEvaluator, Evaluator, PickFreeze, PlacementSpread, Problem, Reference};
use gpu_amcs::kinematics::{tx60, BaseTransform, Joints, Layout, RobotModel, Uncertainty};
use gpu_amcs::mc::sensitivity::{run_sensitivity, SensitivityOptions};
use gpu_amcs::mc::tail::{run_tail, TailOptions};
use gpu_amcs::sampling::{Philox, ALL_NORMALS};

/// The six-joint TX60's uncertain inputs (33) and inputs with the placement (39).
const N_UNCERTAIN: usize = 33;
const N_WITH_BASE: usize = 39;

const POINTS: [[f64; 6]; 3] = [
    [10.0, -20.0, 90.0, 0.0, 30.0, 0.0],
    [-40.0, 10.0, 60.0, 20.0, -30.0, 50.0],
    [70.0, 30.0, 100.0, -45.0, 60.0, -90.0],
];

/// [`POINTS`] as configurations.
fn points() -> Vec<Joints> {
    POINTS.iter().map(|&q| q.into()).collect()
}

/// The TX60 placed 2 m from the tracker and turned, with the 39 × 39 covariance `c` (internal
/// units: mm and radians).
fn placed(c: Vec<f64>) -> RobotModel {
    let mut m = tx60();
    m.tool = [30.0, -20.0, 80.0];
    m.tool_sigma = [0.0; 3];
    m.base = Some(BaseTransform {
        xyz: [2000.0, 100.0, 0.0],
        rpy: [0.05, -0.02, 1.2],
    });
    m.uncertainty = Uncertainty::from_matrix(Layout::SIX.measured(), c);
    m
}

/// `∫ f(x) φ(x) dx` by the trapezoid rule on [−9, 9] (error far below the Monte Carlo's).
fn gauss(f: impl Fn(f64) -> f64) -> f64 {
    let n = 3600;
    let h = 18.0 / n as f64;
    (0..=n)
        .map(|i| {
            let x = -9.0 + i as f64 * h;
            let wt = if i == 0 || i == n { 0.5 } else { 1.0 };
            wt * f(x) * (-0.5 * x * x).exp()
        })
        .sum::<f64>()
        * h
        / (2.0 * std::f64::consts::PI).sqrt()
}

/// Only base x and y uncertain (σx = 0.02, σy = 0.01 mm): the drawn placement moves every point
/// by the same (δx, δy) turned by the mean rotation, so `w = √(δx² + δy²)` exactly. Subset
/// simulation's P_f at 0.1 mm (≈ 6e-7) matches the one-dimensional integral
/// `∫ φ(x) Pr[σy²Y² ≥ l² − σx²x²] dx` within 3 reported CoVs, and the Sobol indices of base_x
/// and base_y match `S_x = V(E[w | X]) / V(w)` and `S_T,x = 1 − S_y` by quadrature within 4
/// bootstrap standard errors; the placement group holds everything.
#[test]
fn placement_inputs_have_their_closed_forms() {
    let (sx, sy) = (0.02, 0.01);
    let n = N_WITH_BASE;
    let mut c = vec![0.0; n * n];
    c[33 * n + 33] = sx * sx;
    c[34 * n + 34] = sy * sy;
    let pb = Problem::new(placed(c), &points(), &Reference::Calibrated, 5).unwrap();
    // w is the length of the translation at every draw.
    let spread = PlacementSpread::of(&pb).unwrap().unwrap();
    let gen = Philox::new(pb.seed);
    let mut ev = CpuEvaluator::new(pb.clone());
    assert_eq!(ev.offset_width(), N_WITH_BASE);
    let mut w = vec![0.0; 100];
    ev.evaluate(0, &mut w, None).unwrap();
    for (k, wk) in w.iter().enumerate() {
        let d = spread.deltas(&gen, k as u64);
        assert!((wk - d[33].hypot(d[34])).abs() < 1e-9, "{wk} vs {d:?}");
    }

    // Tail: P(w ≥ l).
    let l: f64 = 0.1;
    let upper = gpu_amcs::identify::noise::normal_upper_tail;
    let exact = gauss(|x| {
        let r = l * l - sx * sx * x * x;
        if r <= 0.0 {
            1.0
        } else {
            2.0 * upper(r.sqrt() / sy)
        }
    });
    let opts = TailOptions {
        thresholds: vec![l],
        target_cov: 0.1,
        samples_per_level: 2000,
        max_evaluations: 2_000_000,
        ..TailOptions::default()
    };
    let t = run_tail(&mut CpuEvaluator::new(pb.clone()), &pb, &opts, None).unwrap();
    assert_eq!(t.dimension, 2);
    let e = &t.estimates[0];
    let cov = e.cov.unwrap();
    eprintln!(
        "placement tail: P_f {:.4e} vs exact {exact:.4e} (CoV {cov:.3})",
        e.p_f
    );
    assert!(
        (e.p_f / exact - 1.0).abs() < 3.0 * cov,
        "{} vs {exact}",
        e.p_f
    );

    // Sobol indices: g(x) = E_Y √(σx² x² + σy² Y²), and symmetrically for y.
    let mean = gauss(|x| gauss(|y| (sx * sx * x * x + sy * sy * y * y).sqrt()));
    let var = sx * sx + sy * sy - mean * mean;
    let first = |a: f64, b: f64| {
        gauss(|x| gauss(|y| (a * a * x * x + b * b * y * y).sqrt()).powi(2)) - mean * mean
    };
    let (s_x, s_y) = (first(sx, sy) / var, first(sy, sx) / var);
    let (t_x, t_y) = (1.0 - s_y, 1.0 - s_x);
    let opts = SensitivityOptions {
        draws: 1 << 14,
        ..SensitivityOptions::default()
    };
    let r = run_sensitivity(&pb, &mut CpuEvaluator::new(pb.clone()), &opts).unwrap();
    assert_eq!(r.parameters, ["base_x", "base_y"]);
    let q = r.w();
    for (input, s, t) in [(&q.inputs[0], s_x, t_x), (&q.inputs[1], s_y, t_y)] {
        eprintln!(
            "{}: S {:.4} ± {:.4} (exact {s:.4}), S_T {:.4} ± {:.4} (exact {t:.4})",
            input.name,
            input.first_order.value,
            input.first_order.std_error.unwrap(),
            input.total.value,
            input.total.std_error.unwrap()
        );
        assert!((input.first_order.value - s).abs() < 4.0 * input.first_order.std_error.unwrap());
        assert!((input.total.value - t).abs() < 4.0 * input.total.std_error.unwrap());
    }
    let group = q
        .groups
        .iter()
        .find(|g| g.name == "base placement")
        .unwrap();
    assert_eq!(group.members, ["base_x", "base_y"]);
    assert!((group.total.value - 1.0).abs() < 4.0 * group.total.std_error.unwrap() + 1e-9);
}

/// A 39 × 39 covariance with parameters, the tool and every placement input uncertain, base x
/// correlated with θ2 and base yaw with α3.
fn correlated() -> Vec<f64> {
    let n = N_WITH_BASE;
    let mut c = vec![0.0; n * n];
    let sig: Vec<(usize, f64)> = vec![
        (1, 1e-3),
        (7, 2e-3),
        (12, 0.02),
        (18, 5e-4),
        (31, 0.01),
        (33, 0.03),
        (34, 0.02),
        (35, 0.01),
        (36, 2e-4),
        (37, 1e-4),
        (38, 3e-4),
    ];
    for &(i, s) in &sig {
        c[i * n + i] = s * s;
    }
    for (i, j, rho) in [(1, 33, 0.6), (12, 38, -0.4)] {
        let v = rho * c[i * n + i].sqrt() * c[j * n + j].sqrt();
        c[i * n + j] = v;
        c[j * n + i] = v;
    }
    c
}

/// Offset rows of 39 inputs equal to a draw's placement deltas give that draw's `w`; a
/// pick-freeze row with mask 0 is draw `a` and with every bit draw `b`; a row that takes only
/// the placement's normals from `b` keeps the 33 inputs of `a` (they come first in the Cholesky
/// order) and moves the placement; a row of 33 entries is refused by shape.
#[test]
fn placement_rows_are_consistent() {
    let mut m = placed(correlated());
    m.tool_sigma = [0.0, 0.01, 0.0];
    let pb = Problem::new(m, &points(), &Reference::Calibrated, 9).unwrap();
    let spread = PlacementSpread::of(&pb).unwrap().unwrap();
    let gen = Philox::new(pb.seed);
    let mut ev = CpuEvaluator::new(pb.clone());
    let rows = 256;
    let mut wd = vec![0.0; rows];
    ev.evaluate(100, &mut wd, None).unwrap();
    let offsets: Vec<f64> = (0..rows as u64)
        .flat_map(|k| spread.deltas(&gen, 100 + k)[..N_WITH_BASE].to_vec())
        .collect();
    let mut wo = vec![0.0; rows];
    ev.evaluate_offsets(&offsets, &mut wo, None).unwrap();
    for (a, b) in wd.iter().zip(&wo) {
        assert!((a - b).abs() < 1e-10, "{a} vs {b}");
    }
    assert!(ev
        .evaluate_offsets(&vec![0.0; rows * N_UNCERTAIN], &mut wo, None)
        .is_err());

    let placement_bits = 0x3f_u64 << N_UNCERTAIN;
    let masks = [
        0,
        ALL_NORMALS,
        placement_bits,
        ALL_NORMALS & !placement_bits,
    ];
    let (a0, b0) = (100u64, 1u64 << 50);
    let request = PickFreeze {
        first: a0,
        b_first: b0,
        count: rows,
        masks: &masks,
    };
    let mut pf = vec![0.0; request.rows()];
    ev.evaluate_pick_freeze(&request, &mut pf).unwrap();
    let mut wb = vec![0.0; rows];
    ev.evaluate(b0, &mut wb, None).unwrap();
    for r in 0..rows {
        assert!((pf[r] - wd[r]).abs() < 1e-10);
        assert!((pf[rows + r] - wb[r]).abs() < 1e-10);
        let (a, b) = (a0 + r as u64, b0 + r as u64);
        let (da, db) = (spread.deltas(&gen, a), spread.deltas(&gen, b));
        for (mask, from_b) in [
            (placement_bits, false),
            (ALL_NORMALS & !placement_bits, true),
        ] {
            let d = spread.pick_freeze_deltas(&gen, a, b, mask);
            let keep = if from_b { &db } else { &da };
            assert_eq!(d[..N_UNCERTAIN], keep[..N_UNCERTAIN], "row {r}");
            assert_ne!(
                d[N_UNCERTAIN..N_WITH_BASE],
                keep[N_UNCERTAIN..N_WITH_BASE],
                "row {r}"
            );
        }
        // Matrix 2's rows are the offsets of those deltas.
        let d = spread.pick_freeze_deltas(&gen, a, b, placement_bits);
        let mut one = [0.0];
        ev.evaluate_offsets(&d[..N_WITH_BASE], &mut one, None)
            .unwrap();
        assert!((pf[2 * rows + r] - one[0]).abs() < 1e-10);
    }
}
