//! What the XML readers (URDF and xacro) share: the text roxmltree is given.

use std::borrow::Cow;

/// `text` with an XML declaration that only whitespace precedes (xacro-generated URDF often
/// starts with a blank line) blanked out, so that roxmltree, which wants the declaration first or
/// not at all, reads the rest. The declaration is replaced by as many spaces as it has characters, so every
/// line and column the parser reports is still the file's. The text is read as UTF-8 whatever the
/// declaration says, as it is without one; any other text is returned as it is.
pub(super) fn leading_declaration_blanked(text: &str) -> Cow<'_, str> {
    let body = text.trim_start_matches([' ', '\t', '\r', '\n']);
    let lead = text.len() - body.len();
    let is_declaration = body
        .strip_prefix("<?xml")
        .and_then(|rest| rest.chars().next())
        .is_some_and(char::is_whitespace);
    if lead == 0 || !is_declaration {
        return Cow::Borrowed(text);
    }
    let Some(end) = body.find("?>") else {
        return Cow::Borrowed(text);
    };
    let decl = &body[..end + 2];
    let blank: String = decl
        .chars()
        .map(|c| if c == '\n' || c == '\r' { c } else { ' ' })
        .collect();
    Cow::Owned(format!("{}{blank}{}", &text[..lead], &body[end + 2..]))
}
