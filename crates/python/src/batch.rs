//! What `flakescatter.dask.analyze_many` needs of the facade's `analyze`, beside the
//! `flakescatter analyze` runs its workers make: each manifest's sample name (the
//! report's folder) and the comparison across samples built from the reports'
//! `summary.json` (`comparison_row`), as the CLI's batch writes it.

use std::path::PathBuf;

use flakescatter::analyze::{
    Manifest, SampleRow, check_sample_names, comparison_report, default_name,
};
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

/// Refuses sample names that cannot each have their own folder of a batch's directory
/// (`names` and their manifests `files`, in order; `reserved`: the batch's own files):
/// `InputError` naming the manifests and names, as `flakescatter analyze` does.
#[pyfunction]
pub fn _check_sample_names(
    py: Python<'_>,
    names: Vec<String>,
    files: Vec<PathBuf>,
    reserved: Vec<String>,
) -> PyResult<()> {
    let pairs: Vec<(&str, &std::path::Path)> = names
        .iter()
        .map(String::as_str)
        .zip(files.iter().map(PathBuf::as_path))
        .collect();
    let reserved: Vec<&str> = reserved.iter().map(String::as_str).collect();
    check_sample_names(&pairs, &reserved).map_err(|e| input(py, e))
}
