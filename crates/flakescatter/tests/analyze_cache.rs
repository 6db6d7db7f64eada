//! The cache of `analyze` is keyed on the program build as well as the version, the
//! inputs and the settings (issue 52, item 24): a report written by one build is
//! reused by the same build and redone by another with the same version.

use std::path::{Path, PathBuf};

use flakescatter::analyze::{Content, Manifest, SampleInput, analyze_sample, read_cache};
use flakescatter::inputs::{MapSource, short_names};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures")
        .join(name)
}

fn sample() -> SampleInput {
    // Quick settings: no topographic model, no pixel-level statistics.
    let text = "[maps]\nfiles = [\"x.x3p\"]\n[stats]\npixel_normals = false\n[models]\nfit = false\ntopographic = \"none\"\nmulti_angle = false\ntheta_s_deg = [-30, 0, 30]\n";
    let manifest = Manifest::from_toml(text, "s.toml").unwrap();
    let maps = vec![MapSource::new(
        fixture("synth-hwhm6-rough.height.x3p"),
        None,
    )];
    let map_names = short_names(&maps);
    SampleInput {
        manifest,
        file: PathBuf::from("s.toml"),
        name: "s".into(),
        maps,
        map_names,
        measured: Vec::new(),
        paint: None,
    }
}

/// Writes the report's cache files into `dir` (as the CLI does).
fn write_cache(dir: &Path, files: &[flakescatter::analyze::OutFile]) {
    for f in files.iter().filter(|f| f.path.starts_with("cache/")) {
        let Content::Text(t) = &f.content else {
            panic!("{} is not text", f.path)
        };
        let p = dir.join(&f.path);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, t).unwrap();
    }
}

#[test]
fn another_build_of_the_same_version_does_not_reuse_the_cache() {
    let dir = std::env::temp_dir().join(format!("fs-analyze-cache-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let s = sample();
    let none = |_: &str, _: usize, _: usize| {};
    let first = analyze_sample(&s, &read_cache(&dir, &s.map_names), "build-a", &none).unwrap();
    assert_eq!(first.work.maps_segmented, 1);
    assert_eq!(first.summary["build"], "build-a");
    write_cache(&dir, &first.files);
    // The same build reuses everything.
    let again = analyze_sample(&s, &read_cache(&dir, &s.map_names), "build-a", &none).unwrap();
    assert_eq!((again.work.maps_reused, again.work.maps_segmented), (1, 0));
    assert!(again.work.models_reused);
    // Another build (same version, same inputs and settings) redoes the work.
    let other = analyze_sample(&s, &read_cache(&dir, &s.map_names), "build-b", &none).unwrap();
    assert_eq!((other.work.maps_reused, other.work.maps_segmented), (0, 1));
    assert!(!other.work.models_reused);
    assert_ne!(
        first.summary["inputs"]["maps"][0]["cache_key"],
        other.summary["inputs"]["maps"][0]["cache_key"]
    );
    let _ = std::fs::remove_dir_all(&dir);
}
