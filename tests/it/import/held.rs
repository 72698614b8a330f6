//! Seven-axis arms imported with one joint held at a fixed angle: the KUKA LBR iiwa 14 R820 and
//! the Franka Emika Panda from their published DH tables, and a seven-joint URDF, each proved
//! against the seven-joint forward kinematics (written out here, no crate code) with the held
//! joint at its angle; the iiwa without a hold as a seven-axis model; and the refusals (eight
//! joints, too many held, bad holds).

use super::{dh_standard, dist, eye, import, mul, pos, rot, trans, write, M4};
use crate::common::{run, stderr, tmpdir};
use gpu_amcs::import::{import_file, ImportOptions, JointHold};
use gpu_amcs::kinematics::RobotModel;
use std::f64::consts::FRAC_PI_2;

/// The LBR iiwa 14 R820, standard DH `[θ, d, a, α]` in mm and rad (KUKA's figures: base to
/// shoulder 360 mm, shoulder to elbow 420 mm, elbow to wrist 400 mm, wrist to flange 126 mm),
/// limits ±170°, ±120°, ±170°, ±120°, ±170°, ±120°, ±175°.
pub(super) const IIWA: [[f64; 4]; 7] = [
    [0.0, 360.0, 0.0, -FRAC_PI_2],
    [0.0, 0.0, 0.0, FRAC_PI_2],
    [0.0, 420.0, 0.0, FRAC_PI_2],
    [0.0, 0.0, 0.0, -FRAC_PI_2],
    [0.0, 400.0, 0.0, -FRAC_PI_2],
    [0.0, 0.0, 0.0, FRAC_PI_2],
    [0.0, 126.0, 0.0, 0.0],
];
const IIWA_LIMITS: [f64; 7] = [170.0, 120.0, 170.0, 120.0, 170.0, 120.0, 175.0];

/// The Panda, Craig's modified DH `[θ_i, d_i, a_{i−1}, α_{i−1}]` in mm and rad, as Franka
/// publishes it, the flange 107 mm along joint 7's axis; limits in degrees (Franka's radians:
/// ±2.8973, ±1.7628, ±2.8973, −3.0718…−0.0698, ±2.8973, −0.0175…3.7525, ±2.8973).
pub(super) const PANDA: [[f64; 4]; 7] = [
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

/// Modified DH with a tip point `tool` in the last frame.
pub(super) fn dh_modified7(rows: &[[f64; 4]], q: &[f64], tool: [f64; 3]) -> [f64; 3] {
    let mut t: M4 = eye();
    for (r, qi) in rows.iter().zip(q) {
        t = mul(&t, &rot([1.0, 0.0, 0.0], r[3]));
        t = mul(&t, &trans(r[2], 0.0, 0.0));
        t = mul(&t, &rot([0.0, 0.0, 1.0], r[0] + qi));
        t = mul(&t, &trans(0.0, 0.0, r[1]));
    }
    pos(&mul(&t, &trans(tool[0], tool[1], tool[2])))
}

/// The six model joints' angles put back into seven, the held joint `k` (0-based) at `held`.
fn seven(q: &[f64], k: usize, held: f64) -> [f64; 7] {
    assert_eq!(q.len(), 6);
    let mut out = [0.0; 7];
    let mut it = q.iter();
    for (j, v) in out.iter_mut().enumerate() {
        *v = if j == k { held } else { *it.next().unwrap() };
    }
    out
}

/// Largest distance between the model and `reference` at 1000 configurations within the
/// model's limits and at the middle of its limits.
fn deviation(model: &RobotModel, reference: impl Fn(&[f64]) -> [f64; 3]) -> f64 {
    super::max_dev(model, reference)
}

fn opts(holds: &[(&str, f64)]) -> ImportOptions {
    ImportOptions {
        held: holds
            .iter()
            .map(|(j, a)| JointHold {
                joint: j.to_string(),
                angle_deg: *a,
            })
            .collect(),
        ..ImportOptions::default()
    }
}

pub(super) fn iiwa_csv() -> String {
    let mut s = String::from(
        "convention,standard\nunits,mm-deg\nname,LBR iiwa 14 R820\ntheta,d,a,alpha,lower,upper\n",
    );
    for (r, l) in IIWA.iter().zip(IIWA_LIMITS) {
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

#[test]
fn lbr_iiwa_with_joint_3_held_imports_as_a_six_axis_model() {
    let dir = tmpdir("iiwa");
    let path = write(&dir, "iiwa14.csv", &iiwa_csv());
    // Seven joints without a hold: a seven-axis model, proved against the seven-joint DH FK.
    let imp = import(&path).unwrap();
    assert_eq!(imp.model.joints(), 7);
    assert!(imp.max_deviation_mm < 1e-9, "{}", imp.max_deviation_mm);
    let dev = deviation(&imp.model, |q| dh_standard(&IIWA, q));
    assert!(dev < 1e-9, "seven axes: {dev}");
    // Eight joints: refused, naming the count and saying what to do.
    let eight = write(
        &dir,
        "iiwa8.csv",
        &format!("{}0,0,60,90,-170,170\n", iiwa_csv()),
    );
    let e = import(&eight).unwrap_err().to_string();
    assert!(
        e.contains("8 revolute joints") && e.contains("hold 1 of them"),
        "{e}"
    );
    for held in [0.0, 30.0, -95.0] {
        let imp = import_file(&path, &opts(&[("3", held)])).unwrap();
        assert!(imp.max_deviation_mm < 1e-9, "{}", imp.max_deviation_mm);
        assert!(
            imp.notes
                .iter()
                .any(|n| n.contains("joint 3") && n.contains("held")),
            "{:?}",
            imp.notes
        );
        assert!(imp.to_toml().contains("# Note: joint 'joint 3' held at"));
        let h = held.to_radians();
        let dev = deviation(&imp.model, |q| dh_standard(&IIWA, &seven(q, 2, h)));
        assert!(dev < 1e-9, "held {held}°: {dev}");
        let limits: Vec<f64> = imp.model.limits_deg.iter().map(|l| l.1).collect();
        assert_eq!(limits, [170.0, 120.0, 120.0, 170.0, 120.0, 175.0]);
        eprintln!(
            "iiwa 14, joint 3 held at {held}°: proof {:.2e} mm, 7-joint DH FK {dev:.2e} mm",
            imp.max_deviation_mm
        );
    }
    // The same joint by its name in the table.
    let by_name = import_file(&path, &opts(&[("joint 3", 0.0)])).unwrap();
    let by_number = import_file(&path, &opts(&[("3", 0.0)])).unwrap();
    assert_eq!(by_name.model, by_number.model);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The Panda's modified DH table as a DH TOML file, with its 107 mm flange as the tool.
pub(super) fn panda_toml() -> String {
    let mut s = String::from(
        "convention = \"modified\"\nunits = \"mm-deg\"\nname = \"Panda\"\ntool = [0.0, 0.0, 107.0]\n",
    );
    for (r, l) in PANDA.iter().zip(PANDA_LIMITS) {
        s.push_str(&format!(
            "\n[[joint]]\ntheta = {}\nd = {}\na = {}\nalpha = {}\nlimits = [{}, {}]\n",
            r[0].to_degrees(),
            r[1],
            r[2],
            r[3].to_degrees(),
            l.0.to_degrees(),
            l.1.to_degrees()
        ));
    }
    s
}

#[test]
fn panda_with_joint_7_held_imports_as_a_six_axis_model() {
    let dir = tmpdir("panda");
    let path = write(&dir, "panda.toml", &panda_toml());
    for held in [0.0, 45.0] {
        let imp = import_file(&path, &opts(&[("7", held)])).unwrap();
        assert!(imp.max_deviation_mm < 1e-9, "{}", imp.max_deviation_mm);
        let h = held.to_radians();
        let dev = deviation(&imp.model, |q| {
            dh_modified7(&PANDA, &seven(q, 6, h), [0.0, 0.0, 107.0])
        });
        assert!(dev < 1e-9, "held {held}°: {dev}");
        // At the published zero pose the flange is 88 mm forward and 926 mm up... less 107 mm:
        // x = 82.5 − 82.5 + 88, z = 333 + 316 + 384 − 107.
        let q0 = [0.0; 6];
        let p = imp.model.world_position(&q0);
        assert!(dist(p, [88.0, 0.0, 926.0]) < 1e-9, "{p:?}");
        eprintln!(
            "Panda, joint 7 held at {held}°: proof {:.2e} mm, 7-joint DH FK {dev:.2e} mm",
            imp.max_deviation_mm
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A seven-joint URDF (the iiwa's geometry as joint origins and axes): a joint held by its name
/// on the command line, the model proved and run; and the refusals, each one line naming the
/// joint or the flag.
#[test]
fn seven_joint_urdf_with_a_held_joint_on_the_command_line() {
    let dir = tmpdir("iiwa-urdf");
    let origins = [
        "0 0 0.1575",
        "0 0 0.2025",
        "0 0.2045 0",
        "0 0 0.2155",
        "0 0.1845 0",
        "0 0 0.2155",
        "0 0.081 0",
    ];
    // Every axis is its joint frame's z; the origins' rotations turn the frames (the layout of
    // the iiwa_stack description).
    let axes = ["0 0 1"; 7];
    let rpys = [
        "0 0 0",
        "1.5707963267948966 0 3.141592653589793",
        "1.5707963267948966 0 3.141592653589793",
        "1.5707963267948966 0 0",
        "-1.5707963267948966 3.141592653589793 0",
        "1.5707963267948966 0 0",
        "-1.5707963267948966 3.141592653589793 0",
    ];
    let mut s = String::from("<robot name=\"iiwa14\">\n  <link name=\"iiwa_link_0\"/>\n");
    for k in 1..=7 {
        s.push_str(&format!("  <link name=\"iiwa_link_{k}\"/>\n"));
    }
    s.push_str("  <link name=\"iiwa_link_ee\"/>\n");
    for k in 1..=7 {
        s.push_str(&format!(
            "  <joint name=\"iiwa_joint_{k}\" type=\"revolute\">\n    <parent link=\"iiwa_link_{}\"/>\n    <child link=\"iiwa_link_{k}\"/>\n    <origin xyz=\"{}\" rpy=\"{}\"/>\n    <axis xyz=\"{}\"/>\n    <limit lower=\"-2.0\" upper=\"2.0\" effort=\"1\" velocity=\"1\"/>\n  </joint>\n",
            k - 1,
            origins[k - 1],
            rpys[k - 1],
            axes[k - 1]
        ));
    }
    s.push_str("  <joint name=\"iiwa_joint_ee\" type=\"fixed\">\n    <parent link=\"iiwa_link_7\"/>\n    <child link=\"iiwa_link_ee\"/>\n    <origin xyz=\"0 0 0.045\" rpy=\"0 0 0\"/>\n  </joint>\n</robot>\n");
    let urdf = write(&dir, "iiwa14.urdf", &s);
    let u = urdf.to_str().unwrap();
    let out = dir.join("iiwa.toml");
    let o = out.to_str().unwrap();
    // The URDF's own FK (origins, rpy and axes composed here), joint 3 at 20°.
    let joints: Vec<([f64; 3], [f64; 3], [f64; 3])> = (0..7)
        .map(|k| {
            let v = |t: &str| -> [f64; 3] {
                let x: Vec<f64> = t.split(' ').map(|x| x.parse().unwrap()).collect();
                [x[0], x[1], x[2]]
            };
            (v(origins[k]).map(|x| 1000.0 * x), v(rpys[k]), v(axes[k]))
        })
        .collect();
    let fk7 = |q: &[f64]| -> [f64; 3] {
        let mut t = eye();
        for ((xyz, r, axis), qi) in joints.iter().zip(q) {
            t = mul(&t, &trans(xyz[0], xyz[1], xyz[2]));
            t = mul(&t, &super::rpy(r[0], r[1], r[2]));
            t = mul(&t, &rot(*axis, *qi));
        }
        pos(&mul(&t, &trans(0.0, 0.0, 45.0)))
    };
    let r = run(&["import", u, "-o", o, "--hold-joint", "iiwa_joint_3=20"]);
    assert!(r.status.success(), "{}", stderr(&r));
    assert!(
        stderr(&r).contains("note: joint 'iiwa_joint_3' held at 20°"),
        "{}",
        stderr(&r)
    );
    let model = RobotModel::from_file(&out).unwrap();
    let dev = deviation(&model, |q| fk7(&seven(q, 2, 20f64.to_radians())));
    assert!(dev < 1e-9, "{dev}");
    // Without a hold: a seven-axis model, the URDF's FK at all seven joints.
    let out7 = dir.join("iiwa7.toml");
    let r = run(&["import", u, "-o", out7.to_str().unwrap()]);
    assert!(r.status.success(), "{}", stderr(&r));
    let model7 = RobotModel::from_file(&out7).unwrap();
    assert_eq!(model7.joints(), 7);
    let dev = deviation(&model7, |q| fk7(q));
    assert!(dev < 1e-9, "seven axes: {dev}");
    // An eighth revolute joint past the flange: refused in one line naming the count and the
    // flag that holds a joint, no file written.
    let eight = write(
        &dir,
        "iiwa8.urdf",
        &s.replace(
            "</robot>\n",
            "  <link name=\"iiwa_link_8\"/>\n  <joint name=\"iiwa_joint_8\" type=\"revolute\">\n    <parent link=\"iiwa_link_ee\"/>\n    <child link=\"iiwa_link_8\"/>\n    <origin xyz=\"0 0 0.05\" rpy=\"0 0 0\"/>\n    <axis xyz=\"1 0 0\"/>\n    <limit lower=\"-2.0\" upper=\"2.0\" effort=\"1\" velocity=\"1\"/>\n  </joint>\n</robot>\n",
        ),
    );
    let out8 = dir.join("iiwa8.toml");
    let r = run(&[
        "import",
        eight.to_str().unwrap(),
        "-o",
        out8.to_str().unwrap(),
    ]);
    assert_eq!(r.status.code(), Some(2), "{}", stderr(&r));
    let e = stderr(&r);
    assert_eq!(e.trim().lines().count(), 1, "{e}");
    for w in [
        "8 revolute joints",
        "iiwa_joint_8",
        "hold 1 of them",
        "--hold-joint",
    ] {
        assert!(e.contains(w), "expected '{w}' in {e}");
    }
    assert!(!out8.exists(), "an eight-joint chain wrote a file");
    // The six-axis model runs the engine (σ = 0 until calibrated: w = 0, and a note says so).
    let r = run(&[
        "mcs",
        "--model",
        o,
        "--points",
        "5",
        "--draws",
        "2000",
        "--backend",
        "cpu",
    ]);
    assert!(r.status.success(), "{}", stderr(&r));
    assert!(
        crate::common::stdout(&r).contains("carries no uncertainty"),
        "{}",
        crate::common::stdout(&r)
    );
    // Refusals: no file written, one line naming what is wrong.
    let bad = dir.join("bad.toml");
    let b = bad.to_str().unwrap();
    for (args, want) in [
        (
            vec!["--hold-joint", "iiwa_joint_9=0"],
            vec!["'iiwa_joint_9'", "iiwa_joint_1"],
        ),
        (
            vec!["--hold-joint", "iiwa_joint_3=150"],
            vec!["iiwa_joint_3", "150°", "limits"],
        ),
        (
            vec!["--hold-joint", "3=0", "--hold-joint", "iiwa_joint_3=10"],
            vec!["held twice"],
        ),
        (
            vec![
                "--hold-joint",
                "2=0",
                "--hold-joint",
                "3=0",
                "--hold-joint",
                "4=0",
                "--hold-joint",
                "5=0",
            ],
            vec!["3 revolute joints", "4 to 7"],
        ),
        (
            vec!["--hold-joint", "3=abc"],
            vec!["--hold-joint", "not an angle"],
        ),
    ] {
        let mut a = vec!["import", u, "-o", b];
        a.extend(args.iter().copied());
        let r = run(&a);
        assert_eq!(r.status.code(), Some(2), "{args:?}: {}", stderr(&r));
        let e = stderr(&r);
        assert_eq!(e.trim().lines().count(), 1, "{e}");
        for w in want {
            assert!(e.contains(w), "{args:?}: expected '{w}' in {e}");
        }
        assert!(!bad.exists(), "{args:?} wrote a file");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The held iiwa runs every analysis: `calibrate` (simulated sweeps, identification, σ), then
/// `amcs`, `sensitivity`, `tail` and `map` on the calibrated model, and `plan` on the nominal one
/// with its default target (the imported tool sits on the flange axis up to rounding, 7.7e-15 mm
/// off it, so the plan takes the off-axis default rather than a target that hides joint 5).
#[test]
fn held_iiwa_runs_every_analysis() {
    let dir = tmpdir("iiwa-all");
    let path = write(&dir, "iiwa14.csv", &iiwa_csv());
    let p = |n: &str| dir.join(n).display().to_string();
    let ok = |args: &[&str]| {
        let r = run(args);
        assert!(r.status.success(), "{args:?}: {}", stderr(&r));
        crate::common::stdout(&r)
    };
    ok(&[
        "import",
        path.to_str().unwrap(),
        "-o",
        &p("iiwa.toml"),
        "--hold-joint",
        "3=0",
    ]);
    let cal = ok(&[
        "calibrate",
        "--model",
        &p("iiwa.toml"),
        "--runs",
        "2",
        "--step",
        "10",
        "-o",
        &p("cal.toml"),
    ]);
    assert!(cal.contains("improvement"), "{cal}");
    let m = p("cal.toml");
    ok(&[
        "amcs",
        "--model",
        &m,
        "--points",
        "10",
        "--backend",
        "cpu",
        "-q",
    ]);
    ok(&[
        "sensitivity",
        "--model",
        &m,
        "--points",
        "5",
        "--draws",
        "64",
        "--backend",
        "cpu",
        "-q",
    ]);
    ok(&[
        "tail",
        "--model",
        &m,
        "--points",
        "5",
        "--threshold",
        "0.3",
        "--backend",
        "cpu",
        "-q",
    ]);
    let map = ok(&[
        "map",
        "--model",
        &m,
        "--plane",
        "xz",
        "--at",
        "0",
        "--cells",
        "5,5",
        "--backend",
        "cpu",
        "--free-orientation",
    ]);
    assert!(!map.contains("reached    0 of"), "{map}");
    ok(&[
        "plan",
        "--model",
        &p("iiwa.toml"),
        "--poses",
        "20",
        "--candidates",
        "400",
        "--tracker-sigma",
        "0.01",
        "--draws",
        "20000",
        "--backend",
        "cpu",
        "-q",
        "--out",
        &p("design.csv"),
    ]);
    assert_eq!(
        std::fs::read_to_string(dir.join("design.csv"))
            .unwrap()
            .lines()
            .count(),
        21
    );
    let _ = std::fs::remove_dir_all(&dir);
}
