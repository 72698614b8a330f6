//! The output methods every result class shares, written once over the library's
//! [`Report`] of the result: `to_json()` (the command line's `--json` document), `to_dict()`,
//! `to_text()` (what it prints), `to_csv(table)` and `to_pandas(table)` (the files `--csv`
//! writes), `to_svg(figure)` (the files `--svg` writes) and `files()` (every file of the report
//! directory by name). A result class implements [`PyReport`] and declares its Python methods
//! with [`report_class!`], which adds the shared ones; so a new analysis's Python result is its
//! `Report` plus the getters of its own.

use crate::errors::value_error;
use gpu_amcs_core::report::Report;
use pyo3::prelude::*;

/// A Python result class over a library report.
pub trait PyReport {
    /// The library's report of the result.
    fn report(&self) -> &dyn Report;

    /// The CSV file `to_csv()` gives without a table name; `None`: the report's first.
    fn default_table(&self) -> Option<&'static str> {
        None
    }

    /// A table `to_pandas(table)` gives that is not one of the report's CSV files (`None`: not
    /// such a table).
    fn extra_frame<'py>(
        &self,
        _py: Python<'py>,
        _table: &str,
    ) -> Option<PyResult<Bound<'py, PyAny>>> {
        None
    }
}

/// The file `name` (with or without its extension `ext`) of `files`, the first without a name;
/// an error naming the keyword `what` and the names there are.
pub fn pick(
    files: Vec<(String, String)>,
    name: Option<&str>,
    what: &str,
    ext: &str,
) -> PyResult<String> {
    let stem = |n: &str| n.trim_end_matches(ext).to_string();
    let known: Vec<String> = files.iter().map(|(n, _)| stem(n)).collect();
    let found = match name {
        None => files.into_iter().next(),
        Some(want) => files.into_iter().find(|(n, _)| stem(n) == stem(want)),
    };
    found.map(|(_, text)| text).ok_or_else(|| match name {
        Some(want) => value_error(format!(
            "{what}: unknown {what} '{want}' (this report has \"{}\")",
            known.join("\", \"")
        )),
        None => value_error(format!("{what}: this report has none")),
    })
}

/// `#[pymethods]` of a result class that implements [`PyReport`]: the methods given, then the
/// shared output methods (see the module docs). `text` adds `to_text()` too (a class whose
/// `to_text` takes arguments writes its own).
#[macro_export]
macro_rules! report_class {
    ($ty:ty, text, { $($extra:tt)* }) => {
        $crate::report_class!($ty, { $($extra)*
            /// The text the command line prints.
            fn to_text(&self) -> String {
                $crate::reports::PyReport::report(self).text()
            }
        });
    };
    ($ty:ty, { $($extra:tt)* }) => {
        #[pyo3::pymethods]
        impl $ty {
            $($extra)*

            /// The JSON document the command line writes with `--json` (same fields, same
            /// values).
            fn to_json(&self) -> String {
                $crate::reports::PyReport::report(self).json()
            }

            /// `to_json()` parsed: a dict of plain Python values.
            fn to_dict<'py>(
                &self,
                py: pyo3::Python<'py>,
            ) -> pyo3::PyResult<pyo3::Bound<'py, pyo3::PyAny>> {
                $crate::analyses::parse_json(py, self.to_json())
            }

            /// A CSV file the command line writes with `--csv`, by name (`table`, with or
            /// without `.csv`; the result's main table when not given).
            #[pyo3(signature = (table = None))]
            fn to_csv(&self, table: Option<&str>) -> pyo3::PyResult<String> {
                let r = $crate::reports::PyReport::report(self);
                let table = table.or($crate::reports::PyReport::default_table(self));
                $crate::reports::pick(r.csv(), table, "table", ".csv")
            }

            /// `to_csv(table)` as a pandas DataFrame (needs pandas).
            #[pyo3(signature = (table = None))]
            fn to_pandas<'py>(
                &self,
                py: pyo3::Python<'py>,
                table: Option<&str>,
            ) -> pyo3::PyResult<pyo3::Bound<'py, pyo3::PyAny>> {
                if let Some(t) = table {
                    if let Some(f) = $crate::reports::PyReport::extra_frame(self, py, t) {
                        return f;
                    }
                }
                $crate::analyses::frame(py, self.to_csv(table)?)
            }

            /// An SVG figure the command line writes with `--svg`, by name (`figure`, with or
            /// without `.svg`; the first when not given).
            #[pyo3(signature = (figure = None))]
            fn to_svg(&self, figure: Option<&str>) -> pyo3::PyResult<String> {
                let r = $crate::reports::PyReport::report(self);
                $crate::reports::pick(r.svg(), figure, "figure", ".svg")
            }

            /// Every file of the report directory but the HTML page, by name (the JSON
            /// document, the CSV tables, the SVG figures), as the command line writes them.
            fn files(&self) -> std::collections::BTreeMap<String, String> {
                $crate::reports::PyReport::report(self)
                    .files()
                    .into_iter()
                    .collect()
            }
        }
    };
}
