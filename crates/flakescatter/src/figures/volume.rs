//! The multiple-scattering figure (issue 20): how much of the light the paper's coating
//! returns at each angle from specular has met more than one flake, from the volume
//! model (physics.md §10), answering the paper's question about its third region
//! (beyond 40° from specular, "predominantly multiple scattering"?) with a number.
//!
//! The coating is the paper's: a 38 µm film of index 1.5 holding aluminium flakes of
//! mean diameter 16 µm (log-normal, relative sd 0.25) and 1 µm thickness at 5 % by mass
//! in a 1.2 g/cm³ binder, centres anywhere in the film, Gaussian orientations of hwhm
//! 6° (the width the paper found to fit), perfect-conductor faces, absorbing rims, a
//! black substrate. Detectors are in-plane 1.5° cones every 3° (touching, not
//! overlapping). Several independent layers (seeds 1…K) are traced; each number is the
//! ratio of sums over the layers with the ratio estimator's standard error from the
//! scatter between them, so it carries the layer-to-layer (flake sampling) variation as
//! well as the ray sampling. Shares are of the flake light (the first-surface reflection,
//! which only the specular cone sees, is left out); a region's share weights each of
//! its detectors by the power it collects.
//!
//! Conventions: radians in the API, degrees in the files; `aspecular = θs + θi`
//! (positive toward the source).

use std::fmt::Write as _;

use flakescatter_optics::flake::FlakeReflectance;
use serde_json::{Value, json};

use super::{APERTURE_DEG, FiguresError, INCIDENCES, Index, Report, gaussian, sig};
use crate::chart::{Chart, Series, Style};
use crate::compare::Region;
use crate::instrument::{DetectorSet, Instrument};
use crate::pipeline::{Coating, OrientationSource};
use crate::volume::{Amount, Depth, Diameter, RimRule, Substrate, VolumeSettings, volume_curves};

/// Orientation width of the layers, degrees (the paper's better fit).
const HWHM_DEG: f64 = 6.0;
/// Detector spacing, degrees (two 1.5° half-angles: cones touch without overlapping).
const STEP_DEG: i32 = 3;
/// Largest |θs|, degrees.
const MAX_THETA_S_DEG: i32 = 84;

/// How much is traced.
#[derive(Debug, Clone, Copy)]
struct Sampling {
    /// Independent layers (seeds 1..=layers).
    layers: u64,
    /// Tile side, µm.
    tile_um: f64,
    /// Rays per incidence and layer.
    rays: u64,
}

impl Sampling {
    fn new(quick: bool) -> Self {
        if quick {
            Self {
                layers: 3,
                tile_um: 500.0,
                rays: 64 * 200,
            }
        } else {
            // The far region's share is decided by the few steep flakes a layer holds:
            // many flakes (8 layers of about 25 000) matter more than rays per flake
            // (2.6 here). 16 layers of 4000 µm tiles at 2^17 rays gave 50.9 ± 1.8 % and
            // 39.4 ± 1.3 % beyond 40° (θi = 30°, 60°), within one standard error of these.
            Self {
                layers: 8,
                tile_um: 2500.0,
                rays: 1 << 16,
            }
        }
    }
}

/// `ΣM / ΣT` over replicates with the ratio estimator's standard error
/// `sqrt(Σ (M_k − r T_k)² / (K (K − 1))) / T̄` (NaN for one replicate or `ΣT = 0`).
pub(super) fn ratio(m: &[f64], t: &[f64]) -> (f64, f64) {
    let k = m.len() as f64;
    let (sm, st): (f64, f64) = (m.iter().sum(), t.iter().sum());
    if st <= 0.0 {
        return (f64::NAN, f64::NAN);
    }
    let r = sm / st;
    if m.len() < 2 {
        return (r, f64::NAN);
    }
    let ss: f64 = m.iter().zip(t).map(|(a, b)| (a - r * b).powi(2)).sum();
    (r, (ss / (k * (k - 1.0))).sqrt() / (st / k))
}

/// Mean and standard error of the mean (NaN for one value).
fn mean_se(x: &[f64]) -> (f64, f64) {
    let k = x.len() as f64;
    let mean = x.iter().sum::<f64>() / k;
    if x.len() < 2 {
        return (mean, f64::NAN);
    }
    let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (k - 1.0);
    (mean, (var / k).sqrt())
}

/// A number for the CSV: 10 significant digits, empty when undefined.
fn cell(x: f64) -> String {
    if x.is_finite() {
        format!("{x:.9e}")
    } else {
        String::new()
    }
}

/// A share as a percentage with its standard error, for text (`37.2 ± 2.1 %`).
/// The standard error to two significant digits and the share to the same decimal
/// place (at least one).
fn percent((r, se): (f64, f64)) -> String {
    if !r.is_finite() {
        return "undefined (no light)".into();
    }
    let (r, se) = (100.0 * r, 100.0 * se);
    if se.is_finite() && se > 0.0 {
        let d = (1.0 - se.log10().floor()).clamp(1.0, 4.0) as usize;
        format!("{r:.d$} ± {se:.d$} %")
    } else {
        format!("{r:.1} %")
    }
}

/// The figure: CSV, two charts, its `index.md` entry; returns its `comparison.json`
/// part.
pub(super) fn multiple_scattering(
    quick: bool,
    report: &mut Report,
    index: &mut Index,
) -> Result<Value, FiguresError> {
    let sampling = Sampling::new(quick);
    let traced = trace(&sampling)?;
    let (flakes, segments, rays_per_incidence) =
        (&traced.flakes, traced.segments, traced.rays_per_incidence);
    let mut csv = String::from(
        "theta_i_deg,theta_s_deg,aspecular_deg,region,single_bounce_brdf_per_sr,single_bounce_std_err_per_sr,multiple_bounce_brdf_per_sr,multiple_bounce_std_err_per_sr,multiple_share,multiple_share_std_err\n",
    );
    let mut share_series = Vec::new();
    let mut brdf_series = Vec::new();
    let mut per_incidence = Vec::new();
    let mut far_text = Vec::new();
    let mut beyond = Vec::new();
    let mut near_max_text = Vec::new();
    let mut far_first_text = Vec::new();
    for (ii, &ti) in INCIDENCES.iter().enumerate() {
        let found = incidence(&traced, sampling.layers, ii, ti, &mut csv);
        near_max_text.push(found.near_max_text);
        far_first_text.push(found.far_first_text);
        beyond.push(found.beyond);
        far_text.push(found.far_text);
        per_incidence.push(found.json);
        push_series(&mut share_series, &mut brdf_series, ii, ti, found.points);
    }
    // The region boundaries, ±40° from specular (unlabelled; the axis label says so).
    for x in [-40.0, 40.0] {
        share_series.push(Series {
            label: String::new(),
            points: vec![(x, 0.0), (x, 1.0)],
            style: Style::Dashed,
            colour: 5,
        });
    }
    let mean_flakes = flakes.iter().sum::<f64>() / flakes.len() as f64;
    let what = format!(
        "volume model, {} layers of {:.0} flakes in {} µm tiles, {} rays per incidence each",
        sampling.layers, mean_flakes, sampling.tile_um, rays_per_incidence
    );
    let short = format!(
        "{} layers × {:.0} flakes, hwhm {HWHM_DEG}°",
        sampling.layers, mean_flakes
    );
    draw(report, csv, share_series, brdf_series, &short, &far_text);
    let texts = Texts {
        what,
        beyond,
        near_max: near_max_text,
        far_first: far_first_text,
    };
    describe(index, &sampling, &per_incidence, &texts);
    Ok(json!({
        "description": "volume model of the paper's coating: multiple-bounce share of the flake light a region's detectors collect (power-weighted), ratio of sums over independent layers with the ratio estimator's standard error",
        "layers": sampling.layers,
        "tile_um": sampling.tile_um,
        "rays_per_incidence": rays_per_incidence,
        "mean_flakes_per_layer": sig(mean_flakes),
        "segments": segments,
        "hwhm_deg": HWHM_DEG,
        "aperture_deg": APERTURE_DEG,
        "detector_step_deg": STEP_DEG,
        "incidences": per_incidence,
    }))
}

/// What the layers gave, rows incidence-major (`ii · detectors + j`).
struct Traced {
    /// The detectors' θs, degrees.
    ts_deg: Vec<f64>,
    /// The detectors' projected solid angles, sr.
    proj: Vec<f64>,
    /// Per row, the single-bounce BRDF of each layer, 1/sr.
    single: Vec<Vec<f64>>,
    /// Per row, the multiple-bounce BRDF of each layer, 1/sr.
    multiple: Vec<Vec<f64>>,
    /// Per incidence, the escaped single and multiple fractions of each layer.
    escaped: Vec<(Vec<f64>, Vec<f64>)>,
    /// Flakes of each layer.
    flakes: Vec<f64>,
    /// Ray segments traced over all layers.
    segments: u64,
    /// Rays per incidence and layer.
    rays_per_incidence: u64,
}

/// Traces the layers of the paper's coating (module docs), one per seed.
fn trace(sampling: &Sampling) -> Result<Traced, FiguresError> {
    let ts_deg: Vec<f64> = (-MAX_THETA_S_DEG / STEP_DEG..=MAX_THETA_S_DEG / STEP_DEG)
        .map(|k| f64::from(k * STEP_DEG))
        .collect();
    let instrument = Instrument::new(
        INCIDENCES.iter().map(|d| d.to_radians()).collect(),
        DetectorSet::InPlane(ts_deg.iter().map(|d| d.to_radians()).collect()),
        APERTURE_DEG.to_radians(),
    )?;
    let coating = Coating {
        n: 1.5,
        flake: FlakeReflectance::PerfectConductor,
    };
    let source = OrientationSource::Distribution(gaussian(HWHM_DEG)?);
    let nd = ts_deg.len();
    let nrows = INCIDENCES.len() * nd;
    // Per layer: single and multiple BRDF of every row, and the escaped fractions.
    let mut single = vec![Vec::new(); nrows];
    let mut multiple = vec![Vec::new(); nrows];
    let mut escaped: Vec<(Vec<f64>, Vec<f64>)> = vec![(Vec::new(), Vec::new()); INCIDENCES.len()];
    let mut flakes = Vec::new();
    let mut segments = 0u64;
    let mut rays_per_incidence = 0;
    for seed in 1..=sampling.layers {
        let settings = VolumeSettings {
            film_um: 38.0,
            diameter: Diameter::LogNormal {
                mean_um: 16.0,
                rel_sd: 0.25,
            },
            thickness_um: 1.0,
            amount: Amount::MassLoading {
                fraction: 0.05,
                binder_density_g_cm3: 1.2,
            },
            depth: Depth::WholeFilm,
            tile_um: sampling.tile_um,
            substrate: Substrate::Black,
            rims: RimRule::Absorb,
            rays: sampling.rays,
            // One layer per seed: the figure draws its layers itself, one per seed.
            layers: 1,
            seed,
            ..VolumeSettings::default()
        };
        let c = volume_curves(&coating, &instrument, &settings, &source, &|_, _| {})?;
        for (k, r) in c.rows.iter().enumerate() {
            single[k].push(r.single_bounce_brdf);
            multiple[k].push(r.multiple_bounce_brdf);
        }
        for (k, (_, e)) in c.energy.iter().enumerate() {
            escaped[k].0.push(e.escaped_single);
            escaped[k].1.push(e.escaped_multiple);
        }
        flakes.push(c.layer.flakes as f64);
        segments += c.segments;
        rays_per_incidence = c.rays_per_incidence;
    }
    let proj: Vec<f64> = instrument
        .cones()
        .iter()
        .map(flakescatter_optics::detector::Cone::projected_solid_angle)
        .collect();
    Ok(Traced {
        ts_deg,
        proj,
        single,
        multiple,
        escaped,
        flakes,
        segments,
        rays_per_incidence,
    })
}

/// One incidence's curves for the charts, `(aspecular°, value)`.
struct Points {
    /// Multiple-bounce share.
    share: Vec<(f64, f64)>,
    /// Share + 1 standard error.
    hi: Vec<(f64, f64)>,
    /// Share − 1 standard error.
    lo: Vec<(f64, f64)>,
    /// Single-bounce BRDF, 1/sr.
    s_pts: Vec<(f64, f64)>,
    /// Multiple-bounce BRDF, 1/sr.
    m_pts: Vec<(f64, f64)>,
}

/// What one incidence found.
struct Found {
    points: Points,
    /// Its `comparison.json` entry.
    json: Value,
    /// The far region's share, for text.
    far_text: String,
    /// From which angle on only multiple scattering arrives, for text.
    beyond: String,
    /// The largest per-detector share 5°–40° from specular, for text.
    near_max_text: String,
    /// The far region's flake light within 15° of its boundary, for text.
    far_first_text: String,
}

/// Incidence `ii` (θi = `ti` degrees) of the traced layers: its CSV rows (appended to
/// `csv`), its curves, its shares by region and its numbers for the text.
fn incidence(t: &Traced, layers: u64, ii: usize, ti: f64, csv: &mut String) -> Found {
    let Traced {
        ts_deg,
        proj,
        single,
        multiple,
        escaped,
        ..
    } = t;
    let nd = ts_deg.len();
    let (mut share, mut hi, mut lo, mut s_pts, mut m_pts) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (j, &ts) in ts_deg.iter().enumerate() {
        let k = ii * nd + j;
        let a = ts + ti;
        let region = Region::of(ti.to_radians(), ts.to_radians());
        let (s, s_se) = mean_se(&single[k]);
        let (m, m_se) = mean_se(&multiple[k]);
        let total: Vec<f64> = single[k]
            .iter()
            .zip(&multiple[k])
            .map(|(x, y)| x + y)
            .collect();
        let (r, r_se) = ratio(&multiple[k], &total);
        let _ = writeln!(
            csv,
            "{ti},{ts},{a},{},{},{},{},{},{},{}",
            region.name(),
            cell(s),
            cell(s_se),
            cell(m),
            cell(m_se),
            cell(r),
            cell(r_se)
        );
        share.push((a, r));
        hi.push((a, r + r_se));
        lo.push((a, r - r_se));
        s_pts.push((a, s));
        m_pts.push((a, m));
    }
    // The largest per-detector share 5°–40° from specular, and how much of the far
    // region's flake light (layer means × projected solid angle) arrives within 15°
    // of its boundary.
    let near_max = (0..nd)
        .filter(|&j| Region::of(ti.to_radians(), ts_deg[j].to_radians()) == Region::NearSpecular)
        .map(|j| share[j].1)
        .filter(|r| r.is_finite())
        .fold(f64::NAN, f64::max);
    let far_power = |within: f64| -> f64 {
        (0..nd)
            .filter(|&j| {
                let a = (ts_deg[j] + ti).abs();
                Region::of(ti.to_radians(), ts_deg[j].to_radians()) == Region::Far && a <= within
            })
            .map(|j| (s_pts[j].1 + m_pts[j].1) * proj[j])
            .sum()
    };
    let near_max_text = format!("{:.0} % (θi = {ti}°)", 100.0 * near_max);
    let far_first_text = format!(
        "{:.0} % (θi = {ti}°)",
        100.0 * far_power(55.0) / far_power(f64::INFINITY)
    );
    // From which angle on no layer sends a single reflection to any detector.
    let only_multiple = s_pts
        .iter()
        .rposition(|&(_, s)| s > 0.0)
        .and_then(|j| s_pts.get(j + 1))
        .map(|&(a, _)| a);
    let beyond = match only_multiple {
        Some(a) => format!("{a}° (θi = {ti}°)"),
        None => format!("nowhere (θi = {ti}°)"),
    };
    let (regions, far_text) = regions(t, layers, ii, ti);
    let (r_all, se_all) = ratio(&escaped[ii].1, &{
        escaped[ii]
            .0
            .iter()
            .zip(&escaped[ii].1)
            .map(|(a, b)| a + b)
            .collect::<Vec<_>>()
    });
    let (es, _) = mean_se(&escaped[ii].0);
    let (em, _) = mean_se(&escaped[ii].1);
    let json = json!({
        "theta_i_deg": ti,
        "regions": regions,
        "escaped_single": sig(es),
        "escaped_multiple": sig(em),
        "hemisphere_multiple_share": sig(r_all),
        "hemisphere_multiple_share_std_err": sig(se_all),
    });
    Found {
        points: Points {
            share,
            hi,
            lo,
            s_pts,
            m_pts,
        },
        json,
        far_text,
        beyond,
        near_max_text,
        far_first_text,
    }
}

/// The multiple-bounce share of the power the detectors of each region collect at
/// incidence `ii` (θi = `ti` degrees), ratio of sums over the layers; and the far
/// region's share for text.
fn regions(t: &Traced, layers: u64, ii: usize, ti: f64) -> (Vec<Value>, String) {
    let Traced {
        ts_deg,
        proj,
        single,
        multiple,
        ..
    } = t;
    let nd = ts_deg.len();
    let mut far_text = String::new();
    let mut regions = Vec::new();
    for region in Region::ALL {
        let js: Vec<usize> = (0..nd)
            .filter(|&j| Region::of(ti.to_radians(), ts_deg[j].to_radians()) == region)
            .collect();
        let sum = |v: &[Vec<f64>], l: usize| -> f64 {
            js.iter().map(|&j| v[ii * nd + j][l] * proj[j]).sum()
        };
        let layers = layers as usize;
        let m: Vec<f64> = (0..layers).map(|l| sum(multiple, l)).collect();
        let t: Vec<f64> = (0..layers)
            .map(|l| sum(single, l) + sum(multiple, l))
            .collect();
        let (r, se) = ratio(&m, &t);
        if region == Region::Far {
            far_text = format!("{} (θi = {ti}°)", percent((r, se)));
        }
        regions.push(json!({
            "region": region.name(),
            "detectors": js.len(),
            "multiple_share": sig(r),
            "std_err": sig(se),
        }));
    }
    (regions, far_text)
}

/// Adds incidence `ii`'s curves to the share chart's and the BRDF chart's series.
fn push_series(
    share_series: &mut Vec<Series>,
    brdf_series: &mut Vec<Series>,
    ii: usize,
    ti: f64,
    points: Points,
) {
    let Points {
        share,
        hi,
        lo,
        s_pts,
        m_pts,
    } = points;
    let label = format!("θi = {ti}°");
    share_series.push(Series {
        label: label.clone(),
        points: share,
        style: Style::Line,
        colour: ii,
    });
    share_series.push(Series {
        label: if ii == 0 {
            "dashed: ± 1 standard error".into()
        } else {
            String::new()
        },
        points: hi,
        style: Style::Dashed,
        colour: ii,
    });
    share_series.push(Series {
        label: String::new(),
        points: lo,
        style: Style::Dashed,
        colour: ii,
    });
    brdf_series.push(Series {
        label: format!("single bounce, {label}"),
        points: s_pts,
        style: Style::Line,
        colour: ii,
    });
    brdf_series.push(Series {
        label: format!("multiple bounces, {label}"),
        points: m_pts,
        style: Style::Dashed,
        colour: ii,
    });
}

/// Writes the CSV and draws the two charts.
fn draw(
    report: &mut Report,
    csv: String,
    share_series: Vec<Series>,
    brdf_series: Vec<Series>,
    short: &str,
    far_text: &[String],
) {
    report.text("multiple_scattering.csv", csv);
    report.chart(
        "multiple_scattering_share",
        Chart {
            title: format!(
                "Multiple scattering in the paper's coating (volume model)\n{short}; beyond 40° from specular (brown lines): {}",
                far_text.join(", ")
            ),
            x_label: "θs + θi, angle from specular (degrees; positive toward the source)".into(),
            y_label: "multiple-bounce share of the flake light (1 = all)".into(),
            log_y: false,
            series: share_series,
        },
    );
    report.chart(
        "multiple_scattering_brdf",
        Chart {
            title: format!(
                "Single and multiple bounces in the paper's coating (volume model)\nBRDF, mean over {short}; first-surface reflection left out"
            ),
            x_label: "θs + θi, angle from specular (degrees; positive toward the source)".into(),
            y_label: "BRDF (1/sr)".into(),
            log_y: true,
            series: brdf_series,
        },
    );
}

/// The numbers of the text besides the shares by region.
struct Texts {
    /// What was traced.
    what: String,
    /// Per incidence, from which angle on only multiple scattering arrives.
    beyond: Vec<String>,
    /// Per incidence, the largest per-detector share 5°–40° from specular.
    near_max: Vec<String>,
    /// Per incidence, the far region's flake light within 15° of its boundary.
    far_first: Vec<String>,
}

/// The figure's `index.md` entry: the question, the method and the answer.
fn describe(index: &mut Index, sampling: &Sampling, per_incidence: &[Value], texts: &Texts) {
    let Texts {
        what,
        beyond,
        near_max: near_max_text,
        far_first: far_first_text,
    } = texts;
    let region_text = |ii: usize, name: &str| -> String {
        let r = &per_incidence[ii]["regions"];
        r.as_array()
            .and_then(|v| v.iter().find(|x| x["region"] == name))
            .map(|x| {
                percent((
                    x["multiple_share"].as_f64().unwrap_or(f64::NAN),
                    x["std_err"].as_f64().unwrap_or(f64::NAN),
                ))
            })
            .unwrap_or_default()
    };
    let verdict: Vec<String> = INCIDENCES
        .iter()
        .enumerate()
        .map(|(ii, ti)| {
            let r = per_incidence[ii]["regions"][2]["multiple_share"]
                .as_f64()
                .unwrap_or(f64::NAN);
            let se = per_incidence[ii]["regions"][2]["std_err"]
                .as_f64()
                .unwrap_or(f64::NAN);
            let word = if !(r.is_finite() && se.is_finite()) {
                "cannot be told"
            } else if r - 2.0 * se > 0.5 {
                "holds"
            } else if r + 2.0 * se < 0.5 {
                "does not hold"
            } else {
                "is not decided at this sample size"
            };
            format!("{word} at θi = {ti}°")
        })
        .collect();
    let files = [
        "multiple_scattering.csv".to_string(),
        "multiple_scattering_share.svg".into(),
        "multiple_scattering_share.png".into(),
        "multiple_scattering_brdf.svg".into(),
        "multiple_scattering_brdf.png".into(),
    ];
    index.add(
        "Multiple scattering — the paper's region 3 (beyond 40° from specular)",
        &files,
        format!(
            "Not a figure of the paper: its question. The paper attributes its third region \
             (beyond 40° from specular, where both its models fail) to \"predominantly \
             multiple scattering\" and calls for a model with flake sizes and positions. The \
             volume model (physics.md §10) places the paper's coating in three dimensions — \
             38 µm film, n = 1.5, flakes of mean diameter 16 µm (log-normal, relative sd \
             0.25), 1 µm thick, 5 % aluminium by mass in a 1.2 g/cm³ binder (volume fraction \
             0.0229), centres anywhere in the film, Gaussian orientations of hwhm {HWHM_DEG}°, \
             perfect-conductor faces, absorbing rims, black substrate — and follows every ray \
             until it leaves: {what}, in-plane cones of {APERTURE_DEG}° every {STEP_DEG}° \
             (physical weighting whatever `--weighting` says). The share is the light that met \
             two or more flakes, or was reflected back down by the top interface, over all the \
             flake light a detector collects (the first-surface reflection left out); ± is the \
             standard error from the scatter between the independent layers (ratio of sums, \
             {} degrees of freedom), which includes the flake-sampling variation. \
             **Answer:** beyond 40° from specular multiple scattering carries {far30} of the \
             flake light at θi = 30° and {far60} at θi = 60° (5°–40°: {near30} and {near60}; \
             within 5°: {spec30} and {spec60}); over the whole hemisphere {hemi30} and \
             {hemi60} of the light the flakes return. The paper's suggestion that region 3 is \
             \"predominantly multiple scattering\" (read as a share above 50 % by more than \
             two standard errors) {verdict}, for this coating in this model. Per detector \
             (`multiple_scattering_share`) the share is at most {near_max} from 5° to 40° \
             and rises steeply beyond: from {beyond} on no layer sends a single reflection \
             into any detector (the Gaussian of hwhm {HWHM_DEG}° holds almost no flakes \
             tilted that far), so all the flake light there is multiply scattered; but it is \
             faint (`multiple_scattering_brdf`), and {far_first} of region 3's flake light \
             arrives within 15° of its boundary, where single reflections from the steepest \
             flakes still compete. Roughness of the flake faces and scattering by \
             their edges, which the paper also names, are not in the model. \
             `multiple_scattering.csv`: `theta_i_deg, theta_s_deg, aspecular_deg` (θs + θi), \
             `region`, `single_bounce_brdf_per_sr`, `multiple_bounce_brdf_per_sr` (means over \
             the layers, sr⁻¹) with standard errors, `multiple_share` with its standard error \
             (empty where no flake light arrives).",
            sampling.layers - 1,
            far30 = region_text(0, "far"),
            far60 = region_text(1, "far"),
            near30 = region_text(0, "near-specular"),
            near60 = region_text(1, "near-specular"),
            spec30 = region_text(0, "specular"),
            spec60 = region_text(1, "specular"),
            hemi30 = percent((
                per_incidence[0]["hemisphere_multiple_share"]
                    .as_f64()
                    .unwrap_or(f64::NAN),
                per_incidence[0]["hemisphere_multiple_share_std_err"]
                    .as_f64()
                    .unwrap_or(f64::NAN)
            )),
            hemi60 = percent((
                per_incidence[1]["hemisphere_multiple_share"]
                    .as_f64()
                    .unwrap_or(f64::NAN),
                per_incidence[1]["hemisphere_multiple_share_std_err"]
                    .as_f64()
                    .unwrap_or(f64::NAN)
            )),
            verdict = verdict.join(" and "),
            beyond = beyond.join(" and "),
            near_max = near_max_text.join(" and "),
            far_first = far_first_text.join(" and "),
        ),
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ratio_estimator_matches_a_hand_computation() {
        // M = (1, 2, 3), T = (2, 4, 5): r = 6/11; residuals M − rT = (−1, −2, 3)/11, their
        // squares sum to 14/121; se = sqrt(14/121 / (3·2)) / (11/3).
        let (r, se) = ratio(&[1.0, 2.0, 3.0], &[2.0, 4.0, 5.0]);
        assert!((r - 6.0 / 11.0).abs() < 1e-15);
        let want = (14.0f64 / 121.0 / 6.0).sqrt() * 3.0 / 11.0;
        assert!((se - want).abs() < 1e-15, "{se} vs {want}");
        // Proportional replicates have no scatter in the ratio.
        let (r, se) = ratio(&[1.0, 2.0], &[4.0, 8.0]);
        assert!((r - 0.25).abs() < 1e-15 && se.abs() < 1e-15);
        assert!(ratio(&[0.0, 0.0], &[0.0, 0.0]).0.is_nan());
        assert!(ratio(&[1.0], &[2.0]).1.is_nan());
        // Mean and standard error of (1, 2, 3, 6): mean 3, sample variance 14/3.
        let (m, s) = mean_se(&[1.0, 2.0, 3.0, 6.0]);
        assert!((m - 3.0).abs() < 1e-15 && (s - (14.0f64 / 3.0 / 4.0).sqrt()).abs() < 1e-15);
    }
}
