//! Tabulated BRDFs for renderers: a model's point BRDF at the centre of every bin of a
//! MERL table ([`crate::io::merl`]; layout and indexing in `docs/formats.md`).
//!
//! Each bin's centre ([`Bin::centre`]: `θh = (π/2)((h + ½)/90)²`, `θd = (π/2)(d + ½)/90`,
//! `φd = π(p + ½)/180`, `φh = 0`) gives an incident direction `ωi` and an outgoing
//! `ωo` ([`Bin::centre_directions`]); turned about the normal so that the source lies at
//! azimuth 180° (the models' convention, `φr = 0` the specular half-plane), they are the
//! incidence `θi = acos ωi·z` and the detector direction at which the model's point BRDF
//! (sr⁻¹, an aperture-0 detector) is evaluated. A bin whose `ωi` or `ωo` is not above
//! the surface is left without a value (MERL's −1). Bins are independent, so the table
//! is the same for any thread count.
//!
//! Sources: the distribution model (grey), a paint (its r, g, b channels), or the
//! distribution model at many wavelengths turned into linear sRGB ([`SpectralSource`]).
//!
//! What a table cannot hold: the specular delta of a smooth clear coat (a fraction of
//! the beam in one direction, not a BRDF) is left out; a paint's rough coat is in.
//!
//! ```
//! use flakescatter::export::{BrdfSource, merl_table};
//! use flakescatter::gaussian::{DistributionModel, ModelOptions};
//! use flakescatter::stats::{GaussianWidth, Orientation};
//! use flakescatter::io::merl::Bin;
//!
//! let o = Orientation::gaussian(GaussianWidth::Hwhm(6f64.to_radians()))?;
//! let model = DistributionModel::new(o, 1.5, ModelOptions::default())?;
//! let table = merl_table(&BrdfSource::Distribution(&model), &|_, _| {})?.table;
//! // Near the mirror direction at a moderate angle: grey, positive.
//! let bin = Bin::new(2, 30, 90).unwrap();
//! let v = table.value(0, bin).unwrap();
//! assert!(v > 0.0 && Some(v) == table.value(2, bin));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use flakescatter_gaussian::DistributionModel;
use flakescatter_io::merl::{BINS, Bin, MerlTable, PHI_D_BINS, THETA_D_BINS, THETA_H_BINS};
use flakescatter_optics::Vec3;
use flakescatter_paint::PaintModel;
use rayon::prelude::*;

use crate::PipelineError;

/// What fills a table.
#[derive(Debug, Clone, Copy)]
pub enum BrdfSource<'a> {
    /// The distribution model's flakes (physics.md §4): one BRDF, written to R, G and B
    /// alike (grey).
    Distribution(&'a DistributionModel),
    /// A paint (physics.md §12): R, G and B are its channels at these indices
    /// ([`paint_rgb`]).
    Paint {
        /// The paint.
        model: &'a PaintModel,
        /// The paint channel of R, G and B.
        rgb: [usize; 3],
    },
    /// The distribution model at several wavelengths ([`SpectralSource`]), its BRDF
    /// spectrum turned into linear sRGB.
    Spectral(&'a SpectralSource),
}

/// The IEC 61966-2-1 (sRGB) matrix from CIE XYZ (`Y = 1` for the white) to linear sRGB,
/// rows R, G, B: the standard's four-decimal values.
pub const XYZ_TO_LINEAR_SRGB: [[f64; 3]; 3] = [
    [3.2406, -1.5372, -0.4986],
    [-0.9689, 1.8758, 0.0415],
    [0.0557, -0.2040, 1.0570],
];

/// A spectral model to tabulate: one distribution model per wavelength and the weights
/// that turn its BRDF spectrum `f(λᵢ)` into linear sRGB, `RGB = Σᵢ wᵢ f(λᵢ)`, with
/// `wᵢ = M · Wᵢ / 100`: `Wᵢ` the ASTM E308 tristimulus weights of the wavelength list
/// for CIE illuminant D65 and the CIE 1931 2° observer (`flakescatter_colour`,
/// `Σ W_ȳ = 100`), `M` [`XYZ_TO_LINEAR_SRGB`]. A BRDF spectrum that is the same at
/// every wavelength gives R = G = B = that BRDF to the matrix's four decimals (the D65
/// white is sRGB's white). A colour outside the sRGB gamut has a negative component,
/// which is written as 0 (the table's negative numbers mean "no value") and counted.
#[derive(Debug, Clone)]
pub struct SpectralSource {
    models: Vec<DistributionModel>,
    /// Whether every wavelength's coat has the same index (one incidence serves all).
    one_coat: bool,
    weights: Vec<[f64; 3]>,
    wavelengths_nm: Vec<f64>,
}

impl SpectralSource {
    /// The spectral coating `coating` with the flakes of `orientation` at
    /// `wavelengths_nm` (nm; strictly increasing, covering 400–700 nm as colorimetry
    /// needs), `settings` as the distribution model's.
    ///
    /// # Errors
    /// [`PipelineError::Spectral`] for a wavelength list colorimetry refuses or a
    /// coating that has no value at a wavelength; the model's errors.
    pub fn new(
        coating: &crate::spectral::SpectralCoating,
        orientation: &flakescatter_stats::Orientation,
        settings: &crate::Settings,
        wavelengths_nm: &[f64],
    ) -> Result<Self, PipelineError> {
        let tw = flakescatter_colour::TristimulusWeights::new(
            wavelengths_nm,
            flakescatter_colour::Illuminant::D65,
            flakescatter_colour::Observer::Cie1931TwoDegree,
        )
        .map_err(|e| {
            PipelineError::Spectral(format!("the wavelengths of the sRGB conversion: {e}"))
        })?;
        // Σ W_ȳ = 100 for the white: XYZ per unit BRDF at wavelength i is W_i / 100.
        let weights: Vec<[f64; 3]> = tw
            .weights()
            .iter()
            .map(|w| {
                let xyz = [w[0] / 100.0, w[1] / 100.0, w[2] / 100.0];
                XYZ_TO_LINEAR_SRGB.map(|row| row[0] * xyz[0] + row[1] * xyz[1] + row[2] * xyz[2])
            })
            .collect();
        let models = coating
            .at_all(wavelengths_nm)?
            .into_iter()
            .map(|at| {
                let mut m = crate::pipeline::distribution_model(
                    &at.coating,
                    settings,
                    orientation.clone(),
                )?;
                if let Some(a) = at.absorption {
                    m = m.with_absorption(a);
                }
                Ok(m)
            })
            .collect::<Result<Vec<_>, PipelineError>>()?;
        let one_coat = models.windows(2).all(|p| p[0].index() == p[1].index());
        Ok(Self {
            models,
            one_coat,
            weights,
            wavelengths_nm: wavelengths_nm.to_vec(),
        })
    }

    /// The wavelengths, nm.
    #[must_use]
    pub fn wavelengths_nm(&self) -> &[f64] {
        &self.wavelengths_nm
    }

    /// The linear-sRGB weight `wᵢ` of each wavelength (R, G, B per sr⁻¹ of BRDF).
    #[must_use]
    pub fn weights(&self) -> &[[f64; 3]] {
        &self.weights
    }
}

/// Which of a paint's channels are R, G and B: its channels named `r`, `g` and `b`
/// (case-insensitive), or its one channel for all three (grey).
///
/// # Errors
/// [`PipelineError::Measurement`] naming the paint's channels when neither holds.
pub fn paint_rgb(model: &PaintModel) -> Result<[usize; 3], PipelineError> {
    let names: Vec<String> = model
        .params()
        .channels
        .iter()
        .map(|c| c.channel.name.to_ascii_lowercase())
        .collect();
    if names.len() == 1 {
        return Ok([0; 3]);
    }
    let find = |n: &str| names.iter().position(|c| c == n);
    match (find("r"), find("g"), find("b")) {
        (Some(r), Some(g), Some(b)) => Ok([r, g, b]),
        _ => Err(PipelineError::Measurement(format!(
            "a MERL table holds R, G and B: the paint's channels are {} (expected r, g and b, or one channel for a grey table)",
            names.join(", ")
        ))),
    }
}

/// The incidence `θi` (radians) and the unit detector direction (source at azimuth
/// 180°) of `bin`'s centre; `None` when the centre's directions are not both above the
/// surface.
#[must_use]
pub fn bin_geometry(bin: Bin) -> Option<(f64, Vec3)> {
    let (wi, wo) = bin.centre_directions()?;
    let theta_i = wi[2].clamp(-1.0, 1.0).acos();
    // Turn about z by π − φi so that ωi lies at azimuth π.
    let phi_i = if wi[0] == 0.0 && wi[1] == 0.0 {
        std::f64::consts::PI
    } else {
        wi[1].atan2(wi[0])
    };
    let (s, c) = (std::f64::consts::PI - phi_i).sin_cos();
    let r = Vec3::new(wo[0] * c - wo[1] * s, wo[0] * s + wo[1] * c, wo[2]);
    Some((theta_i, r))
}

/// The R, G, B point BRDF (sr⁻¹) of `source` at `bin`'s centre; `None` below the
/// horizon. A spectral source's components may be negative (outside the sRGB gamut);
/// [`merl_table`] writes those as 0.
///
/// # Errors
/// The model's, for an incidence it refuses (not raised for a bin above the horizon).
pub fn bin_value(source: &BrdfSource<'_>, bin: Bin) -> Result<Option<[f64; 3]>, PipelineError> {
    let Some((theta_i, r)) = bin_geometry(bin) else {
        return Ok(None);
    };
    Ok(Some(match source {
        BrdfSource::Distribution(m) => {
            let inc = m.incidence(theta_i)?;
            let v = m.brdf(&inc, &r);
            [v; 3]
        }
        BrdfSource::Paint { model, rgb } => {
            let inc = model.incidence(theta_i).map_err(PipelineError::Paint)?;
            let mut out = [0.0; 3];
            for (o, &k) in out.iter_mut().zip(rgb) {
                *o = model.brdf(&inc, &r, k);
            }
            out
        }
        BrdfSource::Spectral(s) => {
            let mut out = [0.0; 3];
            // What depends on the incidence alone (the coat's refraction and Fresnel
            // factors) is the same at every wavelength when the coat does not disperse.
            let shared = if s.one_coat {
                Some(s.models[0].incidence(theta_i)?)
            } else {
                None
            };
            for (m, w) in s.models.iter().zip(&s.weights) {
                let own;
                let inc = match &shared {
                    Some(i) => i,
                    None => {
                        own = m.incidence(theta_i)?;
                        &own
                    }
                };
                let f = m.brdf(inc, &r);
                for c in 0..3 {
                    out[c] += w[c] * f;
                }
            }
            out
        }
    }))
}

/// The whole MERL table of `source`, every bin at its centre, with negative components
/// (a spectral colour outside the sRGB gamut) written as 0 and counted.
/// `progress(done, total)` is called as rows of `θh` are finished (from worker threads).
///
/// # Errors
/// The model's ([`bin_value`]).
pub fn merl_table(
    source: &BrdfSource<'_>,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Tabulated, PipelineError> {
    let row = THETA_D_BINS * PHI_D_BINS;
    let done = std::sync::atomic::AtomicUsize::new(0);
    let rows: Vec<Vec<Option<[f64; 3]>>> = (0..THETA_H_BINS)
        .into_par_iter()
        .map(|h| {
            let values = (0..row)
                .map(|k| {
                    let bin = Bin::from_index(h * row + k).expect("bin within the table");
                    bin_value(source, bin)
                })
                .collect::<Result<Vec<_>, _>>()?;
            let n = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            progress(n, THETA_H_BINS);
            Ok(values)
        })
        .collect::<Result<_, PipelineError>>()?;
    let mut table = MerlTable::unfilled();
    let mut clipped = 0;
    for (i, v) in rows.into_iter().flatten().enumerate() {
        let bin = Bin::from_index(i).expect("bin within the table");
        if v.is_some_and(|v| v.iter().any(|x| *x < 0.0)) {
            clipped += 1;
        }
        for c in 0..3 {
            table.set(c, bin, v.map(|v| v[c].max(0.0)));
        }
    }
    debug_assert_eq!(table.raw().len(), 3 * BINS);
    Ok(Tabulated { table, clipped })
}

/// A filled table and what had to be changed to fill it.
#[derive(Debug, Clone)]
pub struct Tabulated {
    /// The table.
    pub table: MerlTable,
    /// Bins with a colour outside the sRGB gamut (a negative component written as 0).
    pub clipped: usize,
}
