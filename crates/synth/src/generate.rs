//! The generator: flakes → height map, intensity map, label map and truth table.
//!
//! Conventions: lengths in µm, angles in radians, `z` up, heights from the substrate
//! (`z = 0`); map axes `x = col * dx`, `y = row * dy` (row-major). `θn` is the polar angle
//! of a flake normal from `z`; `φn = atan2(m.y, m.x)` in `[0, 2π)`, measured from `+x`
//! toward `+y`.
//!
//! Steps, each with its own random stream (so that changing one effect does not reshuffle
//! the others, and no result depends on the thread count):
//! 1. Flakes (sequential stream): for each, diameter, centre `x`, centre `y`, a uniform
//!    number `u` for the height, normal (from the orientation distribution). The
//!    mid-plane height is `h + u (film − 2h)`, `h` the flake's half height at its tilt, so
//!    that it lies inside the film; a flake that cannot (`2h > film`) draws a new
//!    diameter and normal until it can (the film rule of the `params` module).
//! 2. Render the top faces with a z-buffer (`disc` module): label map and face heights.
//! 3. Flake pixels: face height + roughness field. Background pixels: a height uniform in
//!    `[0, film]` (stray light from anywhere in the film); they are meant to be masked out
//!    by the intensity cutoff.
//! 4. Confocal effects: Gaussian blur (PSF), rounding to the z step, height noise.
//! 5. Intensity: flake or background level + noise, clipped to `[0, 1]`, 8-bit rounding.
//! 6. Truth: per flake, visible pixels from the label map (before any blur).

use std::f64::consts::PI;

use flakescatter_stats::heightmap::HeightMap;
use nalgebra::{Unit, Vector3};
use rand::RngExt;
use rand_distr::{Distribution, LogNormal, StandardNormal};
use rayon::prelude::*;

use crate::SynthError;
use crate::disc::{Disc, render};
use crate::field::{Stream, correlated_field, gaussian_blur, stream_rng};
use crate::params::{DiameterDistribution, FlakeAmount, LayerParams, half_height};

/// Ground truth of one generated flake.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruthFlake {
    /// 1-based id; the value of this flake in [`SyntheticLayer::labels`].
    pub id: u32,
    /// Unit normal of the flake faces (`z > 0`).
    pub normal: Unit<Vector3<f64>>,
    /// Polar angle of the normal from the coating normal `z`, radians.
    pub theta_n: f64,
    /// Azimuth of the normal, radians in `[0, 2π)`, from `+x` toward `+y`.
    pub phi_n: f64,
    /// `x` of the mid-plane centre, µm (may lie outside the map for edge flakes).
    pub centre_x_um: f64,
    /// `y` of the mid-plane centre, µm.
    pub centre_y_um: f64,
    /// Height of the mid-plane centre above the substrate, µm.
    pub centre_z_um: f64,
    /// Depth of the mid-plane centre below the film's top surface, `film - centre_z`, µm.
    pub depth_um: f64,
    /// Diameter, µm.
    pub diameter_um: f64,
    /// True area of one face, `π d² / 4`, µm².
    pub true_area_um2: f64,
    /// Number of map pixels on which this flake is the top-most surface.
    pub visible_pixels: usize,
    /// `visible_pixels · dx · dy`, µm² (area projected on the `xy` plane).
    pub visible_projected_area_um2: f64,
    /// Visible area on the flake itself, `visible_projected_area / m.z`, µm².
    pub visible_true_area_um2: f64,
}

/// A generated layer.
#[derive(Debug, Clone, PartialEq)]
pub struct SyntheticLayer {
    /// Measured-like heights above the substrate, µm, every pixel valid. Metadata records
    /// the generator and its parameters.
    pub height: HeightMap,
    /// Unit-less intensity on `[0, 1]`, multiples of `1/255`.
    pub intensity: HeightMap,
    /// Row-major label map: the [`TruthFlake::id`] visible at each pixel, `0` = background.
    pub labels: Vec<u32>,
    /// Every placed flake, in id order (`truth[k].id == k + 1`), including flakes that are
    /// hidden or outside the map (`visible_pixels == 0`).
    pub truth: Vec<TruthFlake>,
    /// Flakes whose first diameter and normal could not lie inside the film and were
    /// drawn again (the film rule); at most about
    /// [`MAX_REDRAWN_FRACTION`](crate::MAX_REDRAWN_FRACTION) of them for validated
    /// parameters. 0 for [`generate_from_discs`].
    pub redrawn_flakes: usize,
}

impl SyntheticLayer {
    /// The flakes that show on at least one pixel.
    pub fn visible_flakes(&self) -> impl Iterator<Item = &TruthFlake> {
        self.truth.iter().filter(|f| f.visible_pixels > 0)
    }

    /// Fraction of the map's pixels on which some flake is visible.
    pub fn covered_fraction(&self) -> f64 {
        self.labels.iter().filter(|&&l| l != 0).count() as f64 / self.labels.len() as f64
    }
}

/// Generates a random layer as described in the module docs.
///
/// # Errors
/// [`SynthError::HeightMap`] only if the map cannot be built (not expected for validated
/// parameters).
pub fn generate(params: &LayerParams) -> Result<SyntheticLayer, SynthError> {
    let (discs, redrawn) = place(params);
    let mut layer = generate_from_discs(params, &discs)?;
    layer.redrawn_flakes = redrawn;
    Ok(layer)
}

/// The flakes [`generate`] would place for `params` (step 1 of the module docs).
pub fn place_flakes(params: &LayerParams) -> Vec<Disc> {
    place(params).0
}

/// Draws a diameter, µm.
fn draw_diameter<R: rand::Rng>(
    d: DiameterDistribution,
    lognormal: Option<&LogNormal<f64>>,
    rng: &mut R,
) -> f64 {
    match (d, lognormal) {
        (DiameterDistribution::LogNormal { mean_um, .. }, Some(ln)) => loop {
            let d: f64 = ln.sample(rng);
            if (0.25 * mean_um..=3.0 * mean_um).contains(&d) {
                break d;
            }
        },
        (DiameterDistribution::LogNormal { mean_um, .. }, None) => mean_um,
        (DiameterDistribution::Fixed(d), _) => d,
    }
}

/// Redraws of one flake before it is laid flat (which always fits: validated parameters
/// have `thickness ≤ film`). With at most 0.1 % of flakes needing a redraw this is never
/// reached in practice.
const MAX_REDRAWS: usize = 10_000;

/// Step 1 of the module docs: the flakes and how many needed a new draw.
fn place(params: &LayerParams) -> (Vec<Disc>, usize) {
    let s = params.spec();
    let mut rng = stream_rng(s.seed, Stream::Flakes, 0);
    let margin = 0.5 * s.diameter.max_um();
    let x0 = -0.5 * s.dx_um - margin;
    let y0 = -0.5 * s.dy_um - margin;
    let wx = s.nx as f64 * s.dx_um + 2.0 * margin;
    let wy = s.ny as f64 * s.dy_um + 2.0 * margin;
    let lognormal = match s.diameter {
        DiameterDistribution::LogNormal { mean_um, rel_sd } => {
            let var = (1.0 + rel_sd * rel_sd).ln();
            LogNormal::new(mean_um.ln() - 0.5 * var, var.sqrt()).ok()
        }
        DiameterDistribution::Fixed(_) => None,
    };
    let mut discs = Vec::new();
    let mut area = 0.0;
    let mut redrawn = 0;
    let (film, t) = (s.film_um, s.thickness_um);
    loop {
        match s.amount {
            FlakeAmount::Count(n) if discs.len() >= n => break,
            FlakeAmount::Coverage(c) if area >= c * wx * wy => break,
            _ => {}
        }
        let mut diameter_um = draw_diameter(s.diameter, lognormal.as_ref(), &mut rng);
        let centre_x_um = x0 + wx * rng.random::<f64>();
        let centre_y_um = y0 + wy * rng.random::<f64>();
        let u: f64 = rng.random();
        let mut normal = s.orientation.sample_normal(&mut rng);
        // The film rule: a new diameter and normal until the flake fits.
        if 2.0 * half_height(diameter_um, t, normal.z) > film {
            redrawn += 1;
            let mut tries = 0;
            while 2.0 * half_height(diameter_um, t, normal.z) > film {
                tries += 1;
                if tries > MAX_REDRAWS {
                    normal = Unit::new_unchecked(Vector3::z());
                    break;
                }
                diameter_um = draw_diameter(s.diameter, lognormal.as_ref(), &mut rng);
                normal = s.orientation.sample_normal(&mut rng);
            }
        }
        let h = half_height(diameter_um, t, normal.z);
        let disc = Disc {
            centre_x_um,
            centre_y_um,
            centre_z_um: h + u * (film - 2.0 * h).max(0.0),
            diameter_um,
            thickness_um: t,
            normal,
        };
        area += disc.true_area_um2();
        discs.push(disc);
    }
    (discs, redrawn)
}

/// Runs steps 2–6 of the module docs on given flakes: the grid, film, roughness,
/// confocal, intensity and seed come from `params`; its diameter, amount and orientation
/// are not used. Disc `k` gets id `k + 1`.
///
/// # Errors
/// [`SynthError::InvalidDisc`] for a disc with non-finite fields, a diameter ≤ 0, a
/// negative thickness, a normal that is not a unit vector with `z > 0`, or a disc that
/// does not lie inside the film `[0, film_um]` of `params`;
/// [`SynthError::TooManyFlakes`] for more than `u32::MAX - 1` discs.
pub fn generate_from_discs(
    params: &LayerParams,
    discs: &[Disc],
) -> Result<SyntheticLayer, SynthError> {
    let s = params.spec();
    if discs.len() >= u32::MAX as usize {
        return Err(SynthError::TooManyFlakes(discs.len()));
    }
    for (i, d) in discs.iter().enumerate() {
        d.validate(i)?;
        // Inside the film, up to rounding of the placement above.
        let h = half_height(d.diameter_um, d.thickness_um, d.normal.z);
        let slack = 1e-9 * s.film_um.max(1.0);
        if d.centre_z_um - h < -slack || d.centre_z_um + h > s.film_um + slack {
            return Err(SynthError::InvalidDisc {
                index: i,
                reason: "does not lie inside the film: its centre height must be within half its height span (t cos θ + d sin θ)/2 of [0, film_um]",
            });
        }
    }
    let (nx, ny, dx, dy) = (s.nx, s.ny, s.dx_um, s.dy_um);
    let (mut z, labels) = render(nx, ny, dx, dy, discs);

    // Flake roughness, then background heights.
    if s.roughness.rms_um > 0.0 {
        let rough = correlated_field(
            s.seed,
            nx,
            ny,
            dx,
            dy,
            s.roughness.rms_um,
            s.roughness.correlation_um,
        );
        z.par_iter_mut().zip(&rough).for_each(|(h, r)| *h += r);
    }
    let film = s.film_um;
    z.par_chunks_mut(nx).enumerate().for_each(|(row, zr)| {
        let mut rng = stream_rng(s.seed, Stream::Background, row as u64);
        for h in zr {
            // Draw for every pixel so the stream does not depend on the flakes.
            let b = film * rng.random::<f64>();
            if *h == f64::NEG_INFINITY {
                *h = b;
            }
        }
    });

    // Confocal effects.
    let c = s.confocal;
    gaussian_blur(&mut z, nx, ny, dx, dy, c.psf_sd_um);
    if c.z_step_um > 0.0 {
        z.par_iter_mut()
            .for_each(|h| *h = (*h / c.z_step_um).round() * c.z_step_um);
    }
    if c.noise_sd_um > 0.0 {
        z.par_chunks_mut(nx).enumerate().for_each(|(row, zr)| {
            let mut rng = stream_rng(s.seed, Stream::HeightNoise, row as u64);
            for h in zr {
                let e: f64 = StandardNormal.sample(&mut rng);
                *h += c.noise_sd_um * e;
            }
        });
    }

    // Intensity.
    let lv = s.intensity;
    let mut intensity = vec![0.0; nx * ny];
    intensity
        .par_chunks_mut(nx)
        .zip(labels.par_chunks(nx))
        .enumerate()
        .for_each(|(row, (ir, lr))| {
            let mut rng = stream_rng(s.seed, Stream::IntensityNoise, row as u64);
            for (v, &l) in ir.iter_mut().zip(lr) {
                let e: f64 = StandardNormal.sample(&mut rng);
                let base = if l == 0 { lv.background } else { lv.flake };
                *v = ((base + lv.noise_sd * e).clamp(0.0, 1.0) * 255.0).round() / 255.0;
            }
        });

    // Truth.
    let mut counts = vec![0usize; discs.len() + 1];
    for &l in &labels {
        counts[l as usize] += 1;
    }
    let truth = discs
        .iter()
        .enumerate()
        .map(|(i, d)| {
            let m = d.normal;
            let visible_pixels = counts[i + 1];
            let projected = visible_pixels as f64 * dx * dy;
            TruthFlake {
                id: (i + 1) as u32,
                normal: m,
                theta_n: m.x.hypot(m.y).atan2(m.z),
                phi_n: m.y.atan2(m.x).rem_euclid(2.0 * PI),
                centre_x_um: d.centre_x_um,
                centre_y_um: d.centre_y_um,
                centre_z_um: d.centre_z_um,
                depth_um: film - d.centre_z_um,
                diameter_um: d.diameter_um,
                true_area_um2: d.true_area_um2(),
                visible_pixels,
                visible_projected_area_um2: projected,
                visible_true_area_um2: projected / m.z,
            }
        })
        .collect();

    let mut height = HeightMap::new(nx, ny, dx, dy, z)?;
    let mut inten = HeightMap::new(nx, ny, dx, dy, intensity)?;
    inten.set_quantity(flakescatter_stats::heightmap::Quantity::Intensity);
    for map in [&mut height, &mut inten] {
        map.set_metadata(
            "generator",
            concat!("flakescatter-synth ", env!("CARGO_PKG_VERSION")),
        );
        map.set_metadata("seed", s.seed.to_string());
        map.set_metadata("flakes", discs.len().to_string());
    }
    height.set_metadata("z_unit", "um");
    inten.set_metadata("z_unit", "1 (intensity, full scale 1)");
    Ok(SyntheticLayer {
        height,
        intensity: inten,
        labels,
        truth,
        redrawn_flakes: 0,
    })
}

/// Header of [`truth_csv`]: the flake-table "normals" column set (`nx, ny, nz, area_um2`,
/// `area_um2` = visible true area) plus the rest of the ground truth.
pub const TRUTH_COLUMNS: [&str; 15] = [
    "id",
    "x_um",
    "y_um",
    "nx",
    "ny",
    "nz",
    "area_um2",
    "theta_n_deg",
    "phi_n_deg",
    "z_um",
    "depth_um",
    "diameter_um",
    "true_area_um2",
    "visible_pixels",
    "visible_projected_area_um2",
];

/// The truth table as CSV text (header [`TRUTH_COLUMNS`], `\n` line ends), one row per
/// flake visible on at least one pixel, in id order. This is the file format written by
/// `flakescatter synth --truth-out` and `cargo xtask fixtures`; it is readable as a flake
/// table (normals column set). Angles are in degrees here, at the file boundary
/// (`phi_n_deg` in `[0, 360)` from `+x` toward `+y`); `x_um`, `y_um` are the mid-plane
/// centre in map coordinates, `z_um` its height above the substrate and `depth_um` its
/// depth below the film surface. Numbers use Rust's shortest round-trip form.
pub fn truth_csv(layer: &SyntheticLayer) -> String {
    let mut out = TRUTH_COLUMNS.join(",");
    out.push('\n');
    for f in layer.visible_flakes() {
        let row = [
            f.id.to_string(),
            f.centre_x_um.to_string(),
            f.centre_y_um.to_string(),
            f.normal.x.to_string(),
            f.normal.y.to_string(),
            f.normal.z.to_string(),
            f.visible_true_area_um2.to_string(),
            f.theta_n.to_degrees().to_string(),
            f.phi_n.to_degrees().to_string(),
            f.centre_z_um.to_string(),
            f.depth_um.to_string(),
            f.diameter_um.to_string(),
            f.true_area_um2.to_string(),
            f.visible_pixels.to_string(),
            f.visible_projected_area_um2.to_string(),
        ];
        out.push_str(&row.join(","));
        out.push('\n');
    }
    out
}
