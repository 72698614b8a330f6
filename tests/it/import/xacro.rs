//! xacro files expanded by the importer: two fake ROS-Industrial packages (a shared resources
//! package and a support package with a macro file and a top file), compared with the same
//! robot written out by hand as URDF; block parameters, if/unless, args, package look-up, and the
//! refusals (one line naming the file and the line, exit 2, nothing written).
//!
//! Over 600 lines: the fake packages and their hand-expanded URDF are the fixtures every test
//! here shares.

use super::{import, write};
use crate::common::{arg, fails_leaving_nothing, run, stderr, tmpdir};
use gpu_amcs::import::{self as imp, ImportOptions};
use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

const NS: &str = "xmlns:xacro=\"http://www.ros.org/wiki/xacro\"";

/// The FANUC M-10iA as its support package lays it out (lengths in m, limits in degrees through
/// `radians()`), one joint origin turned by `${radians(90)}` and the tool flange by `${pi/2}`.
const M10IA_MACRO: &str = r#"<?xml version="1.0"?>
<robot xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:include filename="$(find fanuc_resources)/urdf/common_materials.xacro"/>
  <xacro:macro name="fanuc_m10ia" params="prefix">
    <xacro:property name="d1" value="0.450"/>
    <xacro:property name="a1" value="0.150"/>
    <xacro:property name="a2" value="0.600"/>
    <xacro:property name="a3" value="0.200"/>
    <xacro:property name="d4" value="${a2 + 0.04}"/>
    <xacro:property name="d6" value="0.100"/>
    <link name="${prefix}base_link">
      <visual><geometry><box size="0.1 0.1 0.1"/></geometry><xacro:material_fanuc_gray28/></visual>
    </link>
    <link name="${prefix}link_1"/>
    <link name="${prefix}link_2"/>
    <link name="${prefix}link_3"/>
    <link name="${prefix}link_4"/>
    <link name="${prefix}link_5"/>
    <link name="${prefix}link_6"/>
    <link name="${prefix}tool0"/>
    <joint name="${prefix}joint_1" type="revolute">
      <origin xyz="0 0 ${d1}" rpy="0 0 0"/>
      <parent link="${prefix}base_link"/>
      <child link="${prefix}link_1"/>
      <axis xyz="0 0 1"/>
      <limit lower="${radians(-170)}" upper="${radians(170)}" effort="0" velocity="${radians(210)}"/>
    </joint>
    <joint name="${prefix}joint_2" type="revolute">
      <origin xyz="${a1} 0 0" rpy="0 0 0"/>
      <parent link="${prefix}link_1"/>
      <child link="${prefix}link_2"/>
      <axis xyz="0 1 0"/>
      <limit lower="${radians(-90)}" upper="${radians(160)}" effort="0" velocity="${radians(190)}"/>
    </joint>
    <joint name="${prefix}joint_3" type="revolute">
      <origin xyz="0 0 ${a2}" rpy="0 0 0"/>
      <parent link="${prefix}link_2"/>
      <child link="${prefix}link_3"/>
      <axis xyz="0 -1 0"/>
      <limit lower="${radians(-180)}" upper="${radians(265)}" effort="0" velocity="${radians(210)}"/>
    </joint>
    <joint name="${prefix}joint_4" type="revolute">
      <origin xyz="0 0 ${a3}" rpy="${radians(90)} 0 0"/>
      <parent link="${prefix}link_3"/>
      <child link="${prefix}link_4"/>
      <axis xyz="-1 0 0"/>
      <limit lower="${radians(-190)}" upper="${radians(190)}" effort="0" velocity="${radians(400)}"/>
    </joint>
    <joint name="${prefix}joint_5" type="revolute">
      <origin xyz="${d4} 0 0" rpy="0 0 0"/>
      <parent link="${prefix}link_4"/>
      <child link="${prefix}link_5"/>
      <axis xyz="0 -1 0"/>
      <limit lower="${-2 * pi / 3}" upper="${2*pi/3}" effort="0" velocity="${radians(400)}"/>
    </joint>
    <joint name="${prefix}joint_6" type="revolute">
      <origin xyz="${d6} 0 0" rpy="0 0 0"/>
      <parent link="${prefix}link_5"/>
      <child link="${prefix}link_6"/>
      <axis xyz="-1 0 0"/>
      <limit lower="${radians(-360)}" upper="${radians(360)}" effort="0" velocity="${radians(600)}"/>
    </joint>
    <joint name="${prefix}joint_6-tool0" type="fixed">
      <origin xyz="0 0 0" rpy="${pi} ${-pi/2} 0"/>
      <parent link="${prefix}link_6"/>
      <child link="${prefix}tool0"/>
    </joint>
  </xacro:macro>
</robot>
"#;

const MATERIALS: &str = r#"<?xml version="1.0"?>
<robot xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:property name="gray" value="0.28"/>
  <xacro:macro name="material_fanuc_gray28">
    <material name="gray28"><color rgba="${gray} ${gray} ${gray} 1.0"/></material>
  </xacro:macro>
</robot>
"#;

const M10IA_TOP: &str = r#"<?xml version="1.0"?>
<robot name="fanuc_m10ia" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:include filename="$(find fanuc_m10ia_support)/urdf/m10ia_macro.xacro"/>
  <xacro:fanuc_m10ia prefix=""/>
</robot>
"#;

/// The same robot expanded by hand (the numbers as f64 prints them).
fn m10ia_urdf() -> String {
    let r = |d: f64| format!("{}", d.to_radians());
    let joint = |k: usize, xyz: &str, rpy: &str, axis: &str, lo: String, hi: String| {
        format!(
            "  <joint name=\"joint_{k}\" type=\"revolute\">\n    <origin xyz=\"{xyz}\" rpy=\"{rpy}\"/>\n    <parent link=\"{}\"/>\n    <child link=\"link_{k}\"/>\n    <axis xyz=\"{axis}\"/>\n    <limit lower=\"{lo}\" upper=\"{hi}\" effort=\"0\" velocity=\"1\"/>\n  </joint>\n",
            if k == 1 { "base_link".to_string() } else { format!("link_{}", k - 1) }
        )
    };
    let mut s = String::from(
        "<?xml version=\"1.0\"?>\n<robot name=\"fanuc_m10ia\">\n  <link name=\"base_link\"/>\n",
    );
    for k in 1..=6 {
        s += &format!("  <link name=\"link_{k}\"/>\n");
    }
    s += "  <link name=\"tool0\"/>\n";
    s += &joint(1, "0 0 0.45", "0 0 0", "0 0 1", r(-170.0), r(170.0));
    s += &joint(2, "0.15 0 0", "0 0 0", "0 1 0", r(-90.0), r(160.0));
    s += &joint(3, "0 0 0.6", "0 0 0", "0 -1 0", r(-180.0), r(265.0));
    s += &joint(
        4,
        "0 0 0.2",
        &format!("{} 0 0", r(90.0)),
        "-1 0 0",
        r(-190.0),
        r(190.0),
    );
    s += &joint(
        5,
        &format!("{} 0 0", 0.6f64 + 0.04),
        "0 0 0",
        "0 -1 0",
        format!("{}", -2.0 * PI / 3.0),
        format!("{}", 2.0 * PI / 3.0),
    );
    s += &joint(6, "0.1 0 0", "0 0 0", "-1 0 0", r(-360.0), r(360.0));
    s += &format!(
        "  <joint name=\"joint_6-tool0\" type=\"fixed\">\n    <origin xyz=\"0 0 0\" rpy=\"{} {} 0\"/>\n    <parent link=\"link_6\"/>\n    <child link=\"tool0\"/>\n  </joint>\n</robot>\n",
        PI,
        -PI / 2.0
    );
    s
}

/// `root/fanuc_resources` and `root/fanuc_m10ia_support`, each with its package.xml; returns the
/// top xacro file.
fn fanuc_packages(root: &Path) -> PathBuf {
    for (pkg, files) in [
        (
            "fanuc_resources",
            vec![("urdf/common_materials.xacro", MATERIALS)],
        ),
        (
            "fanuc_m10ia_support",
            vec![
                ("urdf/m10ia_macro.xacro", M10IA_MACRO),
                ("urdf/m10ia.xacro", M10IA_TOP),
            ],
        ),
    ] {
        let d = root.join(pkg);
        std::fs::create_dir_all(d.join("urdf")).unwrap();
        std::fs::write(
            d.join("package.xml"),
            format!("<?xml version=\"1.0\"?>\n<package format=\"2\">\n  <name>{pkg}</name>\n</package>\n"),
        )
        .unwrap();
        for (f, text) in files {
            std::fs::write(d.join(f), text).unwrap();
        }
    }
    root.join("fanuc_m10ia_support/urdf/m10ia.xacro")
}

#[test]
fn fanuc_support_package_imports_as_its_hand_expanded_urdf() {
    let dir = tmpdir("xacro-fanuc");
    let top = fanuc_packages(&dir.join("ws/src"));
    let x = import(&top).unwrap();
    let u = import(&write(&dir, "m10ia.urdf", &m10ia_urdf())).unwrap();
    assert_eq!(x.model, u.model);
    assert_eq!(x.model.name, "fanuc_m10ia");
    assert_eq!(x.max_deviation_mm, u.max_deviation_mm);
    assert!(x.max_deviation_mm < imp::PROOF_TOLERANCE_MM);
    // The command line: exit 0, the model written, and the same model as the URDF's.
    let out = dir.join("m10ia.toml");
    let o = run(&[
        "import",
        top.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&out).unwrap();
    let body = |t: &str| {
        t.lines()
            .filter(|l| !l.starts_with('#'))
            .collect::<Vec<_>>()
            .join("\n")
    };
    assert_eq!(body(&text), body(&u.to_toml()));
}

/// A six-joint arm built by a macro with a block parameter (`*origin`), a `**blocks` parameter,
/// a default, an outer-scope default (`^|`) and if/unless around an optional tool link.
const BLOCKS: &str = r#"<?xml version="1.0"?>
<robot name="blocky" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:property name="name" value="blocky"/>
  <xacro:property name="with_tool" value="true"/>
  <xacro:property name="axis" value="0 1 0"/>
  <xacro:macro name="rev" params="k parent *origin axis:=^|'0 0 1' lim:=2 **extra">
    <link name="l${k}"/>
    <joint name="j${k}" type="revolute">
      <xacro:insert_block name="origin"/>
      <parent link="${parent}"/>
      <child link="l${k}"/>
      <axis xyz="${axis}"/>
      <limit lower="${-lim}" upper="${lim}"/>
      <xacro:insert_block name="extra"/>
    </joint>
  </xacro:macro>
  <link name="l0"/>
  <xacro:rev k="1" parent="l0" axis="0 0 1"><origin xyz="0 0 0.3"/><x><dynamics damping="0"/></x></xacro:rev>
  <xacro:rev k="2" parent="l1"><origin xyz="0 0.1 0"/><x/></xacro:rev>
  <xacro:rev k="3" parent="l2" lim="${2}"><origin xyz="0.4 0 0"/><x/></xacro:rev>
  <xacro:rev k="4" parent="l3" axis="0 0 1"><origin xyz="0.05 0 ${0.7/2}"/><x/></xacro:rev>
  <xacro:rev k="5" parent="l4"><origin xyz="0 0 0"/><x/></xacro:rev>
  <xacro:rev k="6" parent="l5" axis="0 0 1"><origin xyz="0 0 0.08"/><x/></xacro:rev>
  <xacro:if value="${with_tool and 1 + 1 == 2}">
    <link name="tool"/>
    <joint name="jt" type="fixed"><origin xyz="0 0 0.1"/><parent link="l6"/><child link="tool"/></joint>
  </xacro:if>
  <xacro:unless value="${with_tool}">
    <link name="wrong"/>
    <joint name="jw" type="fixed"><origin xyz="1 0 0"/><parent link="l6"/><child link="wrong"/></joint>
  </xacro:unless>
  <xacro:if value="0"><link name="never"/></xacro:if>
</robot>
"#;

#[test]
fn block_parameters_defaults_and_if_unless_expand() {
    let dir = tmpdir("xacro-blocks");
    let x = import(&write(&dir, "b.xacro", BLOCKS)).unwrap();
    // The same arm by hand (the simple test arm plus a tool 0.1 m up).
    let tool = "  <link name=\"tool\"/>\n  <joint name=\"jt\" type=\"fixed\"><origin xyz=\"0 0 0.1\"/><parent link=\"l6\"/><child link=\"tool\"/></joint>\n";
    let u = import(&write(&dir, "b.urdf", &super::simple_urdf(tool))).unwrap();
    let mut want = u.model.clone();
    want.name = "blocky".into();
    assert_eq!(x.model, want);
    // The tool point is the tool link (if), not the unless branch's link 1 m off.
    let opts = ImportOptions {
        tip: Some("l6".into()),
        ..Default::default()
    };
    let mut bare = imp::import_file(&dir.join("b.urdf"), &opts).unwrap().model;
    bare.name = "blocky".into();
    assert_ne!(x.model, bare);
}

const ARGS: &str = r#"<?xml version="1.0"?>
<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:arg name="upper" default="0.4"/>
  <xacro:arg name="tool_z" default="0.08"/>
  <xacro:property name="up" value="$(arg upper)"/>
  <link name="l0"/><link name="l1"/><link name="l2"/><link name="l3"/><link name="l4"/><link name="l5"/><link name="l6"/>
  <joint name="j1" type="revolute"><origin xyz="0 0 0.3"/><parent link="l0"/><child link="l1"/><axis xyz="0 0 1"/><limit lower="-2" upper="2"/></joint>
  <joint name="j2" type="revolute"><origin xyz="0 0.1 0"/><parent link="l1"/><child link="l2"/><axis xyz="0 1 0"/><limit lower="-2" upper="2"/></joint>
  <joint name="j3" type="revolute"><origin xyz="${up * 1} 0 0"/><parent link="l2"/><child link="l3"/><axis xyz="0 1 0"/><limit lower="-2" upper="2"/></joint>
  <joint name="j4" type="revolute"><origin xyz="0.05 0 0.35"/><parent link="l3"/><child link="l4"/><axis xyz="0 0 1"/><limit lower="-2" upper="2"/></joint>
  <joint name="j5" type="revolute"><origin xyz="0 0 0"/><parent link="l4"/><child link="l5"/><axis xyz="0 1 0"/><limit lower="-2" upper="2"/></joint>
  <joint name="j6" type="revolute"><origin xyz="0 0 $(arg tool_z)"/><parent link="l5"/><child link="l6"/><axis xyz="0 0 1"/><limit lower="-2" upper="2"/></joint>
</robot>
"#;

#[test]
fn xacro_args_take_their_defaults_or_the_callers_values() {
    let dir = tmpdir("xacro-args");
    let p = write(&dir, "a.xacro", ARGS);
    let d = import(&p).unwrap();
    let u = import(&write(&dir, "a.urdf", &super::simple_urdf(""))).unwrap();
    assert_eq!(d.model, u.model);
    let opts = ImportOptions {
        xacro_args: BTreeMap::from([("upper".to_string(), "0.5".to_string())]),
        ..Default::default()
    };
    let o = imp::import_file(&p, &opts).unwrap();
    let u5 = import(&write(
        &dir,
        "a5.urdf",
        &super::simple_urdf("").replace("\"0.4 0 0\"", "\"0.5 0 0\""),
    ))
    .unwrap();
    assert_eq!(o.model, u5.model);
    assert_ne!(o.model, d.model);
    // The command line's --xacro-arg.
    let out = dir.join("a5.toml");
    let r = run(&[
        "import",
        &arg(&dir, "a.xacro"),
        "--xacro-arg",
        "upper:=0.5",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(r.status.success(), "{}", stderr(&r));
    let m = gpu_amcs::kinematics::RobotModel::from_file(&out).unwrap();
    assert_eq!(m.params, u5.model.params);
}

#[test]
fn packages_are_found_by_map_and_by_package_xml_name() {
    let dir = tmpdir("xacro-pkgs");
    let top = fanuc_packages(&dir.join("ws"));
    // Move the resources package out of reach: not found walking up, found through the map.
    let away = dir.join("elsewhere/res");
    std::fs::create_dir_all(dir.join("elsewhere")).unwrap();
    std::fs::rename(dir.join("ws/fanuc_resources"), &away).unwrap();
    let e = import(&top).unwrap_err().to_string();
    assert!(
        e.contains("package 'fanuc_resources' not found") && e.contains("m10ia_macro.xacro:3:"),
        "{e}"
    );
    let opts = ImportOptions {
        packages: BTreeMap::from([("fanuc_resources".to_string(), away.clone())]),
        ..Default::default()
    };
    assert!(imp::import_file(&top, &opts).is_ok());
    // A folder whose package.xml names it (the folder name differs) is found by that name.
    std::fs::rename(&away, dir.join("ws/resources-checkout")).unwrap();
    assert!(import(&top).is_ok());
    // The command line's --package.
    std::fs::rename(dir.join("ws/resources-checkout"), &away).unwrap();
    let out = dir.join("m.toml");
    let o = run(&[
        "import",
        top.to_str().unwrap(),
        "--package",
        &format!("fanuc_resources={}", away.display()),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn a_plain_urdf_named_xacro_imports_as_the_urdf() {
    let dir = tmpdir("xacro-plain");
    let x = import(&write(&dir, "p.xacro", &super::simple_urdf(""))).unwrap();
    let u = import(&write(&dir, "p.urdf", &super::simple_urdf(""))).unwrap();
    assert_eq!(x.model, u.model);
}

/// 1-based line of the first line of `text` containing `marker`.
fn line_of(text: &str, marker: &str) -> usize {
    1 + text.lines().position(|l| l.contains(marker)).unwrap()
}

fn arm_with(extra: &str) -> String {
    let s = super::simple_urdf("");
    s.replace(
        "<robot name=\"r\">",
        &format!("<robot name=\"r\" {NS}>\n{extra}"),
    )
}

#[test]
fn refusals_name_the_file_and_line_and_write_nothing() {
    let dir = tmpdir("xacro-refuse");
    // Files that include each other.
    write(
        &dir,
        "cycle_a.xacro",
        &format!("<robot {NS}>\n  <xacro:include filename=\"cycle_b.xacro\"/>\n</robot>\n"),
    );
    write(
        &dir,
        "cycle_b.xacro",
        &format!("<robot {NS}>\n\n  <xacro:include filename=\"cycle_a.xacro\"/>\n</robot>\n"),
    );
    let macro_file = format!(
        "<robot {NS}>\n  <xacro:macro name=\"nolimit\">\n    <joint name=\"j9\" type=\"revolute\"><parent link=\"l6\"/><child link=\"l9\"/><axis xyz=\"0 0 x\"/><limit lower=\"-1\" upper=\"1\"/></joint>\n  </xacro:macro>\n</robot>\n"
    );
    write(&dir, "inc.xacro", &macro_file);
    let cases: Vec<(&str, String, &str, Vec<String>)> = vec![
        (
            "element.xacro",
            arm_with("  <xacro:element xacro:name=\"link\"/>\n"),
            "<xacro:element",
            vec!["<xacro:element> is not supported".into()],
        ),
        (
            "call.xacro",
            arm_with("  <xacro:call macro=\"m\"/>\n"),
            "<xacro:call",
            vec!["<xacro:call> is not supported".into()],
        ),
        (
            "undefined.xacro",
            arm_with("  <link name=\"${missing}_x\"/>\n"),
            "missing",
            vec!["undefined property 'missing'".into()],
        ),
        (
            "divzero.xacro",
            arm_with("  <xacro:property name=\"z\" value=\"0\"/>\n  <link name=\"x\"><origin xyz=\"${1/z} 0 0\"/></link>\n"),
            "1/z",
            vec!["division by zero".into()],
        ),
        (
            "nopkg.xacro",
            arm_with("  <xacro:include filename=\"$(find no_such_pkg)/urdf/x.xacro\"/>\n"),
            "no_such_pkg",
            vec!["package 'no_such_pkg' not found".into()],
        ),
        (
            "recursion.xacro",
            arm_with("  <xacro:macro name=\"loop\" params=\"n\"><xacro:loop n=\"${n+1}\"/></xacro:macro>\n  <xacro:loop n=\"0\"/>\n"),
            "<xacro:loop n=\"${n+1}\"",
            vec!["nest deeper than 64".into(), "'loop'".into()],
        ),
        (
            "args.xacro",
            arm_with("  <link name=\"$(arg nope)\"/>\n"),
            "nope",
            vec!["undefined arg 'nope'".into()],
        ),
        (
            "eval.xacro",
            arm_with("  <link name=\"$(eval 1+1)\"/>\n"),
            "eval",
            vec!["unsupported substitution".into()],
        ),
        (
            "param.xacro",
            arm_with("  <xacro:macro name=\"m\" params=\"a\"/>\n  <xacro:m b=\"1\"/>\n"),
            "xacro:m b",
            vec!["macro 'm' has no parameter 'b'".into()],
        ),
    ];
    for (name, text, marker, want) in &cases {
        let p = write(&dir, name, text);
        let e = import(&p).unwrap_err().to_string();
        let at = format!("{name}:{}:", line_of(text, marker));
        assert!(e.contains(&at), "{name}: expected '{at}' in: {e}");
        for w in want {
            assert!(e.contains(w.as_str()), "{name}: expected '{w}' in: {e}");
        }
        assert!(!e.contains('\n'), "{name}: one line: {e}");
        assert!(
            !e.contains("--"),
            "{name}: a library error names no flag: {e}"
        );
        let out = arg(&dir, "out.toml");
        fails_leaving_nothing(&dir, &["import", &arg(&dir, name), "--out", &out], &at);
    }
    // The include cycle: named at the include that closes it, in the included file.
    let e = import(&dir.join("cycle_a.xacro")).unwrap_err().to_string();
    assert!(
        e.contains("cycle_b.xacro:3:") && e.contains("include cycle"),
        "{e}"
    );
    let out = arg(&dir, "out.toml");
    fails_leaving_nothing(
        &dir,
        &["import", &arg(&dir, "cycle_a.xacro"), "--out", &out],
        "include cycle",
    );
    // A URDF error inside a macro of an included file names that file and line.
    let p = write(
        &dir,
        "uses.xacro",
        &arm_with("  <xacro:include filename=\"inc.xacro\"/>\n  <link name=\"l9\"/>\n  <xacro:nolimit/>\n"),
    );
    let e = import(&p).unwrap_err().to_string();
    assert!(
        e.contains("inc.xacro:3:") && e.contains("joint 'j9'"),
        "{e}"
    );
}

#[test]
fn expansion_bombs_stop_with_an_error() {
    let dir = tmpdir("xacro-bombs");
    // Ten macros, each calling the one before ten times: 10^10 links.
    let mut m = String::from("  <xacro:macro name=\"m0\"><link name=\"lol\"/></xacro:macro>\n");
    for k in 1..10 {
        m += &format!(
            "  <xacro:macro name=\"m{k}\">{}</xacro:macro>\n",
            format!("<xacro:m{}/>", k - 1).repeat(10)
        );
    }
    m += "  <xacro:m9/>\n";
    let e = import(&write(&dir, "laughs.xacro", &arm_with(&m)))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("larger than 16 MiB") || e.contains("steps"),
        "{e}"
    );
    // A property doubling forty times.
    let mut p = String::from("  <xacro:property name=\"p0\" value=\"haha\"/>\n");
    for k in 1..40 {
        p += &format!(
            "  <xacro:property name=\"p{k}\" value=\"${{p{}}}${{p{}}}\"/>\n",
            k - 1,
            k - 1
        );
    }
    p += "  <link name=\"${p39}\"/>\n";
    let e = import(&write(&dir, "double.xacro", &arm_with(&p)))
        .unwrap_err()
        .to_string();
    assert!(e.contains("longer than 16 MiB"), "{e}");
    // A property defined by itself.
    let e = import(&write(
        &dir,
        "self.xacro",
        &arm_with("  <xacro:property name=\"a\" value=\"${b}\"/>\n  <xacro:property name=\"b\" value=\"${a}\"/>\n  <link name=\"${a}\"/>\n"),
    ))
    .unwrap_err()
    .to_string();
    assert!(e.contains("in terms of itself"), "{e}");
    // A thousand properties each defined by the one before, and three hundred nested ifs: an
    // error, not a stack overflow.
    let mut p = String::from("  <xacro:property name=\"q0\" value=\"1\"/>\n");
    for k in 1..1000 {
        p += &format!(
            "  <xacro:property name=\"q{k}\" value=\"${{q{} + 1}}\"/>\n",
            k - 1
        );
    }
    p += "  <link name=\"x${q999}\"/>\n";
    let e = import(&write(&dir, "chain.xacro", &arm_with(&p)))
        .unwrap_err()
        .to_string();
    assert!(e.contains("nest deeper than 256"), "{e}");
    let ifs = format!(
        "{}<link name=\"x\"/>{}\n",
        "<xacro:if value=\"1\">".repeat(300),
        "</xacro:if>".repeat(300)
    );
    let e = import(&write(&dir, "ifs.xacro", &arm_with(&ifs)))
        .unwrap_err()
        .to_string();
    assert!(e.contains("nest deeper than 256"), "{e}");
    // Text that is not ASCII around a substitution.
    let t =
        arm_with("  <xacro:property name=\"s\" value=\"é\"/>\n  <material name=\"ü$x${s}ß\"/>\n");
    assert!(import(&write(&dir, "utf8.xacro", &t)).is_ok());
}

#[test]
fn the_prefix_is_whatever_the_file_binds_to_the_xacro_namespace() {
    let dir = tmpdir("xacro-prefix");
    let text = super::simple_urdf("")
        .replace(
            "<robot name=\"r\">",
            "<robot name=\"r\" xmlns:x=\"http://www.ros.org/wiki/xacro\">\n  <x:property name=\"up\" value=\"0.3\"/>",
        )
        .replace("\"0 0 0.3\"", "\"0 0 ${up}\"");
    let x = import(&write(&dir, "p.xacro", &text)).unwrap();
    let u = import(&write(&dir, "p.urdf", &super::simple_urdf(""))).unwrap();
    assert_eq!(x.model, u.model);
    // A prefix bound to another namespace is not xacro: <x:property> is then left alone, and
    // the ${up} it would have defined is undefined.
    let other = text.replace(
        "http://www.ros.org/wiki/xacro",
        "http://example.com/not-xacro",
    );
    let e = import(&write(&dir, "o.xacro", &other))
        .unwrap_err()
        .to_string();
    assert!(e.contains("undefined property 'up'"), "{e}");
}

#[test]
fn includes_nest_at_most_32_deep() {
    let dir = tmpdir("xacro-deep");
    let chain = |n: usize| {
        for k in 0..n {
            let inner = if k + 1 < n {
                format!("<xacro:include filename=\"f{}.xacro\"/>", k + 1)
            } else {
                String::new()
            };
            write(
                &dir,
                &format!("f{k}.xacro"),
                &format!("<robot {NS}>\n{inner}\n</robot>\n"),
            );
        }
        write(
            &dir,
            "top.xacro",
            &arm_with("  <xacro:include filename=\"f0.xacro\"/>\n"),
        )
    };
    // 32 included files below the top one import; 33 do not.
    assert!(import(&chain(32)).is_ok());
    let e = import(&chain(33)).unwrap_err().to_string();
    assert!(
        e.contains("nest deeper than 32") && e.contains("f31.xacro:2:"),
        "{e}"
    );
}
