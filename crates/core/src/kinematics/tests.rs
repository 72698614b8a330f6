//! Tests of the model: the TOML round trip and the checks of every field.

use super::*;
use crate::kinematics::tx60;

// The TX60's counts: six joints.
const N_PARAMS: usize = Layout::SIX.n_params();
const N_ROBOT_INPUTS: usize = 33;
fn tool_at(k: usize) -> usize {
    Layout::SIX.robot().index(Block::Tool, k).unwrap()
}

#[test]
fn toml_round_trip() {
    let m = tx60();
    let back = RobotModel::from_toml(&m.to_toml(), "x").unwrap();
    assert_eq!(m.fixed, back.fixed);
    for i in 0..N_PARAMS {
        assert!((m.params[i] - back.params[i]).abs() < 1e-15);
    }
    assert_eq!(
        m.param_sigmas().map(|v| (v * 1e12).round()),
        back.param_sigmas().map(|v| (v * 1e12).round())
    );
}

#[test]
fn covariance_round_trip() {
    let mut m = tx60();
    let s = m.param_sigmas();
    let mut c = vec![0.0; N_PARAMS * N_PARAMS];
    for i in 0..N_PARAMS {
        c[i * N_PARAMS + i] = s[i] * s[i];
    }
    c[1] = 0.3 * s[0] * s[1];
    c[N_PARAMS] = c[1];
    m.uncertainty = Uncertainty::from_matrix(InputSpace::parameters(6), c.clone());
    let back = RobotModel::from_toml(&m.to_toml(), "x").unwrap();
    match back.uncertainty {
        Uncertainty::Covariance(b) => {
            assert_eq!(b.space(), InputSpace::parameters(6));
            let b = b.matrix();
            for i in 0..c.len() {
                assert!((b[i] - c[i]).abs() <= 1e-12 * c[i].abs().max(1e-20));
            }
        }
        _ => panic!("lost covariance"),
    }
}

fn err_of(text: &str) -> String {
    RobotModel::from_toml(text, "m.toml")
        .unwrap_err()
        .to_string()
}

#[test]
fn values_exactly_at_the_limits_pass_and_just_past_fail() {
    // The file's degrees go through radians and back: the check must not reject a value of
    // exactly the limit by a rounding ulp, for any joint or parameter.
    let mut m = tx60();
    for (i, p) in m.params.iter_mut().enumerate() {
        let kind = param_kind(i);
        let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
        let max = if kind.is_angle() {
            MAX_ANGLE_DEG
        } else {
            MAX_LENGTH_MM
        };
        *p = sign * max * kind.to_internal();
    }
    let mut s = Params::filled(N_PARAMS, 0.0);
    for (i, v) in s.iter_mut().enumerate() {
        let kind = param_kind(i);
        let fixed = match m.fixed[param_joint(i)] {
            FixedParam::D => ParamKind::D,
            FixedParam::Beta => ParamKind::Beta,
        };
        if kind != fixed {
            *v = if kind.is_angle() {
                MAX_SIGMA_DEG
            } else {
                MAX_SIGMA_MM
            } * kind.to_internal();
        }
    }
    m.uncertainty = Uncertainty::Independent(s);
    m.limits_deg = Limits::filled(6, (-MAX_LIMIT_DEG, MAX_LIMIT_DEG));
    m.tool = [MAX_LENGTH_MM, -MAX_LENGTH_MM, 0.0];
    m.check().unwrap();
    RobotModel::from_toml(&m.to_toml(), "m.toml").unwrap();
    let mut past = m.clone();
    past.params[3] *= 1.000_001;
    assert_eq!(past.check().unwrap_err().field, "joint[1].alpha");
    let mut past = m.clone();
    s[2] *= 1.000_001;
    past.uncertainty = Uncertainty::Independent(s);
    assert_eq!(past.check().unwrap_err().field, "joint[1].sigma.a");
}

/// `tool_sigma` is optional (absent: the file and the model are as before), round-trips,
/// and a bad value is named; a 33 × 33 covariance carries the tool and must agree with a
/// given `tool_sigma`.
#[test]
fn tool_sigma_in_the_file() {
    let m = tx60();
    assert!(!m.to_toml().contains("tool_sigma"));
    let mut t = m.clone();
    t.tool_sigma = [0.002, 0.0, 0.0035];
    let text = t.to_toml();
    assert!(text.contains("tool_sigma = [0.002, 0.0, 0.0035]"), "{text}");
    assert_eq!(
        RobotModel::from_toml(&text, "x").unwrap().tool_sigma,
        t.tool_sigma
    );
    let neg = text.replace("tool_sigma = [0.002,", "tool_sigma = [-0.002,");
    assert!(err_of(&neg).contains("tool_sigma[0]"), "{}", err_of(&neg));
    let two = text.replace("tool_sigma = [0.002, 0.0,", "tool_sigma = [0.002,");
    assert!(
        err_of(&two).contains("tool_sigma: must be exactly 3"),
        "{}",
        err_of(&two)
    );
    // 33 × 33: the tool's variances from the matrix
    let n = N_ROBOT_INPUTS;
    let s = m.param_sigmas();
    let mut c = vec![0.0; n * n];
    for i in 0..N_PARAMS {
        c[i * n + i] = s[i] * s[i];
    }
    for k in 0..3 {
        c[tool_at(k) * (n + 1)] = t.tool_sigma[k].powi(2);
    }
    c[tool_at(2) * n + 1] = 0.5 * t.tool_sigma[2] * s[1];
    c[n + tool_at(2)] = c[tool_at(2) * n + 1];
    t.uncertainty = Uncertainty::from_matrix(InputSpace::robot(6), c);
    t.check().unwrap();
    let text = t.to_toml();
    assert!(text.contains("then the tool's x, y, z"));
    let back = RobotModel::from_toml(&text, "x").unwrap();
    assert_eq!(back.uncertainty.dim(), N_ROBOT_INPUTS);
    for k in 0..3 {
        assert!((back.tool_sigma[k] - t.tool_sigma[k]).abs() < 1e-15);
    }
    assert_eq!(back.full_covariance().unwrap().len(), n * n);
    let off = text.replace("tool_sigma = [0.002,", "tool_sigma = [0.003,");
    assert!(
        err_of(&off).contains("tool_sigma[0]: differs from sqrt of covariance diagonal"),
        "{}",
        err_of(&off)
    );
    // a 30 × 30 matrix keeps tool_sigma as the tool's independent spread
    let mut p = m.clone();
    p.uncertainty = Uncertainty::from_matrix(
        InputSpace::parameters(6),
        (0..N_PARAMS * N_PARAMS)
            .map(|x| {
                if x % (N_PARAMS + 1) == 0 {
                    s[x / N_PARAMS].powi(2)
                } else {
                    0.0
                }
            })
            .collect(),
    );
    p.tool_sigma = [0.0, 0.001, 0.0];
    let full = p.full_covariance().unwrap();
    assert_eq!(full[tool_at(1) * (n + 1)], 1e-6);
    assert_eq!(p.free_inputs().last(), Some(&tool_at(1)));
}

#[test]
fn bad_fields_are_named() {
    let good = tx60().to_toml();
    let neg = good.replacen(
        "sigma = { theta = 0.003216, d = 0.005056",
        "sigma = { theta = 0.003216, d = -0.005056",
        1,
    );
    assert_ne!(neg, good);
    assert!(
        err_of(&neg).contains("joint[1].sigma.d"),
        "{}",
        err_of(&neg)
    );
    let nan = good.replacen("\na = 0.0", "\na = nan", 1);
    assert!(err_of(&nan).contains("joint[1].a"), "{}", err_of(&nan));
    let unknown = good.replacen("fixed = \"beta\"", "fixed = \"beta\"\nfoo = 1", 1);
    assert!(err_of(&unknown).contains("foo"), "{}", err_of(&unknown));
    let line = 1
        + good[..good.find("fixed = \"beta\"").unwrap()]
            .matches('\n')
            .count()
        + 1;
    assert!(
        err_of(&unknown).starts_with(&format!("model file m.toml: line {line}, column 1: ")),
        "{}",
        err_of(&unknown)
    );
    assert!(!err_of("x = ").contains('|'), "{}", err_of("x = "));
    let missing = good.replacen(
        "sigma = { theta = 0.003216, d = 0.005056,",
        "sigma = { d = 0.005056,",
        1,
    );
    assert!(err_of(&missing).contains("theta"), "{}", err_of(&missing));
    let lim = good.replacen("limits = [-180.0, 180.0]", "limits = [180.0, -180.0]", 1);
    assert!(err_of(&lim).contains("joint[1].limits"), "{}", err_of(&lim));
}

/// A model with a placement-covering covariance: the TX60 with a tool, a placement and a
/// 39 × 39 covariance (parameters' σ², a tool σ of 2 µm, base σ of 0.1 mm and 0.01°, one
/// correlation between θ2 and base_yaw).
fn measured_tx60() -> RobotModel {
    let mut m = tx60();
    let space = InputSpace::measured(6);
    let n = space.len();
    let s = m.param_sigmas();
    let mut c = vec![0.0; n * n];
    for i in 0..N_PARAMS {
        c[i * n + i] = s[i] * s[i];
    }
    for i in space.range(Block::Tool).unwrap() {
        c[i * n + i] = 0.002f64.powi(2);
    }
    for (k, i) in space.range(Block::Placement).unwrap().enumerate() {
        c[i * n + i] = if k < 3 {
            0.01
        } else {
            0.01f64.to_radians().powi(2)
        };
    }
    let (a, b) = (5, space.index(Block::Placement, 5).unwrap());
    c[a * n + b] = 0.3 * c[a * n + a].sqrt() * c[b * n + b].sqrt();
    c[b * n + a] = c[a * n + b];
    m.tool = [30.0, -20.0, 80.0];
    m.tool_sigma = [0.002; 3];
    m.base = Some(BaseTransform {
        xyz: [2000.0, 100.0, 0.0],
        rpy: [0.05, -0.02, 1.2],
    });
    m.uncertainty = Uncertainty::from_matrix(space, c);
    m.check().unwrap();
    m
}

/// The file names the covariance's blocks; the blocks survive the round trip, and a file
/// without the list (written before blocks were named) reads as the same model.
#[test]
fn covariance_blocks_are_written_and_older_files_still_load() {
    for m in [measured_tx60(), {
        let mut p = measured_tx60().without_base_uncertainty();
        p.base = None;
        p
    }] {
        let text = m.to_toml();
        let names = m.uncertainty.covariance().unwrap().space().block_names();
        let line = format!(
            "blocks = [{}]",
            names
                .iter()
                .map(|b| format!("\"{b}\""))
                .collect::<Vec<_>>()
                .join(", ")
        );
        assert!(text.contains(&format!("[covariance]\n{line}\n")), "{text}");
        let back = RobotModel::from_toml(&text, "m.toml").unwrap();
        assert_eq!(
            back.uncertainty.covariance().unwrap().space().block_names(),
            names
        );
        let old = text.replace(&format!("{line}\n"), "");
        assert_ne!(old, text);
        let legacy = RobotModel::from_toml(&old, "m.toml").unwrap();
        assert_eq!(
            legacy, back,
            "an older file without the list reads the same"
        );
    }
}

/// A covariance over a block the code does not know is one clear error naming it and the
/// known blocks; blocks out of order, and a matrix of the wrong size for the named blocks,
/// are refused naming the field.
#[test]
fn unknown_or_mismatched_covariance_blocks_are_named() {
    let text = measured_tx60().to_toml();
    let blocks = "blocks = [\"joints\", \"tool\", \"placement\"]";
    assert!(text.contains(blocks));
    let unknown = text.replace(blocks, "blocks = [\"joints\", \"tool\", \"compliance\"]");
    assert_eq!(
        err_of(&unknown),
        "model file m.toml: covariance.blocks: unknown block 'compliance' (known: joints, tool, placement)"
    );
    let order = text.replace(blocks, "blocks = [\"joints\", \"placement\", \"tool\"]");
    let e = err_of(&order);
    assert!(
        e.contains("covariance.blocks: the blocks must start with \"joints\""),
        "{e}"
    );
    // 39 rows named as the 33 of joints and tool: the size does not silently choose.
    let short = text.replace(blocks, "blocks = [\"joints\", \"tool\"]");
    let e = err_of(&short);
    assert!(
        e.contains("covariance.matrix: must have 33 rows for the blocks [joints, tool] of 6 joints, found 39"),
        "{e}"
    );
    // A legacy size that fits no block set names the sizes it accepts.
    let m = tx60();
    let mut bad = m.to_toml();
    bad.push_str("\n[covariance]\nmatrix = [[1.0]]\n");
    let e = err_of(&bad);
    assert!(e.contains("covariance.matrix: must have 30 rows"), "{e}");
}

/// A covariance of the joints and the placement without the tool: the placement keeps its
/// normal slots (33–38), the tool its independent σ, and the base-frame model drops the
/// placement's rows.
#[test]
fn a_covariance_without_the_tool_block() {
    let full = measured_tx60();
    let c = full.uncertainty.covariance().unwrap();
    let space = InputSpace::new(6, &[Block::Joints, Block::Placement]).unwrap();
    let mut m = full.clone();
    m.uncertainty = Uncertainty::Covariance(c.restricted(space));
    m.tool_sigma = [0.0, 0.004, 0.0];
    m.check().unwrap();
    assert_eq!(m.base_sigmas(), full.base_sigmas());
    let robot = m.covariance_in(InputSpace::robot(6));
    assert_eq!(robot[31 * 33 + 31], 0.004f64.powi(2));
    assert_eq!(robot[5 * 33 + 5], c.entry(5, 5));
    let measured = m.covariance_in(InputSpace::measured(6));
    assert_eq!(measured[5 * 39 + 38], c.entry(5, 38));
    assert_eq!(measured[31 * 39 + 38], 0.0);
    // The file holds degrees: the round trip agrees to the rounding of deg → rad → deg.
    let back = RobotModel::from_toml(&m.to_toml(), "m.toml").unwrap();
    let (a, b) = (
        back.uncertainty.covariance().unwrap(),
        m.uncertainty.covariance().unwrap(),
    );
    assert_eq!(a.space(), space);
    assert_eq!(back.tool_sigma, m.tool_sigma);
    for (x, y) in a.matrix().iter().zip(b.matrix()) {
        assert!((x - y).abs() <= 1e-14 * y.abs(), "{x} vs {y}");
    }
    assert_eq!(
        m.without_base_uncertainty().uncertainty.dim(),
        N_PARAMS,
        "the base frame keeps the parameters' block"
    );
}

#[test]
fn model_files_keep_the_term_and_name_a_bad_field() {
    use crate::discrepancy::{Discrepancy, NoiseSource};
    use crate::kinematics::{tx60, RobotModel};
    let mut m = tx60();
    m.discrepancy = Some(Discrepancy {
        residual_norms: (1..=12).map(|i| 0.01 * f64::from(i)).collect(),
        robot_share: 0.75,
        noise: NoiseSource::Stated,
        noise_sigma_mm: Some(0.012),
        compensation: None,
    });
    let text = m.to_toml();
    assert!(text.contains("[discrepancy]"), "{text}");
    let back = RobotModel::from_toml(&text, "m.toml").unwrap();
    assert_eq!(back.discrepancy, m.discrepancy);
    assert_eq!(back.to_toml(), text);
    let bad = text.replace("robot_share = 0.75", "robot_share = 1.5");
    let err = RobotModel::from_toml(&bad, "m.toml")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("m.toml") && err.contains("discrepancy.robot_share"),
        "{err}"
    );
    let typo = text.replace("robot_share", "robot_shar");
    let err = RobotModel::from_toml(&typo, "m.toml")
        .unwrap_err()
        .to_string();
    assert!(err.contains("robot_shar"), "{err}");
    // Without the table: no term.
    let i = text.find("\n# What the geometric model").unwrap();
    let none = RobotModel::from_toml(&text[..i], "m.toml").unwrap();
    assert!(none.discrepancy.is_none());
}

#[test]
fn model_files_keep_the_compensation_exactly_and_check_its_joints() {
    use crate::discrepancy::{Compensation, Discrepancy, NoiseSource};
    use crate::kinematics::{tx60, RobotModel};
    let mut m = tx60();
    m.discrepancy = Some(Discrepancy {
        residual_norms: (1..=12).map(|i| 0.01 * f64::from(i)).collect(),
        robot_share: 1.0,
        noise: NoiseSource::Unknown,
        noise_sigma_mm: None,
        compensation: Some(Compensation {
            length_scales_deg: vec![71.4, 4.35, 40.0, 24814.2, 77.5, 12325.9],
            signal_sigma_mm: 0.214,
            white_sigma_mm: 0.192,
            loo_rms_geometric_mm: 0.4426,
            loo_rms_compensated_mm: 0.3097,
            loo_sigma_mm: 0.18,
            configurations_deg: vec![
                vec![10.0, 20.0, 30.0, 0.0, 45.0, 0.1],
                vec![
                    -52.068972,
                    -2.9892927,
                    -110.4353232,
                    -66.5851442,
                    -117.98,
                    -0.0479652,
                ],
            ],
            weights: vec![[1.0 / 3.0, -2.5e-3, 7.0], [0.1, 0.2, -0.3]],
        }),
    });
    let q = [0.3, 0.2, 1.1, 0.0, 0.6, 0.1];
    let text = m.to_toml();
    assert!(text.contains("[discrepancy.compensation]"), "{text}");
    let back = RobotModel::from_toml(&text, "m.toml").unwrap();
    assert_eq!(back.discrepancy, m.discrepancy);
    assert!(back.compensated());
    // The same prediction to the bit, and it differs from the geometric one.
    assert_eq!(back.compensated_position(&q), m.compensated_position(&q));
    assert_ne!(
        back.compensated_position(&q),
        crate::kinematics::position(&m.params, &m.tool, &q)
    );
    // A compensation of another joint count names the field.
    let bad = text.replace(
        "length_scales_deg = [71.4, 4.35, 40.0, 24814.2, 77.5, 12325.9]",
        "length_scales_deg = [71.4, 4.35, 40.0, 24814.2, 77.5]",
    );
    let err = RobotModel::from_toml(&bad, "m.toml")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("discrepancy.compensation.length_scales_deg") && err.contains("6 joints"),
        "{err}"
    );
    let bad = text.replace("[0.1, 0.2, -0.3]", "[0.1, 0.2]");
    assert!(RobotModel::from_toml(&bad, "m.toml").is_err());
    let bad = text.replace("loo_sigma_mm = 0.18", "loo_sigma_mm = 0.0");
    let err = RobotModel::from_toml(&bad, "m.toml")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("discrepancy.compensation.loo_sigma_mm"),
        "{err}"
    );
}
