//! The content checksum of a shard file: SHA-256 of the file's JSON object as written, appended
//! as its last field (`"content_sha256"`), and verified before anything else is read, so that
//! an edited digit or a truncated copy is refused instead of merging into a silently different
//! result.
//!
//! The checksum covers the exact bytes of the object without the field (`{…}`), not a
//! re-serialisation, so no float has to survive a parse and a print to verify.

use super::SummaryError;
use crate::digest::sha256_hex;

/// Name of the checksum field.
pub const FIELD: &str = "content_sha256";

/// `object` (one JSON object, `{…}`, no trailing newline) with its checksum appended as the last
/// field, and a newline.
pub fn seal(object: &str) -> String {
    let hash = sha256_hex(object.as_bytes());
    let body = object
        .strip_suffix('}')
        .expect("a JSON object ends with '}'");
    let sep = if body.trim_end().ends_with('{') {
        ""
    } else {
        ","
    };
    format!("{body}{sep}\"{FIELD}\":\"{hash}\"}}\n")
}

/// The object of a sealed `text` after checking its checksum; `file` names it in errors.
///
/// # Errors
///
/// [`SummaryError::Corrupt`] when the text does not end with the checksum field ("no content
/// checksum") or the checksum does not match ("content checksum mismatch (edited or
/// corrupted)").
pub fn verify(text: &str, file: &str) -> Result<String, SummaryError> {
    let corrupt = |message: &str| SummaryError::Corrupt {
        file: file.to_string(),
        message: message.to_string(),
    };
    let t = text.trim_end();
    let marker = format!("\"{FIELD}\":\"");
    let Some(at) = t.rfind(&marker) else {
        return Err(corrupt(
            "no content checksum (the file was not written by this version's shard writer, \
             or was edited)",
        ));
    };
    let tail = &t[at + marker.len()..];
    let hash = tail.strip_suffix("\"}").filter(|h| {
        h.len() == 64
            && h.bytes()
                .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b))
    });
    let Some(hash) = hash else {
        return Err(corrupt("content checksum mismatch (edited or corrupted)"));
    };
    let body = t[..at].trim_end();
    let object = match body.strip_suffix(',') {
        Some(b) => format!("{b}}}"),
        None => format!("{body}}}"),
    };
    if sha256_hex(object.as_bytes()) != hash {
        return Err(corrupt("content checksum mismatch (edited or corrupted)"));
    }
    Ok(object)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sealed_text_verifies_and_every_edit_is_caught() {
        let object = r#"{"a":1,"b":[0.5,2e-3],"c":"x"}"#;
        let sealed = seal(object);
        assert!(sealed.ends_with("\"}\n"));
        assert_eq!(verify(&sealed, "f").unwrap(), object);
        // Every one-byte change of the sealed text apart from its trailing newline.
        let bytes = sealed.trim_end().as_bytes();
        for i in 0..bytes.len() {
            let mut b = bytes.to_vec();
            b[i] = if b[i] == b'7' { b'8' } else { b'7' };
            let t = String::from_utf8(b).unwrap();
            let e = verify(&t, "f").unwrap_err().to_string();
            assert!(e.starts_with("f: not a summary:"), "{i}: {e}");
        }
        // Truncated, or without the field.
        assert!(verify(&sealed[..sealed.len() / 2], "f").is_err());
        let e = verify(object, "f").unwrap_err().to_string();
        assert!(e.contains("no content checksum"), "{e}");
        assert_eq!(
            seal("{}"),
            format!("{{\"{FIELD}\":\"{}\"}}\n", sha256_hex(b"{}"))
        );
        assert_eq!(verify(&seal("{}"), "f").unwrap(), "{}");
    }
}
