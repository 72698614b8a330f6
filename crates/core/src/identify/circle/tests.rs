//! Tests of the circle fits: exact arcs, degenerate input, and the commanded-angle fit on
//! short noisy arcs.

use super::*;

fn arc(
    center: Vector3<f64>,
    axis: Vector3<f64>,
    radius: f64,
    from_deg: f64,
    to_deg: f64,
    n: usize,
) -> (Vec<Vector3<f64>>, Vec<f64>) {
    let nn = axis.normalize();
    let u = perpendicular(&nn);
    let v = nn.cross(&u);
    let phase = 0.7;
    let mut pts = Vec::new();
    let mut qs = Vec::new();
    for k in 0..n {
        let q = (from_deg + (to_deg - from_deg) * k as f64 / (n - 1) as f64).to_radians();
        pts.push(center + (u * (q + phase).cos() + v * (q + phase).sin()) * radius);
        qs.push(q);
    }
    (pts, qs)
}

fn check_exact(axis: Vector3<f64>, span: f64) {
    let c = Vector3::new(120.0, -35.0, 410.0);
    let (p, q) = arc(c, axis, 87.0, -span / 2.0, span / 2.0, 15);
    for method in CircleFitMethod::ALL {
        let f = fit_circle(&p, &q, method, None).unwrap();
        assert!(
            (f.center - c).norm() < 1e-8,
            "{method:?} {axis:?} {:?}",
            f.center
        );
        assert!(
            (f.normal - axis.normalize()).norm() < 1e-10,
            "{method:?} {axis:?}"
        );
        assert!((f.radius - 87.0).abs() < 1e-8);
        assert!(f.max_residual < 1e-8);
    }
    // Reversed rotation sense flips the axis.
    let qr: Vec<f64> = q.iter().map(|v| -v).collect();
    let pr: Vec<Vector3<f64>> = p.clone();
    for method in CircleFitMethod::ALL {
        let f = fit_circle(&pr, &qr, method, None).unwrap();
        assert!((f.normal + axis.normalize()).norm() < 1e-10, "{method:?}");
    }
}

#[test]
fn exact_circles_any_orientation() {
    for axis in [
        Vector3::x(),
        Vector3::y(),
        Vector3::z(),
        -Vector3::y(),
        Vector3::new(0.3, -0.8, 0.2),
        Vector3::new(-1.0, 1.0, 1.0),
    ] {
        check_exact(axis, 120.0);
        check_exact(axis, 12.0);
    }
}

#[test]
fn degenerate_inputs() {
    let c = Vector3::new(0.0, 0.0, 0.0);
    let (p, q) = arc(c, Vector3::y(), 50.0, 0.0, 90.0, 10);
    assert_eq!(
        fit_circle(&p[..2], &q[..2], CircleFitMethod::CommandedAngles, None),
        Err(CircleFitError::TooFewPoints { points: 2 })
    );
    let line: Vec<Vector3<f64>> = (0..5).map(|k| Vector3::new(k as f64, 2.0, 3.0)).collect();
    for m in CircleFitMethod::ALL {
        assert_eq!(
            fit_circle(&line, &q[..5], m, None),
            Err(CircleFitError::Collinear)
        );
    }
    let same = vec![Vector3::new(1.0, 2.0, 3.0); 5];
    assert_eq!(
        fit_circle(&same, &q[..5], CircleFitMethod::PointCloud, None),
        Err(CircleFitError::Collinear)
    );
    let (p, q) = arc(c, Vector3::y(), 50.0, 0.0, 4.0, 5);
    assert!(matches!(
        fit_circle(&p, &q, CircleFitMethod::CommandedAngles, None),
        Err(CircleFitError::ArcTooShort { .. })
    ));
    let mut p2 = p.clone();
    p2[1].x = f64::NAN;
    assert_eq!(
        fit_circle(&p2, &q, CircleFitMethod::CommandedAngles, None),
        Err(CircleFitError::NotFinite)
    );
}

#[test]
fn commanded_fit_pins_radius_on_short_noisy_arc() {
    use crate::sampling::standard_normal as gauss;
    use rand::SeedableRng;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let axis = Vector3::new(0.2, 0.9, -0.3).normalize();
    let c = Vector3::new(100.0, 200.0, 300.0);
    let (mut err_cloud, mut err_cmd) = (0.0, 0.0);
    for _ in 0..20 {
        let (mut p, q) = arc(c, axis, 300.0, -6.0, 6.0, 7);
        for v in p.iter_mut() {
            *v += Vector3::new(gauss(&mut rng), gauss(&mut rng), gauss(&mut rng)) * 0.01;
        }
        let a = fit_circle(&p, &q, CircleFitMethod::PointCloud, None).unwrap();
        let b = fit_circle(&p, &q, CircleFitMethod::CommandedAngles, None).unwrap();
        err_cloud += (a.radius - 300.0).abs();
        err_cmd += (b.radius - 300.0).abs();
    }
    assert!(err_cmd < err_cloud / 2.0, "{err_cmd} vs {err_cloud}");
}
