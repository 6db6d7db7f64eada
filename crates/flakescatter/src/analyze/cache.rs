//! The cache of a report directory (module docs of [`super`]): each map's segmentation
//! (`cache/maps/NAME.json`) and the model results (`cache/models.json`), each under the
//! key of its inputs, kept bit for bit through JSON; the paint fit's cache
//! (`cache/paint.json`) is read here and written by the paint part.

use std::collections::BTreeMap;
use std::path::Path;

use flakescatter_io::files::read_text;
use flakescatter_stats::flake::UnitVec3;
use flakescatter_stats::nalgebra::{Unit, Vector3};
use flakescatter_stats::segment::{SegmentWarning, Segmentation, SegmentedFlake};
use serde::{Deserialize, Serialize};
use serde_json::Value;

use super::{Content, OutFile};
use crate::pipeline::{CurveRow, Curves};

/// A segmented flake as kept in the cache (every field of [`SegmentedFlake`], bit for
/// bit through JSON).
#[derive(Debug, Clone, Serialize, Deserialize)]
struct FlakeRec {
    normal: [f64; 3],
    theta_n: f64,
    phi_n: f64,
    centre_um: [f64; 2],
    pixels: usize,
    inliers: usize,
    projected_area_um2: f64,
    area_um2: f64,
    equivalent_diameter_um: f64,
    rms_um: f64,
    tilt_se: f64,
    touches_border: bool,
    quality: f64,
}

impl FlakeRec {
    fn of(f: &SegmentedFlake) -> Self {
        Self {
            normal: [f.normal.x, f.normal.y, f.normal.z],
            theta_n: f.theta_n,
            phi_n: f.phi_n,
            centre_um: f.centre_um,
            pixels: f.pixels,
            inliers: f.inliers,
            projected_area_um2: f.projected_area_um2,
            area_um2: f.area_um2,
            equivalent_diameter_um: f.equivalent_diameter_um,
            rms_um: f.rms_um,
            tilt_se: f.tilt_se,
            touches_border: f.touches_border,
            quality: f.quality,
        }
    }

    fn flake(&self) -> SegmentedFlake {
        let n: UnitVec3 =
            Unit::new_unchecked(Vector3::new(self.normal[0], self.normal[1], self.normal[2]));
        SegmentedFlake {
            normal: n,
            theta_n: self.theta_n,
            phi_n: self.phi_n,
            centre_um: self.centre_um,
            pixels: self.pixels,
            inliers: self.inliers,
            projected_area_um2: self.projected_area_um2,
            area_um2: self.area_um2,
            equivalent_diameter_um: self.equivalent_diameter_um,
            rms_um: self.rms_um,
            tilt_se: self.tilt_se,
            touches_border: self.touches_border,
            quality: self.quality,
        }
    }
}

/// A map's segmentation as kept in the cache.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub(super) struct MapCache {
    pub(super) key: String,
    flakes: Vec<FlakeRec>,
    /// Label map as runs `(label, count)` in raster order.
    labels: Vec<(u32, u32)>,
    valid_pixels: usize,
    dropped_pixels: usize,
    warning: Option<String>,
}

impl MapCache {
    pub(super) fn of(key: String, s: &Segmentation) -> Self {
        let mut runs: Vec<(u32, u32)> = Vec::new();
        for &l in &s.labels {
            match runs.last_mut() {
                Some((v, n)) if *v == l && *n < u32::MAX => *n += 1,
                _ => runs.push((l, 1)),
            }
        }
        Self {
            key,
            flakes: s.flakes.iter().map(FlakeRec::of).collect(),
            labels: runs,
            valid_pixels: s.valid_pixels,
            dropped_pixels: s.dropped_pixels,
            warning: s.warning.map(|w| match w {
                SegmentWarning::NoValidPixels => "no-valid-pixels".into(),
                SegmentWarning::NoFlakes => "no-flakes".into(),
            }),
        }
    }

    /// The segmentation, if the cache is consistent with a map of `len` pixels.
    pub(super) fn segmentation(&self, len: usize) -> Option<Segmentation> {
        let mut labels = Vec::with_capacity(len);
        for &(l, n) in &self.labels {
            if l as usize > self.flakes.len() || labels.len() + n as usize > len {
                return None;
            }
            labels.extend(std::iter::repeat_n(l, n as usize));
        }
        (labels.len() == len).then(|| Segmentation {
            flakes: self.flakes.iter().map(FlakeRec::flake).collect(),
            labels,
            valid_pixels: self.valid_pixels,
            dropped_pixels: self.dropped_pixels,
            warning: match self.warning.as_deref() {
                Some("no-valid-pixels") => Some(SegmentWarning::NoValidPixels),
                Some(_) => Some(SegmentWarning::NoFlakes),
                None => None,
            },
        })
    }
}

/// One curve row as kept in the cache.
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
pub(super) struct RowRec {
    pub(super) theta_i: f64,
    pub(super) detector: usize,
    pub(super) brdf: f64,
    pub(super) reflectance: Option<f64>,
    pub(super) relative: f64,
    pub(super) rays: Option<u64>,
    pub(super) std_err: Option<f64>,
}

/// A model's curves as kept in the cache.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub(super) struct CurveRec {
    /// `distribution (pooled width)`, `distribution (pooled histogram)`, `topographic`
    /// or `topographic (isotropic)`.
    pub(super) label: String,
    pub(super) model: String,
    pub(super) source: String,
    pub(super) rows: Vec<RowRec>,
}

/// The width fit as kept.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub(super) struct FitRec {
    pub(super) hwhm: f64,
    pub(super) hwhm_std: f64,
    pub(super) scales: Vec<(f64, f64)>,
    pub(super) chi2: f64,
    pub(super) dof: usize,
    pub(super) points: usize,
    pub(super) iterations: usize,
    pub(super) uncertainty_basis: String,
    pub(super) uncertainty_scale: f64,
    pub(super) warnings: Vec<String>,
}

/// The multi-angle readout as kept.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub(super) struct MultiRec {
    pub(super) theta_i: f64,
    /// `(aspecular, reflectance factor, L*)`.
    pub(super) readouts: Vec<(f64, f64, f64)>,
    pub(super) flop_index: Option<f64>,
}

/// The model results as kept.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub(super) struct ModelCache {
    pub(super) key: String,
    pub(super) curves: Vec<CurveRec>,
    /// Failures of single models (the others still run), `(model, message)`.
    pub(super) failures: Vec<(String, String)>,
    pub(super) fit: Option<Result<FitRec, String>>,
    pub(super) multi_angle: Option<Result<MultiRec, String>>,
    pub(super) topo_warnings: Vec<String>,
}

/// What an earlier run of the same report directory left (module docs).
#[derive(Debug, Clone, Default)]
pub struct Cache {
    pub(super) maps: BTreeMap<String, MapCache>,
    pub(super) models: Option<ModelCache>,
    pub(super) paint: Option<Value>,
}

/// Reads the cache of the report directory `dir` (the sample's own directory): files
/// that are missing or cannot be parsed are ignored (the work is then redone).
#[must_use]
pub fn read_cache(dir: &Path, map_names: &[String]) -> Cache {
    let mut c = Cache::default();
    for name in map_names {
        let p = dir.join("cache").join("maps").join(format!("{name}.json"));
        if let Some(m) = read_text(&p)
            .ok()
            .and_then(|t| serde_json::from_str::<MapCache>(&t).ok())
        {
            c.maps.insert(name.clone(), m);
        }
    }
    c.models = read_text(dir.join("cache").join("models.json"))
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok());
    c.paint = read_text(dir.join("cache").join("paint.json"))
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok());
    c
}

fn row_rec(r: &CurveRow) -> RowRec {
    RowRec {
        theta_i: r.theta_i,
        detector: r.detector,
        brdf: r.brdf,
        reflectance: r.reflectance,
        relative: r.relative,
        rays: r.rays,
        std_err: r.std_err,
    }
}

pub(super) fn curve_rec(label: &str, c: &Curves) -> CurveRec {
    CurveRec {
        label: label.to_owned(),
        model: c.model.to_owned(),
        source: c.source.clone(),
        rows: c.rows.iter().map(row_rec).collect(),
    }
}

/// The cache files of a report: each map's segmentation under its name, then the
/// model results.
pub(super) fn files(
    names: &[String],
    map_caches: &[MapCache],
    models: &ModelCache,
) -> Vec<OutFile> {
    let text = |path: &str, t: String| OutFile {
        path: path.to_owned(),
        content: Content::Text(t),
    };
    let mut files = Vec::new();
    for (k, c) in map_caches.iter().enumerate() {
        files.push(text(
            &format!("cache/maps/{}.json", names[k]),
            serde_json::to_string(c).unwrap_or_default() + "\n",
        ));
    }
    files.push(text(
        "cache/models.json",
        serde_json::to_string(models).unwrap_or_default() + "\n",
    ));
    files
}
