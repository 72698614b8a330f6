//! Unit tests of the xacro expression language: precedence, functions, strings and logic, and
//! refusals as messages.

use super::*;
use std::collections::HashMap;
use std::f64::consts::PI;

struct Props(HashMap<&'static str, Value>);

impl Names for Props {
    fn lookup(&mut self, name: &str) -> Result<Option<Value>, String> {
        Ok(self.0.get(name).cloned())
    }
}

fn ev(src: &str) -> Result<Value, String> {
    let mut p = Props(HashMap::from([
        ("a", Value::Str("0.5".into())),
        ("prefix", Value::Str("r_".into())),
        ("flag", Value::Str("true".into())),
        ("n", Value::Num(3.0)),
    ]));
    eval(src, &mut p)
}

fn n(src: &str) -> f64 {
    match ev(src) {
        Ok(Value::Num(x)) => x,
        other => panic!("{src}: {other:?}"),
    }
}

#[test]
fn import_xacro_expr_arithmetic_has_python_precedence() {
    assert_eq!(n("1 + 2 * 3"), 7.0);
    assert_eq!(n("(1 + 2) * 3"), 9.0);
    assert_eq!(n("2 ** 3 ** 2"), 512.0);
    assert_eq!(n("-2 ** 2"), -4.0);
    assert_eq!(n("2 ** -1"), 0.5);
    assert_eq!(n("7 / 2"), 3.5);
    assert_eq!(n("7 // 2"), 3.0);
    assert_eq!(n("-7 % 3"), 2.0);
    assert_eq!(n("1e-3 * 1000"), 1.0);
    assert_eq!(n("a * 4 + n"), 5.0);
    assert_eq!(n("--1"), 1.0);
}

#[test]
fn import_xacro_expr_functions_and_pi() {
    assert_eq!(n("pi / 2"), PI / 2.0);
    assert_eq!(n("radians(90)"), PI / 2.0);
    assert_eq!(n("radians(90)"), n("pi/2"));
    assert_eq!(n("degrees(pi)"), 180.0);
    assert_eq!(n("math.pi"), PI);
    assert_eq!(n("atan2(1, 1)"), PI / 4.0);
    assert_eq!(n("sqrt(16) + abs(-2) + floor(1.7) + ceil(1.2)"), 9.0);
    assert_eq!(
        n("cos(0) + sin(0) + tan(0) + asin(0) + acos(1) + atan(0)"),
        1.0
    );
    assert_eq!(format!("{}", Value::Num(PI / 2.0)), "1.5707963267948966");
    assert_eq!(format!("{}", Value::Num(2.0)), "2");
    assert_eq!(format!("{}", Value::Num(-0.25)), "-0.25");
}

#[test]
fn import_xacro_expr_strings_and_logic() {
    assert_eq!(ev("prefix + 'link'"), Ok(Value::Str("r_link".into())));
    assert_eq!(ev("n > 2 and not (a > 1)"), Ok(Value::Bool(true)));
    assert_eq!(ev("n == 4 or flag"), Ok(Value::Bool(true)));
    assert_eq!(ev("prefix == 'r_'"), Ok(Value::Bool(true)));
    assert_eq!(ev("not flag"), Ok(Value::Bool(false)));
    assert_eq!(ev("1 <= 1"), Ok(Value::Bool(true)));
    assert_eq!(ev("1 != 1"), Ok(Value::Bool(false)));
}

#[test]
fn import_xacro_expr_refusals_are_messages() {
    for (src, want) in [
        ("1 / 0", "division by zero"),
        ("1 % (2 - 2)", "division by zero"),
        ("0 ** -1", "division by zero"),
        ("b + 1", "undefined property 'b'"),
        ("sqrt(-1)", "outside its domain"),
        ("asin(2)", "outside its domain"),
        ("foo(1)", "unknown function 'foo'"),
        ("atan2(1)", "takes 2"),
        ("1 +", "expected a value"),
        ("(1", "expected ')'"),
        ("1 2", "unexpected number"),
        ("prefix * 2", "not a number"),
        ("__import__('os')", "unknown function"),
        ("10 ** 400", "not a finite number"),
        ("'abc", "unterminated"),
        ("1 ; 2", "unexpected character"),
        ("", "empty expression"),
    ] {
        let e = ev(src).unwrap_err();
        assert!(e.contains(want), "{src}: {e}");
    }
    let deep = format!("{}1{}", "(".repeat(500), ")".repeat(500));
    assert!(ev(&deep).unwrap_err().contains("nested deeper"));
}
