//! Colour channels with a band (`fit --paint --flake-stack … --channel-band NM`, a
//! parameter file's `flakes.metal.band_fwhm_nm`; physics.md §12.7 "Channels with a
//! band"), end to end, and their bad input.

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

/// Airy's single-layer reflectance at normal incidence (a film of index `n1`, `d` nm, in
/// `n0` on both sides, vacuum wavelength `wl` nm): `r = r01 (1 − e)/(1 − r01² e)`,
/// `e = exp(4πi n1 d/λ)`.
fn airy(n0: f64, n1: f64, d: f64, wl: f64) -> f64 {
    let r01 = (n0 - n1) / (n0 + n1);
    let phase = 4.0 * PI * n1 * d / wl;
    let (c, sn) = (phase.cos(), phase.sin());
    let (nr, ni) = (r01 * (1.0 - c), -r01 * sn);
    let (dr, di) = (1.0 - r01 * r01 * c, -r01 * r01 * sn);
    (nr * nr + ni * ni) / (dr * dr + di * di)
}

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

/// `model --params` at normal incidence and exit, per channel r, g, b.
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

/// At normal incidence and exit the flake light of a banded 300 nm film over a perfect
/// conductor's is the band's mean of Airy's reflectance (the coat's own lobe subtracted
/// with flakes that reflect nothing).
#[test]
fn a_band_in_a_parameter_file_is_the_bands_mean_of_airy() {
    let dir = scratch("paint_band", "airy");
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
    let dir = scratch("paint_band", "fit");
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
    let dir = scratch("paint_band", "bad");
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
