//! Real paints: the joint fit of a paint to a measured BRDF table (`fit --paint`) and a
//! fitted paint's BRDF per channel (`model --params`).

use flakescatter::compare::MeasuredKind;
use flakescatter::paint::file::ParamsFile;
use flakescatter::paint::report::{fit_and_report, worst_ratio};
use flakescatter::paint::{Family, FitExtras, FitOptions, Selection, paint_curves};
use flakescatter::paint_model::{FlakeMetal, PaintModel};
use flakescatter::{DetectorSet, Instrument};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{Columns, floats, path_of};
use crate::errors::{Kind, input, raise, released, warn};

/// A JSON value as Python objects (through the standard `json` module).
fn to_python<'py>(py: Python<'py>, v: &serde_json::Value) -> PyResult<Bound<'py, PyAny>> {
    // Keys sorted, whatever serde_json's `preserve_order` (turned on by zarrs) keeps.
    let mut v = v.clone();
    v.sort_all_objects();
    let text = serde_json::to_string(&v).map_err(|e| input(py, e.to_string()))?;
    py.import("json")?.call_method1("loads", (text,))
}

/// The flakes of `fit_paint`'s keywords: a stack (`flake_stack`, `flake_core`, piled
/// `flake_layers` deep) or a metal (`flake_index`, else aluminium).
fn flakes(
    py: Python<'_>,
    flake_index: Option<(f64, f64)>,
    flake_stack: Option<&str>,
    flake_core: Option<&str>,
    flake_layers: Option<i64>,
) -> PyResult<FlakeMetal> {
    let flake_metal = match (flake_stack, flake_index) {
        (Some(_), Some(_)) => {
            return Err(input(
                py,
                "flake_stack and flake_index: give one (the flakes are a stack or a metal)",
            ));
        }
        (Some(stack), None) => {
            flakescatter::paint::stack_flakes(stack, flake_core).map_err(|e| {
                let key = match e {
                    flakescatter::film::StackFlakeError::Core(_) => "flake_core",
                    _ => "flake_stack",
                };
                input(py, format!("{key}: {e}"))
            })?
        }
        (None, _) if flake_core.is_some() => {
            return Err(input(py, "flake_core needs flake_stack"));
        }
        (None, Some((n, k))) => FlakeMetal::Index { n, k },
        (None, None) => FlakeMetal::Aluminium,
    };
    Ok(match flake_layers {
        None => flake_metal,
        Some(l) => {
            let layers = u32::try_from(l)
                .ok()
                .filter(|l| (1..=1000).contains(l))
                .ok_or_else(|| {
                    input(
                        py,
                        format!("flake_layers={l}: expected a whole number from 1 to 1000"),
                    )
                })?;
            if !matches!(&flake_metal, FlakeMetal::Stack(s) if s.core.is_none()) {
                return Err(input(
                    py,
                    "flake_layers needs free interference flakes (flake_stack=... without flake_core)",
                ));
            }
            flake_metal
                .with_layers(layers)
                .map_err(|e| input(py, format!("flake_layers: {e}")))?
        }
    })
}

/// Fit a paint (clear coat, flakes, base; physics.md §12) to the BRDF table `measured`
/// (a CSV path with `theta_i_deg, theta_r_deg, phi_r_deg, brdf_<channel>_per_sr`), as
/// `flakescatter fit --paint`. Returns a dict: `fit` (the report: family, evidence,
/// parameters with 95 % intervals, correlations, residual groups, warnings), `params`
/// (the parameter file `paint_brdf` takes), `worst_ratio` (worst group rms / target),
/// and `points` (columns `theta_i_deg, theta_r_deg, phi_r_deg, channel, measured,
/// model`). Warnings are also emitted as `FlakescatterWarning`. Interference flakes:
/// `flake_stack` (and `flake_core`) as `--flake-stack`/`--flake-core`, with
/// `fit_thickness` (layer numbers from 1) and `thickness_range_nm` as `--fit-thickness`
/// and `--thickness-range`; `flake_layers` (1–1000, free stacks only) piles the flakes
/// that deep, as `--flake-layers` (physics.md §12.8); `fit_flake_layers=True` fits that
/// number instead, as `--fit-flake-layers`: the whole fit at every N from 1 to 16, the
/// lowest χ² kept, `fit` then holding `flake_layers` (the N kept) and
/// `flake_layers_scan` (`layers`, and `chi2` at each, `None` where that fit failed); it
/// needs a free stack and no `flake_layers` (`InputError` otherwise) and takes 16 fits'
/// time. `channel_band_nm` (a stack only, in (0, 400]) averages the flakes over a
/// Gaussian band of that full width at half maximum about each channel's wavelength, as
/// `--channel-band` (physics.md §12.7, "Channels with a band"). `fit_tint=True` fits
/// the binder's tint over the flakes too (per channel its optical depth, the `tint <c>`
/// parameters), as `--fit-tint` (physics.md §12.9).
#[pyfunction]
#[pyo3(signature = (measured, *, family = "auto", coverage = None, n = 1.5, fit_n = false, region = (2.0, 180.0), max_theta_r = None, min_value = None, haze = true, smoothing = 0.01, flake_index = None, flake_stack = None, flake_core = None, fit_thickness = None, thickness_range_nm = (10.0, 600.0), flake_layers = None, fit_flake_layers = false, channel_band_nm = None, fit_tint = false))]
#[allow(clippy::too_many_arguments)]
pub fn fit_paint<'py>(
    py: Python<'py>,
    measured: &Bound<'py, PyAny>,
    family: &str,
    coverage: Option<f64>,
    n: f64,
    fit_n: bool,
    region: (f64, f64),
    max_theta_r: Option<f64>,
    min_value: Option<f64>,
    haze: bool,
    smoothing: f64,
    flake_index: Option<(f64, f64)>,
    flake_stack: Option<&str>,
    flake_core: Option<&str>,
    fit_thickness: Option<Vec<usize>>,
    thickness_range_nm: (f64, f64),
    flake_layers: Option<i64>,
    fit_flake_layers: bool,
    channel_band_nm: Option<f64>,
    fit_tint: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let path = path_of(py, "measured", measured)?;
    let families =
        Family::choice(family).map_err(|e| input(py, format!("family={family:?}: {e}")))?;
    let (lo, hi) = region;
    if !(lo >= 0.0 && hi > lo && hi <= 180.0) {
        return Err(input(
            py,
            format!("region=({lo}, {hi}): expected (LO, HI) in degrees with 0 <= LO < HI <= 180"),
        ));
    }
    let mut selection = Selection {
        aspecular: (lo.to_radians(), hi.to_radians()),
        ..Selection::default()
    };
    if let Some(t) = max_theta_r {
        if !(t > 0.0 && t <= 90.0) {
            return Err(input(
                py,
                format!("max_theta_r={t}: expected (0, 90] degrees"),
            ));
        }
        selection.max_theta_r = t.to_radians();
    }
    if let Some(v) = min_value {
        if !(v.is_finite() && v >= 0.0) {
            return Err(input(
                py,
                format!("min_value={v}: expected a BRDF >= 0 (1/sr)"),
            ));
        }
        selection.min_value = v;
    }
    flakescatter::checks::coat_index(n).map_err(|e| input(py, format!("n={e}")))?;
    let flake_metal = flakes(py, flake_index, flake_stack, flake_core, flake_layers)?
        .with_band(channel_band_nm)
        .map_err(|e| input(py, format!("channel_band_nm: {e}")))?;
    if fit_flake_layers {
        if let Some(l) = flake_layers {
            return Err(input(
                py,
                format!(
                    "fit_flake_layers=True and flake_layers={l}: give one (the number of flake layers is fitted or given)"
                ),
            ));
        }
        if !matches!(&flake_metal, FlakeMetal::Stack(s) if s.core.is_none()) {
            return Err(input(
                py,
                "fit_flake_layers=True needs free interference flakes (flake_stack=... without flake_core): a pile of flakes that transmit nothing is the top flake itself",
            ));
        }
    }
    let thickness = match fit_thickness {
        None => None,
        Some(layers) => {
            let t = flakescatter::paint::ThicknessFit {
                layers,
                range_nm: thickness_range_nm,
            };
            if !matches!(flake_metal, FlakeMetal::Stack(_)) {
                return Err(input(
                    py,
                    "fit_thickness needs interference flakes (flake_stack=...)",
                ));
            }
            Some(t)
        }
    };
    let opts = FitOptions {
        families,
        n,
        fit_n,
        coverage,
        flake_metal,
        selection,
        haze,
        smoothing,
        thickness,
    };
    let (m, fit, report) = released(py, || {
        let m = flakescatter::paint::read_measurement(&path, MeasuredKind::Brdf)?;
        let (fit, report) =
            fit_and_report(&m, &opts, FitExtras { tint: fit_tint }, fit_flake_layers)?;
        Ok::<_, flakescatter::PipelineError>((m, fit, report))
    })?
    .map_err(|e| raise(py, Kind::Input, crate::errors::message(&e), None))?;
    for w in &fit.warnings {
        warn(py, &format!("{}: {w}", m.file))?;
    }
    let params = ParamsFile::new(&fit.params, None);
    let params_value = serde_json::to_value(&params).map_err(|e| input(py, e.to_string()))?;
    let rows: Vec<_> = fit.points.iter().map(|p| &m.rows[p.row]).collect();
    let points = Columns::new(py)
        .f64(
            "theta_i_deg",
            rows.iter().map(|o| o.theta_i.to_degrees()).collect(),
        )?
        .f64(
            "theta_r_deg",
            rows.iter().map(|o| o.theta_r.to_degrees()).collect(),
        )?
        .f64(
            "phi_r_deg",
            rows.iter().map(|o| o.phi_r.to_degrees()).collect(),
        )?
        .value(
            "channel",
            fit.points
                .iter()
                .map(|p| m.channels[p.channel].name.clone())
                .collect::<Vec<_>>(),
        )?
        .f64("measured", fit.points.iter().map(|p| p.value).collect())?
        .f64("model", fit.model.clone())?
        .done();
    let d = PyDict::new(py);
    d.set_item("fit", to_python(py, &report)?)?;
    d.set_item("params", to_python(py, &params_value)?)?;
    d.set_item("worst_ratio", worst_ratio(&fit.groups))?;
    d.set_item("points", points)?;
    Ok(d)
}

/// A paint's BRDF per channel (as `flakescatter model --params`): `params` is the
/// parameter file (a path, or the dict `fit_paint` returns as `params`); rows are every
/// incidence of `theta_i` (degrees) × every detector `(theta_r, phi_r)` (degrees,
/// `phi_r = 0` the specular half-plane), averaged over cones of half-angle `aperture`
/// (degrees; 0: point BRDF). Returns columns `theta_i_deg, theta_r_deg, phi_r_deg` and
/// `brdf_<channel>_per_sr` (sr⁻¹).
#[pyfunction]
#[pyo3(signature = (params, theta_i, theta_r, phi_r, *, aperture = 0.0))]
pub fn paint_brdf<'py>(
    py: Python<'py>,
    params: &Bound<'py, PyAny>,
    theta_i: &Bound<'py, PyAny>,
    theta_r: &Bound<'py, PyAny>,
    phi_r: &Bound<'py, PyAny>,
    aperture: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let paint = if let Ok(d) = params.cast::<PyDict>() {
        let text: String = py.import("json")?.call_method1("dumps", (d,))?.extract()?;
        let file: ParamsFile = serde_json::from_str(&text)
            .map_err(|e| input(py, format!("params: not a paint parameter dict ({e})")))?;
        file.to_params("params")
            .map_err(|e| raise(py, Kind::Input, crate::errors::message(&e), None))?
    } else {
        let path = path_of(py, "params", params)?;
        flakescatter::paint::file::read_params(&path)
            .map_err(|e| raise(py, Kind::Input, crate::errors::message(&e), None))?
    };
    let model = PaintModel::new(paint).map_err(|e| input(py, e.to_string()))?;
    let ti = floats(py, "theta_i", theta_i)?;
    let tr = floats(py, "theta_r", theta_r)?;
    let pr = floats(py, "phi_r", phi_r)?;
    if tr.len() != pr.len() {
        return Err(input(
            py,
            format!(
                "theta_r has {} values, phi_r {}: give one phi_r per theta_r",
                tr.len(),
                pr.len()
            ),
        ));
    }
    if !(aperture.is_finite() && (0.0..=20.0).contains(&aperture)) {
        return Err(input(
            py,
            format!("aperture={aperture}: expected [0, 20] degrees"),
        ));
    }
    let instrument = Instrument::new(
        ti.iter().map(|d| d.to_radians()).collect(),
        DetectorSet::OutOfPlane(
            tr.iter()
                .zip(&pr)
                .map(|(a, b)| (a.to_radians(), b.to_radians()))
                .collect(),
        ),
        aperture.to_radians(),
    )
    .map_err(|e| input(py, e.to_string()))?;
    let curves = released(py, || paint_curves(&model, &instrument))?
        .map_err(|e| raise(py, Kind::Input, crate::errors::message(&e), None))?;
    let nd = tr.len();
    let mut cols = Columns::new(py)
        .f64(
            "theta_i_deg",
            (0..curves.rows.len()).map(|k| ti[k / nd]).collect(),
        )?
        .f64(
            "theta_r_deg",
            (0..curves.rows.len()).map(|k| tr[k % nd]).collect(),
        )?
        .f64(
            "phi_r_deg",
            (0..curves.rows.len()).map(|k| pr[k % nd]).collect(),
        )?;
    for (c, name) in curves.channels.iter().enumerate() {
        cols = cols.f64(
            &format!("brdf_{name}_per_sr"),
            curves.rows.iter().map(|r| r.brdf[c]).collect(),
        )?;
    }
    Ok(cols.done())
}
