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

/// Refuses sample names that cannot each have their own folder in a batch directory
/// (`flakescatter::analyze::check_sample_names`, with the batch's own files and the
/// marker reserved). Called before any work.
pub fn check_names(names: &[(&str, &Path)]) -> anyhow::Result<()> {
    let mut reserved: Vec<&str> = COMPARISON_FILES.to_vec();
    reserved.push(MARKER);
    flakescatter::analyze::check_sample_names(names, &reserved).map_err(|e| anyhow::anyhow!(e))
}
