//! `flakescatter stats` end to end: outputs, exit codes and bad-input messages.

mod common;

use std::path::PathBuf;

use common::run;

fn dir(name: &str) -> PathBuf {
    common::scratch("stats", name)
}

fn write(d: &std::path::Path, name: &str, text: &str) -> PathBuf {
    let p = d.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn histogram_and_json_summary() {
    let d = dir("ok");
    // Four flakes: θx = 2.5° (θn = 2.5°) with areas 1, 1, 2 and one with θy = −0.5° (area 4).
    let table =
        "theta_x_deg,theta_y_deg,area_um2,comment\n2.5,0,1,a\n0,2.5,1,b\n-2.5,0,2,c\n0,-0.5,4,d\n";
    let f = write(&d, "tilts.csv", table);
    let out = d.join("hist.csv");
    let o = run(&[
        "stats",
        "--flakes",
        f.to_str().unwrap(),
        "--bin",
        "1",
        "--out",
        out.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let csv = std::fs::read_to_string(&out).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "theta_lo_deg,theta_hi_deg,area_fraction,p_per_rad,p_tilde"
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 90);
    // Bin [0°, 1°) holds area 4 of 8, bin [2°, 3°) area 4 of 8.
    assert_eq!(rows[0][2], 0.5);
    assert_eq!(rows[2][2], 0.5);
    // p̃ = fraction / (cos 2° − cos 3°), p per rad = fraction / 1° in radians.
    let r = |x: f64| x.to_radians();
    assert!((rows[2][4] / (0.5 / (r(2.0).cos() - r(3.0).cos())) - 1.0).abs() < 1e-12);
    assert!((rows[2][3] / (0.5 / r(1.0)) - 1.0).abs() < 1e-12);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["flakes"], 4);
    assert_eq!(v["total_area_um2"], 8.0);
    assert_eq!(v["input"]["bin_deg"], 1.0);
    assert_eq!(v["version"], env!("CARGO_PKG_VERSION"));
    // ML: area-weighted mean square tilt m2 = (4·2.5² + 4·0.5²)/8 deg² = 3.25 deg²;
    // for small s, E[θ²] = 2 s² (1 − s²/3 + …), so s ≈ sqrt(m2/2) and
    // hwhm = s·sqrt(2 ln 2) = sqrt(3.25 ln 2) deg, to ~1e-4 relative.
    let hwhm = v["hwhm_deg"].as_f64().unwrap();
    let expected = (3.25 * 2f64.ln()).sqrt();
    assert!((hwhm / expected - 1.0).abs() < 1e-3, "{hwhm} vs {expected}");
    let ci = v["hwhm_ci95_deg"].as_array().unwrap();
    let (lo, hi) = (ci[0].as_f64().unwrap(), ci[1].as_f64().unwrap());
    assert!(lo < hwhm && hwhm < hi);
    assert!(
        v["hwhm_ci95_method"]
            .as_str()
            .unwrap()
            .contains("profile likelihood")
    );
}

#[test]
fn histogram_to_stdout_without_json() {
    let d = dir("stdout");
    let f = write(&d, "n.csv", "nx,ny,nz,area_um2\n0,0,1,2\n");
    let o = run(&["stats", "--flakes", f.to_str().unwrap(), "--bin", "45"]);
    assert_eq!(o.status.code(), Some(0));
    let text = String::from_utf8(o.stdout).unwrap();
    assert_eq!(text.lines().count(), 3);
    assert!(text.lines().nth(1).unwrap().starts_with("0,45,1,"));
}

fn expect_error(name: &str, table: &str, extra: &[&str], code: i32, needles: &[&str]) {
    let d = dir(name);
    let f = write(&d, "t.csv", table);
    let mut args = vec!["stats", "--flakes", f.to_str().unwrap()];
    args.extend_from_slice(extra);
    let o = run(&args);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(code), "{name}: {err}");
    assert!(!err.contains("panicked"), "{err}");
    for n in needles {
        assert!(err.contains(n), "{name}: {n:?} not in {err}");
    }
}

#[test]
fn bad_input_exit_2_with_file_line_column() {
    let good = "nx,ny,nz,area_um2\n0,0,1,1\n";
    for bin in ["0", "-1", "46", "nan"] {
        expect_error("bin", good, &["--bin", bin], 2, &["--bin"]);
    }
    expect_error(
        "missing",
        "nx,ny,area_um2\n0,0,1\n",
        &[],
        2,
        &["t.csv", "closest is normals set", "nz"],
    );
    expect_error(
        "unknown",
        "a,b,c\n1,2,3\n",
        &[],
        2,
        &["t.csv", "none of the flake column sets"],
    );
    expect_error(
        "nonnumeric",
        "nx,ny,nz,area_um2\n0,0,1,1\n0,0,one,1\n",
        &[],
        2,
        &["t.csv, line 3, column nz", "\"one\""],
    );
    expect_error(
        "nan",
        "theta_x_deg,theta_y_deg,area_um2\n1,NaN,1\n",
        &[],
        2,
        &["line 2, column theta_y_deg", "finite"],
    );
    expect_error(
        "zero-area",
        "nx,ny,nz,area_um2\n0,0,1,0\n",
        &[],
        2,
        &["line 2, column area_um2", "> 0"],
    );
    expect_error(
        "negative-area",
        "theta_x_deg,theta_y_deg,area_um2\n1,1,1\n1,1,-3\n",
        &[],
        2,
        &["line 3, column area_um2"],
    );
    expect_error(
        "degenerate",
        "x1_um,z1_um,x2_um,z2_um,y1_um,zy1_um,y2_um,zy2_um\n4,0,4,1,0,0,10,0\n",
        &[],
        2,
        &["line 2, column x1_um, x2_um", "degenerate"],
    );
    expect_error(
        "empty",
        "nx,ny,nz,area_um2\n",
        &[],
        2,
        &["t.csv", "no data rows"],
    );
    let o = run(&["stats", "--flakes", "/nonexistent/x.csv"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("/nonexistent/x.csv"));
}

#[test]
fn unwritable_output_is_exit_1() {
    expect_error(
        "unwritable",
        "nx,ny,nz,area_um2\n0,0,1,1\n",
        &["--out", "/nonexistent-dir/h.csv"],
        1,
        &["--out", "h.csv"],
    );
}

/// `stats --map` over the two shipped maps (generated with hwhm 3° and 6°,
/// fixtures/README.md), paired by suffix: a per-map table whose intervals cover each
/// generator's width, both maps flagged, a pooled width between the two (the pooled
/// maximum-likelihood mean square tilt is the area-weighted mean of the maps' own, so it
/// lies between them), the 2-map warning with a map-level interval on 1 degree of
/// freedom, the plot as a PNG, and the pairing errors.
#[test]
fn several_maps_are_pooled_and_a_map_that_differs_is_flagged() {
    let d = dir("maps");
    let fx = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures");
    let (m3, m6) = (
        fx.join("synth-hwhm3-smooth.height.x3p"),
        fx.join("synth-hwhm6-rough.height.x3p"),
    );
    let (m3, m6) = (m3.to_str().unwrap(), m6.to_str().unwrap());
    let (per, plot) = (d.join("per.csv"), d.join("hist.png"));
    let o = run(&[
        "stats",
        "--map",
        m3,
        m6,
        "--intensity-suffix",
        ".intensity",
        "--cutoff",
        "0.49",
        "--per-map",
        per.to_str().unwrap(),
        "--plot",
        plot.to_str().unwrap(),
        "--json",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("only 2 maps"), "{err}");
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["map_level"]["dof"], 1, "{}", j["map_level"]);
    let text = std::fs::read_to_string(&per).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert!(lines[0].starts_with("map,flakes,area_um2,effective_flakes,hwhm_deg,hwhm_ci95_lo_deg,hwhm_ci95_hi_deg,z,flagged"), "{}", lines[0]);
    assert_eq!(lines.len(), 3, "{text}");
    let mut widths = Vec::new();
    for (line, truth) in lines[1..].iter().zip([3.0, 6.0]) {
        let c: Vec<&str> = line.split(',').collect();
        let f = |i: usize| c[i].parse::<f64>().unwrap();
        assert!(
            f(5) < truth && truth < f(6),
            "{line}: interval misses {truth}°"
        );
        assert_eq!(c[8], "true", "{line}: not flagged");
        widths.push(f(4));
    }
    let pooled = j["hwhm_deg"].as_f64().unwrap();
    assert!(
        widths[0] < pooled && pooled < widths[1],
        "{pooled} vs {widths:?}"
    );
    let dec = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&plot).unwrap()));
    assert!(dec.read_info().unwrap().info().width > 0);

    // Pairing errors name what is missing.
    let o = run(&[
        "stats",
        "--map",
        m6,
        "--intensity-suffix",
        ".nope",
        "--cutoff",
        "0.49",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("synth-hwhm6-rough.nope.x3p"), "{err}");
    let i6 = fx.join("synth-hwhm6-rough.intensity.x3p");
    let o = run(&[
        "stats",
        "--map",
        m3,
        m6,
        "--intensity",
        i6.to_str().unwrap(),
        "--cutoff",
        "0.49",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--intensity given 1 times for 2 height maps"),
        "{err}"
    );

    // --pixel-normals: the pixel-level statistics beside the flake-level width.
    let o = run(&[
        "stats",
        "--map",
        m6,
        "--intensity-suffix",
        ".intensity",
        "--cutoff",
        "0.49",
        "--pixel-normals",
        "--json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["histogram_of"], "pixel normals");
    assert!(
        j["pixel_level"].is_object() && j["width_sources"].is_object(),
        "{j}"
    );
    let _ = std::fs::remove_dir_all(&d);
}
