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
//! What a table cannot hold: the specular delta of a smooth clear coat (a fraction of
//! the beam in one direction, not a BRDF) is left out; a paint's rough coat is in.
//!
//! ```
//! use flakescatter::export::{BrdfSource, merl_table};
//! use flakescatter::gaussian::{DistributionModel, GaussianWidth, ModelOptions, Orientation};
//! use flakescatter::io::merl::Bin;
//!
//! let o = Orientation::gaussian(GaussianWidth::Hwhm(6f64.to_radians()))?;
//! let model = DistributionModel::new(o, 1.5, ModelOptions::default())?;
//! let table = merl_table(&BrdfSource::Distribution(&model), &|_, _| {})?;
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
/// horizon.
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
    }))
}

/// The whole MERL table of `source`, every bin at its centre. `progress(done, total)`
/// is called as rows of `θh` are finished (from worker threads).
///
/// # Errors
/// The model's ([`bin_value`]).
pub fn merl_table(
    source: &BrdfSource<'_>,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<MerlTable, PipelineError> {
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
    for (i, v) in rows.into_iter().flatten().enumerate() {
        let bin = Bin::from_index(i).expect("bin within the table");
        for c in 0..3 {
            table.set(c, bin, v.map(|v| v[c]));
        }
    }
    debug_assert_eq!(table.raw().len(), 3 * BINS);
    Ok(table)
}
