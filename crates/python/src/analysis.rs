//! Flakes and measurements: `segment`, `orientation_stats`, `compare`, `fit`.
//!
//! Units as the CLI's tables: µm and µm² in `_um`/`_um2` columns, degrees in `_deg`
//! columns, unit normals without a suffix. Measured curves are a path to the CSV the
//! CLI reads or a dict of arrays read by the same reader.
#![allow(clippy::too_many_arguments)] // One keyword per CLI flag.

use flakescatter::compare::{
    IncidenceComparison, MeasuredKind, compare as facade_compare, distribution_points, select,
};
use flakescatter::fit::{FitSetup, GaussianFit, fit_gaussian, fit_nonparametric};
use flakescatter::io::flakes::{FlakeTableError, read_flakes, read_flakes_from, write_histogram};
use flakescatter::io::measured::MeasuredCurve;
use flakescatter::stats::fit::fit_gaussian_ml;
use flakescatter::stats::histogram::AreaHistogram;
use flakescatter::stats::segment::{SegmentParams, segment as facade_segment};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::convert::{
    Columns, coating, floats, measured as measured_curve, path_of, settings, table_csv,
    typed_degrees,
};
use crate::errors::{Kind, input, raise, released, to_py, warn};
use crate::map::Map;

/// Finds the individual flakes of a height map, as `flakescatter segment` (mask from
/// invalid points, regions split where heights jump or the plane turns, a robust plane
/// fit per flake). Returns the flake table as a dict of 1-D arrays with the CLI's
/// columns: `x_um`, `y_um` (centroid; x along columns, y along rows), `nx`, `ny`, `nz`
/// (unit normal), `area_um2` (true area = projected / nz), `theta_n_deg`, `phi_n_deg`,
/// `projected_area_um2`, `equivalent_diameter_um`, `rms_um` (plane residual),
/// `tilt_se_deg` (standard error of the tilt), `pixels`, `inliers` (int64),
/// `touches_border` (bool), `quality` (0..1).
#[pyfunction]
#[pyo3(signature = (map, *, z_step_um = 0.3, noise_um = 0.03, min_pixels = 100))]
pub fn segment<'py>(
    py: Python<'py>,
    map: &Bound<'py, Map>,
    z_step_um: f64,
    noise_um: f64,
    min_pixels: usize,
) -> PyResult<Bound<'py, PyDict>> {
    if !(z_step_um.is_finite() && z_step_um >= 0.0) {
        return Err(input(
            py,
            format!("z_step_um={z_step_um}: must be finite and >= 0 µm"),
        ));
    }
    if !(noise_um.is_finite() && noise_um >= 0.0) {
        return Err(input(
            py,
            format!("noise_um={noise_um}: must be finite and >= 0 µm"),
        ));
    }
    if min_pixels < 3 {
        return Err(input(
            py,
            format!("min_pixels={min_pixels}: must be at least 3"),
        ));
    }
    let mut params = SegmentParams::for_instrument(z_step_um, noise_um);
    params.min_pixels = min_pixels;
    let m = map.get();
    let seg = released(py, || facade_segment(&m.map, &params))?
        .map_err(|e| to_py(py, Kind::Input, &e))?;
    if let Some(w) = &seg.warning {
        warn(py, &format!("{w}; the flake table is empty"))?;
    }
    let f = &seg.flakes;
    let col = |g: fn(&flakescatter::stats::segment::SegmentedFlake) -> f64| {
        f.iter().map(g).collect::<Vec<f64>>()
    };
    let int = |g: fn(&flakescatter::stats::segment::SegmentedFlake) -> usize| {
        f.iter()
            .map(|x| i64::try_from(g(x)).unwrap_or(i64::MAX))
            .collect::<Vec<i64>>()
    };
    // The names of the one flake table (`segment --out`, `analyze`'s `flakes.csv`), in
    // its order; the last two (map, flake number) belong to files of several maps.
    use flakescatter::io::flakes::SEGMENTED_COLUMNS as C;
    Ok(Columns::new(py)
        .f64(C[0], col(|x| x.centre_um[0]))?
        .f64(C[1], col(|x| x.centre_um[1]))?
        .f64(C[2], col(|x| x.normal.x))?
        .f64(C[3], col(|x| x.normal.y))?
        .f64(C[4], col(|x| x.normal.z))?
        .f64(C[5], col(|x| x.area_um2))?
        .f64(C[6], col(|x| x.theta_n.to_degrees()))?
        .f64(C[7], col(|x| x.phi_n.to_degrees()))?
        .f64(C[8], col(|x| x.projected_area_um2))?
        .f64(C[9], col(|x| x.equivalent_diameter_um))?
        .f64(C[10], col(|x| x.rms_um))?
        .f64(C[11], col(|x| x.tilt_se.to_degrees()))?
        .i64(C[12], int(|x| x.pixels))?
        .i64(C[13], int(|x| x.inliers))?
        .bool(C[14], f.iter().map(|x| x.touches_border).collect())?
        .f64(C[15], col(|x| x.quality))?
        .done())
}

/// A flake-table error: `FileError` when the file cannot be read, `FileFormatError`
/// for its content.
fn table_error(py: Python<'_>, e: &FlakeTableError) -> PyErr {
    let kind = if matches!(e, FlakeTableError::Io { .. }) {
        Kind::File
    } else {
        Kind::Content
    };
    to_py(py, kind, e)
}

/// The histogram CSV text as columns (it was written by `io`, so every cell is a number).
fn histogram_columns<'py>(py: Python<'py>, text: &str) -> PyResult<Bound<'py, PyDict>> {
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
    let mut cols: Vec<Vec<f64>> = vec![Vec::new(); header.len()];
    for line in lines.filter(|l| !l.is_empty()) {
        for (c, cell) in cols.iter_mut().zip(line.split(',')) {
            c.push(cell.parse().map_err(|_| {
                raise(
                    py,
                    Kind::Internal,
                    format!("internal error: histogram cell {cell:?}"),
                    None,
                )
            })?);
        }
    }
    let mut out = Columns::new(py);
    for (h, c) in header.iter().zip(cols) {
        out = out.f64(h, c)?;
    }
    Ok(out.done())
}

/// Orientation statistics of flakes, as `flakescatter stats --flakes FILE --json`: the
/// area-weighted histogram of the flake polar angle θn and the maximum-likelihood
/// Gaussian width with its 95 % confidence interval. `flakes` is a path to a flake
/// table (any of the CLI's column sets) or a dict with `nx`, `ny`, `nz`, `area_um2`
/// arrays (e.g. `segment()`'s result). `bin_deg` is the histogram bin width, degrees,
/// in [0.001, 45].
#[pyfunction]
#[pyo3(signature = (flakes, *, bin_deg = 1.0))]
pub fn orientation_stats<'py>(
    py: Python<'py>,
    flakes: &Bound<'py, PyAny>,
    bin_deg: f64,
) -> PyResult<Bound<'py, PyDict>> {
    if !(bin_deg.is_finite() && (0.001..=45.0).contains(&bin_deg)) {
        return Err(input(
            py,
            format!("bin_deg={bin_deg}: the bin width must be in [0.001, 45] degrees"),
        ));
    }
    let (name, table) = if let Ok(d) = flakes.cast::<PyDict>() {
        let text = table_csv(py, "flakes", d, &["nx", "ny", "nz", "area_um2"], &[])?;
        let name = "flakes (dict)".to_string();
        let t = read_flakes_from(text.as_bytes(), &name);
        (name, t)
    } else {
        let path = path_of(py, "flakes", flakes)?;
        let name = path.display().to_string();
        (name, read_flakes(&path))
    };
    let table = table.map_err(|e| table_error(py, &e))?;
    let flakes = table.flakes;
    let hist = AreaHistogram::from_flakes(&flakes, bin_deg.to_radians()).map_err(|e| {
        raise(
            py,
            Kind::Input,
            format!("histogram of {name}: {}", crate::errors::message(&e)),
            None,
        )
    })?;
    let samples: Vec<(f64, f64)> = flakes.iter().map(|f| (f.theta_n(), f.area_um2)).collect();
    let fit = released(py, || fit_gaussian_ml(&samples))?.map_err(|e| {
        raise(
            py,
            Kind::Input,
            format!(
                "fitting a Gaussian to {name}: {}",
                crate::errors::message(&e)
            ),
            None,
        )
    })?;
    let mut text = Vec::new();
    write_histogram(&mut text, &name, &hist).map_err(|e| to_py(py, Kind::Internal, &e))?;
    let text = String::from_utf8_lossy(&text);
    let (lo, hi) = fit.hwhm_ci95();
    let d = PyDict::new(py);
    d.set_item("histogram", histogram_columns(py, &text)?)?;
    d.set_item("column_set", table.column_set.name())?;
    d.set_item("flakes", flakes.len())?;
    d.set_item("total_area_um2", hist.total_area_um2())?;
    d.set_item("hwhm_deg", fit.hwhm().to_degrees())?;
    d.set_item("hwhm_ci95_deg", (lo.to_degrees(), hi.to_degrees()))?;
    d.set_item("hwhm_ci95_method", fit.ci_method.describe())?;
    d.set_item("sigma_deg", fit.sigma.to_degrees())?;
    d.set_item("effective_flakes", fit.effective_n)?;
    d.set_item("bin_deg", bin_deg)?;
    Ok(d)
}

/// The measured-kind keyword.
fn kind_of(py: Python<'_>, kind: &str) -> PyResult<MeasuredKind> {
    kind.parse()
        .map_err(|e: String| input(py, format!("measured_kind={kind:?}: {e}")))
}

/// A measured curve with the `theta_i`/`theta_s` selection applied (degrees; every
/// selected incidence must be measured), as the CLI's `--theta-i`/`--theta-s` of
/// `compare` and `fit`.
fn selected(
    py: Python<'_>,
    measured: &Bound<'_, PyAny>,
    theta_i: Option<&Bound<'_, PyAny>>,
    theta_s: Option<&Bound<'_, PyAny>>,
) -> PyResult<MeasuredCurve> {
    let curve = measured_curve(py, measured)?;
    let ti = theta_i.map(|o| floats(py, "theta_i", o)).transpose()?;
    let ts = theta_s.map(|o| floats(py, "theta_s", o)).transpose()?;
    if let Some(v) = &ti {
        crate::convert::check_range(py, "theta_i", v, (0.0, 90.0), (false, true))?;
    }
    if let Some(v) = &ts {
        crate::convert::check_range(py, "theta_s", v, (-90.0, 90.0), (true, true))?;
    }
    if ti.is_none() && ts.is_none() {
        return Ok(curve);
    }
    let rad = |v: &Option<Vec<f64>>| {
        v.as_ref()
            .map(|v| v.iter().map(|d| d.to_radians()).collect::<Vec<_>>())
    };
    select(&curve, rad(&ti).as_deref(), rad(&ts).as_deref())
        .map_err(|e| raise(py, Kind::Input, format!("theta_i/theta_s: {e}"), None))
}

/// A measured curve against the distribution model, as `flakescatter compare --json
/// --out FILE`: the model's vertical scale fitted per incidence on the points 5°–40°
/// from specular, residuals `log10(measured) - log10(scale × model)` per region
/// (`specular` < 5°, `near-specular` 5°–40°, `far` > 40° from specular). `measured` is a
/// path to the CSV or a dict with `theta_i_deg`, `theta_s_deg`, `value` (and optionally
/// `uncertainty`) arrays; `measured_kind` is `"brdf"` (1/sr), `"reflectance-factor"`
/// (π × BRDF) or `"relative"`. The clear coat's reflection is on by default, as in the
/// CLI. Returns `points` (a dict of arrays: `theta_i_deg`, `theta_s_deg`, `region`,
/// `measured`, `model` (scaled), `residual_log10`, NaN where the model is zero) and
/// `incidences` (a list of dicts: `theta_i_deg`, `scale`, `regions`).
#[pyfunction]
#[pyo3(signature = (measured, *, measured_kind = "brdf", theta_i = None, theta_s = None, n = 1.5, hwhm = None, sigma = None, rms_tilt = None, distribution = None, aperture = 1.5, transmission = "exact-unpolarized", weighting = "physical", clearcoat = true, flake_index = None))]
pub fn compare<'py>(
    py: Python<'py>,
    measured: &Bound<'py, PyAny>,
    measured_kind: &str,
    theta_i: Option<&Bound<'py, PyAny>>,
    theta_s: Option<&Bound<'py, PyAny>>,
    n: f64,
    hwhm: Option<f64>,
    sigma: Option<f64>,
    rms_tilt: Option<f64>,
    distribution: Option<&Bound<'py, PyAny>>,
    aperture: f64,
    transmission: &str,
    weighting: &str,
    clearcoat: bool,
    flake_index: Option<(f64, f64)>,
) -> PyResult<Bound<'py, PyDict>> {
    let kind = kind_of(py, measured_kind)?;
    let coat = coating(py, n, flake_index)?;
    let set = settings(py, transmission, weighting, clearcoat)?;
    let aperture_rad = aperture_rad(py, aperture)?;
    let orientation = crate::convert::orientation(py, hwhm, sigma, rms_tilt, distribution)?;
    let curve = selected(py, measured, theta_i, theta_s)?;
    let results = released(py, || {
        let model = |ti: f64, ts: &[f64]| {
            distribution_points(&coat, &set, aperture_rad, &orientation, ti, ts)
        };
        facade_compare(&curve, kind, &model)
    })?
    .map_err(|e| to_py(py, Kind::Input, &e))?;
    comparison_dict(py, &results)
}

/// The aperture keyword in radians, in [0, 20] degrees.
fn aperture_rad(py: Python<'_>, aperture: f64) -> PyResult<f64> {
    if !(aperture.is_finite() && (0.0..=20.0).contains(&aperture)) {
        return Err(input(
            py,
            format!("aperture={aperture}: expected a half-angle in [0, 20] degrees"),
        ));
    }
    Ok(aperture.to_radians())
}

fn comparison_dict<'py>(
    py: Python<'py>,
    results: &[IncidenceComparison],
) -> PyResult<Bound<'py, PyDict>> {
    let pts: Vec<_> = results.iter().flat_map(|c| c.points.iter()).collect();
    let without: Vec<String> = pts
        .iter()
        .filter(|p| !p.residual.is_finite())
        .map(|p| {
            format!(
                "θi {} θs {}",
                typed_degrees(p.theta_i),
                typed_degrees(p.theta_s)
            )
        })
        .collect();
    if !without.is_empty() {
        warn(
            py,
            &format!(
                "{} measured point(s) have a model value of zero (no light reaches the detector in the model) and are left out of the residuals: {}",
                without.len(),
                without.join(", ")
            ),
        )?;
    }
    let np = py.import("numpy")?;
    let regions = PyList::new(py, pts.iter().map(|p| p.region.name()))?;
    let points = Columns::new(py)
        .f64(
            "theta_i_deg",
            pts.iter().map(|p| typed_degrees(p.theta_i)).collect(),
        )?
        .f64(
            "theta_s_deg",
            pts.iter().map(|p| typed_degrees(p.theta_s)).collect(),
        )?
        .value("region", np.call_method1("array", (regions,))?)?
        .f64("measured", pts.iter().map(|p| p.measured).collect())?
        .f64("model", pts.iter().map(|p| p.model).collect())?
        .f64("residual_log10", pts.iter().map(|p| p.residual).collect())?
        .done();
    let incidences = PyList::empty(py);
    for c in results {
        let d = PyDict::new(py);
        d.set_item("theta_i_deg", typed_degrees(c.theta_i))?;
        d.set_item("scale", c.scale)?;
        let regs = PyList::empty(py);
        for r in &c.regions {
            let rd = PyDict::new(py);
            rd.set_item("region", r.region.name())?;
            rd.set_item("points", r.points)?;
            rd.set_item("points_without_model", r.no_model)?;
            rd.set_item("rms_log10", r.rms_log10)?;
            rd.set_item("mean_log10", r.mean_log10)?;
            regs.append(rd)?;
        }
        d.set_item("regions", regs)?;
        incidences.append(d)?;
    }
    let out = PyDict::new(py);
    out.set_item("points", points)?;
    out.set_item("incidences", incidences)?;
    Ok(out)
}

/// Fits the flake orientation distribution to a measured curve, as `flakescatter fit
/// --json`. Default: a Gaussian p~ — its hwhm with a standard uncertainty, the vertical
/// scale per incidence (or one, `common_scale=True`) and with `fit_n=True` the clear-coat
/// index — by least squares on log values of the points in `region` (aspecular degrees,
/// default (5, 40)). Returns a dict: `hwhm_deg`, `hwhm_std_deg`, `n`, `n_std` (None
/// unless fitted), `scales` (list of (theta_i_deg, scale); theta_i_deg None for a common
/// scale), `chi2`, `dof`, `points`, `iterations`, `uncertainty_basis`,
/// `uncertainty_scale`, `warnings` (also emitted as `FlakescatterWarning`).
///
/// With `nonparametric=True`: a tabulated p~ on `bins` (edges, degrees; default
/// 0, 2, ..., 30) by regularised non-negative least squares with smoothness `lambda_`
/// (the CLI's `--lambda`); returns `theta_lo_deg`, `theta_hi_deg`, `area_fraction`,
/// `p_tilde` arrays (so that the dict can be passed as `distribution=`), `lambda`,
/// `points`, `chi2_relative`.
#[pyfunction]
#[pyo3(signature = (measured, *, measured_kind = "brdf", theta_i = None, theta_s = None, hwhm_start = 4.0, fit_n = false, common_scale = false, region = (5.0, 40.0), nonparametric = false, bins = None, lambda_ = 0.05, n = 1.5, aperture = 1.5, transmission = "exact-unpolarized", weighting = "physical", clearcoat = true, flake_index = None))]
pub fn fit<'py>(
    py: Python<'py>,
    measured: &Bound<'py, PyAny>,
    measured_kind: &str,
    theta_i: Option<&Bound<'py, PyAny>>,
    theta_s: Option<&Bound<'py, PyAny>>,
    hwhm_start: f64,
    fit_n: bool,
    common_scale: bool,
    region: (f64, f64),
    nonparametric: bool,
    bins: Option<&Bound<'py, PyAny>>,
    lambda_: f64,
    n: f64,
    aperture: f64,
    transmission: &str,
    weighting: &str,
    clearcoat: bool,
    flake_index: Option<(f64, f64)>,
) -> PyResult<Bound<'py, PyDict>> {
    let kind = kind_of(py, measured_kind)?;
    let coat = coating(py, n, flake_index)?;
    let set = settings(py, transmission, weighting, clearcoat)?;
    let aperture = aperture_rad(py, aperture)?;
    let (lo, hi) = region;
    if !(lo >= 0.0 && hi > lo && hi < 180.0) {
        return Err(input(
            py,
            format!("region=({lo}, {hi}): expected (LO, HI) in degrees with 0 <= LO < HI < 180"),
        ));
    }
    let mut setup = FitSetup::new(coat, set, aperture, kind);
    setup.region = (lo.to_radians(), hi.to_radians());
    setup.common_scale = common_scale;
    if nonparametric {
        if fit_n {
            return Err(input(
                py,
                "fit_n applies to the Gaussian fit, not nonparametric=True",
            ));
        }
        if !(lambda_.is_finite() && lambda_ >= 0.0) {
            return Err(input(
                py,
                format!("lambda_={lambda_}: expected a finite number >= 0"),
            ));
        }
        let edges = bin_edges(py, bins)?;
        let curve = selected(py, measured, theta_i, theta_s)?;
        let est =
            released(py, || fit_nonparametric(&curve, &setup, &edges, lambda_))?.map_err(|e| {
                raise(
                    py,
                    Kind::Input,
                    format!(
                        "non-parametric fit of {}: {}",
                        curve.file,
                        crate::errors::message(&e)
                    ),
                    None,
                )
            })?;
        let lo: Vec<f64> = est.edges.windows(2).map(|e| typed_degrees(e[0])).collect();
        let hi: Vec<f64> = est.edges.windows(2).map(|e| typed_degrees(e[1])).collect();
        let d = Columns::new(py)
            .f64("theta_lo_deg", lo)?
            .f64("theta_hi_deg", hi)?
            .f64("area_fraction", est.area_fractions.clone())?
            .f64("p_tilde", est.p_tilde.clone())?
            .value("lambda", est.lambda)?
            .value("points", est.points)?
            .value("chi2_relative", est.chi2)?
            .done();
        return Ok(d);
    }
    if !(hwhm_start.is_finite() && hwhm_start > 0.0 && hwhm_start < 60.0) {
        return Err(input(
            py,
            format!("hwhm_start={hwhm_start}: expected a width in (0, 60) degrees"),
        ));
    }
    let curve = selected(py, measured, theta_i, theta_s)?;
    let g = released(py, || {
        fit_gaussian(&curve, &setup, hwhm_start.to_radians(), fit_n)
    })?
    .map_err(|e| {
        raise(
            py,
            Kind::Input,
            format!(
                "Gaussian fit of {}: {}",
                curve.file,
                crate::errors::message(&e)
            ),
            None,
        )
    })?;
    for w in &g.warnings {
        warn(py, &format!("{}: {w}", curve.file))?;
    }
    gaussian_dict(py, &g)
}

/// The bin edges of a non-parametric fit, radians, from `bins` (degrees; default 0, 2,
/// ..., 30): at most 1000 bins, increasing edges within [0, 90] degrees.
fn bin_edges(py: Python<'_>, bins: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<f64>> {
    let edges_deg = match bins {
        Some(b) => floats(py, "bins", b)?,
        None => (0..=15).map(|k| 2.0 * f64::from(k)).collect(),
    };
    if edges_deg.len() > 1001 {
        return Err(input(
            py,
            format!(
                "bins: {} bins is more than the limit of 1000",
                edges_deg.len() - 1
            ),
        ));
    }
    if edges_deg.len() < 2
        || edges_deg.windows(2).any(|w| !(w[1] > w[0]))
        || !(edges_deg[0] >= 0.0)
        || !(edges_deg[edges_deg.len() - 1] <= 90.0)
    {
        return Err(input(
            py,
            "bins: expected at least two increasing edges within [0, 90] degrees",
        ));
    }
    Ok(edges_deg.iter().map(|d| d.to_radians()).collect())
}

/// The dict of a Gaussian fit (see [`fit`]).
fn gaussian_dict<'py>(py: Python<'py>, g: &GaussianFit) -> PyResult<Bound<'py, PyDict>> {
    let scales = PyList::empty(py);
    for (t, s) in &g.scales {
        scales.append((
            if t.is_nan() {
                None
            } else {
                Some(typed_degrees(*t))
            },
            *s,
        ))?;
    }
    let d = PyDict::new(py);
    d.set_item("hwhm_deg", g.hwhm.to_degrees())?;
    d.set_item("hwhm_std_deg", g.hwhm_std.to_degrees())?;
    d.set_item("n", g.n)?;
    d.set_item("n_std", g.n_std)?;
    d.set_item("scales", scales)?;
    d.set_item("chi2", g.chi2)?;
    d.set_item("dof", g.dof)?;
    d.set_item("points", g.points)?;
    d.set_item("iterations", g.iterations)?;
    d.set_item("uncertainty_basis", g.uncertainty_basis.describe())?;
    d.set_item("uncertainty_scale", g.uncertainty_scale)?;
    d.set_item(
        "warnings",
        g.warnings
            .iter()
            .map(ToString::to_string)
            .collect::<Vec<_>>(),
    )?;
    Ok(d)
}
