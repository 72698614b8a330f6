//! Plans a robot can run (issue 34): designs above a floor and outside keep-out boxes, clear of
//! the arm's own links, within the controller's joint limits (UR's elbow ±180°), in a visiting
//! order that keeps joint travel small, and written as URScript, RAPID and KRL programs whose
//! poses, parsed back, equal the design.

use crate::common::{self, run, tmpdir};
use gpu_amcs::identify::chain::nominal_state;
use gpu_amcs::kinematics::{Joints, RobotModel};
use gpu_amcs::plan::workcell::{capsules, clash, segment_distance, Clash};
use gpu_amcs::plan::{plan, KeepOut, Plan, PlanOptions, Workcell};
use nalgebra::Vector3;

fn preset(name: &str) -> RobotModel {
    gpu_amcs::presets::preset(name).unwrap()
}

/// A quick plan of `model` for a few task points with the workcell `w`.
fn quick_plan(model: &RobotModel, w: Workcell) -> Plan {
    quick_plan_approached(model, w, None)
}

/// [`quick_plan`] with every joint arriving at each pose from `approach`.
fn quick_plan_approached(
    model: &RobotModel,
    w: Workcell,
    approach: Option<gpu_amcs::plan::Approach>,
) -> Plan {
    let o = PlanOptions {
        poses: 20,
        candidates: 300,
        search_draws: 100,
        passes: 1,
        swaps: 20,
        random_designs: 5,
        thresholds: vec![0.03],
        workcell: w,
        approach,
        ..PlanOptions::default()
    };
    let mut m = model.clone();
    m.tool = o.target_mm;
    let task: Vec<Joints> = (0..5)
        .map(|k| Joints::from_fn(m.joints(), |j| 10.0 * (k + j) as f64 - 20.0))
        .collect();
    plan(&m, &task, &o).unwrap()
}

/// The lowest surface point of the moving links' capsules (link 1 on), mm.
fn lowest(model: &RobotModel, q_deg: &Joints) -> f64 {
    let s = nominal_state(model);
    capsules(model, &s, &q_deg.map(f64::to_radians), None)
        .iter()
        .filter(|c| c.link > 0)
        .map(|c| c.a.z.min(c.b.z) - c.radius)
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn planned_poses_stay_above_the_floor_outside_the_boxes_and_clear_of_the_arm() {
    // UR5e: base frame on the mounting surface, floor 50 mm above it (a table edge, say), a
    // box in front; TX60: base frame on the mounting surface too (the shoulder 375 mm above),
    // floor at the base.
    for (name, floor, boxes) in [
        (
            "ur5e",
            50.0,
            vec![KeepOut {
                min_mm: [400.0, -200.0, -100.0],
                max_mm: [900.0, 200.0, 300.0],
            }],
        ),
        ("tx60", 0.0, vec![]),
    ] {
        let model = preset(name);
        let w = Workcell {
            floor_mm: Some(floor),
            keep_out: boxes.clone(),
            ..Workcell::default()
        };
        let p = quick_plan(&model, w.clone());
        let m = &p.nominal;
        let s = nominal_state(m);
        assert!(p.rejected.floor > 0, "{name}: the floor refused nothing");
        let mut min_height = f64::INFINITY;
        for (k, q) in p.design_deg.iter().enumerate() {
            assert_eq!(
                clash(m, &s, &q.map(f64::to_radians), &w, true),
                None,
                "{name} pose {k}"
            );
            min_height = min_height.min(lowest(m, q) - floor);
            for (j, (v, (lo, hi))) in q.iter().zip(&p.limits_deg).enumerate() {
                assert!(*lo <= *v && *v <= *hi, "{name} pose {k} q{}", j + 1);
            }
        }
        eprintln!(
            "{name}: lowest link surface {min_height:.1} mm above the floor, travel {:.0}° ({:.0}° as chosen)",
            p.travel_deg, p.travel_unordered_deg
        );
        assert!(min_height >= 0.0, "{name}: {min_height}");
        // The same plan without a floor reaches below it.
        let free = quick_plan(&model, Workcell::default());
        let below = free
            .design_deg
            .iter()
            .map(|q| lowest(&free.nominal, q) - floor)
            .fold(f64::INFINITY, f64::min);
        assert!(below < 0.0, "{name}: {below}");
    }
}

#[test]
fn the_ur_elbow_is_kept_within_its_physical_half_turn_and_travel_falls_with_the_order() {
    let p = quick_plan(&preset("ur5e"), Workcell::default());
    assert_eq!(p.limits_deg[2], (-180.0, 180.0));
    assert!(p.limits_note.as_deref().unwrap_or("").contains("elbow"));
    let max_q3 = p.design_deg.iter().map(|q| q[2].abs()).fold(0.0, f64::max);
    assert!(max_q3 <= 175.0 + 1e-9, "{max_q3}");
    assert!(
        p.travel_deg < p.travel_unordered_deg,
        "{} vs {}",
        p.travel_deg,
        p.travel_unordered_deg
    );
    // The TX60's limits are its own.
    let t = quick_plan(&preset("tx60"), Workcell::default());
    assert!(t.limits_note.is_none());
    assert_eq!(
        t.limits_deg,
        t.nominal.limits_deg.iter().copied().collect::<Vec<_>>()
    );
}

#[test]
fn an_arm_folded_into_itself_collides_and_a_stretched_one_does_not() {
    for name in ["ur5e", "tx60"] {
        let m = preset(name);
        let s = nominal_state(&m);
        let w = Workcell::default();
        let n = m.joints();
        let q = |deg: &[f64]| Joints::from_fn(n, |j| deg[j].to_radians());
        // The elbow folded back on itself: the wrist lies on the upper arm / shoulder.
        let folded = q(&[0.0, -90.0, 180.0, 0.0, 0.0, 0.0]);
        match clash(&m, &s, &folded, &w, true) {
            Some(Clash::SelfCollision { a, b, depth_mm }) => {
                assert!(b >= a + 2 && depth_mm > 0.0, "{name}: {a} {b} {depth_mm}")
            }
            other => panic!("{name}: folded arm gave {other:?}"),
        }
        let stretched = q(&[0.0, -45.0, 45.0, 0.0, 45.0, 0.0]);
        assert_eq!(clash(&m, &s, &stretched, &w, true), None, "{name}");
        // Without the check, nothing is refused.
        let off = Workcell {
            self_collision: false,
            ..Workcell::default()
        };
        assert_eq!(clash(&m, &s, &folded, &off, true), None);
    }
    // Segment distance: crossing, parallel and end-to-end.
    let v = |x: f64, y: f64, z: f64| Vector3::new(x, y, z);
    let d = segment_distance(
        &v(-1., 0., 0.),
        &v(1., 0., 0.),
        &v(0., -1., 2.),
        &v(0., 1., 2.),
    );
    assert!((d - 2.0).abs() < 1e-12);
    let d = segment_distance(
        &v(0., 0., 0.),
        &v(1., 0., 0.),
        &v(3., 0., 0.),
        &v(4., 0., 0.),
    );
    assert!((d - 2.0).abs() < 1e-12);
    let d = segment_distance(
        &v(0., 0., 0.),
        &v(5., 0., 0.),
        &v(1., 3., 0.),
        &v(2., 3., 0.),
    );
    assert!((d - 3.0).abs() < 1e-12);
}

#[test]
fn an_iso9283_cube_below_the_floor_and_bad_workcells_are_refused_naming_the_flag() {
    let d = tmpdir("plan-runnable-refusals");
    let out = d.join("design.csv").display().to_string();
    // UR5e: points --iso9283 puts the cube's P1 with the flange near the base's level.
    let o = run(&[
        "plan",
        "--preset",
        "ur5e",
        "--iso9283",
        "--floor",
        "100",
        "--out",
        &out,
        "-q",
    ]);
    common::assert_fails_naming(&o, "--iso9283", "below the floor");
    for (args, flag) in [
        (vec!["--keep-out", "0,0,0,1,1"], "--keep-out"),
        (vec!["--link-radius", "-1"], "--link-radius"),
        (
            vec!["--program", &*d.join("p.txt").display().to_string()],
            "--program",
        ),
    ] {
        let mut a = vec![
            "plan",
            "--points",
            "5",
            "--poses",
            "12",
            "--candidates",
            "100",
        ];
        a.extend(args.iter().map(|s| &**s));
        a.extend(["--out", &out, "-q"]);
        let o = run(&a);
        common::assert_fails_naming(&o, flag, "");
    }
    assert!(!d.join("design.csv").exists());
}

/// The design CSV written by `--out`: degrees per pose.
fn design(csv: &str) -> Vec<Vec<f64>> {
    csv.lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect()
}

/// The numbers between the first `[`/`{` after `key` and its closing bracket, with the KRL axis
/// names dropped.
fn numbers_after(line: &str, key: &str, open: char, close: char) -> Option<Vec<f64>> {
    let rest = &line[line.find(key)? + key.len()..];
    let inner = &rest[rest.find(open)? + 1..];
    let inner = inner.trim_start_matches(open);
    let inner = &inner[..inner.find(close)?];
    Some(
        inner
            .split(',')
            .map(|f| f.split_whitespace().last().unwrap().parse().unwrap())
            .collect(),
    )
}

#[test]
fn robot_programs_parse_back_to_the_design() {
    let d = tmpdir("plan-programs");
    for (preset_name, file, fmt, waits) in [
        ("ur5e", "cal.script", None, "sleep("),
        ("irb2400", "cal.mod", None, "WaitTime"),
        ("kr6r700sixx", "cal.src", None, "WAIT SEC"),
        ("tx60", "cal.txt", Some("krl"), "WAIT SEC"),
    ] {
        let out = d.join(format!("{preset_name}.csv"));
        let prog = d.join(file);
        let mut a = vec![
            "plan".to_string(),
            "--preset".into(),
            preset_name.into(),
            "--points".into(),
            "5".into(),
            "--poses".into(),
            "12".into(),
            "--candidates".into(),
            "200".into(),
            "--draws".into(),
            "1000".into(),
            "--floor".into(),
            "-400".into(),
            "--out".into(),
            out.display().to_string(),
            "--program".into(),
            prog.display().to_string(),
            "-q".into(),
        ];
        if let Some(f) = fmt {
            a.extend(["--program-format".into(), f.into()]);
        }
        let args: Vec<&str> = a.iter().map(|s| s.as_str()).collect();
        let o = run(&args);
        assert!(o.status.success(), "{preset_name}: {}", common::stderr(&o));
        let want = design(&std::fs::read_to_string(&out).unwrap());
        let text = std::fs::read_to_string(&prog).unwrap();
        assert!(text.is_ascii(), "{preset_name}: a program must be ASCII");
        let (poses, tol): (Vec<Vec<f64>>, f64) = match file.rsplit('.').next() {
            Some("script") => (
                text.lines()
                    .filter_map(|l| numbers_after(l, "movej(", '[', ']'))
                    .map(|r| r.iter().map(|v| v.to_degrees()).collect())
                    .collect(),
                // 8 decimals of a radian against the design file's 6 of a degree.
                0.5e-8_f64.to_degrees() + 0.5e-6 + 1e-9,
            ),
            Some("mod") => (
                text.lines()
                    .filter_map(|l| numbers_after(l, "MoveAbsJ", '[', ']'))
                    .collect(),
                1e-9,
            ),
            _ => (
                text.lines()
                    .filter_map(|l| numbers_after(l, "PTP", '{', '}'))
                    .collect(),
                1e-9,
            ),
        };
        assert_eq!(poses.len(), want.len(), "{preset_name}:\n{text}");
        assert_eq!(text.matches(waits).count(), want.len(), "{preset_name}");
        for (k, (p, w)) in poses.iter().zip(&want).enumerate() {
            assert_eq!(p.len(), 6);
            for j in 0..6 {
                assert!(
                    (p[j] - w[j]).abs() <= tol,
                    "{preset_name} pose {k} q{}: {} vs {}",
                    j + 1,
                    p[j],
                    w[j]
                );
            }
        }
        // The header says whose angles these are.
        let known = preset_name == "ur5e";
        assert_eq!(
            text.contains("not known to gpu-amcs"),
            !known,
            "{preset_name}:\n{text}"
        );
    }
}

/// `--approach`: every joint arrives at each pose from the chosen side. The program moves to
/// an approach pose 2° short of each design pose on that side (every joint), then to the pose,
/// and waits once per pose; the design file gives the sides `s1..s6` a pose file records. (The
/// candidates' approach poses are checked against the limits and the workcell when they are
/// drawn; an approach pose outside a joint limit is refused naming the pose and joint.)
#[test]
fn an_approach_side_puts_an_approach_move_before_every_pose() {
    let d = tmpdir("plan-approach");
    for (preset_name, file, side, sign) in [
        ("ur5e", "cal.script", "positive", 1.0),
        ("irb2400", "cal.mod", "negative", -1.0),
    ] {
        let (sided, prog) = (d.join(format!("{preset_name}-sided.csv")), d.join(file));
        let mut a = vec![
            "plan",
            "--preset",
            preset_name,
            "--points",
            "5",
            "--poses",
            "12",
            "--candidates",
            "200",
            "--draws",
            "1000",
            "-q",
            "--approach",
            side,
        ];
        a.extend(["--out", sided.to_str().unwrap()]);
        a.extend(["--program", prog.to_str().unwrap()]);
        let o = run(&a);
        assert!(o.status.success(), "{preset_name}: {}", common::stderr(&o));
        let sided_text = std::fs::read_to_string(&sided).unwrap();
        let want: Vec<Vec<f64>> = (design(&sided_text).into_iter())
            .map(|r| r[..6].to_vec())
            .collect();
        assert_eq!(want.len(), 12);
        let mut lines = sided_text.lines();
        assert!(lines.next().unwrap().ends_with(",s1,s2,s3,s4,s5,s6"));
        let s = format!(",{sign}").repeat(6);
        assert!(
            lines.all(|l| l.ends_with(&s)),
            "{preset_name}:\n{sided_text}"
        );
        let text = std::fs::read_to_string(&prog).unwrap();
        let (moves, waits, tol): (Vec<Vec<f64>>, &str, f64) = if file.ends_with("script") {
            (
                text.lines()
                    .filter_map(|l| numbers_after(l, "movej(", '[', ']'))
                    .map(|r| r.iter().map(|v| v.to_degrees()).collect())
                    .collect(),
                "sleep(",
                0.5e-8_f64.to_degrees() + 0.5e-6 + 1e-9,
            )
        } else {
            (
                text.lines()
                    .filter_map(|l| numbers_after(l, "MoveAbsJ", '[', ']'))
                    .collect(),
                "WaitTime",
                1e-9,
            )
        };
        assert_eq!(moves.len(), 2 * want.len(), "{preset_name}:\n{text}");
        assert_eq!(text.matches(waits).count(), want.len());
        assert!(text.contains(&format!("every joint arrives at each pose moving {side}")));
        for (k, w) in want.iter().enumerate() {
            let (pre, at) = (&moves[2 * k], &moves[2 * k + 1]);
            for j in 0..6 {
                assert!(
                    (at[j] - w[j]).abs() <= tol,
                    "{preset_name} pose {k} q{}",
                    j + 1
                );
                // The move from the approach pose turns every joint by +2° × the side.
                let step = at[j] - pre[j];
                assert!(
                    (step - 2.0 * sign).abs() <= 2.0 * tol,
                    "{preset_name} {k} {j}: {step}"
                );
            }
        }
    }
    // A pose whose approach would start beyond a joint limit is refused, naming it.
    let mut p = quick_plan(&preset("tx60"), Workcell::default());
    let lo = p.limits_deg[1].0;
    p.design_deg[3][1] = lo + 0.5;
    let e = p
        .approach_poses(gpu_amcs::plan::Approach::Positive)
        .unwrap_err()
        .to_string();
    assert!(e.contains("pose 4") && e.contains("joint 2"), "{e}");
    assert!(p.approach_poses(gpu_amcs::plan::Approach::Negative).is_ok());
    // With a floor, every approach pose of a plan made with the approach keeps above it too.
    let mut mt = preset("ur5e");
    let floor = 50.0;
    let negative = Some(gpu_amcs::plan::Approach::Negative);
    let w = Workcell {
        floor_mm: Some(floor),
        ..Workcell::default()
    };
    let p = quick_plan_approached(&mt, w, negative);
    mt.tool = p.target_mm;
    assert_eq!(p.approach, negative);
    let pre = p
        .approach_poses(gpu_amcs::plan::Approach::Negative)
        .unwrap();
    for (q, a) in p.design_deg.iter().zip(&pre) {
        assert!(lowest(&mt, q) >= floor - 1e-9 && lowest(&mt, a) >= floor - 1e-9);
    }
}
