//! `fit --paint`, `model --params`, `compare --params` end to end, and their bad input.

mod common;

use common::{run_text as run, scratch};
use std::path::{Path, PathBuf};

fn paints() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/real/paints")
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The fitted paint written to P.json is the paint `compare --params` and
/// `model --params` evaluate: the residual groups agree with the fit's, and the model at
/// the table's geometries (written with --detectors) is the fit's per-point model.
#[test]
fn fit_params_model_and_compare_agree() {
    let dir = scratch("paint", "roundtrip");
    let gold = paints().join("gold-metallic-paint2.csv");
    let params = dir.join("gold.json");
    let points = dir.join("points.csv");
    let plots = dir.join("plots");
    let (code, out, err) = run(&[
        "fit",
        "--measured",
        s(&gold),
        "--paint",
        "--family",
        "trowbridge-reitz",
        "--theta-i",
        "30,60",
        "--max-theta-r",
        "80",
        "--params-out",
        s(&params),
        "--out",
        s(&points),
        "--plot",
        s(&plots),
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let fit: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(fit["fit"]["family"], "trowbridge-reitz");
    for f in [
        "in_plane_theta_i_30.png",
        "in_plane_theta_i_60.png",
        "out_of_plane_residuals.png",
    ] {
        let bytes = std::fs::read(plots.join(f)).unwrap();
        assert_eq!(&bytes[1..4], b"PNG", "{f}");
    }
    // compare --params: the same residual groups as the fit reported.
    let (code, out, err) = run(&[
        "compare",
        "--measured",
        s(&gold),
        "--params",
        s(&params),
        "--theta-i",
        "30,60",
        "--max-theta-r",
        "80",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let cmp: serde_json::Value = serde_json::from_str(&out).unwrap();
    let (a, b) = (
        fit["fit"]["residuals"].as_array().unwrap(),
        cmp["residuals"].as_array().unwrap(),
    );
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(b) {
        let (p, q) = (
            x["rms_log10"].as_f64().unwrap(),
            y["rms_log10"].as_f64().unwrap(),
        );
        assert!((p - q).abs() < 1e-9, "{x} vs {y}");
    }
    // model --params at the out-of-plane geometries of θi = 60 (point detectors): the
    // fit's per-point model values.
    let table = std::fs::read_to_string(&points).unwrap();
    let rows: Vec<Vec<String>> = table
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(str::to_string).collect())
        .filter(|f: &Vec<String>| f[0] == "60" && f[2] != "0" && f[2] != "180" && f[3] == "g")
        .collect();
    assert!(rows.len() > 50);
    let mut det = String::from("theta_r_deg,phi_r_deg\n");
    for r in &rows {
        det.push_str(&format!("{},{}\n", r[1], r[2]));
    }
    let detectors = dir.join("detectors.csv");
    std::fs::write(&detectors, det).unwrap();
    let (code, out, err) = run(&[
        "model",
        "--params",
        s(&params),
        "--theta-i",
        "60",
        "--detectors",
        s(&detectors),
        "--aperture",
        "0",
    ]);
    assert_eq!(code, 0, "{err}");
    let header: Vec<&str> = out.lines().next().unwrap().split(',').collect();
    let g = header.iter().position(|h| *h == "brdf_g_per_sr").unwrap();
    for (line, r) in out.lines().skip(1).zip(&rows) {
        let v: f64 = line.split(',').nth(g).unwrap().parse().unwrap();
        let want: f64 = r[5].parse().unwrap();
        assert!((v - want).abs() <= 1e-12 * want, "{line} vs {want}");
    }
}

/// Bad tables and flags: exit status 2, the file, line and column (or the flag) named.
#[test]
fn bad_input_is_named() {
    let dir = scratch("paint", "bad");
    let head = "theta_i_deg,theta_r_deg,phi_r_deg,brdf_g_per_sr\n";
    let good_rows: String = (0..40)
        .map(|k| format!("30,{},{}\n", 2 * (k % 20) + 1, if k < 20 { 0 } else { 180 }))
        .map(|g| format!("{}1e-1\n", g.trim_end().to_string() + ","))
        .collect();
    let cases: Vec<(&str, String, &str)> = vec![
        (
            "zero",
            format!("{head}30,10,0,0\n{good_rows}"),
            "line 2, column brdf_g_per_sr: 0 is not positive",
        ),
        (
            "negative",
            format!("{head}{good_rows}30,10,45,-0.5\n"),
            "line 42, column brdf_g_per_sr",
        ),
        (
            "channel",
            "theta_i_deg,theta_r_deg,phi_r_deg,brdf_green_per_sr\n30,10,0,1\n".into(),
            "line 1, column brdf_green_per_sr: unknown channel `green`",
        ),
        (
            "angle",
            format!("{head}{good_rows}30,95,0,1\n"),
            "line 42, column theta_r_deg: 95 is outside [0, 90)",
        ),
        (
            "duplicate",
            format!("{head}30,10,0,1\n30,10,360,1\n"),
            "line 3, column theta_i_deg, theta_r_deg, phi_r_deg: the geometry (30, 10, 360) degrees is already on line 2",
        ),
        ("empty", head.into(), "no data rows"),
    ];
    for (name, text, needle) in cases {
        let f = dir.join(format!("{name}.csv"));
        std::fs::write(&f, text).unwrap();
        let (code, _, err) = run(&["fit", "--measured", s(&f), "--paint"]);
        assert_eq!(code, 2, "{name}: {err}");
        assert!(
            err.contains(s(&f)) && err.contains(needle),
            "{name}: `{err}` lacks `{needle}`"
        );
    }
    // No usable rows after the selection.
    let f = dir.join("few.csv");
    std::fs::write(&f, format!("{head}{good_rows}")).unwrap();
    let (code, _, err) = run(&["fit", "--measured", s(&f), "--paint", "--min-value", "5"]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains(s(&f)) && err.contains("no usable point"),
        "{err}"
    );
    // Flags that do not apply.
    for (args, needle) in [
        (
            vec!["--aperture", "1.5"],
            "--aperture does not apply to --paint",
        ),
        (
            vec!["--nonparametric"],
            "--nonparametric does not apply to --paint",
        ),
        (vec!["--family", "cauchy"], "--family cauchy"),
        (vec!["--coverage", "1.5"], "--coverage 1.5"),
        (vec!["--theta-s", "-30"], "--theta-s"),
    ] {
        let mut a = vec!["fit", "--measured", s(&f), "--paint"];
        a.extend(args);
        let (code, _, err) = run(&a);
        assert_eq!(code, 2, "{a:?}: {err}");
        assert!(err.contains(needle), "{a:?}: `{err}` lacks `{needle}`");
    }
    let (code, _, err) = run(&["fit", "--measured", s(&f), "--coverage", "0.5"]);
    assert_eq!(code, 2);
    assert!(err.contains("--coverage applies to --paint"), "{err}");
    // A table in a command that takes curves says where it belongs.
    let (code, _, err) = run(&["fit", "--measured", s(&f)]);
    assert_eq!(code, 2);
    assert!(err.contains("fit --paint"), "{err}");
}

/// A channel of the table that the paint does not have, and a malformed parameter file.
#[test]
fn params_must_match_the_table() {
    let dir = scratch("paint", "params");
    let head = "theta_i_deg,theta_r_deg,phi_r_deg,brdf_g_per_sr\n";
    let rows: String = (0..30)
        .map(|k| format!("45,{},0,{}\n", 2 * k + 1, 0.5 / f64::from(k + 1)))
        .collect();
    let table = dir.join("g.csv");
    std::fs::write(&table, format!("{head}{rows}")).unwrap();
    let params = dir.join("p.json");
    let (code, _, err) = run(&[
        "fit",
        "--measured",
        s(&table),
        "--paint",
        "--family",
        "gaussian",
        "--params-out",
        s(&params),
    ]);
    assert_eq!(code, 0, "{err}");
    let rtable = dir.join("r.csv");
    std::fs::write(
        &rtable,
        format!("theta_i_deg,theta_r_deg,phi_r_deg,brdf_r_per_sr\n{rows}"),
    )
    .unwrap();
    let (code, _, err) = run(&["compare", "--measured", s(&rtable), "--params", s(&params)]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains(s(&rtable))
            && err.contains(
                "channel `r` (column brdf_r_per_sr) is not in the paint's parameters, which have g"
            ),
        "{err}"
    );
    let bad = dir.join("bad.json");
    std::fs::write(
        &bad,
        "{\"format\": \"flakescatter paint parameters\", \"version\": 1}",
    )
    .unwrap();
    let (code, _, err) = run(&["model", "--params", s(&bad)]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains(s(&bad)) && err.contains("missing field"),
        "{err}"
    );
    let (code, _, err) = run(&["model", "--params", s(&params), "--hwhm", "3"]);
    assert_eq!(code, 2);
    assert!(err.contains("cannot be used with"), "{err}");
}

/// `model --paint` from flags is the paint its JSON echoes: the same paint given back as
/// a parameter file gives the same numbers; and heavy-tailed orientations are flags.
#[test]
fn a_paint_from_flags_is_its_parameter_file() {
    let dir = scratch("paint", "flags");
    let flags = [
        "model",
        "--paint",
        "--orientation",
        "pearson-vii",
        "--alpha",
        "0.1",
        "--shape",
        "2.5",
        "--channels",
        "r,550nm",
        "--flake-scale",
        "0.9,0.7",
        "--base-albedo",
        "0.2",
        "--paint-coverage",
        "0.6",
        "--coat-roughness",
        "0.02",
        "--haze",
        "0.1",
        "--haze-roughness",
        "0.4",
        "--theta-i",
        "20,50",
        "--theta-s",
        "-60:60:10",
        "--aperture",
        "0.5",
    ];
    let (code, csv_flags, err) = run(&flags);
    assert_eq!(code, 0, "{err}");
    let (code, out, err) = run(&[&flags[..], &["--json"]].concat());
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let params = dir.join("p.json");
    std::fs::write(
        &params,
        serde_json::to_string(&v["paint"]["paint"]).unwrap(),
    )
    .unwrap();
    let (code, csv_file, err) = run(&[
        "model",
        "--params",
        s(&params),
        "--theta-i",
        "20,50",
        "--theta-s",
        "-60:60:10",
        "--aperture",
        "0.5",
    ]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(csv_flags, csv_file);
    assert!(csv_flags.starts_with(
        "theta_i_deg,theta_s_deg,theta_r_deg,phi_r_deg,aperture_deg,brdf_r_per_sr,brdf_550nm_per_sr\n"
    ));
    for (args, needle) in [
        (
            vec!["model", "--paint", "--shape", "2"],
            "--shape needs --orientation pearson-vii",
        ),
        (
            vec!["model", "--paint", "--orientation", "trowbridge-reitz"],
            "needs --alpha",
        ),
        (
            vec!["model", "--paint", "--flake-scale", "1.5"],
            "flake scale of channel `g` = 1.5",
        ),
        (vec!["model", "--channels", "g"], "--paint"),
    ] {
        let (code, _, err) = run(&args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: `{err}` lacks `{needle}`");
    }
}

/// The measured argument for multiple scattering (physics.md §12.5): the volume model
/// (a 3-D layer of aluminium flakes, Trowbridge–Reitz α 0.12, mass loading 0.1, over a
/// Lambertian primer of reflectance 0.3) has light bounced between flakes, a large share
/// of it far from specular; the paint model, which scatters once off each flake, fitted
/// to the volume model's total BRDF reaches the targets' level in every group: its
/// fitted flake tails and base carry the multiple scattering.
#[test]
fn multiple_scattering_is_carried_by_the_fitted_paint() {
    let dir = scratch("paint", "volume");
    let mut det = String::from("theta_r_deg,phi_r_deg\n");
    let mut geo = Vec::new();
    for phi in [0, 180] {
        for k in 1..=16 {
            geo.push((5 * k, phi));
        }
    }
    for phi in [30, 60, 90, 135] {
        for tr in (10..=80).step_by(10) {
            geo.push((tr, phi));
        }
    }
    for (a, b) in &geo {
        det.push_str(&format!("{a},{b}\n"));
    }
    let detectors = dir.join("det.csv");
    std::fs::write(&detectors, det).unwrap();
    let vol = dir.join("volume.csv");
    let (code, _, err) = run(&[
        "volume",
        "--orientation",
        "trowbridge-reitz",
        "--alpha",
        "0.12",
        "--flake-index",
        "0.96,6.69",
        "--mass-loading",
        "0.1",
        "--substrate-reflectance",
        "0.3",
        "--substrate",
        "lambertian",
        "--theta-i",
        "15,45,75",
        "--detectors",
        s(&detectors),
        "--aperture",
        "5",
        "--rays",
        "1000000",
        "--tile-um",
        "4000",
        "--out",
        s(&vol),
    ]);
    assert_eq!(code, 0, "{err}");
    let text = std::fs::read_to_string(&vol).unwrap();
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (ti, total, multiple) = (
        col("theta_i_deg"),
        col("brdf_per_sr"),
        col("multiple_bounce_brdf_per_sr"),
    );
    let mut table = String::from("theta_i_deg,theta_r_deg,phi_r_deg,brdf_g_per_sr\n");
    let mut shares = Vec::new();
    for (k, line) in text.lines().skip(1).enumerate() {
        let f: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        let (tr, pr) = geo[k % geo.len()];
        if f[total] > 0.0 {
            table.push_str(&format!("{},{tr},{pr},{}\n", f[ti], f[total]));
        }
        // Far from specular, in the plane: the multiple bounces' share.
        let ts = if pr == 0 {
            -f64::from(tr)
        } else {
            f64::from(tr)
        };
        if (ts + f[ti]).abs() > 40.0 && pr % 180 == 0 && f[total] > 0.0 {
            shares.push(f[multiple] / f[total]);
        }
    }
    shares.sort_by(f64::total_cmp);
    let median = shares[shares.len() / 2];
    assert!(
        median > 0.2,
        "multiple bounces carry a median {median} far from specular"
    );
    let t = dir.join("volume-table.csv");
    std::fs::write(&t, table).unwrap();
    let (code, out, err) = run(&[
        "fit",
        "--measured",
        s(&t),
        "--paint",
        "--region",
        "5:180",
        "--max-theta-r",
        "80",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let mut worst = 0.0f64;
    for g in v["fit"]["residuals"].as_array().unwrap() {
        let rms = g["rms_log10"].as_f64().unwrap();
        // The issue's targets, written out here; the report states the same per group.
        let target = match (g["plane"].as_str(), g["region"].as_str()) {
            (Some("out"), Some("all")) => 0.1,
            (Some("in"), Some("near")) if g["theta_i_deg"].as_f64() < Some(70.0) => 0.06,
            (Some("in"), Some("far")) if g["theta_i_deg"].as_f64() < Some(70.0) => 0.12,
            (Some("in"), Some("near" | "far")) => 0.2,
            _ => {
                assert!(g["target_rms_log10"].is_null(), "{g}");
                continue;
            }
        };
        assert_eq!(g["target_rms_log10"].as_f64(), Some(target), "{g}");
        worst = worst.max(rms / target);
        assert!(
            rms <= 1.2 * target,
            "{g}: rms {rms} against target {target}"
        );
    }
    assert_eq!(v["fit"]["worst_ratio_to_target"].as_f64(), Some(worst));
}
