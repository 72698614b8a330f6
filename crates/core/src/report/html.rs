//! A self-contained HTML report page: title, summary of headline numbers, tables, inline SVG
//! figures, the model and settings, and links to the files written beside it.
//!
//! The page opens from a file on an offline machine: no JavaScript, no external style sheet,
//! font, image or any other request; the style is one inline `<style>` element and the figures
//! are the SVG documents themselves, inlined. Every string is HTML-escaped, every figure is a
//! `<figure>` with a `<figcaption>` and an SVG `role="img"` labelled by its `<title>` and
//! `<desc>`, and every table has column headers (with the units in them).
//!
//! [`Page`] is the builder any report uses (a heat map is just one more [`Figure`]); [`pages`]
//! holds what the pages share, [`run`], [`comparison`], [`sensitivity`] and [`tail`] the pages of
//! those reports (the map's, the study's and the identification's live with their reports).
//!
//! ```
//! use gpu_amcs_core::report::html::{Figure, Page, Table};
//! let mut page = Page::new("Example");
//! page.summary("mean of w", "0.31 mm");
//! page.table(Table::new("Reliability", &["l_c (mm)", "R"], vec![vec!["0.5".into(), "0.9".into()]]));
//! page.figure(Figure::from_svg("a.svg", "<svg width=\"10\" height=\"10\"></svg>", "An empty plot."));
//! page.setting("seed", "1");
//! page.link("report.json", "the full report");
//! let html = page.render();
//! assert!(html.contains("<th scope=\"col\">l_c (mm)</th>") && !html.contains("<script"));
//! ```

pub mod comparison;
pub mod pages;
pub mod run;
pub mod sensitivity;
pub mod tail;

use crate::engine::BackendInfo;
use std::fmt::Write as _;

/// Escapes `s` for HTML text and quoted attribute values.
pub fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// A table: a caption, column headers (units in them, e.g. `"l_c (mm)"`) and rows of cells.
#[derive(Clone, Debug)]
pub struct Table {
    /// What the table shows.
    pub caption: String,
    /// Column headers.
    pub header: Vec<String>,
    /// Rows of cells (the first cell of a row is its row header).
    pub rows: Vec<Vec<String>>,
}

impl Table {
    /// A table from its caption, column headers and rows.
    pub fn new(caption: &str, header: &[&str], rows: Vec<Vec<String>>) -> Table {
        Table {
            caption: caption.to_string(),
            header: header.iter().map(|h| h.to_string()).collect(),
            rows,
        }
    }
}

/// An SVG figure with its title and text alternative.
#[derive(Clone, Debug)]
pub struct Figure {
    /// The SVG file written beside the page, if any (linked from the caption).
    pub file: Option<String>,
    /// Title (the SVG's `<title>` and the start of the caption).
    pub title: String,
    /// Text alternative: what the figure shows, in words and numbers (the SVG's `<desc>`).
    pub description: String,
    /// The SVG document (an XML declaration before the root is dropped when inlined).
    pub svg: String,
}

impl Figure {
    /// A figure from the SVG written as `file`, titled by the SVG's heading (its first `<text>`
    /// element, as the plots of [`crate::report::svg`] draw it), else by the file name.
    pub fn from_svg(file: &str, svg: &str, description: &str) -> Figure {
        Figure {
            file: Some(file.to_string()),
            title: svg_heading(svg).unwrap_or_else(|| file.to_string()),
            description: description.to_string(),
            svg: svg.to_string(),
        }
    }
}

/// The text of the first `<text>` element of `svg`, unescaped.
pub fn svg_heading(svg: &str) -> Option<String> {
    let start = svg.find("<text")?;
    let rest = &svg[start..];
    let open = rest.find('>')? + 1;
    let close = rest[open..].find("</text>")?;
    let t = rest[open..open + close].trim();
    (!t.is_empty() && !t.contains('<')).then(|| {
        t.replace("&lt;", "<")
            .replace("&gt;", ">")
            .replace("&quot;", "\"")
            .replace("&#39;", "'")
            .replace("&amp;", "&")
    })
}

/// One part of the page body, in order.
#[derive(Clone, Debug)]
enum Block {
    Heading(String),
    Paragraph(String),
    Table(Table),
    Figure(Figure),
}

/// The page builder.
#[derive(Clone, Debug, Default)]
pub struct Page {
    title: String,
    summary: Vec<(String, String)>,
    notes: Vec<String>,
    blocks: Vec<Block>,
    settings: Vec<(String, String)>,
    links: Vec<(String, String)>,
}

/// The inline style: readable type, figures that shrink to the window, ruled tables.
const STYLE: &str = "body{font-family:sans-serif;margin:0;color:#111;background:#fff}\
main{max-width:1100px;margin:0 auto;padding:1em 1.5em}\
h1{font-size:1.6em}h2{font-size:1.25em;border-bottom:1px solid #ccc;padding-bottom:.2em;margin-top:1.6em}\
dl.summary{display:flex;flex-wrap:wrap;gap:.6em}\
dl.summary div{border:1px solid #ccc;border-radius:4px;padding:.4em .8em;background:#f6f8fa}\
dl.summary dt{font-size:.85em;color:#444}dl.summary dd{margin:0;font-size:1.15em;font-weight:bold}\
table{border-collapse:collapse;margin:.6em 0 1.2em}caption{text-align:left;font-weight:bold;padding:.3em 0}\
th,td{border:1px solid #ccc;padding:.25em .6em;text-align:right}\
th{background:#eef1f4}tbody th{text-align:left;font-weight:normal}\
figure{margin:1em 0}svg{max-width:100%;height:auto;border:1px solid #ddd}\
figcaption{font-size:.9em;color:#333;max-width:720px}\
.notes li{color:#7a4b00}footer{margin-top:2em;font-size:.85em;color:#555}";

impl Page {
    /// An empty page titled `title`.
    pub fn new(title: &str) -> Page {
        Page {
            title: title.to_string(),
            ..Page::default()
        }
    }

    /// Adds a headline number to the summary; `value` carries its unit (`"0.312 mm"`).
    pub fn summary(&mut self, label: &str, value: &str) -> &mut Page {
        self.summary.push((label.to_string(), value.to_string()));
        self
    }

    /// Adds a note for the reader (shown under the summary).
    pub fn note(&mut self, text: &str) -> &mut Page {
        self.notes.push(text.to_string());
        self
    }

    /// Starts a new section of the body.
    pub fn heading(&mut self, text: &str) -> &mut Page {
        self.blocks.push(Block::Heading(text.to_string()));
        self
    }

    /// Adds a paragraph of text.
    pub fn paragraph(&mut self, text: &str) -> &mut Page {
        self.blocks.push(Block::Paragraph(text.to_string()));
        self
    }

    /// Adds a table.
    pub fn table(&mut self, table: Table) -> &mut Page {
        self.blocks.push(Block::Table(table));
        self
    }

    /// Adds a figure.
    pub fn figure(&mut self, figure: Figure) -> &mut Page {
        self.blocks.push(Block::Figure(figure));
        self
    }

    /// Adds a row to the model-and-settings table.
    pub fn setting(&mut self, name: &str, value: &str) -> &mut Page {
        self.settings.push((name.to_string(), value.to_string()));
        self
    }

    /// Adds the backend, adapter and driver rows to the model-and-settings table.
    pub fn backend(&mut self, b: &BackendInfo) -> &mut Page {
        self.setting("backend", &b.backend)
            .setting("adapter", &b.adapter)
            .setting("driver", &b.driver)
    }

    /// Links a file written beside the page (a plain file name, linked relatively).
    pub fn link(&mut self, file: &str, description: &str) -> &mut Page {
        self.links.push((file.to_string(), description.to_string()));
        self
    }

    /// The page as one HTML document.
    pub fn render(&self) -> String {
        let mut s = String::new();
        let title = escape(&self.title);
        let _ = write!(
            s,
            "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
             <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
             <title>{title}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<main>\n\
             <h1>{title}</h1>\n"
        );
        if !self.summary.is_empty() {
            s.push_str("<section aria-labelledby=\"summary\">\n<h2 id=\"summary\">Summary</h2>\n<dl class=\"summary\">\n");
            for (label, value) in &self.summary {
                let _ = writeln!(
                    s,
                    "<div><dt>{}</dt><dd>{}</dd></div>",
                    escape(label),
                    escape(value)
                );
            }
            s.push_str("</dl>\n</section>\n");
        }
        if !self.notes.is_empty() {
            s.push_str("<ul class=\"notes\">\n");
            for n in &self.notes {
                let _ = writeln!(s, "<li>{}</li>", escape(n));
            }
            s.push_str("</ul>\n");
        }
        let mut figures = 0;
        for b in &self.blocks {
            match b {
                Block::Heading(t) => {
                    let _ = writeln!(s, "<h2>{}</h2>", escape(t));
                }
                Block::Paragraph(t) => {
                    let _ = writeln!(s, "<p>{}</p>", escape(t));
                }
                Block::Table(t) => render_table(&mut s, t, false),
                Block::Figure(f) => {
                    figures += 1;
                    render_figure(&mut s, f, figures);
                }
            }
        }
        if !self.settings.is_empty() {
            s.push_str("<h2>Model and settings</h2>\n");
            let mut rows: Vec<Vec<String>> = self
                .settings
                .iter()
                .map(|(n, v)| vec![n.clone(), v.clone()])
                .collect();
            rows.push(vec![
                "gpu-amcs version".into(),
                env!("CARGO_PKG_VERSION").into(),
            ]);
            let t = Table::new("Model and settings of the run", &["setting", "value"], rows);
            render_table(&mut s, &t, true);
        }
        if !self.links.is_empty() {
            s.push_str("<h2>Files</h2>\n<p>Written beside this page:</p>\n<ul>\n");
            for (file, what) in &self.links {
                let _ = writeln!(
                    s,
                    "<li><a href=\"{}\">{}</a>: {}</li>",
                    escape(&relative_href(file)),
                    escape(file),
                    escape(what)
                );
            }
            s.push_str("</ul>\n");
        }
        let _ = write!(
            s,
            "<footer>Written by gpu-amcs {}. This page is self-contained: it loads nothing.</footer>\n\
             </main>\n</body>\n</html>\n",
            env!("CARGO_PKG_VERSION")
        );
        s
    }
}

/// A relative link to a plain file name: `./NAME`, so a name with a colon is never a scheme,
/// with the characters a URL path cannot hold percent-encoded.
fn relative_href(file: &str) -> String {
    let mut out = String::from("./");
    for b in file.bytes() {
        if b.is_ascii_alphanumeric() || b"-_.~".contains(&b) {
            out.push(b as char);
        } else {
            let _ = write!(out, "%{b:02X}");
        }
    }
    out
}

fn render_table(s: &mut String, t: &Table, left: bool) {
    let style = if left { " class=\"settings\"" } else { "" };
    let _ = writeln!(
        s,
        "<table{style}>\n<caption>{}</caption>",
        escape(&t.caption)
    );
    s.push_str("<thead><tr>");
    for h in &t.header {
        let _ = write!(s, "<th scope=\"col\">{}</th>", escape(h));
    }
    s.push_str("</tr></thead>\n<tbody>\n");
    for row in &t.rows {
        s.push_str("<tr>");
        for (i, c) in row.iter().enumerate() {
            if i == 0 {
                let _ = write!(s, "<th scope=\"row\">{}</th>", escape(c));
            } else {
                let _ = write!(s, "<td>{}</td>", escape(c));
            }
        }
        s.push_str("</tr>\n");
    }
    s.push_str("</tbody>\n</table>\n");
}

/// The figure's SVG made fit to inline: no XML declaration or namespace attribute (HTML puts
/// `<svg>` in the SVG namespace itself), its ids prefixed with `prefix` so that several figures
/// on one page cannot clash, `role="img"` labelled by the title and described by the
/// description, which open the element.
fn inline_svg(f: &Figure, prefix: &str) -> String {
    let mut svg = f.svg.trim();
    while svg.starts_with("<?") || svg.starts_with("<!") {
        svg = svg.find('>').map_or("", |i| svg[i + 1..].trim_start());
    }
    let svg = svg
        .replace(" xmlns=\"http://www.w3.org/2000/svg\"", "")
        .replace(" xmlns:xlink=\"http://www.w3.org/1999/xlink\"", "")
        .replace(" id=\"", &format!(" id=\"{prefix}-"))
        .replace("url(#", &format!("url(#{prefix}-"))
        .replace("href=\"#", &format!("href=\"#{prefix}-"));
    let title = format!(
        "<title id=\"{prefix}-title\">{}</title><desc id=\"{prefix}-desc\">{}</desc>",
        escape(&f.title),
        escape(&f.description)
    );
    let attrs = format!(
        " role=\"img\" aria-labelledby=\"{prefix}-title\" aria-describedby=\"{prefix}-desc\""
    );
    match (svg.find("<svg"), svg.find('>')) {
        (Some(0), Some(end)) => {
            let (open, rest) = svg.split_at(end);
            let (open, slash) = match open.strip_suffix('/') {
                Some(o) => (o, true),
                None => (open, false),
            };
            let body = if slash {
                format!(">{title}</svg>{}", &rest[1..])
            } else {
                format!(">{title}{}", &rest[1..])
            };
            format!("<svg{attrs}{}{body}", &open[4..])
        }
        // Not an SVG document: shown as text rather than inlined.
        _ => format!("<pre>{}</pre>", escape(&svg)),
    }
}

fn render_figure(s: &mut String, f: &Figure, n: usize) {
    let prefix = format!("fig{n}");
    let _ = writeln!(s, "<figure id=\"{prefix}\">\n{}", inline_svg(f, &prefix));
    let _ = write!(
        s,
        "<figcaption><strong>Figure {n}. {}</strong> {}",
        escape(&f.title),
        escape(&f.description)
    );
    if let Some(file) = &f.file {
        let _ = write!(
            s,
            " (<a href=\"{}\">{}</a>)",
            escape(&relative_href(file)),
            escape(file)
        );
    }
    s.push_str("</figcaption>\n</figure>\n");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn user_strings_are_escaped_everywhere() {
        let evil = "<script>alert('x')</script> & \"q\"";
        let mut p = Page::new(evil);
        p.summary(evil, evil)
            .note(evil)
            .heading(evil)
            .paragraph(evil)
            .table(Table::new(evil, &[evil], vec![vec![evil.into()]]))
            .figure(Figure {
                file: Some(evil.into()),
                title: evil.into(),
                description: evil.into(),
                svg: "<svg width=\"1\" height=\"1\"></svg>".into(),
            })
            .setting(evil, evil)
            .link(evil, evil);
        let html = p.render();
        assert!(!html.contains("<script"), "{html}");
        assert!(!html.contains("'x'"), "{html}");
        assert!(
            html.contains("&lt;script&gt;alert(&#39;x&#39;)&lt;/script&gt; &amp; &quot;q&quot;")
        );
        // The link is relative and percent-encoded: no markup, no scheme.
        assert!(
            html.contains("href=\"./%3Cscript%3Ealert%28%27x%27%29"),
            "{html}"
        );
    }

    #[test]
    fn svg_is_inlined_with_title_description_and_own_ids() {
        let svg = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"20\" height=\"10\"><pattern id=\"hatch\"/><rect fill=\"url(#hatch)\"/><text x=\"1\">A &amp; B</text></svg>\n";
        let f = Figure::from_svg("a.svg", svg, "two rectangles");
        assert_eq!(f.title, "A & B");
        let mut p = Page::new("t");
        p.figure(f.clone()).figure(f);
        let html = p.render();
        assert!(!html.contains("<?xml") && !html.contains("http"), "{html}");
        assert_eq!(
            html.matches("<svg role=\"img\" aria-labelledby=\"fig")
                .count(),
            2
        );
        assert!(html.contains("<title id=\"fig2-title\">A &amp; B</title><desc id=\"fig2-desc\">two rectangles</desc>"));
        assert!(html.contains("id=\"fig1-hatch\"") && html.contains("url(#fig2-hatch)"));
        assert!(html.contains("<figcaption><strong>Figure 2. A &amp; B</strong> two rectangles (<a href=\"./a.svg\">a.svg</a>)"));
        // A self-closing root gets its title inside.
        let f = Figure::from_svg("b.svg", "<svg width=\"1\"/>", "nothing");
        assert_eq!(f.title, "b.svg");
        let mut p = Page::new("t");
        p.figure(f);
        assert!(p.render().contains("<svg role=\"img\" aria-labelledby=\"fig1-title\" aria-describedby=\"fig1-desc\" width=\"1\"><title id=\"fig1-title\">b.svg</title>"));
    }

    #[test]
    fn settings_end_with_the_version_and_tables_have_headers() {
        let mut p = Page::new("t");
        p.setting("seed", "7").table(Table::new(
            "R",
            &["l_c (mm)", "R"],
            vec![vec!["0.5".into(), "1".into()]],
        ));
        let html = p.render();
        assert!(html.contains("<th scope=\"col\">l_c (mm)</th><th scope=\"col\">R</th>"));
        assert!(html.contains("<tr><th scope=\"row\">0.5</th><td>1</td></tr>"));
        assert!(html.contains(&format!(
            "<tr><th scope=\"row\">gpu-amcs version</th><td>{}</td></tr>",
            env!("CARGO_PKG_VERSION")
        )));
        assert!(html.find("seed").unwrap() < html.find("gpu-amcs version").unwrap());
    }
}
