//! The backlash's term for unknown sides (docs/METHOD.md §19.5): a model identified with its
//! gaps also carries the discrepancy term of the prediction that does not know the sides (each
//! joint at the centre of its gap). A problem of such a model uses it until every point's sides
//! are given, then turns to the sides; a validation predicts each pose by whether its sides are
//! all recorded; the model file keeps the term. (Its honesty on simulated poses is in
//! `backlash::a_model_with_backlash_is_honest_whether_the_sides_are_known_or_not`.)

use crate::backlash::{points, with_backlash, GAPS_DEG};
use crate::joint_errors::model_with_joint_errors;
use gpu_amcs::discrepancy::{Discrepancy, NoiseSource};
use gpu_amcs::engine::{CpuEvaluator, Evaluator, Frame, Problem, ProblemError, Reference};
use gpu_amcs::identify::validate::{point_errors_in, Measurement};
use gpu_amcs::identify::Placement;
use gpu_amcs::kinematics::{Joints, RobotModel};

/// A term of 40 residual norms 0.01 … 0.40 mm, scaled by `f`.
fn term(f: f64) -> Discrepancy {
    Discrepancy {
        residual_norms: (1..=40).map(|i| f * 0.01 * i as f64).collect(),
        robot_share: 1.0,
        noise: NoiseSource::Unknown,
        noise_sigma_mm: None,
        compensation: None,
    }
}

/// The TX60 with compliance, harmonics and gaps, its own discrepancy term, and (`unknown`) a
/// term for unknown sides three times as large.
fn model(unknown: bool) -> RobotModel {
    let mut m = with_backlash(model_with_joint_errors(3.0), &GAPS_DEG, 0.002);
    m.discrepancy = Some(term(1.0));
    if unknown {
        let b = m.joint_errors.as_mut().and_then(|e| e.backlash.as_mut());
        b.unwrap().sides_unknown = Some(term(3.0));
    }
    m
}

/// `w` and the per-point errors of draws 0 … 63.
fn run(p: &Problem) -> (Vec<f64>, Vec<f64>) {
    let m = p.n_points();
    let (mut w, mut e) = (vec![0.0; 64], vec![0.0; 64 * m]);
    CpuEvaluator::new(p.clone())
        .evaluate(0, &mut w, Some(&mut e))
        .unwrap();
    (w, e)
}

fn sides(value: f64) -> Vec<Joints> {
    points().iter().map(|_| Joints::filled(6, value)).collect()
}

/// Without sides the problem predicts with the centre and the term for unknown sides; with
/// every point's sides it is the problem of the model as given with those sides, bit for bit,
/// whichever frame and discrepancy use were chosen before; with some sides missing it stays,
/// and counts them; a side that is not one is refused and changes nothing.
#[test]
fn a_problem_uses_the_term_until_every_side_is_given() {
    let pts = points();
    let new = |m: RobotModel| Problem::new(m, &pts, &Reference::Calibrated, 7).unwrap();
    let p = new(model(true));
    assert!(p.sided.is_some());
    let e = p.model.joint_errors.as_ref().unwrap();
    assert!(e.backlash.is_none(), "the centre draws no sides");
    assert_eq!(p.model.discrepancy, Some(term(3.0)));
    // The centre's draws are those of the model as given with every gap closed and the
    // larger term.
    let mut closed = model(false);
    closed.joint_errors.as_mut().unwrap().backlash = None;
    closed.discrepancy = Some(term(3.0));
    assert_eq!(run(&p), run(&new(closed)));
    // Every side given: the model as given, in either frame and discrepancy use.
    let all = sides(1.0);
    let sided = |frame: Frame, measured: bool| {
        let prepare = |p: Problem| {
            let p = p.in_frame(frame);
            match measured {
                true => p.with_discrepancy_use(gpu_amcs::discrepancy::DiscrepancyUse::Measured),
                false => p,
            }
        };
        let mut a = prepare(new(model(true)));
        a.set_known_sides(&all).unwrap();
        assert!(a.sided.is_none() && a.sides_unused.is_none());
        let mut b = prepare(new(model(false)));
        b.set_known_sides(&all).unwrap();
        assert!(a.model.joint_errors.as_ref().unwrap().backlash.is_some());
        assert_eq!(run(&a), run(&b), "{frame:?}, measured {measured}");
        // ... and not the centre's
        assert_ne!(run(&a).0, run(&prepare(new(model(true)))).0);
    };
    for frame in [Frame::Measurement, Frame::Base] {
        for measured in [false, true] {
            sided(frame, measured);
        }
    }
    // One side missing at point 2: that point stands at the centre with the term for unknown
    // sides, the others take theirs (mixed_sides_are_the_two_problems_point_by_point); one
    // missing at every point: the centre stays everywhere, the given sides counted.
    let mut some = sides(-1.0);
    some[2][0] = 0.0;
    let mut q = new(model(true));
    q.set_known_sides(&some).unwrap();
    assert!(q.sided.is_none());
    assert_eq!(q.sides_unused, Some((5, 6)));
    let mut none = sides(-1.0);
    for s in none.iter_mut() {
        s[1] = 0.0;
    }
    let mut q = new(model(true));
    q.set_known_sides(&none).unwrap();
    assert!(q.sided.is_some());
    let n = 6 * pts.len();
    assert_eq!(q.sides_unused, Some((n - pts.len(), n)));
    assert_eq!(run(&q), run(&p));
    // A value that is no side, or a row too few: refused, the problem as it was.
    let mut bad = sides(1.0);
    bad[1][3] = 2.0;
    for s in [bad, sides(1.0)[1..].to_vec()] {
        let mut r = new(model(true));
        let err = r.set_known_sides(&s).unwrap_err();
        assert!(matches!(err, ProblemError::Sides(_)), "{err}");
        assert!(r.sided.is_some());
        assert_eq!(run(&r), run(&p));
    }
}

/// Sides given at some points but not all: each point whose sides are all given is drawn as
/// the problem with every side given draws it (the model's own term, its joints turned to the
/// sides), each other one as the centre's problem draws it (no side, the term for unknown
/// sides): draw for draw and bit for bit on the CPU, in both frames, with the predictions at
/// the sided points moved to the sides; the GPU within its f32 bound (docs/METHOD.md §7).
#[test]
fn mixed_sides_are_the_two_problems_point_by_point() {
    let pts = points();
    let m = pts.len();
    // A term for unknown sides of another shape than the model's own, so that its size's
    // factors differ too, not only its radii.
    let mut skewed = model(true);
    let b = skewed
        .joint_errors
        .as_mut()
        .and_then(|e| e.backlash.as_mut());
    b.unwrap().sides_unknown = Some(Discrepancy {
        residual_norms: (1..=30).map(|i| 0.002 * (i * i) as f64).collect(),
        ..term(1.0)
    });
    let factors = |d: &Discrepancy| d.draw_factors(gpu_amcs::discrepancy::DiscrepancyUse::Robot);
    assert_ne!(
        factors(skewed.sides_unknown_term().unwrap()),
        factors(skewed.discrepancy.as_ref().unwrap())
    );
    let new = |frame: Frame| {
        Problem::new(skewed.clone(), &pts, &Reference::Calibrated, 7)
            .unwrap()
            .in_frame(frame)
    };
    let given: Vec<Joints> = (0..m)
        .map(|j| Joints::from_fn(6, |i| if (i + j) % 2 == 0 { 1.0 } else { -1.0 }))
        .collect();
    // Points 1 and 3 lose a side: they stand at the centre.
    let mut some = given.clone();
    some[1][4] = 0.0;
    some[3][0] = 0.0;
    for frame in [Frame::Measurement, Frame::Base] {
        let centre = new(frame);
        let mut sided = new(frame);
        sided.predict_known_sides(&given).unwrap();
        let mut mixed = new(frame);
        mixed.predict_known_sides(&some).unwrap();
        assert_eq!(mixed.centre(), &[false, true, false, true, false][..m]);
        for j in 0..m {
            let from = if j == 1 || j == 3 { &centre } else { &sided };
            assert_eq!(mixed.reference[j], from.reference[j], "{frame:?} point {j}");
        }
        let ((wx, ex), (_, es), (_, ec)) = (run(&mixed), run(&sided), run(&centre));
        for k in 0..64 {
            let row = &ex[k * m..(k + 1) * m];
            for j in 0..m {
                let want = if j == 1 || j == 3 {
                    ec[k * m + j]
                } else {
                    es[k * m + j]
                };
                assert_eq!(row[j], want, "{frame:?} draw {k} point {j}");
            }
            assert_eq!(wx[k], row.iter().copied().fold(0.0, f64::max));
        }
        // The two problems differ at those points: the comparison sees which one is drawn.
        assert!((0..64).any(|k| es[k * m + 1] != ec[k * m + 1]));
        if frame == Frame::Base && crate::common::have_adapter("mixed_sides (GPU)") {
            let (_, _, _, (dw, de)) = crate::joint_errors::cpu_and_gpu(&mixed, 500, 4000);
            assert!(
                dw <= 1e-5 && de <= 1e-5,
                "mixed sides on the GPU: {dw} {de}"
            );
        }
    }
}

/// A validation predicts a pose whose sides are all recorded with them, any other at the
/// centre: the measured position where the sided prediction puts the target has error 0 with
/// its sides and the centre's distance from it without them, or with one side missing.
#[test]
fn validation_predicts_each_pose_by_whether_its_sides_are_recorded() {
    let m = model(true);
    let q: Vec<f64> = points()[1].iter().map(|v| v.to_radians()).collect();
    let s = Joints::filled(6, 1.0);
    let turned = m.predicted_position(&q, m.side_turns(&s).as_ref(), true, false);
    let centre = m.predicted_position(&q, None, true, false);
    let gap = (0..3)
        .map(|k| (turned[k] - centre[k]).powi(2))
        .sum::<f64>()
        .sqrt();
    assert!(gap > 0.01, "{gap}");
    let mut one_missing = s;
    one_missing[4] = 0.0;
    let pose = |sides: Option<Joints>| Measurement {
        q_deg: Joints::from_fn(6, |i| points()[1][i]),
        position_mm: turned,
        payload_kg: None,
        line: 2,
        target: None,
        on_base: false,
        sides,
    };
    let e = point_errors_in(
        &m,
        &[pose(Some(s)), pose(None), pose(Some(one_missing))],
        Placement::Known,
    );
    assert!(e[0] < 1e-9, "{e:?}");
    assert!(
        (e[1] - gap).abs() < 1e-9 && (e[2] - gap).abs() < 1e-9,
        "{e:?}"
    );
    // A model without the term turns the recorded sides and leaves the missing one unturned.
    let plain = model(false);
    let e = point_errors_in(
        &plain,
        &[pose(None), pose(Some(one_missing))],
        Placement::Known,
    );
    assert!(
        (e[0] - gap).abs() < 1e-9 && e[1] > 0.0 && e[1] < gap,
        "{e:?}"
    );
}

/// The model file keeps the term as `[joint_errors.backlash_sides_unknown]`; a bad value names
/// its field there, and the term without gaps is refused.
#[test]
fn a_model_file_keeps_the_term_for_unknown_sides() {
    let m = model(true);
    let text = m.to_toml();
    assert!(
        text.contains("[joint_errors.backlash_sides_unknown]"),
        "{text}"
    );
    let back = RobotModel::from_toml(&text, "u.toml").unwrap();
    let b = back.joint_errors.unwrap().backlash.unwrap();
    let t = b.sides_unknown.expect("kept");
    assert_eq!(t.residual_norms.len(), 40);
    for (a, b) in t.residual_norms.iter().zip(&term(3.0).residual_norms) {
        assert!((a - b).abs() <= 1e-15 * b);
    }
    let at = text.find("[joint_errors.backlash_sides_unknown]").unwrap();
    let (head, tail) = text.split_at(at);
    let share = tail.lines().find(|l| l.starts_with("robot_share")).unwrap();
    let bad = format!("{head}{}", tail.replacen(share, "robot_share = 1.5", 1));
    let err = RobotModel::from_toml(&bad, "u.toml")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("joint_errors.backlash_sides_unknown.robot_share"),
        "{err}"
    );
    let no_gaps = text
        .lines()
        .filter(|l| !l.starts_with("backlash_deg") && !l.starts_with("backlash_sigma_deg"))
        .collect::<Vec<_>>()
        .join("\n");
    let err = RobotModel::from_toml(&no_gaps, "u.toml")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("joint_errors.backlash_sides_unknown") && err.contains("backlash_deg"),
        "{err}"
    );
}

/// The WGSL kernel draws a problem at the centre (the term for unknown sides in place of the
/// sides) and, once every side is given, the sided one as the CPU lanes do (docs/METHOD.md §7:
/// 1e-5 mm).
#[test]
fn the_gpu_draws_the_term_for_unknown_sides_as_the_cpu() {
    if !crate::common::have_adapter("the_gpu_draws_the_term_for_unknown_sides_as_the_cpu") {
        return;
    }
    let pts = points();
    let centre = Problem::new(model(true), &pts, &Reference::Calibrated, 21).unwrap();
    assert!(centre.discrepancy.is_some());
    let (_, _, wc, (dw, de)) = crate::joint_errors::cpu_and_gpu(&centre, 500, 20_000);
    eprintln!("centre: max |Δw| {dw:.2e} mm, max |Δe| {de:.2e} mm");
    assert!(dw <= 1e-5 && de <= 1e-5, "{dw} {de}");
    let mut sided = centre.clone();
    sided.set_known_sides(&sides(-1.0)).unwrap();
    let (_, _, ws, (dw, de)) = crate::joint_errors::cpu_and_gpu(&sided, 500, 20_000);
    eprintln!("sides given: max |Δw| {dw:.2e} mm, max |Δe| {de:.2e} mm");
    assert!(dw <= 1e-5 && de <= 1e-5, "{dw} {de}");
    assert!(
        crate::common::max_gap(&wc, &ws) > 1e-3,
        "the sides changed nothing"
    );
}

/// `validate --term-out` renews the term each held-out pose is predicted with: the term for
/// unknown sides from poses without every side recorded, the model's own from the others; a
/// part too small for a term of its own is refused, naming it.
#[test]
fn held_out_errors_renew_the_term_their_poses_are_predicted_with() {
    use gpu_amcs::identify::validate::held_out_term;
    let m = model(true);
    let pose = |k: usize, sides: Option<Joints>| {
        let q: Vec<f64> = (0..6)
            .map(|i| 3.0 * k as f64 - 20.0 + 5.0 * i as f64)
            .collect();
        let qr: Vec<f64> = q.iter().map(|v| v.to_radians()).collect();
        let mut p = m.predicted_position(&qr, None, true, false);
        p[0] += 0.05 * (k + 1) as f64;
        Measurement {
            q_deg: Joints::from_fn(6, |i| q[i]),
            position_mm: p,
            payload_kg: None,
            line: k as u64 + 2,
            target: None,
            on_base: false,
            sides,
        }
    };
    let norms = |d: &Discrepancy| d.residual_norms.clone();
    let own = |h: &gpu_amcs::identify::validate::HeldOutTerm| {
        let b = h
            .model
            .joint_errors
            .as_ref()
            .unwrap()
            .backlash
            .as_ref()
            .unwrap();
        (
            norms(h.model.discrepancy.as_ref().unwrap()),
            norms(b.sides_unknown.as_ref().unwrap()),
        )
    };
    // Without sides: the centre's errors, 0.05 … 0.60 mm, into the term for unknown sides.
    let unknown: Vec<Measurement> = (0..12).map(|k| pose(k, None)).collect();
    let h = held_out_term(&m, &unknown, Placement::Known).unwrap();
    let (d, u) = own(&h);
    assert_eq!(d, term(1.0).residual_norms);
    assert_eq!(u.len(), 12);
    for (k, r) in u.iter().enumerate() {
        assert!((r - 0.05 * (k + 1) as f64).abs() < 1e-9, "{u:?}");
    }
    // With every side: the model's own term, the other kept.
    let known: Vec<Measurement> = (0..12)
        .map(|k| pose(k, Some(Joints::filled(6, 1.0))))
        .collect();
    let h = held_out_term(&m, &known, Placement::Known).unwrap();
    let (d, u) = own(&h);
    assert_eq!(d.len(), 12);
    assert_eq!(u, term(3.0).residual_norms);
    // Twelve with their sides and three without: too few for the centre's term.
    let mixed: Vec<Measurement> = known
        .into_iter()
        .chain(unknown.into_iter().take(3))
        .collect();
    let err = held_out_term(&m, &mixed, Placement::Known)
        .unwrap_err()
        .to_string();
    assert!(err.contains("3 poses without every side recorded"), "{err}");
}

/// `validate` says which poses it predicts at the centre: a measurement file whose first pose has
/// no sides and the others every side, against a model with the term (one pose at the centre)
/// and without it (the sides drawn there).
#[test]
fn validate_says_which_poses_it_predicts_at_the_centre() {
    use crate::common::{arg, run_ok, tmpdir};
    let d = tmpdir("backlash_unknown_validate");
    let (with_term, without) = (arg(&d, "u.toml"), arg(&d, "p.toml"));
    std::fs::write(&with_term, model(true).to_toml()).unwrap();
    std::fs::write(&without, model(false).to_toml()).unwrap();
    let m = model(true);
    let rows: Vec<String> = (0..12)
        .map(|k| {
            let q: Vec<f64> = (0..6)
                .map(|i| 2.0 * k as f64 - 10.0 + 4.0 * i as f64)
                .collect();
            let qr: Vec<f64> = q.iter().map(|v| v.to_radians()).collect();
            let p = m.predicted_position(&qr, None, true, false);
            let s = if k == 0 {
                "0,0,0,0,0,0"
            } else {
                "1,-1,1,-1,1,-1"
            };
            let q: Vec<String> = q.iter().map(|v| v.to_string()).collect();
            format!("{},{},{},{},{s}", q.join(","), p[0], p[1], p[2])
        })
        .collect();
    let file = arg(&d, "meas.csv");
    let head = "q1,q2,q3,q4,q5,q6,x,y,z,s1,s2,s3,s4,s5,s6";
    std::fs::write(&file, format!("{head}\n{}\n", rows.join("\n"))).unwrap();
    let text = run_ok(&["validate", "--model", &with_term, &file, "--frame", "base"]);
    assert!(
        text.contains("approach sides recorded at 11 poses, every side at 11: those predicted with them, the others at the centre")
            && text.contains("1 of the 12 poses without every backlash side recorded: predicted at the centre"),
        "{text}"
    );
    let text = run_ok(&["validate", "--model", &without, &file, "--frame", "base"]);
    assert!(
        text.contains("the predictive check draws only the sides not recorded")
            && !text.contains("predicted at the centre"),
        "{text}"
    );
}
