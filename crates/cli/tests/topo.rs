//! `flakescatter topo`: CSV columns and values on a tilted plane (closed form), the JSON
//! summary, intensity cutoff, several maps, and bad input (exit status 2).

mod common;

use std::path::{Path, PathBuf};
use std::process::Output;

use common::{bin, fresnel_ts_tp as ts_tp, stderr};

fn dir(name: &str) -> PathBuf {
    common::scratch("topo", name)
}

/// Writes a plain-text matrix (rows of whitespace-separated values).
fn write_matrix(path: &Path, nx: usize, ny: usize, f: impl Fn(usize, usize) -> String) {
    let mut s = String::new();
    for r in 0..ny {
        let row: Vec<String> = (0..nx).map(|c| f(c, r)).collect();
        s.push_str(&row.join(" "));
        s.push('\n');
    }
    std::fs::write(path, s).unwrap();
}

/// A 40 × 40 plane tilted by 2° along x (0.5 µm pitch, heights in µm) and an intensity
/// map that is bright on columns 0..30 only.
fn fixtures(d: &Path) -> (PathBuf, PathBuf) {
    let plane = d.join("plane.txt");
    let slope = 2f64.to_radians().tan();
    write_matrix(&plane, 40, 40, |c, _| {
        format!("{:.12}", c as f64 * 0.5 * slope)
    });
    let intensity = d.join("intensity.txt");
    write_matrix(&intensity, 40, 40, |c, _| {
        if c < 30 { "0.9".into() } else { "0.1".into() }
    });
    (plane, intensity)
}

fn run(args: &[&str]) -> Output {
    bin().arg("topo").args(args).output().unwrap()
}

/// At normal incidence a plane tilted by β = 2° sends every ray to
/// θs = asin(n sin 2β) = 6.0039° (source side); each of the 36 × 36 usable pixels
/// (5 × 5 window) carries F γ/(m.z cos θt) = F with γ = m.z = cos β, cos θt = 1, and
/// F = ½[Ts(0)Ts(θo) + Tp(0)Tp(θo)]; reflectance = F · 1296/1600.
#[test]
fn tilted_plane_csv_has_the_documented_columns_and_values() {
    let d = dir("csv");
    let (plane, _) = fixtures(&d);
    let theta_o = (1.5 * 4f64.to_radians().sin()).asin();
    let ts = format!("{:.6},20", theta_o.to_degrees());
    let out = run(&[
        plane.to_str().unwrap(),
        "--pixel-um",
        "0.5",
        "--z-unit",
        "um",
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
    let text = String::from_utf8(out.stdout).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "theta_i_deg,theta_s_deg,phi_s_deg,aperture_deg,brdf_per_sr,reflectance,relative,rays,std_err"
    );
    let rows: Vec<Vec<String>> = lines
        .map(|l| l.split(',').map(str::to_owned).collect())
        .collect();
    assert_eq!(rows.len(), 2);
    let (t0, p0) = ts_tp(0.0, 1.5);
    let (to, po) = ts_tp(theta_o, 1.5);
    let f = 0.5 * (t0 * to + p0 * po);
    let expected = f * 1296.0 / 1600.0;
    let refl: f64 = rows[0][5].parse().unwrap();
    assert!((refl - expected).abs() < 1e-8, "{refl} vs {expected}");
    assert_eq!(rows[0][7], "1296");
    // Every 5 µm tile carries the same weight per usable pixel... except the border
    // tiles with fewer usable pixels, so the spread is finite and positive.
    let se: f64 = rows[0][8].parse().unwrap();
    assert!(se > 0.0 && se.is_finite());
    assert_eq!(rows[1][7], "0");
    assert_eq!(rows[1][5].parse::<f64>().unwrap(), 0.0);
}

#[test]
fn standard_errors_not_estimable_are_empty_with_one_warning() {
    // The 40 × 40 map of 0.5 µm is 20 µm square, smaller than one default 32 µm tile (and
    // --tile-um 1e9 makes one tile of anything): no spread between tiles, so the std_err
    // column is empty in every row, the JSON has null, and stderr says it once.
    let d = dir("one-tile");
    let (plane, _) = fixtures(&d);
    let base = [
        plane.to_str().unwrap(),
        "--pixel-um",
        "0.5",
        "--z-unit",
        "um",
        "--theta-i",
        "0,30",
        "--theta-s",
        "-40:40:10",
    ];
    for extra in [&[][..], &["--tile-um", "1e9"][..]] {
        let out = run(&[&base[..], extra].concat());
        assert!(out.status.success(), "{}", stderr(&out));
        let text = String::from_utf8(out.stdout.clone()).unwrap();
        let rows: Vec<&str> = text.lines().skip(1).collect();
        assert_eq!(rows.len(), 18);
        assert!(rows.iter().all(|r| r.ends_with(',')), "{text}");
        assert_eq!(
            stderr(&out).matches("not estimable").count(),
            1,
            "{}",
            stderr(&out)
        );
    }
    let out = run(&[&base[..], &["--json"][..]].concat());
    assert!(out.status.success(), "{}", stderr(&out));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(
        v["rows"]
            .as_array()
            .unwrap()
            .iter()
            .all(|r| r["std_err"].is_null())
    );
    // One warning about the standard errors (others, e.g. an undefined `relative` where
    // the tilted plane sends nothing to specular, may stand beside it).
    let warnings = v["warnings"].as_array().unwrap();
    assert_eq!(
        warnings
            .iter()
            .filter(|w| w.as_str().unwrap().contains("not estimable"))
            .count(),
        1,
        "{warnings:?}"
    );
}

#[test]
fn json_summary_counts_pixels_and_rays_over_several_maps() {
    let d = dir("json");
    let (plane, intensity) = fixtures(&d);
    let (p, i) = (plane.to_str().unwrap(), intensity.to_str().unwrap());
    let out = run(&[
        p,
        p,
        "--intensity",
        i,
        "--intensity",
        i,
        "--cutoff",
        "0.5",
        "--pixel-um",
        "0.5",
        "--z-unit",
        "um",
        "--theta-i",
        "0,30",
        "--theta-s",
        "-10:10:5",
        "--json",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["version"], env!("CARGO_PKG_VERSION"));
    assert_eq!(v["command"], "topo");
    let c = &v["counts"];
    // Columns 0..30 valid; the window leaves columns 2..=27 (26) and rows 2..=37 (36).
    assert_eq!(c["maps"], 2);
    assert_eq!(c["pixels"], 3200);
    assert_eq!(c["usable_pixels"], 2 * 26 * 36);
    assert_eq!(c["rays_traced"], 2 * 2 * 26 * 36);
    assert_eq!(c["rays_lost_tir"], 0);
    assert_eq!(c["rays_lost_down"], 0);
    assert_eq!(v["rows"].as_array().unwrap().len(), 2 * 5);
    assert_eq!(v["inputs"]["cutoff"], 0.5);
    assert!(v["rows"][0].get("std_err").is_some() && v["rows"][0].get("rays").is_some());
}

#[test]
fn bad_input_exits_with_status_2_and_a_clear_message() {
    let d = dir("bad");
    let (plane, intensity) = fixtures(&d);
    let nan = d.join("nan.txt");
    write_matrix(&nan, 10, 10, |_, _| "NaN".into());
    let small = d.join("small.txt");
    write_matrix(&small, 12, 10, |_, _| "0.5".into());
    let (p, i) = (plane.to_str().unwrap(), intensity.to_str().unwrap());
    let cal = ["--pixel-um", "0.5", "--z-unit", "um", "--theta-i", "0"];
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec![p, "--intensity", i, "--cutoff", "1.0"],
            "cutoff 1 leaves 0 of 1600 pixels usable",
        ),
        (vec![p, "--window", "4"], "--window <K>"),
        (
            vec![small.to_str().unwrap(), "--window", "11"],
            "larger than height map",
        ),
        (
            vec![p, "--intensity", small.to_str().unwrap(), "--cutoff", "0.5"],
            "intensity map is 12 x 10",
        ),
        (vec![nan.to_str().unwrap()], "no valid pixel"),
        (vec![p, "--aperture", "0"], "--aperture 0"),
        (vec![p, "--cutoff", "0.5"], "needs --intensity"),
        (
            vec![p, p, "--intensity", i, "--cutoff", "0.5"],
            "one intensity map per height map",
        ),
    ];
    for (args, needle) in cases {
        let mut all = args.clone();
        all.extend(cal);
        let out = run(&all);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", stderr(&out));
        assert!(stderr(&out).contains(needle), "{args:?}: {}", stderr(&out));
        assert!(!stderr(&out).contains("panicked"));
    }
}
