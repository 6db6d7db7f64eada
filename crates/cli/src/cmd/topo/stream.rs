//! The maps of a `topo` (or `stats --pixel-normals`) run: read whole into memory, or,
//! when every map is a Zarr store, opened to be read band by band while the model
//! traces them (docs/guide.md "Big maps").

use std::path::Path;

use anyhow::{Context, bail};
use flakescatter::inputs::{MapSource, SourceKind};
use flakescatter::io::ChannelSelector;
use flakescatter::io::zarr::{ZarrMap, is_store};
use flakescatter::stats::heightmap::HeightMap;
use flakescatter::streaming::{StoreCutoff, ZarrSource};
use flakescatter::topo::HeightSource;

use crate::maps::MapInputArgs;

/// The maps of a run.
pub enum Loaded {
    /// Read whole.
    Memory(Vec<HeightMap>),
    /// Zarr stores, read band by band.
    Stores(Vec<ZarrSource>),
}

impl Loaded {
    /// All pixels of all maps.
    pub fn pixels(&self) -> usize {
        match self {
            Self::Memory(maps) => maps.iter().map(HeightMap::len).sum(),
            Self::Stores(stores) => stores
                .iter()
                .map(|s| {
                    let (nx, ny) = s.size();
                    nx * ny
                })
                .sum(),
        }
    }

    /// The stores as sources (empty for maps in memory).
    pub fn sources(&self) -> Vec<&dyn HeightSource> {
        match self {
            Self::Memory(_) => Vec::new(),
            Self::Stores(stores) => stores.iter().map(|s| s as &dyn HeightSource).collect(),
        }
    }
}

/// Whether `selector` (of a Zarr store that has `height` and `intensity`) names the
/// array `name` at `index`, as the in-memory reader resolves it.
fn names(selector: &ChannelSelector, index: usize, name: &str) -> bool {
    match selector {
        ChannelSelector::Index(i) => *i == index,
        ChannelSelector::Name(n) => n.eq_ignore_ascii_case(name),
    }
}

/// The stores of `sources` opened for streaming, when every source is a Zarr store
/// that the band reader can read as the in-memory loader would: heights from the
/// `height` array (no `--pixel-um` override, no other channel) and the cutoff from
/// the store's own `intensity` array (`--intensity-channel intensity`) or a partner
/// Zarr store (`--intensity other.zarr`). `None` otherwise: the maps are then read
/// whole (and any error is the in-memory loader's). `window` is checked against each
/// store's size as the in-memory loader does.
pub fn stores(
    input: &MapInputArgs,
    sources: &[MapSource],
    window: usize,
) -> anyhow::Result<Option<Vec<ZarrSource>>> {
    let streamable = |s: &MapSource| -> bool {
        if s.kind != SourceKind::Map || !is_store(&s.height) {
            return false;
        }
        let Ok(store) = ZarrMap::open(&s.height) else {
            return false;
        };
        let height_ok = s
            .channel
            .as_ref()
            .is_none_or(|c| store.has_height() && names(c, 0, "height"));
        let intensity_ok = match (&s.intensity, &s.intensity_channel) {
            (None, None) => true,
            (None, Some(c)) => {
                store.has_height() && store.has_intensity() && names(c, 1, "intensity")
            }
            (Some(i), None) => {
                is_store(i) && flakescatter::distinct::same_data(&s.height, i).is_none()
            }
            (Some(_), Some(_)) => false,
        };
        store.has_height() && height_ok && intensity_ok
    };
    if sources.is_empty() || input.calibration.pixel_um.is_some() || !sources.iter().all(streamable)
    {
        return Ok(None);
    }
    let mut out = Vec::with_capacity(sources.len());
    for s in sources {
        let cutoff = match (input.cutoff, &s.intensity) {
            (None, _) => StoreCutoff::None,
            (Some(c), Some(i)) => StoreCutoff::Partner(i.clone(), c),
            (Some(c), None) => StoreCutoff::Own(c),
        };
        let store = ZarrSource::open(&s.height, &cutoff)
            .with_context(|| format!("height map {}", s.height.display()))?;
        let (nx, ny) = store.size();
        if window > nx.min(ny) {
            bail!(
                "--window {window}: larger than height map {} ({nx} x {ny} pixels)",
                s.height.display()
            );
        }
        out.push(store);
    }
    Ok(Some(out))
}

/// The in-memory loader's message for a map without a valid pixel, for a streamed run
/// that found one (`map` 0-based of `sources`, `pixels` its size).
pub fn no_valid_pixel(
    sources: &[MapSource],
    map: usize,
    pixels: usize,
    cutoff: Option<f64>,
) -> anyhow::Error {
    let path = sources
        .get(map)
        .map_or(Path::new("?"), |s| s.height.as_path());
    match cutoff {
        None => anyhow::anyhow!(
            "height map {}: no valid pixel (all {pixels} are NaN or masked)",
            path.display()
        ),
        Some(c) => anyhow::anyhow!(
            "height map {}: no valid pixel (all {pixels} are NaN, masked or below --cutoff {c})",
            path.display()
        ),
    }
}
