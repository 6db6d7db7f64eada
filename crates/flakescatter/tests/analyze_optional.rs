//! One optional statistic failing does not sink a sample (issue 52, item 15): the
//! shipped smooth fixture with its intensity cutoff, alone and with the defaults, has
//! a pixel-level histogram whose Gaussian fit lands on the lower end of its range (its
//! 0.3 µm z step makes most 5 × 5 windows flat: the pixel tilts pile into the first
//! 1° bin). The sample is still analysed; the fit is marked failed and why.

use std::path::{Path, PathBuf};

use flakescatter::analyze::{Cache, Manifest, SampleInput, analyze_sample};
use flakescatter::inputs::{MapSource, short_names};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures")
        .join(name)
}

#[test]
fn a_failed_pixel_level_fit_is_reported_not_fatal() {
    let text = "[maps]\nfiles = [\"x.x3p\"]\ncutoff = 0.49\n[models]\nfit = false\ntopographic = \"none\"\n";
    let manifest = Manifest::from_toml(text, "s.toml").unwrap();
    let maps = vec![MapSource::new(
        fixture("synth-hwhm3-smooth.height.x3p"),
        Some(fixture("synth-hwhm3-smooth.intensity.x3p")),
    )];
    let map_names = short_names(&maps);
    let s = SampleInput {
        manifest,
        file: PathBuf::from("s.toml"),
        name: "s".into(),
        maps,
        map_names,
        measured: Vec::new(),
        paint: None,
    };
    let none = |_: &str, _: usize, _: usize| {};
    let r = analyze_sample(&s, &Cache::default(), "b", &none).unwrap();
    let failed = r.summary["failed_statistics"].as_array().unwrap();
    assert_eq!(failed.len(), 1, "{failed:?}");
    assert_eq!(
        failed[0]["statistic"],
        "statistics.pixel_level.histogram_fit"
    );
    assert_eq!(failed[0]["key"], "stats.pixel_normals");
    let why = failed[0]["error"].as_str().unwrap();
    for needle in [
        "lower end",
        "synth-hwhm3-smooth",
        "`stats.bin_deg`",
        "`models.window`",
    ] {
        assert!(why.contains(needle), "{needle:?} not in {why}");
    }
    let px = &r.summary["statistics"]["pixel_level"];
    assert!(px["histogram_fit_hwhm_deg"].is_null());
    assert!(
        px["histogram_fit_error"]
            .as_str()
            .unwrap()
            .contains("lower end")
    );
    // The rest of the pixel level stands (usable pixels counted).
    assert!(px["usable_pixels"].as_u64().unwrap() > 0);
    // One warning for it, and the report text marks it.
    let n = r
        .warnings
        .iter()
        .filter(|w| w.contains("pixel_level.histogram_fit"))
        .count();
    assert_eq!(n, 1, "{:?}", r.warnings);
    assert!(r.document.to_markdown().contains("Statistics that failed"));
}
