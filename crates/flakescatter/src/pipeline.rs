//! The composition the layers cannot own: a coating, an instrument and a source of
//! flake orientations turned into reflectance curves with units and metadata.
//!
//! Conventions: radians in, radians out; reflectances are fractions of the incident
//! beam power, BRDFs per steradian; `relative` is normalised to the same detector at the
//! specular direction (physics.md §4).

use flakescatter_gaussian::{BaseLoop, ConeMethod, DistributionModel, ModelError, ModelOptions};
use flakescatter_optics::absorption::PathAbsorption;
use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_optics::polarization::{Transmission, Weighting};
use flakescatter_stats::heightmap::HeightMap;
use flakescatter_stats::histogram::AreaHistogram;
use flakescatter_stats::{Flake, Orientation};
use flakescatter_topo::{IsotropicOptions, IsotropicResult, TopoModel, TopoOptions, TopoResult};

use crate::PipelineError;
use crate::instrument::Instrument;
use crate::topo_base;

/// The coating: clear-coat index and flake reflectance.
#[derive(Debug, Clone, PartialEq)]
pub struct Coating {
    /// Clear-coat refractive index (real, ≥ 1; default 1.5).
    pub n: f64,
    /// Flake reflectance (default perfect conductor, the paper's assumption).
    pub flake: FlakeReflectance,
}

impl Coating {
    /// A coating whose clear-coat index is checked (finite, ≥ 1): the one constructor
    /// the command line, Python and the `analyze` manifest use (a caller names its own
    /// setting in front of the message).
    ///
    /// # Errors
    /// [`crate::checks::SettingError::CoatIndex`].
    pub fn new(n: f64, flake: FlakeReflectance) -> Result<Self, crate::checks::SettingError> {
        Ok(Self {
            n: crate::checks::coat_index(n)?,
            flake,
        })
    }
}

impl Default for Coating {
    fn default() -> Self {
        Self {
            n: 1.5,
            flake: FlakeReflectance::PerfectConductor,
        }
    }
}

/// How the models weight and combine Fresnel factors, and whether the clear coat's own
/// reflection is included (physics.md §4–§6).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Settings {
    /// Fresnel bookkeeping (default `exact-unpolarized`).
    pub transmission: Transmission,
    /// Ray weighting (default `physical`).
    pub weighting: Weighting,
    /// Add the clear coat's specular reflection (default off).
    pub clearcoat: bool,
    /// Cone integration of the distribution model (default exact).
    pub cone_method: ConeMethod,
    /// Albedo `ρ ∈ [0, 1]` of a Lambertian base under the flakes of the distribution
    /// model (physics.md §13): only with thin-film flakes without a core, which transmit
    /// light down to it. Default 0, a black base (the model without it, to the bit).
    /// The topographic and Mueller paths refuse a non-zero value.
    pub base_albedo: f64,
}

/// Where flake orientations come from for the distribution model.
#[derive(Debug, Clone)]
pub enum OrientationSource {
    /// A distribution given directly (Gaussian, tabulated, flat).
    Distribution(Orientation),
    /// A measured flake table, binned into an area-weighted histogram of this bin
    /// width (radians) and used as a tabulated distribution.
    Flakes {
        /// The flakes.
        flakes: Vec<Flake>,
        /// Histogram bin width, radians.
        bin_width: f64,
    },
}

impl OrientationSource {
    /// The orientation distribution this source stands for.
    ///
    /// # Errors
    /// [`PipelineError::Orientation`] when a flake table cannot be binned.
    pub fn orientation(&self) -> Result<Orientation, PipelineError> {
        match self {
            Self::Distribution(o) => Ok(o.clone()),
            Self::Flakes { flakes, bin_width } => AreaHistogram::from_flakes(flakes, *bin_width)
                .and_then(|h| h.to_orientation())
                .map_err(|e| PipelineError::Orientation(e.to_string())),
        }
    }
}

/// One row of a curve: one incidence × one detector.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurveRow {
    /// Incidence angle, radians.
    pub theta_i: f64,
    /// Index of the detector in the instrument's list.
    pub detector: usize,
    /// Cone-averaged BRDF, sr⁻¹ (the point BRDF for aperture 0).
    pub brdf: f64,
    /// Fraction of the incident beam collected; `None` for point detectors.
    pub reflectance: Option<f64>,
    /// Collected power relative to the same detector at the specular direction.
    pub relative: f64,
    /// Rays counted (topographic model only).
    pub rays: Option<u64>,
    /// Standard error of `brdf` (topographic model: from tiles of the map;
    /// distribution model: the quadrature's error estimate).
    pub std_err: Option<f64>,
}

/// Reflectance curves with what they were computed from.
#[derive(Debug, Clone)]
pub struct Curves {
    /// Which model produced them (`distribution` or `topographic`).
    pub model: &'static str,
    /// The instrument.
    pub instrument: Instrument,
    /// The coating.
    pub coating: Coating,
    /// The settings.
    pub settings: Settings,
    /// Rows, ordered by incidence then detector.
    pub rows: Vec<CurveRow>,
    /// Free-form description of the orientation source, for metadata.
    pub source: String,
}

/// The distribution model for a coating, settings and orientation distribution.
///
/// # Errors
/// [`PipelineError::Model`] for an invalid index or flake index.
pub fn distribution_model(
    coating: &Coating,
    settings: &Settings,
    orientation: Orientation,
) -> Result<DistributionModel, PipelineError> {
    distribution_model_with(coating, settings, orientation, None)
}

/// [`distribution_model`] with the binder's absorption when `absorption` is given, and
/// the base under the flakes of [`Settings::base_albedo`] (physics.md §13) when it is
/// not 0.
fn distribution_model_with(
    coating: &Coating,
    settings: &Settings,
    orientation: Orientation,
    absorption: Option<PathAbsorption>,
) -> Result<DistributionModel, PipelineError> {
    let mut model = DistributionModel::new(
        orientation,
        coating.n,
        ModelOptions {
            transmission: settings.transmission,
            weighting: settings.weighting,
            flake: coating.flake.clone(),
            clearcoat: settings.clearcoat,
            exit_fresnel: true,
        },
    )?;
    if let Some(a) = absorption {
        model = model.with_absorption(a);
    }
    if settings.base_albedo != 0.0 {
        model = model.with_base(settings.base_albedo, BaseLoop::Included)?;
    }
    Ok(model)
}

/// The distribution model (physics.md §4) for `source` seen by `instrument`.
///
/// # Errors
/// [`PipelineError::Model`] for an invalid coating, [`PipelineError::Orientation`] for a
/// source that gives no distribution.
pub fn distribution_curves(
    coating: &Coating,
    instrument: &Instrument,
    settings: &Settings,
    source: &OrientationSource,
) -> Result<Curves, PipelineError> {
    distribution_curves_of(coating, instrument, settings, source.orientation()?, None)
}

/// The rows of [`distribution_curves`], bit for bit, handed to `each` one incidence at a
/// time as they are computed (one row per detector, in order), so that a large grid is
/// never held whole: for writing a table as it is computed. Every error of the model
/// comes before the first call of `each`; `each`'s own first error ends the run and is
/// returned.
///
/// # Errors
/// Those of [`distribution_curves`], and the first of `each`.
pub fn distribution_rows<E: From<PipelineError>>(
    coating: &Coating,
    instrument: &Instrument,
    settings: &Settings,
    source: &OrientationSource,
    each: impl FnMut(&[CurveRow]) -> Result<(), E>,
) -> Result<(), E> {
    let orientation = source.orientation()?;
    let model = distribution_model(coating, settings, orientation)?;
    curve_rows(&model, instrument, settings, each)
}

/// [`distribution_curves`] for an orientation distribution, with the binder's absorption
/// along each ray's path when `absorption` is given (physics.md §8.1; `None` is exactly
/// [`distribution_curves`]).
pub(crate) fn distribution_curves_of(
    coating: &Coating,
    instrument: &Instrument,
    settings: &Settings,
    orientation: Orientation,
    absorption: Option<PathAbsorption>,
) -> Result<Curves, PipelineError> {
    let description = describe(&orientation);
    let model = distribution_model_with(coating, settings, orientation, absorption)?;
    let mut rows = Vec::with_capacity(
        instrument
            .theta_i()
            .len()
            .saturating_mul(instrument.cones().len()),
    );
    curve_rows(&model, instrument, settings, |block| {
        rows.extend_from_slice(block);
        Ok::<(), PipelineError>(())
    })?;
    Ok(Curves {
        model: "distribution",
        instrument: instrument.clone(),
        coating: coating.clone(),
        settings: *settings,
        rows,
        source: description,
    })
}

/// The model's curve over `instrument` as [`CurveRow`]s, one incidence at a time
/// (`flakescatter_gaussian::curve_each`: the model's errors before any row).
fn curve_rows<E: From<PipelineError>>(
    model: &DistributionModel,
    instrument: &Instrument,
    settings: &Settings,
    mut each: impl FnMut(&[CurveRow]) -> Result<(), E>,
) -> Result<(), E> {
    /// The model's error or `each`'s, told apart.
    enum Failed<E> {
        Model(ModelError),
        Each(E),
    }
    impl<E> From<ModelError> for Failed<E> {
        fn from(e: ModelError) -> Self {
            Self::Model(e)
        }
    }
    let exact = settings.cone_method == ConeMethod::Exact;
    let mut rows = Vec::with_capacity(instrument.cones().len());
    flakescatter_gaussian::curve_each(
        model,
        instrument.theta_i(),
        instrument.cones(),
        settings.cone_method,
        |points| {
            rows.clear();
            rows.extend(points.iter().enumerate().map(|(j, p)| {
                let c = &p.collected;
                let std_err = match c.reflectance {
                    Some(rho) if rho > 0.0 => Some(c.error * c.brdf / rho),
                    Some(_) => Some(0.0),
                    None => Some(c.error),
                };
                CurveRow {
                    theta_i: p.theta_i,
                    detector: j,
                    brdf: c.brdf,
                    reflectance: c.reflectance,
                    relative: p.relative,
                    rays: None,
                    std_err: if exact { std_err } else { None },
                }
            }));
            each(&rows).map_err(Failed::Each)
        },
    )
    .map_err(|e| match e {
        Failed::Model(e) => E::from(PipelineError::Model(e)),
        Failed::Each(e) => e,
    })
}

/// Refuses [`Settings::base_albedo`] for the topographic paths that keep a black base
/// under the flakes: the isotropic, streamed, split and Mueller runs (physics.md §13;
/// the plain in-memory run adds the base, [`crate::topo_base`]).
///
/// # Errors
/// [`PipelineError::Spectral`] for a non-zero albedo.
pub(crate) fn check_black_base(settings: &Settings) -> Result<(), PipelineError> {
    if settings.base_albedo != 0.0 {
        return Err(PipelineError::Spectral(
            "base albedo: a reflecting base under the flakes is modelled by the distribution model and by the plain topographic model over maps in memory; the isotropic, streamed, split and Mueller topographic runs keep a black base (physics.md §13)".into(),
        ));
    }
    Ok(())
}

/// Options of the topographic model that are not instrument or coating settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TopoSettings {
    /// Least-squares window, odd, ≥ 3 pixels (default 5: the paper's 5 × 5).
    pub window: usize,
    /// Side of the map tiles whose spread gives the standard errors, µm (default 32).
    pub tile_um: f64,
}

impl Default for TopoSettings {
    fn default() -> Self {
        Self {
            window: 5,
            tile_um: flakescatter_topo::DEFAULT_BLOCK_UM,
        }
    }
}

/// The topographic model (physics.md §5) over `maps` (their masks already holding any
/// intensity cutoff), accumulated into one result. `progress(done, total)` is called
/// from the calling thread as tiles finish. Returns the curves (with `rays` and
/// `std_err` per row) and the model's own totals (pixels, usable pixels, rays traced and
/// lost).
///
/// # Errors
/// [`PipelineError::Topo`] for invalid options or maps (no usable pixel, window too
/// large, ...); [`PipelineError::Instrument`] for point detectors (aperture 0), which
/// rays cannot enter.
pub fn topographic_curves(
    coating: &Coating,
    instrument: &Instrument,
    settings: &Settings,
    topo: &TopoSettings,
    maps: &[&HeightMap],
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<(Curves, TopoResult), PipelineError> {
    topographic_curves_of(
        coating, None, instrument, settings, topo, maps, None, progress,
    )
}

/// [`topographic_curves`] with the binder's absorption along each ray's path when
/// `absorption` is given (physics.md §8.1; `None` is exactly [`topographic_curves`]).
///
/// A non-zero [`Settings::base_albedo`] adds the base under the flakes (physics.md §13,
/// module [`crate::topo_base`]) from `base` when given (computed once for several
/// wavelengths, on the run's tiles), else from the maps.
#[allow(clippy::too_many_arguments)]
pub(crate) fn topographic_curves_of(
    coating: &Coating,
    absorption: Option<PathAbsorption>,
    instrument: &Instrument,
    settings: &Settings,
    topo: &TopoSettings,
    maps: &[&HeightMap],
    base: Option<&topo_base::MapBase>,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<(Curves, TopoResult), PipelineError> {
    if instrument.aperture() <= 0.0 {
        return Err(PipelineError::Instrument(
            "the topographic model counts rays into detector cones: the aperture must be > 0"
                .into(),
        ));
    }
    let mut model = any_base_model(coating, settings, topo)?;
    if let Some(a) = absorption {
        model = model.with_absorption(a);
    }
    let own;
    let map = match base {
        Some(b) => Some(b),
        None => {
            own = topo_base::map_base(&model, settings.base_albedo, maps)?;
            own.as_ref()
        }
    };
    let base = map
        .filter(|_| settings.base_albedo != 0.0)
        .map(|m| {
            let options = ModelOptions {
                transmission: settings.transmission,
                weighting: settings.weighting,
                flake: coating.flake.clone(),
                clearcoat: false,
                exit_fresnel: true,
            };
            topo_base::BaseTerm::new(m, settings.base_albedo, coating.n, options, absorption)
        })
        .transpose()?;
    let mut result =
        model.run_with_progress(maps, instrument.theta_i(), instrument.cones(), progress)?;
    let Some(base) = base else {
        return Ok((plain_curves(coating, instrument, settings, &result), result));
    };
    base.add_to(&mut result)?;
    let mut curves = plain_curves(coating, instrument, settings, &result);
    curves.source = format!("{}, {}", curves.source, topo_base::describe(base.share()));
    Ok((curves, result))
}

/// What the base term of [`Settings::base_albedo`] needs of `maps` (on the statistics
/// tiles of the topographic runs it is added to), to be computed once for the runs at
/// several wavelengths; `None` for a black base.
///
/// # Errors
/// [`PipelineError::Topo`] for invalid options or maps.
pub(crate) fn topo_map_base(
    coating: &Coating,
    settings: &Settings,
    topo: &TopoSettings,
    maps: &[&HeightMap],
) -> Result<Option<topo_base::MapBase>, PipelineError> {
    if settings.base_albedo == 0.0 {
        return Ok(None);
    }
    topo_base::map_base(
        &any_base_model(coating, settings, topo)?,
        settings.base_albedo,
        maps,
    )
}

/// The model of [`topographic_curves`] and [`crate::streaming`]'s plain runs.
///
/// # Errors
/// [`PipelineError::Instrument`] for point detectors, [`PipelineError::Topo`] for
/// invalid options.
pub(crate) fn plain_model(
    coating: &Coating,
    instrument: &Instrument,
    settings: &Settings,
    topo: &TopoSettings,
) -> Result<TopoModel, PipelineError> {
    if instrument.aperture() <= 0.0 {
        return Err(PipelineError::Instrument(
            "the topographic model counts rays into detector cones: the aperture must be > 0"
                .into(),
        ));
    }
    topo_model(coating, settings, topo)
}

/// The curves of a plain topographic result.
pub(crate) fn plain_curves(
    coating: &Coating,
    instrument: &Instrument,
    settings: &Settings,
    result: &TopoResult,
) -> Curves {
    let nd = instrument.cones().len();
    let rows = result
        .points
        .iter()
        .enumerate()
        .map(|(k, p)| CurveRow {
            theta_i: p.theta_i,
            detector: k % nd,
            brdf: p.brdf,
            reflectance: Some(p.reflectance),
            relative: p.relative,
            rays: Some(p.rays),
            std_err: p.brdf_std_err,
        })
        .collect();
    Curves {
        model: "topographic",
        instrument: instrument.clone(),
        coating: coating.clone(),
        settings: *settings,
        rows,
        source: format!(
            "{} height map(s), {} usable of {} pixels",
            result.maps, result.usable_pixels, result.pixels
        ),
    }
}

/// The topographic model averaged over the sample's rotation about its normal
/// (physics.md §5.1) over `maps`, accumulated into one result: every pixel's ring of
/// exit directions, exactly, instead of one ray. `node_spacing` is the spacing of the
/// tilt nodes of its table (radians; `None` for the smallest aperture / 128).
/// `progress(done, total)` is called from the calling thread as tiles finish. Returns
/// the curves (`rays` = pixels whose ring meets the cone, `std_err` from tiles as in
/// [`topographic_curves`]) and the model's result, which also holds each row's
/// interpolation error estimate (`interpolation_error`, reflectance units), the ring
/// losses and the table size.
///
/// # Errors
/// As [`topographic_curves`], and [`PipelineError::Topo`] for an invalid node spacing.
pub fn isotropic_curves(
    coating: &Coating,
    instrument: &Instrument,
    settings: &Settings,
    topo: &TopoSettings,
    node_spacing: Option<f64>,
    maps: &[&HeightMap],
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<(Curves, IsotropicResult), PipelineError> {
    if instrument.aperture() <= 0.0 {
        return Err(PipelineError::Instrument(
            "the topographic model counts rays into detector cones: the aperture must be > 0"
                .into(),
        ));
    }
    let model = topo_model(coating, settings, topo)?;
    let result = model.run_isotropic_with(
        maps,
        instrument.theta_i(),
        instrument.cones(),
        &IsotropicOptions { node_spacing },
        progress,
    )?;
    Ok((
        isotropic_curves_of(coating, instrument, settings, &result),
        result,
    ))
}

/// The curves of an isotropic result.
pub(crate) fn isotropic_curves_of(
    coating: &Coating,
    instrument: &Instrument,
    settings: &Settings,
    result: &IsotropicResult,
) -> Curves {
    let nd = instrument.cones().len();
    let rows = result
        .points
        .iter()
        .enumerate()
        .map(|(k, p)| CurveRow {
            theta_i: p.theta_i,
            detector: k % nd,
            brdf: p.brdf,
            reflectance: Some(p.reflectance),
            relative: p.relative,
            rays: Some(p.rays),
            std_err: p.brdf_std_err,
        })
        .collect();
    Curves {
        model: "topographic-isotropic",
        instrument: instrument.clone(),
        coating: coating.clone(),
        settings: *settings,
        rows,
        source: format!(
            "{} height map(s), {} usable of {} pixels, averaged over the sample's rotation",
            result.maps, result.usable_pixels, result.pixels
        ),
    }
}

/// The topographic model for a coating, settings and topographic options.
///
/// # Errors
/// [`PipelineError::Topo`] for invalid options; [`PipelineError::Spectral`] for a
/// non-zero [`Settings::base_albedo`] (the topographic model's base is black).
pub fn topo_model(
    coating: &Coating,
    settings: &Settings,
    topo: &TopoSettings,
) -> Result<TopoModel, PipelineError> {
    check_black_base(settings)?;
    any_base_model(coating, settings, topo)
}

/// The topographic model of [`topo_model`], whatever [`Settings::base_albedo`] (for the
/// paths that add the base themselves).
fn any_base_model(
    coating: &Coating,
    settings: &Settings,
    topo: &TopoSettings,
) -> Result<TopoModel, PipelineError> {
    Ok(TopoModel::new(TopoOptions {
        n: coating.n,
        transmission: settings.transmission,
        weighting: settings.weighting,
        flake: coating.flake.clone(),
        clearcoat: settings.clearcoat,
        window: topo.window,
    })?
    .with_block_um(topo.tile_um)?)
}

/// The orientation distribution drawn about the specular direction, as in the paper's
/// Fig. 4: `p̃(|θs + θi|) / p̃(0)` for the in-plane detector `theta_s` at incidence
/// `theta_i` (radians; the flake tilt is read off as the aspecular angle). NaN when
/// `p̃(0) = 0`.
#[must_use]
pub fn p_tilde_about_specular(orientation: &Orientation, theta_i: f64, theta_s: f64) -> f64 {
    let p0 = orientation.p_tilde(0.0);
    if p0 > 0.0 {
        let aspecular = flakescatter_optics::detector::theta_s_to_aspecular(theta_i, theta_s);
        orientation.p_tilde(aspecular.abs()) / p0
    } else {
        f64::NAN
    }
}

/// A short description of a distribution for metadata (radians).
pub(crate) fn describe(o: &Orientation) -> String {
    if o.is_delta() {
        return "flat (all flake normals along z)".into();
    }
    match o.gaussian_width() {
        Some(w) => format!(
            "gaussian p~ ∝ exp(-θ²/(2s²)), s = {:.6e} rad (hwhm {:.6e} rad)",
            w.sigma(),
            w.hwhm()
        ),
        None => match (o.pearson_vii_params(), o.log_linear_knots()) {
            (Some((alpha, shape)), _) => format!(
                "pearson-vii D ∝ (1 + tan²θ/(γα²))^-(γ+1)/cos⁴θ, alpha = {alpha:.6e}, shape γ = {shape:.6e}"
            ),
            (_, Some((knots, _))) => format!(
                "log-linear p~ on {} knots in [0, {:.6e}] rad",
                knots.len(),
                o.max_theta()
            ),
            _ => format!("tabulated on [0, {:.6e}] rad", o.max_theta()),
        },
    }
}
