//! A tinted binder in a paint (`fit --paint --fit-tint`, `channels[].tint` in a
//! parameter file), end to end, and its bad input (physics.md §12.9).

mod common;

use common::{run_text as run, s, scratch};

/// A paint file: flat coat of index 1.5, Trowbridge–Reitz flakes (α 0.1), coverage 0.6
/// of aluminium, channels r, g, b with flake scale 1, no base, and `tint` (JSON text
/// after the base albedo, e.g. `, "tint": 0.3`) per channel.
fn params(tints: [&str; 3]) -> String {
    format!(
        r#"{{
  "format": "flakescatter paint parameters",
  "version": 1,
  "coat": {{ "n": 1.5, "roughness": 0, "haze": 0, "haze_roughness": 0 }},
  "orientation": {{ "family": "trowbridge-reitz", "alpha": 0.1 }},
  "flakes": {{ "metal": "aluminium", "coverage": 0.6 }},
  "channels": [
    {{ "name": "r", "wavelength_nm": 612, "flake_scale": 1, "base_albedo": 0{} }},
    {{ "name": "g", "wavelength_nm": 547, "flake_scale": 1, "base_albedo": 0{} }},
    {{ "name": "b", "wavelength_nm": 464, "flake_scale": 1, "base_albedo": 0{} }}
  ]
}}"#,
        tints[0], tints[1], tints[2]
    )
}

/// `model --params` at θi = 30° on a few detectors: the output and, per detector, the
/// values of r, g, b.
fn model(file: &std::path::Path, detectors: &[(f64, f64)]) -> (String, Vec<Vec<f64>>) {
    let d = file.with_extension("detectors.csv");
    let mut text = String::from("theta_r_deg,phi_r_deg\n");
    for (t, p) in detectors {
        text.push_str(&format!("{t},{p}\n"));
    }
    std::fs::write(&d, text).unwrap();
    let (code, out, err) = run(&[
        "model",
        "--params",
        s(file),
        "--theta-i",
        "30",
        "--detectors",
        s(&d),
        "--aperture",
        "0",
    ]);
    assert_eq!(code, 0, "{err}");
    let header: Vec<&str> = out.lines().next().unwrap().split(',').collect();
    let cols: Vec<usize> = ["r", "g", "b"]
        .iter()
        .map(|c| {
            header
                .iter()
                .position(|h| *h == format!("brdf_{c}_per_sr"))
                .unwrap()
        })
        .collect();
    let rows = out
        .lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            cols.iter().map(|&j| f[j].parse().unwrap()).collect()
        })
        .collect();
    (out, rows)
}

/// `channels[].tint` in a parameter file: with a flat coat and no base the point BRDF
/// is the flake term alone, so tinted over untinted is Beer–Lambert along the refracted
/// path, `exp(−t (1/μt + 1/μ2))` with `μ = cos(asin(sin θ/1.5))` (Snell, worked out
/// here), to 1e-12; `"tint": 0` is the file without the key, byte for byte.
#[test]
fn a_tint_in_a_parameter_file_attenuates_the_flake_light() {
    let dir = scratch("paint_tint", "beer");
    let (clear, zero, tinted) = (
        dir.join("clear.json"),
        dir.join("zero.json"),
        dir.join("tinted.json"),
    );
    std::fs::write(&clear, params(["", "", ""])).unwrap();
    std::fs::write(
        &zero,
        params([r#", "tint": 0"#, r#", "tint": 0"#, r#", "tint": 0"#]),
    )
    .unwrap();
    let tints = [0.05, 0.15, 0.4];
    std::fs::write(
        &tinted,
        params([r#", "tint": 0.05"#, r#", "tint": 0.15"#, r#", "tint": 0.4"#]),
    )
    .unwrap();
    let detectors = [
        (0.0, 0.0),
        (20.0, 0.0),
        (30.0, 0.0),
        (50.0, 180.0),
        (70.0, 45.0),
    ];
    let (a_text, a) = model(&clear, &detectors);
    let (z_text, _) = model(&zero, &detectors);
    assert_eq!(a_text, z_text);
    let (_, b) = model(&tinted, &detectors);
    let mu = |deg: f64| {
        let sn = deg.to_radians().sin() / 1.5;
        (1.0 - sn * sn).sqrt()
    };
    for (j, (tr, _)) in detectors.iter().enumerate() {
        for k in 0..3 {
            let want = (-tints[k] * (1.0 / mu(30.0) + 1.0 / mu(*tr))).exp();
            let got = b[j][k] / a[j][k];
            assert!(
                (got - want).abs() <= 1e-12 * want,
                "θr {tr} channel {k}: {got} vs {want}"
            );
        }
    }
}

fn gold() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures/real/paints/gold-metallic-paint2.csv")
}

/// `fit --paint --fit-tint` on the gold paint: the report says so and lists the three
/// tints (fitted and physical), the parameter file carries the non-zero ones, and
/// `compare --params` with that file gives the fit's residual groups back (the tint is
/// in the file and `compare` honours it); without the flag no report mentions a tint.
#[test]
fn a_fitted_tint_round_trips() {
    let dir = scratch("paint_tint", "roundtrip");
    let params = dir.join("p.json");
    let table = gold();
    let common = [
        "fit",
        "--measured",
        s(&table),
        "--paint",
        "--family",
        "trowbridge-reitz",
        "--theta-i",
        "30,60",
        "--max-theta-r",
        "80",
        "--min-value",
        "1e-3",
        "--json",
    ];
    let mut a = common.to_vec();
    a.extend(["--fit-tint", "--params-out", s(&params)]);
    let (code, out, err) = run(&a);
    assert_eq!(code, 0, "{err}");
    let fit: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(fit["fit"]["tint_fitted"], true);
    let physical = fit["fit"]["physical"].as_array().unwrap();
    let file: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&params).unwrap()).unwrap();
    let mut nonzero = 0;
    for (k, c) in ["r", "g", "b"].iter().enumerate() {
        let e = physical
            .iter()
            .find(|e| e["name"] == format!("tint {c}"))
            .unwrap_or_else(|| panic!("tint {c} in {physical:?}"));
        let t = e["value"].as_f64().unwrap();
        assert!((0.0..=5.0).contains(&t), "{e}");
        let written = &file["channels"][k]["tint"];
        if t > 0.0 {
            nonzero += 1;
            assert_eq!(written.as_f64(), Some(t), "{c}");
        } else {
            assert!(written.is_null(), "{c}: {written}");
        }
        assert!(
            fit["fit"]["fitted"]
                .as_array()
                .unwrap()
                .iter()
                .any(|e| e["name"] == format!("tint {c}"))
        );
    }
    // Gold's flakes are tinted (blue absorbed: a yellow binder).
    assert!(nonzero > 0, "{physical:?}");
    let (code, out, err) = run(&[
        "compare",
        "--measured",
        s(&table),
        "--params",
        s(&params),
        "--theta-i",
        "30,60",
        "--max-theta-r",
        "80",
        "--min-value",
        "1e-3",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let cmp: serde_json::Value = serde_json::from_str(&out).unwrap();
    let (x, y) = (
        fit["fit"]["residuals"].as_array().unwrap(),
        cmp["residuals"].as_array().unwrap(),
    );
    assert_eq!(x.len(), y.len());
    for (p, q) in x.iter().zip(y) {
        let (p, q) = (
            p["rms_log10"].as_f64().unwrap(),
            q["rms_log10"].as_f64().unwrap(),
        );
        assert!((p - q).abs() < 1e-9, "{p} vs {q}");
    }
    let (code, without, err) = run(&common);
    assert_eq!(code, 0, "{err}");
    // (Keys and parameter names; the table's path may hold the word.)
    assert!(!without.contains("\"tint"), "{without}");
    // The tint changes the fit (the flag is honoured).
    let plain: serde_json::Value = serde_json::from_str(&without).unwrap();
    assert_ne!(fit["fit"]["chi2"], plain["fit"]["chi2"]);
    assert_eq!(
        fit["fit"]["parameters"].as_u64().unwrap(),
        plain["fit"]["parameters"].as_u64().unwrap() + 3
    );
}

/// Bad tints: exit 2 naming the flag or the key and what was expected.
#[test]
fn bad_tints_are_named() {
    let m = gold();
    let m = s(&m);
    // Without --paint.
    let (code, _, err) = run(&["fit", "--measured", m, "--fit-tint"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--fit-tint applies to --paint"), "{err}");
    // With no flakes to tint.
    let (code, _, err) = run(&[
        "fit",
        "--paint",
        "--measured",
        m,
        "--fit-tint",
        "--coverage",
        "0",
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--fit-tint with --coverage 0"), "{err}");
    // In a parameter file.
    let dir = scratch("paint_tint", "badfile");
    for (tint, want) in [
        (r#", "tint": -0.1"#, "channels[1].tint"),
        (r#", "tint": "blue""#, "tint"),
    ] {
        let file = dir.join("p.json");
        std::fs::write(&file, params(["", tint, ""])).unwrap();
        let (code, _, err) = run(&["model", "--params", s(&file), "--theta-i", "30"]);
        assert_eq!(code, 2, "{tint}: {err}");
        assert!(err.contains(want), "{tint}: {err}");
        assert!(err.contains("p.json"), "{tint}: {err}");
    }
}
