//! `model`/`topo --polarization mueller`, `--incident`, `--analyzer` end to end: the CLI
//! writes the facade's numbers (bit for bit: the CSV keeps the shortest round-trip
//! form), the readings obey `a · M · s` computed here from the written elements, the
//! scalar `--transmission s|p` curves are `m00 ± m01` of the Mueller columns, in-plane
//! cones have the mirror-symmetric block form, and bad flags exit 2 naming the flag.

mod common;

use std::path::{Path, PathBuf};

use common::{run_text as run, scratch};
use flakescatter::io::{ReadOptions, read_intensity, read_map};
use flakescatter::optics::flake::FlakeReflectance;
use flakescatter::optics::mueller::{Analyzer, Stokes};
use flakescatter::stats::{GaussianWidth, Orientation};
use flakescatter::{
    Coating, DetectorSet, Instrument, OrientationSource, Polarimetry, Settings, TopoSettings,
    distribution_mueller, topographic_mueller,
};

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures")
}

/// A CSV as header and rows of numbers (empty cells are NaN).
fn table(text: &str) -> (Vec<String>, Vec<Vec<f64>>) {
    let mut lines = text.lines();
    let header = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_owned)
        .collect();
    let rows = lines
        .map(|l| {
            l.split(',')
                .map(|v| {
                    if v.is_empty() {
                        f64::NAN
                    } else {
                        v.parse().unwrap()
                    }
                })
                .collect()
        })
        .collect();
    (header, rows)
}

fn col(header: &[String], name: &str) -> usize {
    header
        .iter()
        .position(|h| h == name)
        .unwrap_or_else(|| panic!("no column {name} in {header:?}"))
}

/// Equal as written: both NaN (empty cell) or the same number.
fn same(a: f64, b: f64) -> bool {
    (a.is_nan() && b.is_nan()) || a == b
}

/// Out-of-plane detectors (degrees) and their file.
const DETECTORS: [(f64, f64); 6] = [
    (30.0, 0.0),
    (45.0, 20.0),
    (55.0, 160.0),
    (10.0, 90.0),
    (70.0, 5.0),
    (35.0, -40.0),
];

fn detector_file(dir: &Path) -> PathBuf {
    let p = dir.join("det.csv");
    let mut text = String::from("theta_r_deg,phi_r_deg\n");
    for (t, p) in DETECTORS {
        text.push_str(&format!("{t},{p}\n"));
    }
    std::fs::write(&p, text).unwrap();
    p
}

fn instrument(theta_i: &[f64], aperture_deg: f64) -> Instrument {
    Instrument::new(
        theta_i.iter().map(|t| t.to_radians()).collect(),
        DetectorSet::OutOfPlane(
            DETECTORS
                .iter()
                .map(|&(t, p)| (t.to_radians(), p.to_radians()))
                .collect(),
        ),
        aperture_deg.to_radians(),
    )
    .unwrap()
}

#[test]
fn model_writes_the_facades_mueller_curves_and_reads_them_as_a_m_s() {
    let dir = scratch("pol", "model");
    let det = detector_file(&dir);
    let (code, out, err) = run(&[
        "model",
        "--theta-i",
        "30,70",
        "--detectors",
        det.to_str().unwrap(),
        "--aperture",
        "2",
        "--hwhm",
        "8",
        "--flake-index",
        "0.96,6.69",
        "--clearcoat",
        "--polarization",
        "mueller",
        "--incident",
        "2,0,1.2,1.6",
        "--analyzer",
        "s",
    ]);
    assert_eq!(code, 0, "{err}");
    let (h, rows) = table(&out);
    let m = col(&h, "m00");
    assert_eq!(
        &h[m..m + 16].join(","),
        "m00,m01,m02,m03,m10,m11,m12,m13,m20,m21,m22,m23,m30,m31,m32,m33"
    );
    assert_eq!(h.last().unwrap(), "dop_unpolarized");
    assert_eq!(rows.len(), 2 * DETECTORS.len());

    let coating = Coating {
        n: 1.5,
        flake: FlakeReflectance::complex(0.96, 6.69).unwrap(),
    };
    let settings = Settings {
        clearcoat: true,
        ..Settings::default()
    };
    let source = OrientationSource::Distribution(
        Orientation::gaussian(GaussianWidth::Hwhm(8f64.to_radians())).unwrap(),
    );
    let pol = Polarimetry {
        incident: Stokes::new([2.0, 0.0, 1.2, 1.6]).unwrap(),
        analyzer: Analyzer::polarizer(Stokes::S).unwrap(),
    };
    let mu = distribution_mueller(
        &coating,
        &instrument(&[30.0, 70.0], 2.0),
        &settings,
        &source,
        &pol,
    )
    .unwrap();
    let (b, r, rel, dop) = (
        col(&h, "brdf_per_sr"),
        col(&h, "reflectance"),
        col(&h, "relative"),
        col(&h, "dop_unpolarized"),
    );
    for (row, f) in rows.iter().zip(&mu.rows) {
        for e in 0..16 {
            assert!(
                same(row[m + e], f.brdf[e]),
                "m{}{}: {} vs {}",
                e / 4,
                e % 4,
                row[m + e],
                f.brdf[e]
            );
        }
        assert!(same(row[b], f.detected_brdf) && same(row[r], f.detected_reflectance.unwrap()));
        assert!(same(row[rel], f.relative) && same(row[dop], f.dop_unpolarized));
        // The reading from the written elements: a = ½(1, 1, 0, 0) (an s polariser),
        // s = (1, 0, 0.6, 0.8) (the Stokes vector normalised to S0 = 1).
        let el = |i: usize, j: usize| row[m + 4 * i + j];
        let ms = |i: usize| el(i, 0) + 0.6 * el(i, 2) + 0.8 * el(i, 3);
        let want = 0.5 * (ms(0) + ms(1));
        assert!(
            (row[b] - want).abs() <= 1e-12 * el(0, 0),
            "{} vs {want}",
            row[b]
        );
        // DOP for unpolarised light from the first column.
        let d = (el(1, 0).powi(2) + el(2, 0).powi(2) + el(3, 0).powi(2)).sqrt() / el(0, 0);
        assert!(
            (row[dop] - d).abs() < 1e-12 && (0.0..=1.0).contains(&d),
            "{d}"
        );
    }
    // Out of the plane the analyser reads something that depends on S2 and S3: the
    // elements that carry it are not all zero.
    assert!(rows.iter().any(|row| row[m + 2].abs() > 1e-6 * row[m]));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn scalar_s_and_p_curves_are_m00_plus_and_minus_m01() {
    // physics.md §11: F00 is the exact unpolarised BRDF and F00 ± F01 the exact s and p
    // ones. The scalar path (--transmission s|p, no Mueller matrix) and the Mueller path
    // compute them separately; in and out of the plane they agree to the quadrature's
    // rounding.
    let dir = scratch("pol", "sp");
    let det = detector_file(&dir);
    for geometry in [
        vec!["--theta-s", "-80:80:4"],
        vec!["--detectors", det.to_str().unwrap()],
    ] {
        let base = |extra: &[&str]| {
            let mut a = vec![
                "model",
                "--theta-i",
                "0,45,75",
                "--hwhm",
                "10",
                "--clearcoat",
            ];
            a.extend(&geometry);
            a.extend(extra);
            let (code, out, err) = run(&a);
            assert_eq!(code, 0, "{a:?}: {err}");
            table(&out)
        };
        let (h, mueller) = base(&["--polarization", "mueller"]);
        let (m00, m01) = (col(&h, "m00"), col(&h, "m01"));
        let b = col(&h, "brdf_per_sr");
        for (extra, sign) in [
            (vec![], 0.0),
            (vec!["--transmission", "s"], 1.0),
            (vec!["--transmission", "p"], -1.0),
            (vec!["--incident", "s"], 1.0),
            (vec!["--incident", "p"], -1.0),
        ] {
            let (hs, scalar) = base(&extra);
            let bs = col(&hs, "brdf_per_sr");
            assert_eq!(scalar.len(), mueller.len());
            for (s, m) in scalar.iter().zip(&mueller) {
                let want = m[m00] + sign * m[m01];
                assert!(
                    (s[bs] - want).abs() <= 1e-10 * m[m00],
                    "{extra:?}: {} vs {want}",
                    s[bs]
                );
                if sign == 0.0 {
                    assert!((m[b] - m[m00]).abs() <= 1e-12 * m[m00]);
                }
            }
        }
        if geometry[0] == "--theta-s" {
            // In the plane of incidence the mirror symmetry y → −y gives M = D M D,
            // D = diag(1, 1, −1, −1): the 2 × 2 off-diagonal blocks vanish.
            for m in &mueller {
                for (i, j) in [
                    (0, 2),
                    (0, 3),
                    (1, 2),
                    (1, 3),
                    (2, 0),
                    (2, 1),
                    (3, 0),
                    (3, 1),
                ] {
                    let v = m[m00 + 4 * i + j];
                    assert!(v.abs() <= 1e-12 * m[m00], "m{i}{j} = {v} (m00 {})", m[m00]);
                }
            }
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn topo_writes_the_facades_mueller_curves_and_m00_is_the_scalar_curve() {
    let dir = scratch("pol", "topo");
    let det = detector_file(&dir);
    let height = fixtures().join("synth-hwhm6-rough.height.x3p");
    let intensity = fixtures().join("synth-hwhm6-rough.intensity.x3p");
    let common = [
        "topo",
        height.to_str().unwrap(),
        "--intensity",
        intensity.to_str().unwrap(),
        "--cutoff",
        "0.49",
        "--theta-i",
        "20,60",
        "--detectors",
        det.to_str().unwrap(),
        "--aperture",
        "4",
    ];
    let mut args = common.to_vec();
    args.extend([
        "--polarization",
        "mueller",
        "--incident",
        "p",
        "--analyzer",
        "1,0,1,0",
    ]);
    let (code, out, err) = run(&args);
    assert_eq!(code, 0, "{err}");
    let (h, rows) = table(&out);
    let (code, out, err) = run(&common);
    assert_eq!(code, 0, "{err}");
    let (hs, scalar) = table(&out);

    let opts = ReadOptions::default();
    let (mut map, _) = read_map(&height, &opts).unwrap();
    let (mask, _) = read_intensity(&intensity, &opts).unwrap();
    map.apply_intensity_cutoff(&mask, 0.49).unwrap();
    let pol = Polarimetry {
        incident: Stokes::P,
        analyzer: Analyzer::polarizer(Stokes::new([1.0, 0.0, 1.0, 0.0]).unwrap()).unwrap(),
    };
    let (mu, _) = topographic_mueller(
        &Coating::default(),
        &instrument(&[20.0, 60.0], 4.0),
        &Settings::default(),
        &TopoSettings::default(),
        &[&map],
        &pol,
        &|_, _| {},
    )
    .unwrap();
    let m = col(&h, "m00");
    let (b, se, rays) = (col(&h, "brdf_per_sr"), col(&h, "std_err"), col(&h, "rays"));
    let mut lit = 0;
    for ((row, f), s) in rows.iter().zip(&mu.rows).zip(&scalar) {
        for e in 0..16 {
            assert!(same(row[m + e], f.brdf[e]));
        }
        assert!(same(row[b], f.detected_brdf));
        assert!(same(row[se], f.detected_std_err.unwrap_or(f64::NAN)));
        assert_eq!(row[rays], f.rays.unwrap() as f64);
        // m00 is the scalar topographic curve (same rays, summed in another order).
        let s_b = s[col(&hs, "brdf_per_sr")];
        assert!((row[m] - s_b).abs() <= 1e-12 * s_b, "{} vs {s_b}", row[m]);
        // p incidence, analyser along s + p: ½(m00 − m01 + m20 − m21).
        let el = |i: usize, j: usize| row[m + 4 * i + j];
        let want = 0.5 * (el(0, 0) - el(0, 1) + el(2, 0) - el(2, 1));
        assert!((row[b] - want).abs() <= 1e-12 * el(0, 0).max(1e-300));
        if row[m] > 0.0 {
            lit += 1;
        }
    }
    assert!(lit >= 4, "{lit} detectors lit");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn json_has_the_degree_of_polarisation_convention_and_units() {
    let (code, out, err) = run(&[
        "model",
        "--theta-i",
        "60",
        "--theta-s",
        "-60,-30",
        "--polarization",
        "mueller",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert!(
        v["polarimetry"]["convention"]
            .as_str()
            .unwrap()
            .contains("SCATMECH")
    );
    assert!(
        v["polarimetry"]["units"]["m00 ... m33"]
            .as_str()
            .unwrap()
            .contains("1/sr")
    );
    assert_eq!(
        v["inputs"]["polarimetry"]["incident_stokes"],
        serde_json::json!([1.0, 0.0, 0.0, 0.0])
    );
    assert_eq!(v["inputs"]["polarimetry"]["analyzer"], "none");
    for row in v["rows"].as_array().unwrap() {
        let m: Vec<f64> = row["mueller_brdf_per_sr"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        let d = (m[4] * m[4] + m[8] * m[8] + m[12] * m[12]).sqrt() / m[0];
        assert!((row["dop_unpolarized"].as_f64().unwrap() - d).abs() < 1e-14);
        assert_eq!(row["brdf_per_sr"].as_f64().unwrap(), m[0]);
    }
    // The flakes polarise the specular light: refraction in and out favours p
    // (DOP > 0) at 60°.
    assert!(v["rows"][0]["dop_unpolarized"].as_f64().unwrap() > 0.01);
}

#[test]
fn bad_polarisation_flags_exit_2_naming_the_flag_and_write_nothing() {
    let dir = scratch("pol", "bad");
    let out = dir.join("out.csv");
    let o = out.to_str().unwrap();
    for (args, needle) in [
        (vec!["--incident", "1,2,0,0"], "--incident 1,2,0,0"),
        (vec!["--incident", "-1,0,0,0"], "S0 (the power) must be > 0"),
        (vec!["--incident", "1,0,nan,0"], "finite"),
        (vec!["--incident", "1,0"], "four numbers S0,S1,S2,S3"),
        (vec!["--incident", "left"], "--incident left"),
        (vec!["--analyzer", "1,0.3,0,0"], "--analyzer 1,0.3,0,0"),
        (vec!["--analyzer", "unpolarized"], "--analyzer unpolarized"),
        (
            vec!["--transmission", "s", "--incident", "p"],
            "--transmission s",
        ),
        (
            vec!["--transmission", "paper", "--polarization", "mueller"],
            "no Mueller form",
        ),
        (vec!["--polarization", "jones"], "--polarization"),
        (vec!["--multi-angle", "--incident", "s"], "--multi-angle"),
        (
            vec!["--wavelengths", "500,600", "--polarization", "mueller"],
            "--wavelengths",
        ),
    ] {
        let mut a = vec!["model", "--out", o];
        a.extend(&args);
        let (code, _, err) = run(&a);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(!out.exists(), "{args:?} left {o}");
    }
    let height = fixtures().join("synth-hwhm3-smooth.height.x3p");
    let (code, _, err) = run(&[
        "topo",
        height.to_str().unwrap(),
        "--analyzer",
        "2,0,0,1",
        "--out",
        o,
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("--analyzer 2,0,0,1") && err.contains("degree of polarisation 0.5 (within"),
        "{err}"
    );
    assert!(!out.exists());
    // topo's multi-angle and spectral runs are scalar too.
    for extra in [
        &["--multi-angle", "--analyzer", "s"][..],
        &["--wavelengths", "500", "--polarization", "mueller"][..],
        &["--multi-angle", "--isotropic"][..],
    ] {
        let mut a = vec!["topo", height.to_str().unwrap(), "--out", o];
        a.extend(extra);
        let (code, _, err) = run(&a);
        assert_eq!(code, 2, "{extra:?}: {err}");
        assert!(
            err.contains("--multi-angle") || err.contains("--wavelengths"),
            "{extra:?}: {err}"
        );
        assert!(!out.exists(), "{extra:?} left {o}");
    }
    std::fs::remove_dir_all(&dir).ok();
}
