//! Robot import and export: every format from published figures, the proof, the refusals, the
//! round trip and the presets against their sources.
//!
//! The reference forward kinematics here is written out independently of the crate: plain 4×4
//! products of the source's own transforms (DH rows, URDF origins with Rodrigues rotations).
//!
//! Over 600 lines: every format is checked against published figures with the same FK proof; one file keeps the figures and their sources together.

use crate::common;

mod held;
mod inertial;
mod seven;
mod xacro;
mod xacro_ns;

use common::{arg, bin, run, stderr, tmpdir};
use gpu_amcs::import::{self, export, ImportError, ImportOptions, SourceFormat};
use gpu_amcs::kinematics::{self, position, Joints, RobotModel};
use gpu_amcs::presets;
use std::f64::consts::{FRAC_PI_2, PI};
use std::path::{Path, PathBuf};

/// Joints of the six-axis robots these tests import.
const JOINTS: usize = 6;

type M4 = [[f64; 4]; 4];

fn mul(a: &M4, b: &M4) -> M4 {
    let mut r = [[0.0; 4]; 4];
    for i in 0..4 {
        for j in 0..4 {
            r[i][j] = (0..4).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    r
}

fn eye() -> M4 {
    std::array::from_fn(|i| std::array::from_fn(|j| if i == j { 1.0 } else { 0.0 }))
}

fn trans(x: f64, y: f64, z: f64) -> M4 {
    let mut m = eye();
    m[0][3] = x;
    m[1][3] = y;
    m[2][3] = z;
    m
}

/// Rotation by `t` about the unit axis `u` (Rodrigues).
fn rot(u: [f64; 3], t: f64) -> M4 {
    let n = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt();
    let [x, y, z] = u.map(|v| v / n);
    let (s, c) = t.sin_cos();
    let v = 1.0 - c;
    let mut m = eye();
    m[0][0] = c + x * x * v;
    m[0][1] = x * y * v - z * s;
    m[0][2] = x * z * v + y * s;
    m[1][0] = y * x * v + z * s;
    m[1][1] = c + y * y * v;
    m[1][2] = y * z * v - x * s;
    m[2][0] = z * x * v - y * s;
    m[2][1] = z * y * v + x * s;
    m[2][2] = c + z * z * v;
    m
}

fn rpy(r: f64, p: f64, y: f64) -> M4 {
    mul(
        &rot([0.0, 0.0, 1.0], y),
        &mul(&rot([0.0, 1.0, 0.0], p), &rot([1.0, 0.0, 0.0], r)),
    )
}

fn pos(m: &M4) -> [f64; 3] {
    [m[0][3], m[1][3], m[2][3]]
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Standard DH, rows `[θ, d, a, α]` (mm, rad), q in rad.
fn dh_standard(rows: &[[f64; 4]], q: &[f64]) -> [f64; 3] {
    let mut t = eye();
    for (r, qi) in rows.iter().zip(q) {
        let z = [0.0, 0.0, 1.0];
        t = mul(&t, &rot(z, r[0] + qi));
        t = mul(&t, &trans(r[2], 0.0, r[1]));
        t = mul(&t, &rot([1.0, 0.0, 0.0], r[3]));
    }
    pos(&t)
}

/// Craig's modified DH, rows `[θ_i, d_i, a_{i−1}, α_{i−1}]` (mm, rad).
fn dh_modified(rows: &[[f64; 4]; 6], q: &[f64]) -> [f64; 3] {
    let mut t = eye();
    for (r, qi) in rows.iter().zip(q) {
        t = mul(&t, &rot([1.0, 0.0, 0.0], r[3]));
        t = mul(&t, &trans(r[2], 0.0, 0.0));
        t = mul(&t, &rot([0.0, 0.0, 1.0], r[0] + qi));
        t = mul(&t, &trans(0.0, 0.0, r[1]));
    }
    pos(&t)
}

/// URDF-style chain: per joint origin (xyz mm, rpy), axis; then the tip transform.
fn urdf_fk(joints: &[([f64; 3], [f64; 3], [f64; 3])], tip: &M4, q: &[f64]) -> [f64; 3] {
    let mut t = eye();
    for ((xyz, r, axis), qi) in joints.iter().zip(q) {
        t = mul(&t, &trans(xyz[0], xyz[1], xyz[2]));
        t = mul(&t, &rpy(r[0], r[1], r[2]));
        t = mul(&t, &rot(*axis, *qi));
    }
    pos(&mul(&t, tip))
}

/// Deterministic configurations within the model's limits (a small LCG: no crate randomness),
/// radians, one angle per joint of the model.
fn configs(model: &RobotModel, n: usize, seed: u64) -> Vec<Joints> {
    let mut s = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    let mut next = || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..n)
        .map(|_| {
            Joints::from_fn(model.joints(), |j| {
                let (lo, hi) = model.limits_deg[j];
                (lo + (hi - lo) * next()).to_radians()
            })
        })
        .collect()
}

/// Max deviation of the model's FK from `reference` over 1000 configurations and q = 0.
fn max_dev(model: &RobotModel, reference: impl Fn(&[f64]) -> [f64; 3]) -> f64 {
    let mut qs = configs(model, 1000, 7);
    qs.push(model.joints_at(0.0));
    qs.iter()
        .map(|q| dist(model.world_position(q), reference(q)))
        .fold(0.0, f64::max)
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn import(path: &Path) -> Result<import::Imported, ImportError> {
    import::import_file(path, &ImportOptions::default())
}

/// Largest deviation between `model` and the model imported back from its URDF export (written
/// into `dir`), mm.
fn urdf_round_trip(dir: &Path, model: &RobotModel) -> f64 {
    let back = import(&write(dir, "back.urdf", &export::to_urdf(model, None)))
        .unwrap()
        .model;
    max_dev(&back, |q| model.world_position(q))
}

/// The one-line error of importing `text` written as `dir/name`.
fn import_err(dir: &Path, name: &str, text: &str) -> String {
    let e = import(&write(dir, name, text)).unwrap_err().to_string();
    assert!(!e.contains('\n'), "one line: {e}");
    e
}

const UR5E_D: [f64; 6] = [162.5, 0.0, 0.0, 133.3, 99.7, 99.6];
const UR5E_A: [f64; 6] = [0.0, -425.0, -392.2, 0.0, 0.0, 0.0];
const UR10E_D: [f64; 6] = [180.7, 0.0, 0.0, 174.15, 119.85, 116.55];
const UR10E_A: [f64; 6] = [0.0, -612.7, -571.55, 0.0, 0.0, 0.0];
const UR_ALPHA: [f64; 6] = [FRAC_PI_2, 0.0, 0.0, FRAC_PI_2, -FRAC_PI_2, 0.0];

fn ur_rows(d: [f64; 6], a: [f64; 6]) -> [[f64; 4]; 6] {
    std::array::from_fn(|j| [0.0, d[j], a[j], UR_ALPHA[j]])
}

/// The flange of the UR5e at q = 0 (UR's table): (a2 + a3, −(d4 + d6), d1 − d5).
const UR5E_FLANGE_ZERO: [f64; 3] = [-817.2, -232.9, 62.8];

#[test]
fn standard_dh_csv_in_metres_radians() {
    let dir = tmpdir("dhcsv");
    let mut csv = String::from("# UR5e, UR's published DH table\nconvention,standard\nunits,m-rad\nname,UR5e from csv\ntheta,d,a,alpha,lower,upper\n");
    for j in 0..6 {
        csv.push_str(&format!(
            "0,{},{},{},{},{}\n",
            UR5E_D[j] / 1000.0,
            UR5E_A[j] / 1000.0,
            UR_ALPHA[j],
            -2.0 * PI,
            2.0 * PI
        ));
    }
    let imp = import(&write(&dir, "ur5e.csv", &csv)).unwrap();
    assert_eq!(imp.format, SourceFormat::StandardDh);
    assert_eq!(imp.model.name, "UR5e from csv");
    assert!(imp.max_deviation_mm <= 1e-9);
    assert_eq!(imp.configurations, import::PROOF_CONFIGURATIONS + 1);
    let rows = ur_rows(UR5E_D, UR5E_A);
    let dev = max_dev(&imp.model, |q| dh_standard(&rows, q));
    assert!(dev < 1e-9, "{dev}");
    let p0 = position(&imp.model.params, &imp.model.tool, &[0.0; 6]);
    assert!(dist(p0, UR5E_FLANGE_ZERO) < 1e-9, "{p0:?}");
    for (lo, hi) in imp.model.limits_deg {
        assert!((lo + 360.0).abs() < 1e-9 && (hi - 360.0).abs() < 1e-9);
    }
    // The header records the proof and the model file reads back.
    let text = imp.to_toml();
    assert!(text.contains("max tool-point deviation"), "{text}");
    assert!(text.contains("over 1001 configurations"), "{text}");
    let back = RobotModel::from_toml(&text, "x").unwrap();
    assert_eq!(back.params, imp.model.params);
}

#[test]
fn standard_dh_toml_in_mm_degrees() {
    let dir = tmpdir("dhtoml");
    let mut t = String::from("convention = \"standard\"\nunits = \"mm-deg\"\n");
    for j in 0..6 {
        t.push_str(&format!(
            "[[joint]]\ntheta = 0.0\nd = {}\na = {}\nalpha = {}\nlimits = [-360.0, 360.0]\n",
            UR10E_D[j],
            UR10E_A[j],
            UR_ALPHA[j].to_degrees()
        ));
    }
    let imp = import(&write(&dir, "ur10e.toml", &t)).unwrap();
    assert_eq!(imp.model.name, "ur10e");
    let rows = ur_rows(UR10E_D, UR10E_A);
    let dev = max_dev(&imp.model, |q| dh_standard(&rows, q));
    assert!(dev < 1e-9, "{dev}");
    // Extra or missing values are refused, never dropped.
    let three = t.replacen(
        "limits = [-360.0, 360.0]",
        "limits = [-360.0, 360.0, 5.0]",
        1,
    );
    let e = import(&write(&dir, "three.toml", &three))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("joint[1].limits") && e.contains("exactly 2"),
        "{e}"
    );
    let tool = t.replacen(
        "units = \"mm-deg\"\n",
        "units = \"mm-deg\"\ntool = [1.0, 2.0]\n",
        1,
    );
    let e = import(&write(&dir, "tool.toml", &tool))
        .unwrap_err()
        .to_string();
    assert!(e.contains("tool") && e.contains("exactly 3"), "{e}");
}

/// Craig's PUMA 560 table (Craig, Introduction to Robotics, table 3.4): α_{i−1}, a_{i−1}, d_i,
/// θ_i with a2 = 431.8, a3 = 20.32, d3 = 149.09, d4 = 433.07 mm; plus a tool 56.25 mm along z6.
#[test]
fn modified_dh_csv_in_mm_degrees() {
    let dir = tmpdir("mdh");
    // theta, d, a(i-1), alpha(i-1)
    let rows_deg: [[f64; 4]; 6] = [
        [0.0, 0.0, 0.0, 0.0],
        [0.0, 0.0, 0.0, -90.0],
        [0.0, 149.09, 431.8, 0.0],
        [0.0, 433.07, 20.32, -90.0],
        [0.0, 0.0, 0.0, 90.0],
        [0.0, 0.0, 0.0, -90.0],
    ];
    let mut csv = String::from(
        "convention,modified\nunits,mm-deg\ntool,0,0,56.25\ntheta,d,a,alpha,lower,upper\n",
    );
    for r in rows_deg {
        csv.push_str(&format!("{},{},{},{},-170,170\n", r[0], r[1], r[2], r[3]));
    }
    let imp = import(&write(&dir, "puma.csv", &csv)).unwrap();
    assert_eq!(imp.format, SourceFormat::ModifiedDh);
    let rows = rows_deg.map(|r| [r[0].to_radians(), r[1], r[2], r[3].to_radians()]);
    let dev = max_dev(&imp.model, |q| {
        let p = dh_modified(&rows, q);
        // tool along z6: recompute with the tool appended
        let mut t = eye();
        for (r, qi) in rows.iter().zip(q) {
            t = mul(&t, &rot([1.0, 0.0, 0.0], r[3]));
            t = mul(&t, &trans(r[2], 0.0, 0.0));
            t = mul(&t, &rot([0.0, 0.0, 1.0], r[0] + qi));
            t = mul(&t, &trans(0.0, 0.0, r[1]));
        }
        let tp = pos(&mul(&t, &trans(0.0, 0.0, 56.25)));
        assert!(dist(p, pos(&t)) == 0.0);
        tp
    });
    assert!(dev < 1e-9, "{dev}");
}

/// UR5e calibration file as UR's ROS description ships it (`default_kinematics.yaml`), rounded
/// angles and all.
const UR5E_CALIBRATION: &str = "\
kinematics:
  shoulder:
    x: 0
    y: 0
    z: 0.1625
    roll: 0
    pitch: 0
    yaw: 0
  upper_arm:
    x: 0
    y: 0
    z: 0
    roll: 1.570796327
    pitch: 0
    yaw: 0
  forearm:
    x: -0.425
    y: 0
    z: 0
    roll: 0
    pitch: 0
    yaw: 0
  wrist_1:
    x: -0.3922
    y: 0
    z: 0.1333
    roll: 0
    pitch: 0
    yaw: 0
  wrist_2:
    x: 0
    y: -0.0997
    z: -2.044881182297852e-11
    roll: 1.570796327
    pitch: 0
    yaw: 0
  wrist_3:
    x: 0
    y: 0.0996
    z: -2.042830148012698e-11
    roll: 1.570796326589793
    pitch: 3.141592653589793
    yaw: 3.141592653589793
  hash: calib_209549117540498681
";

fn ur_yaml_joints(text: &str) -> Vec<([f64; 3], [f64; 3], [f64; 3])> {
    let v: Vec<f64> = text
        .lines()
        .filter_map(|l| l.split_once(':'))
        .filter_map(|(_, v)| v.split('#').next().unwrap().trim().parse::<f64>().ok())
        .collect();
    (0..6)
        .map(|j| {
            let x = &v[6 * j..6 * j + 6];
            (
                [x[0] * 1e3, x[1] * 1e3, x[2] * 1e3],
                [x[3], x[4], x[5]],
                [0.0, 0.0, 1.0],
            )
        })
        .collect()
}

#[test]
fn ur_calibration_file() {
    let dir = tmpdir("ur");
    let imp = import(&write(&dir, "ur5e_calibration.yaml", UR5E_CALIBRATION)).unwrap();
    assert_eq!(imp.format, SourceFormat::UrCalibration);
    let joints = ur_yaml_joints(UR5E_CALIBRATION);
    let dev = max_dev(&imp.model, |q| urdf_fk(&joints, &eye(), q));
    assert!(dev < 1e-9, "{dev}");
    // The file's rounded π/2 (3e-10 rad off) moves the flange by far less than a micrometre.
    let p0 = position(&imp.model.params, &imp.model.tool, &[0.0; 6]);
    assert!(dist(p0, UR5E_FLANGE_ZERO) < 1e-6, "{p0:?}");
    // ... and against UR's DH table everywhere, to that rounding.
    let rows = ur_rows(UR5E_D, UR5E_A);
    assert!(max_dev(&imp.model, |q| dh_standard(&rows, q)) < 1e-6);
}

/// A UR10e calibration file in the style a controller's factory calibration produces: every
/// joint off its nominal by small lengths and angles, rotations near π written as roll/pitch/yaw
/// near π (test figures, not a real robot's).
const UR10E_CALIBRATED: &str = "\
# test figures in the style of a factory calibration
---
kinematics:
  shoulder:
    x: 0
    y: 0
    z: 0.1807193
    roll: -0
    pitch: 0
    yaw: 4.0e-07
  upper_arm:
    x: 0.000115
    y: 0
    z: 0
    roll: 1.57057447
    pitch: 0
    yaw: 1.0e-05
  forearm:
    x: -0.6127535
    y: 0
    z: 0
    roll: 3.14085459
    pitch: 3.14156384
    yaw: 3.14159004
  wrist_1:
    x: -0.5715611
    y: 0.0008017
    z: 0.1741035
    roll: 0.00058793
    pitch: -0.00070168
    yaw: 8.26e-06
  wrist_2:
    x: 0.0000531  # comment after a value
    y: -0.1198317
    z: 0.0000422
    roll: 1.5704152
    pitch: 0
    yaw: 1.6e-06
  wrist_3:
    x: 0
    y: 0.1165806
    z: -0.0000393
    roll: 1.5709651
    pitch: 3.14159265
    yaw: 3.14159240
  hash: calib_123
";

#[test]
fn calibrated_ur_file_uses_beta_on_the_parallel_axes() {
    let dir = tmpdir("urcal");
    let imp = import(&write(&dir, "cal.yml", UR10E_CALIBRATED)).unwrap();
    let joints = ur_yaml_joints(UR10E_CALIBRATED);
    let dev = max_dev(&imp.model, |q| urdf_fk(&joints, &eye(), q));
    assert!(dev < 1e-9, "{dev}");
    assert!(imp.max_deviation_mm < 1e-9);
    // J2 ∥ J3 ∥ J4 within the threshold: β form, β ≠ 0 from the calibration's tilts.
    use kinematics::{param_index, FixedParam, ParamKind};
    for j in [1, 2] {
        assert_eq!(imp.model.fixed[j], FixedParam::D, "J{}", j + 1);
        assert!(imp.model.params[param_index(j, ParamKind::Beta)].abs() > 1e-6);
    }
    assert_eq!(imp.model.fixed[0], FixedParam::Beta);
    // Exported again and re-imported: the same FK.
    let yaml = export::to_ur_calibration(&imp.model).unwrap();
    let back = import(&write(&dir, "back.yaml", &yaml)).unwrap().model;
    assert!(max_dev(&imp.model, |q| position(&back.params, &back.tool, q)) < 1e-9);
}

#[test]
fn ur_file_errors_name_the_line_and_key() {
    let dir = tmpdir("urbad");
    for (text, want) in [
        (
            UR5E_CALIBRATION.replace("    roll: 0\n", "    rol: 0\n"),
            "unknown key 'rol'",
        ),
        (
            UR5E_CALIBRATION.replace("z: 0.1625", "z: abc"),
            "kinematics.shoulder.z",
        ),
        (
            UR5E_CALIBRATION.replace("  wrist_3:", "  wrist_9:"),
            "unknown key 'wrist_9'",
        ),
        (
            UR5E_CALIBRATION.replace("kinematics:", "kin:"),
            "missing the top-level 'kinematics:'",
        ),
        (
            format!("---\n{UR5E_CALIBRATION}---\n{UR5E_CALIBRATION}"),
            "a second YAML document",
        ),
    ] {
        let e = import_err(&dir, "bad.yaml", &text);
        assert!(e.contains(want), "{want}: {e}");
        assert!(e.contains("bad.yaml:"), "{e}");
    }
    let no_x = UR5E_CALIBRATION.replacen("    x: -0.425\n", "", 1);
    let e = import_err(&dir, "nox.yaml", &no_x);
    assert!(e.contains("kinematics.forearm.x: missing"), "{e}");
}

#[test]
fn dh_table_errors_name_the_field() {
    let dir = tmpdir("dhbad");
    let good = "convention,standard\nunits,mm-deg\ntheta,d,a,alpha,lower,upper\n0,100,0,90,-10,10\n0,0,300,0,-10,10\n0,0,300,0,-10,10\n0,100,0,90,-10,10\n0,100,0,-90,-10,10\n0,80,0,0,-10,10\n";
    assert!(import(&write(&dir, "g.csv", good)).is_ok());
    for (text, want) in [
        (good.replace("units,mm-deg", "units,inch"), "units 'inch'"),
        (
            good.replace("convention,standard\n", ""),
            "missing 'convention'",
        ),
        (
            good.replace(
                "0,100,0,90,-10,10\n0,100,0,-90,-10,10\n0,80,0,0,-10,10\n",
                "",
            ),
            "3 revolute joints (joint 1, joint 2, joint 3); the model needs 4 to 7",
        ),
        (
            good.replace("0,80,0,0,-10,10", "0,80,0,0,10,-10"),
            "joint[6].limits",
        ),
        (
            good.replace("0,80,0,0,-10,10", "0,80,0,x,-10,10"),
            "'x' is not a number",
        ),
        (
            good.replace("0,80,0,0,-10,10", "0,80,0,0,-10"),
            "a row needs 6 values",
        ),
    ] {
        let e = import_err(&dir, "bad.csv", &text);
        assert!(e.contains(want), "{want}: {e}");
    }
    let toml = "convention = \"standard\"\nunits = \"m-rad\"\n[[joint]]\ntheta = 0.0\nd = 0.1\na = 0.0\nalpha = 1.0\nlimits = [-1.0, 1.0]\nfoo = 1\n";
    let e = import_err(&dir, "bad.toml", toml);
    assert!(e.contains("foo") && e.contains("bad.toml:"), "{e}");
}

/// The ABB IRB 2400 as its ROS-Industrial URDF describes it (xacro expanded), with the extra
/// `base` leaf that ROS-Industrial adds.
fn irb2400_urdf() -> String {
    std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/irb2400.urdf"
    ))
    .unwrap()
}

#[test]
fn urdf_irb2400_matches_its_source_and_the_preset() {
    let dir = tmpdir("irb");
    let path = write(&dir, "irb2400.urdf", &irb2400_urdf());
    // Two leaves (tool0 and base): without a tip, the link named tool0, and a note says so.
    let auto = import(&path).unwrap();
    assert_eq!(auto.notes, ["tip link 'tool0' (named tool0)"]);
    let opts = ImportOptions {
        tip: Some("tool0".into()),
        ..Default::default()
    };
    let imp = import::import_file(&path, &opts).unwrap();
    assert!(imp.notes.is_empty());
    assert_eq!(auto.model, imp.model);
    assert_eq!(imp.model.name, "abb_irb2400");
    let joints: Vec<_> = presets::IRB2400_URDF
        .iter()
        .map(|j| (j.xyz.map(|v| v * 1e3), [0.0; 3], j.axis))
        .collect();
    assert!(max_dev(&imp.model, |q| urdf_fk(&joints, &eye(), q)) < 1e-9);
    let p0 = position(&imp.model.params, &imp.model.tool, &[0.0; 6]);
    assert!(dist(p0, [940.0, 0.0, 1455.0]) < 1e-9, "{p0:?}");
    assert!((imp.model.limits_deg[1].0 - (-1.7453f64).to_degrees()).abs() < 1e-12);
    let preset = presets::irb2400();
    let dev = max_dev(&preset, |q| urdf_fk(&joints, &eye(), q));
    eprintln!("preset irb2400: max FK deviation from its URDF figures {dev:.3e} mm");
    assert!(dev < 1e-9);
}

/// The KUKA KR 6 R700 sixx of ROS-Industrial's `kuka_kr6_support` (kr6r700sixx_macro.xacro,
/// expanded): joint_a1 turns about −z, which the model's first axis (base +z) cannot hold.
fn kr6_urdf(a1_axis: &str) -> String {
    let joints = [
        ("joint_a1", "0 0 0.4", a1_axis, -170.0_f64, 170.0_f64),
        ("joint_a2", "0.025 0 0", "0 1 0", -190.0, 45.0),
        ("joint_a3", "0.315 0 0", "0 1 0", -120.0, 156.0),
        ("joint_a4", "0 0 0.035", "-1 0 0", -185.0, 185.0),
        ("joint_a5", "0.365 0 0", "0 1 0", -120.0, 120.0),
        ("joint_a6", "0.080 0 0", "-1 0 0", -350.0, 350.0),
    ];
    let mut s = String::from("<?xml version=\"1.0\"?>\n<robot name=\"kuka_kr6r700sixx\">\n  <link name=\"base_link\"/>\n");
    for k in 1..=6 {
        s.push_str(&format!("  <link name=\"link_{k}\"/>\n"));
    }
    s.push_str("  <link name=\"flange\"/>\n  <link name=\"tool0\"/>\n");
    for (k, (name, xyz, axis, lo, hi)) in joints.iter().enumerate() {
        let parent = if k == 0 {
            "base_link".to_string()
        } else {
            format!("link_{k}")
        };
        s.push_str(&format!(
            "  <joint name=\"{name}\" type=\"revolute\">\n    <origin xyz=\"{xyz}\" rpy=\"0 0 0\"/>\n    <parent link=\"{parent}\"/>\n    <child link=\"link_{}\"/>\n    <axis xyz=\"{axis}\"/>\n    <limit lower=\"{}\" upper=\"{}\" effort=\"0\" velocity=\"1\"/>\n  </joint>\n",
            k + 1,
            lo.to_radians(),
            hi.to_radians()
        ));
    }
    s.push_str("  <joint name=\"joint_a6-flange\" type=\"fixed\">\n    <parent link=\"link_6\"/>\n    <child link=\"flange\"/>\n    <origin xyz=\"0 0 0\" rpy=\"0 0 0\"/>\n  </joint>\n");
    s.push_str("  <joint name=\"flange-tool0\" type=\"fixed\">\n    <parent link=\"flange\"/>\n    <child link=\"tool0\"/>\n    <origin xyz=\"0 0 0\" rpy=\"0 1.5707963267948966 0\"/>\n  </joint>\n</robot>\n");
    s
}

/// The KR 6's joints for [`urdf_fk`] (mm), A1 about `a1_z`·z.
fn kr6_joints(a1_z: f64) -> [([f64; 3], [f64; 3], [f64; 3]); 6] {
    [
        ([0.0, 0.0, 400.0], [0.0, 0.0, a1_z]),
        ([25.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
        ([315.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
        ([0.0, 0.0, 35.0], [-1.0, 0.0, 0.0]),
        ([365.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
        ([80.0, 0.0, 0.0], [-1.0, 0.0, 0.0]),
    ]
    .map(|(x, a)| (x, [0.0; 3], a))
}

/// The KUKA KR 6 R700 sixx URDF, written from the ROS-Industrial figures: A1 turns about −z,
/// which the model holds with its base transform Rx(180°). The import and the preset equal the
/// URDF's own forward kinematics (composed from its transforms, no MDH code) within 1e-9 mm at
/// 1000 random configurations and q = 0, where the flange is at (785, 0, 435) mm; the model's
/// errors are those of its base-frame chain (the base is rigid).
#[test]
fn kr6_first_axis_down_imports_with_a_base_transform() {
    let dir = tmpdir("kr6");
    let imp = import(&write(&dir, "kr6.urdf", &kr6_urdf("0 0 -1"))).unwrap();
    let b = imp.model.base.expect("a base transform");
    assert_eq!((b.xyz, b.rpy), ([0.0; 3], [std::f64::consts::PI, 0.0, 0.0]));
    let down = kr6_joints(-1.0);
    let dev = max_dev(&imp.model, |q| urdf_fk(&down, &eye(), q));
    assert!(dev < 1e-9, "{dev}");
    let preset = presets::kr6r700sixx();
    let dev = max_dev(&preset, |q| urdf_fk(&down, &eye(), q));
    eprintln!("preset kr6r700sixx: max FK deviation from its URDF figures {dev:.3e} mm");
    assert!(dev < 1e-9, "{dev}");
    assert!(dist(preset.world_position(&[0.0; 6]), [785.0, 0.0, 435.0]) < 1e-9);
    let text = preset.to_toml();
    assert!(
        text.contains("base = { xyz = [0.0, 0.0, 0.0], rpy = [180.0, 0.0, 0.0] }"),
        "{text}"
    );
    let back = RobotModel::from_toml(&text, "kr6").unwrap();
    assert!(max_dev(&back, |q| preset.world_position(q)) < 1e-9);
    // The same arm with A1 about +z imports exactly (fixed joints folded into the tip).
    let imp = import(&write(&dir, "kr6up.urdf", &kr6_urdf("0 0 1"))).unwrap();
    let joints = kr6_joints(1.0);
    assert!(max_dev(&imp.model, |q| urdf_fk(&joints, &eye(), q)) < 1e-9);
    let p0 = position(&imp.model.params, &imp.model.tool, &[0.0; 6]);
    assert!(dist(p0, [785.0, 0.0, 435.0]) < 1e-9, "{p0:?}");
    let (lo, hi) = imp.model.limits_deg[1];
    assert!((lo + 190.0).abs() < 1e-12 && (hi - 45.0).abs() < 1e-12);
}

/// `urdf` with a `world` root link joined to its link `root` by a fixed joint at `xyz` (m),
/// `rpy` (rad), as a cell description mounts an arm.
fn mounted(urdf: &str, root: &str, xyz: &str, rpy: &str) -> String {
    urdf.replacen(
        "</robot>",
        &format!("  <link name=\"world\"/>\n  <joint name=\"mount\" type=\"fixed\">\n    <origin xyz=\"{xyz}\" rpy=\"{rpy}\"/>\n    <parent link=\"world\"/>\n    <child link=\"{root}\"/>\n  </joint>\n</robot>"),
        1,
    )
}

/// Imports `text` (an arm mounted by `mount` in its description's frame), checks the proof
/// (read from the import), the world positions against `mount` · the unmounted arm's and the
/// export → re-import round trip at random configurations; returns the model.
fn check_mounted(name: &str, text: &str, unmounted: &RobotModel, mount: &M4) -> RobotModel {
    let dir = tmpdir(&format!("mount-{name}"));
    let imp = import(&write(&dir, &format!("{name}.urdf"), text)).unwrap();
    assert_eq!(imp.configurations, import::PROOF_CONFIGURATIONS + 1);
    assert!(
        imp.max_deviation_mm < 1e-9,
        "{name}: proof {}",
        imp.max_deviation_mm
    );
    let m = imp.model;
    assert!(m.base.is_some(), "{name}: a base transform");
    let dev = max_dev(&m, |q| {
        let p = unmounted.world_position(q);
        pos(&mul(mount, &trans(p[0], p[1], p[2])))
    });
    assert!(dev < 1e-9, "{name}: {dev}");
    let back = import(&write(&dir, "back.urdf", &export::to_urdf(&m, None)))
        .unwrap()
        .model;
    let rt = max_dev(&back, |q| m.world_position(q));
    assert!(rt < 1e-9, "{name}: round trip {rt}");
    eprintln!(
        "{name}: proof {:.3e} mm, vs mount·arm {dev:.3e} mm, export→import {rt:.3e} mm, base {:?}",
        imp.max_deviation_mm, m.base
    );
    m
}

/// A UR5e on a wall (the world → base_link joint pitched 90°): joint 1's axis is horizontal and
/// becomes the model's base z; the MDH chain is the UR5e's own.
#[test]
// 1.5708: the rounded quarter turn a URDF writes, on purpose (3.7e-6 rad past it, the axis
// points slightly down).
#[allow(clippy::approx_constant)]
fn wall_mounted_ur5e_imports_with_its_base() {
    let ur5e = presets::ur5e();
    assert!(ur5e.base.is_none());
    let text = mounted(
        &export::to_urdf(&ur5e, None),
        "base_link",
        "0 0 0",
        "0 1.5708 0",
    );
    let m = check_mounted("wall", &text, &ur5e, &rpy(0.0, 1.5708, 0.0));
    // The arm is the same: the chain beyond joint 1 and the tool keep their values.
    for k in 1..30 {
        assert!((m.params[k] - ur5e.params[k]).abs() < 1e-9, "param {k}");
    }
    // The base is the mount itself (written as roll 180°, pitch 180° − 1.5708, yaw 180°: the
    // same turn with the pitch within ±90°).
    let b = m.base.unwrap();
    let mount = rpy(0.0, 1.5708, 0.0);
    for e in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] {
        let want = pos(&mul(&mount, &trans(e[0], e[1], e[2])));
        assert!(dist(b.apply(e), want) < 1e-12, "{b:?}");
    }
}

/// A world → base joint with an offset (100, 200, 300) mm and a small tilt.
#[test]
fn offset_and_tilted_mount_imports_with_its_base() {
    let dir = tmpdir("mount-direct");
    let direct = import(&write(&dir, "d.urdf", &simple_urdf("")))
        .unwrap()
        .model;
    let text = mounted(&simple_urdf(""), "l0", "0.1 0.2 0.3", "0.02 -0.03 0.5");
    let mount = mul(&trans(100.0, 200.0, 300.0), &rpy(0.02, -0.03, 0.5));
    check_mounted("offset", &text, &direct, &mount);
}

/// A KUKA-like chain whose first axis points down and lies 2.796 mm off the description's
/// origin (as in ROS-Industrial's KR 210 L150): the base is the half turn about x at the axis
/// point nearest the origin.
#[test]
fn kuka_first_axis_off_the_origin_imports() {
    let off = 0.002_795_836_679_707_883;
    let text = kr6_urdf("0 0 -1").replacen("0 0 0.4", &format!("{off} 0 0.4"), 1);
    let dir = tmpdir("kuka-off");
    let imp = import(&write(&dir, "k.urdf", &text)).unwrap();
    assert!(imp.max_deviation_mm < 1e-9, "{}", imp.max_deviation_mm);
    let b = imp.model.base.unwrap();
    assert_eq!(b.rpy, [PI, 0.0, 0.0]);
    assert!(dist(b.xyz, [off * 1000.0, 0.0, 0.0]) < 1e-12, "{b:?}");
    let mut joints = kr6_joints(-1.0);
    joints[0].0[0] = off * 1000.0;
    let dev = max_dev(&imp.model, |q| urdf_fk(&joints, &eye(), q));
    assert!(dev < 1e-9, "{dev}");
    let rt = urdf_round_trip(&dir, &imp.model);
    assert!(rt < 1e-9, "{rt}");
    // The same chain through the origin keeps the MDH parameters: the offset is all in the base.
    let centred = import(&write(&dir, "c.urdf", &kr6_urdf("0 0 -1")))
        .unwrap()
        .model;
    for k in 0..30 {
        assert!(
            (imp.model.params[k] - centred.params[k]).abs() < 1e-12,
            "param {k}"
        );
    }
    eprintln!(
        "KUKA off-origin: proof {:.3e} mm, vs URDF FK {dev:.3e} mm, round trip {rt:.3e} mm",
        imp.max_deviation_mm
    );
}

/// A six-revolute URDF chain with an optional extra joint snippet and edits.
fn simple_urdf(extra: &str) -> String {
    let mut s = String::from("<robot name=\"r\">\n  <link name=\"l0\"/>\n");
    for k in 1..=6 {
        s.push_str(&format!("  <link name=\"l{k}\"/>\n"));
    }
    let origins = [
        "0 0 0.3",
        "0 0.1 0",
        "0.4 0 0",
        "0.05 0 0.35",
        "0 0 0",
        "0 0 0.08",
    ];
    let axes = ["0 0 1", "0 1 0", "0 1 0", "0 0 1", "0 1 0", "0 0 1"];
    for k in 1..=6 {
        s.push_str(&format!(
            "  <joint name=\"j{k}\" type=\"revolute\">\n    <origin xyz=\"{}\"/>\n    <parent link=\"l{}\"/>\n    <child link=\"l{k}\"/>\n    <axis xyz=\"{}\"/>\n    <limit lower=\"-2\" upper=\"2\"/>\n  </joint>\n",
            origins[k - 1],
            k - 1,
            axes[k - 1]
        ));
    }
    s.push_str(extra);
    s.push_str("</robot>\n");
    s
}

fn refused(name: &str, text: &str, want: &[&str]) {
    // One directory per file name: tests calling this run in parallel.
    let e = import_err(&tmpdir(&format!("refuse-{name}")), name, text);
    for w in want {
        assert!(e.contains(w), "{name}: expected '{w}' in: {e}");
    }
}

/// `base` with `from` replaced by `to` inside joint `joint`'s element only.
fn with_joint(base: &str, joint: &str, from: &str, to: &str) -> String {
    let at = base.find(&format!("<joint name=\"{joint}\"")).unwrap();
    let end = at + base[at..].find("</joint>").unwrap();
    assert!(base[at..end].contains(from), "{joint}: {from}");
    format!(
        "{}{}{}",
        &base[..at],
        base[at..end].replacen(from, to, 1),
        &base[end..]
    )
}

#[test]
fn the_refusals_name_the_element() {
    let base = simple_urdf("");
    assert!(import(&write(&tmpdir("ok"), "ok.urdf", &base)).is_ok());
    let revolute = "type=\"revolute\"";
    let extra_joint = |name: &str, kind: &str, parent: &str, child: &str| {
        simple_urdf(&format!(
            "  <link name=\"{child}\"/>\n  <joint name=\"{name}\" type=\"{kind}\"><parent link=\"{parent}\"/><child link=\"{child}\"/><axis xyz=\"1 0 0\"/><limit lower=\"-1\" upper=\"1\"/></joint>\n"
        ))
    };
    let cases: Vec<(&str, String, Vec<&str>)> = vec![
        (
            "prismatic.urdf",
            with_joint(&base, "j3", revolute, "type=\"prismatic\""),
            vec!["joint 'j3'", "prismatic", "prismatic.urdf:"],
        ),
        (
            "floating.urdf",
            with_joint(&base, "j3", revolute, "type=\"floating\""),
            vec!["joint 'j3'", "floating"],
        ),
        (
            "planar.urdf",
            with_joint(&base, "j5", revolute, "type=\"planar\""),
            vec!["joint 'j5'", "planar"],
        ),
        (
            "mimic.urdf",
            with_joint(&base, "j2", "<axis", "<mimic joint=\"j1\"/><axis"),
            vec!["joint 'j2'", "mimic"],
        ),
        (
            "nolimit.urdf",
            with_joint(&base, "j1", "<limit lower=\"-2\" upper=\"2\"/>", ""),
            vec!["joint 'j1'", "without <limit"],
        ),
        (
            "zeroaxis.urdf",
            with_joint(&base, "j4", "xyz=\"0 0 1\"", "xyz=\"0 0 0\""),
            vec!["joint 'j4'", "cannot be normalised"],
        ),
        (
            "badaxis.urdf",
            with_joint(&base, "j1", "xyz=\"0 0 1\"", "xyz=\"0 0 x\""),
            vec!["joint 'j1'", "axis xyz"],
        ),
        (
            "malformed.urdf",
            base.replace("</robot>", "</robt>"),
            vec!["malformed XML", "malformed.urdf:"],
        ),
        (
            "x.urdf",
            "<robot xmlns:xacro=\"http://www.ros.org/wiki/xacro\" name=\"r\">\n<xacro:macro name=\"m\"/>\n</robot>\n".into(),
            vec!["xacro", "run xacro first", ":2"],
        ),
        (
            "three.urdf",
            with_joint(
                &with_joint(
                    &with_joint(&base, "j6", revolute, "type=\"fixed\""),
                    "j5",
                    revolute,
                    "type=\"fixed\"",
                ),
                "j4",
                revolute,
                "type=\"fixed\"",
            ),
            vec!["3 revolute joints", "j1, j2, j3", "4 to 7"],
        ),
        (
            "eight.urdf",
            simple_urdf(concat!(
                "  <link name=\"l7\"/>\n  <joint name=\"j7\" type=\"revolute\"><parent link=\"l6\"/><child link=\"l7\"/><axis xyz=\"1 0 0\"/><limit lower=\"-1\" upper=\"1\"/></joint>\n",
                "  <link name=\"l8\"/>\n  <joint name=\"j8\" type=\"revolute\"><origin xyz=\"0 0 0.05\"/><parent link=\"l7\"/><child link=\"l8\"/><axis xyz=\"0 1 0\"/><limit lower=\"-1\" upper=\"1\"/></joint>\n",
            )),
            vec!["8 revolute joints", "j7, j8", "hold 1 of them"],
        ),
        (
            // Two links hang off the last one: which is the tip cannot be told.
            "branch.urdf",
            simple_urdf(concat!(
                "  <link name=\"cam\"/>\n  <joint name=\"cam_joint\" type=\"fixed\"><parent link=\"l6\"/><child link=\"cam\"/></joint>\n",
                "  <link name=\"light\"/>\n  <joint name=\"light_joint\" type=\"fixed\"><parent link=\"l6\"/><child link=\"light\"/></joint>\n",
            )),
            vec!["branches", "cam, light", "name the tip link"],
        ),
        (
            "finger.urdf",
            extra_joint("finger", "prismatic", "l6", "f"),
            vec!["joint 'finger'", "prismatic"],
        ),
    ];
    for (name, text, want) in &cases {
        refused(name, text, want);
    }
    // Five and seven revolute joints are within the 4 to 7 a model takes: each imports as a
    // model of as many joints.
    for (name, text, joints) in [
        (
            "five.urdf",
            with_joint(&base, "j6", revolute, "type=\"fixed\""),
            5,
        ),
        ("seven.urdf", extra_joint("j7", "revolute", "l6", "l7"), 7),
    ] {
        let imp = import(&write(&tmpdir(&format!("count-{name}")), name, &text)).unwrap();
        assert_eq!(imp.model.joints(), joints, "{name}");
        assert!(
            imp.max_deviation_mm < 1e-9,
            "{name}: {}",
            imp.max_deviation_mm
        );
    }
    // Off the chain, a prismatic gripper finger is no concern once the tip is named.
    let p = write(
        &tmpdir("finger"),
        "finger.urdf",
        &extra_joint("finger", "prismatic", "l6", "f"),
    );
    let opts = ImportOptions {
        tip: Some("l6".into()),
        ..Default::default()
    };
    assert!(import::import_file(&p, &opts).is_ok());
}

#[test]
fn base_link_chooses_the_base_frame() {
    // A `world` root with the arm bolted 1 m off its origin: from `world` the bolt becomes the
    // model's base transform; from `l0` (the arm's own base) the chain is the same.
    let t = simple_urdf(
        "  <link name=\"world\"/>\n  <joint name=\"bolt\" type=\"fixed\"><origin xyz=\"1 0 0\"/><parent link=\"world\"/><child link=\"l0\"/></joint>\n",
    );
    let dir = tmpdir("base");
    let w = import(&write(&dir, "w.urdf", &t)).unwrap().model;
    let b = w.base.expect("the bolt as the base transform");
    assert_eq!((b.xyz, b.rpy), ([1000.0, 0.0, 0.0], [0.0; 3]));
    let opts = ImportOptions {
        base: Some("l0".into()),
        ..Default::default()
    };
    let m = import::import_file(&dir.join("w.urdf"), &opts)
        .unwrap()
        .model;
    let direct = import(&write(&dir, "d.urdf", &simple_urdf("")))
        .unwrap()
        .model;
    assert_eq!(m.params, direct.params);
    assert_eq!(w.params, direct.params);
    let opts = ImportOptions {
        base: Some("l9".into()),
        ..Default::default()
    };
    let e = import::import_file(&dir.join("w.urdf"), &opts).unwrap_err();
    assert!(
        e.to_string().contains("base link 'l9' is not in the file"),
        "{e}"
    );
    // A DH table in TOML has no line for a field: none is printed.
    let toml = "convention = \"standard\"\nunits = \"metres\"\njoint = []\n";
    let e = import_err(&dir, "u.toml", toml);
    assert!(
        e.ends_with("u.toml: units: 'metres' must be 'mm-deg' or 'm-rad'"),
        "{e}"
    );
}

#[test]
fn continuous_joints_get_360_degrees() {
    let t = simple_urdf("").replace(
        "<joint name=\"j6\" type=\"revolute\">",
        "<joint name=\"j6\" type=\"continuous\">",
    );
    let imp = import(&write(&tmpdir("cont"), "c.urdf", &t)).unwrap();
    assert_eq!(imp.model.limits_deg[5], (-360.0, 360.0));
    assert!((imp.model.limits_deg[0].1 - 2f64.to_degrees()).abs() < 1e-12);
}

#[test]
fn quat_xyzw_gives_the_rotation() {
    // 90° about z as a quaternion on j2's origin, and the same as rpy: same model.
    let s = std::f64::consts::FRAC_1_SQRT_2;
    let a = simple_urdf("").replace(
        "<origin xyz=\"0 0.1 0\"/>",
        &format!("<origin xyz=\"0 0.1 0\" quat_xyzw=\"0 0 {s} {s}\"/>"),
    );
    let b = simple_urdf("").replace(
        "<origin xyz=\"0 0.1 0\"/>",
        &format!("<origin xyz=\"0 0.1 0\" rpy=\"0 0 {FRAC_PI_2}\"/>"),
    );
    let dir = tmpdir("quat");
    let ma = import(&write(&dir, "a.urdf", &a)).unwrap().model;
    let mb = import(&write(&dir, "b.urdf", &b)).unwrap().model;
    let dev = max_dev(&ma, |q| position(&mb.params, &mb.tool, q));
    assert!(dev < 1e-9, "{dev}");
}

#[test]
fn what_the_mdh_cannot_hold_is_a_named_error() {
    let dir = tmpdir("unrep");
    // J3 on the same line as J2 (coincident axes): no common normal.
    let same =
        simple_urdf("").replacen("<origin xyz=\"0.4 0 0\"/>", "<origin xyz=\"0 0.2 0\"/>", 1);
    refused("same.urdf", &same, &["joint 'j2'", "parallel-axis"]);
    let _ = dir;
}

#[test]
fn the_proof_catches_a_wrong_conversion() {
    let rows = ur_rows(UR5E_D, UR5E_A);
    let table = import::dh::DhTable {
        name: "ur5e".into(),
        convention: import::dh::Convention::Standard,
        rows: rows
            .iter()
            .map(|r| import::dh::DhRow {
                params: *r,
                limits_deg: (-360.0, 360.0),
            })
            .collect(),
        tool: [0.0; 3],
    };
    let chain = table.to_chain();
    let good = import::convert(&chain, "t").unwrap().model;
    assert!(import::prove(&chain, &good, "t").is_ok());
    // A model off by 1e-6 mm in one length (or an angle sign) is caught, naming the size.
    let mut bad = good.clone();
    bad.params[kinematics::param_index(2, kinematics::ParamKind::A)] += 1e-6;
    let e = import::prove(&chain, &bad, "t").unwrap_err();
    match &e {
        ImportError::Proof { deviation_mm, .. } => assert!(*deviation_mm > 5e-7, "{e}"),
        _ => panic!("{e}"),
    }
    let mut flipped = good.clone();
    flipped.params[kinematics::param_index(3, kinematics::ParamKind::Alpha)] *= -1.0;
    assert!(import::prove(&chain, &flipped, "t").is_err());
}

/// A calibrated-looking model: the TX60 with small errors on every parameter, β on J2, and a
/// tool point off the flange axis.
fn perturbed_tx60() -> RobotModel {
    let mut m = kinematics::tx60();
    for (k, p) in m.params.iter_mut().enumerate() {
        *p += 1e-3 * ((k as f64 * 1.7).sin());
    }
    m.params[9] = 2e-4; // β2
    m.tool = [30.0, -20.0, 80.0];
    m
}

fn round_trip_dev(m: &RobotModel, text: &str, name: &str) -> f64 {
    let dir = tmpdir("rt");
    let imp = import(&write(&dir, name, text)).unwrap();
    let back = imp.model;
    assert_eq!(back.limits_deg.len(), JOINTS);
    max_dev(m, |q| back.world_position(q))
}

#[test]
fn export_import_round_trip() {
    for m in [
        perturbed_tx60(),
        kinematics::tx60(),
        presets::ur5e(),
        presets::irb2400(),
        presets::kr6r700sixx(),
    ] {
        let urdf = export::to_urdf(&m, None);
        assert!(urdf.contains("does not fit in URDF"));
        let dev = round_trip_dev(&m, &urdf, "m.urdf");
        assert!(dev < 1e-9, "{}: URDF round trip {dev}", m.name);
        let back = import(&write(&tmpdir("rt2"), "m.urdf", &urdf))
            .unwrap()
            .model;
        for j in 0..JOINTS {
            assert!((back.limits_deg[j].0 - m.limits_deg[j].0).abs() < 1e-9);
            assert!((back.limits_deg[j].1 - m.limits_deg[j].1).abs() < 1e-9);
        }
    }
    for m in [presets::ur5e(), presets::ur10e(), kinematics::tx60()] {
        let yaml = export::to_ur_calibration(&m).unwrap();
        assert!(yaml.contains("does not fit here"));
        // The `hash` key the ROS 2 UR description requires: a digest of the kinematics lines,
        // so another geometry gives another hash.
        let hash = yaml
            .lines()
            .find_map(|l| l.strip_prefix("  hash: calib_gpu_amcs_"))
            .unwrap();
        assert_eq!(hash.len(), 16);
        let mut moved = m.clone();
        moved.params[1] += 0.5;
        assert!(!export::to_ur_calibration(&moved).unwrap().contains(hash));
        let dev = round_trip_dev(&m, &yaml, "m.yaml");
        assert!(dev < 1e-9, "{}: UR round trip {dev}", m.name);
    }
    // A tool point off the flange axis has no place in UR's format.
    let e = export::to_ur_calibration(&perturbed_tx60()).unwrap_err();
    assert!(e.to_string().contains("off the joint-6 axis"), "{e}");
}

#[test]
fn presets_equal_their_sources() {
    let ur5e = presets::ur5e();
    let rows = ur_rows(UR5E_D, UR5E_A);
    let dev = max_dev(&ur5e, |q| dh_standard(&rows, q));
    eprintln!("preset ur5e: max FK deviation from UR's DH table {dev:.3e} mm");
    assert!(dev < 1e-9);
    let p0 = position(&ur5e.params, &ur5e.tool, &[0.0; 6]);
    assert!(dist(p0, UR5E_FLANGE_ZERO) < 1e-9, "{p0:?}");
    let ur10e = presets::ur10e();
    let rows = ur_rows(UR10E_D, UR10E_A);
    let dev = max_dev(&ur10e, |q| dh_standard(&rows, q));
    eprintln!("preset ur10e: max FK deviation from UR's DH table {dev:.3e} mm");
    assert!(dev < 1e-9);
    let p0 = position(&ur10e.params, &ur10e.tool, &[0.0; 6]);
    let want = [-612.7 - 571.55, -(174.15 + 116.55), 180.7 - 119.85];
    assert!(dist(p0, want) < 1e-9, "{p0:?}");
    for name in presets::PRESETS {
        let m = presets::preset(name).unwrap();
        // Every preset is a valid model file.
        RobotModel::from_toml(&m.to_toml(), name).unwrap();
    }
}

fn ok(o: &std::process::Output) -> String {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn cli_import_export_and_model_list() {
    let dir = tmpdir("cli");
    let urdf = write(&dir, "irb.urdf", &irb2400_urdf());
    let out = dir.join("irb.toml");
    // ROS-Industrial's tree: tool0 is the tip unless another is named, and a note says so.
    let o = run(&["import", s(&urdf), "--out", s(&out)]);
    assert_eq!(o.status.code(), Some(0));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("note: tip link 'tool0' (named tool0)"),
        "{err}"
    );
    let auto = std::fs::read_to_string(&out).unwrap();
    std::fs::remove_file(&out).unwrap();
    let said = ok(&run(&[
        "import",
        s(&urdf),
        "--out",
        s(&out),
        "--tip",
        "tool0",
    ]));
    assert!(said.contains("max deviation"), "{said}");
    let toml = std::fs::read_to_string(&out).unwrap();
    assert!(toml.starts_with("# Imported by gpu-amcs"), "{toml}");
    assert_eq!(auto, toml);
    // The input is never overwritten.
    let o = run(&["import", s(&urdf), "--out", s(&urdf), "--tip", "tool0"]);
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(std::fs::read_to_string(&urdf).unwrap(), irb2400_urdf());
    // Export back to URDF and UR yaml.
    let back = dir.join("back.urdf");
    let yaml = dir.join("back.yaml");
    ok(&run(&[
        "export",
        "--model",
        s(&out),
        "--urdf",
        s(&back),
        "--name",
        "irb_back",
    ]));
    assert!(std::fs::read_to_string(&back)
        .unwrap()
        .contains("<robot name=\"irb_back\">"));
    ok(&run(&[
        "export",
        "--preset",
        "ur5e",
        "--ur-calibration",
        s(&yaml),
    ]));
    assert!(std::fs::read_to_string(&yaml)
        .unwrap()
        .starts_with("# Written by gpu-amcs"));
    // Nothing to write is a usage error; a tool off the flange axis cannot go to UR's format.
    assert_eq!(run(&["export", "--preset", "ur5e"]).status.code(), Some(2));
    let list = ok(&run(&["model", "--list"]));
    for p in presets::PRESETS {
        assert!(list.contains(p), "{list}");
    }
    // fk prints full precision: the UR5e flange at q = 0 to the last digit.
    let pts = write(&dir, "q.csv", "q1,q2,q3,q4,q5,q6\n0,0,0,0,0,0\n");
    let text = ok(&run(&["fk", "--preset", "ur5e", "--points-file", s(&pts)]));
    let row: Vec<f64> = text
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    let m = presets::ur5e();
    let p = position(&m.params, &m.tool, &[0.0; 6]);
    assert_eq!(&row[6..9], &p, "{text}");
}

/// Import applies the model file's own rules, naming the source's joint and element, so it
/// never writes a model that every other command refuses; a repeated DH directive is an error;
/// a reach that suggests the wrong units is a warning.
#[test]
fn imports_are_validated_as_model_files() {
    let base = simple_urdf("");
    // Limits of ±100 rad (5730°) on joint 3, and a 1 km link before joint 4.
    refused(
        "limits.urdf",
        &with_joint(
            &base,
            "j3",
            "lower=\"-2\" upper=\"2\"",
            "lower=\"-100\" upper=\"100\"",
        ),
        &["joint 'j3'", "limits", "720", "limits.urdf"],
    );
    refused(
        "km.urdf",
        &with_joint(&base, "j4", "0.05 0 0.35", "1000 0 0.35"),
        &[
            "joint 'j3'",
            "MDH a (the model's joint[3].a)",
            "1000000 mm is out of range",
            "check the units",
        ],
    );
    // A DH table that states its units twice: the second no longer silently wins.
    let dir = tmpdir("dh-twice");
    let good = "convention,standard\nunits,mm-deg\ntheta,d,a,alpha,lower,upper\n0,100,0,90,-10,10\n0,0,300,0,-10,10\n0,0,300,0,-10,10\n0,100,0,90,-10,10\n0,100,0,-90,-10,10\n0,80,0,0,-10,10\n";
    let twice = good.replace("units,mm-deg\n", "units,mm-deg\nunits,m-rad\n");
    let e = import_err(&dir, "twice.csv", &twice);
    assert!(
        e.contains("twice.csv:3") && e.contains("'units' is given twice"),
        "{e}"
    );
    let e = import_err(&dir, "conv.csv", &format!("convention,modified\n{good}"));
    assert!(e.contains("'convention' is given twice"), "{e}");
    // A metres table labelled mm-deg converts, with a warning naming the units; a good one
    // has none.
    let metres = good
        .replace("0,100,0,90", "0,0.1,0,90")
        .replace("0,0,300,0", "0,0,0.3,0")
        .replace("0,80,0,0", "0,0.08,0,0")
        .replace("0,100,0,-90", "0,0.1,0,-90");
    let imp = import(&write(&dir, "metres.csv", &metres)).unwrap();
    assert_eq!(imp.warnings.len(), 1, "{:?}", imp.warnings);
    assert!(imp.warnings[0].contains("metres"), "{:?}", imp.warnings);
    assert!(import(&write(&dir, "good.csv", good))
        .unwrap()
        .warnings
        .is_empty());
    // The command line prints the warning and still writes the model.
    let out = dir.join("m.toml");
    let o = bin()
        .args([
            "import",
            &arg(&dir, "metres.csv"),
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).starts_with("warning: the arm reaches only"),
        "{}",
        stderr(&o)
    );
    assert!(out.exists());
    // An analysis of it names the model, not a box flag the user never gave.
    let o = run(&[
        "mcs",
        "--model",
        out.to_str().unwrap(),
        "-q",
        "--backend",
        "cpu",
    ]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(
        e.starts_with("error: --model:") && e.contains("metres") && !e.contains("--box"),
        "{e}"
    );
}

/// What used to be accepted silently or worded badly: duplicate joint and link names, an origin
/// with both rpy and quat_xyzw, a URDF whose joints form a cycle.
#[test]
fn ambiguous_urdf_elements_are_refused() {
    let base = simple_urdf("");
    refused(
        "dupjoint.urdf",
        &base.replacen("joint name=\"j5\"", "joint name=\"j2\"", 1),
        &[
            "joint 'j2'",
            "a second joint of this name (the first is on line",
        ],
    );
    refused(
        "duplink.urdf",
        &base.replacen(
            "<link name=\"l6\"/>\n",
            "<link name=\"l6\"/>\n  <link name=\"l6\"/>\n",
            1,
        ),
        &["link 'l6'", "a second link of this name"],
    );
    refused(
        "both.urdf",
        &with_joint(
            &base,
            "j2",
            "<origin xyz=\"0 0.1 0\"/>",
            "<origin xyz=\"0 0.1 0\" rpy=\"0 0 0\" quat_xyzw=\"0 0 0 1\"/>",
        ),
        &["both rpy and quat_xyzw"],
    );
    // l0 gets a parent: every link has one.
    let cycle = simple_urdf(
        "  <joint name=\"back\" type=\"fixed\"><parent link=\"l6\"/><child link=\"l0\"/></joint>\n",
    );
    let e = import_err(&tmpdir("cycle"), "cycle.urdf", &cycle);
    assert!(
        e.contains("found none: the joints form a cycle") && !e.ends_with(':'),
        "{e}"
    );
}

/// A URDF with the tip not named: a link named `tool0` first, then one named `flange`, then the
/// single deepest leaf of the longest revolute chain (a sensor hanging off link 2 is not the
/// arm); two such leaves are ambiguous and refused naming every leaf.
#[test]
fn default_tip_prefers_tool0_then_flange_then_the_longest_chain() {
    let dir = tmpdir("tips");
    // A six-joint arm from base_link to link_6 (all axes along z or y, offsets in metres).
    let arm = |extra: &str| -> String {
        let mut s = String::from("<robot name=\"arm\">\n  <link name=\"base_link\"/>\n");
        let axes = ["0 0 1", "0 1 0", "0 1 0", "1 0 0", "0 1 0", "1 0 0"];
        let xyz = [
            "0 0 0.3",
            "0.05 0 0.1",
            "0 0 0.4",
            "0.1 0 0.05",
            "0.3 0 0",
            "0.08 0 0",
        ];
        for j in 0..6 {
            let parent = if j == 0 {
                "base_link".to_string()
            } else {
                format!("link_{j}")
            };
            s.push_str(&format!(
                "  <link name=\"link_{}\"/>\n  <joint name=\"j{}\" type=\"revolute\">\n    \
                 <parent link=\"{parent}\"/>\n    <child link=\"link_{}\"/>\n    \
                 <origin xyz=\"{}\" rpy=\"0 0 0\"/>\n    <axis xyz=\"{}\"/>\n    \
                 <limit lower=\"-3\" upper=\"3\" effort=\"1\" velocity=\"1\"/>\n  </joint>\n",
                j + 1,
                j + 1,
                j + 1,
                xyz[j],
                axes[j]
            ));
        }
        s.push_str(extra);
        s.push_str("</robot>\n");
        s
    };
    let fixed = |parent: &str, child: &str| {
        format!(
            "  <link name=\"{child}\"/>\n  <joint name=\"{parent}-{child}\" type=\"fixed\">\n    \
             <parent link=\"{parent}\"/>\n    <child link=\"{child}\"/>\n    \
             <origin xyz=\"0 0 0.01\" rpy=\"0 0 0\"/>\n  </joint>\n"
        )
    };
    let sensor = fixed("link_2", "camera");
    let cases = [
        (
            format!(
                "{}{}{sensor}",
                fixed("link_6", "flange"),
                fixed("flange", "tool0")
            ),
            "tip link 'tool0' (named tool0)",
        ),
        (
            format!("{}{sensor}", fixed("link_6", "flange")),
            "tip link 'flange' (named flange)",
        ),
        (
            format!("{}{sensor}", fixed("link_6", "gripper")),
            "tip link 'gripper' (the deepest leaf of the longest revolute chain)",
        ),
    ];
    for (k, (extra, note)) in cases.iter().enumerate() {
        let path = write(&dir, &format!("t{k}.urdf"), &arm(extra));
        let imp = import(&path).unwrap();
        assert_eq!(imp.notes, [note.to_string()], "case {k}");
    }
    // A single leaf is the tip without a choice: no note.
    let imp = import(&write(&dir, "single.urdf", &arm(""))).unwrap();
    assert!(imp.notes.is_empty(), "{:?}", imp.notes);
    // Two grippers at the end of the arm: ambiguous.
    let two = format!("{}{}", fixed("link_6", "left"), fixed("link_6", "right"));
    let path = write(&dir, "two.urdf", &arm(&two));
    let e = import(&path).unwrap_err();
    assert!(matches!(e, ImportError::Branching { .. }), "{e}");
    assert!(e.to_string().contains("left, right"), "{e}");
    // On an analysis command: the note, and --tip to choose another link; an ambiguous tree
    // says to name one.
    let path = write(
        &dir,
        "flange.urdf",
        &arm(&format!("{}{sensor}", fixed("link_6", "flange"))),
    );
    let q = write(&dir, "q.csv", "q1,q2,q3,q4,q5,q6\n0,0,0,0,0,0\n");
    let q = q.display().to_string();
    let o = run(&[
        "fk",
        "--model",
        &path.display().to_string(),
        "--points-file",
        &q,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("tip link 'flange' (named flange)"),
        "{}",
        stderr(&o)
    );
    let o = run(&[
        "fk",
        "--model",
        &path.display().to_string(),
        "--tip",
        "link_6",
        "--points-file",
        &q,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("note"), "{}", stderr(&o));
    let two = write(
        &dir,
        "two2.urdf",
        &arm(&format!(
            "{}{}",
            fixed("link_6", "left"),
            fixed("link_6", "right")
        )),
    );
    let o = run(&[
        "mcs",
        "--backend",
        "cpu",
        "--model",
        &two.display().to_string(),
        "--draws",
        "1000",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--tip LINK"), "{}", stderr(&o));
    let o = run(&[
        "mcs",
        "--backend",
        "cpu",
        "--tip",
        "tool0",
        "--draws",
        "1000",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("--tip names the tip link"),
        "{}",
        stderr(&o)
    );
}

/// `import` says where it found joint 1 when that is not the description's origin along z: the
/// KR 6 exported to URDF (its first axis points down) comes back with the base Rx(180°), and the
/// command prints it; the TX60 (axis up through the origin) prints nothing of the kind.
#[test]
fn import_prints_the_base_it_inferred() {
    let dir = tmpdir("base-note");
    for (preset, want) in [
        ("kr6r700sixx", Some("xyz (0, 0, 0) mm, rpy (180, 0, 0)°")),
        ("tx60", None),
    ] {
        let urdf = dir.join(format!("{preset}.urdf"));
        let toml = dir.join(format!("{preset}.toml"));
        let o = run(&["export", "--preset", preset, "--urdf", s(&urdf)]);
        assert!(o.status.success(), "{}", stderr(&o));
        let o = run(&["import", s(&urdf), "--out", s(&toml)]);
        assert!(o.status.success(), "{}", stderr(&o));
        let err = stderr(&o);
        match want {
            Some(w) => assert!(err.contains(w), "{preset}: {err}"),
            None => assert!(!err.contains("joint 1's frame"), "{preset}: {err}"),
        }
    }
}

/// A UR5e as UR's ROS description lays it out (REP-103 `base_link`, turned half a turn about z
/// into `base_link_inertia`, the factory kinematics as joint origins, then `flange` and `tool0`)
/// imports with base Rz(180°) and exports back to the factory calibration file: every joint's
/// origin within 1e-6 (metres, and rotation matrix entries; the file writes wrist_3's Rx(−π/2)
/// as rpy (π/2, π, π)), and the hash key is there. The model's FK in the description's frame is
/// the URDF's.
#[test]
fn ur5e_from_its_ros_urdf_exports_the_factory_calibration() {
    let factory = ur_yaml_joints(UR5E_CALIBRATION);
    // The URDF's links are named after the calibration file's joints.
    let names = gpu_amcs::import::ur::UR_JOINTS;
    let joints = [
        "shoulder_pan",
        "shoulder_lift",
        "elbow",
        "wrist_1",
        "wrist_2",
        "wrist_3",
    ];
    let mut u = String::from(
        "<robot name=\"ur5e\">\n  <link name=\"base_link\"/>\n  <link name=\"base_link_inertia\"/>\n  \
         <joint name=\"base_link-base_link_inertia\" type=\"fixed\"><parent link=\"base_link\"/>\
         <child link=\"base_link_inertia\"/><origin xyz=\"0 0 0\" rpy=\"0 0 3.141592653589793\"/></joint>\n",
    );
    let mut parent = "base_link_inertia".to_string();
    for j in 0..6 {
        let (xyz, rpy, _) = factory[j];
        let child = format!("{}_link", names[j]);
        u.push_str(&format!(
            "  <link name=\"{child}\"/>\n  <joint name=\"{}_joint\" type=\"revolute\"><parent link=\"{parent}\"/>\
             <child link=\"{child}\"/><origin xyz=\"{} {} {}\" rpy=\"{} {} {}\"/><axis xyz=\"0 0 1\"/>\
             <limit lower=\"-6.28\" upper=\"6.28\" effort=\"1\" velocity=\"1\"/></joint>\n",
            joints[j],
            xyz[0] / 1e3,
            xyz[1] / 1e3,
            xyz[2] / 1e3,
            rpy[0],
            rpy[1],
            rpy[2]
        ));
        parent = child;
    }
    u.push_str(
        "  <link name=\"flange\"/>\n  <joint name=\"wrist_3-flange\" type=\"fixed\"><parent link=\"wrist_3_link\"/>\
         <child link=\"flange\"/><origin xyz=\"0 0 0\" rpy=\"0 -1.5707963267948966 -1.5707963267948966\"/></joint>\n  \
         <link name=\"tool0\"/>\n  <joint name=\"flange-tool0\" type=\"fixed\"><parent link=\"flange\"/>\
         <child link=\"tool0\"/><origin xyz=\"0 0 0\" rpy=\"1.5707963267948966 0 1.5707963267948966\"/></joint>\n</robot>\n",
    );
    let dir = tmpdir("ur-ros");
    let imp = import(&write(&dir, "ur5e.urdf", &u)).unwrap();
    let b = imp
        .model
        .base
        .expect("base_link → base_link_inertia becomes the base");
    assert!(b.xyz.iter().all(|v| v.abs() < 1e-12), "{b:?}");
    assert!(
        (b.rpy[2].abs() - PI).abs() < 1e-12 && b.rpy[0].abs() < 1e-12,
        "{b:?}"
    );
    let yaml = export::to_ur_calibration(&imp.model).unwrap();
    let back = ur_yaml_joints(&yaml);
    let rot = |rpy: [f64; 3]| nalgebra::Rotation3::from_euler_angles(rpy[0], rpy[1], rpy[2]);
    for j in 0..6 {
        let (xa, ra, _) = factory[j];
        let (xb, rb, _) = back[j];
        for k in 0..3 {
            assert!(
                (xa[k] - xb[k]).abs() < 1e-3,
                "{}: xyz {xa:?} vs {xb:?}\n{yaml}",
                names[j]
            );
        }
        let d = (rot(ra).matrix() - rot(rb).matrix()).abs().max();
        assert!(d < 1e-6, "{}: rpy {ra:?} vs {rb:?}\n{yaml}", names[j]);
    }
    assert!(yaml.contains("  hash: calib_gpu_amcs_"), "{yaml}");
    // Fed back, the file is the model in UR's base frame: the same FK as the model without its
    // base turn.
    let again = import(&write(&dir, "back.yaml", &yaml)).unwrap().model;
    assert!(max_dev(&again, |q| position(&imp.model.params, &imp.model.tool, q)) < 1e-9);
    // A mount other than UR's own turn is not in the file, and the command says so.
    for (preset, noted) in [("kr6r700sixx", true), ("ur5e", false)] {
        let out = dir.join(format!("{preset}.yaml"));
        let o = run(&["export", "--preset", preset, "--ur-calibration", s(&out)]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert_eq!(
            stderr(&o).contains("base transform is not part"),
            noted,
            "{preset}"
        );
    }
}

/// The KUKA KR 210 L150 as ROS-Industrial describes it (kuka_experimental,
/// `kuka_kr210_support/urdf/kr210l150_macro.xacro`, prefix ""; joint origins in m, limits in
/// degrees): a CAD-derived chain whose A1 axis stands 2.796 mm off the description's origin and
/// whose consecutive axes are offset sideways by tens of millimetres. The import infers the base
/// (a translation to the A1 axis), equals the URDF's own forward kinematics (tool0 at
/// (0.0375, 0, −0.00023924) m on link 6) within 1e-9 mm, and round-trips through the export.
#[test]
fn kuka_kr210_l150_from_its_ros_industrial_description() {
    // (origin xyz in m, axis, limits in degrees) per joint.
    type Joint = ([f64; 3], [f64; 3], (f64, f64));
    let joints: [Joint; 6] = [
        (
            [-0.00262, 0.00097586, 0.33099],
            [0.0, 0.0, 1.0],
            (-185.0, 185.0),
        ),
        ([0.35277, -0.037476, 0.4192], [0.0, 1.0, 0.0], (-45.0, 85.0)),
        (
            [-9.8483e-05, -0.1475, 1.2499],
            [0.0, 1.0, 0.0],
            (-210.0, 65.0),
        ),
        (
            [0.95795, 0.184, -0.055059],
            [1.0, 0.0, 0.0],
            (-350.0, 350.0),
        ),
        ([0.542, 0.0, 0.0], [0.0, 1.0, 0.0], (-125.0, 125.0)),
        ([0.1925, 0.0, 0.0], [1.0, 0.0, 0.0], (-350.0, 350.0)),
    ];
    let tool0 = [0.0375, 0.0, -0.00023924];
    let mut s = String::from(
        "<?xml version=\"1.0\"?>\n<robot name=\"kuka_kr210l150\">\n  <link name=\"base_link\"/>\n",
    );
    for k in 1..=6 {
        s.push_str(&format!("  <link name=\"link_{k}\"/>\n"));
    }
    s.push_str("  <link name=\"tool0\"/>\n  <link name=\"Link1\"/>\n");
    for (k, (xyz, axis, (lo, hi))) in joints.iter().enumerate() {
        let parent = if k == 0 {
            "base_link".to_string()
        } else {
            format!("link_{k}")
        };
        s.push_str(&format!(
            "  <joint name=\"joint_{}\" type=\"revolute\">\n    <origin xyz=\"{} {} {}\" rpy=\"0 0 0\"/>\n    <parent link=\"{parent}\"/>\n    <child link=\"link_{}\"/>\n    <axis xyz=\"{} {} {}\"/>\n    <limit lower=\"{}\" upper=\"{}\" effort=\"0\" velocity=\"2\"/>\n  </joint>\n",
            k + 1,
            xyz[0],
            xyz[1],
            xyz[2],
            k + 1,
            axis[0],
            axis[1],
            axis[2],
            lo.to_radians(),
            hi.to_radians()
        ));
    }
    s.push_str(&format!(
        "  <joint name=\"link_6-tool0\" type=\"fixed\">\n    <parent link=\"link_6\"/>\n    <child link=\"tool0\"/>\n    <origin xyz=\"{} {} {}\" rpy=\"0 0 0\"/>\n  </joint>\n",
        tool0[0], tool0[1], tool0[2]
    ));
    // The description's compatibility link, a second leaf off link 1.
    s.push_str("  <joint name=\"Link1-link_1\" type=\"fixed\">\n    <parent link=\"link_1\"/>\n    <child link=\"Link1\"/>\n    <origin xyz=\"0 0 0\" rpy=\"0 0 0\"/>\n  </joint>\n</robot>\n");
    let dir = tmpdir("kr210");
    let imp = import(&write(&dir, "kr210l150.urdf", &s)).unwrap();
    assert!(imp.max_deviation_mm < 1e-9, "{}", imp.max_deviation_mm);
    // The base stands on the A1 axis: 2.796 mm from the origin, not turned.
    let b = imp.model.base.expect("a base transform");
    let off = (b.xyz[0].powi(2) + b.xyz[1].powi(2)).sqrt();
    assert!((off - 2.795_836_679_707_883).abs() < 1e-9, "{b:?}");
    let mm = |v: [f64; 3]| v.map(|x| 1000.0 * x);
    let chain: Vec<([f64; 3], [f64; 3], [f64; 3])> = joints
        .iter()
        .map(|(x, a, _)| (mm(*x), [0.0; 3], *a))
        .collect();
    let tip = {
        let t = mm(tool0);
        trans(t[0], t[1], t[2])
    };
    let dev = max_dev(&imp.model, |q| urdf_fk(&chain, &tip, q));
    assert!(dev < 1e-9, "{dev}");
    for (j, (_, _, (lo, hi))) in joints.iter().enumerate() {
        assert!(
            (imp.model.limits_deg[j].0 - lo).abs() < 1e-9
                && (imp.model.limits_deg[j].1 - hi).abs() < 1e-9
        );
    }
    let rt = urdf_round_trip(&dir, &imp.model);
    assert!(rt < 1e-9, "{rt}");
    eprintln!(
        "KR 210 L150: proof {:.3e} mm, vs URDF FK {dev:.3e} mm, round trip {rt:.3e} mm, base {:?}",
        imp.max_deviation_mm, b
    );
    let _ = std::fs::remove_dir_all(&dir);
}
