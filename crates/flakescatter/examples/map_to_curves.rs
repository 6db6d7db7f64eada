//! From a confocal height map to flake statistics to both models' curves, the way a
//! lab's script would do it with the `flakescatter` library.
//!
//! Run from the repository root:
//! `cargo run --release -p flakescatter --example map_to_curves`
//! (optionally with a height map and its intensity map as the two arguments).

use flakescatter::io::{ReadOptions, read_intensity, read_map};
use flakescatter::stats::fit::fit_gaussian_ml;
use flakescatter::stats::segment::{SegmentParams, segment};
use flakescatter::{
    Coating, DetectorSet, Instrument, OrientationSource, Settings, TopoSettings,
    distribution_curves, topographic_curves,
};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures");
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (height_file, intensity_file) = match args.as_slice() {
        [h, i] => (h.clone(), i.clone()),
        _ => (
            format!("{root}/synth-hwhm6-rough.height.x3p"),
            format!("{root}/synth-hwhm6-rough.intensity.x3p"),
        ),
    };

    // 1. The confocal map, masked where the intensity is below the cutoff.
    let options = ReadOptions::default();
    let (mut map, format) = read_map(&height_file, &options)?;
    let (intensity, _) = read_intensity(&intensity_file, &options)?;
    let usable = map.apply_intensity_cutoff(&intensity, 0.49)?;
    println!(
        "{height_file}: {format:?}, {} x {} pixels of {:.3} x {:.3} µm, {usable} bright",
        map.nx(),
        map.ny(),
        map.dx(),
        map.dy()
    );

    // 2. Individual flakes and their orientation statistics (paper eqs. 5–8).
    let seg = segment(&map, &SegmentParams::default())?;
    let tilts: Vec<(f64, f64)> = seg
        .flakes
        .iter()
        .map(|f| {
            let flake = f.to_flake();
            (flake.theta_n(), flake.area_um2)
        })
        .collect();
    let width = fit_gaussian_ml(&tilts)?;
    let (lo, hi) = width.hwhm_ci95();
    println!(
        "{} flakes, area-weighted Gaussian hwhm {:.2}° (95 % interval {:.2}°–{:.2}°)",
        tilts.len(),
        width.hwhm().to_degrees(),
        lo.to_degrees(),
        hi.to_degrees()
    );

    // 3. Both models at 30° and 60° incidence, in-plane detectors of 1.5° half-angle.
    let detectors = DetectorSet::InPlane((-70..=70).map(|d| f64::from(d).to_radians()).collect());
    let instrument = Instrument::new(
        vec![30f64.to_radians(), 60f64.to_radians()],
        detectors,
        1.5f64.to_radians(),
    )?;
    let coating = Coating::default();
    let settings = Settings::default();
    let flakes: Vec<_> = seg.flakes.iter().map(|f| f.to_flake()).collect();
    let from_flakes = distribution_curves(
        &coating,
        &instrument,
        &settings,
        &OrientationSource::Flakes {
            flakes,
            bin_width: 1f64.to_radians(),
        },
    )?;
    let from_gaussian = distribution_curves(
        &coating,
        &instrument,
        &settings,
        &OrientationSource::Distribution(width.orientation()?),
    )?;
    let (topo, totals) = topographic_curves(
        &coating,
        &instrument,
        &settings,
        &TopoSettings::default(),
        &[&map],
        &|_, _| {},
    )?;
    println!(
        "topographic model: {} rays traced from {} usable pixels, {} lost to total internal reflection",
        totals.rays_traced, totals.usable_pixels, totals.rays_lost_tir
    );

    // 4. The curves side by side (BRDF in 1/sr), every 10°.
    println!("theta_i_deg,theta_s_deg,histogram_model,gaussian_model,topographic_model,topo_rays");
    for ((a, b), c) in from_flakes
        .rows
        .iter()
        .zip(&from_gaussian.rows)
        .zip(&topo.rows)
    {
        let ts = match instrument.detectors() {
            DetectorSet::InPlane(t) => t[a.detector].to_degrees(),
            DetectorSet::OutOfPlane(_) => f64::NAN,
        };
        if ts.rem_euclid(10.0).abs() < 1e-9 {
            println!(
                "{:.0},{ts:.0},{:.4e},{:.4e},{:.4e},{}",
                a.theta_i.to_degrees(),
                a.brdf,
                b.brdf,
                c.brdf,
                c.rays.unwrap_or(0)
            );
        }
    }
    Ok(())
}
