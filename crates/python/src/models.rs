//! The models: distribution, topographic (one ray per pixel, or averaged over the
//! sample's rotation), their Mueller forms, and the volume model.
//!
//! Every function takes degrees and micrometres, calls one facade function with the GIL
//! released and returns a dict of 1-D numpy arrays, one row per incidence × detector
//! (incidence-major, the CLI's order) with the CLI's column names: `theta_i_deg`,
//! `theta_s_deg` (θr for out-of-plane detectors), `phi_s_deg`, `aperture_deg`,
//! `brdf_per_sr` (1/sr), `reflectance` (fraction of the beam; NaN for point
//! detectors), `relative` (to the same detector at the specular direction; NaN where
//! undefined), and for the ray models `rays` (int64) and `std_err` (1/sr; NaN where not
//! estimable).
#![allow(clippy::too_many_arguments)] // One keyword per CLI flag.

use flakescatter::gaussian::ConeMethod;
use flakescatter::optics::mueller::{Analyzer, Stokes};
use flakescatter::stats::heightmap::HeightMap;
use flakescatter::volume::{Amount, Depth, Diameter, RimRule, Substrate};
use flakescatter::{
    Curves, OrientationSource, Polarimetry, TopoSettings, VolumeCurves, VolumeSettings,
    distribution_curves, distribution_mueller as facade_distribution_mueller, isotropic_curves,
    topographic_curves, topographic_mueller as facade_topographic_mueller, volume_curves,
};
use numpy::PyArray1;
use numpy::PyArray3;
use numpy::ndarray::Array3;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{
    Columns, InstrumentArgs, coating, coating_with_stack, floats, nan, orientation, settings,
};
use crate::errors::{Kind, input, interruptible, released, to_py, warn};
use crate::map::{Map, maps_of};

/// The angle columns of rows `(incidence index, detector index)`, degrees as given.
fn angle_columns<'py>(
    py: Python<'py>,
    args: &InstrumentArgs,
    rows: &[(usize, usize)],
) -> PyResult<Columns<'py>> {
    let ti = rows.iter().map(|&(i, _)| args.theta_i[i]).collect();
    let ts = rows.iter().map(|&(_, j)| args.detector_deg(j).0).collect();
    let ps = rows.iter().map(|&(_, j)| args.detector_deg(j).1).collect();
    Columns::new(py)
        .f64("theta_i_deg", ti)?
        .f64("theta_s_deg", ts)?
        .f64("phi_s_deg", ps)?
        .f64("aperture_deg", vec![args.aperture; rows.len()])
}

/// `(incidence index, detector index)` of each row, checked against the row's own
/// incidence (rows are incidence-major, `detector` the index in the instrument).
fn row_index(
    py: Python<'_>,
    args: &InstrumentArgs,
    rows: impl Iterator<Item = (f64, usize)>,
) -> PyResult<Vec<(usize, usize)>> {
    let nd = args.detector_count();
    rows.enumerate()
        .map(|(k, (theta_i, detector))| {
            let i = k / nd;
            if args.theta_i.get(i).map(|t| t.to_radians()) != Some(theta_i) || detector >= nd {
                return Err(crate::errors::raise(
                    py,
                    Kind::Internal,
                    format!("internal error: row {k} is not incidence {i} × detector {detector}"),
                    None,
                ));
            }
            Ok((i, detector))
        })
        .collect()
}

/// The CLI's warning for incidences whose `relative` is undefined.
fn relative_warnings(
    py: Python<'_>,
    args: &InstrumentArgs,
    idx: &[(usize, usize)],
    relative: &[f64],
) -> PyResult<()> {
    let mut seen: Vec<usize> = Vec::new();
    for (&(i, _), r) in idx.iter().zip(relative) {
        if !r.is_finite() && !seen.contains(&i) {
            seen.push(i);
            warn(
                py,
                &format!(
                    "theta_i {}°: the detector at the specular direction collects nothing, so `relative` is undefined (NaN)",
                    args.theta_i[i]
                ),
            )?;
        }
    }
    Ok(())
}

/// The scalar curves as columns (`rays` and `std_err` for the ray models).
pub(crate) fn curve_columns<'py>(
    py: Python<'py>,
    args: &InstrumentArgs,
    curves: &Curves,
    ray_columns: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let idx = row_index(
        py,
        args,
        curves.rows.iter().map(|r| (r.theta_i, r.detector)),
    )?;
    let relative: Vec<f64> = curves.rows.iter().map(|r| r.relative).collect();
    relative_warnings(py, args, &idx, &relative)?;
    let mut cols = angle_columns(py, args, &idx)?
        .f64("brdf_per_sr", curves.rows.iter().map(|r| r.brdf).collect())?
        .f64(
            "reflectance",
            curves.rows.iter().map(|r| nan(r.reflectance)).collect(),
        )?
        .f64("relative", relative)?;
    if ray_columns {
        cols = cols
            .i64(
                "rays",
                curves
                    .rows
                    .iter()
                    .map(|r| r.rays.map_or(-1, |n| i64::try_from(n).unwrap_or(i64::MAX)))
                    .collect(),
            )?
            .f64(
                "std_err",
                curves.rows.iter().map(|r| nan(r.std_err)).collect(),
            )?;
    }
    Ok(cols.done())
}

/// The cone method keyword.
fn cone_method(py: Python<'_>, cone: &str) -> PyResult<ConeMethod> {
    match cone {
        "exact" => Ok(ConeMethod::Exact),
        "constant" => Ok(ConeMethod::ConstantIntegrand),
        _ => Err(input(
            py,
            format!("cone={cone:?}: expected \"exact\" or \"constant\""),
        )),
    }
}

/// The distribution model (physics.md §4): reflectance of mirror flakes under a clear
/// coat from their orientation distribution, as `flakescatter model`.
#[pyfunction]
#[pyo3(signature = (*, n = 1.5, hwhm = None, sigma = None, rms_tilt = None, distribution = None, theta_i = None, theta_s = None, detectors = None, aperture = 1.5, transmission = "exact-unpolarized", weighting = "physical", clearcoat = false, flake_index = None, cone = "exact", flake_stack = None, flake_core = None, wavelength_nm = None, base_albedo = 0.0))]
pub fn distribution_model<'py>(
    py: Python<'py>,
    n: f64,
    hwhm: Option<f64>,
    sigma: Option<f64>,
    rms_tilt: Option<f64>,
    distribution: Option<&Bound<'py, PyAny>>,
    theta_i: Option<&Bound<'py, PyAny>>,
    theta_s: Option<&Bound<'py, PyAny>>,
    detectors: Option<&Bound<'py, PyAny>>,
    aperture: f64,
    transmission: &str,
    weighting: &str,
    clearcoat: bool,
    flake_index: Option<(f64, f64)>,
    cone: &str,
    flake_stack: Option<&str>,
    flake_core: Option<&str>,
    wavelength_nm: Option<f64>,
    base_albedo: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let args = InstrumentArgs::new(py, theta_i, theta_s, detectors, aperture)?;
    let coat = coating_with_stack(py, n, flake_index, flake_stack, flake_core, wavelength_nm)?;
    let mut set = settings(py, transmission, weighting, clearcoat)?;
    set.cone_method = cone_method(py, cone)?;
    set.base_albedo = checked_albedo(py, base_albedo)?;
    let instrument = args.instrument(py)?;
    let source =
        OrientationSource::Distribution(orientation(py, hwhm, sigma, rms_tilt, distribution)?);
    let curves = released(py, || {
        distribution_curves(&coat, &instrument, &set, &source)
    })?
    .map_err(|e| to_py(py, Kind::Input, &e))?;
    curve_columns(py, &args, &curves, false)
}

/// `base_albedo=`: a Lambertian base under thin-film flakes (physics.md §13), in
/// [0, 1]; the models refuse it for flakes that transmit nothing.
fn checked_albedo(py: Python<'_>, base_albedo: f64) -> PyResult<f64> {
    if !(base_albedo.is_finite() && (0.0..=1.0).contains(&base_albedo)) {
        return Err(input(
            py,
            format!("base_albedo={base_albedo}: expected an albedo in [0, 1] (0 is a black base)"),
        ));
    }
    Ok(base_albedo)
}

/// Topographic settings from the keywords, checked as the CLI checks them.
pub(crate) fn topo_settings(py: Python<'_>, window: usize, tile_um: f64) -> PyResult<TopoSettings> {
    flakescatter::checks::window(window).map_err(|e| input(py, format!("window={e}")))?;
    flakescatter::checks::tile_um(tile_um).map_err(|e| input(py, format!("tile_um={e}")))?;
    Ok(TopoSettings { window, tile_um })
}

/// Copies of the maps' `HeightMap`s are not needed: the borrowed maps live as long as
/// the Python objects, which the call holds.
fn map_refs<'a>(maps: &'a [Bound<'_, Map>]) -> Vec<&'a HeightMap> {
    maps.iter().map(|m| &m.get().map).collect()
}

/// Emits the topographic model's warnings (few tiles, no standard error).
pub(crate) fn topo_warnings(
    py: Python<'_>,
    warnings: &[flakescatter::topo::TopoWarning],
    tile_um: f64,
) -> PyResult<()> {
    for w in warnings {
        warn(py, &format!("{w} (tile_um={tile_um})"))?;
    }
    Ok(())
}

/// The topographic model (physics.md §5) over one or more height maps, accumulated, as
/// `flakescatter topo`: one ray per usable pixel reflected by the local least-squares
/// plane. `base_albedo` (with `flake_stack` without `flake_core`) puts a Lambertian
/// base under the transmitting flakes, as `topo --base-albedo` (physics.md §13, "The
/// base under a map's flakes"). Interruptible with Ctrl-C.
#[pyfunction]
#[pyo3(signature = (maps, *, window = 5, tile_um = 32.0, n = 1.5, theta_i = None, theta_s = None, detectors = None, aperture = 1.5, transmission = "exact-unpolarized", weighting = "physical", clearcoat = false, flake_index = None, flake_stack = None, flake_core = None, wavelength_nm = None, base_albedo = 0.0))]
pub fn topographic_model<'py>(
    py: Python<'py>,
    maps: &Bound<'py, PyAny>,
    window: usize,
    tile_um: f64,
    n: f64,
    theta_i: Option<&Bound<'py, PyAny>>,
    theta_s: Option<&Bound<'py, PyAny>>,
    detectors: Option<&Bound<'py, PyAny>>,
    aperture: f64,
    transmission: &str,
    weighting: &str,
    clearcoat: bool,
    flake_index: Option<(f64, f64)>,
    flake_stack: Option<&str>,
    flake_core: Option<&str>,
    wavelength_nm: Option<f64>,
    base_albedo: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let maps = maps_of(py, maps)?;
    let args = InstrumentArgs::new(py, theta_i, theta_s, detectors, aperture)?;
    let coat = coating_with_stack(py, n, flake_index, flake_stack, flake_core, wavelength_nm)?;
    let mut set = settings(py, transmission, weighting, clearcoat)?;
    set.base_albedo = checked_albedo(py, base_albedo)?;
    let topo = topo_settings(py, window, tile_um)?;
    let instrument = args.instrument(py)?;
    let refs = map_refs(&maps);
    let (curves, result) = interruptible(py, |progress| {
        topographic_curves(&coat, &instrument, &set, &topo, &refs, progress)
    })?
    .map_err(|e| to_py(py, Kind::Input, &e))?;
    topo_warnings(py, &result.warnings, tile_um)?;
    curve_columns(py, &args, &curves, true)
}

/// The topographic model averaged over the sample's rotation about its normal
/// (physics.md §5.1): every pixel's ring of exit directions, exactly. As
/// `topographic_model`, plus `interpolation_error` (reflectance units, the tilt table's
/// interpolation error estimate per row); `rays` counts the pixels whose ring meets the
/// cone. Interruptible with Ctrl-C.
#[pyfunction]
#[pyo3(signature = (maps, *, node_spacing_deg = None, window = 5, tile_um = 32.0, n = 1.5, theta_i = None, theta_s = None, detectors = None, aperture = 1.5, transmission = "exact-unpolarized", weighting = "physical", clearcoat = false, flake_index = None))]
pub fn isotropic_model<'py>(
    py: Python<'py>,
    maps: &Bound<'py, PyAny>,
    node_spacing_deg: Option<f64>,
    window: usize,
    tile_um: f64,
    n: f64,
    theta_i: Option<&Bound<'py, PyAny>>,
    theta_s: Option<&Bound<'py, PyAny>>,
    detectors: Option<&Bound<'py, PyAny>>,
    aperture: f64,
    transmission: &str,
    weighting: &str,
    clearcoat: bool,
    flake_index: Option<(f64, f64)>,
) -> PyResult<Bound<'py, PyDict>> {
    let maps = maps_of(py, maps)?;
    let args = InstrumentArgs::new(py, theta_i, theta_s, detectors, aperture)?;
    let coat = coating(py, n, flake_index)?;
    let set = settings(py, transmission, weighting, clearcoat)?;
    let topo = topo_settings(py, window, tile_um)?;
    let instrument = args.instrument(py)?;
    let refs = map_refs(&maps);
    let spacing = node_spacing_deg.map(f64::to_radians);
    let (curves, result) = interruptible(py, |progress| {
        isotropic_curves(&coat, &instrument, &set, &topo, spacing, &refs, progress)
    })?
    .map_err(|e| to_py(py, Kind::Input, &e))?;
    topo_warnings(py, &result.warnings, tile_um)?;
    let d = curve_columns(py, &args, &curves, true)?;
    d.set_item(
        "interpolation_error",
        PyArray1::from_vec(py, result.interpolation_error.clone()),
    )?;
    Ok(d)
}

/// The polarisation keywords: `incident` (None/"unpolarized", "s", "p", or a Stokes
/// vector of four numbers) and `analyzer` (None, "s", "p", or the fully polarised
/// Stokes vector it passes).
fn polarimetry(
    py: Python<'_>,
    incident: Option<&Bound<'_, PyAny>>,
    analyzer: Option<&Bound<'_, PyAny>>,
) -> PyResult<Polarimetry> {
    let stokes = |name: &str, obj: &Bound<'_, PyAny>| -> PyResult<Stokes> {
        if let Ok(s) = obj.extract::<String>() {
            return match s.as_str() {
                "unpolarized" if name == "incident" => Ok(Stokes::UNPOLARIZED),
                "s" => Ok(Stokes::S),
                "p" => Ok(Stokes::P),
                _ => Err(input(
                    py,
                    format!(
                        "{name}={s:?}: expected {}\"s\", \"p\" or a Stokes vector (S0, S1, S2, S3)",
                        if name == "incident" {
                            "\"unpolarized\", "
                        } else {
                            ""
                        }
                    ),
                )),
            };
        }
        let v = floats(py, name, obj)?;
        let arr: [f64; 4] = v.try_into().map_err(|_| {
            input(
                py,
                format!("{name}: a Stokes vector has four numbers (S0, S1, S2, S3)"),
            )
        })?;
        Stokes::new(arr).map_err(|e| input(py, format!("{name}: {}", crate::errors::message(&e))))
    };
    let incident = match incident {
        None => Stokes::UNPOLARIZED,
        Some(o) => stokes("incident", o)?,
    };
    let analyzer = match analyzer {
        None => Analyzer::None,
        Some(o) => Analyzer::polarizer(stokes("analyzer", o)?)
            .map_err(|e| input(py, format!("analyzer: {}", crate::errors::message(&e))))?,
    };
    Ok(Polarimetry { incident, analyzer })
}

/// Mueller rows as columns: `mueller_brdf_per_sr`, `mueller_reflectance`,
/// `mueller_std_err` of shape `(rows, 4, 4)` (row-major 4 × 4 per row), and 1-D
/// `detected_brdf_per_sr`, `detected_std_err`, `relative`, `dop_unpolarized` (and
/// `rays` for the topographic model).
fn mueller_columns<'py>(
    py: Python<'py>,
    args: &InstrumentArgs,
    curves: &flakescatter::MuellerCurves,
    with_rays: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let rows = &curves.rows;
    let idx = row_index(py, args, rows.iter().map(|r| (r.theta_i, r.detector)))?;
    let relative: Vec<f64> = rows.iter().map(|r| r.relative).collect();
    relative_warnings(py, args, &idx, &relative)?;
    let cube = |f: &dyn Fn(&flakescatter::MuellerRow) -> Option<[f64; 16]>| -> PyResult<Bound<'py, PyArray3<f64>>> {
        let flat: Vec<f64> = rows
            .iter()
            .flat_map(|r| f(r).unwrap_or([f64::NAN; 16]))
            .collect();
        let a = Array3::from_shape_vec((rows.len(), 4, 4), flat)
            .map_err(|e| input(py, format!("internal shape error: {e}")))?;
        Ok(PyArray3::from_owned_array(py, a))
    };
    let mut cols = angle_columns(py, args, &idx)?
        .value("mueller_brdf_per_sr", cube(&|r| Some(r.brdf))?)?
        .value("mueller_reflectance", cube(&|r| r.reflectance)?)?
        .value("mueller_std_err", cube(&|r| r.brdf_std_err)?)?
        .f64(
            "detected_brdf_per_sr",
            rows.iter().map(|r| r.detected_brdf).collect(),
        )?
        .f64(
            "detected_std_err",
            rows.iter().map(|r| nan(r.detected_std_err)).collect(),
        )?
        .f64("relative", relative)?
        .f64(
            "dop_unpolarized",
            rows.iter().map(|r| r.dop_unpolarized).collect(),
        )?;
    if with_rays {
        cols = cols.i64(
            "rays",
            rows.iter()
                .map(|r| r.rays.map_or(-1, |n| i64::try_from(n).unwrap_or(i64::MAX)))
                .collect(),
        )?;
    }
    Ok(cols.done())
}

/// The distribution model's Mueller matrices (physics.md §8, §11): per detector the
/// cone-averaged Mueller BRDF in the detector axis' s/p basis (SCATMECH's convention),
/// the reading for the `incident` Stokes vector behind `analyzer`, and the degree of
/// polarisation for unpolarised light. `transmission` is fixed to `exact-unpolarized`
/// (the polarisation is given by `incident`).
#[pyfunction]
#[pyo3(signature = (*, incident = None, analyzer = None, n = 1.5, hwhm = None, sigma = None, rms_tilt = None, distribution = None, theta_i = None, theta_s = None, detectors = None, aperture = 1.5, weighting = "physical", clearcoat = false, flake_index = None, cone = "exact"))]
pub fn distribution_mueller<'py>(
    py: Python<'py>,
    incident: Option<&Bound<'py, PyAny>>,
    analyzer: Option<&Bound<'py, PyAny>>,
    n: f64,
    hwhm: Option<f64>,
    sigma: Option<f64>,
    rms_tilt: Option<f64>,
    distribution: Option<&Bound<'py, PyAny>>,
    theta_i: Option<&Bound<'py, PyAny>>,
    theta_s: Option<&Bound<'py, PyAny>>,
    detectors: Option<&Bound<'py, PyAny>>,
    aperture: f64,
    weighting: &str,
    clearcoat: bool,
    flake_index: Option<(f64, f64)>,
    cone: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let args = InstrumentArgs::new(py, theta_i, theta_s, detectors, aperture)?;
    let coat = coating(py, n, flake_index)?;
    let mut set = settings(py, "exact-unpolarized", weighting, clearcoat)?;
    set.cone_method = cone_method(py, cone)?;
    let pol = polarimetry(py, incident, analyzer)?;
    let instrument = args.instrument(py)?;
    let source =
        OrientationSource::Distribution(orientation(py, hwhm, sigma, rms_tilt, distribution)?);
    let curves = released(py, || {
        facade_distribution_mueller(&coat, &instrument, &set, &source, &pol)
    })?
    .map_err(|e| to_py(py, Kind::Input, &e))?;
    mueller_columns(py, &args, &curves, false)
}

/// The topographic model's Mueller matrices over height maps (as
/// `distribution_mueller`, with `rays`; standard errors from map tiles).
/// Interruptible with Ctrl-C.
#[pyfunction]
#[pyo3(signature = (maps, *, incident = None, analyzer = None, window = 5, tile_um = 32.0, n = 1.5, theta_i = None, theta_s = None, detectors = None, aperture = 1.5, weighting = "physical", clearcoat = false, flake_index = None))]
pub fn topographic_mueller<'py>(
    py: Python<'py>,
    maps: &Bound<'py, PyAny>,
    incident: Option<&Bound<'py, PyAny>>,
    analyzer: Option<&Bound<'py, PyAny>>,
    window: usize,
    tile_um: f64,
    n: f64,
    theta_i: Option<&Bound<'py, PyAny>>,
    theta_s: Option<&Bound<'py, PyAny>>,
    detectors: Option<&Bound<'py, PyAny>>,
    aperture: f64,
    weighting: &str,
    clearcoat: bool,
    flake_index: Option<(f64, f64)>,
) -> PyResult<Bound<'py, PyDict>> {
    let maps = maps_of(py, maps)?;
    let args = InstrumentArgs::new(py, theta_i, theta_s, detectors, aperture)?;
    let coat = coating(py, n, flake_index)?;
    let set = settings(py, "exact-unpolarized", weighting, clearcoat)?;
    let topo = topo_settings(py, window, tile_um)?;
    let pol = polarimetry(py, incident, analyzer)?;
    let instrument = args.instrument(py)?;
    let refs = map_refs(&maps);
    let (curves, result) = interruptible(py, |progress| {
        facade_topographic_mueller(&coat, &instrument, &set, &topo, &refs, &pol, progress)
    })?
    .map_err(|e| to_py(py, Kind::Input, &e))?;
    topo_warnings(py, &result.warnings, tile_um)?;
    mueller_columns(py, &args, &curves, true)
}

/// The volume model (physics.md §10): a three-dimensional layer of cylinder flakes in
/// the film, traced with multiple scattering. Columns as the other models, plus the
/// split by history: `coat_brdf_per_sr` (the clear coat's own reflection),
/// `single_bounce_brdf_per_sr` / `single_bounce_std_err`,
/// `multiple_bounce_brdf_per_sr` / `multiple_bounce_std_err` (1/sr); `rays` as the
/// topographic model. Every value is the mean over `layers` independent layers of the
/// seed (the `rays` shared among them); `std_err` is its standard error over the layers
/// (rays and layers; the rays only when `layers=1`), `ray_std_err` and `layer_std_err`
/// its two parts, `ci95` the half-width of its 95 % interval (Student's t on
/// `layers − 1` degrees of freedom; NaN when `layers=1`). The dict also holds `energy`
/// (per incidence: the shares of the beam reflected by the coat, escaped after one or
/// more flake events, absorbed, cut off) and `layer` (what the layers realised: counts
/// summed, fractions averaged). `binder_absorption` is the binder's Napierian absorption
/// coefficient in 1/µm (default 0, a clear binder), applied along every path inside the
/// film; its share is `energy["absorbed_binder"]`. Interference flakes: `flake_stack`
/// (and `flake_core`) at the one vacuum wavelength `wavelength_nm` (nm), as `volume
/// --flake-stack SPEC --flake-core M --wavelength NM`: the light a free flake transmits
/// goes on through it (physics.md §10, §13); a spectrum is a call per wavelength (the
/// same seed gives the same layers and rays at each, as `--wavelengths`).
/// Interruptible with Ctrl-C.
#[pyfunction]
#[pyo3(signature = (*, n = 1.5, hwhm = None, sigma = None, rms_tilt = None, distribution = None, theta_i = None, theta_s = None, detectors = None, aperture = 1.5, flake_index = None, film_um = 38.0, diameter_um = 16.0, diameter_rel_sd = 0.25, thickness_um = 1.0, mass_fraction = None, binder_density_g_cm3 = 1.2, volume_fraction = None, flakes = None, depth_um = None, tile_um = 1000.0, substrate = "black", substrate_albedo = 0.0, rims = "absorb", rays = 1_000_000, seed = 1, max_events = 1000, min_weight = 1e-6, layers = 8, binder_absorption = 0.0, flake_stack = None, flake_core = None, wavelength_nm = None))]
pub fn volume_model<'py>(
    py: Python<'py>,
    n: f64,
    hwhm: Option<f64>,
    sigma: Option<f64>,
    rms_tilt: Option<f64>,
    distribution: Option<&Bound<'py, PyAny>>,
    theta_i: Option<&Bound<'py, PyAny>>,
    theta_s: Option<&Bound<'py, PyAny>>,
    detectors: Option<&Bound<'py, PyAny>>,
    aperture: f64,
    flake_index: Option<(f64, f64)>,
    film_um: f64,
    diameter_um: f64,
    diameter_rel_sd: f64,
    thickness_um: f64,
    mass_fraction: Option<f64>,
    binder_density_g_cm3: f64,
    volume_fraction: Option<f64>,
    flakes: Option<usize>,
    depth_um: Option<(f64, f64)>,
    tile_um: f64,
    substrate: &str,
    substrate_albedo: f64,
    rims: &str,
    rays: u64,
    seed: u64,
    max_events: u32,
    min_weight: f64,
    layers: u32,
    binder_absorption: f64,
    flake_stack: Option<&str>,
    flake_core: Option<&str>,
    wavelength_nm: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let args = InstrumentArgs::new(py, theta_i, theta_s, detectors, aperture)?;
    // As `volume --flake-stack SPEC --flake-core M --wavelength NM`: the stack in the
    // binder at that one wavelength (the CLI's `--wavelengths` is a loop over this).
    let coat = coating_with_stack(py, n, flake_index, flake_stack, flake_core, wavelength_nm)?;
    let instrument = args.instrument(py)?;
    let source =
        OrientationSource::Distribution(orientation(py, hwhm, sigma, rms_tilt, distribution)?);
    let amount = amount_of(
        py,
        mass_fraction,
        volume_fraction,
        flakes,
        binder_density_g_cm3,
    )?;
    let substrate = substrate_of(py, substrate, substrate_albedo)?;
    let rims = rim_rule(py, rims)?;
    let vs = VolumeSettings {
        film_um,
        diameter: Diameter::LogNormal {
            mean_um: diameter_um,
            rel_sd: diameter_rel_sd,
        },
        thickness_um,
        amount,
        depth: match depth_um {
            None => Depth::WholeFilm,
            Some((top_um, bottom_um)) => Depth::Uniform { top_um, bottom_um },
        },
        tile_um,
        substrate,
        rims,
        rays,
        layers,
        seed,
        max_events,
        min_weight,
        binder_alpha_per_um: binder_absorption,
    };
    let curves = interruptible(py, |progress| {
        volume_curves(&coat, &instrument, &vs, &source, progress)
    })?
    .map_err(|e| to_py(py, Kind::Input, &e))?;
    let rows = &curves.rows;
    let idx = row_index(py, &args, rows.iter().map(|r| (r.theta_i, r.detector)))?;
    let relative: Vec<f64> = rows.iter().map(|r| r.relative).collect();
    relative_warnings(py, &args, &idx, &relative)?;
    let d = angle_columns(py, &args, &idx)?
        .f64("brdf_per_sr", rows.iter().map(|r| r.brdf).collect())?
        .f64("reflectance", rows.iter().map(|r| r.reflectance).collect())?
        .f64("relative", relative)?
        .i64(
            "rays",
            rows.iter()
                .map(|r| i64::try_from(r.rays).unwrap_or(i64::MAX))
                .collect(),
        )?
        .f64("std_err", rows.iter().map(|r| r.std_err).collect())?
        .f64("ray_std_err", rows.iter().map(|r| r.ray_std_err).collect())?
        .f64(
            "layer_std_err",
            rows.iter()
                .map(|r| r.layer_std_err.unwrap_or(f64::NAN))
                .collect(),
        )?
        .f64(
            "ci95",
            rows.iter().map(|r| r.ci95.unwrap_or(f64::NAN)).collect(),
        )?
        .f64(
            "coat_brdf_per_sr",
            rows.iter().map(|r| r.coat_brdf).collect(),
        )?
        .f64(
            "single_bounce_brdf_per_sr",
            rows.iter().map(|r| r.single_bounce_brdf).collect(),
        )?
        .f64(
            "single_bounce_std_err",
            rows.iter().map(|r| r.single_bounce_std_err).collect(),
        )?
        .f64(
            "multiple_bounce_brdf_per_sr",
            rows.iter().map(|r| r.multiple_bounce_brdf).collect(),
        )?
        .f64(
            "multiple_bounce_std_err",
            rows.iter().map(|r| r.multiple_bounce_std_err).collect(),
        )?
        .done();
    d.set_item("energy", energy_dict(py, &args, &curves)?)?;
    d.set_item("layer", layer_dict(py, &curves)?)?;
    d.set_item("rays_per_incidence", curves.rays_per_incidence)?;
    d.set_item("rays_per_layer", curves.rays_per_layer)?;
    d.set_item("layers", layers)?;
    d.set_item("seed", curves.seed)?;
    Ok(d)
}

/// The flake amount of the volume model: a mass loading (the default, 5 %), a volume
/// fraction or a count; at most one of them.
fn amount_of(
    py: Python<'_>,
    mass_fraction: Option<f64>,
    volume_fraction: Option<f64>,
    flakes: Option<usize>,
    binder_density_g_cm3: f64,
) -> PyResult<Amount> {
    Ok(match (mass_fraction, volume_fraction, flakes) {
        (_, None, None) => Amount::MassLoading {
            fraction: mass_fraction.unwrap_or(0.05),
            binder_density_g_cm3,
        },
        (None, Some(f), None) => Amount::VolumeFraction(f),
        (None, None, Some(c)) => Amount::Count(c),
        _ => {
            return Err(input(
                py,
                "mass_fraction, volume_fraction, flakes: give at most one amount",
            ));
        }
    })
}

/// The substrate of the volume model by name (`black`, `specular`, `lambertian`) and
/// albedo (none for a black one).
fn substrate_of(py: Python<'_>, substrate: &str, substrate_albedo: f64) -> PyResult<Substrate> {
    Ok(match substrate {
        "black" if substrate_albedo != 0.0 => {
            return Err(input(
                py,
                format!(
                    "substrate_albedo={substrate_albedo}: a black substrate has none; give substrate=\"specular\" or \"lambertian\""
                ),
            ));
        }
        "black" => Substrate::Black,
        "specular" => Substrate::Specular(substrate_albedo),
        "lambertian" => Substrate::Lambertian(substrate_albedo),
        s => {
            return Err(input(
                py,
                format!("substrate={s:?}: expected \"black\", \"specular\" or \"lambertian\""),
            ));
        }
    })
}

/// How the volume model treats flake rims, by name (`absorb`, `ignore`, `diffuse`).
fn rim_rule(py: Python<'_>, rims: &str) -> PyResult<RimRule> {
    Ok(match rims {
        "absorb" => RimRule::Absorb,
        "ignore" => RimRule::Ignore,
        "diffuse" => RimRule::Diffuse,
        r => {
            return Err(input(
                py,
                format!("rims={r:?}: expected \"absorb\", \"ignore\" or \"diffuse\""),
            ));
        }
    })
}

/// The `energy` dict of a volume run: per incidence, the shares of the beam reflected
/// by the coat, escaped, absorbed and cut off.
fn energy_dict<'py>(
    py: Python<'py>,
    args: &InstrumentArgs,
    curves: &VolumeCurves,
) -> PyResult<Bound<'py, PyDict>> {
    let energy = PyDict::new(py);
    let e = &curves.energy;
    let col = |f: fn(&flakescatter::volume::EnergyBalance) -> f64| -> Vec<f64> {
        e.iter().map(|(_, b)| f(b)).collect()
    };
    energy.set_item("theta_i_deg", PyArray1::from_vec(py, args.theta_i.clone()))?;
    for (name, f) in [
        (
            "coat_reflected",
            (|b| b.coat_reflected) as fn(&flakescatter::volume::EnergyBalance) -> f64,
        ),
        ("escaped_single", |b| b.escaped_single),
        ("escaped_multiple", |b| b.escaped_multiple),
        ("escaped_via_substrate", |b| b.escaped_via_substrate),
        ("absorbed_substrate", |b| b.absorbed_substrate),
        ("absorbed_flakes", |b| b.absorbed_flakes),
        ("absorbed_binder", |b| b.absorbed_binder),
        ("absorbed_rims", |b| b.absorbed_rims),
        ("absorbed_other", |b| b.absorbed_other),
        ("cut_off", |b| b.cut_off),
        ("total", |b| b.total()),
    ] {
        energy.set_item(name, PyArray1::from_vec(py, col(f)))?;
    }
    Ok(energy)
}

/// The `layer` dict of a volume run: what the layers realised (counts summed,
/// fractions averaged).
fn layer_dict<'py>(py: Python<'py>, curves: &VolumeCurves) -> PyResult<Bound<'py, PyDict>> {
    let l = &curves.layer;
    let layer = PyDict::new(py);
    layer.set_item("flakes", l.flakes)?;
    layer.set_item("requested_volume_fraction", l.requested_volume_fraction)?;
    layer.set_item("volume_fraction", l.volume_fraction)?;
    layer.set_item("projected_coverage", l.projected_coverage)?;
    layer.set_item("area_coverage", l.area_coverage)?;
    layer.set_item("attempts", l.attempts)?;
    layer.set_item("flakes_resized", l.resized)?;
    layer.set_item("flakes_moved", l.moved)?;
    layer.set_item("resized_area_fraction", l.resized_area_fraction)?;
    Ok(layer)
}
