//! A sample of several synthetic maps of one seeded layer family (known hwhm): the
//! pooled statistics of the segmented flakes against the same estimator on the
//! generator's truth tables of the visible flakes (true normals, visible true areas),
//! the coverage of the map-level interval, and a map of another width flagged.
//!
//! The reference is the synthetic truth, not the code under test: each layer's truth
//! table lists the flakes that show on the map with their exact normals and the area
//! that shows, and the reference width is the area-weighted maximum-likelihood fit
//! (`fit_gaussian_ml`, checked against closed forms and simulated coverage in the stats
//! crate) of those flakes pooled over the sample's maps.

use flakescatter::sample::{SampleSettings, sample_statistics};
use flakescatter::stats::distribution::{GaussianWidth, Orientation};
use flakescatter::stats::fit::fit_gaussian_ml;
use flakescatter::stats::heightmap::HeightMap;
use flakescatter::stats::segment::SegmentParams;
use flakescatter::synth::{LayerParams, LayerSpec, generate};

/// A 512² map at 0.18 µm (the paper's field) of hwhm `hwhm_deg`, masked at the
/// intensity midpoint, with its visible flakes' `(θn, visible true area)`.
fn map(hwhm_deg: f64, seed: u64) -> (HeightMap, Vec<(f64, f64)>) {
    let o = Orientation::gaussian(GaussianWidth::Hwhm(hwhm_deg.to_radians())).unwrap();
    let spec = LayerSpec::new(512, 512, o, seed);
    let layer = generate(&LayerParams::new(spec).unwrap()).unwrap();
    let truth = layer
        .visible_flakes()
        .map(|f| (f.theta_n, f.visible_true_area_um2))
        .collect();
    let mut height = layer.height;
    height
        .apply_intensity_cutoff(&layer.intensity, 0.49)
        .unwrap();
    (height, truth)
}

fn settings() -> SampleSettings {
    SampleSettings {
        // The generator's 0.3 µm z step; the CLI's default 0.03 µm noise allowance.
        segment: SegmentParams::for_instrument(0.3, 0.03),
        bin_width: 1f64.to_radians(),
        pixel_normals: None,
    }
}

#[test]
fn pooled_width_of_eight_maps_matches_the_visible_truth_and_its_interval_covers_it() {
    let hwhm = 6.0;
    let (mut covered, mut worst) = (0, 0.0f64);
    let mut all_truth = Vec::new();
    let reps = 20;
    for rep in 0..reps {
        let maps: Vec<(HeightMap, Vec<(f64, f64)>)> =
            (0..8).map(|j| map(hwhm, 1000 + 10 * rep + j)).collect();
        let refs: Vec<&HeightMap> = maps.iter().map(|m| &m.0).collect();
        let stats = sample_statistics(&refs, &settings(), &|_, _| {}).unwrap();
        let truth: Vec<(f64, f64)> = maps.iter().flat_map(|m| m.1.iter().copied()).collect();
        let reference = fit_gaussian_ml(&truth).unwrap().hwhm();
        all_truth.extend(truth);
        let got = stats.pooled.hwhm();
        let (lo, hi) = stats.pooled.map_level.unwrap().hwhm_ci95();
        let rel = got / reference - 1.0;
        worst = worst.max(rel.abs());
        covered += usize::from(lo <= reference && reference <= hi);
        eprintln!(
            "rep {rep}: pooled hwhm {:.3}° (map-level [{:.3}, {:.3}], flake-level [{:.3}, {:.3}]) vs visible truth {:.3}°: {:+.2} %; flagged {:?}",
            got.to_degrees(),
            lo.to_degrees(),
            hi.to_degrees(),
            stats.pooled.flake_level.hwhm_ci95().0.to_degrees(),
            stats.pooled.flake_level.hwhm_ci95().1.to_degrees(),
            reference.to_degrees(),
            100.0 * rel,
            stats
                .pooled
                .maps
                .iter()
                .enumerate()
                .filter(|m| m.1.flagged)
                .map(|m| m.0)
                .collect::<Vec<_>>()
        );
    }
    let visible = fit_gaussian_ml(&all_truth).unwrap();
    eprintln!(
        "worst {:.2} %, covered {covered}/{reps}; visible flakes of all {} maps: hwhm {:.3}° [{:.3}, {:.3}] (generator {hwhm}°)",
        100.0 * worst,
        8 * reps,
        visible.hwhm().to_degrees(),
        visible.hwhm_ci95().0.to_degrees(),
        visible.hwhm_ci95().1.to_degrees()
    );
    assert!(worst < 0.03, "worst relative difference {worst}");
    assert!(covered >= 18, "covered {covered} of {reps}");
}

#[test]
fn a_map_of_another_width_is_flagged() {
    // Seven maps of hwhm 6° and, third, one of hwhm 10°: the Gamma-corrected log test
    // (stats::pool) flags it in about 97 % of such samples (numpy simulation there).
    let maps: Vec<HeightMap> = (0..8)
        .map(|j| map(if j == 2 { 10.0 } else { 6.0 }, 2000 + j).0)
        .collect();
    let refs: Vec<&HeightMap> = maps.iter().collect();
    let stats = sample_statistics(&refs, &settings(), &|_, _| {}).unwrap();
    let p = &stats.pooled;
    assert!(p.maps[2].flagged, "{:?}", p.maps[2]);
    let worst = (0..8)
        .max_by(|&a, &b| {
            p.maps[a]
                .z
                .unwrap()
                .abs()
                .total_cmp(&p.maps[b].z.unwrap().abs())
        })
        .unwrap();
    assert_eq!(worst, 2);
    assert!(p.maps[2].z.unwrap() > p.z_bound.unwrap());
    // Its own width is the wide one: its interval lies above the pooled width of the
    // others' flakes.
    let own = p.maps[2].fit.unwrap();
    assert!(
        own.hwhm_ci95().0 > 6.5f64.to_radians(),
        "{:?}",
        own.hwhm_ci95()
    );
    // The maps differ more than their flakes explain.
    assert!(p.heterogeneity.unwrap().p < 0.05);
}
