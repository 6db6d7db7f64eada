//! Project automation tasks, run as `cargo xtask <task>` (see `main.rs`). Each task is a
//! module with a `run(args)` entry point; tasks that produce committed files also expose
//! what they produce, so that tests can prove the committed files are current.

pub mod bench;
pub mod figures;
pub mod fixtures;

use std::path::PathBuf;

/// The workspace root (the parent of this crate's directory).
pub fn workspace_root() -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    dir.parent().map_or(dir.clone(), PathBuf::from)
}
