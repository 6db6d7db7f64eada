//! A topographic run over Zarr stores split into ranges of tiles, for
//! `flakescatter.dask`: `StoreRun(stores, ...)` opens the stores (metadata only) and
//! checks every keyword; `tile_count()` numbers the tiles; `trace(start, stop)` traces a
//! range into its per-tile sums, returned as a dict of plain values and numpy arrays
//! (so Dask can move it between processes); `finish(parts)` reduces the parts, in tile
//! order, into the dict `topographic_model` / `isotropic_model` return for the same maps
//! in memory, bit for bit (facade `streaming`, module docs "Split runs").

use std::path::PathBuf;

use flakescatter::streaming::{
    StoreCutoff, StoreError, ZarrSource, finish_isotropic, finish_topographic, tile_count,
    trace_tiles,
};
use flakescatter::topo::{HeightSource, TileSums, TileSumsKind};
use flakescatter::{Coating, Instrument, Settings, TopoSettings};
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::convert::{InstrumentArgs, coating, coating_with_stack, path_of, settings};
use crate::errors::{Kind, input, interruptible, to_py};
use crate::models::{curve_columns, topo_settings, topo_warnings};

/// The stores, opened, with every setting of a run (module docs).
#[pyclass(module = "flakescatter._flakescatter", frozen)]
pub struct StoreRun {
    args: InstrumentArgs,
    coat: Coating,
    set: Settings,
    topo: TopoSettings,
    instrument: Instrument,
    /// `None`: the plain model; `Some(node spacing, radians)`: the isotropic one.
    isotropic: Option<Option<f64>>,
    stores: Vec<ZarrSource>,
}

/// The exception class of a store that cannot be streamed: a missing store is a
/// `FileError`, a store whose content is not usable a `FileFormatError`.
fn store_error(py: Python<'_>, e: &StoreError) -> PyErr {
    use flakescatter::io::zarr::ZarrProblem as P;
    let kind = match e {
        StoreError::Zarr(z) if matches!(z.problem, P::NotAStore { .. }) && !z.store.exists() => {
            Kind::File
        }
        StoreError::BadCutoff(_) => Kind::Input,
        _ => Kind::Content,
    };
    to_py(py, kind, e)
}

/// The exception of a run's error: a band that cannot be read is the store's fault
/// (`FileFormatError`, naming the store and array), the rest are the keywords'.
fn run_error(py: Python<'_>, e: &flakescatter::PipelineError) -> PyErr {
    use flakescatter::topo::TopoError;
    let kind = match e {
        flakescatter::PipelineError::Topo(TopoError::Source { .. }) => Kind::Content,
        _ => Kind::Input,
    };
    to_py(py, kind, e)
}

/// The store paths of `stores`: one path, or a sequence of them.
fn store_paths(py: Python<'_>, stores: &Bound<'_, PyAny>) -> PyResult<Vec<PathBuf>> {
    if let Ok(p) = path_of(py, "stores", stores) {
        return Ok(vec![p]);
    }
    let bad = || {
        input(
            py,
            "stores: expected a Zarr store's path or a sequence of them",
        )
    };
    let mut out = Vec::new();
    for item in stores.try_iter().map_err(|_| bad())? {
        out.push(path_of(py, "stores", &item?)?);
    }
    if out.is_empty() {
        return Err(input(py, "stores: no Zarr store given"));
    }
    Ok(out)
}

impl StoreRun {
    fn sources(&self) -> Vec<&dyn HeightSource> {
        self.stores.iter().map(|s| s as &dyn HeightSource).collect()
    }

    fn kind(&self) -> TileSumsKind {
        if self.isotropic.is_some() {
            TileSumsKind::Isotropic
        } else {
            TileSumsKind::Plain
        }
    }
}

#[pymethods]
impl StoreRun {
    /// Opens `stores` (a Zarr store's path or a sequence of them; metadata only) for a
    /// plain (`isotropic=False`) or isotropic run with the keywords of
    /// `topographic_model` / `isotropic_model`; `intensity_cutoff` masks points whose
    /// intensity (the store's own `intensity` array, or `intensity_store`'s) is below it.
    #[new]
    #[pyo3(signature = (stores, *, isotropic = false, node_spacing_deg = None, intensity_cutoff = None, intensity_store = None, window = 5, tile_um = 32.0, n = 1.5, theta_i = None, theta_s = None, detectors = None, aperture = 1.5, transmission = "exact-unpolarized", weighting = "physical", clearcoat = false, flake_index = None, flake_stack = None, flake_core = None, wavelength_nm = None))]
    #[allow(clippy::too_many_arguments)] // One keyword per CLI flag.
    fn new(
        py: Python<'_>,
        stores: &Bound<'_, PyAny>,
        isotropic: bool,
        node_spacing_deg: Option<f64>,
        intensity_cutoff: Option<f64>,
        intensity_store: Option<&Bound<'_, PyAny>>,
        window: usize,
        tile_um: f64,
        n: f64,
        theta_i: Option<&Bound<'_, PyAny>>,
        theta_s: Option<&Bound<'_, PyAny>>,
        detectors: Option<&Bound<'_, PyAny>>,
        aperture: f64,
        transmission: &str,
        weighting: &str,
        clearcoat: bool,
        flake_index: Option<(f64, f64)>,
        flake_stack: Option<&str>,
        flake_core: Option<&str>,
        wavelength_nm: Option<f64>,
    ) -> PyResult<Self> {
        let paths = store_paths(py, stores)?;
        let args = InstrumentArgs::new(py, theta_i, theta_s, detectors, aperture)?;
        let coat = if isotropic {
            if flake_stack.is_some() || flake_core.is_some() || wavelength_nm.is_some() {
                return Err(input(
                    py,
                    "flake_stack, flake_core and wavelength_nm apply to the plain model only (isotropic_model takes flake_index)",
                ));
            }
            coating(py, n, flake_index)?
        } else {
            if node_spacing_deg.is_some() {
                return Err(input(
                    py,
                    "node_spacing_deg applies to the isotropic model only",
                ));
            }
            coating_with_stack(py, n, flake_index, flake_stack, flake_core, wavelength_nm)?
        };
        let set = settings(py, transmission, weighting, clearcoat)?;
        let topo = topo_settings(py, window, tile_um)?;
        let instrument = args.instrument(py)?;
        let cutoff = match (intensity_cutoff, intensity_store) {
            (None, None) => StoreCutoff::None,
            (None, Some(_)) => {
                return Err(input(py, "intensity_store needs intensity_cutoff"));
            }
            (Some(c), None) => StoreCutoff::Own(c),
            (Some(c), Some(s)) => StoreCutoff::Partner(path_of(py, "intensity_store", s)?, c),
        };
        if paths.len() > 1 && matches!(cutoff, StoreCutoff::Partner(..)) {
            return Err(input(
                py,
                "intensity_store: one intensity store pairs with one height store (give each store its own `intensity` array to cut several)",
            ));
        }
        let stores = paths
            .iter()
            .map(|p| ZarrSource::open(p, &cutoff).map_err(|e| store_error(py, &e)))
            .collect::<PyResult<Vec<_>>>()?;
        let spacing = node_spacing_deg.map(f64::to_radians);
        Ok(Self {
            args,
            coat,
            set,
            topo,
            instrument,
            isotropic: isotropic.then_some(spacing),
            stores,
        })
    }

    /// The number of statistics tiles (maps in order, each row-major, tiles of
    /// `tile_um`): `trace` takes ranges of these numbers.
    fn tile_count(&self, py: Python<'_>) -> PyResult<u64> {
        tile_count(&self.coat, &self.set, &self.topo, &self.sources())
            .map_err(|e| to_py(py, Kind::Input, &e))
    }

    /// Traces tiles `start..stop` into their per-tile sums (a dict: `kind`, `start`,
    /// `stop`, `width`, `rows` (float64, `width` per tile), `counts` (uint64), `usable`,
    /// `lost_tir`, `lost_down`, `valid` (per map), `nodes`). Interruptible with Ctrl-C.
    fn trace<'py>(&self, py: Python<'py>, start: u64, stop: u64) -> PyResult<Bound<'py, PyDict>> {
        let sources = self.sources();
        let sums = interruptible(py, |progress| {
            trace_tiles(
                &self.coat,
                &self.instrument,
                &self.set,
                &self.topo,
                self.isotropic,
                &sources,
                start..stop,
                progress,
            )
        })?
        .map_err(|e| run_error(py, &e))?;
        sums_dict(py, sums)
    }

    /// The result of the run from its parts (`trace` over consecutive ranges covering
    /// every tile, in tile order): the dict of `topographic_model` (or
    /// `isotropic_model`) on the same maps, bit for bit.
    fn finish<'py>(
        &self,
        py: Python<'py>,
        parts: &Bound<'py, PyList>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let parts = parts
            .iter()
            .enumerate()
            .map(|(k, p)| sums_of(py, k, &p, self.kind()))
            .collect::<PyResult<Vec<_>>>()?;
        let sources = self.sources();
        let (c, s, t, i) = (&self.coat, &self.set, &self.topo, &self.instrument);
        match self.isotropic {
            None => {
                let (curves, result) = finish_topographic(c, i, s, t, &sources, &parts)
                    .map_err(|e| to_py(py, Kind::Input, &e))?;
                topo_warnings(py, &result.warnings, t.tile_um)?;
                curve_columns(py, &self.args, &curves, true)
            }
            Some(spacing) => {
                let (curves, result) = finish_isotropic(c, i, s, t, spacing, &sources, &parts)
                    .map_err(|e| to_py(py, Kind::Input, &e))?;
                topo_warnings(py, &result.warnings, t.tile_um)?;
                let d = curve_columns(py, &self.args, &curves, true)?;
                d.set_item(
                    "interpolation_error",
                    PyArray1::from_vec(py, result.interpolation_error.clone()),
                )?;
                Ok(d)
            }
        }
    }
}

/// The dict of a range's sums (`StoreRun.trace`).
fn sums_dict(py: Python<'_>, s: TileSums) -> PyResult<Bound<'_, PyDict>> {
    let d = PyDict::new(py);
    let kind = match s.kind {
        TileSumsKind::Plain => "plain",
        TileSumsKind::Isotropic => "isotropic",
    };
    d.set_item("kind", kind)?;
    d.set_item("start", s.tiles.start)?;
    d.set_item("stop", s.tiles.end)?;
    d.set_item("width", s.width)?;
    d.set_item("rows", PyArray1::from_vec(py, s.rows))?;
    d.set_item("counts", PyArray1::from_vec(py, s.counts))?;
    d.set_item("usable", s.usable)?;
    d.set_item("lost_tir", s.lost_tir)?;
    d.set_item("lost_down", s.lost_down)?;
    d.set_item("valid", s.valid)?;
    d.set_item("nodes", s.nodes)?;
    Ok(d)
}

/// Part `k` of `finish`, read back from its dict (`InputError` naming the part and key
/// for anything that is not one `trace` made for this run).
fn sums_of(
    py: Python<'_>,
    k: usize,
    part: &Bound<'_, PyAny>,
    kind: TileSumsKind,
) -> PyResult<TileSums> {
    let bad = |what: &str| {
        input(
            py,
            format!("parts[{k}]: {what} (expected a dict from StoreRun.trace)"),
        )
    };
    let d = part.cast::<PyDict>().map_err(|_| bad("not a dict"))?;
    let get = |key: &str| -> PyResult<Bound<'_, PyAny>> {
        d.get_item(key)?
            .ok_or_else(|| bad(&format!("no key `{key}`")))
    };
    let int = |key: &str| -> PyResult<u64> {
        get(key)?
            .extract::<u64>()
            .map_err(|_| bad(&format!("`{key}` is not a non-negative integer")))
    };
    let found = get("kind")?
        .extract::<String>()
        .map_err(|_| bad("`kind` is not a string"))?;
    let want = match kind {
        TileSumsKind::Plain => "plain",
        TileSumsKind::Isotropic => "isotropic",
    };
    if found != want {
        return Err(bad(&format!("`kind` is {found:?}, this run is {want:?}")));
    }
    let rows = get("rows")?
        .extract::<numpy::PyReadonlyArray1<'_, f64>>()
        .map_err(|_| bad("`rows` is not a float64 array"))?
        .as_array()
        .to_vec();
    let counts = get("counts")?
        .extract::<numpy::PyReadonlyArray1<'_, u64>>()
        .map_err(|_| bad("`counts` is not a uint64 array"))?
        .as_array()
        .to_vec();
    let valid = get("valid")?
        .extract::<Vec<u64>>()
        .map_err(|_| bad("`valid` is not a list of integers"))?;
    let usize_of = |key: &str| -> PyResult<usize> {
        usize::try_from(int(key)?).map_err(|_| bad(&format!("`{key}` is too large")))
    };
    Ok(TileSums {
        kind,
        tiles: int("start")?..int("stop")?,
        width: usize_of("width")?,
        rows,
        counts,
        usable: int("usable")?,
        lost_tir: int("lost_tir")?,
        lost_down: int("lost_down")?,
        valid,
        nodes: usize_of("nodes")?,
    })
}
