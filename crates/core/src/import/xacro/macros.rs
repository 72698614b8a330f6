//! xacro macros: their parameter lists and their calls, each in a scope of its own.

use super::output::Out;
use super::source::{attr, El, Node};
use super::{Expander, Prop, MAX_MACRO_DEPTH};
use crate::import::ImportError;
use std::collections::HashMap;
use std::rc::Rc;

/// A parameter of a macro.
pub(super) struct Param {
    pub(super) name: String,
    /// 0 plain, 1 `*block`, 2 `**block`.
    pub(super) stars: usize,
    /// `^`: the caller's property of the same name.
    pub(super) outer: bool,
    pub(super) default: Option<String>,
}

/// A macro: its parameters and its body.
pub(super) struct Macro {
    pub(super) params: Vec<Param>,
    pub(super) body: Rc<El>,
}

impl Expander<'_> {
    /// Expands the call `el` of the macro `name` (`m`): its parameters from the call's
    /// attributes and elements, the outer scope and the defaults, then its body in that scope.
    pub(super) fn call(&mut self, name: &str, m: &Macro, el: &El) -> Result<Vec<Out>, ImportError> {
        if self.macro_depth >= MAX_MACRO_DEPTH {
            return Err(self.err(format!(
                "macro calls nest deeper than {MAX_MACRO_DEPTH} (a recursive macro '{name}'?)"
            )));
        }
        for (k, _) in &el.attrs {
            if !m.params.iter().any(|p| p.stars == 0 && &p.name == k) {
                return Err(self.err(format!("macro '{name}' has no parameter '{k}'")));
            }
        }
        let mut blocks = el.children.iter().filter_map(|c| match c {
            Node::El(e) => Some(e.clone()),
            Node::Text(_) => None,
        });
        let mut scope = HashMap::new();
        let upto = self.scopes.len();
        for p in &m.params {
            let prop = if p.stars > 0 {
                let Some(b) = blocks.next() else {
                    return Err(self.err(format!(
                        "macro '{name}': no element given for block parameter '{}'",
                        p.name
                    )));
                };
                let out = if p.stars == 1 {
                    self.element(&b)?
                } else {
                    self.children(&b.children)?
                };
                self.at = el.at.clone();
                Prop::Block(Rc::new(out))
            } else if let Some(v) = attr(el, &p.name) {
                Prop::Done(self.text_value(v, upto)?)
            } else {
                let outer = if p.outer {
                    self.resolve(&p.name, upto).map_err(|m| self.err(m))?
                } else {
                    None
                };
                match (outer, &p.default) {
                    (Some(v), _) => Prop::Done(v),
                    (None, Some(d)) => Prop::Done(self.text_value(d, upto)?),
                    (None, None) => {
                        return Err(self.err(format!(
                            "macro '{name}': parameter '{}' is not given and has no default",
                            p.name
                        )))
                    }
                }
            };
            scope.insert(p.name.clone(), prop);
        }
        if blocks.next().is_some() {
            return Err(self.err(format!(
                "macro '{name}' is given more elements than it has block parameters"
            )));
        }
        self.scopes.push(scope);
        self.macro_depth += 1;
        let out = self.children(&m.body.children);
        self.macro_depth -= 1;
        self.scopes.pop();
        self.at = el.at.clone();
        out
    }
}

/// `a b:=1 c:=^ d:=^|2 *e **f` (also the old `b=1`), quoted defaults allowed.
pub(super) fn parse_params(s: &str) -> Result<Vec<Param>, String> {
    let mut out: Vec<Param> = Vec::new();
    let mut rest = s.trim_start();
    while !rest.is_empty() {
        // One token: up to whitespace outside quotes.
        let mut quote = None;
        let mut end = rest.len();
        for (k, c) in rest.char_indices() {
            match quote {
                Some(q) if c == q => quote = None,
                Some(_) => {}
                None if c == '\'' || c == '"' => quote = Some(c),
                None if c.is_whitespace() => {
                    end = k;
                    break;
                }
                None => {}
            }
        }
        let tok = &rest[..end];
        rest = rest[end..].trim_start();
        let stars = tok.len() - tok.trim_start_matches('*').len();
        if stars > 2 {
            return Err(format!("bad parameter '{tok}'"));
        }
        let body = &tok[stars..];
        let (name, default) = match body.split_once(":=").or_else(|| body.split_once('=')) {
            Some((n, d)) => (n, Some(d)),
            None => (body, None),
        };
        if name.is_empty() || !name.chars().all(|c| c.is_alphanumeric() || c == '_') {
            return Err(format!("bad parameter name '{tok}'"));
        }
        if stars > 0 && default.is_some() {
            return Err(format!("block parameter '{tok}' cannot have a default"));
        }
        let (outer, default) = match default {
            Some(d) if d.starts_with('^') => {
                let d = d[1..].strip_prefix('|').map(str::to_string);
                (true, d)
            }
            Some(d) => (false, Some(d.to_string())),
            None => (false, None),
        };
        let default = default.map(|d| {
            let t = d.as_str();
            if t.len() >= 2
                && ((t.starts_with('\'') && t.ends_with('\''))
                    || (t.starts_with('"') && t.ends_with('"')))
            {
                t[1..t.len() - 1].to_string()
            } else {
                d
            }
        });
        if out.iter().any(|p| p.name == name) {
            return Err(format!("parameter '{name}' given twice"));
        }
        out.push(Param {
            name: name.to_string(),
            stars,
            outer,
            default,
        });
    }
    Ok(out)
}
