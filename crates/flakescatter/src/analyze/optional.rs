//! The optional statistics of a sample — the Gaussian fitted to the flake histogram,
//! the pixel-level statistics (`stats.pixel_normals`) and their histogram fit — and
//! what a sample's size allows: one of them failing does not sink the sample. The
//! report is written with the statistic marked failed and why ([`FailedStatistic`],
//! `summary.json` key `failed_statistics`, the report's text), naming the map, the
//! manifest key and the smallest size that works where size is the cause.
//!
//! Sizes: the pixel-level statistics need maps of at least `models.window` pixels a
//! side; standard errors from tiles (the topographic model, the pixel-level interval)
//! need at least 2 tiles of `models.tile_um` over the maps and are reliable from
//! [`MIN_TILES`]; a flake needs at least `instrument.min_pixels` pixels.

use flakescatter_stats::heightmap::HeightMap;
use flakescatter_stats::segment::Segmentation;
use flakescatter_topo::{MIN_TILES, TopoError};
use serde_json::{Value, json};

use super::Manifest;
use crate::PipelineError;
use crate::pipeline::TopoSettings;
use crate::sample::{SampleStatistics, pixel_level};

/// An optional statistic that failed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FailedStatistic {
    /// Which: its place in `summary.json` (`statistics.pixel_level`, ...).
    pub statistic: String,
    /// The manifest key that asks for it or shapes it.
    pub key: String,
    /// Why, naming the map and the smallest size that works where size is the cause.
    pub error: String,
}

impl FailedStatistic {
    /// The entry of `summary.json`'s `failed_statistics`.
    #[must_use]
    pub fn to_json(&self) -> Value {
        json!({"statistic": self.statistic, "key": self.key, "error": self.error})
    }

    /// The warning printed once for it.
    #[must_use]
    pub fn warning(&self) -> String {
        format!(
            "{} failed and is marked so in the report: {}",
            self.statistic, self.error
        )
    }
}

/// `map NAME (NX × NY pixels, X × Y µm)`.
fn describe(name: &str, map: &HeightMap) -> String {
    format!(
        "map {name} ({} × {} pixels, {:.1} × {:.1} µm)",
        map.nx(),
        map.ny(),
        map.nx() as f64 * map.dx(),
        map.ny() as f64 * map.dy()
    )
}

/// Statistics tiles of `tile_um` over `map` (as the topographic layer cuts them: blocks
/// of `round(tile / pitch)` pixels, the last one partial).
fn tiles(map: &HeightMap, tile_um: f64) -> usize {
    let tc = ((tile_um / map.dx()).round() as usize).max(1);
    let tr = ((tile_um / map.dy()).round() as usize).max(1);
    map.nx().div_ceil(tc) * map.ny().div_ceil(tr)
}

/// The largest tile side (a whole number of pixels of the first map) that cuts the
/// maps into at least `target` tiles, µm.
fn largest_tile(maps: &[&HeightMap], target: usize) -> Option<f64> {
    let pitch = maps.first()?.dx();
    let widest = maps.iter().map(|m| m.nx().max(m.ny())).max()?;
    (1..=widest)
        .rev()
        .map(|b| b as f64 * pitch)
        .find(|&t| maps.iter().map(|m| tiles(m, t)).sum::<usize>() >= target)
}

/// When the maps hold fewer than [`MIN_TILES`] statistics tiles of `models.tile_um`:
/// the maps, the key and the sizes that work. `None` when there are enough.
#[must_use]
pub fn tile_hint(m: &Manifest, maps: &[&HeightMap], names: &[String]) -> Option<String> {
    let t = m.models.tile_um;
    let total: usize = maps.iter().map(|map| tiles(map, t)).sum();
    let reliable = usize::try_from(MIN_TILES).unwrap_or(usize::MAX);
    if total >= reliable {
        return None;
    }
    let listed: Vec<String> = maps
        .iter()
        .zip(names)
        .map(|(map, n)| format!("{}: {} tile(s)", describe(n, map), tiles(map, t)))
        .collect();
    let pitch = maps.first().map_or(1.0, |map| map.dx());
    let smaller = |target: usize| {
        largest_tile(maps, target).map_or_else(
            || "no tile side does".to_owned(),
            |x| format!("`tile_um` ≤ {x:.2} µm"),
        )
    };
    let advice = if total < 2 {
        format!(
            "a standard error needs at least 2 tiles ({}) and is reliable from {reliable} ({}); or measure maps at least {:.0} µm ({} pixels) along one side",
            smaller(2),
            smaller(reliable),
            2.0 * t,
            (2.0 * t / pitch).ceil()
        )
    } else {
        format!(
            "standard errors are reliable from {reliable} tiles ({}); or measure more or larger maps",
            smaller(reliable)
        )
    };
    Some(format!(
        "`models.tile_um` = {t} µm cuts the maps into {total} statistics tile(s) ({}): {advice}",
        listed.join("; "),
    ))
}

/// Why the pixel-level statistics failed, naming the map and the size that works.
fn pixel_error(e: &PipelineError, m: &Manifest, maps: &[&HeightMap], names: &[String]) -> String {
    let name = |k: usize| {
        maps.get(k)
            .zip(names.get(k))
            .map_or_else(|| format!("map {}", k + 1), |(map, n)| describe(n, map))
    };
    let why = match e {
        PipelineError::Topo(TopoError::WindowTooLarge { window, map, .. }) => format!(
            "{} is smaller than the pixel-level window (`models.window` = {window} pixels): the smallest map that works is {window} × {window} pixels",
            name(*map)
        ),
        PipelineError::Topo(TopoError::NoValidPixels { map, .. }) => {
            format!("{} has no valid pixel", name(*map))
        }
        e => format!(
            "{e} (maps: {})",
            maps.iter()
                .zip(names)
                .map(|(map, n)| describe(n, map))
                .collect::<Vec<_>>()
                .join(", ")
        ),
    };
    format!(
        "{why}; set `stats.pixel_normals = false` to leave them out{}",
        tile_hint(m, maps, names).map_or_else(String::new, |h| format!("; {h}"))
    )
}

/// Computes the pixel-level statistics into `stats` when `stats.pixel_normals` asks
/// for them, and collects every optional statistic that failed (module docs).
pub fn optional_statistics(
    m: &Manifest,
    maps: &[&HeightMap],
    names: &[String],
    stats: &mut SampleStatistics,
) -> Vec<FailedStatistic> {
    let mut failed = Vec::new();
    if let Err(e) = &stats.histogram_fit {
        failed.push(FailedStatistic {
            statistic: "statistics.histogram_fit".into(),
            key: "stats.bin_deg".into(),
            error: format!(
                "Gaussian least-squares fit to the flake histogram (bins of `stats.bin_deg` = {}°): {e}",
                m.stats.bin_deg
            ),
        });
    }
    if !m.stats.pixel_normals {
        return failed;
    }
    let topo = TopoSettings {
        window: m.models.window,
        tile_um: m.models.tile_um,
    };
    let segs: Vec<&Segmentation> = stats.segmentations.iter().collect();
    match pixel_level(maps, &segs, &topo, m.stats.bin_deg.to_radians()) {
        Ok(px) => {
            if let Err(e) = &px.orientation.histogram_fit {
                let which = if maps.len() == 1 {
                    describe(&names[0], maps[0])
                } else {
                    format!("the {} maps pooled", maps.len())
                };
                failed.push(FailedStatistic {
                    statistic: "statistics.pixel_level.histogram_fit".into(),
                    key: "stats.pixel_normals".into(),
                    error: format!(
                        "Gaussian least-squares fit to the pixel-level histogram of {which} (bins of `stats.bin_deg` = {}°, windows of `models.window` = {} pixels): {e}; the other pixel-level statistics are reported; set `stats.pixel_normals = false` to leave them out",
                        m.stats.bin_deg, m.models.window
                    ),
                });
            }
            stats.pixel = Some(px);
        }
        Err(e) => failed.push(FailedStatistic {
            statistic: "statistics.pixel_level".into(),
            key: "stats.pixel_normals".into(),
            error: pixel_error(&e, m, maps, names),
        }),
    }
    failed
}

/// Refuses a sample none of whose maps holds a flake, naming every map, its size and
/// `instrument.min_pixels` (the smallest flake kept) when a map is smaller than that.
///
/// # Errors
/// The message, when no map holds a flake.
pub fn require_flakes(
    m: &Manifest,
    maps: &[&HeightMap],
    names: &[String],
    segs: &[Segmentation],
) -> Result<(), String> {
    if segs.iter().any(|s| !s.flakes.is_empty()) {
        return Ok(());
    }
    let min = m.instrument.min_pixels;
    let listed: Vec<String> = maps
        .iter()
        .zip(names)
        .map(|(map, n)| {
            let small = if map.len() < min {
                format!(", fewer pixels than one flake needs (`instrument.min_pixels` = {min})")
            } else {
                String::new()
            };
            format!("{}{small}", describe(n, map))
        })
        .collect();
    Err(format!(
        "no flake found in any map ({}): a flake is kept from `instrument.min_pixels` = {min} pixels, so a map needs at least that many valid pixels on one flake (e.g. {side} × {side} pixels); check `maps.cutoff`, `instrument.z_step_um` and `instrument.noise_um`",
        listed.join("; "),
        side = (min as f64).sqrt().ceil()
    ))
}
