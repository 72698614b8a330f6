//! Unit tests of the robot sensitivity analysis: the options' checks, the input groups of the
//! TX60 (tool coordinates included) and of a seven-joint model, and the design's joint count.

use super::groups::robot_groups;
use super::*;
use crate::kinematics::tx60;

#[test]
fn options_name_the_field() {
    let field = |o: SensitivityOptions| match o.check() {
        Err(SensitivityError::Setting { field, .. }) => field,
        r => panic!("{r:?}"),
    };
    let o = SensitivityOptions::default();
    assert!(o.check().is_ok());
    assert_eq!(
        field(SensitivityOptions {
            draws: 1000,
            ..o.clone()
        }),
        SensitivitySetting::Draws
    );
    assert_eq!(
        field(SensitivityOptions {
            draws: MAX_DRAWS * 2,
            ..o.clone()
        }),
        SensitivitySetting::Draws
    );
    assert_eq!(
        field(SensitivityOptions {
            draws: 32,
            ..o.clone()
        }),
        SensitivitySetting::Draws
    );
    assert_eq!(
        field(SensitivityOptions {
            bootstrap: 10,
            ..o.clone()
        }),
        SensitivitySetting::Bootstrap
    );
    assert_eq!(
        field(SensitivityOptions {
            chunk: 0,
            ..o.clone()
        }),
        SensitivitySetting::Chunk
    );
    for l in [0.0, -1.0, f64::NAN] {
        let t = SensitivityOptions {
            thresholds: vec![0.5, l],
            ..o.clone()
        };
        assert_eq!(field(t), SensitivitySetting::Thresholds);
    }
}

#[test]
fn tx60_groups_cover_the_free_parameters() {
    let free = tx60().free_params();
    let lay = Layout::SIX;
    let g = robot_groups(lay, &free);
    let names: Vec<&str> = g.iter().map(|g| g.name.as_str()).collect();
    // Joint 6 has no free parameter.
    assert_eq!(
        names,
        [
            "joint 1",
            "joint 2",
            "joint 3",
            "joint 4",
            "joint 5",
            "joint angles θ",
            "twists α/β",
            "lengths a/d"
        ]
    );
    let per_joint: usize = g[..5].iter().map(|g| g.members.len()).sum();
    let per_kind: usize = g[5..].iter().map(|g| g.members.len()).sum();
    assert_eq!((per_joint, per_kind), (free.len(), free.len()));
    assert_eq!(param_name(lay, free[g[1].members[3]]), "beta2");
}

/// With an uncertain tool, its coordinates are inputs of their own group and of no joint
/// or kind group.
#[test]
fn tool_coordinates_form_the_tool_group() {
    let mut m = tx60();
    m.tool_sigma = [0.002, 0.0, 0.003];
    let free = m.free_inputs();
    let lay = m.layout();
    let n_params = lay.n_params();
    assert_eq!(free[free.len() - 2..], [n_params, n_params + 2]);
    let g = robot_groups(lay, &free);
    let tool = g.last().unwrap();
    assert_eq!(tool.name, "tool");
    let names: Vec<String> = tool
        .members
        .iter()
        .map(|&c| param_name(lay, free[c]))
        .collect();
    assert_eq!(names, ["tool_x", "tool_z"]);
    for other in &g[..g.len() - 1] {
        assert!(
            other.members.iter().all(|&c| free[c] < n_params),
            "{}",
            other.name
        );
    }
}

/// A seven-joint model's inputs: seven joint groups, its tool and placement after its 35
/// parameters; its design carries the joint count through a file, a six-joint one's reads
/// as before.
#[test]
fn seven_joint_inputs_are_laid_out_by_the_model() {
    let lay = Layout::new(7);
    // theta1, d7, beta7, tool_x, base_yaw
    let free = vec![0, 31, 34, 35, 43];
    let g = robot_groups(lay, &free);
    let names: Vec<&str> = g.iter().map(|g| g.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "joint 1",
            "joint 7",
            "joint angles θ",
            "twists α/β",
            "lengths a/d",
            "tool",
            "base placement"
        ]
    );
    assert_eq!(g[1].members, [1, 2]);
    assert_eq!(param_name(lay, 35), "tool_x");
    assert_eq!(param_name(lay, 43), "base_yaw");
    let seven = Design {
        input_kind: InputKind::CholeskyInnovations,
        free: free.clone(),
        joints: 7,
        discrepancy: false,
        joint_errors: Vec::new(),
    };
    let json = serde_json::to_string(&seven).unwrap();
    assert!(json.contains("\"joints\":7"), "{json}");
    assert_eq!(serde_json::from_str::<Design>(&json).unwrap(), seven);
    let six = Design {
        free: vec![0, 1],
        joints: 6,
        ..seven
    };
    let json = serde_json::to_string(&six).unwrap();
    assert!(
        !json.contains("joints") && !json.contains("discrepancy"),
        "{json}"
    );
    assert_eq!(serde_json::from_str::<Design>(&json).unwrap(), six);
    let with_term = Design {
        discrepancy: true,
        joint_errors: Vec::new(),
        ..six.clone()
    };
    let json = serde_json::to_string(&with_term).unwrap();
    assert!(json.contains("\"discrepancy\":true"), "{json}");
    assert_eq!(serde_json::from_str::<Design>(&json).unwrap(), with_term);
    // A design whose inputs lie beyond its joint count is refused.
    let bad = Design {
        free: vec![40],
        joints: 6,
        ..six.clone()
    };
    let out = Outputs::default();
    let backend = || BackendInfo {
        backend: "cpu".into(),
        adapter: String::new(),
        driver: String::new(),
    };
    let r = bad.result(
        ("m".into(), 1, 1),
        backend(),
        &out,
        &SensitivityOptions::default(),
    );
    assert!(matches!(r, Err(SensitivityError::Design(_))), "{r:?}");
    let r = Design { joints: 9, ..six }.result(
        ("m".into(), 1, 1),
        backend(),
        &out,
        &SensitivityOptions::default(),
    );
    assert!(matches!(r, Err(SensitivityError::Design(_))), "{r:?}");
}
