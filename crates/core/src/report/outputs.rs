//! One report abstraction: what an analysis writes, said once.
//!
//! Every analysis — a run ([`RunReport`](super::RunReport)), a comparison
//! ([`Comparison`](super::Comparison)), Sobol indices, tail probabilities, a workspace map, an
//! identification, the factor study — implements [`Report`]: the text for the terminal, one JSON
//! document, its CSV tables and SVG figures by file name, any other files (Markdown), and the
//! HTML page that shows them. A front end writes whichever parts it is asked for through the
//! one trait, so adding an analysis adds no list of names anywhere else.
//!
//! The names are known before the analysis runs: each report type has a `planned_layout`
//! function (what fixes the names — the number of layers of a map, the factors of a study — is
//! its argument), and [`Report::layout`] of the finished report is that same layout, so a front
//! end can check every place it will write before any work.
//!
//! ```
//! use gpu_amcs_core::report::{Layout, Report, INDEX};
//! struct Hello;
//! impl Report for Hello {
//!     fn layout(&self) -> Layout {
//!         Layout::new("hello.json", &["hello.csv"], &[], &[])
//!     }
//!     fn text(&self) -> String {
//!         "hello\n".into()
//!     }
//!     fn json(&self) -> String {
//!         "{\"hello\": 1}\n".into()
//!     }
//!     fn csv(&self) -> Vec<(String, String)> {
//!         vec![("hello.csv".into(), "hello\n1\n".into())]
//!     }
//!     fn svg(&self) -> Vec<(String, String)> {
//!         Vec::new()
//!     }
//!     fn page(&self, _settings: &[(String, String)], _files: &[(String, String)]) -> String {
//!         "<!DOCTYPE html><title>hello</title>".into()
//!     }
//! }
//! let names: Vec<String> = Hello.html(&[]).into_iter().map(|(n, _)| n).collect();
//! assert_eq!(names, ["hello.json", "hello.csv", INDEX]);
//! assert_eq!(Hello.layout().html(), names);
//! ```

/// Name of the page in a report directory.
pub const INDEX: &str = "index.html";

/// The names of the files a report writes, by part.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Layout {
    /// Name of the JSON document in a report directory (`report.json`, `map.json`, …).
    pub json: String,
    /// The CSV files it may write.
    pub csv: Vec<String>,
    /// The SVG figures it may write.
    pub svg: Vec<String>,
    /// Its other files (Markdown).
    pub other: Vec<String>,
}

impl Layout {
    /// A layout from its parts' names.
    pub fn new(json: &str, csv: &[&str], svg: &[&str], other: &[&str]) -> Layout {
        let owned = |v: &[&str]| v.iter().map(|s| s.to_string()).collect();
        Layout {
            json: json.to_string(),
            csv: owned(csv),
            svg: owned(svg),
            other: owned(other),
        }
    }

    /// Every file but the page, in the order of [`Report::files`]: the JSON document, the other
    /// files, the CSV tables, the SVG figures.
    pub fn files(&self) -> Vec<String> {
        std::iter::once(self.json.clone())
            .chain(self.other.iter().cloned())
            .chain(self.csv.iter().cloned())
            .chain(self.svg.iter().cloned())
            .collect()
    }

    /// Every file of the HTML report directory: [`Layout::files`], then [`INDEX`].
    pub fn html(&self) -> Vec<String> {
        let mut v = self.files();
        v.push(INDEX.to_string());
        v
    }
}

/// What an analysis writes. Each part is a pure function of the finished report; a front end
/// decides which parts to write and where (the library names no option of any front end).
pub trait Report {
    /// The names of the files, equal to the report type's `planned_layout` for this report
    /// (every name [`Report::csv`], [`Report::svg`] and [`Report::other`] return is in it; a
    /// name in it may be missing from a report, e.g. the AMCS trace of an MCS run).
    fn layout(&self) -> Layout;

    /// The text for the terminal.
    fn text(&self) -> String;

    /// The JSON document.
    fn json(&self) -> String;

    /// The CSV tables: `(file name, contents)`.
    fn csv(&self) -> Vec<(String, String)>;

    /// The SVG figures: `(file name, contents)`.
    fn svg(&self) -> Vec<(String, String)>;

    /// Other files of the report directory (Markdown): `(file name, contents)`.
    fn other(&self) -> Vec<(String, String)> {
        Vec::new()
    }

    /// The HTML page, linking `files` (the other files of its directory, as
    /// [`Report::files`] gives them); `settings` are rows of the model-and-settings table that
    /// only the caller knows (where the model came from).
    fn page(&self, settings: &[(String, String)], files: &[(String, String)]) -> String;

    /// Every file but the page: the JSON document (named by [`Layout::json`]), the other files,
    /// the CSV tables and the SVG figures.
    fn files(&self) -> Vec<(String, String)> {
        let mut files = vec![(self.layout().json, self.json())];
        files.extend(self.other());
        files.extend(self.csv());
        files.extend(self.svg());
        files
    }

    /// Every file of the HTML report directory: [`Report::files`], then the page as
    /// [`INDEX`]; `settings` as for [`Report::page`].
    fn html(&self, settings: &[(String, String)]) -> Vec<(String, String)> {
        let mut files = self.files();
        let page = self.page(settings, &files);
        files.push((INDEX.to_string(), page));
        files
    }
}
