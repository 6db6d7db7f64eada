//! Interference flakes in a paint (`fit --paint --flake-stack … --fit-thickness`, a
//! parameter file with a stack in `model --params`, colour channels with a band,
//! `--channel-band`), end to end, and their bad input.

mod common;

use common::{run_text as run, s, scratch};
use std::f64::consts::PI;

/// A paint file: flat coat of index 1.5, Trowbridge–Reitz flakes (α 0.1), coverage 0.6,
/// flakes of `metal` (JSON), three channels with flake scale 1 and no base.
fn params(metal: &str) -> String {
    format!(
        r#"{{
  "format": "flakescatter paint parameters",
  "version": 1,
  "coat": {{ "n": 1.5, "roughness": 0.03, "haze": 0, "haze_roughness": 0 }},
  "orientation": {{ "family": "trowbridge-reitz", "alpha": 0.1 }},
  "flakes": {{ "metal": {metal}, "coverage": 0.6 }},
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
    // Numerator r01 (1 − e), denominator 1 − r01² e, e = c + i sn.
    let (nr, ni) = (r01 * (1.0 - c), -r01 * sn);
    let (dr, di) = (1.0 - r01 * r01 * c, -r01 * r01 * sn);
    (nr * nr + ni * ni) / (dr * dr + di * di)
}

/// The first data row of `model --params` at normal incidence and normal exit, per
/// channel r, g, b.
fn normal_brdf(file: &std::path::Path) -> Vec<f64> {
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
    ["r", "g", "b"]
        .iter()
        .map(|c| {
            let j = header
                .iter()
                .position(|h| *h == format!("brdf_{c}_per_sr"))
                .unwrap();
            row[j].parse().unwrap()
        })
        .collect()
}

/// A parameter file with a stack is read: at normal incidence and exit (level flakes
/// met head-on, the coat's lobe the same in both), the flake light of a 2.6-index film
/// 120 nm thick over that of a perfect conductor is Airy's reflectance at each channel's
/// wavelength. The coat's own rough reflection is the same in both files and is
/// subtracted with a third file whose flakes reflect nothing (index 1.5: no contrast).
#[test]
fn a_stack_in_a_parameter_file_is_the_films_reflectance() {
    let dir = scratch("paint_stack", "airy");
    let write = |name: &str, metal: &str| {
        let p = dir.join(name);
        std::fs::write(&p, params(metal)).unwrap();
        p
    };
    let film = normal_brdf(&write("film.json", r#"{"stack": "2.6:120"}"#));
    let mirror = normal_brdf(&write("mirror.json", r#""perfect-conductor""#));
    let none = normal_brdf(&write("none.json", r#"{"n": 1.5, "k": 0}"#));
    for (k, wl) in [612.0, 547.0, 464.0].into_iter().enumerate() {
        let ratio = (film[k] - none[k]) / (mirror[k] - none[k]);
        let want = airy(1.5, 2.6, 120.0, wl);
        assert!(
            (ratio - want).abs() < 1e-9,
            "{wl} nm: {ratio} vs Airy {want}"
        );
    }
}

/// A table made from a pearl paint (TiO2 100 nm / mica 300 nm / TiO2 100 nm) by
/// `model --params`, fitted with the stack's TiO2 thickness free from a start of 230 nm
/// (another interference order): the thickness comes back, the scan is reported, and the
/// fitted parameter file carries the stack with it.
#[test]
fn fit_thickness_gives_the_stack_back() {
    let dir = scratch("paint_stack", "fit");
    let truth = dir.join("truth.json");
    std::fs::write(
        &truth,
        params(r#"{"stack": "TiO2:100/mica:300/TiO2:100"}"#)
            .replace(r#""base_albedo": 0 }"#, r#""base_albedo": 0.1 }"#),
    )
    .unwrap();
    let mut det = String::from("theta_r_deg,phi_r_deg\n");
    for k in 0..=20 {
        let tr = 4 * k;
        det.push_str(&format!("{tr},0\n"));
        if tr > 0 {
            det.push_str(&format!("{tr},180\n"));
        }
    }
    for phi in [30, 60] {
        for k in 1..=8 {
            det.push_str(&format!("{},{phi}\n", 10 * k));
        }
    }
    let detectors = dir.join("detectors.csv");
    std::fs::write(&detectors, det).unwrap();
    let table = dir.join("table.csv");
    let (code, _, err) = run(&[
        "model",
        "--params",
        s(&truth),
        "--theta-i",
        "20,45,65",
        "--detectors",
        s(&detectors),
        "--aperture",
        "0",
        "--out",
        s(&table),
    ]);
    assert_eq!(code, 0, "{err}");
    let fitted = dir.join("fitted.json");
    let (code, out, err) = run(&[
        "fit",
        "--paint",
        "--measured",
        s(&table),
        "--flake-stack",
        "TiO2:230/mica:300/TiO2:230",
        "--fit-thickness",
        "1,3",
        "--thickness-range",
        "40:300",
        "--family",
        "trowbridge-reitz",
        "--no-haze",
        "--params-out",
        s(&fitted),
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let d = v["fit"]["physical"]
        .as_array()
        .unwrap()
        .iter()
        .find(|e| e["name"] == "thickness (nm)")
        .unwrap()["value"]
        .as_f64()
        .unwrap();
    assert!((d - 100.0).abs() < 1e-2, "thickness {d}");
    let scan = &v["fit"]["thickness"]["scan"];
    assert_eq!(scan["thickness_nm"].as_array().unwrap().len(), 53);
    assert_eq!(v["fit"]["thickness"]["layers"], serde_json::json!([1, 3]));
    let file: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&fitted).unwrap()).unwrap();
    let stack = file["flakes"]["metal"]["stack"].as_str().unwrap();
    let layers: Vec<&str> = stack.split('/').collect();
    assert_eq!(layers.len(), 3, "{stack}");
    assert_eq!(layers[1], "mica:300", "{stack}");
    let t: f64 = layers[0].strip_prefix("TiO2:").unwrap().parse().unwrap();
    assert!((t - 100.0).abs() < 1e-2, "{stack}");
    assert_eq!(layers[0], layers[2]);
}

/// Bad thickness flags: exit 2, the flag and what was expected named, nothing fitted.
#[test]
fn bad_thickness_flags_are_named() {
    let dir = scratch("paint_stack", "bad");
    let table = dir.join("t.csv");
    let mut t = String::from("theta_i_deg,theta_r_deg,phi_r_deg,brdf_g_per_sr\n");
    for k in 0..60 {
        t.push_str(&format!("45,{},0,{}\n", k, 1.0 + f64::from(k)));
    }
    std::fs::write(&table, t).unwrap();
    let m = s(&table);
    let stack = "TiO2:100/mica:300/TiO2:100";
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["--fit-thickness", "1"], "--flake-stack"),
        (
            vec!["--flake-stack", stack, "--fit-thickness", "0"],
            "--fit-thickness 0",
        ),
        (
            vec!["--flake-stack", stack, "--fit-thickness", "1,x"],
            "--fit-thickness 1,x",
        ),
        (
            vec!["--flake-stack", stack, "--fit-thickness", "4"],
            "layer 4",
        ),
        (
            vec![
                "--flake-stack",
                stack,
                "--fit-thickness",
                "1",
                "--thickness-range",
                "300:40",
            ],
            "--thickness-range 300:40",
        ),
        (
            vec![
                "--flake-stack",
                stack,
                "--fit-thickness",
                "1",
                "--thickness-range",
                "0:40",
            ],
            "--thickness-range 0:40",
        ),
        (vec!["--flake-stack", "TiO2:-3"], "--flake-stack"),
        (
            vec!["--flake-stack", stack, "--wavelengths", "400:700:10"],
            "--flake-stack and --flake-core do",
        ),
    ];
    for (extra, want) in cases {
        let mut a = vec!["fit", "--paint", "--measured", m];
        a.extend(extra.iter().copied());
        let (code, _, err) = run(&a);
        assert_eq!(code, 2, "{extra:?}: {err}");
        assert!(err.contains(want), "{extra:?}: {err}");
    }
    // Without --paint the paint's thickness flag is refused.
    let (code, _, err) = run(&["fit", "--measured", m, "--fit-thickness", "1"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--fit-thickness applies to --paint"), "{err}");
}

/// A parameter file whose stack or core does not parse names the key and the layer.
#[test]
fn a_bad_stack_in_a_parameter_file_is_named() {
    let dir = scratch("paint_stack", "badfile");
    for (metal, want) in [
        (r#"{"stack": "TiO2:-3"}"#, "flakes.metal.stack: layer 1"),
        (
            r#"{"stack": "kryptonite:40"}"#,
            "flakes.metal.stack: layer 1",
        ),
        (
            r#"{"stack": "TiO2:40", "core": "unobtainium"}"#,
            "flakes.metal.core",
        ),
    ] {
        let p = dir.join("p.json");
        std::fs::write(&p, params(metal)).unwrap();
        let (code, _, err) = run(&["model", "--params", s(&p)]);
        assert_eq!(code, 2, "{metal}: {err}");
        assert!(
            err.contains(want) && err.contains("p.json"),
            "{metal}: {err}"
        );
    }
}

// Colour channels with a band (`fit --paint --flake-stack … --channel-band NM`, a
// parameter file's `flakes.metal.band_fwhm_nm`; physics.md §12.7 "Channels with a band").

/// The band's mean of Airy: Gaussian weights of full width `fwhm` at half maximum about
/// `centre`, every 5 nm out to one width each side, within 380–780 nm, normalised.
fn band_airy(centre: f64, fwhm: f64) -> f64 {
    let sigma = fwhm / (8.0 * 2f64.ln()).sqrt();
    let k = (fwhm / 5.0).floor() as i32;
    let (mut sum, mut total) = (0.0, 0.0);
    for j in -k..=k {
        let wl = centre + 5.0 * f64::from(j);
        if (380.0..=780.0).contains(&wl) {
            let w = (-0.5 * ((wl - centre) / sigma).powi(2)).exp();
            sum += w * airy(1.5, 2.6, 300.0, wl);
            total += w;
        }
    }
    sum / total
}

/// At normal incidence and exit the flake light of a banded 300 nm film over a perfect
/// conductor's is the band's mean of Airy's reflectance (the coat's own lobe subtracted
/// with flakes that reflect nothing).
#[test]
fn a_band_in_a_parameter_file_is_the_bands_mean_of_airy() {
    let dir = scratch("paint_stack_band", "airy");
    let write = |name: &str, metal: &str| {
        let p = dir.join(name);
        std::fs::write(&p, params(metal)).unwrap();
        p
    };
    let film = normal_brdf(&write(
        "film.json",
        r#"{"stack": "2.6:300", "band_fwhm_nm": 60}"#,
    ));
    let mirror = normal_brdf(&write("mirror.json", r#""perfect-conductor""#));
    let none = normal_brdf(&write("none.json", r#"{"n": 1.5, "k": 0}"#));
    for (k, wl) in [612.0, 547.0, 464.0].into_iter().enumerate() {
        let ratio = (film[k] - none[k]) / (mirror[k] - none[k]);
        let want = band_airy(wl, 60.0);
        assert!((ratio - want).abs() < 1e-9, "{wl} nm: {ratio} vs {want}");
    }
}

/// A table made by `model --params` from a banded paint is fitted exactly with the same
/// band (χ² at rounding level) and not without it; the fitted parameter file keeps the
/// band.
#[test]
fn a_banded_table_is_fitted_with_its_band() {
    let dir = scratch("paint_stack_band", "fit");
    let truth = dir.join("truth.json");
    std::fs::write(
        &truth,
        params(r#"{"stack": "2.6:300", "band_fwhm_nm": 80}"#)
            .replace(r#""base_albedo": 0 }"#, r#""base_albedo": 0.1 }"#),
    )
    .unwrap();
    let mut det = String::from("theta_r_deg,phi_r_deg\n");
    for k in 0..=16 {
        det.push_str(&format!("{},0\n", 5 * k));
        if k > 0 {
            det.push_str(&format!("{},180\n", 5 * k));
        }
    }
    let dets = dir.join("detectors.csv");
    std::fs::write(&dets, det).unwrap();
    let table = dir.join("table.csv");
    let (code, _, err) = run(&[
        "model",
        "--params",
        s(&truth),
        "--theta-i",
        "20,50",
        "--detectors",
        s(&dets),
        "--aperture",
        "0",
        "--out",
        s(&table),
    ]);
    assert_eq!(code, 0, "{err}");
    let fit = |band: &[&str], out: &std::path::Path| {
        let mut a = vec![
            "fit",
            "--paint",
            "--measured",
            s(&table),
            "--family",
            "trowbridge-reitz",
            "--coverage",
            "0.6",
            "--flake-stack",
            "2.6:300",
            "--json",
            "--params-out",
            s(out),
        ];
        a.extend(band);
        let (code, text, err) = run(&a);
        assert_eq!(code, 0, "{err}");
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        v["fit"]["chi2"].as_f64().unwrap()
    };
    let banded = dir.join("banded.json");
    let with = fit(&["--channel-band", "80"], &banded);
    let without = fit(&[], &dir.join("plain.json"));
    assert!(with < 1e-12, "χ² with the band {with}");
    assert!(without > 1e3 * with.max(1e-15), "χ² without it {without}");
    let p: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&banded).unwrap()).unwrap();
    assert_eq!(p["flakes"]["metal"]["band_fwhm_nm"], 80.0);
}

#[test]
fn bad_bands_are_named() {
    let dir = scratch("paint_stack_band", "bad");
    let table = common::fixture("real/paints/pearl-paint.csv");
    let base = ["fit", "--measured", s(&table)];
    for (extra, needle) in [
        (vec!["--channel-band", "40"], "--channel-band"),
        (
            vec!["--paint", "--channel-band", "40"],
            "interference flakes",
        ),
        (
            vec![
                "--paint",
                "--flake-stack",
                "TiO2:100",
                "--channel-band",
                "0",
            ],
            "--channel-band 0",
        ),
        (
            vec![
                "--paint",
                "--flake-stack",
                "TiO2:100",
                "--channel-band",
                "500",
            ],
            "--channel-band 500",
        ),
        (
            vec![
                "--paint",
                "--flake-stack",
                "TiO2:100",
                "--channel-band",
                "wide",
            ],
            "--channel-band",
        ),
    ] {
        let mut a = base.to_vec();
        a.extend(&extra);
        let (code, _, err) = run(&a);
        assert_eq!(code, 2, "{extra:?}: {err}");
        assert!(err.contains(needle), "{extra:?}: {err}");
    }
    let p = dir.join("bad.json");
    std::fs::write(&p, params(r#"{"stack": "2.6:300", "band_fwhm_nm": -3}"#)).unwrap();
    let (code, _, err) = run(&["model", "--params", s(&p)]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("flakes.metal.band_fwhm_nm"), "{err}");
}
