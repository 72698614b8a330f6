//! A xacro expander for the subset ROS-Industrial support packages use, so that a `.xacro` file
//! imports without ROS: the expansion is URDF text that [`super::urdf::parse`] then reads.
//!
//! Supported: `include` (relative paths, `$(find pkg)`), `property` (a value, or simple block
//! content), `macro` with plain, default (`a:=1`), outer-scope (`a:=^`, `a:=^|1`) and block
//! (`*b`, `**b`) parameters, macro calls, `insert_block`, `arg` with `$(arg name)`, `if`,
//! `unless`, `${...}` expressions ([`expr`]) and `$(find pkg)`, `$(arg name)`, `$(dirname)`
//! inside attribute values and text. Anything else in the xacro namespace is refused, naming the
//! construct, the file and the line ([`ImportError::Xacro`]).
//!
//! `$(find pkg)` is resolved from the caller's package map first, then by walking up from the
//! including file's directory: a directory named `pkg` (or whose `package.xml` says
//! `<name>pkg</name>`) holding a `package.xml`, the directory itself or one of its children.
//!
//! Hostile input is bounded: every file goes through the description size cap and roxmltree's
//! DTD refusal, includes nest at most [`MAX_INCLUDE_DEPTH`] deep and never in a cycle, macro
//! calls nest at most [`MAX_MACRO_DEPTH`] deep, and the expansion stops with an error past
//! [`MAX_OUTPUT_BYTES`] of output or [`MAX_STEPS`] steps of work.
//!
//! Over 600 lines: the directives share one scope stack, one set of limits and one error
//! location; the expression language lives apart in [`expr`].

pub mod expr;

use super::ImportError;
use expr::{Names, Value};
use std::collections::{BTreeMap, HashMap};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// The xacro namespace.
pub const XACRO_NS: &str = "http://www.ros.org/wiki/xacro";
/// Deepest include nesting.
pub const MAX_INCLUDE_DEPTH: usize = 32;
/// Deepest macro call nesting.
pub const MAX_MACRO_DEPTH: usize = 64;
/// Largest expansion (bytes of names, attributes and text), and largest string value.
pub const MAX_OUTPUT_BYTES: usize = 16 << 20;
/// Deepest nesting of elements as the expansion walks them (XML nesting, includes, macro
/// bodies and conditionals together), and of properties defined through other properties.
pub const MAX_NESTING: usize = 256;
/// Most elements, expressions and property look-ups one expansion may process.
pub const MAX_STEPS: usize = 10_000_000;
/// What one output element counts towards [`MAX_OUTPUT_BYTES`] besides its text: its tags and
/// its share of the expander's memory.
const ELEMENT_OVERHEAD: usize = 64;
/// Largest `package.xml` read while looking for a package by its `<name>`.
const PACKAGE_XML_LIMIT: u64 = 1 << 20;

/// A source element, owned (macros outlive the document they were defined in).
#[derive(Debug)]
struct El {
    /// Local name; `xacro` is true when it is in the xacro namespace.
    name: String,
    xacro: bool,
    attrs: Vec<(String, String)>,
    children: Vec<Node>,
    at: At,
}

#[derive(Debug)]
enum Node {
    El(Rc<El>),
    Text(String),
}

/// File and 1-based line of a source element.
type At = (Rc<str>, usize);

/// An expanded element.
#[derive(Clone, Debug)]
enum Out {
    El {
        name: String,
        attrs: Vec<(String, String)>,
        children: Vec<Out>,
        at: At,
    },
    Text(String, At),
}

/// A property: its raw text until an expression needs it, then its value.
#[derive(Clone, Debug)]
enum Prop {
    Raw(String, At),
    Resolving,
    Done(Value),
    Block(Rc<Vec<Out>>),
}

struct Param {
    name: String,
    /// 0 plain, 1 `*block`, 2 `**block`.
    stars: usize,
    /// `^`: the caller's property of the same name.
    outer: bool,
    default: Option<String>,
}

struct Macro {
    params: Vec<Param>,
    body: Rc<El>,
}

/// The expanded URDF text of a xacro file, and for each line of it the source file and line it
/// came from.
#[derive(Debug, Clone)]
pub struct Expanded {
    /// URDF text.
    pub text: String,
    /// `origins[k]` is the (file, line) of output line k + 1.
    pub origins: Vec<(String, usize)>,
}

struct Expander<'a> {
    scopes: Vec<HashMap<String, Prop>>,
    macros: HashMap<String, Rc<Macro>>,
    args: BTreeMap<String, String>,
    overrides: &'a BTreeMap<String, String>,
    packages: &'a BTreeMap<String, PathBuf>,
    includes: Vec<PathBuf>,
    macro_depth: usize,
    /// Current element and property nesting (bounded by [`MAX_NESTING`]: the walk recurses).
    nesting: usize,
    bytes: usize,
    steps: usize,
    at: At,
}

/// Expands the xacro file `path` (named as given in errors) with the caller's package
/// directories and `name:=value` argument overrides.
///
/// # Errors
///
/// [`ImportError::Read`] for a file that cannot be read or is too large,
/// [`ImportError::Syntax`] for malformed XML (or a DTD), and [`ImportError::Xacro`] for an
/// unsupported construct or a failed expansion (undefined property, include cycle, unknown
/// package, division by zero, recursion, size), naming the file and line.
pub fn expand_file(
    path: &Path,
    packages: &BTreeMap<String, PathBuf>,
    args: &BTreeMap<String, String>,
) -> Result<Expanded, ImportError> {
    let mut x = Expander {
        scopes: vec![HashMap::new()],
        macros: HashMap::new(),
        args: BTreeMap::new(),
        overrides: args,
        packages,
        includes: Vec::new(),
        macro_depth: 0,
        nesting: 0,
        bytes: 0,
        steps: 0,
        at: (Rc::from(path.display().to_string()), 1),
    };
    let root = Rc::new(x.load(path, &path.display().to_string())?);
    if let Ok(canon) = std::fs::canonicalize(path) {
        x.includes.push(canon);
    }
    if root.xacro {
        return Err(x.err_at(
            &root.at,
            format!("the root element <xacro:{}> must be <robot>", root.name),
        ));
    }
    let out = x.element(&root)?;
    let mut e = Expanded {
        text: String::new(),
        origins: Vec::new(),
    };
    e.text.push_str("<?xml version=\"1.0\"?>\n");
    e.origins.push((root.at.0.to_string(), 1));
    for o in &out {
        write_out(o, 0, &mut e);
    }
    Ok(e)
}

fn escape(s: &str, out: &mut String) {
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\n' => out.push_str("&#10;"),
            '\r' => out.push_str("&#13;"),
            '\t' => out.push_str("&#9;"),
            c => out.push(c),
        }
    }
}

/// One element or text per line, so that each output line maps to one source line.
fn write_out(o: &Out, indent: usize, e: &mut Expanded) {
    let pad = "  ".repeat(indent.min(64));
    match o {
        Out::Text(t, at) => {
            e.text.push_str(&pad);
            escape(t.trim(), &mut e.text);
            e.text.push('\n');
            e.origins.push((at.0.to_string(), at.1));
        }
        Out::El {
            name,
            attrs,
            children,
            at,
        } => {
            e.text.push_str(&pad);
            e.text.push('<');
            e.text.push_str(name);
            for (k, v) in attrs {
                let _ = write!(e.text, " {k}=\"");
                escape(v, &mut e.text);
                e.text.push('"');
            }
            let origin = (at.0.to_string(), at.1);
            if children.is_empty() {
                e.text.push_str("/>\n");
                e.origins.push(origin);
                return;
            }
            e.text.push_str(">\n");
            e.origins.push(origin.clone());
            for c in children {
                write_out(c, indent + 1, e);
            }
            let _ = writeln!(e.text, "{pad}</{name}>");
            e.origins.push(origin);
        }
    }
}

fn is_xacro_ns(ns: Option<&str>) -> bool {
    ns.is_some_and(|ns| {
        let ns = ns.trim_end_matches('/');
        ns == XACRO_NS
            || ns == "http://ros.org/wiki/xacro"
            || ns == "https://www.ros.org/wiki/xacro"
    })
}

fn convert(n: roxmltree::Node, doc: &roxmltree::Document, file: &Rc<str>) -> El {
    let at = (file.clone(), doc.text_pos_at(n.range().start).row as usize);
    let children = n
        .children()
        .filter_map(|c| {
            if c.is_element() {
                Some(Node::El(Rc::new(convert(c, doc, file))))
            } else if c.is_text() {
                c.text().map(|t| Node::Text(t.to_string()))
            } else {
                None
            }
        })
        .collect();
    El {
        name: n.tag_name().name().to_string(),
        xacro: is_xacro_ns(n.tag_name().namespace()),
        // xacro-namespace attributes on other elements are xacro's own; they do not reach the
        // URDF.
        attrs: n
            .attributes()
            .filter(|a| !is_xacro_ns(a.namespace()) || is_xacro_ns(n.tag_name().namespace()))
            .map(|a| (a.name().to_string(), a.value().to_string()))
            .collect(),
        children,
        at,
    }
}

fn attr<'e>(el: &'e El, name: &str) -> Option<&'e str> {
    el.attrs
        .iter()
        .find(|(k, _)| k == name)
        .map(|(_, v)| v.as_str())
}

impl Names for Expander<'_> {
    fn lookup(&mut self, name: &str) -> Result<Option<Value>, String> {
        let top = self.scopes.len();
        self.resolve(name, top)
    }
}

impl Expander<'_> {
    fn err_at(&self, at: &At, what: String) -> ImportError {
        ImportError::Xacro {
            path: at.0.to_string(),
            line: at.1,
            what,
        }
    }

    fn err(&self, what: impl Into<String>) -> ImportError {
        self.err_at(&self.at, what.into())
    }

    fn step(&mut self) -> Result<(), ImportError> {
        self.steps += 1;
        if self.steps > MAX_STEPS {
            return Err(self.err(format!(
                "the expansion takes more than {MAX_STEPS} steps (a runaway macro?)"
            )));
        }
        Ok(())
    }

    fn grow(&mut self, n: usize) -> Result<(), ImportError> {
        self.bytes += n;
        if self.bytes > MAX_OUTPUT_BYTES {
            return Err(self.err(format!(
                "the expansion is larger than {} MiB",
                MAX_OUTPUT_BYTES >> 20
            )));
        }
        Ok(())
    }

    /// Reads and parses one file (the size cap, no DTD) into an owned tree.
    fn load(&mut self, path: &Path, shown: &str) -> Result<El, ImportError> {
        let text = crate::input::read_text(
            path,
            crate::input::DESCRIPTION_FILE_LIMIT,
            "robot description",
        )?;
        self.grow(text.len() / 16)?;
        let doc = roxmltree::Document::parse(&text).map_err(|e| ImportError::Syntax {
            path: shown.into(),
            line: e.pos().row as usize,
            message: format!("malformed XML: {e}"),
        })?;
        let file: Rc<str> = Rc::from(shown);
        Ok(convert(doc.root_element(), &doc, &file))
    }

    /// The property `name` visible in scopes `0..upto`, evaluated on first use.
    fn resolve(&mut self, name: &str, upto: usize) -> Result<Option<Value>, String> {
        self.steps += 1;
        if self.steps > MAX_STEPS {
            return Err(format!(
                "more than {MAX_STEPS} steps (a runaway expression?)"
            ));
        }
        let Some(k) = (0..upto).rev().find(|&k| self.scopes[k].contains_key(name)) else {
            return Ok(None);
        };
        match self.scopes[k][name].clone() {
            Prop::Done(v) => Ok(Some(v)),
            Prop::Block(_) => Err(format!(
                "'{name}' is a block, not a value (use insert_block)"
            )),
            Prop::Resolving => Err(format!("property '{name}' is defined in terms of itself")),
            Prop::Raw(raw, at) => {
                if self.nesting >= MAX_NESTING {
                    return Err(format!(
                        "properties defined through other properties nest deeper than {MAX_NESTING}"
                    ));
                }
                self.scopes[k].insert(name.into(), Prop::Resolving);
                let saved = std::mem::replace(&mut self.at, at);
                self.nesting += 1;
                let v = self.text_value(&raw, k + 1);
                self.nesting -= 1;
                self.at = saved;
                let v = match v {
                    Ok(v) => v,
                    Err(ImportError::Xacro { what, .. }) if what.starts_with("in property") => {
                        return Err(what)
                    }
                    Err(ImportError::Xacro { path, line, what }) => {
                        return Err(format!("in property '{name}' ({path}:{line}): {what}"))
                    }
                    Err(e) => return Err(e.to_string()),
                };
                self.scopes[k].insert(name.into(), Prop::Done(v.clone()));
                Ok(Some(v))
            }
        }
    }

    /// The value of an attribute or text: `${...}`, `$(...)` and plain text; one `${...}` alone
    /// keeps its value's type, anything else is text. Properties come from scopes `0..upto`.
    fn text_value(&mut self, s: &str, upto: usize) -> Result<Value, ImportError> {
        if !s.contains('$') {
            return Ok(Value::Str(s.to_string()));
        }
        let mut out = String::new();
        let mut single = None;
        let mut rest = s;
        let mut pieces = 0;
        while !rest.is_empty() {
            pieces += 1;
            if let Some(r) = rest
                .strip_prefix("$${")
                .or_else(|| rest.strip_prefix("$$("))
            {
                out.push_str(&rest[1..3]);
                rest = r;
            } else if let Some(r) = rest.strip_prefix("${") {
                let end = close(r, '}')
                    .ok_or_else(|| self.err(format!("unterminated '${{' in '{s}'")))?;
                let src = &r[..end];
                let v = self.expr_in(src, upto)?;
                let _ = write!(out, "{v}");
                single = Some(v);
                rest = &r[end + 1..];
            } else if let Some(r) = rest.strip_prefix("$(") {
                let end =
                    close(r, ')').ok_or_else(|| self.err(format!("unterminated '$(' in '{s}'")))?;
                let v = self.substitution(&r[..end])?;
                out.push_str(&v);
                rest = &r[end + 1..];
            } else {
                let next = rest
                    .char_indices()
                    .skip(1)
                    .find(|&(_, c)| c == '$')
                    .map_or(rest.len(), |(k, _)| k);
                out.push_str(&rest[..next]);
                rest = &rest[next..];
            }
            if out.len() > MAX_OUTPUT_BYTES {
                return Err(self.err(format!(
                    "a value is longer than {} MiB",
                    MAX_OUTPUT_BYTES >> 20
                )));
            }
        }
        match single {
            Some(v) if pieces == 1 => Ok(v),
            _ => Ok(Value::Str(out)),
        }
    }

    fn expr_in(&mut self, src: &str, upto: usize) -> Result<Value, ImportError> {
        self.step()?;
        struct Limited<'b, 'a> {
            x: &'b mut Expander<'a>,
            upto: usize,
        }
        impl Names for Limited<'_, '_> {
            fn lookup(&mut self, name: &str) -> Result<Option<Value>, String> {
                self.x.resolve(name, self.upto)
            }
        }
        let mut l = Limited { x: self, upto };
        expr::eval(src, &mut l).map_err(|m| {
            if m.starts_with("in property") {
                self.err(m)
            } else {
                self.err(format!("{m} in '${{{src}}}'"))
            }
        })
    }

    /// `$(find pkg)`, `$(arg name)`, `$(dirname)`.
    fn substitution(&mut self, inner: &str) -> Result<String, ImportError> {
        let mut words = inner.split_whitespace();
        let cmd = words.next().unwrap_or("");
        let arg1 = words.next();
        let extra = words.next().is_some();
        match (cmd, arg1, extra) {
            ("find", Some(pkg), false) => self.find(pkg),
            ("arg", Some(name), false) => self.args.get(name).cloned().ok_or_else(|| {
                self.err(format!(
                    "undefined arg '{name}' (declare it with <xacro:arg name=\"{name}\" default=\"...\"/> or pass {name}:=VALUE)"
                ))
            }),
            ("dirname", None, false) => Ok(Path::new(&*self.at.0)
                .parent()
                .map(|p| p.display().to_string())
                .unwrap_or_default()),
            _ => Err(self.err(format!(
                "unsupported substitution '$({inner})' (supported: $(find PKG), $(arg NAME), $(dirname))"
            ))),
        }
    }

    /// The directory of package `pkg`: the caller's map, else a directory named `pkg` (or whose
    /// package.xml names it) with a package.xml, found walking up from the current file.
    fn find(&mut self, pkg: &str) -> Result<String, ImportError> {
        if let Some(d) = self.packages.get(pkg) {
            return Ok(d.display().to_string());
        }
        let here = Path::new(&*self.at.0).parent().map(Path::to_path_buf);
        let start = here
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or_else(|| PathBuf::from("."));
        let start = std::fs::canonicalize(&start).unwrap_or(start);
        let is_pkg = |d: &Path| d.join("package.xml").is_file();
        for dir in start.ancestors() {
            if dir.file_name().is_some_and(|n| n == pkg) && is_pkg(dir) {
                return Ok(dir.display().to_string());
            }
            if is_pkg(&dir.join(pkg)) {
                return Ok(dir.join(pkg).display().to_string());
            }
        }
        // By the <name> in package.xml: the current package and its siblings.
        for dir in start.ancestors() {
            if package_name(dir).as_deref() == Some(pkg) {
                return Ok(dir.display().to_string());
            }
            let Ok(rd) = std::fs::read_dir(dir) else {
                continue;
            };
            for entry in rd.flatten().take(10_000) {
                let p = entry.path();
                if p.is_dir() && package_name(&p).as_deref() == Some(pkg) {
                    return Ok(p.display().to_string());
                }
            }
        }
        Err(self.err(format!(
            "package '{pkg}' not found: no directory holding a package.xml for it above this file; map it to its directory (NAME=DIR)"
        )))
    }

    /// Expands one source element into zero or more output elements.
    fn element(&mut self, el: &Rc<El>) -> Result<Vec<Out>, ImportError> {
        self.step()?;
        self.at = el.at.clone();
        if self.nesting >= MAX_NESTING {
            return Err(self.err(format!(
                "elements nest deeper than {MAX_NESTING} (counting includes, macro bodies and conditionals)"
            )));
        }
        self.nesting += 1;
        let out = self.element_in(el);
        self.nesting -= 1;
        out
    }

    fn element_in(&mut self, el: &Rc<El>) -> Result<Vec<Out>, ImportError> {
        if el.xacro {
            return self.directive(el);
        }
        let mut attrs = Vec::with_capacity(el.attrs.len());
        for (k, v) in &el.attrs {
            let v = self.text_value(v, self.scopes.len())?.to_string();
            self.grow(k.len() + v.len() + 4)?;
            attrs.push((k.clone(), v));
        }
        self.grow(el.name.len() * 2 + ELEMENT_OVERHEAD)?;
        let children = self.children(&el.children)?;
        Ok(vec![Out::El {
            name: el.name.clone(),
            attrs,
            children,
            at: el.at.clone(),
        }])
    }

    fn children(&mut self, nodes: &[Node]) -> Result<Vec<Out>, ImportError> {
        let mut out = Vec::new();
        for n in nodes {
            match n {
                Node::El(e) => out.extend(self.element(e)?),
                Node::Text(t) if !t.trim().is_empty() => {
                    let v = self.text_value(t, self.scopes.len())?.to_string();
                    self.grow(v.len())?;
                    out.push(Out::Text(v, self.at.clone()));
                }
                Node::Text(_) => {}
            }
        }
        Ok(out)
    }

    fn allow(&self, el: &El, names: &[&str]) -> Result<(), ImportError> {
        match el.attrs.iter().find(|(k, _)| !names.contains(&k.as_str())) {
            Some((k, _)) => Err(self.err_at(
                &el.at,
                format!("<xacro:{}> attribute '{k}' is not supported", el.name),
            )),
            None => Ok(()),
        }
    }

    fn need<'e>(&self, el: &'e El, name: &str) -> Result<&'e str, ImportError> {
        attr(el, name).ok_or_else(|| {
            self.err_at(
                &el.at,
                format!("<xacro:{}> needs a '{name}' attribute", el.name),
            )
        })
    }

    fn string(&mut self, s: &str) -> Result<String, ImportError> {
        Ok(self.text_value(s, self.scopes.len())?.to_string())
    }

    fn directive(&mut self, el: &Rc<El>) -> Result<Vec<Out>, ImportError> {
        match el.name.as_str() {
            "include" => {
                self.allow(el, &["filename"])?;
                let f = self.need(el, "filename")?;
                let f = self.string(f)?;
                self.include(&f, el)
            }
            "property" => {
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
            "macro" => {
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
            "insert_block" => {
                self.allow(el, &["name"])?;
                let name = self.need(el, "name")?;
                let top = self.scopes.len();
                let Some(k) = (0..top).rev().find(|&k| self.scopes[k].contains_key(name)) else {
                    return Err(self.err(format!("<xacro:insert_block>: no block named '{name}'")));
                };
                let Prop::Block(b) = self.scopes[k][name].clone() else {
                    return Err(self.err(format!("<xacro:insert_block>: '{name}' is a value, not a block")));
                };
                self.grow(b.len() * 16)?;
                for o in b.iter() {
                    self.grow(out_size(o))?;
                }
                Ok(b.as_ref().clone())
            }
            other => match self.macros.get(other).cloned() {
                Some(m) => self.call(other, &m, el),
                None => Err(self.err(format!(
                    "<xacro:{other}> is not supported (supported: include, property, macro and its calls, insert_block, arg, if, unless)"
                ))),
            },
        }
    }

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

    fn call(&mut self, name: &str, m: &Macro, el: &El) -> Result<Vec<Out>, ImportError> {
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

fn out_size(o: &Out) -> usize {
    match o {
        Out::Text(t, _) => t.len(),
        Out::El {
            name,
            attrs,
            children,
            ..
        } => {
            name.len() * 2
                + ELEMENT_OVERHEAD
                + attrs
                    .iter()
                    .map(|(k, v)| k.len() + v.len() + 4)
                    .sum::<usize>()
                + children.iter().map(out_size).sum::<usize>()
        }
    }
}

/// The end of a `${...}`/`$(...)` body: the first `close` outside quotes.
fn close(s: &str, close: char) -> Option<usize> {
    let mut quote = None;
    for (k, c) in s.char_indices() {
        match quote {
            Some(q) if c == q => quote = None,
            Some(_) => {}
            None if c == '\'' || c == '"' => quote = Some(c),
            None if c == close => return Some(k),
            None => {}
        }
    }
    None
}

/// The `<package><name>` of the package.xml in `dir`, if any.
fn package_name(dir: &Path) -> Option<String> {
    let p = dir.join("package.xml");
    if !p.is_file() {
        return None;
    }
    let text = crate::input::read_text(&p, PACKAGE_XML_LIMIT, "package.xml").ok()?;
    let start = text.find("<name>")? + "<name>".len();
    let end = text[start..].find("</name>")?;
    Some(text[start..start + end].trim().to_string())
}

/// `a b:=1 c:=^ d:=^|2 *e **f` (also the old `b=1`), quoted defaults allowed.
fn parse_params(s: &str) -> Result<Vec<Param>, String> {
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
