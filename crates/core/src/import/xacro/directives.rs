//! The xacro directives (`include`, `property`, `arg`, `if`, `unless`, `macro`, `insert_block`
//! and macro calls) as the expander meets them.

use super::macros::{parse_params, Macro};
use super::output::{out_size, Out};
use super::source::{attr, El, Node};
use super::{Expander, Prop, MAX_INCLUDE_DEPTH};
use crate::import::ImportError;
use std::path::{Path, PathBuf};
use std::rc::Rc;

impl Expander<'_> {
    /// Expands the xacro-namespace element `el`: a directive, or a call of a macro defined
    /// before.
    pub(super) fn directive(&mut self, el: &Rc<El>) -> Result<Vec<Out>, ImportError> {
        match el.name.as_str() {
            "include" => {
                self.allow(el, &["filename"])?;
                let f = self.need(el, "filename")?;
                let f = self.string(f)?;
                self.include(&f, el)
            }
            "property" => self.property(el),
            "arg" => {
                self.allow(el, &["name", "default"])?;
                let name = self.need(el, "name")?.to_string();
                if let Some(v) = self.overrides.get(&name) {
                    self.args.insert(name, v.clone());
                } else if !self.args.contains_key(&name) {
                    let d = self.need(el, "default")?;
                    let d = self.string(d)?;
                    self.args.insert(name, d);
                }
                Ok(Vec::new())
            }
            "if" | "unless" => {
                self.allow(el, &["value"])?;
                let v = self.need(el, "value")?;
                let v = self.text_value(v, self.scopes.len())?;
                let t = v.truth().map_err(|m| {
                    self.err_at(&el.at, format!("<xacro:{} value>: {m}", el.name))
                })?;
                if t == (el.name == "if") {
                    self.children(&el.children)
                } else {
                    Ok(Vec::new())
                }
            }
            "macro" => self.define_macro(el),
            "insert_block" => self.insert_block(el),
            other => match self.macros.get(other).cloned() {
                Some(m) => self.call(other, &m, el),
                None => Err(self.err(format!(
                    "<xacro:{other}> is not supported (supported: include, property, macro and its calls, insert_block, arg, if, unless)"
                ))),
            },
        }
    }

    /// Expands the file `f` included by `el` (relative to `el`'s file), refusing cycles and
    /// includes nested too deep.
    fn include(&mut self, f: &str, el: &El) -> Result<Vec<Out>, ImportError> {
        let base = Path::new(&*el.at.0).parent().unwrap_or(Path::new(""));
        let p = if Path::new(f).is_absolute() {
            PathBuf::from(f)
        } else {
            base.join(f)
        };
        let canon = std::fs::canonicalize(&p)
            .map_err(|e| self.err_at(&el.at, format!("cannot include '{}': {e}", p.display())))?;
        if self.includes.contains(&canon) {
            return Err(self.err_at(
                &el.at,
                format!(
                    "include cycle: '{}' includes itself (directly or through others)",
                    p.display()
                ),
            ));
        }
        if self.includes.len() > MAX_INCLUDE_DEPTH {
            return Err(self.err_at(
                &el.at,
                format!("includes nest deeper than {MAX_INCLUDE_DEPTH}"),
            ));
        }
        let root = Rc::new(self.load(&p, &p.display().to_string())?);
        self.includes.push(canon);
        let out = self.children(&root.children);
        self.includes.pop();
        self.at = el.at.clone();
        out
    }

    /// `<xacro:property>`: a value (raw until an expression needs it; a `default` only where
    /// the scope has none yet) or a block, defined in the innermost scope.
    fn property(&mut self, el: &El) -> Result<Vec<Out>, ImportError> {
        self.allow(el, &["name", "value", "default"])?;
        let name = self.need(el, "name")?.to_string();
        let top = self.scopes.len() - 1;
        let prop = if let Some(v) = attr(el, "value").or_else(|| attr(el, "default")) {
            if attr(el, "value").is_none() && self.scopes[top].contains_key(&name) {
                return Ok(Vec::new());
            }
            Prop::Raw(v.to_string(), el.at.clone())
        } else if el.children.iter().any(|c| matches!(c, Node::El(_))) {
            let block = self.children(&el.children)?;
            Prop::Block(Rc::new(block))
        } else {
            return Err(self.err_at(
                &el.at,
                format!("<xacro:property name=\"{name}\"> has neither a value nor block content"),
            ));
        };
        self.scopes[top].insert(name, prop);
        Ok(Vec::new())
    }

    /// `<xacro:macro>`: the macro `name` with its parameters and its body `el`.
    fn define_macro(&mut self, el: &Rc<El>) -> Result<Vec<Out>, ImportError> {
        self.allow(el, &["name", "params"])?;
        let name = self.need(el, "name")?.to_string();
        let params = parse_params(attr(el, "params").unwrap_or(""))
            .map_err(|m| self.err_at(&el.at, format!("macro '{name}': {m}")))?;
        self.macros.insert(
            name,
            Rc::new(Macro {
                params,
                body: el.clone(),
            }),
        );
        Ok(Vec::new())
    }

    /// `<xacro:insert_block>`: the block `name` of the innermost scope that has one.
    fn insert_block(&mut self, el: &El) -> Result<Vec<Out>, ImportError> {
        self.allow(el, &["name"])?;
        let name = self.need(el, "name")?;
        let top = self.scopes.len();
        let Some(k) = (0..top).rev().find(|&k| self.scopes[k].contains_key(name)) else {
            return Err(self.err(format!("<xacro:insert_block>: no block named '{name}'")));
        };
        let Prop::Block(b) = self.scopes[k][name].clone() else {
            return Err(self.err(format!(
                "<xacro:insert_block>: '{name}' is a value, not a block"
            )));
        };
        self.grow(b.len() * 16)?;
        for o in b.iter() {
            self.grow(out_size(o))?;
        }
        Ok(b.as_ref().clone())
    }
}
