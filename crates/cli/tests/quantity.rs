//! `convert` and `info` carry a map's quantity (issue 52, item 5): the shipped intensity
//! image, converted to each format and back, keeps its values (the X3P's raw float64
//! values, read here with the zip crate and decoded by hand, not by the X3P reader),
//! is marked as intensities in each output, is described by `info` as intensities
//! (no µm), and is refused where heights are expected.

use std::io::Read;
use std::path::Path;
use std::process::Output;

mod common;
use common::{fixture, run, s, scratch};

fn ok(o: &Output) {
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// A zip member's bytes, with the zip crate.
fn member(path: &Path, name: &str) -> Vec<u8> {
    let f = std::fs::File::open(path).unwrap();
    let mut z = zip::ZipArchive::new(f).unwrap();
    let mut out = Vec::new();
    z.by_name(name).unwrap().read_to_end(&mut out).unwrap();
    out
}

/// The X3P's values: `main.xml` must say float64 (`D`), Z increment 1 and offset 0, so
/// the value is the raw little-endian float64 of `data.bin` itself (NaN = invalid).
fn raw_x3p(path: &Path) -> Vec<f64> {
    let xml = String::from_utf8(member(path, "main.xml")).unwrap();
    let cz = &xml[xml.find("<CZ>").unwrap()..xml.find("</CZ>").unwrap()];
    assert!(cz.contains("<DataType>D</DataType>"), "{cz}");
    assert!(cz.contains("<Increment>1</Increment>"), "{cz}");
    assert!(cz.contains("<Offset>0</Offset>"), "{cz}");
    member(path, "bindata/data.bin")
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
        .collect()
}

/// The numbers of a text matrix (lines not starting with `#`).
fn raw_text(path: &Path) -> Vec<f64> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#'))
        .flat_map(|l| l.split_whitespace().map(|t| t.parse::<f64>().unwrap()))
        .collect()
}

/// The data section of a text SDF (between the first two `*` lines), `BAD` as NaN, times
/// its `Zscale`, which must be 1.
fn raw_sdf(path: &Path) -> (Vec<f64>, String) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut parts = text.split("\n*\n");
    let header = parts.next().unwrap();
    assert!(header.contains("Zscale      = 1\n"), "{header}");
    let data = parts.next().unwrap();
    let values = data
        .split_whitespace()
        .map(|t| {
            if t == "BAD" {
                f64::NAN
            } else {
                t.parse().unwrap()
            }
        })
        .collect();
    (values, parts.collect::<Vec<_>>().join("\n*\n"))
}

fn same(a: &[f64], b: &[f64], what: &str) {
    assert_eq!(a.len(), b.len(), "{what}");
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        assert!(
            x == y || (x.is_nan() && y.is_nan()),
            "{what}: point {i}: {x} against {y}"
        );
    }
}

#[test]
fn the_intensity_fixture_converts_to_every_format_and_back_unchanged() {
    let d = scratch("quantity", "convert");
    let src = fixture("synth-hwhm3-smooth.intensity.x3p");
    let raw = raw_x3p(&src);
    assert_eq!(raw.len(), 512 * 512);
    let max = raw
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(f64::MIN, f64::max);
    assert!(max <= 1.0 && max > 0.5, "intensities are 0..1: {max}");
    for ext in ["x3p", "sdf", "txt"] {
        let out = d.join(format!("i.{ext}"));
        ok(&run(&["convert", s(&src), s(&out)]));
        match ext {
            "x3p" => {
                same(&raw_x3p(&out), &raw, "x3p");
                let xml = String::from_utf8(member(&out, "main.xml")).unwrap();
                assert!(xml.contains("<Comment>Intensity, unit-less"), "{xml}");
            }
            "sdf" => {
                let (v, trailer) = raw_sdf(&out);
                same(&v, &raw, "sdf");
                assert!(trailer.contains("Quantity = intensity"), "{trailer}");
            }
            _ => {
                same(&raw_text(&out), &raw, "txt");
                let head = std::fs::read_to_string(&out).unwrap();
                assert!(
                    head.starts_with("# Channel: intensity\n"),
                    "{}",
                    &head[..80]
                );
                assert!(!head.contains("Value units"));
            }
        }
        // `info`: intensities, no µm and no height statistics.
        let o = run(&["info", s(&out)]);
        ok(&o);
        let text = String::from_utf8_lossy(&o.stdout);
        assert!(text.contains("quantity        intensities"), "{text}");
        assert!(text.contains(&format!("intensity max   {max}\n")), "{text}");
        assert!(!text.contains("height max") && !text.contains(&format!("{} µm", max * 1e6)));
        let o = run(&["info", s(&out), "--json"]);
        ok(&o);
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(v["quantity"], "intensity", "{ext}");
        assert!(v["max_m"].is_null(), "{ext}");
        assert_eq!(v["intensity_values"]["max"].as_f64(), Some(max), "{ext}");
        // And back to X3P from each: the same raw values, still intensities.
        let back = d.join(format!("back-{ext}.x3p"));
        ok(&run(&["convert", s(&out), s(&back)]));
        same(&raw_x3p(&back), &raw, &format!("{ext} -> x3p"));
    }
    // The fixture itself, described by `info`.
    let o = run(&["info", s(&src), "--json"]);
    ok(&o);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["quantity"], "intensity");
    // Heights stay heights.
    let o = run(&[
        "info",
        s(&fixture("synth-hwhm3-smooth.height.x3p")),
        "--json",
    ]);
    ok(&o);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["quantity"], "height");
    assert!(v["max_m"].as_f64().unwrap() > 1e-6);
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn an_intensity_image_is_refused_where_heights_are_expected() {
    let d = scratch("quantity", "refuse");
    let src = fixture("synth-hwhm3-smooth.intensity.x3p");
    let txt = d.join("i.txt");
    ok(&run(&["convert", s(&src), s(&txt)]));
    for map in [&src, &txt] {
        for args in [
            vec!["stats", "--map", s(map)],
            vec!["segment", s(map), "--out", s(&d.join("f.csv"))],
        ] {
            let o = run(&args);
            let err = String::from_utf8_lossy(&o.stderr);
            assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
            assert!(
                err.contains("holds intensities") && err.contains(s(map)),
                "{err}"
            );
        }
    }
    // Where an intensity is expected, a text image with `# Channel: intensity` (and no
    // value unit) is one.
    let height = fixture("synth-hwhm3-smooth.height.x3p");
    let o = run(&[
        "info",
        s(&height),
        "--intensity",
        s(&txt),
        "--cutoff",
        "0.49",
        "--json",
    ]);
    ok(&o);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    // The fixture's README: 73.8 % of the map is covered by flakes (intensity 0.9).
    let kept = v["valid_points"].as_f64().unwrap() / (512.0 * 512.0);
    assert!((kept - 0.738).abs() < 0.001, "{kept}");
    // A height map where an intensity is expected: refused.
    let htxt = d.join("h.txt");
    ok(&run(&["convert", s(&height), s(&htxt)]));
    let o = run(&[
        "info",
        s(&height),
        "--intensity",
        s(&htxt),
        "--cutoff",
        "0.49",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("holds heights"), "{err}");
    let _ = std::fs::remove_dir_all(&d);
}
