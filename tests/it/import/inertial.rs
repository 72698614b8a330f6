//! Link masses from a URDF's `<inertial>` data (issue 33): a UR5e-like description with rotated
//! joint frames, a flange fixed to the last link and a camera fixed beside the chain on the
//! forearm. The imported model's gravity torques (`kinematics::gravity::gravity_torques` with the
//! model's `links`, in its MDH frames) equal the torques computed here in the description's own
//! frames (hand-written forward kinematics, no crate code) at random configurations; the model
//! file keeps them; the simulator and the identification use them; bad data are refused naming
//! the link and line.

use super::{eye, mul, pos, rot, rpy, trans, write, M4};
use crate::common::{run_ok, tmpdir};
use gpu_amcs::import::{import_file, ImportOptions};
use gpu_amcs::kinematics::gravity::{gravity_torques, GRAVITY};
use gpu_amcs::kinematics::RobotModel;
use std::f64::consts::FRAC_PI_2;

/// Per revolute joint: origin xyz (m), rpy, child link mass (kg) and centre of mass (m, link
/// frame). Geometry of UR's UR5e description; masses UR's published figures for the UR5e
/// (3.761, 8.058, 2.846, 1.37, 1.3, 0.365 kg); the centres of mass are plausible, for the test.
/// Origin xyz (m), rpy, child link mass (kg), centre of mass (m).
type JointRow = ([f64; 3], [f64; 3], f64, [f64; 3]);
const JOINTS: [JointRow; 6] = [
    (
        [0.0, 0.0, 0.1625],
        [0.0, 0.0, 0.0],
        3.761,
        [0.0, -0.0256, 0.0019],
    ),
    (
        [0.0, 0.0, 0.0],
        [FRAC_PI_2, 0.0, 0.0],
        8.058,
        [-0.2125, 0.0, 0.1136],
    ),
    (
        [-0.425, 0.0, 0.0],
        [0.0, 0.0, 0.0],
        2.846,
        [-0.1566, 0.0, 0.0265],
    ),
    (
        [-0.3922, 0.0, 0.1333],
        [0.0, 0.0, 0.0],
        1.37,
        [0.0, -0.0018, 0.0163],
    ),
    (
        [0.0, -0.0997, 0.0],
        [FRAC_PI_2, 0.0, 0.0],
        1.3,
        [0.0, 0.0018, 0.0163],
    ),
    (
        [0.0, 0.0996, 0.0],
        [FRAC_PI_2, std::f64::consts::PI, std::f64::consts::PI],
        0.365,
        [0.0, 0.0, -0.0012],
    ),
];
/// The flange: fixed to wrist_3_link at this origin (m, rpy), 0.2 kg at (0, 0, 0.01) m.
const FLANGE: ([f64; 3], [f64; 3]) = ([0.0, 0.0, 0.02], [0.0, -FRAC_PI_2, -FRAC_PI_2]);
/// The camera: fixed to forearm_link at this origin, 0.5 kg at (0.01, 0.02, 0.03) m.
const CAMERA: ([f64; 3], [f64; 3]) = ([-0.2, 0.05, 0.08], [0.3, 0.0, 0.2]);
const LINKS: [&str; 6] = [
    "shoulder_link",
    "upper_arm_link",
    "forearm_link",
    "wrist_1_link",
    "wrist_2_link",
    "wrist_3_link",
];

fn v3(v: [f64; 3]) -> String {
    format!("{} {} {}", v[0], v[1], v[2])
}

fn inertial(mass: f64, com: [f64; 3]) -> String {
    format!(
        "<inertial><origin xyz=\"{}\" rpy=\"0.1 0.2 0.3\"/><mass value=\"{mass}\"/>\
         <inertia ixx=\"0.01\" ixy=\"0\" ixz=\"0\" iyy=\"0.01\" iyz=\"0\" izz=\"0.01\"/></inertial>",
        v3(com)
    )
}

/// The description's text; `mass_of_forearm` replaces the forearm's mass value.
fn urdf(mass_of_forearm: &str) -> String {
    let mut s = String::from("<?xml version=\"1.0\"?>\n<robot name=\"ur5e_masses\">\n");
    s += &format!(
        "<link name=\"base_link\">{}</link>\n",
        inertial(4.0, [0.0; 3])
    );
    for (k, (_, _, m, c)) in JOINTS.iter().enumerate() {
        let mut i = inertial(*m, *c);
        if k == 2 {
            i = i.replace(
                &format!("value=\"{m}\""),
                &format!("value=\"{mass_of_forearm}\""),
            );
        }
        s += &format!("<link name=\"{}\">\n  {i}\n</link>\n", LINKS[k]);
    }
    s += &format!(
        "<link name=\"flange\">{}</link>\n",
        inertial(0.2, [0.0, 0.0, 0.01])
    );
    s += "<link name=\"tool0\"/>\n";
    s += &format!(
        "<link name=\"camera\">{}</link>\n",
        inertial(0.5, [0.01, 0.02, 0.03])
    );
    let mut parent = "base_link";
    for (k, (xyz, r, _, _)) in JOINTS.iter().enumerate() {
        s += &format!(
            "<joint name=\"j{}\" type=\"revolute\"><origin xyz=\"{}\" rpy=\"{}\"/>\
             <parent link=\"{parent}\"/><child link=\"{}\"/><axis xyz=\"0 0 1\"/>\
             <limit lower=\"-6.28\" upper=\"6.28\" effort=\"1\" velocity=\"1\"/></joint>\n",
            k + 1,
            v3(*xyz),
            v3(*r),
            LINKS[k]
        );
        parent = LINKS[k];
    }
    s += &format!(
        "<joint name=\"flange_fix\" type=\"fixed\"><origin xyz=\"{}\" rpy=\"{}\"/>\
         <parent link=\"wrist_3_link\"/><child link=\"flange\"/></joint>\n",
        v3(FLANGE.0),
        v3(FLANGE.1)
    );
    s += "<joint name=\"tool_fix\" type=\"fixed\"><origin xyz=\"0 0 0.05\"/>\
          <parent link=\"flange\"/><child link=\"tool0\"/></joint>\n";
    s += &format!(
        "<joint name=\"camera_fix\" type=\"fixed\"><origin xyz=\"{}\" rpy=\"{}\"/>\
         <parent link=\"forearm_link\"/><child link=\"camera\"/></joint>\n</robot>\n",
        v3(CAMERA.0),
        v3(CAMERA.1)
    );
    s
}

fn origin(xyz: [f64; 3], r: [f64; 3]) -> M4 {
    mul(
        &trans(xyz[0] * 1e3, xyz[1] * 1e3, xyz[2] * 1e3),
        &rpy(r[0], r[1], r[2]),
    )
}

fn apply(m: &M4, p: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|i| (0..3).map(|k| m[i][k] * p[k] * 1e3).sum::<f64>() + m[i][3])
}

/// The gravity torques (N·m) about the joints at `q` (rad), in the description's frames:
/// every mass as a point at its centre, the payload `payload_kg` at tool0.
fn torques_here(q: &[f64], payload_kg: f64) -> Vec<f64> {
    let mut t = eye();
    let mut frames = Vec::new();
    // (point mm, mass kg) and the first joint that carries it (0-based)
    let mut masses: Vec<([f64; 3], f64, usize)> = Vec::new();
    for (k, (xyz, r, m, c)) in JOINTS.iter().enumerate() {
        t = mul(&mul(&t, &origin(*xyz, *r)), &rot([0.0, 0.0, 1.0], q[k]));
        frames.push(t);
        masses.push((apply(&t, *c), *m, k));
        if k == 2 {
            let cam = mul(&t, &origin(CAMERA.0, CAMERA.1));
            masses.push((apply(&cam, [0.01, 0.02, 0.03]), 0.5, k));
        }
    }
    let flange = mul(&t, &origin(FLANGE.0, FLANGE.1));
    masses.push((apply(&flange, [0.0, 0.0, 0.01]), 0.2, 5));
    let tool0 = mul(&flange, &trans(0.0, 0.0, 50.0));
    masses.push((pos(&tool0), payload_kg, 5));
    (0..6)
        .map(|i| {
            let f = &frames[i];
            let (o, z) = (pos(f), [f[0][2], f[1][2], f[2][2]]);
            masses
                .iter()
                .filter(|(_, _, from)| *from >= i)
                .map(|(c, m, _)| {
                    // (r × F)·z with F = (0, 0, −m g), r in m
                    let (rx, ry) = ((c[0] - o[0]) * 1e-3, (c[1] - o[1]) * 1e-3);
                    let w = m * GRAVITY;
                    -ry * w * z[0] + rx * w * z[1]
                })
                .sum()
        })
        .collect()
}

fn imported(dir: &std::path::Path, text: &str) -> Result<RobotModel, String> {
    let p = write(dir, "ur5e_masses.urdf", text);
    let opts = ImportOptions {
        tip: Some("tool0".into()),
        ..ImportOptions::default()
    };
    import_file(&p, &opts)
        .map(|i| i.model)
        .map_err(|e| e.to_string())
}

/// The imported links give the description's gravity torques at random configurations, with
/// and without a payload (agreement to 1e-9 N·m on torques of tens of N·m).
#[test]
fn imported_masses_give_the_descriptions_gravity_torques() {
    let dir = tmpdir("inertial-torques");
    let m = imported(&dir, &urdf("2.846")).unwrap();
    let links = m.links.expect("the description has <inertial> data");
    let masses: Vec<f64> = links.mass_kg.to_vec();
    let want = [3.761, 8.058, 2.846 + 0.5, 1.37, 1.3, 0.365 + 0.2];
    for (a, b) in masses.iter().zip(want) {
        assert!((a - b).abs() < 1e-12, "{masses:?}");
    }
    let mut s = 12345u64;
    let mut next = || {
        s = s.wrapping_mul(6364136223846793005).wrapping_add(1);
        ((s >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 6.0
    };
    let (mut worst, mut largest): (f64, f64) = (0.0, 0.0);
    for _ in 0..50 {
        let q: Vec<f64> = (0..6).map(|_| next()).collect();
        for payload in [0.0, 3.0] {
            let here = torques_here(&q, payload);
            let model = gravity_torques(&m.params, &m.tool, &links, payload, &q);
            for i in 0..6 {
                worst = worst.max((here[i] - model[i]).abs());
            }
            largest = largest.max(here[1].abs());
        }
    }
    assert!(largest > 20.0, "the arm loads J2: {largest} N·m");
    assert!(worst < 1e-9, "largest torque difference {worst} N·m");
}

/// The model file keeps the links to the bit; `simulate` bends the robot with them and
/// `identify --beyond-geometry=keep` carries them into the joint errors; a bad mass in the
/// description or the file is refused naming where.
#[test]
fn the_links_travel_through_the_model_file_simulate_and_identify() {
    let dir = tmpdir("inertial-cli");
    let p = |f: &str| dir.join(f).display().to_string();
    write(&dir, "arm.urdf", &urdf("2.846"));
    run_ok(&[
        "import",
        &p("arm.urdf"),
        "--tip",
        "tool0",
        "-o",
        &p("arm.toml"),
    ]);
    let text = std::fs::read_to_string(p("arm.toml")).unwrap();
    assert!(text.contains("[links]"), "{text}");
    let back = RobotModel::from_file(std::path::Path::new(&p("arm.toml"))).unwrap();
    let direct = imported(&dir, &urdf("2.846")).unwrap();
    assert_eq!(back.links, direct.links);
    run_ok(&[
        "simulate",
        "--model",
        &p("arm.toml"),
        "--poses",
        "120",
        "--tracker-sigma",
        "0.01",
        "--compliance",
        "1",
        "-o",
        &p("cal.csv"),
    ]);
    run_ok(&[
        "identify",
        &p("cal.csv"),
        "--nominal",
        &p("arm.toml"),
        "--tracker-sigma",
        "0.01",
        "--beyond-geometry=keep",
        "-o",
        &p("id.toml"),
    ]);
    let id = RobotModel::from_file(std::path::Path::new(&p("id.toml"))).unwrap();
    assert_eq!(
        id.links, direct.links,
        "the identified model keeps the nominal's links"
    );
    let e = id.joint_errors.expect("kept");
    assert_eq!(
        Some(e.links),
        direct.links,
        "the compliance's torques use them"
    );
    // Refusals: a negative mass in the description names the link and its line; a file whose
    // [links] has the wrong count names the field.
    let err = imported(&dir, &urdf("-1")).unwrap_err();
    assert!(
        err.contains("forearm_link") && err.contains("ur5e_masses.urdf:11:"),
        "{err}"
    );
    let bad = text.replace(
        &text[text.find("mass_kg = [").unwrap()..]
            .lines()
            .next()
            .unwrap()
            .to_string(),
        "mass_kg = [1.0, 2.0]",
    );
    std::fs::write(p("bad.toml"), bad).unwrap();
    let err = RobotModel::from_file(std::path::Path::new(&p("bad.toml")))
        .unwrap_err()
        .to_string();
    assert!(err.contains("links.mass_kg"), "{err}");
}

/// Largest gravity-torque difference (N·m) between two models' links over 50 random
/// configurations, with a 2 kg payload.
fn torque_gap(a: &RobotModel, b: &RobotModel) -> f64 {
    let (la, lb) = (a.links.unwrap(), b.links.unwrap());
    let mut s = 99u64;
    let mut worst: f64 = 0.0;
    for _ in 0..50 {
        let q: Vec<f64> = (0..a.joints())
            .map(|_| {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1);
                ((s >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 6.0
            })
            .collect();
        let ta = gravity_torques(&a.params, &a.tool, &la, 2.0, &q);
        let tb = gravity_torques(&b.params, &b.tool, &lb, 2.0, &q);
        for i in 0..q.len() {
            worst = worst.max((ta[i] - tb[i]).abs());
        }
    }
    worst
}

/// The URDF export writes each link's mass at its centre of mass, so importing the export gives
/// the same torques: for the UR5e-like import (centres given) and for the TX60 with the default
/// masses at the midpoints of its frame origins.
#[test]
fn the_urdf_export_keeps_the_links() {
    let dir = tmpdir("inertial-export");
    let ur = imported(&dir, &urdf("2.846")).unwrap();
    let mut tx = gpu_amcs::kinematics::tx60();
    tx.links = Some(gpu_amcs::kinematics::gravity::LinkMasses::of(&tx));
    for m in [ur, tx] {
        let text = gpu_amcs::import::export::to_urdf(&m, None);
        assert!(text.contains("<inertial>"), "{text}");
        let back = import_file(&write(&dir, "back.urdf", &text), &ImportOptions::default())
            .unwrap()
            .model;
        let gap = torque_gap(&m, &back);
        assert!(gap < 1e-9, "{}: {gap} N·m", m.name);
        let (a, b) = (m.links.unwrap(), back.links.unwrap());
        assert!(a
            .mass_kg
            .iter()
            .zip(b.mass_kg.iter())
            .all(|(x, y)| (x - y).abs() < 1e-12));
    }
}

/// The UR5e preset carries UR's published link masses and centres of mass (given in UR's
/// standard DH frames): its gravity torques equal the ones composed here from UR's DH table
/// directly (d, a, α in m and rad; masses kg; centres m, frame i).
#[test]
fn the_ur5e_preset_has_urs_published_masses() {
    let d = [0.1625, 0.0, 0.0, 0.1333, 0.0997, 0.0996];
    let a = [0.0, -0.425, -0.3922, 0.0, 0.0, 0.0];
    let alpha = [FRAC_PI_2, 0.0, 0.0, FRAC_PI_2, -FRAC_PI_2, 0.0];
    let mass = [3.761, 8.058, 2.846, 1.37, 1.3, 0.365];
    let com = [
        [0.0, -0.02561, 0.00193],
        [0.2125, 0.0, 0.11336],
        [0.15, 0.0, 0.0265],
        [0.0, -0.0018, 0.01634],
        [0.0, 0.0018, 0.01634],
        [0.0, 0.0, -0.001159],
    ];
    let m = gpu_amcs::presets::ur5e();
    let links = m.links.expect("the preset has UR's masses");
    let mut s = 7u64;
    let mut worst: f64 = 0.0;
    for _ in 0..50 {
        let q: Vec<f64> = (0..6)
            .map(|_| {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1);
                ((s >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 6.0
            })
            .collect();
        // Joint i turns about frame i − 1's z; link i's centre is in frame i.
        let mut t = eye();
        let mut axes = Vec::new();
        let mut centres = Vec::new();
        for j in 0..6 {
            axes.push(t);
            t = mul(&t, &rot([0.0, 0.0, 1.0], q[j]));
            t = mul(&t, &trans(0.0, 0.0, d[j] * 1e3));
            t = mul(&t, &trans(a[j] * 1e3, 0.0, 0.0));
            t = mul(&t, &rot([1.0, 0.0, 0.0], alpha[j]));
            centres.push((apply(&t, com[j]), mass[j]));
        }
        let here: Vec<f64> = (0..6)
            .map(|i| {
                let f = &axes[i];
                let (o, z) = (pos(f), [f[0][2], f[1][2], f[2][2]]);
                centres[i..]
                    .iter()
                    .map(|(c, m)| {
                        let (rx, ry) = ((c[0] - o[0]) * 1e-3, (c[1] - o[1]) * 1e-3);
                        let w = m * GRAVITY;
                        -ry * w * z[0] + rx * w * z[1]
                    })
                    .sum()
            })
            .collect();
        let model = gravity_torques(&m.params, &m.tool, &links, 0.0, &q);
        for i in 0..6 {
            worst = worst.max((here[i] - model[i]).abs());
        }
    }
    assert!(worst < 1e-9, "largest torque difference {worst} N·m");
}

/// Edges: holding a joint drops the masses with a note (its body would join the one before);
/// a description whose links have no mass gives no `[links]`; NaN and out-of-range values in the
/// file's `[links]` and in a pose file's `payload_kg` are refused naming the field or column.
#[test]
fn masses_edges_are_refused_or_said() {
    let dir = tmpdir("inertial-edges");
    let p = write(&dir, "arm.urdf", &urdf("2.846"));
    let held = import_file(
        &p,
        &ImportOptions {
            tip: Some("tool0".into()),
            held: vec![gpu_amcs::import::JointHold {
                joint: "j4".into(),
                angle_deg: 0.0,
            }],
            ..ImportOptions::default()
        },
    )
    .unwrap();
    assert!(held.model.links.is_none());
    assert!(
        held.held.iter().any(|n| n.contains("link masses")),
        "{:?}",
        held.held
    );
    let massless = urdf("0")
        .replace("value=\"3.761\"", "value=\"0\"")
        .replace("value=\"8.058\"", "value=\"0\"")
        .replace("value=\"1.37\"", "value=\"0\"")
        .replace("value=\"1.3\"", "value=\"0\"")
        .replace("value=\"0.365\"", "value=\"0\"")
        .replace("value=\"0.2\"", "value=\"0\"")
        .replace("value=\"0.5\"", "value=\"0\"");
    assert!(imported(&dir, &massless).unwrap().links.is_none());
    let good = imported(&dir, &urdf("2.846")).unwrap().to_toml();
    for (bad, field) in [
        ("com_mm = [[1.0, 2.0, 3.0]]", "links.com_mm"),
        ("com_mm = [[nan, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]", "links.com_mm"),
    ] {
        let start = good.find("com_mm = [").unwrap();
        let end = start + good[start..].find('\n').unwrap();
        let text = format!("{}{bad}{}", &good[..start], &good[end..]);
        let f = write(&dir, "bad.toml", &text);
        let err = RobotModel::from_file(&f).unwrap_err().to_string();
        assert!(err.contains(field), "{bad}: {err}");
    }
    let mass = good.find("mass_kg = [").unwrap();
    let end = mass + good[mass..].find('\n').unwrap();
    let text = format!(
        "{}mass_kg = [1.0, -2.0, 1.0, 1.0, 1.0, 1.0]{}",
        &good[..mass],
        &good[end..]
    );
    let err = RobotModel::from_file(&write(&dir, "bad.toml", &text))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("links.mass_kg") && err.contains("link 2"),
        "{err}"
    );
    for value in ["nan", "inf", "", "1001"] {
        let csv = format!("q1,q2,q3,q4,q5,q6,x,y,z,payload_kg\n0,0,90,0,0,0,500,0,800,{value}\n");
        let err = gpu_amcs::identify::parse_poses(csv.as_bytes(), "p.csv")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("payload_kg") && err.contains("line 2"),
            "{value:?}: {err}"
        );
    }
}
