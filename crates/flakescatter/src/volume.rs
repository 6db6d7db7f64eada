//! The volume model composed (physics.md, "Volume model"): a coating, an instrument, an
//! orientation source and the layer's settings turned into curves split by scattering
//! history, with the energy balance and what the layer realised.
//!
//! Conventions: radians and micrometres; reflectances are fractions of the incident
//! beam power, BRDFs per steradian averaged over each detector cone; `relative` is the
//! collected power over that of the same aperture at the specular direction (coat
//! reflection included, as a measurement sees it). One seed draws both the layers and
//! the rays (a ChaCha8 stream per layer, a generator per ray), so a run is reproducible
//! from it alone. The rays are shared among [`VolumeSettings::layers`] independent
//! layers, and the standard errors are those of the mean over layers, which include the
//! scatter between layers (crate `volume`, module `layers`).
//!
//! A tinted binder ([`VolumeSettings::binder_alpha_per_um`]) absorbs along every path
//! inside the film (Beer–Lambert), reported as `absorbed_binder` in the energy balance.
//! [`spectral_volume_curves`] runs the model at several wavelengths over the same layers
//! with the same rays (common random numbers): each wavelength's curves are the bits of
//! [`volume_curves`] with that wavelength's coating and absorption.

use flakescatter_optics::dispersion::SpectralTable;
use flakescatter_stats::Orientation;
use flakescatter_volume::{
    LayerParams, LayerSpec, LayeredResult, TraceOptions, run_layers, run_layers_each,
};

pub use flakescatter_volume::{
    Amount, Depth, Diameter, EnergyBalance, LayerStats, MAX_LAYERS, RimRule, Substrate, VolumeError,
};

use crate::PipelineError;
use crate::instrument::Instrument;
use crate::pipeline::{Coating, OrientationSource};
use crate::spectral::SpectralCoating;

/// The layer and tracing settings of [`volume_curves`] (the coating's index and flake
/// reflectance come from [`Coating`]).
#[derive(Debug, Clone, PartialEq)]
pub struct VolumeSettings {
    /// Film thickness, µm (default 38, the paper's film).
    pub film_um: f64,
    /// Flake diameters (default log-normal, mean 16 µm, relative sd 0.25).
    pub diameter: Diameter,
    /// Flake thickness, µm (default 1).
    pub thickness_um: f64,
    /// Pigment amount (default 5 % aluminium by mass, binder 1.2 g/cm³).
    pub amount: Amount,
    /// Centre depths (default the whole film).
    pub depth: Depth,
    /// Side of the periodic tile, µm (default 1000: about 4 300 flakes at the default
    /// loading).
    pub tile_um: f64,
    /// Substrate (default black).
    pub substrate: Substrate,
    /// Rim rule (default absorb).
    pub rims: RimRule,
    /// Rays per incidence in all, shared among the layers (each gets `⌈rays/layers⌉`,
    /// rounded up to whole batches of 64; default 10⁶).
    pub rays: u64,
    /// Independent layers drawn from the seed (default [`DEFAULT_LAYERS`], in
    /// `1..=10000`): their spread gives the between-layer part of the standard errors
    /// (with one layer only the rays' part is known).
    pub layers: u32,
    /// Seed of the layer and the rays (default 1).
    pub seed: u64,
    /// Largest number of interactions per path (default 1000).
    pub max_events: u32,
    /// Weight below which a path ends, its rest tallied as cut-off (default 1e-6).
    pub min_weight: f64,
    /// Napierian absorption coefficient of the binder for intensity, µm⁻¹ (default 0, a
    /// clear binder), applied along every path inside the film.
    pub binder_alpha_per_um: f64,
}

/// Default number of layers: enough for a between-layer spread on 7 degrees of freedom
/// (`t_{0.975} = 2.36`), with the rays of one layer (10⁶/8 per incidence) still many.
pub const DEFAULT_LAYERS: u32 = 8;

impl Default for VolumeSettings {
    fn default() -> Self {
        let spec = LayerSpec::new(flakescatter_stats::Orientation::flat(), 1000.0, 1);
        let trace = TraceOptions::default();
        Self {
            film_um: spec.film_um,
            diameter: spec.diameter,
            thickness_um: spec.thickness_um,
            amount: spec.amount,
            depth: spec.depth,
            tile_um: spec.tile_um,
            substrate: trace.substrate,
            rims: trace.rims,
            rays: trace.rays,
            layers: DEFAULT_LAYERS,
            seed: 1,
            max_events: trace.max_events,
            min_weight: trace.min_weight,
            binder_alpha_per_um: trace.binder_alpha_per_um,
        }
    }
}

/// One row: one incidence × one detector.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VolumeRow {
    /// Incidence angle, radians.
    pub theta_i: f64,
    /// Index of the detector in the instrument's list.
    pub detector: usize,
    /// Total cone-averaged BRDF (coat + single + multiple), sr⁻¹: the mean over layers.
    pub brdf: f64,
    /// Its standard error over layers (rays and layers together), sr⁻¹.
    pub std_err: f64,
    /// The rays' part of `std_err`, sr⁻¹.
    pub ray_std_err: f64,
    /// The between-layer part of `std_err`, sr⁻¹ (`None` with one layer).
    pub layer_std_err: Option<f64>,
    /// Half-width of the 95 % interval of `brdf`, Student's t on `layers − 1` degrees of
    /// freedom, sr⁻¹ (`None` with one layer).
    pub ci95: Option<f64>,
    /// First-surface (clear coat) part, sr⁻¹ (exact).
    pub coat_brdf: f64,
    /// Exactly one flake-face reflection, sr⁻¹.
    pub single_bounce_brdf: f64,
    /// Its standard error, sr⁻¹.
    pub single_bounce_std_err: f64,
    /// Every other escaping history, sr⁻¹.
    pub multiple_bounce_brdf: f64,
    /// Its standard error, sr⁻¹.
    pub multiple_bounce_std_err: f64,
    /// Total fraction of the incident power collected.
    pub reflectance: f64,
    /// Collected power relative to the same aperture at the specular direction.
    pub relative: f64,
    /// Escapes counted in the cone.
    pub rays: u64,
}

/// Curves of the volume model with everything a report needs.
#[derive(Debug, Clone)]
pub struct VolumeCurves {
    /// The instrument.
    pub instrument: Instrument,
    /// The coating (index, flake reflectance).
    pub coating: Coating,
    /// The settings.
    pub settings: VolumeSettings,
    /// Rows, ordered by incidence then detector.
    pub rows: Vec<VolumeRow>,
    /// `(θi, energy balance)` per incidence, fractions of the incident power.
    pub energy: Vec<(f64, EnergyBalance)>,
    /// Standard errors of the energy balance, same order.
    pub energy_std_err: Vec<EnergyBalance>,
    /// What placement realised over all layers: counts (flakes, attempts, resized and
    /// moved flakes) summed, fractions averaged.
    pub layer: LayerStats,
    /// What placement realised, per layer.
    pub layers: Vec<LayerStats>,
    /// Rays traced per incidence, all layers.
    pub rays_per_incidence: u64,
    /// Rays traced per incidence through each layer.
    pub rays_per_layer: u64,
    /// `t_{0.975}` on `layers − 1` degrees of freedom (NaN with one layer).
    pub t975: f64,
    /// Straight segments traced over all incidences.
    pub segments: u64,
    /// The seed.
    pub seed: u64,
    /// Free-form description of the orientation source, for metadata.
    pub source: String,
}

/// Places [`VolumeSettings::layers`] independent layers and traces them (crate
/// `flakescatter-volume`, `run_layers`) for every incidence and detector of
/// `instrument`. `progress(done, total)` is called from the calling thread as
/// chunks of rays finish.
///
/// # Errors
/// [`PipelineError::Instrument`] for point detectors (aperture 0);
/// [`PipelineError::Orientation`] for a source that gives no distribution;
/// [`PipelineError::Volume`] for invalid layer or tracing parameters (a negative or
/// non-finite binder absorption among them), or a loading too high to place.
pub fn volume_curves(
    coating: &Coating,
    instrument: &Instrument,
    settings: &VolumeSettings,
    source: &OrientationSource,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<VolumeCurves, PipelineError> {
    let (orientation, description) = prepare(instrument, source)?;
    let result = run_layers(
        &LayerParams::new(layer_spec(settings, orientation))?,
        &trace_options(coating, settings),
        settings.layers,
        instrument.theta_i(),
        instrument.cones(),
        progress,
    )?;
    Ok(curves_of(
        &result,
        coating,
        instrument,
        settings,
        description,
    ))
}

/// The volume model at several wavelengths: one [`VolumeCurves`] per wavelength.
#[derive(Debug, Clone)]
pub struct SpectralVolumeCurves {
    /// The wavelengths, nm (in vacuum).
    pub wavelengths_nm: Vec<f64>,
    /// The curves at each wavelength (same order), each with that wavelength's coating
    /// and its settings (`binder_alpha_per_um` the coefficient at that wavelength).
    pub curves: Vec<VolumeCurves>,
}

/// [`volume_curves`] at each wavelength of `wavelengths_nm` (nm) for `coating` (its
/// clear coat's index and flakes at each wavelength), with the binder's absorption
/// coefficient `binder_alpha_per_um` (µm⁻¹ versus nm) at each wavelength, or
/// `settings.binder_alpha_per_um` at all of them when `None`.
///
/// All wavelengths share the layers (placed once from the seed) and the rays' random
/// numbers (one seed for all: common random numbers), so the spectrum's shape is not
/// blurred by independent noise per wavelength, and each wavelength's curves are the
/// same bits as [`volume_curves`] with that wavelength's coating and absorption. When
/// nothing depends on wavelength (constant index, fixed flakes, the same absorption at
/// every wavelength) the model runs once and its curves are used at every wavelength,
/// which changes no number. Results do not depend on the number of threads.
/// `progress(done, total)` counts chunks of rays over all wavelengths.
///
/// # Errors
/// [`PipelineError::Spectral`] for a wavelength list that
/// [`crate::spectral::check_wavelengths`] refuses, a wavelength outside a table of the
/// coating or of the absorption, or a coating with a depth-rule binder absorption
/// ([`SpectralCoating::binder`], which the volume model has no use for: it follows each
/// path in the binder); as [`volume_curves`].
pub fn spectral_volume_curves(
    coating: &SpectralCoating,
    binder_alpha_per_um: Option<&SpectralTable>,
    wavelengths_nm: &[f64],
    instrument: &Instrument,
    settings: &VolumeSettings,
    source: &OrientationSource,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<SpectralVolumeCurves, PipelineError> {
    if coating.binder.is_some() {
        return Err(PipelineError::Spectral(
            "the volume model follows each path in the binder: give its absorption as a coefficient versus wavelength (binder_alpha_per_um), not with a flake depth".into(),
        ));
    }
    let at = coating.at_all(wavelengths_nm)?;
    let alphas: Vec<f64> = match binder_alpha_per_um {
        None => vec![settings.binder_alpha_per_um; wavelengths_nm.len()],
        Some(t) => wavelengths_nm
            .iter()
            .map(|&w| {
                t.value_at(w).map_err(|e| {
                    PipelineError::Spectral(format!("binder absorption at {w} nm: {e}"))
                })
            })
            .collect::<Result<_, _>>()?,
    };
    let (orientation, description) = prepare(instrument, source)?;
    let params = LayerParams::new(layer_spec(settings, orientation))?;
    let same = coating.is_wavelength_independent() && alphas.iter().all(|&a| a == alphas[0]);
    let runs = if same { 1 } else { at.len() };
    let per: Vec<VolumeSettings> = alphas
        .iter()
        .map(|&a| VolumeSettings {
            binder_alpha_per_um: a,
            ..settings.clone()
        })
        .collect();
    let options: Vec<TraceOptions> = (0..runs)
        .map(|j| trace_options(&at[j].coating, &per[j]))
        .collect();
    let results = run_layers_each(
        &params,
        &options,
        settings.layers,
        instrument.theta_i(),
        instrument.cones(),
        progress,
    )?;
    let curves = (0..at.len())
        .map(|j| {
            let r = &results[if same { 0 } else { j }];
            curves_of(r, &at[j].coating, instrument, &per[j], description.clone())
        })
        .collect();
    Ok(SpectralVolumeCurves {
        wavelengths_nm: wavelengths_nm.to_vec(),
        curves,
    })
}

/// The checks common to every run and the orientation with its description.
fn prepare(
    instrument: &Instrument,
    source: &OrientationSource,
) -> Result<(Orientation, String), PipelineError> {
    if instrument.aperture() <= 0.0 {
        return Err(PipelineError::Instrument(
            "the volume model counts rays into detector cones: the aperture must be > 0".into(),
        ));
    }
    let orientation = source.orientation()?;
    let description = if orientation.is_delta() {
        "flat (all flake normals along z)".to_owned()
    } else if let Some(w) = orientation.gaussian_width() {
        format!("gaussian, hwhm {:.6e} rad", w.hwhm())
    } else {
        format!("tabulated on [0, {:.6e}] rad", orientation.max_theta())
    };
    Ok((orientation, description))
}

/// The layer the settings describe.
fn layer_spec(settings: &VolumeSettings, orientation: Orientation) -> LayerSpec {
    LayerSpec {
        film_um: settings.film_um,
        diameter: settings.diameter,
        thickness_um: settings.thickness_um,
        orientation,
        amount: settings.amount,
        depth: settings.depth.clone(),
        tile_um: settings.tile_um,
        max_attempts: flakescatter_volume::params::DEFAULT_MAX_ATTEMPTS,
        seed: settings.seed,
    }
}

/// The tracer's options for `coating` and the settings.
fn trace_options(coating: &Coating, settings: &VolumeSettings) -> TraceOptions {
    TraceOptions {
        n: coating.n,
        flake: coating.flake.clone(),
        substrate: settings.substrate,
        rims: settings.rims,
        rays: settings.rays,
        seed: settings.seed,
        max_events: settings.max_events,
        min_weight: settings.min_weight,
        binder_alpha_per_um: settings.binder_alpha_per_um,
    }
}

/// The curves of a layered run.
fn curves_of(
    result: &LayeredResult,
    coating: &Coating,
    instrument: &Instrument,
    settings: &VolumeSettings,
    description: String,
) -> VolumeCurves {
    let nd = instrument.cones().len();
    let rows = result
        .points
        .iter()
        .enumerate()
        .map(|(k, lp)| {
            let p = &lp.mean;
            VolumeRow {
                theta_i: p.theta_i,
                detector: k % nd,
                brdf: p.brdf,
                std_err: p.brdf_std_err,
                ray_std_err: lp.brdf_error.rays,
                layer_std_err: lp.brdf_error.layers,
                ci95: lp.brdf_error.ci95,
                coat_brdf: p.coat_brdf,
                single_bounce_brdf: p.single_brdf,
                single_bounce_std_err: p.single_std_err,
                multiple_bounce_brdf: p.multiple_brdf,
                multiple_bounce_std_err: p.multiple_std_err,
                reflectance: p.reflectance,
                relative: p.relative,
                rays: p.rays,
            }
        })
        .collect();
    let layers = result.layers.len() as f64;
    let mean = |f: fn(&LayerStats) -> f64| result.layers.iter().map(f).sum::<f64>() / layers;
    let layer = LayerStats {
        flakes: result.layers.iter().map(|l| l.flakes).sum(),
        requested_volume_fraction: result.layers[0].requested_volume_fraction,
        volume_fraction: mean(|l| l.volume_fraction),
        projected_coverage: mean(|l| l.projected_coverage),
        area_coverage: mean(|l| l.area_coverage),
        attempts: result.layers.iter().map(|l| l.attempts).sum(),
        resized: result.layers.iter().map(|l| l.resized).sum(),
        moved: result.layers.iter().map(|l| l.moved).sum(),
        resized_area_fraction: mean(|l| l.resized_area_fraction),
    };
    VolumeCurves {
        instrument: instrument.clone(),
        coating: coating.clone(),
        settings: settings.clone(),
        rows,
        energy: instrument
            .theta_i()
            .iter()
            .copied()
            .zip(result.energy.iter().copied())
            .collect(),
        energy_std_err: result.energy_std_err.clone(),
        layer,
        layers: result.layers.clone(),
        rays_per_incidence: result.rays_per_layer * u64::from(settings.layers),
        rays_per_layer: result.rays_per_layer,
        t975: result.t975,
        segments: result.segments,
        seed: settings.seed,
        source: description,
    }
}
