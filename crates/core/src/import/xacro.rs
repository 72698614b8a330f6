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
//! [`MAX_OUTPUT_BYTES`] of output or [`MAX_STEPS`] steps of work.//!
//! The expander's scopes, limits and error locations are here; the source trees in `source`,
//! the output and its text in `output`, the directives in `directives`, macros and their calls in
//! `macros`, and the expression language in [`expr`].

mod directives;
pub mod expr;
mod macros;
mod output;
mod source;

use super::ImportError;
use expr::{Names, Value};
use macros::Macro;
use output::{write_out, Out};
use source::{attr, convert, At, El, Node};
use std::collections::{BTreeMap, HashMap};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// The xacro namespaces in use: the ROS wiki's address before and after it moved
/// (ROS-Industrial and Universal Robots packages mostly bind `xacro:` to `http://wiki.ros.org/xacro`,
/// older files to `http://www.ros.org/wiki/xacro`), each also as `https://`. A trailing `/` is
/// ignored. The one list every check of the namespace uses ([`is_xacro_namespace`]).
pub const XACRO_NAMESPACES: [&str; 6] = [
    "http://www.ros.org/wiki/xacro",
    "http://ros.org/wiki/xacro",
    "http://wiki.ros.org/xacro",
    "https://www.ros.org/wiki/xacro",
    "https://ros.org/wiki/xacro",
    "https://wiki.ros.org/xacro",
];

/// Whether `ns` is one of the [`XACRO_NAMESPACES`] (a trailing `/` ignored).
#[must_use]
pub fn is_xacro_namespace(ns: &str) -> bool {
    XACRO_NAMESPACES.contains(&ns.strip_suffix('/').unwrap_or(ns))
}
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

/// A property: its raw text until an expression needs it, then its value.
#[derive(Clone, Debug)]
enum Prop {
    Raw(String, At),
    Resolving,
    Done(Value),
    Block(Rc<Vec<Out>>),
}

/// The expanded URDF text of a xacro file, and for each line of it the source file and line it
/// came from.
#[derive(Debug, Clone)]
pub struct Expanded {
    /// URDF text.
    pub text: String,
    /// `origins[k]` is the (file, line) of output line k + 1.
    pub origins: Vec<(String, usize)>,
    /// Every file the expansion read (the given file, each included file, each package.xml
    /// looked into), canonical, each once: the files an output must not overwrite.
    pub files: Vec<PathBuf>,
}

struct Expander<'a> {
    scopes: Vec<HashMap<String, Prop>>,
    macros: HashMap<String, Rc<Macro>>,
    args: BTreeMap<String, String>,
    overrides: &'a BTreeMap<String, String>,
    packages: &'a BTreeMap<String, PathBuf>,
    includes: Vec<PathBuf>,
    /// Every file read so far, canonical ([`Expanded::files`]).
    read: Vec<PathBuf>,
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
        read: Vec::new(),
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
        files: std::mem::take(&mut x.read),
    };
    e.text.push_str("<?xml version=\"1.0\"?>\n");
    e.origins.push((root.at.0.to_string(), 1));
    for o in &out {
        write_out(o, 0, &mut e);
    }
    Ok(e)
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
        note_read(&mut self.read, path);
        self.grow(text.len() / 16)?;
        let text = super::xml::leading_declaration_blanked(&text);
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
            if package_name(dir, &mut self.read).as_deref() == Some(pkg) {
                return Ok(dir.display().to_string());
            }
            let Ok(rd) = std::fs::read_dir(dir) else {
                continue;
            };
            for entry in rd.flatten().take(10_000) {
                let p = entry.path();
                if p.is_dir() && package_name(&p, &mut self.read).as_deref() == Some(pkg) {
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

/// Records the file `path` as read (canonical, once).
fn note_read(read: &mut Vec<PathBuf>, path: &Path) {
    if let Ok(c) = std::fs::canonicalize(path) {
        if !read.contains(&c) {
            read.push(c);
        }
    }
}

/// The `<package><name>` of the package.xml in `dir`, if any (the file recorded in `read`).
fn package_name(dir: &Path, read: &mut Vec<PathBuf>) -> Option<String> {
    let p = dir.join("package.xml");
    if !p.is_file() {
        return None;
    }
    let text = crate::input::read_text(&p, PACKAGE_XML_LIMIT, "package.xml").ok()?;
    note_read(read, &p);
    let start = text.find("<name>")? + "<name>".len();
    let end = text[start..].find("</name>")?;
    Some(text[start..start + end].trim().to_string())
}
