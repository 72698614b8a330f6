//! The identification does not depend on how the tracker frame is turned (issue 34): the same
//! poses measured in frames turned so that the robot's base sits 0°, 80° and 89.5° from level
//! (where the placement's roll and yaw turn about nearly one axis) give the same condition
//! number, observability and correlations to 1e-6 relative and the same predictions, and the
//! placement's roll-pitch-yaw covariance the model keeps still predicts the same spread of the
//! target in the measurement frame.

use gpu_amcs::identify::chain::{identify_chain, ChainOptions, ChainResult, MeasuredPoint};
use gpu_amcs::identify::noise::NoiseModel;
use gpu_amcs::identify::NominalPrior;
use gpu_amcs::kinematics::tx60;
use gpu_amcs::simulate::{random_placement, random_poses, simulate_poses, TrackerNoise};
use nalgebra::{Matrix3, Rotation3, Vector3};

/// The simulated poses with positions turned by `q`, identified (10 µm stated).
fn identified(points: &[MeasuredPoint], q: &Matrix3<f64>) -> ChainResult {
    let turned: Vec<MeasuredPoint> = points
        .iter()
        .map(|p| {
            let v = q * Vector3::from(p.position_mm);
            MeasuredPoint {
                payload_kg: 0.0,
                position_mm: [v.x, v.y, v.z],
                ..*p
            }
        })
        .collect();
    let opts = ChainOptions {
        noise: NoiseModel::Isotropic { sigma_mm: 0.01 },
        compensate: false,
        ..ChainOptions::default()
    };
    identify_chain(&turned, &tx60(), None, Some(NominalPrior::default()), &opts).unwrap()
}

#[test]
fn turning_the_tracker_frame_changes_nothing() {
    let mut truth = tx60();
    truth.tool = [30.0, -20.0, 80.0];
    let placement = random_placement(5);
    let configs = random_poses(&truth, 120, 6);
    let data = simulate_poses(
        &truth,
        &configs,
        &placement,
        &TrackerNoise::Isotropic(0.01),
        7,
    );
    let points = crate::common::measured_points(&data);
    // Turns that bring the base's pitch to 80° and 89.5° (then a turn about the vertical).
    let base = Rotation3::from_euler_angles(placement.rpy[0], placement.rpy[1], placement.rpy[2]);
    let turn = |pitch_deg: f64| -> Matrix3<f64> {
        (Rotation3::from_euler_angles(0.0, pitch_deg.to_radians(), 0.3) * base.inverse()).into()
    };
    let reference = identified(&points, &Matrix3::identity());
    let a = &reference.report.identifiability;
    for pitch in [80.0, 89.5] {
        let q = turn(pitch);
        let r = identified(&points, &q);
        let pitch_fitted = r.state.base[4].to_degrees();
        assert!(
            (pitch_fitted - pitch).abs() < 0.1,
            "base pitch {pitch_fitted}"
        );
        let b = &r.report.identifiability;
        let rel = |x: f64, y: f64| (x - y).abs() / x.abs().max(1e-300);
        eprintln!(
            "pitch {pitch}°: condition {} vs {}, O1 {} vs {}, correlated pairs {} vs {}",
            b.condition_number,
            a.condition_number,
            b.o1,
            a.o1,
            b.correlated.len(),
            a.correlated.len()
        );
        assert!(rel(a.condition_number, b.condition_number) < 1e-6);
        assert!(rel(a.o1, b.o1) < 1e-6 && rel(a.o3, b.o3) < 1e-6);
        assert_eq!(a.rank, b.rank);
        assert!(b.null_directions.is_empty());
        assert_eq!(a.correlated.len(), b.correlated.len());
        for (x, y) in a.correlated.iter().zip(&b.correlated) {
            assert_eq!((&x.a, &x.b), (&y.a, &y.b));
            assert!((x.rho - y.rho).abs() < 1e-6, "{x:?} {y:?}");
        }
        // The same predictions, turned.
        for c in configs.iter().take(20) {
            let qr = c.map(f64::to_radians);
            let want = q * Vector3::from(reference.state.predict(&qr));
            let got = Vector3::from(r.state.predict(&qr));
            assert!((want - got).norm() < 1e-6, "{}", (want - got).norm());
        }
        // The roll-pitch-yaw covariance the model keeps, propagated to the target's position
        // (numerical derivatives of the prediction in the file's inputs), gives the same σ as
        // the reference's, turned: the placement's degenerate angles are consistent.
        let spread = |res: &ChainResult, turn: &Matrix3<f64>, qr: &[f64]| -> Matrix3<f64> {
            let n = res.state.n_inputs();
            let cov = nalgebra::DMatrix::from_row_slice(n, n, &res.covariance);
            let mut jac = nalgebra::DMatrix::<f64>::zeros(3, n);
            for i in 0..n {
                let h = if res.state.space().is_angle(i) {
                    1e-7
                } else {
                    1e-4
                };
                let (mut p, mut m) = (res.state, res.state);
                p.set(i, res.state.get(i) + h);
                m.set(i, res.state.get(i) - h);
                let d = (Vector3::from(p.predict(qr)) - Vector3::from(m.predict(qr))) / (2.0 * h);
                jac.set_column(i, &d);
            }
            let c = &jac * cov * jac.transpose();
            let c = Matrix3::from_fn(|a, b| c[(a, b)]);
            turn.transpose() * c * turn
        };
        let qr = configs[3].map(f64::to_radians);
        let (s0, s1) = (
            spread(&reference, &Matrix3::identity(), &qr),
            spread(&r, &q, &qr),
        );
        let scale = s0.trace();
        assert!(
            (s0 - s1).norm() < 1e-3 * scale,
            "{s0} vs {s1} (pitch {pitch}°)"
        );
    }
}

/// `compare` analyses in the frame it is given, as `mcs` does: its MCS moments equal `mcs`'s in
/// each frame (they ignored `--frame base` before), and the two frames differ for a model with
/// an identified placement.
#[test]
fn compare_draws_in_the_frame_it_is_given() {
    use crate::common::{arg, run_ok, tmpdir};
    let d = tmpdir("compare_frame");
    let (poses, model) = (arg(&d, "poses.csv"), arg(&d, "model.toml"));
    run_ok(&["simulate", "--poses", "40", "--seed", "3", "-o", &poses]);
    run_ok(&["identify", &poses, "-o", &model]);
    let moments = |json: &str, at: &[&str]| -> serde_json::Value {
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap();
        at.iter().fold(v, |v, k| v[*k].clone())
    };
    let mut seen = Vec::new();
    for frame in ["measurement", "base"] {
        let (m, c) = (
            arg(&d, &format!("mcs-{frame}.json")),
            arg(&d, &format!("cmp-{frame}.json")),
        );
        let common = [
            "--model",
            &model,
            "--points",
            "5",
            "--draws",
            "20000",
            "--backend",
            "cpu",
            "--frame",
            frame,
        ];
        run_ok(&[&["mcs"][..], &common, &["--json", &m]].concat());
        run_ok(
            &[
                &["compare", "--deltas", "0.05"][..],
                &common,
                &["--json", &c],
            ]
            .concat(),
        );
        let want = moments(&m, &["result", "moments"]);
        assert!(want["mean"].as_f64().unwrap() > 0.0, "{want}");
        assert_eq!(moments(&c, &["mcs", "moments"]), want, "{frame}");
        seen.push(want);
    }
    assert_ne!(
        seen[0], seen[1],
        "the placement's spread is drawn in the measurement frame"
    );
}
