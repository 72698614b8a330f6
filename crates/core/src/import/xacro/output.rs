//! The output side of the expansion: expanded elements, their size towards the limit, and their
//! URDF text, one element or text per line so that each output line maps to one source line.

use super::source::At;
use super::{Expanded, ELEMENT_OVERHEAD};
use std::fmt::Write as _;

/// An expanded element.
#[derive(Clone, Debug)]
pub(super) enum Out {
    El {
        name: String,
        attrs: Vec<(String, String)>,
        children: Vec<Out>,
        at: At,
    },
    Text(String, At),
}

/// Appends `s` to `out` escaped for an XML attribute value or text.
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
pub(super) fn write_out(o: &Out, indent: usize, e: &mut Expanded) {
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

/// What the expanded element `o` counts towards [`MAX_OUTPUT_BYTES`](super::MAX_OUTPUT_BYTES).
pub(super) fn out_size(o: &Out) -> usize {
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
