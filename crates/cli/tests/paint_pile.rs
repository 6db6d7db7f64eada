//! Piles of transmitting flakes in a paint (`fit --paint --flake-layers N`,
//! `--fit-flake-layers`, `flakes.layers` in a parameter file), end to end, and their bad
//! input (physics.md §12.8).

mod common;

use common::{run_text as run, s, scratch};
use std::f64::consts::PI;

/// A paint file: rough coat of index 1.5, Trowbridge–Reitz flakes (α 0.1), coverage
/// 0.6, flakes of `metal` (JSON) and `extra` keys in `flakes`, three channels with
/// flake scale 1 and no base.
fn params(metal: &str, extra: &str) -> String {
    format!(
        r#"{{
  "format": "flakescatter paint parameters",
  "version": 1,
  "coat": {{ "n": 1.5, "roughness": 0.03, "haze": 0, "haze_roughness": 0 }},
  "orientation": {{ "family": "trowbridge-reitz", "alpha": 0.1 }},
  "flakes": {{ "metal": {metal}, "coverage": 0.6{extra} }},
  "channels": [
    {{ "name": "r", "wavelength_nm": 612, "flake_scale": 1, "base_albedo": 0 }},
    {{ "name": "g", "wavelength_nm": 547, "flake_scale": 1, "base_albedo": 0 }},
    {{ "name": "b", "wavelength_nm": 464, "flake_scale": 1, "base_albedo": 0 }}
  ]
}}"#
    )
}

/// Airy's single-layer reflectance at normal incidence: a film of index `n1`, `d` nm, in
/// a medium of index `n0` on both sides, vacuum wavelength `wl` nm;
/// `r = r01 (1 − e^{2iδ}) / (1 − r01² e^{2iδ})` with `δ = 2π n1 d/λ`.
fn airy(n0: f64, n1: f64, d: f64, wl: f64) -> f64 {
    let r01 = (n0 - n1) / (n0 + n1);
    let phase = 4.0 * PI * n1 * d / wl;
    let (c, sn) = (phase.cos(), phase.sin());
    let (nr, ni) = (r01 * (1.0 - c), -r01 * sn);
    let (dr, di) = (1.0 - r01 * r01 * c, -r01 * r01 * sn);
    (nr * nr + ni * ni) / (dr * dr + di * di)
}

/// `model --params` at normal incidence and normal exit: the whole output and the
/// values of channels r, g, b.
fn normal_brdf(file: &std::path::Path) -> (String, Vec<f64>) {
    let detectors = file.with_extension("detectors.csv");
    std::fs::write(&detectors, "theta_r_deg,phi_r_deg\n0,0\n").unwrap();
    let (code, out, err) = run(&[
        "model",
        "--params",
        s(file),
        "--theta-i",
        "0",
        "--detectors",
        s(&detectors),
        "--aperture",
        "0",
    ]);
    assert_eq!(code, 0, "{err}");
    let header: Vec<&str> = out.lines().next().unwrap().split(',').collect();
    let row: Vec<&str> = out.lines().nth(1).unwrap().split(',').collect();
    let values = ["r", "g", "b"]
        .iter()
        .map(|c| {
            let j = header
                .iter()
                .position(|h| *h == format!("brdf_{c}_per_sr"))
                .unwrap();
            row[j].parse().unwrap()
        })
        .collect();
    (out, values)
}

/// `flakes.layers` in a parameter file: at normal incidence and exit the flake light of
/// a pile of 4 lossless films (index 2.6, 120 nm) over a perfect conductor's is the
/// lossless pile of Airy's reflectance, `4R/(1 + 3R)` (Stokes); the coat's lobe is
/// subtracted with a file whose flakes reflect nothing. `"layers": 1` is the file
/// without the key, byte for byte.
#[test]
fn layers_in_a_parameter_file_pile_the_films_reflectance() {
    let dir = scratch("paint_pile", "airy");
    let write = |name: &str, metal: &str, extra: &str| {
        let p = dir.join(name);
        std::fs::write(&p, params(metal, extra)).unwrap();
        p
    };
    let film = r#"{"stack": "2.6:120"}"#;
    let (_, pile) = normal_brdf(&write("pile.json", film, r#", "layers": 4"#));
    let (_, mirror) = normal_brdf(&write("mirror.json", r#""perfect-conductor""#, ""));
    let (_, none) = normal_brdf(&write("none.json", r#"{"n": 1.5, "k": 0}"#, ""));
    for (k, wl) in [612.0, 547.0, 464.0].into_iter().enumerate() {
        let ratio = (pile[k] - none[k]) / (mirror[k] - none[k]);
        let r = airy(1.5, 2.6, 120.0, wl);
        let want = 4.0 * r / (1.0 + 3.0 * r);
        assert!((ratio - want).abs() < 1e-9, "{wl} nm: {ratio} vs {want}");
    }
    let (one, _) = normal_brdf(&write("one.json", film, r#", "layers": 1"#));
    let (absent, _) = normal_brdf(&write("absent.json", film, ""));
    assert_eq!(one, absent);
}

/// A bad `flakes.layers`: exit 2, the file and the key named.
#[test]
fn bad_layers_in_a_parameter_file_are_named() {
    let dir = scratch("paint_pile", "badfile");
    for (metal, layers, want) in [
        (
            r#"{"stack": "TiO2:40"}"#,
            "0",
            "whole number from 1 to 1000",
        ),
        (
            r#"{"stack": "TiO2:40"}"#,
            "2.5",
            "whole number from 1 to 1000",
        ),
        (
            r#"{"stack": "TiO2:40"}"#,
            "-3",
            "whole number from 1 to 1000",
        ),
        (
            r#"{"stack": "TiO2:40"}"#,
            "1001",
            "whole number from 1 to 1000",
        ),
        (r#""aluminium""#, "2", "transmit nothing"),
        (
            r#"{"stack": "TiO2:40", "core": "aluminium"}"#,
            "3",
            "transmit nothing",
        ),
    ] {
        let p = dir.join("p.json");
        std::fs::write(&p, params(metal, &format!(r#", "layers": {layers}"#))).unwrap();
        let (code, _, err) = run(&["model", "--params", s(&p)]);
        assert_eq!(code, 2, "{metal} {layers}: {err}");
        assert!(
            err.contains(want) && err.contains("flakes.layers") && err.contains("p.json"),
            "{metal} {layers}: {err}"
        );
    }
}

fn pearl() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures/real/paints/pearl-paint.csv")
}

/// `fit --paint --flake-layers 4` on the pearl paint: the report and the parameter file
/// carry the layers, `compare --params` with that file gives the fit's residual groups
/// back (the pile is in the file), and `--flake-layers 1` is the fit without the flag,
/// byte for byte.
#[test]
fn a_fitted_pile_round_trips_and_one_layer_is_no_pile() {
    let dir = scratch("paint_pile", "roundtrip");
    let params = dir.join("p.json");
    let table = pearl();
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
        "--flake-stack",
        "TiO2:280",
        "--json",
    ];
    let mut a = common.to_vec();
    a.extend(["--flake-layers", "4", "--params-out", s(&params)]);
    let (code, out, err) = run(&a);
    assert_eq!(code, 0, "{err}");
    let fit: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(fit["fit"]["flake_layers"], 4);
    let file: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&params).unwrap()).unwrap();
    assert_eq!(file["flakes"]["layers"], 4);
    let (code, out, err) = run(&[
        "compare",
        "--measured",
        s(&pearl()),
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
    // One layer is the fit without piles.
    let (_, without, _) = run(&common);
    let mut a = common.to_vec();
    a.extend(["--flake-layers", "1"]);
    let (code, with_one, err) = run(&a);
    assert_eq!(code, 0, "{err}");
    assert_eq!(with_one, without);
    assert!(!without.contains("flake_layers"));
    // The pile changes the fit (the flag is honoured).
    assert_ne!(
        fit["fit"]["chi2"],
        serde_json::from_str::<serde_json::Value>(&without).unwrap()["fit"]["chi2"]
    );
}

/// Bad pile flags: exit 2, the flag and what was expected named.
#[test]
fn bad_pile_flags_are_named() {
    let m = pearl();
    let m = s(&m);
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec!["--flake-stack", "TiO2:100", "--flake-layers", "0"],
            "--flake-layers",
        ),
        (
            vec!["--flake-stack", "TiO2:100", "--flake-layers", "2.5"],
            "--flake-layers",
        ),
        (
            vec!["--flake-stack", "TiO2:100", "--flake-layers", "1001"],
            "--flake-layers",
        ),
        (
            vec!["--flake-stack", "TiO2:100", "--flake-layers", "-2"],
            "--flake-layers",
        ),
        (
            vec!["--flake-layers", "2"],
            "--flake-layers 2: needs free interference flakes",
        ),
        (
            vec![
                "--flake-stack",
                "TiO2:100",
                "--flake-core",
                "aluminium",
                "--flake-layers",
                "2",
            ],
            "--flake-layers 2: needs free interference flakes",
        ),
        (
            vec!["--fit-flake-layers"],
            "--fit-flake-layers: needs free interference flakes",
        ),
        (
            vec![
                "--flake-stack",
                "TiO2:100",
                "--fit-flake-layers",
                "--flake-layers",
                "3",
            ],
            "--flake-layers",
        ),
    ];
    for (extra, want) in cases {
        let mut a = vec!["fit", "--paint", "--measured", m];
        a.extend(extra.iter().copied());
        let (code, _, err) = run(&a);
        assert_eq!(code, 2, "{extra:?}: {err}");
        assert!(err.contains(want), "{extra:?}: {err}");
    }
    // Without --paint the paint's pile flags are refused.
    for flag in [&["--flake-layers", "2"][..], &["--fit-flake-layers"][..]] {
        let mut a = vec!["fit", "--measured", m];
        a.extend(flag.iter().copied());
        let (code, _, err) = run(&a);
        assert_eq!(code, 2, "{err}");
        assert!(err.contains("applies to --paint"), "{err}");
    }
}
