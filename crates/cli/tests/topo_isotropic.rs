//! `flakescatter topo --isotropic`: the tilted plane's ring in a cone (closed form), the
//! JSON keys and units, empty standard errors, the same numbers as the facade's
//! `isotropic_curves`, independence of how the map lies on its grid, and flag errors.

mod common;

use std::path::{Path, PathBuf};
use std::process::Output;

use common::{bin, fixture, fresnel_ts_tp as ts_tp, stderr};
use flakescatter::io::{MapFormat, ReadOptions, read_intensity, read_map, write_map};
use flakescatter::stats::heightmap::HeightMap;
use flakescatter::{Coating, DetectorSet, Instrument, Settings, TopoSettings, isotropic_curves};

fn dir(name: &str) -> PathBuf {
    common::scratch("iso", name)
}

fn run(args: &[&str]) -> Output {
    bin().arg("topo").args(args).output().unwrap()
}

/// Header and rows of a CSV text.
fn csv(text: &str) -> (Vec<String>, Vec<Vec<String>>) {
    let mut lines = text.lines();
    let header = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_owned)
        .collect();
    let rows = lines
        .map(|l| l.split(',').map(str::to_owned).collect())
        .collect();
    (header, rows)
}

/// A 40 × 40 plane tilted by 2° along x, 0.5 µm pitch, heights in µm (plain text).
fn tilted_plane(d: &Path) -> PathBuf {
    let p = d.join("plane.txt");
    let slope = 2f64.to_radians().tan();
    let mut s = String::new();
    for _ in 0..40 {
        let row: Vec<String> = (0..40)
            .map(|c| format!("{:.12}", c as f64 * 0.5 * slope))
            .collect();
        s.push_str(&row.join(" "));
        s.push('\n');
    }
    std::fs::write(&p, s).unwrap();
    p
}

/// At normal incidence a plane tilted by β = 2°, turned to every azimuth φ, sends its
/// rays to the ring θo = asin(n sin 2β) at azimuth φ, each with the same weight F (the
/// plain topo test's F = ½[Ts(0)Ts(θo) + Tp(0)Tp(θo)], since γ = m.z = cos β at every
/// azimuth). A cone of half-angle α about (θo, 0) holds the ring's directions with
/// cos θo² + sin θo² cos φ ≥ cos α, i.e. |φ| ≤ φm = acos((cos α − cos² θo) / sin² θo):
/// the fraction φm/π of the ring. So reflectance = F · (1296/1600) · φm/π on both sides
/// (θs = ±θo), with all 1296 usable pixels counted, and nothing at 20°.
#[test]
fn tilted_plane_ring_in_a_cone_is_the_closed_form() {
    let d = dir("plane");
    let plane = tilted_plane(&d);
    let n = 1.5;
    let theta_o = (n * 4f64.to_radians().sin()).asin();
    let alpha = 0.5f64.to_radians();
    let ts = format!(
        "{:.9},-{:.9},20",
        theta_o.to_degrees(),
        theta_o.to_degrees()
    );
    let out = run(&[
        plane.to_str().unwrap(),
        "--pixel-um",
        "0.5",
        "--z-unit",
        "um",
        "--isotropic",
        "--theta-i",
        "0",
        "--theta-s",
        &ts,
        "--aperture",
        "0.5",
        "--tile-um",
        "5",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let (header, rows) = csv(&String::from_utf8_lossy(&out.stdout));
    assert_eq!(
        header.join(","),
        "theta_i_deg,theta_s_deg,phi_s_deg,aperture_deg,brdf_per_sr,reflectance,relative,rays,std_err"
    );
    assert_eq!(rows.len(), 3);
    let (t0, p0) = ts_tp(0.0, n);
    let (to, po) = ts_tp(theta_o, n);
    let f = 0.5 * (t0 * to + p0 * po);
    let (c, s) = (theta_o.cos(), theta_o.sin());
    let phi_m = ((alpha.cos() - c * c) / (s * s)).acos();
    let expected = f * 1296.0 / 1600.0 * phi_m / std::f64::consts::PI;
    for row in &rows[..2] {
        let refl: f64 = row[5].parse().unwrap();
        assert!(
            (refl / expected - 1.0).abs() < 1e-6,
            "{row:?}: {refl} vs {expected}"
        );
        assert_eq!(row[7], "1296");
    }
    assert_eq!(rows[2][5].parse::<f64>().unwrap(), 0.0);
    assert_eq!(rows[2][7], "0");
    // No detector at the specular direction (the normal) receives light: `relative` is
    // undefined, said once.
    assert!(rows.iter().all(|r| r[6].is_empty()));
    assert!(
        stderr(&out).contains("`relative` is undefined"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn json_has_the_isotropic_keys_with_units() {
    let d = dir("json");
    let plane = tilted_plane(&d);
    let out = run(&[
        plane.to_str().unwrap(),
        "--pixel-um",
        "0.5",
        "--z-unit",
        "um",
        "--isotropic",
        "--theta-i",
        "0,30",
        "--theta-s",
        "-40:40:10",
        "--tile-um",
        "5",
        "--json",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(j["model"], "topographic-isotropic");
    assert_eq!(j["inputs"]["isotropic"], true);
    let counts = &j["counts"];
    // 1296 usable pixels, two incidences: 2592 rings.
    assert_eq!(counts["usable_pixels"], 1296);
    assert_eq!(counts["rings_traced"], 2592);
    // Default node spacing: aperture / 128 = 1.5° / 128.
    let spacing = counts["node_spacing_deg"].as_f64().unwrap();
    assert!((spacing - 1.5 / 128.0).abs() < 1e-12, "{spacing}");
    for key in ["rings_lost_tir", "rings_lost_down", "nodes", "tiles"] {
        assert!(counts[key].is_number(), "counts.{key}");
    }
    let rows = j["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 2 * 9);
    for r in rows {
        for key in [
            "theta_i_deg",
            "theta_s_deg",
            "brdf_per_sr",
            "reflectance",
            "rays",
            "std_err",
            "interpolation_error",
        ] {
            assert!(r.get(key).is_some(), "row lacks {key}: {r}");
        }
        let e = r["interpolation_error"].as_f64().unwrap();
        assert!(e >= 0.0 && e.is_finite(), "{r}");
    }
    for key in ["interpolation_error", "rays", "node_spacing_deg", "std_err"] {
        assert!(j["units"][key].is_string(), "units.{key}");
    }
    assert!(j["interpolation_error"]["max"].as_f64().unwrap() >= 0.0);
    assert!(j["interpolation_error"]["max_relative"].is_number());
}

#[test]
fn standard_errors_not_estimable_are_empty_cells() {
    // The plane is 20 µm square, inside one default 32 µm tile: no spread between tiles.
    let d = dir("one-tile");
    let plane = tilted_plane(&d);
    let out = run(&[
        plane.to_str().unwrap(),
        "--pixel-um",
        "0.5",
        "--z-unit",
        "um",
        "--isotropic",
        "--theta-i",
        "0",
        "--theta-s",
        "-10:10:1",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let (header, rows) = csv(&String::from_utf8_lossy(&out.stdout));
    let k = header.iter().position(|h| h == "std_err").unwrap();
    assert_eq!(rows.len(), 21);
    assert!(rows.iter().all(|r| r[k].is_empty()), "{rows:?}");
    let err = stderr(&out);
    assert_eq!(
        err.matches("standard errors not estimable").count(),
        1,
        "{err}"
    );
}

/// The rough fixture masked at its cutoff, as the CLI reads it.
fn rough_fixture() -> HeightMap {
    let opts = ReadOptions::default();
    let (mut map, _) = read_map(fixture("synth-hwhm6-rough.height.x3p"), &opts).unwrap();
    let (intensity, _) = read_intensity(fixture("synth-hwhm6-rough.intensity.x3p"), &opts).unwrap();
    map.apply_intensity_cutoff(&intensity, 0.49).unwrap();
    map
}

#[test]
fn rows_are_the_facades_isotropic_curves() {
    // The command parses flags and writes; the numbers are the facade's, to the last bit
    // (the CSV holds the shortest text that reads back to the same number).
    let out = run(&[
        fixture("synth-hwhm6-rough.height.x3p").to_str().unwrap(),
        "--intensity",
        fixture("synth-hwhm6-rough.intensity.x3p").to_str().unwrap(),
        "--cutoff",
        "0.49",
        "--isotropic",
        "--theta-i",
        "30,60",
        "--theta-s",
        "-70:70:5",
        "--tile-um",
        "16",
        "--clearcoat",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let (header, rows) = csv(&String::from_utf8_lossy(&out.stdout));
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let ts: Vec<f64> = (-14..=14).map(|k| f64::from(k * 5).to_radians()).collect();
    let instrument = Instrument::new(
        vec![30f64.to_radians(), 60f64.to_radians()],
        DetectorSet::InPlane(ts),
        1.5f64.to_radians(),
    )
    .unwrap();
    let settings = Settings {
        clearcoat: true,
        ..Settings::default()
    };
    let topo = TopoSettings {
        window: 5,
        tile_um: 16.0,
    };
    let map = rough_fixture();
    let (curves, _) = isotropic_curves(
        &Coating::default(),
        &instrument,
        &settings,
        &topo,
        None,
        &[&map],
        &|_, _| {},
    )
    .unwrap();
    assert_eq!(rows.len(), curves.rows.len());
    let cell = |s: &str| -> Option<f64> { (!s.is_empty()).then(|| s.parse().unwrap()) };
    for (row, want) in rows.iter().zip(&curves.rows) {
        assert_eq!(cell(&row[col("brdf_per_sr")]), Some(want.brdf), "{row:?}");
        assert_eq!(cell(&row[col("reflectance")]), want.reflectance, "{row:?}");
        assert_eq!(
            cell(&row[col("relative")]),
            want.relative.is_finite().then_some(want.relative)
        );
        assert_eq!(row[col("rays")].parse::<u64>().ok(), want.rays, "{row:?}");
        assert_eq!(cell(&row[col("std_err")]), want.std_err, "{row:?}");
    }
}

#[test]
fn transposed_and_flipped_maps_give_the_same_isotropic_curves() {
    // physics.md §5.1: a pixel enters only through its tilt and area factor, so the map's
    // orientation on its grid cannot matter (to rounding); the plain model changes.
    let d = dir("transpose");
    let map = rough_fixture();
    let (nx, ny) = (map.nx(), map.ny());
    let mut heights = vec![f64::NAN; nx * ny];
    let mut mask = vec![false; nx * ny];
    // Transposed and then flipped left-right: (col, row) -> (ny - 1 - row, col).
    for row in 0..ny {
        for col in 0..nx {
            if let Some(z) = map.get(col, row) {
                let (c2, r2) = (ny - 1 - row, col);
                heights[r2 * ny + c2] = z;
                mask[r2 * ny + c2] = true;
            }
        }
    }
    let turned = HeightMap::with_mask(ny, nx, map.dy(), map.dx(), heights, mask).unwrap();
    let (a, b) = (d.join("map.txt"), d.join("turned.txt"));
    write_map(&map, &a, MapFormat::Text).unwrap();
    write_map(&turned, &b, MapFormat::Text).unwrap();
    let curves = |path: &Path, iso: bool| -> Vec<f64> {
        let mut args = vec![
            path.to_str().unwrap(),
            "--theta-i",
            "30",
            "--theta-s",
            "-70:70:2",
        ];
        if iso {
            args.push("--isotropic");
        }
        let out = run(&args);
        assert!(out.status.success(), "{}", stderr(&out));
        let (_, rows) = csv(&String::from_utf8_lossy(&out.stdout));
        rows.iter().map(|r| r[5].parse().unwrap()).collect()
    };
    let (iso_a, iso_b) = (curves(&a, true), curves(&b, true));
    let peak = iso_a.iter().copied().fold(0.0, f64::max);
    assert!(peak > 0.0);
    for (x, y) in iso_a.iter().zip(&iso_b) {
        assert!((x - y).abs() <= 1e-9 * peak, "{x} vs {y}");
    }
    let (plain_a, plain_b) = (curves(&a, false), curves(&b, false));
    let largest = plain_a
        .iter()
        .zip(&plain_b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max);
    assert!(
        largest > 1e-3 * peak,
        "the plain model did not change: {largest}"
    );
}

#[test]
fn node_spacing_is_checked_and_needs_isotropic() {
    let d = dir("flags");
    let plane = tilted_plane(&d);
    let p = plane.to_str().unwrap();
    let base = ["--pixel-um", "0.5", "--z-unit", "um"];
    let o = run(&[&[p][..], &base, &["--node-spacing-deg", "0.01"]].concat());
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--isotropic"), "{}", stderr(&o));
    for bad in ["0", "-0.01", "1", "nan"] {
        let o = run(&[&[p][..], &base, &["--isotropic", "--node-spacing-deg", bad]].concat());
        assert_eq!(o.status.code(), Some(2), "{bad}: {}", stderr(&o));
        assert!(
            stderr(&o).contains("--node-spacing-deg"),
            "{bad}: {}",
            stderr(&o)
        );
    }
    // The rotation average is scalar: the polarisation flags are refused beside it.
    for pol in [
        &["--polarization", "mueller"][..],
        &["--incident", "s"][..],
        &["--analyzer", "p"][..],
    ] {
        let o = run(&[&[p][..], &base, &["--isotropic"], pol].concat());
        assert_eq!(o.status.code(), Some(2), "{pol:?}: {}", stderr(&o));
        assert!(
            stderr(&o).contains("--isotropic"),
            "{pol:?}: {}",
            stderr(&o)
        );
    }
    // A valid spacing is used and echoed.
    let o = run(&[
        &[p][..],
        &base,
        &[
            "--isotropic",
            "--node-spacing-deg",
            "0.02",
            "--theta-i",
            "0",
            "--theta-s",
            "6",
            "--json",
        ],
    ]
    .concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["inputs"]["node_spacing_deg"], 0.02);
    let used = j["counts"]["node_spacing_deg"].as_f64().unwrap();
    assert!((used - 0.02).abs() < 1e-12, "{used}");
}

#[test]
fn plot_draws_the_standard_error_band() {
    // With standard errors (16 µm tiles on the 92 µm rough fixture) the SVG holds the
    // band polygons; without them (one tile) it holds none.
    let d = dir("plot");
    let draw = |tile: &str, name: &str| -> String {
        let svg = d.join(name);
        let o = run(&[
            fixture("synth-hwhm6-rough.height.x3p").to_str().unwrap(),
            "--intensity",
            fixture("synth-hwhm6-rough.intensity.x3p").to_str().unwrap(),
            "--cutoff",
            "0.49",
            "--isotropic",
            "--theta-i",
            "30",
            "--theta-s",
            "-45:-15:0.5",
            "--tile-um",
            tile,
            "--out",
            d.join(format!("{name}.csv")).to_str().unwrap(),
            "--plot",
            svg.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        std::fs::read_to_string(svg).unwrap()
    };
    let with = draw("16", "with.svg");
    assert!(with.contains("<polygon"), "no band drawn");
    assert!(with.contains("standard error"), "band legend");
    let without = draw("1000", "without.svg");
    assert!(
        !without.contains("<polygon"),
        "a band without standard errors"
    );
}
