//! The comparison across samples: each sample's line ([`SampleRow`]) and the batch's
//! `samples.csv` and document.

use std::fmt::Write as _;

use serde::{Deserialize, Serialize};

use super::cache::ModelCache;
use super::document::{Block, Document};
use super::format::{ci_deg, deg, fmt_ci, num};
use crate::compare::IncidenceComparison;
use crate::sample::SampleStatistics;

/// One sample's line in a comparison across samples.
///
/// As JSON (summary.json `comparison_row`) a non-finite number is written `null`
/// (serde_json's rule) and read back as NaN, so a row read back prints the same line.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(from = "RowRecord")]
pub struct SampleRow {
    /// Sample name.
    pub name: String,
    /// Maps.
    pub maps: usize,
    /// Flakes.
    pub flakes: usize,
    /// Pooled hwhm, degrees.
    pub hwhm_deg: f64,
    /// Its quoted 95 % interval, degrees (`None` for an infinite end).
    pub hwhm_ci95_deg: (Option<f64>, Option<f64>),
    /// Which interval that is (`map level` or `flake level`).
    pub interval: String,
    /// Width fitted to the measured curve, degrees, with its standard uncertainty.
    pub fitted_hwhm_deg: Option<(f64, f64)>,
    /// Near-specular rms log10 residual per model and incidence: `(model, θi°, rms)`.
    pub near_specular: Vec<(String, f64, Option<f64>)>,
    /// Multi-angle lightness at 15°, 45°, 110° aspecular, and the flop index.
    pub lightness: Option<(f64, f64, f64, Option<f64>)>,
}

/// Four numbers of which any may be `null` (the lightness readout as read from JSON).
type MaybeFour = (Option<f64>, Option<f64>, Option<f64>, Option<f64>);

/// [`SampleRow`] as read from JSON: every number may be `null` (a NaN written).
#[derive(Deserialize)]
struct RowRecord {
    name: String,
    maps: usize,
    flakes: usize,
    hwhm_deg: Option<f64>,
    hwhm_ci95_deg: (Option<f64>, Option<f64>),
    interval: String,
    fitted_hwhm_deg: Option<(Option<f64>, Option<f64>)>,
    near_specular: Vec<(String, Option<f64>, Option<f64>)>,
    lightness: Option<MaybeFour>,
}

impl From<RowRecord> for SampleRow {
    fn from(r: RowRecord) -> Self {
        let n = |x: Option<f64>| x.unwrap_or(f64::NAN);
        Self {
            name: r.name,
            maps: r.maps,
            flakes: r.flakes,
            hwhm_deg: n(r.hwhm_deg),
            hwhm_ci95_deg: r.hwhm_ci95_deg,
            interval: r.interval,
            fitted_hwhm_deg: r.fitted_hwhm_deg.map(|(a, b)| (n(a), n(b))),
            near_specular: r
                .near_specular
                .into_iter()
                .map(|(m, t, v)| (m, n(t), v))
                .collect(),
            lightness: r.lightness.map(|(a, b, c, d)| (n(a), n(b), n(c), d)),
        }
    }
}

/// The line of sample `name` of `maps` maps; `qname` names its quoted interval.
pub(super) fn row(
    name: &str,
    maps: usize,
    stats: &SampleStatistics,
    models: &ModelCache,
    comparisons: &[(String, Vec<IncidenceComparison>)],
    qname: &str,
) -> SampleRow {
    let p = &stats.pooled;
    let flake = &p.flake_level;
    let fitted = models
        .fit
        .as_ref()
        .and_then(|f| f.as_ref().ok())
        .map(|f| (f.hwhm.to_degrees(), f.hwhm_std.to_degrees()));
    let near: Vec<(String, f64, Option<f64>)> = comparisons
        .iter()
        .flat_map(|(label, cs)| {
            cs.iter().map(move |c| {
                (
                    label.clone(),
                    deg(c.theta_i),
                    c.regions
                        .iter()
                        .find(|r| r.region.name() == "near-specular")
                        .and_then(|r| r.rms_log10),
                )
            })
        })
        .collect();
    let lightness = models
        .multi_angle
        .as_ref()
        .and_then(|r| r.as_ref().ok())
        .map(|r| {
            let l = |k: usize| r.readouts.get(k).map_or(f64::NAN, |x| x.2);
            (l(1), l(3), l(5), r.flop_index)
        });
    SampleRow {
        name: name.to_owned(),
        maps,
        flakes: stats.histogram.flakes(),
        hwhm_deg: p.hwhm().to_degrees(),
        hwhm_ci95_deg: ci_deg(p.map_level.map_or(flake.hwhm_ci95(), |ml| ml.hwhm_ci95())),
        interval: qname.into(),
        fitted_hwhm_deg: fitted,
        near_specular: near,
        lightness,
    }
}

/// The comparison across samples: `samples.csv` and a document (`index.md`,
/// `index.html` of the batch directory) with one line per sample.
#[must_use]
pub fn comparison_report(rows: &[SampleRow]) -> (String, Document) {
    let models: Vec<String> = {
        let mut v: Vec<String> = Vec::new();
        for r in rows {
            for (m, t, _) in &r.near_specular {
                let k = format!("{m} θi {t}");
                if !v.contains(&k) {
                    v.push(k);
                }
            }
        }
        v
    };
    let mut csv = String::from(
        "sample,maps,flakes,hwhm_deg,hwhm_ci95_lo_deg,hwhm_ci95_hi_deg,interval,fitted_hwhm_deg,fitted_hwhm_std_deg,l15,l45,l110,flop_index",
    );
    for m in &models {
        let _ = write!(csv, ",rms_near_specular[{m}]");
    }
    csv.push('\n');
    let o = |x: Option<f64>| x.map(num).unwrap_or_default();
    let mut table = Vec::new();
    for r in rows {
        let l = r.lightness;
        let _ = write!(
            csv,
            "{},{},{},{},{},{},{},{},{},{},{},{},{}",
            r.name,
            r.maps,
            r.flakes,
            num(r.hwhm_deg),
            o(r.hwhm_ci95_deg.0),
            o(r.hwhm_ci95_deg.1),
            r.interval,
            o(r.fitted_hwhm_deg.map(|f| f.0)),
            o(r.fitted_hwhm_deg.map(|f| f.1)),
            o(l.map(|l| l.0)),
            o(l.map(|l| l.1)),
            o(l.map(|l| l.2)),
            o(l.and_then(|l| l.3)),
        );
        let mut near_cells = Vec::new();
        for m in &models {
            let v = r
                .near_specular
                .iter()
                .find(|(a, t, _)| format!("{a} θi {t}") == *m)
                .and_then(|x| x.2);
            let _ = write!(csv, ",{}", o(v));
            near_cells.push(v.map_or_else(|| "—".into(), |v| format!("{v:.3}")));
        }
        csv.push('\n');
        let mut cells = vec![
            format!("[{0}]({0}/index.md)", r.name),
            r.maps.to_string(),
            r.flakes.to_string(),
            format!("{:.3}", r.hwhm_deg),
            format!("{} ({})", fmt_ci(r.hwhm_ci95_deg), r.interval),
            r.fitted_hwhm_deg
                .map_or_else(|| "—".into(), |f| format!("{:.3} ± {:.3}", f.0, f.1)),
            l.map_or_else(
                || "—".into(),
                |l| format!("{:.1} / {:.1} / {:.1}", l.0, l.1, l.2),
            ),
        ];
        cells.extend(near_cells);
        table.push(cells);
    }
    let mut d = Document::default();
    d.push(Block::Heading(
        1,
        format!("{} samples compared", rows.len()),
    ));
    d.push(Block::Para(
        "Per sample: the pooled flake width with its quoted 95 % interval (map level when the sample has two or more maps), \
         the width fitted to its measured curve, the multi-angle lightness L* at 15°/45°/110° aspecular (distribution model with the pooled width) \
         and the near-specular rms log10 residual of each model. Each sample's own report is linked; `samples.csv` holds the same numbers."
            .into(),
    ));
    let mut header = vec![
        "sample".into(),
        "maps".into(),
        "flakes".into(),
        "hwhm (°)".into(),
        "95 % interval (°)".into(),
        "fitted hwhm (°)".into(),
        "L* 15/45/110".into(),
    ];
    header.extend(models.iter().map(|m| format!("rms near-specular, {m}")));
    d.push(Block::Table(header, table));
    (csv, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A row with NaNs where `row` puts them (a missing readout's lightness, a fit
    /// without its uncertainty) goes through JSON (`null`) and prints the same
    /// samples.csv line; the in-memory line is the reference.
    #[test]
    fn a_row_with_nans_reads_back_from_json_to_the_same_line() {
        let row = SampleRow {
            name: "a".into(),
            maps: 2,
            flakes: 31,
            hwhm_deg: 6.25,
            hwhm_ci95_deg: (Some(5.5), None),
            interval: "map level".into(),
            fitted_hwhm_deg: Some((6.0, f64::NAN)),
            near_specular: vec![("distribution".into(), 30.0, None)],
            lightness: Some((f64::NAN, 41.5, f64::NAN, None)),
        };
        let text = serde_json::to_string(&row).unwrap();
        assert!(text.contains("null"), "{text}");
        let back: SampleRow = serde_json::from_str(&text).unwrap();
        assert_eq!(comparison_report(&[back]).0, comparison_report(&[row]).0);
    }
}
