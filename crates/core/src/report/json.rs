//! JSON output. Field names are stable and documented in the README ("JSON output").

use super::{Comparison, RunReport};

/// The document's schema version; bumped when a field changes meaning or disappears.
pub const SCHEMA_VERSION: u32 = 1;

#[derive(serde::Serialize)]
struct Doc<'a, T: serde::Serialize> {
    schema_version: u32,
    tool: &'static str,
    version: &'static str,
    #[serde(flatten)]
    body: &'a T,
}

fn render<T: serde::Serialize>(body: &T) -> String {
    let doc = Doc {
        schema_version: SCHEMA_VERSION,
        tool: "gpu-amcs",
        version: env!("CARGO_PKG_VERSION"),
        body,
    };
    // Serialising plain data with finite or NaN floats cannot fail (NaN becomes null).
    serde_json::to_string_pretty(&doc).unwrap_or_else(|e| format!("{{\"error\": \"{e}\"}}")) + "\n"
}

/// A single run.
pub fn render_run(rep: &RunReport) -> String {
    render(rep)
}

/// A comparison.
pub fn render_comparison(c: &Comparison) -> String {
    render(c)
}
