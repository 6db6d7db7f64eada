//! A batch of samples in one output directory: `DIR/<name>/` per sample (each an owned
//! report directory, swapped in when that sample is complete) and the comparison
//! across samples (`samples.csv`, `index.md`, `index.html`, `previews.png`) written when the whole
//! batch is. The directory's marker (`output::owned`) lists the comparison files and
//! the sample folders, so a rerun recognises it and nothing else in it is touched.
//!
//! Order of the writes: before the first sample is swapped in, the previous batch's
//! comparison files are removed (a half-finished batch then never shows a comparison
//! of other runs' samples); each sample folder is swapped in when complete (an
//! interrupted batch keeps the samples it finished, and a rerun reuses their caches);
//! at the end the comparison is written and the sample folders of the previous batch
//! that this batch does not hold are removed, so the folder holds exactly this batch.

use std::path::Path;

use anyhow::bail;

use super::OWNER;
use crate::output::batch::Batch;
use crate::output::owned::MARKER;

/// The owner recorded in a batch directory's marker.
pub const BATCH_OWNER: &str = "analyze (batch)";

/// The batch's own files in its directory (`previews.png` when previews are rendered).
pub const COMPARISON_FILES: [&str; 4] = ["samples.csv", "index.md", "index.html", "previews.png"];

/// Takes the batch directory `dir` (checked by the plan: missing, empty, or an earlier
/// batch holding nothing else) for this run's samples.
pub fn open(dir: &Path) -> anyhow::Result<Batch> {
    Batch::open(dir, BATCH_OWNER, &COMPARISON_FILES, OWNER)
}

/// Refuses sample names that cannot each have their own folder in a batch directory:
/// two equal names (also ignoring case: one folder on case-insensitive file systems,
/// macOS and Windows) and names of the batch's own files. Called before any work.
pub fn check_names(names: &[(&str, &Path)]) -> anyhow::Result<()> {
    for (k, (name, file)) in names.iter().enumerate() {
        let lower = name.to_lowercase();
        if let Some(own) = COMPARISON_FILES
            .iter()
            .chain(std::iter::once(&MARKER))
            .find(|f| f.to_lowercase() == lower)
        {
            bail!(
                "sample {} is named `{name}`, the name of the batch's own file `{own}` in --out: give it another `name`",
                file.display()
            );
        }
        if let Some((other, ofile)) = names[..k].iter().find(|(o, _)| o.to_lowercase() == lower) {
            if other == name {
                bail!(
                    "samples {} and {} are both named `{name}`: give one of them another `name`",
                    ofile.display(),
                    file.display(),
                );
            }
            bail!(
                "samples {} and {} are named `{other}` and `{name}`, one folder on file systems that ignore case (macOS, Windows): give one of them another `name`",
                ofile.display(),
                file.display(),
            );
        }
    }
    Ok(())
}
