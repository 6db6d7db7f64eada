//! A scratch directory for the files another program reads and writes on the command's
//! behalf (`analyze` hands Python a MERL table and gets a PNG back): created empty in
//! the system's temporary directory, removed with everything in it when dropped.

use std::path::{Path, PathBuf};

use anyhow::Context;

/// A temporary directory and the files put in it.
pub struct Scratch {
    dir: tempfile::TempDir,
}

impl Scratch {
    /// An empty scratch directory.
    pub fn new() -> anyhow::Result<Self> {
        Ok(Self {
            dir: tempfile::tempdir().context("creating a temporary directory")?,
        })
    }

    /// The path of `name` in it (the file need not exist).
    pub fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    /// Writes `name` with what `body` writes; its path.
    pub fn write(
        &self,
        name: &str,
        body: impl FnOnce(&mut dyn std::io::Write) -> std::io::Result<()>,
    ) -> anyhow::Result<PathBuf> {
        let p = self.path(name);
        let mut f = std::io::BufWriter::new(
            std::fs::File::create(&p).with_context(|| format!("writing {}", p.display()))?,
        );
        body(&mut f)
            .and_then(|()| std::io::Write::flush(&mut f))
            .with_context(|| format!("writing {}", p.display()))?;
        Ok(p)
    }

    /// The bytes of `name`.
    pub fn read(&self, name: &str) -> anyhow::Result<Vec<u8>> {
        read_bytes(&self.path(name))
    }
}

/// The bytes of a file (e.g. a previous report's picture).
pub fn read_bytes(path: &Path) -> anyhow::Result<Vec<u8>> {
    std::fs::read(path).with_context(|| format!("reading {}", path.display()))
}
