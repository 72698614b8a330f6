//! The `${...}` expressions of xacro: a small recursive-descent parser and evaluator over
//! numbers, strings and booleans. Nothing is executed beyond the operators and the fixed list of
//! math functions below.
//!
//! Grammar (Python's precedence, the language xacro evaluates in):
//!
//! ```text
//! or   := and ("or" and)*
//! and  := not ("and" not)*
//! not  := "not" not | cmp
//! cmp  := sum (("<" | "<=" | ">" | ">=" | "==" | "!=") sum)?
//! sum  := prod (("+" | "-") prod)*
//! prod := unary (("*" | "/" | "//" | "%") unary)*
//! unary:= ("-" | "+") unary | pow
//! pow  := atom ("**" unary)?
//! atom := number | 'string' | "string" | name | name "(" args ")" | "(" or ")"
//! ```
//!
//! The unit tests, with known values, are in `tests`.

use std::fmt;

/// A value of an expression or a property.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// A number (xacro's int and float alike).
    Num(f64),
    /// Text.
    Str(String),
    /// A truth value.
    Bool(bool),
}

impl fmt::Display for Value {
    /// Numbers in Rust's shortest round-trip form (integers without a decimal point).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Value::Num(x) => write!(f, "{x}"),
            Value::Str(s) => f.write_str(s),
            Value::Bool(b) => f.write_str(if *b { "true" } else { "false" }),
        }
    }
}

impl Value {
    /// A string that reads as a number or a truth value is that (xacro's properties are text
    /// until an expression uses them).
    pub fn coerce(self) -> Value {
        match self {
            Value::Str(s) => {
                let t = s.trim();
                if let Ok(x) = t.parse::<f64>() {
                    // "inf"/"nan" are names, not numbers, in a robot description.
                    if x.is_finite() {
                        return Value::Num(x);
                    }
                }
                match t {
                    "true" | "True" => Value::Bool(true),
                    "false" | "False" => Value::Bool(false),
                    _ => Value::Str(s),
                }
            }
            v => v,
        }
    }

    /// The truth of a condition: booleans, numbers (non-zero), and the texts true/false/1/0.
    ///
    /// # Errors
    ///
    /// A message for any other text.
    pub fn truth(&self) -> Result<bool, String> {
        match self.clone().coerce() {
            Value::Bool(b) => Ok(b),
            Value::Num(x) => Ok(x != 0.0),
            Value::Str(s) => Err(format!("'{s}' is not a boolean (true, false, 1 or 0)")),
        }
    }
}

/// What an expression refers to by name.
pub trait Names {
    /// The value of property `name`, `Ok(None)` when there is no such property.
    ///
    /// # Errors
    ///
    /// A message when the property exists but cannot be evaluated.
    fn lookup(&mut self, name: &str) -> Result<Option<Value>, String>;
}

#[derive(Clone, Debug, PartialEq)]
enum Tok {
    Num(f64),
    Str(String),
    Name(String),
    Op(&'static str),
}

const OPS: [&str; 17] = [
    "**", "//", "<=", ">=", "==", "!=", "+", "-", "*", "/", "%", "<", ">", "(", ")", ",", "!",
];

fn lex(src: &str) -> Result<Vec<Tok>, String> {
    let mut out = Vec::new();
    let b = src.as_bytes();
    let mut i = 0;
    while i < b.len() {
        let c = b[i] as char;
        if c.is_ascii_whitespace() {
            i += 1;
        } else if c.is_ascii_digit() || (c == '.' && b.get(i + 1).is_some_and(u8::is_ascii_digit)) {
            let start = i;
            while i < b.len() && (b[i].is_ascii_digit() || b[i] == b'.') {
                i += 1;
            }
            if i < b.len() && (b[i] == b'e' || b[i] == b'E') {
                let mut k = i + 1;
                if k < b.len() && (b[k] == b'+' || b[k] == b'-') {
                    k += 1;
                }
                if k < b.len() && b[k].is_ascii_digit() {
                    i = k;
                    while i < b.len() && b[i].is_ascii_digit() {
                        i += 1;
                    }
                }
            }
            let t = &src[start..i];
            let x = t.parse::<f64>().map_err(|_| format!("bad number '{t}'"))?;
            out.push(Tok::Num(x));
        } else if c.is_ascii_alphabetic() || c == '_' {
            let start = i;
            while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_' || b[i] == b'.') {
                i += 1;
            }
            out.push(Tok::Name(src[start..i].to_string()));
        } else if c == '\'' || c == '"' {
            let end = src[i + 1..]
                .find(c)
                .ok_or_else(|| "unterminated string".to_string())?;
            out.push(Tok::Str(src[i + 1..i + 1 + end].to_string()));
            i += end + 2;
        } else {
            let op = OPS
                .iter()
                .find(|op| src[i..].starts_with(**op))
                .ok_or_else(|| {
                    format!(
                        "unexpected character '{}'",
                        &src[i..].chars().next().unwrap_or(c)
                    )
                })?;
            if *op == "!" {
                return Err("unexpected character '!'".into());
            }
            out.push(Tok::Op(op));
            i += op.len();
        }
    }
    Ok(out)
}

/// Nesting limit of parentheses and unary operators (the parser recurses).
const MAX_NESTING: usize = 200;

struct Parser<'a, N: Names> {
    toks: Vec<Tok>,
    pos: usize,
    names: &'a mut N,
    depth: usize,
}

/// Evaluates `src` (the text between `${` and `}`).
///
/// # Errors
///
/// A one-line message: a syntax error, an undefined name, a division by zero, a type mismatch
/// or a non-finite result.
pub fn eval<N: Names>(src: &str, names: &mut N) -> Result<Value, String> {
    let toks = lex(src)?;
    if toks.is_empty() {
        return Err("empty expression".into());
    }
    let mut p = Parser {
        toks,
        pos: 0,
        names,
        depth: 0,
    };
    let v = p.or()?;
    if p.pos != p.toks.len() {
        return Err(format!("unexpected {} in '{src}'", p.describe()));
    }
    Ok(v)
}

fn num(v: Value, what: &str) -> Result<f64, String> {
    match v.coerce() {
        Value::Num(x) => Ok(x),
        Value::Bool(b) => Ok(f64::from(u8::from(b))),
        Value::Str(s) => Err(format!("'{s}' is not a number ({what})")),
    }
}

fn finite(x: f64, what: &str) -> Result<Value, String> {
    if x.is_finite() {
        Ok(Value::Num(x))
    } else {
        Err(format!("{what} is not a finite number"))
    }
}

impl<N: Names> Parser<'_, N> {
    fn peek(&self) -> Option<&Tok> {
        self.toks.get(self.pos)
    }

    fn describe(&self) -> String {
        match self.peek() {
            None => "end of expression".into(),
            Some(Tok::Num(x)) => format!("number {x}"),
            Some(Tok::Str(s)) => format!("string '{s}'"),
            Some(Tok::Name(n)) => format!("name '{n}'"),
            Some(Tok::Op(o)) => format!("'{o}'"),
        }
    }

    fn eat_op(&mut self, op: &str) -> bool {
        if matches!(self.peek(), Some(Tok::Op(o)) if *o == op) {
            self.pos += 1;
            true
        } else {
            false
        }
    }

    fn eat_word(&mut self, w: &str) -> bool {
        if matches!(self.peek(), Some(Tok::Name(n)) if n == w) {
            self.pos += 1;
            true
        } else {
            false
        }
    }

    fn nest(&mut self) -> Result<(), String> {
        self.depth += 1;
        if self.depth > MAX_NESTING {
            return Err(format!("expression nested deeper than {MAX_NESTING}"));
        }
        Ok(())
    }

    fn or(&mut self) -> Result<Value, String> {
        let mut v = self.and()?;
        while self.eat_word("or") {
            let r = self.and()?;
            v = Value::Bool(v.truth()? || r.truth()?);
        }
        Ok(v)
    }

    fn and(&mut self) -> Result<Value, String> {
        let mut v = self.not()?;
        while self.eat_word("and") {
            let r = self.not()?;
            v = Value::Bool(v.truth()? && r.truth()?);
        }
        Ok(v)
    }

    fn not(&mut self) -> Result<Value, String> {
        if self.eat_word("not") {
            self.nest()?;
            let v = self.not()?;
            self.depth -= 1;
            return Ok(Value::Bool(!v.truth()?));
        }
        self.cmp()
    }

    fn cmp(&mut self) -> Result<Value, String> {
        let a = self.sum()?;
        for op in ["<=", ">=", "==", "!=", "<", ">"] {
            if self.eat_op(op) {
                let b = self.sum()?;
                return compare(a, b, op);
            }
        }
        Ok(a)
    }

    fn sum(&mut self) -> Result<Value, String> {
        let mut v = self.prod()?;
        loop {
            if self.eat_op("+") {
                let r = self.prod()?;
                v = match (v.coerce(), r.coerce()) {
                    (Value::Str(a), Value::Str(b)) => Value::Str(a + &b),
                    (a, b) => finite(num(a, "+")? + num(b, "+")?, "the sum")?,
                };
            } else if self.eat_op("-") {
                let r = self.prod()?;
                v = finite(num(v, "-")? - num(r, "-")?, "the difference")?;
            } else {
                return Ok(v);
            }
        }
    }

    fn prod(&mut self) -> Result<Value, String> {
        let mut v = self.unary()?;
        loop {
            let op = ["*", "//", "/", "%"].into_iter().find(|op| self.eat_op(op));
            let Some(op) = op else { return Ok(v) };
            let a = num(v, op)?;
            let b = num(self.unary()?, op)?;
            if op != "*" && b == 0.0 {
                return Err("division by zero".into());
            }
            v = finite(
                match op {
                    "*" => a * b,
                    "/" => a / b,
                    "//" => (a / b).floor(),
                    _ => a - b * (a / b).floor(),
                },
                "the product",
            )?;
        }
    }

    fn unary(&mut self) -> Result<Value, String> {
        for (op, sign) in [("-", -1.0), ("+", 1.0)] {
            if self.eat_op(op) {
                self.nest()?;
                let v = num(self.unary()?, op)?;
                self.depth -= 1;
                return Ok(Value::Num(sign * v));
            }
        }
        self.pow()
    }

    fn pow(&mut self) -> Result<Value, String> {
        let a = self.atom()?;
        if self.eat_op("**") {
            self.nest()?;
            let b = num(self.unary()?, "**")?;
            self.depth -= 1;
            let a = num(a, "**")?;
            if a == 0.0 && b < 0.0 {
                return Err("division by zero (0 to a negative power)".into());
            }
            return finite(a.powf(b), "the power");
        }
        Ok(a)
    }

    fn atom(&mut self) -> Result<Value, String> {
        let t = self.peek().cloned();
        match t {
            Some(Tok::Num(x)) => {
                self.pos += 1;
                Ok(Value::Num(x))
            }
            Some(Tok::Str(s)) => {
                self.pos += 1;
                Ok(Value::Str(s))
            }
            Some(Tok::Op("(")) => {
                self.pos += 1;
                self.nest()?;
                let v = self.or()?;
                self.depth -= 1;
                if !self.eat_op(")") {
                    return Err(format!("expected ')', found {}", self.describe()));
                }
                Ok(v)
            }
            Some(Tok::Name(n)) => {
                self.pos += 1;
                if self.eat_op("(") {
                    let mut args = Vec::new();
                    if !self.eat_op(")") {
                        loop {
                            self.nest()?;
                            args.push(self.or()?);
                            self.depth -= 1;
                            if self.eat_op(")") {
                                break;
                            }
                            if !self.eat_op(",") {
                                return Err(format!(
                                    "expected ',' or ')' in the arguments of {n}(), found {}",
                                    self.describe()
                                ));
                            }
                        }
                    }
                    return call(&n, args);
                }
                self.name(&n)
            }
            _ => Err(format!("expected a value, found {}", self.describe())),
        }
    }

    fn name(&mut self, n: &str) -> Result<Value, String> {
        if let Some(v) = self.names.lookup(n)? {
            return Ok(v.coerce());
        }
        match n.strip_prefix("math.").unwrap_or(n) {
            "pi" => Ok(Value::Num(std::f64::consts::PI)),
            "e" if n == "math.e" => Ok(Value::Num(std::f64::consts::E)),
            "True" | "true" => Ok(Value::Bool(true)),
            "False" | "false" => Ok(Value::Bool(false)),
            _ => Err(format!("undefined property '{n}'")),
        }
    }
}

fn compare(a: Value, b: Value, op: &str) -> Result<Value, String> {
    use std::cmp::Ordering;
    let ord = match (a.coerce(), b.coerce()) {
        (Value::Str(x), Value::Str(y)) => x.cmp(&y),
        (Value::Str(x), y) | (y, Value::Str(x)) => {
            return match op {
                "==" => Ok(Value::Bool(false)),
                "!=" => Ok(Value::Bool(true)),
                _ => Err(format!("cannot compare '{x}' with {y} ({op})")),
            };
        }
        (x, y) => {
            let (x, y) = (num(x, op)?, num(y, op)?);
            x.partial_cmp(&y).unwrap_or(Ordering::Equal)
        }
    };
    Ok(Value::Bool(match op {
        "<" => ord == Ordering::Less,
        "<=" => ord != Ordering::Greater,
        ">" => ord == Ordering::Greater,
        ">=" => ord != Ordering::Less,
        "==" => ord == Ordering::Equal,
        _ => ord != Ordering::Equal,
    }))
}

/// The functions an expression may call.
fn call(name: &str, args: Vec<Value>) -> Result<Value, String> {
    let f = name.strip_prefix("math.").unwrap_or(name);
    let arity = match f {
        "atan2" | "pow" => 2,
        "min" | "max" => args.len().max(1),
        "radians" | "degrees" | "sin" | "cos" | "tan" | "asin" | "acos" | "atan" | "sqrt"
        | "abs" | "fabs" | "floor" | "ceil" | "round" | "float" | "int" => 1,
        _ => return Err(format!("unknown function '{name}'")),
    };
    if args.len() != arity {
        return Err(format!(
            "{name}() takes {arity} argument(s), {} given",
            args.len()
        ));
    }
    let x: Vec<f64> = args
        .into_iter()
        .map(|v| num(v, name))
        .collect::<Result<_, _>>()?;
    let domain = |ok: bool| {
        if ok {
            Ok(())
        } else {
            Err(format!("{name}({}) is outside its domain", x[0]))
        }
    };
    let r = match f {
        "radians" => x[0].to_radians(),
        "degrees" => x[0].to_degrees(),
        "sin" => x[0].sin(),
        "cos" => x[0].cos(),
        "tan" => x[0].tan(),
        "asin" => {
            domain(x[0].abs() <= 1.0)?;
            x[0].asin()
        }
        "acos" => {
            domain(x[0].abs() <= 1.0)?;
            x[0].acos()
        }
        "atan" => x[0].atan(),
        "atan2" => x[0].atan2(x[1]),
        "sqrt" => {
            domain(x[0] >= 0.0)?;
            x[0].sqrt()
        }
        "abs" | "fabs" => x[0].abs(),
        "floor" => x[0].floor(),
        "ceil" => x[0].ceil(),
        "round" => x[0].round(),
        "int" => x[0].trunc(),
        "float" => x[0],
        "pow" => {
            if x[0] == 0.0 && x[1] < 0.0 {
                return Err("division by zero (0 to a negative power)".into());
            }
            x[0].powf(x[1])
        }
        "min" => x.iter().copied().fold(f64::INFINITY, f64::min),
        _ => x.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    };
    finite(r, &format!("{name}()"))
}

#[cfg(test)]
mod tests;
