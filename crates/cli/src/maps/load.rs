//! Loading what was collected: every map source read through the facade (stacks
//! localised, progress for stacks).

use flakescatter::inputs::{LoadError, LoadOptions, LoadedMap, MapSource, SourceKind, load_map};

/// A map as read, with the file it came from.
pub struct Input {
    /// The files.
    pub source: MapSource,
    /// The map and how it was read.
    pub loaded: LoadedMap,
}

/// Reads every source (progress on stderr for stacks when it is a terminal); errors
/// name the file.
pub fn load_all(sources: &[MapSource], options: &LoadOptions) -> anyhow::Result<Vec<Input>> {
    let mut out = Vec::with_capacity(sources.len());
    for s in sources {
        let bar = crate::output::progress::bar(
            "localising {msg} {bar:40} {pos}/{len} slices",
            s.kind == SourceKind::Stack,
        );
        if let Some(b) = &bar {
            b.set_message(s.height.display().to_string());
        }
        let progress =
            |done: u64, total: u64| crate::output::progress::show(bar.as_ref(), done, total);
        let loaded = load_map(s, options, &progress).map_err(|e| match e {
            LoadError::Cutoff {
                map,
                intensity,
                cutoff,
                source,
            } => anyhow::anyhow!(
                "{} with intensity {intensity} and --cutoff {cutoff}: {source}",
                map.display()
            ),
            e => anyhow::Error::from(e),
        })?;
        if let Some(b) = &bar {
            b.finish_and_clear();
        }
        out.push(Input {
            source: s.clone(),
            loaded,
        });
    }
    Ok(out)
}
