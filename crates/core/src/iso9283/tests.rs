//! Tests of the ISO 9283 figures, test cube and certificate.

use super::*;
use crate::kinematics::position;
#[test]
fn the_test_cube_is_reachable_maximal_and_its_poses_sit_where_the_standard_puts_them() {
    let m = crate::kinematics::tx60();
    let rpy = crate::map::tool_down_rpy_deg(&m);
    let cube = test_cube(&m, Some(rpy)).unwrap();
    eprintln!("{cube:?}");
    assert!(cube.edge_mm > 100.0, "{cube:?}");
    let (corners, poses) = cube_points(cube.centre_mm, cube.edge_mm);
    let dist = |a: [f64; 3], b: [f64; 3]| {
        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
    };
    // P2 … P5 at 10 % of the plane's diagonal (a space diagonal, edge·√3) from C1, C2, C7, C8.
    for (k, c) in [corners[0], corners[1], corners[6], corners[7]]
        .iter()
        .enumerate()
    {
        let d = dist(poses[k + 1], *c);
        assert!(
            (d - 0.1 * 3f64.sqrt() * cube.edge_mm).abs() < 1e-9,
            "P{}: {d}",
            k + 2
        );
    }
    assert_eq!(poses[0], cube.centre_mm);
    // Each configuration puts the tool point on its pose (forward kinematics).
    for (q, p) in cube.poses_q_deg.iter().zip(&cube.poses_mm) {
        let x = position(&m.params, &m.tool, &q.map(f64::to_radians));
        assert!(dist(x, *p) < 1e-3, "{x:?} vs {p:?}");
    }
    // Largest at its centre, to the bisection's resolution: 3 % larger fails.
    let ik = crate::map::ik::Ik::new(
        &m,
        crate::map::default_reference_deg(&m).map(f64::to_radians),
        0,
    );
    let rot = Some(crate::map::ik::rpy_rotation(rpy));
    assert!(cube_solution(&ik, rot, cube.centre_mm, cube.edge_mm).is_some());
    assert!(cube_solution(&ik, rot, cube.centre_mm, 1.03 * cube.edge_mm).is_none());
}

use crate::kinematics::tx60;

/// The TX60 with every σ of its parameters 0 (and its tool point exactly known).
fn tx60_without_spread() -> crate::kinematics::RobotModel {
    let mut m = tx60();
    m.uncertainty = crate::kinematics::Uncertainty::Independent(crate::kinematics::Params::filled(
        m.layout().n_params(),
        0.0,
    ));
    m
}

fn cycle(q: Joints, p: [f64; 3], line: u64) -> Measurement {
    Measurement {
        payload_kg: None,
        q_deg: q,
        position_mm: p,
        line,
        target: None,
        on_base: false,
        sides: None,
    }
}

/// Known answers worked by hand. Pose 1: 30 cycles on a circle of radius 0.02 mm around the
/// command moved by (0.03, −0.04, 0): barycentre = centre, so AP = 0.05 and AP_x = 0.03; every
/// l_i = 0.02, so S_l = 0 and RP = 0.02. Pose 2: 4 cycles at ±0.01 and ±0.03 mm along x
/// around the command: AP = 0, l = (0.01, 0.01, 0.03, 0.03), l̄ = 0.02, S_l = √(4·0.0001/3),
/// RP = 0.02 + 3·0.011547 = 0.054641.
#[test]
fn known_offset_and_spread_give_the_hand_figures() {
    let m = tx60();
    let q1 = Joints::from([10.0, -20.0, 90.0, 0.0, 30.0, 0.0]);
    let q2 = Joints::from([-30.0, 10.0, 70.0, 20.0, -40.0, 60.0]);
    let c1 = position(&m.params, &m.tool, &q1.map(f64::to_radians));
    let c2 = position(&m.params, &m.tool, &q2.map(f64::to_radians));
    let mut rows = Vec::new();
    for i in 0..30 {
        let t = i as f64 * std::f64::consts::TAU / 30.0;
        rows.push(cycle(
            q1,
            [
                c1[0] + 0.03 + 0.02 * t.cos(),
                c1[1] - 0.04 + 0.02 * t.sin(),
                c1[2],
            ],
            2 + 2 * i,
        ));
        if i < 4 {
            let dx = [0.01, -0.01, 0.03, -0.03][i as usize];
            rows.push(cycle(q2, [c2[0] + dx, c2[1], c2[2]], 3 + 2 * i));
        }
    }
    let f = pose_figures(&m, &rows, Placement::Known).unwrap();
    assert_eq!(f.len(), 2);
    assert_eq!((f[0].pose, f[0].cycles, f[1].cycles), (1, 30, 4));
    assert!((f[0].ap_mm - 0.05).abs() < 1e-12, "{}", f[0].ap_mm);
    assert!((f[0].ap_xyz_mm[0] - 0.03).abs() < 1e-12);
    assert!((f[0].ap_xyz_mm[1] + 0.04).abs() < 1e-12);
    assert!((f[0].rp_mm - 0.02).abs() < 1e-12, "{}", f[0].rp_mm);
    assert!(f[0].s_l_mm < 1e-12);
    assert!(f[1].ap_mm < 1e-12);
    assert!((f[1].l_mean_mm - 0.02).abs() < 1e-12);
    let s = (4.0 * 1e-4 / 3.0f64).sqrt();
    assert!((f[1].s_l_mm - s).abs() < 1e-12);
    assert!((f[1].rp_mm - (0.02 + 3.0 * s)).abs() < 1e-12);
    assert_eq!(f[1].first_line, 3);
    // A pose with one cycle has no repeatability.
    let one = [rows[0].clone(), rows[2].clone(), cycle(q2, c2, 99)];
    assert_eq!(
        pose_figures(&m, &one, Placement::Known),
        Err(Iso9283Error::TooFewCycles {
            pose: 2,
            line: 99,
            cycles: 1
        })
    );
    assert_eq!(
        pose_figures(&m, &[], Placement::Known),
        Err(Iso9283Error::Empty)
    );
    // A row with another number of joint angles than the model has joints, either way (one
    // more used to panic in the forward kinematics): named by its line.
    for n in [5, 7] {
        let mut odd = cycle(q2, c2, 41);
        odd.q_deg = Joints::from_slice(&[10.0; 7][..n]);
        let rows = [rows[0].clone(), rows[1].clone(), odd];
        let e = pose_figures(&m, &rows, Placement::Known).unwrap_err();
        assert_eq!(
            e,
            Iso9283Error::JointCount {
                line: 41,
                angles: n,
                model: m.name.clone(),
                joints: 6
            }
        );
        assert!(e.to_string().starts_with("line 41: "), "{e}");
    }
}

/// A tool point uncertain in x alone (σ = 0.01 mm) moves every pose by the same |δx|: at
/// s = 0.0196 mm (1.96 σ) each pose and all five together have Pr = 0.95 within the
/// binomial interval.
#[test]
fn certificate_of_a_tool_spread_has_its_closed_form() {
    let mut m = tx60_without_spread();
    m.tool_sigma = [0.01, 0.0, 0.0];
    let poses: [Joints; 3] = [
        [10.0, -20.0, 90.0, 0.0, 30.0, 0.0].into(),
        [-30.0, 10.0, 70.0, 20.0, -40.0, 60.0].into(),
        [40.0, 0.0, 100.0, -10.0, 50.0, 0.0].into(),
    ];
    let c = certificate(&m, &poses, 0.0196, Placement::Known, 100_000, 7).unwrap();
    assert_eq!(c.per_pose.len(), 3);
    for r in c.per_pose.iter().chain([&c.all]) {
        assert!((r.ci_low..=r.ci_high).contains(&0.95), "{r:?}");
        assert!((r.r - 0.95).abs() < 0.004, "{r:?}");
    }
    assert!(render_certificate(&c).contains("all"));
}

/// Cycles the model cannot explain get no certificate: the tool spread of σ = 0.01 mm in x
/// predicts errors of a few hundredths of a mm, so cycles 1 mm off (or in metres) contradict it;
/// cycles 0.01 mm off are certified; a model without uncertainty is refused outright.
#[test]
fn certify_refuses_cycles_beyond_every_predicted_error_and_a_model_without_spread() {
    let mut m = tx60_without_spread();
    let q = Joints::from([10.0, -20.0, 90.0, 0.0, 30.0, 0.0]);
    let c = position(&m.params, &m.tool, &q.map(f64::to_radians));
    let rows = |off: f64, scale: f64| -> Vec<Measurement> {
        (0..10)
            .map(|i| {
                let dy = 0.001 * (i % 3) as f64;
                cycle(
                    q,
                    [(c[0] + off) * scale, (c[1] + dy) * scale, c[2] * scale],
                    2 + i,
                )
            })
            .collect()
    };
    // No spread at all.
    let f = pose_figures(&m, &rows(0.01, 1.0), Placement::Known).unwrap();
    assert_eq!(
        certify(&m, &f, 0.05, Placement::Known, 1000, 7),
        Err(CertifyError::NoUncertainty {
            model: m.name.clone()
        })
    );
    m.tool_sigma = [0.01, 0.0, 0.0];
    assert!(certify(&m, &f, 0.05, Placement::Known, 20_000, 7).is_ok());
    for (off, scale, metres) in [(1.0, 1.0, false), (0.0, 0.001, true)] {
        let f = pose_figures(&m, &rows(off, scale), Placement::Known).unwrap();
        let e = certify(&m, &f, 0.05, Placement::Known, 20_000, 7).unwrap_err();
        let CertifyError::Contradiction {
            pose, line, draws, ..
        } = &e
        else {
            panic!("{e}");
        };
        assert_eq!((*pose, *line, *draws), (1, 2, 20_000));
        assert_eq!(e.to_string().contains("metres"), metres, "{e}");
    }
    // The barycentre's standard error from l̄ and S_l: l = (0.01, 0.01, 0.03, 0.03) gives
    // √(0.002 / 12).
    let f = PoseFigures {
        pose: 1,
        q_deg: q,
        cycles: 4,
        command_mm: c,
        barycentre_mm: c,
        ap_mm: 0.0,
        ap_xyz_mm: [0.0; 3],
        l_mean_mm: 0.02,
        s_l_mm: (4.0 * 1e-4 / 3.0f64).sqrt(),
        rp_mm: 0.0,
        first_line: 2,
    };
    assert!((barycentre_standard_error(&f) - (0.002f64 / 12.0).sqrt()).abs() < 1e-15);
}
