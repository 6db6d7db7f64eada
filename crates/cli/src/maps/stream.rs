//! The maps of a run that reads them tile by tile (`topo`, `stats
//! --pixel-normals-only`): read whole into memory, or, when every map is a Zarr store,
//! opened to be read band by band while the model traces them (docs/guide.md "Big
//! maps"). One set of rules for every such command: which stores stream
//! ([`stores`]), the checks of maps read whole ([`load_whole`]), and the errors of a
//! run as the command reports them ([`run_error`]).

use std::path::Path;

use anyhow::{Context, bail};
use flakescatter::PipelineError;
use flakescatter::inputs::{MapSource, SourceKind};
use flakescatter::io::ChannelSelector;
use flakescatter::io::zarr::{ZarrMap, is_store};
use flakescatter::stats::heightmap::HeightMap;
use flakescatter::streaming::{StoreCutoff, ZarrSource};
use flakescatter::topo::HeightSource;

use crate::maps::{MapInputArgs, load_all};

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

    /// Reads `sources` for a run with a `window` × `window` least-squares window:
    /// streamed when `stream` and every map is a Zarr store the band reader can read
    /// ([`stores`]), whole otherwise ([`load_whole`]).
    ///
    /// # Errors
    /// As [`stores`] and [`load_whole`], naming the map and the flag.
    pub fn open(
        input: &MapInputArgs,
        sources: &[MapSource],
        window: usize,
        stream: bool,
    ) -> anyhow::Result<Self> {
        let stores = if stream {
            stores(input, sources, window)?
        } else {
            None
        };
        Ok(match stores {
            Some(stores) => Self::Stores(stores),
            None => Self::Memory(load_whole(input, sources, window)?),
        })
    }

    /// The maps in memory (empty for stores).
    pub fn maps(&self) -> Vec<&HeightMap> {
        match self {
            Self::Memory(maps) => maps.iter().collect(),
            Self::Stores(_) => Vec::new(),
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
    // Any reading option (a pitch or z-unit override, decimal marks, an MD5 waiver) goes
    // to the whole-map loader, which honours it or refuses it for a store, naming it:
    // the band reader takes none, and a flag is never silently dropped.
    let c = &input.calibration;
    let options = c.pixel_um.is_some()
        || c.z_unit.is_some()
        || c.decimal_comma
        || c.decimal_point
        || c.accept_md5_mismatch;
    if sources.is_empty() || options || !sources.iter().all(streamable) {
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

/// The maps of `sources` read whole, with the intensity cutoff applied; a map without a
/// valid pixel or smaller than the `window` is an error naming it (and the flag).
pub fn load_whole(
    input: &MapInputArgs,
    sources: &[MapSource],
    window: usize,
) -> anyhow::Result<Vec<HeightMap>> {
    let options = input.load_options()?;
    let mut maps = Vec::with_capacity(sources.len());
    for input in load_all(sources, &options)? {
        let (path, map) = (&input.source.height, input.loaded.map);
        if map.valid_count() == 0 {
            bail!(
                "height map {}: no valid pixel (all {} are NaN or masked)",
                path.display(),
                map.len()
            );
        }
        if window > map.nx().min(map.ny()) {
            bail!(
                "--window {window}: larger than height map {} ({} x {} pixels)",
                path.display(),
                map.nx(),
                map.ny()
            );
        }
        maps.push(map);
    }
    Ok(maps)
}

/// A failed model run over `loaded` (read from `sources`) as a command reports it: a
/// streamed map without a valid pixel as the in-memory loader says it (with the
/// `cutoff`), a band that could not be read naming the map (its reader's error names
/// the store and the array), anything else under `flags` (e.g. "--window 5, --tile-um
/// 50").
pub fn run_error(
    e: PipelineError,
    sources: &[MapSource],
    loaded: &Loaded,
    cutoff: Option<f64>,
    flags: String,
) -> anyhow::Error {
    use flakescatter::topo::TopoError;
    match (loaded, e) {
        (Loaded::Stores(_), PipelineError::Topo(TopoError::NoValidPixels { map, pixels })) => {
            no_valid_pixel(sources, map, pixels, cutoff)
        }
        (_, PipelineError::Topo(TopoError::Source { map, error })) => anyhow::anyhow!(
            "reading height map {}: {error}",
            sources
                .get(map)
                .map_or_else(|| format!("{map}"), |s| s.height.display().to_string())
        ),
        (_, e) => anyhow::Error::from(e).context(flags),
    }
}

/// The in-memory loader's message for a map without a valid pixel, for a streamed run
/// that found one (`map` 0-based of `sources`, `pixels` its size).
fn no_valid_pixel(
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
