//! Height maps: the `Map` class, `read_map` and `write_map`.
//!
//! Conventions (those of `HeightMap` and `io`): heights and pitch in micrometres;
//! arrays of shape `(ny, nx)`, row `y` and column `x` (`x` along columns, the file's
//! fastest axis); `heights_um` holds NaN where a point is invalid and `valid` is the
//! mask.

use std::path::PathBuf;

use flakescatter::io::{
    ChannelSelector, MapError, MapFormat, ReadMapError, ReadOptions, WriteMapError, ZUnit,
};
use flakescatter::stats::heightmap::HeightMap;
use numpy::ndarray::Array2;
use numpy::{PyArray2, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::path_of;
use crate::errors::{Kind, guarded, input, released, to_py};

/// A height map: heights in µm on a regular grid with a validity mask.
///
/// `Map(heights_um, pitch_um, valid=None)` builds one from a 2-D array of shape
/// `(ny, nx)` (µm; NaN or `valid == False` marks invalid points) and the pixel pitch
/// `(dx, dy)` in µm (one number for square pixels). `read_map` returns one from a file.
#[pyclass(name = "Map", module = "flakescatter", frozen)]
pub struct Map {
    /// The map.
    pub map: HeightMap,
    /// The file format it was read from (`x3p`, `sdf`, `text`), `None` if built in Python.
    pub format: Option<&'static str>,
}

fn map_error(py: Python<'_>, e: &ReadMapError) -> PyErr {
    match e {
        ReadMapError::Io { .. } => to_py(py, Kind::File, e),
        // The system's error part-way through an X3P member: the file, not its content.
        ReadMapError::Format {
            error: MapError::X3p(flakescatter::io::x3p::X3pError::Read { .. }),
            ..
        } => to_py(py, Kind::File, e),
        // A channel the file does not have is the caller's parameter at fault.
        ReadMapError::Format {
            error: MapError::Channel(_),
            ..
        } => to_py(py, Kind::Input, e),
        ReadMapError::Format { .. } => to_py(py, Kind::Content, e),
    }
}

/// A pitch `(dx, dy)` or one number for both, µm.
fn pitch(py: Python<'_>, name: &str, obj: &Bound<'_, PyAny>) -> PyResult<(f64, f64)> {
    let (dx, dy) = if let Ok(d) = obj.extract::<f64>() {
        (d, d)
    } else {
        obj.extract::<(f64, f64)>().map_err(|_| {
            input(
                py,
                format!("{name}: expected a number or a pair (dx, dy) in µm"),
            )
        })?
    };
    if !(dx.is_finite() && dx > 0.0 && dy.is_finite() && dy > 0.0) {
        return Err(input(
            py,
            format!("{name}=({dx}, {dy}): the pitch must be finite and > 0 µm"),
        ));
    }
    Ok((dx, dy))
}

#[pymethods]
impl Map {
    #[new]
    #[pyo3(signature = (heights_um, pitch_um, valid = None))]
    fn py_new(
        py: Python<'_>,
        heights_um: &Bound<'_, PyAny>,
        pitch_um: &Bound<'_, PyAny>,
        valid: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let np = py.import("numpy")?;
        let z = np
            .call_method1("asarray", (heights_um, "float64"))
            .map_err(|_| input(py, "heights_um: expected a 2-D array of numbers (µm)"))?;
        let z = z
            .cast_into::<PyArray2<f64>>()
            .map_err(|_| input(py, "heights_um: expected a 2-D array of shape (ny, nx)"))?;
        let (ny, nx) = (z.shape()[0], z.shape()[1]);
        let heights: Vec<f64> = z.readonly().as_array().iter().copied().collect();
        let (dx, dy) = pitch(py, "pitch_um", pitch_um)?;
        let mask: Option<Vec<bool>> = match valid {
            None => None,
            Some(v) => {
                let v = np
                    .call_method1("asarray", (v, "bool"))
                    .map_err(|_| input(py, "valid: expected a 2-D boolean array"))?
                    .cast_into::<PyArray2<bool>>()
                    .map_err(|_| {
                        input(py, "valid: expected a 2-D boolean array of shape (ny, nx)")
                    })?;
                if v.shape() != [ny, nx] {
                    return Err(input(
                        py,
                        format!(
                            "valid: shape {:?} differs from heights_um's ({ny}, {nx})",
                            v.shape()
                        ),
                    ));
                }
                Some(v.readonly().as_array().iter().copied().collect())
            }
        };
        let map = match mask {
            Some(mask) => HeightMap::with_mask(nx, ny, dx, dy, heights, mask),
            None => HeightMap::new(nx, ny, dx, dy, heights),
        }
        .map_err(|e| to_py(py, Kind::Input, &e))?;
        Ok(Self { map, format: None })
    }

    /// Heights, µm, shape `(ny, nx)`, float64; NaN where the point is invalid (a copy).
    #[getter]
    fn heights_um<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let m = &self.map;
        let z: Vec<f64> = m
            .heights()
            .iter()
            .zip(m.valid())
            .map(|(&z, &ok)| if ok { z } else { f64::NAN })
            .collect();
        let a = Array2::from_shape_vec((m.ny(), m.nx()), z)
            .map_err(|e| input(py, format!("internal shape error: {e}")))?;
        Ok(PyArray2::from_owned_array(py, a))
    }

    /// Validity mask, shape `(ny, nx)`, bool (a copy).
    #[getter]
    fn valid<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<bool>>> {
        let m = &self.map;
        let a = Array2::from_shape_vec((m.ny(), m.nx()), m.valid().to_vec())
            .map_err(|e| input(py, format!("internal shape error: {e}")))?;
        Ok(PyArray2::from_owned_array(py, a))
    }

    /// Pixel pitch `(dx, dy)`, µm (`dx` along columns, `dy` along rows).
    #[getter]
    fn pitch_um(&self) -> (f64, f64) {
        (self.map.dx(), self.map.dy())
    }

    /// The file format it was read from: `"x3p"`, `"sdf"` or `"text"`; `None` when
    /// built from an array.
    #[getter]
    fn format(&self) -> Option<&'static str> {
        self.format
    }

    /// Metadata read from the file (`format`, `pitch_source`, `x3p.*`, `sdf.*`,
    /// `text.*`, ...), str → str.
    #[getter]
    fn metadata<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (k, v) in self.map.metadata() {
            d.set_item(k, v)?;
        }
        Ok(d)
    }

    /// Number of columns (points along x).
    #[getter]
    fn nx(&self) -> usize {
        self.map.nx()
    }

    /// Number of rows (points along y).
    #[getter]
    fn ny(&self) -> usize {
        self.map.ny()
    }

    /// `(ny, nx)`, the shape of `heights_um`.
    #[getter]
    fn shape(&self) -> (usize, usize) {
        (self.map.ny(), self.map.nx())
    }

    /// Number of valid points.
    #[getter]
    fn valid_count(&self) -> usize {
        self.map.valid_count()
    }

    fn __repr__(&self) -> String {
        format!(
            "Map(nx={}, ny={}, pitch_um=({}, {}), valid={} of {}, format={})",
            self.map.nx(),
            self.map.ny(),
            self.map.dx(),
            self.map.dy(),
            self.map.valid_count(),
            self.map.len(),
            self.format.map_or("None".to_string(), |f| format!("{f:?}"))
        )
    }
}

/// A channel parameter: an int (index) or a str (all digits: an index, else a name).
fn channel_of(
    py: Python<'_>,
    name: &str,
    obj: Option<&Bound<'_, PyAny>>,
) -> PyResult<Option<ChannelSelector>> {
    let Some(obj) = obj else { return Ok(None) };
    if let Ok(i) = obj.extract::<usize>() {
        return Ok(Some(ChannelSelector::Index(i)));
    }
    let s: String = obj.extract().map_err(|_| {
        input(
            py,
            format!("{name}: expected an index (int >= 0) or a channel name (str)"),
        )
    })?;
    s.parse()
        .map(Some)
        .map_err(|e| input(py, format!("{name}={s:?}: {e}")))
}

/// Reads a height map (X3P, SDF, plain text or an instrument format, recognised from
/// the content) and optionally masks it with an intensity image (points whose intensity
/// is below `cutoff` become invalid), as the CLI's `MAP --intensity FILE --cutoff X`, or
/// with an intensity channel of the same file (`--intensity-channel`). `channel` and
/// `intensity_channel`: an index or a name, as the CLI's `--channel`.
#[pyfunction]
#[pyo3(signature = (path, channel = None, intensity = None, cutoff = None, *, intensity_channel = None, pixel_um = None, z_unit = None, accept_md5_mismatch = false))]
#[allow(clippy::too_many_arguments)]
pub fn read_map(
    py: Python<'_>,
    path: &Bound<'_, PyAny>,
    channel: Option<&Bound<'_, PyAny>>,
    intensity: Option<&Bound<'_, PyAny>>,
    cutoff: Option<f64>,
    intensity_channel: Option<&Bound<'_, PyAny>>,
    pixel_um: Option<&Bound<'_, PyAny>>,
    z_unit: Option<&str>,
    accept_md5_mismatch: bool,
) -> PyResult<Map> {
    let path = path_of(py, "path", path)?;
    let channel = channel_of(py, "channel", channel)?;
    let intensity_channel = channel_of(py, "intensity_channel", intensity_channel)?;
    let intensity: Option<PathBuf> = intensity.map(|i| path_of(py, "intensity", i)).transpose()?;
    if intensity.is_some() && intensity_channel.is_some() {
        return Err(input(
            py,
            "give intensity (a second file) or intensity_channel (a channel of the same file), not both",
        ));
    }
    if let Some(i) = &intensity
        && flakescatter::distinct::same_data(&path, i).is_some()
    {
        return Err(input(
            py,
            format!(
                "intensity={}: the intensity map is the height map file {} itself, or a byte-identical copy of it; give the intensity image of the same area",
                i.display(),
                path.display()
            ),
        ));
    }
    let has_intensity = intensity.is_some() || intensity_channel.is_some();
    match (has_intensity, cutoff) {
        (true, None) => {
            return Err(input(
                py,
                "intensity or intensity_channel needs cutoff (a number)",
            ));
        }
        (false, Some(c)) => {
            return Err(input(
                py,
                format!("cutoff={c} needs intensity (a path) or intensity_channel"),
            ));
        }
        (_, Some(c)) if !c.is_finite() => {
            return Err(input(py, format!("cutoff={c}: expected a finite number")));
        }
        _ => {}
    }
    // `..default()` keeps this building when `io` adds reader options.
    #[allow(clippy::needless_update)]
    let options = ReadOptions {
        pixel_um: pixel_um.map(|p| pitch(py, "pixel_um", p)).transpose()?,
        z_unit: z_unit
            .map(|u| {
                u.parse::<ZUnit>()
                    .map_err(|e| input(py, format!("z_unit={u:?}: {e}")))
            })
            .transpose()?,
        accept_md5_mismatch,
        ..ReadOptions::default()
    };
    let read = released(py, || -> Result<_, ReadFail> {
        let sel = flakescatter::io::read_selected(
            &path,
            &options,
            channel.as_ref(),
            intensity_channel.as_ref(),
        )?;
        let (mut map, format) = (sel.map, sel.format);
        if let (Some((mask, i)), Some(cutoff)) = (&sel.intensity, cutoff) {
            let name = &sel.channels[*i].name;
            map.apply_intensity_cutoff(mask, cutoff).map_err(|e| {
                ReadFail::Cutoff(format!(
                    "height map {} with intensity channel {i} ({name}) of the same file and cutoff {cutoff}: {e}",
                    path.display()
                ))
            })?;
        }
        if let (Some(ipath), Some(cutoff)) = (&intensity, cutoff) {
            let (mask, _) = flakescatter::io::read_intensity(ipath, &options)?;
            map.apply_intensity_cutoff(&mask, cutoff).map_err(|e| {
                ReadFail::Cutoff(format!(
                    "height map {} with intensity {} and cutoff {cutoff}: {e}",
                    path.display(),
                    ipath.display()
                ))
            })?;
        }
        Ok((map, format))
    })?;
    match read {
        Ok((map, format)) => Ok(Map {
            map,
            format: Some(format.name()),
        }),
        Err(ReadFail::Read(e)) => Err(map_error(py, &e)),
        Err(ReadFail::Cutoff(msg)) => Err(crate::errors::raise(py, Kind::Input, msg, None)),
    }
}

/// Why `read_map` failed: a file, or the intensity cutoff.
enum ReadFail {
    Read(ReadMapError),
    Cutoff(String),
}

impl From<ReadMapError> for ReadFail {
    fn from(e: ReadMapError) -> Self {
        Self::Read(e)
    }
}

/// Writes a map as X3P (`.x3p`: heights in metres, float64, `valid.bin` for invalid
/// points), SDF (`.sdf`: ISO 25178-71 text, `aISO-1.0`, the shortest decimals that read
/// back to the same heights, `BAD` for invalid points), plain text (`.txt`: µm with
/// pitch header lines) or a Zarr v3 store (`.zarr`: a directory, missing or empty, with
/// the float64 `height` array in µm, NaN at invalid points; docs/formats.md); `format`
/// (`"x3p"`, `"sdf"`, `"text"` or `"zarr"`) overrides the extension.
#[pyfunction]
#[pyo3(signature = (map, path, format = None))]
pub fn write_map(
    py: Python<'_>,
    map: &Bound<'_, Map>,
    path: &Bound<'_, PyAny>,
    format: Option<&str>,
) -> PyResult<()> {
    let path = path_of(py, "path", path)?;
    let fmt = match format {
        Some("x3p") => MapFormat::X3p,
        Some("sdf") => MapFormat::Sdf,
        Some("text") => MapFormat::Text,
        Some("zarr") => MapFormat::Zarr,
        Some(f) => {
            return Err(input(
                py,
                format!("format={f:?}: expected \"x3p\", \"sdf\", \"text\" or \"zarr\""),
            ));
        }
        None => match path.extension().and_then(|e| e.to_str()) {
            Some(e) if e.eq_ignore_ascii_case("x3p") => MapFormat::X3p,
            Some(e) if e.eq_ignore_ascii_case("sdf") => MapFormat::Sdf,
            Some(e) if e.eq_ignore_ascii_case("txt") => MapFormat::Text,
            Some(e) if e.eq_ignore_ascii_case("zarr") => MapFormat::Zarr,
            _ => {
                return Err(input(
                    py,
                    format!(
                        "path {}: a map is written as .x3p, .sdf, .txt or .zarr (or give format=\"x3p\"/\"sdf\"/\"text\"/\"zarr\")",
                        path.display()
                    ),
                ));
            }
        },
    };
    let m = map.get();
    let result = released(py, || flakescatter::io::write_map(&m.map, &path, fmt))?;
    result.map_err(|e| match &e {
        WriteMapError::Io { .. } => to_py(py, Kind::File, &e),
        WriteMapError::Archive { .. } => to_py(py, Kind::File, &e),
        WriteMapError::Unsupported { .. } => to_py(py, Kind::Input, &e),
        WriteMapError::Zarr(_) => to_py(py, Kind::File, &e),
    })
}

/// The maps of a `maps` argument: one `Map` or a sequence of them.
pub fn maps_of<'py>(py: Python<'py>, obj: &Bound<'py, PyAny>) -> PyResult<Vec<Bound<'py, Map>>> {
    guarded(py, || {
        if let Ok(m) = obj.cast::<Map>() {
            return Ok(vec![m.clone()]);
        }
        let bad = || {
            input(
                py,
                "maps: expected a Map or a sequence of Map objects (see read_map)",
            )
        };
        let mut out = Vec::new();
        for item in obj.try_iter().map_err(|_| bad())? {
            let item = item?;
            out.push(item.cast_into::<Map>().map_err(|_| bad())?);
        }
        if out.is_empty() {
            return Err(input(py, "maps: no height map given"));
        }
        Ok(out)
    })
}
