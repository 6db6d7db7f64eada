//! `flakescatter analyze` end to end on the shipped sample manifest
//! (`fixtures/sample.toml`: the two synthetic layers of `fixtures/`, generated with hwhm
//! 3° and 6°, see `fixtures/README.md`): every listed file is written, each map's width
//! interval covers the hwhm its layer was generated with, a rerun with nothing changed
//! does no model work and writes the same bytes, a changed model setting reruns the
//! models but not the segmentation, and bad manifests are refused before any work.

mod common;

use std::path::{Path, PathBuf};

use common::{fixtures, run, s, scratch};
use serde_json::Value;

fn analyze(manifest: &Path, out: &Path) -> Value {
    let o = run(&["analyze", s(manifest), "--out", s(out)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(out.join("summary.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

fn png_size(p: &Path) -> (u32, u32) {
    let d = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(p).unwrap()));
    let r = d.read_info().unwrap();
    (r.info().width, r.info().height)
}

/// A copy of the fixture manifest in `d`, pointing at the fixture maps by absolute path,
/// with `edit` applied to its text.
fn manifest_copy(d: &Path, edit: impl Fn(String) -> String) -> PathBuf {
    let text = std::fs::read_to_string(fixtures().join("sample.toml")).unwrap();
    let fx = fixtures().canonicalize().unwrap();
    let text = text
        .replace("\"synth-hwhm", &format!("\"{}/synth-hwhm", fx.display()))
        .replace("\"../docs/", &format!("\"{}/../docs/", fx.display()));
    let p = d.join("sample.toml");
    std::fs::write(&p, edit(text)).unwrap();
    p
}

#[test]
fn fixture_manifest_writes_every_file_and_a_rerun_reuses_the_work() {
    let d = scratch("analyze", "fixture");
    let out = d.join("report");
    let manifest = fixtures().join("sample.toml");
    let first = analyze(&manifest, &out);

    // Every file the summary lists exists, and the fixed ones are among them.
    let files: Vec<String> = first["files"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f.as_str().unwrap().to_owned())
        .collect();
    for need in [
        "index.md",
        "index.html",
        "summary.json",
        "maps.csv",
        "flakes.csv",
        "histogram.csv",
        "curves.csv",
        "comparison.csv",
        "histogram.png",
        "overlays/synth-hwhm3-smooth.png",
        "overlays/synth-hwhm6-rough.png",
    ] {
        assert!(
            files.iter().any(|f| f == need),
            "{need} not listed: {files:?}"
        );
    }
    for f in &files {
        assert!(out.join(f).is_file(), "{f} listed but not written");
    }
    // Overlays: the map at one image pixel per map pixel (512 × 512, fixtures/README.md)
    // with the 170-pixel colour-bar strip to its right (docs/cli.md, `segment --overlay`).
    for m in ["synth-hwhm3-smooth", "synth-hwhm6-rough"] {
        assert_eq!(
            png_size(&out.join(format!("overlays/{m}.png"))),
            (512 + 170, 512)
        );
    }
    // index.html is readable offline: every PNG inline, none linked.
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    let pngs = files.iter().filter(|f| f.ends_with(".png")).count();
    assert_eq!(html.matches("src=\"data:image/png;base64,").count(), pngs);
    assert!(!html.contains("src=\"overlays/"));
    let md = std::fs::read_to_string(out.join("index.md")).unwrap();
    assert!(md.contains("](overlays/synth-hwhm3-smooth.png)"));

    // Each map's 95 % interval covers the hwhm its layer was generated with.
    let maps = first["statistics"]["maps"].as_array().unwrap();
    assert_eq!(maps.len(), 2);
    for (m, truth) in maps.iter().zip([3.0, 6.0]) {
        let ci = &m["hwhm_ci95_deg"];
        let (lo, hi) = (ci[0].as_f64().unwrap(), ci[1].as_f64().unwrap());
        assert!(
            lo < truth && truth < hi,
            "{}: [{lo}, {hi}] vs {truth}",
            m["map"]
        );
    }
    // Two maps of different widths: both flagged, and the 2-map warning given.
    assert!(maps.iter().all(|m| m["flagged"] == true));
    let warnings = first["warnings"].to_string();
    assert!(warnings.contains("only 2 maps"), "{warnings}");

    // The measured curve was compared with every model and the width fitted to it.
    // 3 models x 2 incidences.
    assert_eq!(
        first["comparison"].as_array().map(Vec::len),
        Some(6),
        "{}",
        first["comparison"]
    );
    assert!(
        first["fit"]["hwhm_deg"].as_f64().is_some(),
        "{}",
        first["fit"]
    );

    // The first run did the work: 2 segmentations, 2 distribution runs, the
    // topographic model, the multi-angle readout.
    let w = &first["work"];
    assert_eq!(w["maps_segmented"], 2);
    assert_eq!(w["maps_reused"], 0);
    assert_eq!(w["models_reused"], false);
    assert!(w["model_work"].as_u64().unwrap() >= 5, "{w}");
    assert_eq!(w["fits"], 1);

    // Nothing changed: no model work, and the same report byte for byte.
    let before: Vec<Vec<u8>> = files
        .iter()
        .map(|f| std::fs::read(out.join(f)).unwrap())
        .collect();
    let second = analyze(&manifest, &out);
    let w = &second["work"];
    assert_eq!(w["model_work"], 0, "{w}");
    assert_eq!(w["maps_segmented"], 0);
    assert_eq!(w["maps_reused"], 2);
    assert_eq!(w["models_reused"], true);
    for (f, b) in files.iter().zip(&before) {
        if matches!(f.as_str(), "summary.json" | "index.md" | "index.html") {
            continue; // they report the work counter, checked below
        }
        assert!(
            &std::fs::read(out.join(f)).unwrap() == b,
            "{f} changed on rerun"
        );
    }
    let mut a = first.clone();
    let mut b = second.clone();
    a["work"] = Value::Null;
    b["work"] = Value::Null;
    assert_eq!(a, b, "summary.json differs beyond the work counter");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_changed_model_setting_reruns_models_but_not_segmentation() {
    let d = scratch("analyze", "changed");
    let out = d.join("report");
    let m1 = manifest_copy(&d, |t| {
        t.replace("topographic = \"isotropic\"", "topographic = \"none\"")
    });
    let first = analyze(&m1, &out);
    assert_eq!(first["work"]["maps_segmented"], 2);
    let m2 = manifest_copy(&d, |t| {
        t.replace(
            "topographic = \"isotropic\"",
            "topographic = \"none\"\naperture_deg = 2.0",
        )
    });
    let second = analyze(&m2, &out);
    let w = &second["work"];
    assert_eq!(w["maps_segmented"], 0, "{w}");
    assert_eq!(w["maps_reused"], 2);
    assert_eq!(w["models_reused"], false);
    assert!(w["distribution_runs"].as_u64().unwrap() >= 1, "{w}");
    // A changed segmentation setting re-segments.
    let m3 = manifest_copy(&d, |t| {
        t.replace("topographic = \"isotropic\"", "topographic = \"none\"")
            .replace("noise_um = 0.03", "noise_um = 0.04")
    });
    let third = analyze(&m3, &out);
    assert_eq!(third["work"]["maps_segmented"], 2, "{}", third["work"]);
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn bad_manifests_are_refused_before_any_work() {
    let d = scratch("analyze", "bad");
    // (what, text replaced, replacement, what the error must name)
    let cases = [
        (
            "unknown key",
            "cutoff = 0.49",
            "cutof = 0.49",
            "unknown field `cutof`",
        ),
        (
            "missing map",
            "synth-hwhm6-rough.height",
            "no-such.height",
            "no-such.height",
        ),
        ("bad value", "n = 1.5", "n = 0.5", "coating.n"),
        (
            "missing partner",
            "\".intensity\"",
            "\".intens\"",
            ".intens",
        ),
        (
            "missing measured curve",
            "measured.csv",
            "no-such.csv",
            "measured.files",
        ),
    ];
    for (what, from, to, needle) in cases {
        let m = manifest_copy(&d, |t| t.replace(from, to));
        let out = d.join(format!("out-{}", what.replace(' ', "-")));
        let o = run(&["analyze", s(&m), "--out", s(&out)]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{what}: accepted");
        assert!(err.contains(needle), "{what}: {err}");
        assert!(
            err.contains("sample.toml"),
            "{what}: the manifest is not named: {err}"
        );
        assert!(!out.exists(), "{what}: {} written", out.display());
    }
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn several_manifests_write_each_sample_and_a_comparison_table() {
    let d = scratch("analyze", "batch");
    let (a, b) = (d.join("a"), d.join("b"));
    std::fs::create_dir_all(&a).unwrap();
    std::fs::create_dir_all(&b).unwrap();
    // Sample a: the fixture; sample b: its hwhm-6° map alone, no topographic model.
    let ma = manifest_copy(&a, |t| {
        t.replace("name = \"synth-pair\"", "name = \"pair\"")
    });
    let mb = manifest_copy(&b, |t| {
        t.replace("name = \"synth-pair\"", "name = \"rough\"")
            .replace(
                &format!(
                    "\"{}/synth-hwhm3-smooth.height.x3p\", ",
                    fixtures().canonicalize().unwrap().display()
                ),
                "",
            )
            .replace("topographic = \"isotropic\"", "topographic = \"none\"")
    });
    let out = d.join("report");
    let o = run(&["analyze", s(&ma), s(&mb), "--out", s(&out)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(out.join("samples.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 3, "{csv}");
    assert!(
        lines[0].starts_with("sample,maps,flakes,hwhm_deg,"),
        "{}",
        lines[0]
    );
    for (line, name, maps) in [(lines[1], "pair", "2"), (lines[2], "rough", "1")] {
        let cells: Vec<&str> = line.split(',').collect();
        assert_eq!((cells[0], cells[1]), (name, maps), "{line}");
        // The table carries the width each sample's own summary reports.
        let sj: Value = serde_json::from_str(
            &std::fs::read_to_string(out.join(name).join("summary.json")).unwrap(),
        )
        .unwrap();
        let h = sj["statistics"]["hwhm_deg"].as_f64().unwrap();
        assert_eq!(cells[3].parse::<f64>().unwrap(), h, "{line}");
    }
    let md = std::fs::read_to_string(out.join("index.md")).unwrap();
    assert!(
        md.contains("(pair/index.md)") && md.contains("(rough/index.md)"),
        "{md}"
    );
    assert!(out.join("index.html").is_file());
    // The one-map sample's hwhm-6° map: its interval covers the generator's 6°.
    let sj: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("rough/summary.json")).unwrap())
            .unwrap();
    let ci = &sj["statistics"]["flake_level"]["hwhm_ci95_deg"];
    assert!(
        ci[0].as_f64().unwrap() < 6.0 && 6.0 < ci[1].as_f64().unwrap(),
        "{ci}"
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// A `[paint]` section: the sample's report gets the fitted paint (its parameter file,
/// residuals, plots) with the same residuals as `fit --paint` on the same table, a rerun
/// reuses the cached fit, and bad paint keys are refused before any work.
#[test]
fn a_paint_section_reports_the_fitted_paint() {
    let d = scratch("analyze", "paint");
    let table = fixtures()
        .canonicalize()
        .unwrap()
        .join("real/paints/gold-metallic-paint2.csv");
    let section = format!(
        "\n[paint]\nfile = \"{}\"\nfamily = \"trowbridge-reitz\"\nmax_theta_r_deg = 80\n",
        table.display()
    );
    let m = manifest_copy(&d, |t| t + &section);
    let out = d.join("out");
    let v = analyze(&m, &out);
    assert_eq!(v["work"]["paint_fits"], 1);
    assert_eq!(v["paint"]["fit"]["family"], "trowbridge-reitz");
    for f in [
        "paint/params.json",
        "paint/points.csv",
        "paint/in_plane_theta_i_45.png",
        "paint/out_of_plane_residuals.png",
    ] {
        assert!(out.join(f).is_file(), "{f}");
        assert!(
            v["files"].as_array().unwrap().iter().any(|x| x == f),
            "{f} not listed"
        );
    }
    let index = std::fs::read_to_string(out.join("index.md")).unwrap();
    assert!(index.contains("## Paint fitted to the measured BRDF table"));
    // The same residuals as the command-line fit of the same table and options.
    let o = run(&[
        "fit",
        "--measured",
        s(&table),
        "--paint",
        "--family",
        "trowbridge-reitz",
        "--max-theta-r",
        "80",
        "--json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let cli: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(cli["fit"]["residuals"], v["paint"]["fit"]["residuals"]);
    // A rerun reuses the fit.
    let again = analyze(&m, &out);
    assert_eq!(again["work"]["paint_fits"], 0);
    assert_eq!(again["paint"]["reused"], true);
    // Bad keys are refused before any work.
    for (from, to, needle) in [
        (
            "family = \"trowbridge-reitz\"",
            "family = \"cauchy\"",
            "paint.family",
        ),
        (
            "max_theta_r_deg = 80",
            "max_theta_r_deg = 95",
            "paint.max_theta_r_deg",
        ),
    ] {
        let text = section.replace(from, to);
        let m = manifest_copy(&d, |t| t + &text);
        let out = d.join("bad-out");
        let o = run(&["analyze", s(&m), "--out", s(&out)]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(needle), "{err}");
        assert!(!out.exists());
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// `head`, the fixture manifest's maps and map settings as command-line arguments (its
/// two layers, their intensity suffix and cutoff), then `tail`: for `segment` and
/// `stats --map`.
fn with_fixture_maps(fx: &Path, head: &[&str], tail: &[&str]) -> Vec<String> {
    let mut a: Vec<String> = head.iter().map(|x| (*x).to_owned()).collect();
    for stem in ["synth-hwhm3-smooth", "synth-hwhm6-rough"] {
        a.push(s(&fx.join(format!("{stem}.height.x3p"))).to_owned());
    }
    a.extend(["--intensity-suffix", ".intensity", "--cutoff", "0.49"].map(String::from));
    a.extend(tail.iter().map(|x| (*x).to_owned()));
    a
}

/// One writer for flake tables and histograms: `analyze`'s `flakes.csv` is what
/// `segment --out` writes, and its `histogram.csv` what `stats --out` writes,
/// for the same maps and settings (the manifest's `cutoff` and intensity suffix), byte
/// for byte but for the map column, which holds the report's short map names.
#[test]
fn the_reports_flake_table_is_segments() {
    let d = scratch("analyze", "flake-table");
    let out = d.join("report");
    analyze(&fixtures().join("sample.toml"), &out);
    let seg = d.join("segment.csv");
    let fx = fixtures();
    let o = run(&with_fixture_maps(&fx, &["segment"], &["--out", s(&seg)]));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // `segment` names a map as it was given.
    let mut segment = std::fs::read_to_string(&seg).unwrap();
    for stem in ["synth-hwhm3-smooth", "synth-hwhm6-rough"] {
        let given = fx.join(format!("{stem}.height.x3p"));
        segment = segment.replace(&format!(",{},", s(&given)), &format!(",{stem},"));
    }
    let report = std::fs::read_to_string(out.join("flakes.csv")).unwrap();
    assert!(report.lines().count() > 100);
    assert_eq!(report, segment);
    // And its histogram is `stats --out`'s (one writer, one number format).
    let hist = d.join("histogram.csv");
    let o = run(&with_fixture_maps(
        &fx,
        &["stats", "--map"],
        &["--out", s(&hist)],
    ));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(
        std::fs::read_to_string(out.join("histogram.csv")).unwrap(),
        std::fs::read_to_string(&hist).unwrap()
    );
}

/// One writer for the pooled width's JSON: `analyze`'s `summary.json` statistics say
/// what `stats --map … --json` says of the same maps and settings (the map-level
/// interval, the heterogeneity, the interval quoted, the z bound and each map, but for
/// the map's name, the report's short name).
#[test]
fn the_reports_pooled_width_is_stats() {
    let d = scratch("analyze", "pooled-json");
    let out = d.join("report");
    let summary = analyze(&fixtures().join("sample.toml"), &out);
    let fx = fixtures();
    let o = run(&with_fixture_maps(&fx, &["stats", "--map"], &["--json"]));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stats: Value = serde_json::from_slice(&o.stdout).unwrap();
    let report = &summary["statistics"];
    for key in ["map_level", "heterogeneity", "quoted_interval", "z_bound"] {
        assert_eq!(report[key], stats[key], "{key}");
    }
    assert!(
        report["map_level"]["mean_square_tilt_std_err_rad2"]
            .as_f64()
            .unwrap()
            > 0.0
    );
    let strip = |v: &Value| {
        let mut v = v.clone();
        for m in v.as_array_mut().unwrap() {
            m.as_object_mut().unwrap().remove("map");
        }
        v
    };
    assert_eq!(strip(&report["maps"]), strip(&stats["maps"]));
    assert_eq!(report["maps"].as_array().unwrap().len(), 2);
}

/// Interference flakes in a manifest (`[coating] flake_stack`, `wavelength_nm`): the
/// report's distribution model of the pooled width is `model --flake-stack S
/// --wavelengths W --hwhm H --clearcoat` at the report's own width and geometry (the
/// same flake reached through the flags instead of the manifest), and a bad stack, a
/// stack without a wavelength or beside `flake_index` is refused naming the key.
#[test]
fn a_manifest_takes_interference_flakes() {
    let d = scratch("analyze", "stack");
    let map = fixtures().join("synth-hwhm6-rough.height.x3p");
    let manifest = |coating: &str| {
        let p = d.join("m.toml");
        std::fs::write(
            &p,
            format!(
                "[maps]\nfiles = [\"{}\"]\nintensity_suffix = \".intensity\"\ncutoff = 0.49\n[models]\nfit = false\n[coating]\n{coating}",
                map.display().to_string().replace('\\', "/")
            ),
        )
        .unwrap();
        p
    };
    let stack = "TiO2:125/mica:400/TiO2:125";
    let out = d.join("report");
    let summary = analyze(
        &manifest(&format!("flake_stack = \"{stack}\"\nwavelength_nm = 550\n")),
        &out,
    );
    let hwhm = summary["statistics"]["hwhm_deg"].as_f64().unwrap();
    let o = run(&[
        "model",
        "--flake-stack",
        stack,
        "--wavelengths",
        "550",
        "--hwhm",
        &hwhm.to_string(),
        "--theta-i",
        "30,60",
        "--theta-s=-70:70:0.5",
        "--clearcoat",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let model = String::from_utf8(o.stdout).unwrap();
    let curves = std::fs::read_to_string(out.join("curves.csv")).unwrap();
    let report: Vec<f64> = curves
        .lines()
        .filter(|l| l.starts_with("distribution (pooled width),"))
        .map(|l| l.split(',').nth(4).unwrap().parse().unwrap())
        .collect();
    let flags: Vec<f64> = model
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(5).unwrap().parse().unwrap())
        .collect();
    assert_eq!(report.len(), 562);
    assert_eq!(report.len(), flags.len());
    for (a, b) in report.iter().zip(&flags) {
        assert!((a - b).abs() <= 1e-12 * b.abs(), "{a} vs {b}");
    }
    for (coating, key) in [
        (
            format!("flake_stack = \"{stack}\"\n"),
            "coating.wavelength_nm",
        ),
        (
            "flake_stack = \"TiO2:-5\"\nwavelength_nm = 550\n".to_string(),
            "coating.flake_stack",
        ),
        (
            format!("flake_stack = \"{stack}\"\nwavelength_nm = 550\nflake_index = [1.0, 6.0]\n"),
            "coating.flake_stack",
        ),
        ("wavelength_nm = 550\n".to_string(), "coating.wavelength_nm"),
    ] {
        let o = run(&[
            "analyze",
            s(&manifest(&coating)),
            "--out",
            s(&d.join("bad")),
        ]);
        assert_eq!(o.status.code(), Some(2), "{coating}");
        let e = String::from_utf8_lossy(&o.stderr);
        assert!(e.contains(key), "{coating}: {e}");
    }
}

/// Every object of `summary.json` has its keys in sorted order, as every JSON output of
/// the project (serde_json keeps insertion order in this build, a feature `zarrs` turns
/// on, so each writer sorts; this checks the report's, with the preview section the
/// command line adds).
#[test]
fn summary_keys_are_sorted() {
    fn check(v: &Value, at: &str) {
        match v {
            Value::Object(m) => {
                let keys: Vec<&String> = m.keys().collect();
                let mut sorted = keys.clone();
                sorted.sort();
                assert_eq!(keys, sorted, "{at}");
                for (k, x) in m {
                    check(x, &format!("{at}.{k}"));
                }
            }
            Value::Array(a) => a.iter().for_each(|x| check(x, at)),
            _ => {}
        }
    }
    let d = scratch("analyze", "sorted");
    let out = d.join("report");
    let summary = analyze(&fixtures().join("sample.toml"), &out);
    assert!(summary.get("preview").is_some());
    check(&summary, "summary");
}
