//! Tests of the conversion for joint counts other than six: seven-axis arms (the KUKA LBR iiwa
//! 14 R820 and the Franka Emika Panda from their published DH tables) import as seven-joint
//! models, checked against their DH forward kinematics written out here; holds still reduce the
//! count; counts outside 4 to 7 are refused; export writes every joint.

use super::export::{to_ur_calibration, to_urdf, ExportError};
use super::{convert, dh, prove, urdf, ImportError, JointHold, SourceChain};
use crate::kinematics::{Joints, RobotModel};
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use std::f64::consts::FRAC_PI_2;

/// The LBR iiwa 14 R820, standard DH `[θ, d, a, α]` in mm and rad, and its limits (±deg).
const IIWA: [[f64; 4]; 7] = [
    [0.0, 360.0, 0.0, -FRAC_PI_2],
    [0.0, 0.0, 0.0, FRAC_PI_2],
    [0.0, 420.0, 0.0, FRAC_PI_2],
    [0.0, 0.0, 0.0, -FRAC_PI_2],
    [0.0, 400.0, 0.0, -FRAC_PI_2],
    [0.0, 0.0, 0.0, FRAC_PI_2],
    [0.0, 126.0, 0.0, 0.0],
];
const IIWA_LIMITS: [f64; 7] = [170.0, 120.0, 170.0, 120.0, 170.0, 120.0, 175.0];

/// The Panda, Craig's modified DH `[θ_i, d_i, a_{i−1}, α_{i−1}]` in mm and rad, the flange
/// 107 mm along joint 7's axis, and its limits (rad).
const PANDA: [[f64; 4]; 7] = [
    [0.0, 333.0, 0.0, 0.0],
    [0.0, 0.0, 0.0, -FRAC_PI_2],
    [0.0, 316.0, 0.0, FRAC_PI_2],
    [0.0, 0.0, 82.5, FRAC_PI_2],
    [0.0, 384.0, -82.5, -FRAC_PI_2],
    [0.0, 0.0, 0.0, FRAC_PI_2],
    [0.0, 0.0, 88.0, FRAC_PI_2],
];
const PANDA_LIMITS: [(f64, f64); 7] = [
    (-2.8973, 2.8973),
    (-1.7628, 1.7628),
    (-2.8973, 2.8973),
    (-3.0718, -0.0698),
    (-2.8973, 2.8973),
    (-0.0175, 3.7525),
    (-2.8973, 2.8973),
];

fn rz(t: f64) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::identity(),
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), t),
    )
}

fn rx(t: f64) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::identity(),
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), t),
    )
}

/// Standard DH forward kinematics of `rows` at `q` (radians), tip at the last frame's origin.
fn dh_standard(rows: &[[f64; 4]], q: &[f64]) -> [f64; 3] {
    let mut t = Isometry3::identity();
    for (r, qi) in rows.iter().zip(q) {
        t = t * rz(r[0] + qi) * Isometry3::translation(r[2], 0.0, r[1]) * rx(r[3]);
    }
    let p = t * Point3::origin();
    [p.x, p.y, p.z]
}

/// Modified DH forward kinematics of `rows` at `q` (radians), tip at `tool` in the last frame.
fn dh_modified(rows: &[[f64; 4]], q: &[f64], tool: [f64; 3]) -> [f64; 3] {
    let mut t = Isometry3::identity();
    for (r, qi) in rows.iter().zip(q) {
        t = t * rx(r[3]) * Isometry3::translation(r[2], 0.0, 0.0) * rz(r[0] + qi);
        t *= Isometry3::translation(0.0, 0.0, r[1]);
    }
    let p = t * Point3::from(tool);
    [p.x, p.y, p.z]
}

/// Largest distance between the model and `reference` at q = 0 and 500 configurations within
/// the model's limits (radians to both).
fn max_deviation(model: &RobotModel, reference: impl Fn(&[f64]) -> [f64; 3]) -> f64 {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    let n = model.joints();
    (0..=500)
        .map(|k| {
            let q = if k == 0 {
                Joints::filled(n, 0.0)
            } else {
                Joints::from_fn(n, |j| {
                    let (lo, hi) = model.limits_deg[j];
                    (lo + (hi - lo) * rng.random::<f64>()).to_radians()
                })
            };
            let (a, b) = (model.world_position(&q), reference(&q));
            (0..3).map(|c| (a[c] - b[c]).powi(2)).sum::<f64>().sqrt()
        })
        .fold(0.0, f64::max)
}

/// The iiwa's first `rows` rows as a CSV DH table (mm, degrees).
fn iiwa_csv(rows: usize) -> String {
    let mut s = String::from(
        "convention,standard\nunits,mm-deg\nname,LBR iiwa 14 R820\ntheta,d,a,alpha,lower,upper\n",
    );
    for (r, l) in IIWA.iter().zip(IIWA_LIMITS).take(rows) {
        s.push_str(&format!(
            "{},{},{},{},{},{}\n",
            r[0].to_degrees(),
            r[1],
            r[2],
            r[3].to_degrees(),
            -l,
            l
        ));
    }
    s
}

fn iiwa_chain(rows: usize) -> SourceChain {
    dh::parse_csv(&iiwa_csv(rows), "iiwa.csv", "iiwa").unwrap()
}

fn holds(h: &[(&str, f64)]) -> Vec<JointHold> {
    h.iter()
        .map(|(j, a)| JointHold {
            joint: j.to_string(),
            angle_deg: *a,
        })
        .collect()
}

#[test]
fn seven_joint_iiwa_and_panda_import_as_seven_joint_models() {
    let imp = convert(&iiwa_chain(7), "iiwa.csv").unwrap();
    let m = &imp.model;
    assert_eq!(
        (m.joints(), m.params.len(), m.layout().n_params()),
        (7, 35, 35)
    );
    let limits: Vec<f64> = m.limits_deg.iter().map(|l| l.1).collect();
    assert_eq!(limits, IIWA_LIMITS);
    assert_eq!(imp.configurations, super::PROOF_CONFIGURATIONS + 1);
    assert!(imp.max_deviation_mm < 1e-9, "{}", imp.max_deviation_mm);
    assert!(imp.held.is_empty());
    let dev = max_deviation(m, |q| dh_standard(&IIWA, q));
    assert!(dev < 1e-9, "iiwa: 7-joint DH FK {dev:e} mm");
    // The model file of seven joints reads back to the same model.
    let back = RobotModel::from_toml(&imp.to_toml(), "iiwa.toml").unwrap();
    assert_eq!(back.joints(), 7);
    assert!(max_deviation(&back, |q| dh_standard(&IIWA, q)) < 1e-9);

    let mut toml = String::from(
        "convention = \"modified\"\nunits = \"mm-deg\"\nname = \"Panda\"\ntool = [0.0, 0.0, 107.0]\n",
    );
    for (r, (lo, hi)) in PANDA.iter().zip(PANDA_LIMITS) {
        toml.push_str(&format!(
            "[[joint]]\ntheta = {}\nd = {}\na = {}\nalpha = {}\nlimits = [{}, {}]\n",
            r[0].to_degrees(),
            r[1],
            r[2],
            r[3].to_degrees(),
            lo.to_degrees(),
            hi.to_degrees()
        ));
    }
    let imp = convert(
        &dh::parse_toml(&toml, "panda.toml", "panda").unwrap(),
        "panda.toml",
    )
    .unwrap();
    assert_eq!(imp.model.joints(), 7);
    let dev = max_deviation(&imp.model, |q| dh_modified(&PANDA, q, [0.0, 0.0, 107.0]));
    assert!(dev < 1e-9, "Panda: 7-joint DH FK {dev:e} mm");
}

#[test]
fn holds_reduce_the_joint_count_and_are_no_longer_needed_for_seven() {
    // One hold: six joints; three: four.
    for (h, n) in [
        (&[("3", 20.0)][..], 6),
        (&[("3", 0.0), ("5", 10.0)][..], 5),
        (&[("1", 0.0), ("3", 0.0), ("5", -15.0)][..], 4),
    ] {
        let mut c = iiwa_chain(7);
        c.hold(&holds(h), "iiwa.csv").unwrap();
        let imp = convert(&c, "iiwa.csv").unwrap();
        assert_eq!(imp.model.joints(), n, "{h:?}");
        assert_eq!(imp.held.len(), h.len());
        let held: Vec<(usize, f64)> = h
            .iter()
            .map(|(j, a)| (j.parse::<usize>().unwrap() - 1, a.to_radians()))
            .collect();
        let dev = max_deviation(&imp.model, |q| {
            let mut it = q.iter();
            let full: Vec<f64> = (0..7)
                .map(|j| {
                    held.iter()
                        .find(|(k, _)| *k == j)
                        .map_or_else(|| *it.next().unwrap(), |(_, a)| *a)
                })
                .collect();
            dh_standard(&IIWA, &full)
        });
        assert!(dev < 1e-9, "{h:?}: {dev:e} mm");
    }
    // Four holds leave three joints: refused, naming the count and the range, no hold advice.
    let mut c = iiwa_chain(7);
    c.hold(
        &holds(&[("1", 0.0), ("2", 10.0), ("3", 0.0), ("5", 0.0)]),
        "iiwa.csv",
    )
    .unwrap();
    let e = convert(&c, "iiwa.csv").unwrap_err().to_string();
    assert!(
        e.contains("3 revolute joints (joint 4, joint 6, joint 7)") && e.contains("4 to 7"),
        "{e}"
    );
    assert!(!e.contains("hold"), "{e}");
}

#[test]
fn counts_outside_four_to_seven_are_refused_with_the_count_the_range_and_the_holds() {
    // Four joints (the iiwa's first four) convert.
    let imp = convert(&iiwa_chain(4), "four.csv").unwrap();
    assert_eq!(imp.model.joints(), 4);
    assert!(max_deviation(&imp.model, |q| dh_standard(&IIWA[..4], q)) < 1e-9);
    // Three do not.
    let e = convert(&iiwa_chain(3), "three.csv").unwrap_err();
    assert!(matches!(e, ImportError::Chain { .. }), "{e:?}");
    let e = e.to_string();
    assert!(
        e.contains("has 3 revolute joints") && e.contains("4 to 7"),
        "{e}"
    );
    // Nine: hold two (the command line adds its flag to a message that says "hold").
    let mut csv = iiwa_csv(7);
    csv.push_str("0,50,0,90,-100,100\n0,60,0,-90,-100,100\n");
    let c = dh::parse_csv(&csv, "nine.csv", "nine").unwrap();
    assert_eq!(c.joints.len(), 9);
    let e = convert(&c, "nine.csv").unwrap_err().to_string();
    assert!(
        e.contains("has 9 revolute joints")
            && e.contains("joint 9")
            && e.contains("4 to 7")
            && e.contains("hold 2 of them"),
        "{e}"
    );
}

#[test]
fn a_seven_joint_model_exports_every_joint_to_urdf_and_is_refused_as_ur_calibration() {
    let model = convert(&iiwa_chain(7), "iiwa.csv").unwrap().model;
    let text = to_urdf(&model, None);
    for k in 1..=7 {
        assert!(text.contains(&format!("<joint name=\"joint_{k}\" type=\"revolute\">")));
        assert!(text.contains(&format!("<link name=\"link_{k}\"/>")));
    }
    assert!(!text.contains("joint_8"));
    assert!(text.contains("<parent link=\"link_7\"/>\n    <child link=\"tool0\"/>"));
    let back = convert(
        &urdf::parse(&text, "iiwa.urdf", None, None).unwrap(),
        "iiwa.urdf",
    )
    .unwrap();
    assert_eq!(back.model.joints(), 7);
    assert!(max_deviation(&back.model, |q| dh_standard(&IIWA, q)) < 1e-9);
    let e = to_ur_calibration(&model).unwrap_err();
    assert!(matches!(e, ExportError::JointCount { joints: 7 }), "{e:?}");
    assert!(e.to_string().contains("six joints"), "{e}");
}

#[test]
fn the_proof_refuses_a_model_of_another_joint_count() {
    let chain = iiwa_chain(7);
    let six = crate::kinematics::tx60();
    let e = prove(&chain, &six, "iiwa.csv").unwrap_err();
    assert!(matches!(e, ImportError::Chain { .. }), "{e:?}");
}
