//! Tests of the model: the TOML round trip and the checks of every field.

use super::*;
use crate::kinematics::tx60;

// The TX60's counts: six joints.
const N_PARAMS: usize = Layout::SIX.n_params();
const N_UNCERTAIN: usize = 33;
fn tool_index(k: usize) -> usize {
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
    let n = N_UNCERTAIN;
    let s = m.param_sigmas();
    let mut c = vec![0.0; n * n];
    for i in 0..N_PARAMS {
        c[i * n + i] = s[i] * s[i];
    }
    for k in 0..3 {
        c[tool_index(k) * (n + 1)] = t.tool_sigma[k].powi(2);
    }
    c[tool_index(2) * n + 1] = 0.5 * t.tool_sigma[2] * s[1];
    c[n + tool_index(2)] = c[tool_index(2) * n + 1];
    t.uncertainty = Uncertainty::from_matrix(InputSpace::robot(6), c);
    t.check().unwrap();
    let text = t.to_toml();
    assert!(text.contains("then the tool's x, y, z"));
    let back = RobotModel::from_toml(&text, "x").unwrap();
    assert_eq!(back.uncertainty.dim(), N_UNCERTAIN);
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
    assert_eq!(full[tool_index(1) * (n + 1)], 1e-6);
    assert_eq!(p.free_inputs().last(), Some(&tool_index(1)));
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
