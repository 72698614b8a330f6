use super::estimate::FittedPoint;
use super::*;
use nalgebra::Matrix3;

fn term(norms: Vec<f64>, share: f64) -> Discrepancy {
    Discrepancy {
        residual_norms: norms,
        robot_share: share,
        noise: NoiseSource::Unknown,
        noise_sigma_mm: None,
    }
}

#[test]
fn checked_names_the_bad_field() {
    let err = term(vec![0.1; 3], 1.0).checked().unwrap_err();
    assert!(
        err.to_string().contains("discrepancy.residual_norms"),
        "{err}"
    );
    let err = term(vec![0.1; 20], 1.5).checked().unwrap_err();
    assert!(err.to_string().contains("discrepancy.robot_share"), "{err}");
    let mut v = vec![0.1; 20];
    v[4] = f64::NAN;
    let err = term(v, 1.0).checked().unwrap_err();
    assert!(err.to_string().contains("value 5"), "{err}");
    let mut t = term(vec![0.1; 20], 0.5);
    t.noise = NoiseSource::Stated;
    assert!(t
        .checked()
        .unwrap_err()
        .to_string()
        .contains("noise_sigma_mm"));
    let ok = term((0..20).rev().map(f64::from).collect(), 0.25)
        .checked()
        .unwrap();
    assert!(ok.residual_norms.windows(2).all(|w| w[0] <= w[1]));
    assert_eq!(ok.radii(DiscrepancyUse::Robot)[19], 19.0 * 0.5);
    assert_eq!(ok.radii(DiscrepancyUse::Measured)[19], 19.0);
}

/// Points with residuals of a known spread, no leverage, whitened by a stated σ.
fn points(residual_sigma: f64, stated: f64, n: usize, seed: u64) -> Vec<FittedPoint> {
    use rand::SeedableRng;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| FittedPoint {
            residual_mm: std::array::from_fn(|_| {
                residual_sigma * super::estimate::gaussian(&mut rng)
            }),
            whiten: Matrix3::identity() / stated,
            leverage: Matrix3::identity() * 0.01,
        })
        .collect()
}

#[test]
fn lack_of_fit_splits_noise_from_discrepancy() {
    // Residuals 0.05 mm against a stated 0.01 mm: 96 % of the mean square is the robot's.
    let p = points(0.05, 0.01, 400, 3);
    let lof = LackOfFit::estimate(&p, true, Some(1e-30), 25.0, 1);
    assert_eq!(lof.found, Some(true));
    assert!((lof.robot_share - 0.96).abs() < 0.02, "{}", lof.robot_share);
    assert!((lof.unexplained_rms_mm.unwrap() - 0.05 * 3f64.sqrt() * 0.98).abs() < 0.005);
    assert!(lof.carried && lof.term.is_some());
    assert_eq!(lof.covariance_scale, 25.0);
    let loo = lof.loo.as_ref().unwrap();
    // The term drawn from these very residuals covers about 95 % of them; the parameters'
    // tiny leverage alone covers almost none.
    assert!((loo.coverage_95 - 0.95).abs() < 0.04, "{loo:?}");
    assert!(loo.coverage_95_parameters_only < 0.05, "{loo:?}");
    assert!((loo.pit_max_mean - 0.5).abs() < 0.2, "{loo:?}");
    assert!(lof.summary().contains("unexplained"), "{}", lof.summary());

    // Residuals that match the stated noise: nothing found, no term, scale 1.
    let p = points(0.01, 0.01, 400, 4);
    // Residuals that match the stated noise: nothing significant; what the scatter leaves
    // above the noise (the positive part of the excess) is a small share at most, kept.
    let lof = LackOfFit::estimate(&p, true, Some(0.4), 1.0, 1);
    assert_eq!(lof.found, Some(false));
    assert!(
        lof.robot_share < 0.15 && lof.covariance_scale == 1.0,
        "{lof:?}"
    );
    assert_eq!(lof.carried, lof.robot_share > 0.0);
    // Residuals below the noise: no share at all.
    let quiet = points(0.008, 0.01, 400, 4);
    let lof = LackOfFit::estimate(&quiet, true, Some(0.99), 0.64, 1);
    assert!(!lof.carried && lof.robot_share == 0.0, "{lof:?}");
    assert!(
        lof.summary().contains("no significant lack of fit"),
        "{}",
        lof.summary()
    );

    // Unknown noise: the term carries everything and says it cannot tell.
    let lof = LackOfFit::estimate(&p, false, None, 1.0, 1);
    assert_eq!(lof.found, None);
    assert!(lof.carried && lof.robot_share == 1.0);
    assert!(lof.summary().contains("cannot be told apart"));

    // Too few points: no term, said.
    let lof = LackOfFit::estimate(&p[..5], false, None, 1.0, 1);
    assert!(!lof.carried && lof.loo.is_none());
    assert!(lof.summary().contains("Too few points"));
}

#[test]
fn pooled_terms_weigh_runs_by_their_residuals() {
    let a = Discrepancy {
        residual_norms: vec![0.1; 30],
        robot_share: 0.5,
        noise: NoiseSource::Stated,
        noise_sigma_mm: Some(0.01),
    };
    let b = Discrepancy {
        residual_norms: vec![0.2; 10],
        robot_share: 0.9,
        noise: NoiseSource::Stated,
        noise_sigma_mm: Some(0.02),
    };
    let p = Discrepancy::pooled(&[&a, &b]).unwrap();
    assert_eq!(p.residual_norms.len(), 40);
    assert!((p.robot_share - (0.75 * 0.5 + 0.25 * 0.9)).abs() < 1e-12);
    assert!((p.noise_sigma_mm.unwrap() - (0.75e-4f64 + 0.25 * 4e-4).sqrt()).abs() < 1e-12);
    // One run without a stated noise: the pool cannot take noise out.
    let c = term(vec![0.3; 10], 1.0);
    let q = Discrepancy::pooled(&[&a, &c]).unwrap();
    assert_eq!(
        (q.noise, q.robot_share, q.noise_sigma_mm),
        (NoiseSource::Unknown, 1.0, None)
    );
    assert!(Discrepancy::pooled(&[]).is_none());
    assert!(p.checked().is_ok());
}
