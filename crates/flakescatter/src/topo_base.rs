//! A reflecting base under the topographic model's transmitting flakes (physics.md §13,
//! "The base under a map's flakes").
//!
//! The base term depends on a map only through its usable pixels' normals as a ray
//! meets them, not through one ray per pixel: it is the distribution model's base term
//! (module `flakescatter_gaussian::base`) driven by the map's pixel-level distribution
//! (physics.md §5.2, binned at [`BASE_BIN_DEG`]) and scaled by the usable-pixel
//! coverage, the area the flakes cover (dark pixels stay black substrate, as in §5).
//! It is added to every row of a plain topographic run after the run, from the pixel
//! tilts computed once for all wavelengths, so the rays' tiles, their order and their
//! bits are those of the run without a base.
//!
//! Uncertainty: the term is `c b` with `c = Σ_t u_t / N_pixels` (`u_t` the usable
//! pixels of statistics tile `t`) and `b` the base's reading for flakes that cover the
//! plane; the spread of `u_t` between tiles gives its standard error
//! `b sqrt(T/(T − 1) Σ_t (u_t − ū)²) / N_pixels` (the form of §5's), the shape of the
//! distribution being held (`b` averages a smooth transmittance over thousands of
//! normals). It is added to the flakes' standard error, not in quadrature: both grow
//! with a tile's usable pixels, and the sum bounds the error of their sum whatever
//! their correlation.

use flakescatter_gaussian::base::{BaseLoop, FacetWeights};
use flakescatter_gaussian::{ConeMethod, DistributionModel, ModelOptions};
use flakescatter_optics::absorption::PathAbsorption;
use flakescatter_optics::detector::Cone;
use flakescatter_stats::{HeightMap, Orientation};
use flakescatter_topo::pixels::PixelTilts;
use flakescatter_topo::{TopoModel, TopoResult};
use rayon::prelude::*;

use crate::PipelineError;

/// Bin width of the pixel-level distribution that drives the base term, degrees. The
/// base's light averages the flakes' transmittance over the normals a ray meets, a
/// smooth function of the tilt, so the bin's spread (a second-order change) stays
/// below 1e-4 of the term (physics.md §13; `crates/flakescatter/tests/topo_base.rs`).
pub const BASE_BIN_DEG: f64 = 1.0;

/// What the base term needs of the maps, computed once for the runs at every
/// wavelength: the pixel tilts (on the statistics tiles of the runs the term is added
/// to), their distribution and its facet weights.
#[derive(Debug, Clone)]
pub struct MapBase {
    tilts: PixelTilts,
    orientation: Orientation,
    weights: FacetWeights,
}

/// The [`MapBase`] of `maps` on the tiles of `model`; `None` for a black base
/// (`albedo` 0).
///
/// # Errors
/// [`PipelineError::Topo`] as [`TopoModel::pixel_tilts`]; [`PipelineError::Orientation`]
/// when the tilts give no distribution.
pub(crate) fn map_base(
    model: &TopoModel,
    albedo: f64,
    maps: &[&HeightMap],
) -> Result<Option<MapBase>, PipelineError> {
    if albedo == 0.0 {
        return Ok(None);
    }
    let tilts = model.pixel_tilts(maps, BASE_BIN_DEG.to_radians())?;
    let orientation = tilts
        .orientation()
        .map_err(|e| PipelineError::Orientation(e.to_string()))?;
    let weights = FacetWeights::new(&orientation);
    Ok(Some(MapBase {
        tilts,
        orientation,
        weights,
    }))
}

/// A description of the base for a run's metadata.
pub(crate) fn describe(share: &BaseShare) -> String {
    format!(
        "a Lambertian base of albedo {} under the flakes (coverage {:.4}, return share {:.4}, escape share {:.4})",
        share.albedo, share.coverage, share.return_fraction, share.escape_fraction
    )
}

/// What the base added to a run, for reports.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BaseShare {
    /// The base's albedo `ρ`.
    pub albedo: f64,
    /// Usable pixels as a fraction of all pixels: the flakes' share of the area, which
    /// scales the term.
    pub coverage: f64,
    /// `r̄`: the share of the base's Lambertian light that returns to it (physics.md
    /// §13).
    pub return_fraction: f64,
    /// `e`: the share of the base's Lambertian light that leaves the coating.
    pub escape_fraction: f64,
}

/// The base term of a run, ready to be added to its rows (module docs).
pub(crate) struct BaseTerm<'a> {
    model: DistributionModel,
    tilts: &'a PixelTilts,
    share: BaseShare,
}

impl<'a> BaseTerm<'a> {
    /// The base of albedo `albedo` under flakes in a coat of index `n`, the flakes and
    /// the Fresnel bookkeeping of `options` (its clear coat is not the base's), their
    /// normals those of `map`; built before the run so that a base that cannot be
    /// modelled is refused before any ray is traced.
    ///
    /// # Errors
    /// [`PipelineError::Model`] when the base cannot be modelled: flakes that are not a
    /// stack without a core, binder absorption, a polarised beam, the paper-printed
    /// weighting (`flakescatter_gaussian::ModelError::BaseFlake`, `BaseSetting`).
    pub(crate) fn new(
        map: &'a MapBase,
        albedo: f64,
        n: f64,
        options: ModelOptions,
        absorption: Option<PathAbsorption>,
    ) -> Result<Self, PipelineError> {
        let mut model = DistributionModel::new(
            map.orientation.clone(),
            n,
            ModelOptions {
                clearcoat: false,
                exit_fresnel: true,
                ..options
            },
        )?;
        if let Some(a) = absorption {
            model = model.with_absorption(a);
        }
        let model = model.with_base_weights(albedo, BaseLoop::Included, &map.weights)?;
        let Some(base) = model.base() else {
            return Err(PipelineError::Spectral(
                "base albedo 0 has no base term".into(),
            ));
        };
        let share = BaseShare {
            albedo: base.albedo(),
            coverage: map.tilts.coverage(),
            return_fraction: base.return_fraction(),
            escape_fraction: base.escape_fraction(),
        };
        Ok(Self {
            model,
            tilts: &map.tilts,
            share,
        })
    }

    /// What the base adds, for reports.
    pub(crate) fn share(&self) -> &BaseShare {
        &self.share
    }

    /// Adds the term to every row of `result` (reflectance, BRDF, relative and their
    /// standard errors; module docs).
    ///
    /// # Errors
    /// [`PipelineError::Model`] for an incidence the model refuses (not in `[0, π/2)`).
    pub(crate) fn add_to(&self, result: &mut TopoResult) -> Result<(), PipelineError> {
        let spread = usable_spread(self.tilts, result.pixels);
        let c = self.share.coverage;
        // The specular cone's reading, once per incidence and aperture.
        let mut specular: Vec<((u64, u64), f64)> = Vec::new();
        for p in &result.points {
            let key = (p.theta_i.to_bits(), p.cone.half_angle().to_bits());
            if specular.iter().all(|(k, _)| *k != key) {
                let cone = Cone::in_plane(-p.theta_i, p.cone.half_angle())
                    .map_err(|e| PipelineError::Instrument(e.to_string()))?;
                let inc = self.model.incidence(p.theta_i)?;
                specular.push((key, self.model.base_cone(&inc, &cone, ConeMethod::Exact).0));
            }
        }
        let incidences = specular
            .iter()
            .map(|((t, _), _)| Ok((*t, self.model.incidence(f64::from_bits(*t))?)))
            .collect::<Result<Vec<_>, PipelineError>>()?;
        result.points.par_iter_mut().for_each(|p| {
            let key = (p.theta_i.to_bits(), p.cone.half_angle().to_bits());
            let inc = &incidences
                .iter()
                .find(|(t, _)| *t == key.0)
                .expect("listed above")
                .1;
            let b_spec = specular
                .iter()
                .find(|(k, _)| *k == key)
                .expect("listed above")
                .1;
            let b = self.model.base_cone(inc, &p.cone, ConeMethod::Exact).0;
            let proj = p.cone.projected_solid_angle();
            p.reflectance += c * b;
            p.brdf = p.reflectance / proj;
            p.specular_reflectance += c * b_spec;
            let spec = p.specular_reflectance;
            p.relative = if spec > 0.0 {
                p.reflectance / spec
            } else {
                f64::NAN
            };
            if let Some(s) = spread {
                let se = p.reflectance_std_err.unwrap_or(0.0) + b * s;
                p.reflectance_std_err = Some(se);
                p.brdf_std_err = Some(se / proj);
            }
        });
        Ok(())
    }
}

/// `sqrt(T/(T − 1) Σ_t (u_t − ū)²) / N_pixels` over the statistics tiles (module docs);
/// `None` with fewer than two tiles.
fn usable_spread(tilts: &PixelTilts, pixels: u64) -> Option<f64> {
    let t = tilts.tiles.len();
    if t < 2 {
        return None;
    }
    let mean = tilts.usable_pixels as f64 / t as f64;
    let ss: f64 = tilts
        .tiles
        .iter()
        .map(|x| (x.pixels as f64 - mean).powi(2))
        .sum();
    Some((t as f64 / (t as f64 - 1.0) * ss).sqrt() / pixels as f64)
}
