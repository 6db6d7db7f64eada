//! What `flakescatter.dask.analyze_many` needs of the facade's `analyze`, beside the
//! `flakescatter analyze` runs its workers make: each manifest's sample name (the
//! report's folder) and the comparison across samples built from the reports'
//! `summary.json` (`comparison_row`), as the CLI's batch writes it.

use std::path::PathBuf;

use flakescatter::analyze::{Manifest, SampleRow, comparison_report, default_name};
use pyo3::prelude::*;

use crate::errors::input;

/// The sample name of the manifest `path`: its `name` key, else its file name without
/// `.toml` made safe (`flakescatter analyze`'s rule). A manifest that cannot be read or
/// parsed gets the file's name (its `analyze` run then reports why).
#[pyfunction]
pub fn _sample_name(path: PathBuf) -> String {
    flakescatter::io::files::read_text(&path)
        .ok()
        .and_then(|t| Manifest::from_toml(&t, &path.display().to_string()).ok())
        .and_then(|m| m.name)
        .unwrap_or_else(|| default_name(&path))
}

/// The comparison of samples from their `summary.json` `comparison_row` values (JSON
/// texts, in the order of the table): `(samples.csv, index.md, index.html)`.
#[pyfunction]
pub fn _comparison_table(py: Python<'_>, rows: Vec<String>) -> PyResult<(String, String, String)> {
    let rows = rows
        .iter()
        .enumerate()
        .map(|(k, t)| {
            serde_json::from_str::<SampleRow>(t).map_err(|e| {
                input(
                    py,
                    format!("rows[{k}]: not a summary.json `comparison_row`: {e}"),
                )
            })
        })
        .collect::<PyResult<Vec<_>>>()?;
    let (csv, doc) = comparison_report(&rows);
    let html = doc.to_html("Samples compared", &|_| None);
    Ok((csv, doc.to_markdown(), html))
}
