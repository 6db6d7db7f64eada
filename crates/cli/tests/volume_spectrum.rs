//! `flakescatter volume --binder-absorption ALPHA|FILE` and `--wavelengths LIST`
//! (issue 47): a tinted binder along every path in the film, and one run giving the
//! spectrum.
//!
//! * `--binder-absorption 0` writes the same CSV bytes as no flag.
//! * A film without flakes (`--volume-fraction 0`) over a black substrate: the beam
//!   enters with `1 − R_av(θi)` and crosses the film once, `d / cos θt`, so the binder
//!   takes `(1 − R_av)(1 − exp(−α d / cos θt))` and the substrate the rest (both
//!   polarisation channels see the same path); every ray is the same, so this holds to
//!   rounding.
//! * `--wavelengths` with a stack: a `wavelength_nm` column first; each wavelength's rows
//!   are, byte for byte, those of `--wavelength` at that wavelength (the same seed); the
//!   energy balance of every wavelength and incidence sums to 1 within 1e-12; a stack
//!   with no wavelength flag runs 380:780:10, as `model` does.
//! * A table of α versus wavelength in a file is read at each wavelength.
//! * Bad flags exit 2 naming the flag.

mod common;

use std::fs;

use common::{run_text, s, scratch};

const BASE: [&str; 15] = [
    "volume",
    "--theta-i",
    "0,40",
    "--theta-s",
    "-40:40:20",
    "--aperture",
    "2",
    "--hwhm",
    "8",
    "--tile-um",
    "200",
    "--rays",
    "6400",
    "--seed",
    "3",
];

fn ok(extra: &[&str]) -> String {
    let mut args: Vec<&str> = BASE.to_vec();
    args.extend_from_slice(extra);
    let (code, out, err) = run_text(&args);
    assert_eq!(code, 0, "{extra:?}: {err}");
    out
}

fn json(extra: &[&str]) -> serde_json::Value {
    let mut a = extra.to_vec();
    a.push("--json");
    serde_json::from_str(&ok(&a)).unwrap()
}

#[test]
fn a_zero_coefficient_writes_the_same_bytes_as_no_flag() {
    assert_eq!(ok(&[]), ok(&["--binder-absorption", "0"]));
    let stack = ["--flake-stack", "TiO2:53", "--wavelength", "550"];
    let mut zero = stack.to_vec();
    zero.extend(["--binder-absorption", "0"]);
    assert_eq!(ok(&stack), ok(&zero));
}

#[test]
fn a_film_without_flakes_loses_beer_lambert_on_the_way_down() {
    let (alpha, d, n) = (0.02f64, 30.0f64, 1.5f64);
    let v = json(&[
        "--volume-fraction",
        "0",
        "--film-um",
        "30",
        "--binder-absorption",
        "0.02",
    ]);
    assert_eq!(v["inputs"]["binder_absorption"]["constant_per_um"], 0.02);
    for (e, ti) in v["energy"].as_array().unwrap().iter().zip([0.0f64, 40.0]) {
        let f = |k: &str| e[k].as_f64().unwrap();
        let (si, ci) = ti.to_radians().sin_cos();
        let ct = (1.0 - (si / n).powi(2)).sqrt();
        let rs = ((ci - n * ct) / (ci + n * ct)).powi(2);
        let rp = ((n * ci - ct) / (n * ci + ct)).powi(2);
        let a = 1.0 - 0.5 * (rs + rp);
        let keep = (-alpha * d / ct).exp();
        eprintln!("θi {ti}: {e}");
        assert!((f("absorbed_binder") - a * (1.0 - keep)).abs() < 1e-12);
        assert!((f("absorbed_substrate") - a * keep).abs() < 1e-12);
        assert!((f("total") - 1.0).abs() < 1e-12);
    }
}

/// The CSV's lines without the header, split at the first comma.
fn spectral_rows(csv: &str) -> Vec<(f64, String)> {
    csv.lines()
        .skip(1)
        .map(|l| {
            let (w, rest) = l.split_once(',').unwrap();
            (w.parse().unwrap(), rest.to_owned())
        })
        .collect()
}

#[test]
fn each_wavelength_of_a_spectrum_is_the_run_at_that_wavelength() {
    let stack = ["--flake-stack", "TiO2:53/SiO2:100", "--layers", "2"];
    let mut many = stack.to_vec();
    many.extend([
        "--wavelengths",
        "450:650:100",
        "--binder-absorption",
        "0.01",
    ]);
    let csv = ok(&many);
    let header = csv.lines().next().unwrap();
    assert!(header.starts_with("wavelength_nm,theta_i_deg,"), "{header}");
    let rows = spectral_rows(&csv);
    assert_eq!(rows.len(), 3 * 2 * 5);
    for w in ["450", "550", "650"] {
        let mut one = stack.to_vec();
        one.extend(["--wavelength", w, "--binder-absorption", "0.01"]);
        let single = ok(&one);
        let want: Vec<&str> = single.lines().skip(1).collect();
        let got: Vec<&str> = rows
            .iter()
            .filter(|(x, _)| *x == w.parse::<f64>().unwrap())
            .map(|(_, r)| r.as_str())
            .collect();
        assert_eq!(got, want, "{w} nm");
        assert_eq!(
            single.lines().next().unwrap(),
            &header["wavelength_nm,".len()..]
        );
    }
    many.push("--json");
    let v: serde_json::Value = serde_json::from_str(&ok(&many)).unwrap();
    assert_eq!(
        v["wavelengths_nm"],
        serde_json::json!([450.0, 550.0, 650.0])
    );
    assert_eq!(v["inputs"]["wavelengths_nm"], "450:650:100");
    let energy = v["energy"].as_array().unwrap();
    assert_eq!(energy.len(), 6);
    for e in energy {
        let f = |k: &str| e[k].as_f64().unwrap();
        let sum = f("coat_reflected")
            + f("escaped_single")
            + f("escaped_multiple")
            + f("absorbed_substrate")
            + f("absorbed_flakes")
            + f("absorbed_binder")
            + f("absorbed_other");
        assert!((sum - 1.0).abs() < 1e-12, "{e}");
        assert!(f("absorbed_binder") > 0.0 && e["wavelength_nm"].is_number());
    }
    assert_eq!(v["rows"].as_array().unwrap().len(), 30);
}

#[test]
fn a_stack_without_a_wavelength_runs_the_visible_at_10_nm() {
    let (code, csv, err) = run_text(&[
        "volume",
        "--flake-stack",
        "TiO2:53",
        "--layers",
        "1",
        "--rays",
        "640",
        "--tile-um",
        "200",
        "--theta-i",
        "30",
        "--theta-s",
        "-30",
    ]);
    assert_eq!(code, 0, "{err}");
    let w: Vec<f64> = spectral_rows(&csv).iter().map(|(w, _)| *w).collect();
    let want: Vec<f64> = (0..=40).map(|k| 380.0 + 10.0 * f64::from(k)).collect();
    assert_eq!(w, want);
}

#[test]
fn an_absorption_table_is_read_at_each_wavelength() {
    let dir = scratch("volume-spectrum", "table");
    let table = dir.join("alpha.csv");
    fs::write(&table, "wavelength_nm,alpha_per_um\n400,0.01\n700,0.04\n").unwrap();
    let v = json(&[
        "--volume-fraction",
        "0",
        "--film-um",
        "30",
        "--binder-absorption",
        s(&table),
        "--wavelengths",
        "400,550,700",
        "--layers",
        "1",
    ]);
    assert_eq!(
        v["binder_alpha_per_um"],
        serde_json::json!([0.01, 0.025, 0.04])
    );
    // Normal incidence: (1 − ρ)(1 − e^{−α d}).
    let a = 1.0 - 0.04;
    for e in v["energy"].as_array().unwrap() {
        if e["theta_i_deg"].as_f64().unwrap() != 0.0 {
            continue;
        }
        let w = e["wavelength_nm"].as_f64().unwrap();
        let alpha = 0.01 + 0.03 * (w - 400.0) / 300.0;
        let want = a * (1.0 - (-alpha * 30.0f64).exp());
        let got = e["absorbed_binder"].as_f64().unwrap();
        assert!((got - want).abs() < 1e-12, "{w} nm: {got} vs {want}");
    }
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_wavelength_and_absorption_flags_exit_2_naming_the_flag() {
    let dir = scratch("volume-spectrum", "bad");
    let table = dir.join("alpha.csv");
    fs::write(&table, "wavelength_nm,alpha_per_um\n400,0.01\n700,0.04\n").unwrap();
    let t = s(&table);
    let plot = dir.join("p.svg");
    for (extra, needle) in [
        (vec!["--binder-absorption", t], "--binder-absorption"),
        (
            vec!["--binder-absorption", "-0.1"],
            "--binder-absorption -0.1",
        ),
        (vec!["--binder-absorption", "nan"], "--binder-absorption"),
        (
            vec!["--binder-absorption", "missing.csv", "--wavelength", "500"],
            "--binder-absorption",
        ),
        (
            vec!["--binder-absorption", t, "--wavelength", "800"],
            "--binder-absorption",
        ),
        (
            vec!["--binder-absorption", t, "--wavelengths", "500,750"],
            "--binder-absorption",
        ),
        (vec!["--wavelengths", "500,600"], "--flake-stack"),
        (
            vec!["--flake-stack", "TiO2:53", "--wavelengths", "600,500"],
            "--wavelengths",
        ),
        (
            vec!["--flake-stack", "TiO2:53", "--wavelengths", "0,500"],
            "--wavelengths",
        ),
        (
            vec!["--flake-stack", "TiO2:53", "--wavelengths", "x"],
            "--wavelengths",
        ),
        (
            vec!["--flake-stack", "TiO2:53", "--wavelengths", "380:780:0.1"],
            "more than the limit of 1000",
        ),
        (
            vec![
                "--flake-stack",
                "TiO2:53",
                "--wavelengths",
                "500",
                "--wavelength",
                "500",
            ],
            "--wavelength",
        ),
        (
            vec!["--flake-stack", "anatase:50", "--wavelengths", "500,900"],
            "--flake-stack",
        ),
        (
            vec![
                "--flake-stack",
                "TiO2:53",
                "--wavelengths",
                "500,600",
                "--plot",
                s(&plot),
            ],
            "--plot",
        ),
    ] {
        let mut args: Vec<&str> = BASE.to_vec();
        args.extend_from_slice(&extra);
        let (code, out, err) = run_text(&args);
        assert_eq!(code, 2, "{extra:?}: {err}");
        assert!(out.is_empty(), "{extra:?}: {out}");
        assert!(err.contains(needle), "{extra:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    assert!(!plot.exists());
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn too_many_spectral_rows_are_refused_before_any_work() {
    // 2 incidences × 178 001 detectors × 31 wavelengths = 1.1e7 rows > 10⁷.
    let (code, out, err) = run_text(&[
        "volume",
        "--theta-i",
        "0,40",
        "--theta-s",
        "-89:89:0.001",
        "--flake-stack",
        "TiO2:53",
        "--wavelengths",
        "400:700:10",
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(out.is_empty());
    assert!(
        err.contains("--wavelengths with --theta-i and --theta-s"),
        "{err}"
    );
}
