//! The source side of the expansion: xacro files read into owned element trees (macros outlive
//! the document they were defined in), each element with its file and line.

use super::is_xacro_namespace;
use std::rc::Rc;

/// A source element, owned (macros outlive the document they were defined in).
#[derive(Debug)]
pub(super) struct El {
    /// Local name; `xacro` is true when it is in the xacro namespace.
    pub(super) name: String,
    pub(super) xacro: bool,
    pub(super) attrs: Vec<(String, String)>,
    pub(super) children: Vec<Node>,
    pub(super) at: At,
}

#[derive(Debug)]
pub(super) enum Node {
    El(Rc<El>),
    Text(String),
}

/// File and 1-based line of a source element.
pub(super) type At = (Rc<str>, usize);

/// Whether `ns` is a xacro namespace ([`super::XACRO_NAMESPACES`]).
fn is_xacro_ns(ns: Option<&str>) -> bool {
    ns.is_some_and(is_xacro_namespace)
}

/// The owned tree of the element `n` of `doc`, read from `file`.
pub(super) fn convert(n: roxmltree::Node, doc: &roxmltree::Document, file: &Rc<str>) -> El {
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

/// The value of the attribute `name` of `el`, if it has one.
pub(super) fn attr<'e>(el: &'e El, name: &str) -> Option<&'e str> {
    el.attrs
        .iter()
        .find(|(k, _)| k == name)
        .map(|(_, v)| v.as_str())
}
