use super::estimate::FittedPoint;
use super::*;
use nalgebra::Matrix3;

fn term(norms: Vec<f64>, share: f64) -> Discrepancy {
    Discrepancy {
        residual_norms: norms,
        robot_share: share,
        noise: NoiseSource::Unknown,
        noise_sigma_mm: None,
        compensation: None,
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
    assert_eq!(ok.radii()[19], 19.0);
    // The size's factors: for a measurement their median is about 1 (the mean square's own
    // posterior), for the robot about √share = 0.5, both ascending.
    let robot = ok.draw_factors(DiscrepancyUse::Robot);
    let measured = ok.draw_factors(DiscrepancyUse::Measured);
    assert_eq!(robot.len(), size::SIZE_DRAWS);
    assert!(robot.windows(2).all(|w| w[0] <= w[1]));
    assert!((measured[128] - 1.0).abs() < 0.05, "{}", measured[128]);
    assert!((robot[128] - 0.5).abs() < 0.05, "{}", robot[128]);
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
    let lof = LackOfFit::estimate(&p, true, Some(1e-30), 1);
    assert_eq!(lof.found, Some(true));
    assert!((lof.robot_share - 0.96).abs() < 0.02, "{}", lof.robot_share);
    assert!((lof.unexplained_rms_mm.unwrap() - 0.05 * 3f64.sqrt() * 0.98).abs() < 0.005);
    assert!(lof.carried && lof.term.is_some());
    assert!(
        (lof.covariance_scale - 25.25).abs() < 2.0,
        "{}",
        lof.covariance_scale
    );
    let loo = lof.loo.as_ref().unwrap();
    // The term drawn from these very residuals covers about 95 % of them; the parameters'
    // tiny leverage alone covers almost none.
    assert!((loo.coverage_95 - 0.95).abs() < 0.04, "{loo:?}");
    assert!(loo.coverage_95_parameters_only < 0.05, "{loo:?}");
    assert!((loo.pit_max_mean - 0.5).abs() < 0.2, "{loo:?}");
    assert!(lof.summary().contains("unexplained"), "{}", lof.summary());

    let p = points(0.01, 0.01, 400, 4);
    // Residuals that match the stated noise: nothing significant; what the scatter leaves
    // above the noise (the positive part of the excess) is a small share at most, kept.
    let lof = LackOfFit::estimate(&p, true, Some(0.4), 1);
    assert_eq!(lof.found, Some(false));
    // The covariance grows by the same excess: scale = mean square over the noise's.
    assert!(lof.robot_share < 0.15, "{lof:?}");
    assert!((lof.covariance_scale - 1.0 / (1.0 - lof.robot_share)).abs() < 1e-9);
    assert_eq!(lof.carried, lof.term.as_ref().unwrap().drawn());
    // The size's posterior: the estimate lies inside its 95 % upper bound.
    let upper = lof.unexplained_upper_mm.unwrap();
    assert!(upper > lof.unexplained_rms_mm.unwrap(), "{lof:?}");
    // Residuals below the noise: no share at all.
    let quiet = points(0.008, 0.01, 400, 4);
    let lof = LackOfFit::estimate(&quiet, true, Some(0.99), 1);
    assert!(!lof.carried && lof.robot_share == 0.0, "{lof:?}");
    assert!(
        lof.summary().contains("no significant lack of fit"),
        "{}",
        lof.summary()
    );

    // Unknown noise: the term carries everything and says it cannot tell.
    let lof = LackOfFit::estimate(&p, false, None, 1);
    assert_eq!(lof.found, None);
    assert!(lof.carried && lof.robot_share == 1.0);
    assert!(lof.summary().contains("cannot be told apart"));

    // Too few points: no term, said.
    let lof = LackOfFit::estimate(&p[..5], false, None, 1);
    assert!(!lof.carried && lof.loo.is_none());
    assert!(lof.summary().contains("Too few points"));
}

#[test]
fn pooled_terms_weigh_runs_by_their_residuals() {
    let a = Discrepancy {
        residual_norms: vec![0.1; 30],
        robot_share: 0.5,
        noise: NoiseSource::Stated,
        compensation: None,
        noise_sigma_mm: Some(0.01),
    };
    let b = Discrepancy {
        residual_norms: vec![0.2; 10],
        robot_share: 0.9,
        compensation: None,
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

mod gp_tests {
    use super::super::gp::{self, Compensation};
    use nalgebra::{Matrix3, Rotation3, Vector3};
    use rand::{Rng, SeedableRng};

    /// `n` random 6-joint configurations (radians) and a smooth field of them plus noise `s`.
    fn data(n: usize, s: f64, seed: u64) -> (Vec<Vec<f64>>, Vec<Vector3<f64>>) {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let q: Vec<Vec<f64>> = (0..n)
            .map(|_| (0..6).map(|_| rng.random_range(-1.5..1.5)).collect())
            .collect();
        let y = q
            .iter()
            .map(|c| {
                field(c) + Vector3::from_fn(|_, _| s * super::super::estimate::gaussian(&mut rng))
            })
            .collect();
        (q, y)
    }

    /// A field like compliance under gravity: smooth in q2, q3, nothing of q1, q4…q6.
    fn field(c: &[f64]) -> Vector3<f64> {
        Vector3::new(
            0.1 * c[1].sin(),
            0.05 * (c[1] + c[2]).cos(),
            0.08 * c[1] * c[2].sin(),
        )
    }

    #[test]
    fn recovers_a_smooth_field_and_its_noise() {
        let (q, y) = data(250, 0.01, 1);
        let fit = gp::fit(&q, &y, 7).unwrap();
        // The white part is the noise (0.01 mm per coordinate) to within its estimate's error.
        assert!((fit.white_sigma - 0.01).abs() < 0.002, "{fit:?}");
        // Joints that do not act get long length scales, the acting ones short.
        assert!(
            fit.length_scales[1] < 3.0 && fit.length_scales[0] > 3.0,
            "{fit:?}"
        );
        // New configurations: the mean predicts the field to well under its own size (RMS
        // 0.07 mm) — within a few noise σ.
        let (qn, _) = data(200, 0.0, 2);
        let miss: Vec<Vector3<f64>> = qn.iter().map(|c| field(c) - fit.mean(c)).collect();
        assert!(gp::rms(&miss) < 0.01, "{}", gp::rms(&miss));
        // Leave-one-out residuals are noise: RMS √3 · 0.01 within 15 %.
        let loo = fit.loo(&y);
        assert!(
            (gp::rms(&loo) / (3f64.sqrt() * 0.01) - 1.0).abs() < 0.15,
            "{}",
            gp::rms(&loo)
        );
    }

    #[test]
    fn closed_form_leave_one_out_matches_refitting() {
        let (q, y) = data(60, 0.02, 3);
        let fit = gp::fit(&q, &y, 1).unwrap();
        let loo = fit.loo(&y);
        // Refit without pose i at the same hyperparameters (the compensation form keeps them)
        // and predict it.
        for i in [0, 17, 59] {
            let mut kq = q.clone();
            let mut ky = y.clone();
            kq.remove(i);
            ky.remove(i);
            let theta: Vec<f64> = fit
                .length_scales
                .iter()
                .map(|l| l.ln())
                .chain([fit.signal_sigma.ln(), fit.white_sigma.ln()])
                .collect();
            let other = gp::condition_for_tests(&kq, &ky, &theta);
            let direct = y[i] - other.mean(&q[i]);
            assert!(
                (direct - loo[i]).norm() < 1e-8 * (1.0 + direct.norm()),
                "{i}: {direct} vs {}",
                loo[i]
            );
        }
    }

    #[test]
    fn white_noise_is_not_compensated() {
        // No structure: the process predicts nothing, its leave-one-out RMS is no better.
        let (q, _) = data(150, 0.0, 4);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let y: Vec<Vector3<f64>> = (0..150)
            .map(|_| Vector3::from_fn(|_, _| 0.03 * super::super::estimate::gaussian(&mut rng)))
            .collect();
        let fit = gp::fit(&q, &y, 2).unwrap();
        assert!(
            gp::rms(&fit.loo(&y)) > (1.0 - gp::required_gain(150)) * gp::rms(&y),
            "{fit:?}"
        );
    }

    #[test]
    fn stored_compensation_is_the_mean_in_the_base_frame() {
        let (q, y) = data(80, 0.01, 5);
        let fit = gp::fit(&q, &y, 3).unwrap();
        let r: Matrix3<f64> = *Rotation3::from_euler_angles(0.3, -0.2, 1.1).matrix();
        let c: Compensation = fit.compensation(&r, 0.1, 0.02, 0.01);
        assert!(c.check(6).is_ok());
        for k in [0, 40] {
            let deg: Vec<f64> = q[k].iter().map(|v| v.to_degrees()).collect();
            let got = Vector3::from(c.correction_mm(&deg));
            assert!((got - r * fit.mean(&q[k])).norm() < 1e-12, "{got}");
        }
        // The stored form's predictive σ (degrees, a Cholesky solve) is the fit's (radians,
        // through K_y⁻¹) at training poses, between them and far away (the prior σ there).
        let far: Vec<f64> = q[0].iter().map(|v| v + 3.0).collect();
        let mid: Vec<f64> = q[1].iter().zip(&q[2]).map(|(a, b)| 0.5 * (a + b)).collect();
        let probes = [q[0].clone(), q[40].clone(), mid, far];
        let deg: Vec<Vec<f64>> = probes
            .iter()
            .map(|p| p.iter().map(|v| v.to_degrees()).collect())
            .collect();
        for (p, stored) in probes.iter().zip(c.predictive_sigmas(&deg)) {
            let fitted = fit.predictive_sigma(p);
            assert!(
                (stored - fitted).abs() < 1e-9 * fitted,
                "{stored} vs {fitted}"
            );
        }
        // A file's compensation of another joint count names the field.
        let (field, msg) = c.check(7).unwrap_err();
        assert!(
            field.contains("length_scales_deg") && msg.contains("7 joints"),
            "{field}: {msg}"
        );
        let mut bad = c.clone();
        bad.weights.pop();
        assert!(bad.check(6).unwrap_err().0.contains("weights"));
    }

    #[test]
    fn too_few_poses_is_one_clear_error() {
        let (q, y) = data(10, 0.01, 6);
        let e = gp::fit(&q, &y, 1).unwrap_err();
        assert!(e.to_string().contains("at least 20"), "{e}");
    }
}

/// The posterior of the mean square (a Bayesian bootstrap) has the spread the sampling theory
/// gives: for Gaussian 3-D residuals `r² = σ²χ²₃`, so the mean square of n of them has relative
/// standard deviation √(2/(3n)) (0.0408 at n = 400, 0.0129 at n = 4000 by the normal limit).
/// The 16 % and 84 % quantiles of the ratios sit one such σ from 1 (to 15 %, the estimate's
/// own scatter from one sample: its fourth moment is estimated from these very residuals).
#[test]
fn size_posterior_has_the_sampling_spread() {
    for (n, seed) in [(400usize, 7u64), (4000, 8)] {
        let p = points(0.01, 0.01, n, seed);
        let norms = standardised_norms(&p);
        let ratios = size::mean_square_ratios(&norms);
        assert_eq!(ratios.len(), size::SIZE_DRAWS);
        assert!(ratios.windows(2).all(|w| w[0] <= w[1]));
        let sd = (2.0 / (3.0 * n as f64)).sqrt();
        let lo = 1.0 - ratios[(0.1587 * 256.0) as usize];
        let hi = ratios[(0.8413 * 256.0) as usize] - 1.0;
        for (what, v) in [("lower", lo), ("upper", hi)] {
            assert!(
                (v / sd - 1.0).abs() < 0.15,
                "n {n}: {what} {v} against σ {sd}"
            );
        }
        // the same norms in another order give the same factors
        let mut reversed = norms.clone();
        reversed.reverse();
        assert_eq!(size::mean_square_ratios(&reversed), ratios);
    }
    // Robot factors: a noise part above every ratio gives zeros; none gives √ratio.
    let ratios = vec![0.9, 1.0, 1.1];
    assert_eq!(size::factors(&ratios, 1.2), vec![0.0; 3]);
    assert_eq!(size::factors(&ratios, 0.0)[1], 1.0);
}

/// A plan of a new calibration takes the term without the compensation, its norms back at the
/// geometric model's size.
#[test]
fn a_new_calibration_keeps_the_term_at_the_geometric_size() {
    let mut t = term((1..=20).map(f64::from).collect(), 1.0);
    assert_eq!(t.for_new_calibration(), t);
    t.compensation = Some(Compensation {
        length_scales_deg: vec![30.0; 6],
        signal_sigma_mm: 1.0,
        white_sigma_mm: 0.5,
        loo_rms_geometric_mm: 0.4,
        loo_rms_compensated_mm: 0.3,
        loo_sigma_mm: 0.5,
        configurations_deg: vec![vec![0.0; 6]],
        weights: vec![[0.0; 3]],
    });
    let planned = t.for_new_calibration();
    assert!(planned.compensation.is_none());
    assert!((planned.residual_norms[19] - 20.0 * 0.4 / 0.3).abs() < 1e-12);
}

/// A term from given norms: the robot's share is what their mean square holds beyond the stated
/// noise's (3σ² for a 3-D norm), 1 without a stated noise, 0 below it; norms sorted.
#[test]
fn a_term_from_norms_takes_the_stated_noise_out() {
    let norms = [0.3, 0.1, 0.2, 0.2];
    let ms = (0.09 + 0.01 + 0.04 + 0.04) / 4.0;
    let t = Discrepancy::from_norms(&norms, NoiseSource::Stated, Some(0.05), None);
    assert!((t.robot_share - (1.0 - 3.0 * 0.0025 / ms)).abs() < 1e-15);
    assert_eq!(t.residual_norms, vec![0.1, 0.2, 0.2, 0.3]);
    assert_eq!(t.noise_sigma_mm, Some(0.05));
    let u = Discrepancy::from_norms(&norms, NoiseSource::Unknown, Some(0.05), None);
    assert_eq!((u.robot_share, u.noise_sigma_mm), (1.0, None));
    let quiet = Discrepancy::from_norms(&norms, NoiseSource::Stated, Some(1.0), None);
    assert_eq!(quiet.robot_share, 0.0);
}
