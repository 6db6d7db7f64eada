//! `colour`, the spectral flags, `--multi-angle` colour and `--measured-multiangle` end to
//! end (docs/cli.md "Spectral models", "colour"). Reference numbers come from
//! `crates/flakescatter/tests/data/spectral` (numpy + colour-science 0.4.7, outside the
//! project; its README says how).

mod common;

use std::path::{Path, PathBuf};

use common::{run_text as run, scratch};
use serde_json::Value;

fn json(args: &[&str]) -> Value {
    let (code, out, err) = run(args);
    assert_eq!(code, 0, "{args:?}: {err}");
    serde_json::from_str(&out).unwrap()
}

const DATA: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../flakescatter/tests/data/spectral"
);

/// The reference spectrum of `config` at `aspecular` as a `colour` input file.
fn reference_spectrum(dir: &Path, config: &str, aspecular: &str, geometry: bool) -> PathBuf {
    let text = std::fs::read_to_string(format!("{DATA}/reference_spectra.csv")).unwrap();
    let mut out = String::from(if geometry {
        "theta_i_deg,aspecular_deg,wavelength_nm,reflectance_factor\n"
    } else {
        "wavelength_nm,reflectance_factor\n"
    });
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        if f[0] == config && (geometry || f[1] == aspecular) {
            if geometry {
                out.push_str(&format!("45,{},{},{}\n", f[1], f[2], f[3]));
            } else {
                out.push_str(&format!("{},{}\n", f[2], f[3]));
            }
        }
    }
    let p = dir.join(format!("{config}-{aspecular}-{geometry}.csv"));
    std::fs::write(&p, out).unwrap();
    p
}

/// `(L, a, b)` of the reference CIELAB.
fn reference_lab(config: &str, aspecular: &str) -> [f64; 3] {
    let text = std::fs::read_to_string(format!("{DATA}/reference_lab.csv")).unwrap();
    let line = text
        .lines()
        .find(|l| l.starts_with(&format!("{config},{aspecular},")))
        .unwrap();
    let f: Vec<f64> = line
        .split(',')
        .skip(7)
        .map(|s| s.parse().unwrap())
        .collect();
    [f[0], f[1], f[2]]
}

#[test]
fn colour_of_a_spectrum_matches_colour_science() {
    let d = scratch("colour", "one");
    let s = reference_spectrum(&d, "rakic_n1.5_hwhm6", "45", false);
    let j = json(&["colour", "--reflectance", s.to_str().unwrap(), "--json"]);
    for key in ["X", "Y", "Z", "L", "a", "b", "C", "h"] {
        assert!(j[key].is_number(), "key {key} missing: {j}");
    }
    let [l, a, b] = reference_lab("rakic_n1.5_hwhm6", "45");
    let de = ((j["L"].as_f64().unwrap() - l).powi(2)
        + (j["a"].as_f64().unwrap() - a).powi(2)
        + (j["b"].as_f64().unwrap() - b).powi(2))
    .sqrt();
    assert!(de < 0.002, "ΔE*ab {de} from colour-science");
    // C and h from a and b by their definitions (h in degrees).
    let (ja, jb) = (j["a"].as_f64().unwrap(), j["b"].as_f64().unwrap());
    assert!((j["C"].as_f64().unwrap() - ja.hypot(jb)).abs() < 1e-12);
    let h = jb.atan2(ja).to_degrees().rem_euclid(360.0);
    assert!((j["h"].as_f64().unwrap() - h).abs() < 1e-9);
    // D50 / 2° on the 5 nm spectrum of another configuration.
    let s = reference_spectrum(&d, "mcpeak_cauchy_depth5", "15", false);
    let j = json(&[
        "colour",
        "--reflectance",
        s.to_str().unwrap(),
        "--illuminant",
        "D50",
        "--observer",
        "2",
        "--json",
    ]);
    let [l, a, b] = reference_lab("mcpeak_cauchy_depth5", "15");
    let de = ((j["L"].as_f64().unwrap() - l).powi(2)
        + (j["a"].as_f64().unwrap() - a).powi(2)
        + (j["b"].as_f64().unwrap() - b).powi(2))
    .sqrt();
    assert!(de < 0.002, "ΔE*ab {de} from colour-science (D50/2°)");
    assert_eq!(j["inputs"]["colorimetry"]["illuminant"], "D50");
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn colour_differences_from_a_reference() {
    let d = scratch("colour", "ref");
    let sample = reference_spectrum(&d, "rakic_cauchy_film20", "45", false);
    let standard = reference_spectrum(&d, "rakic_n1.5_hwhm6", "45", false);
    let j = json(&[
        "colour",
        "--reflectance",
        sample.to_str().unwrap(),
        "--reference",
        standard.to_str().unwrap(),
        "--json",
    ]);
    // The two reference colours, and colour-science 0.4.7's differences between them
    // (`colour.delta_E(standard, sample, method=...)`): CIE 2000 23.359955,
    // CIE 1994 45.504309, CIE 1976 46.409819.
    for (key, want) in [
        ("delta_e_2000", 23.359_955),
        ("delta_e_94", 45.504_309),
        ("delta_e_ab", 46.409_819),
    ] {
        let got = j[key].as_f64().unwrap();
        // Our CIELAB of the two spectra is within 0.002 of colour-science's.
        assert!((got - want).abs() < 0.01, "{key} {got} vs {want}");
    }
    assert!(j["reference"]["L"].is_number());
    // The terminal table carries the same ΔE2000, rounded.
    let (code, out, err) = run(&[
        "colour",
        "--reflectance",
        sample.to_str().unwrap(),
        "--reference",
        standard.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("dE2000") && out.contains("23.36"), "{out}");
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn colour_per_geometry_with_the_flop_index() {
    let d = scratch("colour", "geo");
    let sample = reference_spectrum(&d, "rakic_n1.5_hwhm6", "all", true);
    let standard = reference_spectrum(&d, "rakic_cauchy_film20", "all", true);
    let j = json(&[
        "colour",
        "--reflectance",
        sample.to_str().unwrap(),
        "--reference",
        standard.to_str().unwrap(),
        "--json",
    ]);
    let g = j["geometries"].as_array().unwrap();
    assert_eq!(g.len(), 6);
    let l: Vec<f64> = g.iter().map(|x| x["L"].as_f64().unwrap()).collect();
    for (x, asp) in g.iter().zip(["-15", "15", "25", "45", "75", "110"]) {
        let [rl, _, _] = reference_lab("rakic_n1.5_hwhm6", asp);
        assert!((x["L"].as_f64().unwrap() - rl).abs() < 0.002);
        assert!(x["delta_e_2000"].is_number());
    }
    // The flop index by its formula from the reported L*.
    let fi = 2.69 * (l[1] - l[5]).powf(1.11) / l[3].powf(0.86);
    assert!((j["flop_index"].as_f64().unwrap() - fi).abs() < 1e-9 * fi);
    assert!(j["reference_flop_index"].is_number());
    // A reference without geometry columns is refused naming both files.
    let flat = reference_spectrum(&d, "rakic_n1.5_hwhm6", "45", false);
    let (code, _, err) = run(&[
        "colour",
        "--reflectance",
        sample.to_str().unwrap(),
        "--reference",
        flat.to_str().unwrap(),
    ]);
    assert_eq!(code, 2);
    assert!(err.contains("geometry columns"), "{err}");
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn one_wavelength_equals_the_monochromatic_model() {
    // McPeak's row at 550 nm (crates/optics/data/aluminium_mcpeak2015.csv).
    let common = ["--theta-i", "30,60", "--theta-s", "-70:70:5", "--clearcoat"];
    let mut a = vec![
        "model",
        "--wavelengths",
        "550",
        "--flake-material",
        "mcpeak",
    ];
    a.extend(common);
    let mut b = vec!["model", "--flake-index", "0.789405353,5.851936501"];
    b.extend(common);
    let (ca, spectral, ea) = run(&a);
    let (cb, mono, eb) = run(&b);
    assert_eq!((ca, cb), (0, 0), "{ea} {eb}");
    let spectral: Vec<String> = spectral
        .lines()
        .map(|l| l.split_once(',').unwrap().1.to_string())
        .collect();
    let mono: Vec<&str> = mono.lines().collect();
    assert_eq!(spectral.len(), mono.len());
    for (s, m) in spectral.iter().zip(&mono) {
        assert_eq!(s, m);
    }
}

#[test]
fn multi_angle_is_spectral_and_neutral_for_a_perfect_conductor() {
    let j = json(&["model", "--multi-angle", "--json"]);
    for r in j["readouts"].as_array().unwrap() {
        assert!(r["a"].as_f64().unwrap().abs() < 1e-6 && r["b"].as_f64().unwrap().abs() < 1e-6);
        // Flat spectrum: the luminance factor is the reflectance factor, L* its lightness.
        let y = r["reflectance_factor"].as_f64().unwrap();
        let l = 116.0 * y.cbrt() - 16.0;
        if y > 0.01 {
            assert!((r["L"].as_f64().unwrap() - l).abs() < 1e-9);
        }
    }
    assert_eq!(j["wavelengths_nm"].as_array().unwrap().len(), 41);
    assert_eq!(j["dispersive"], false);
    // Aluminium: the bluish-green tint, a* < 0 and b* < 0 in the bright geometries.
    let j = json(&[
        "model",
        "--multi-angle",
        "--flake-material",
        "aluminium",
        "--json",
    ]);
    let r = &j["readouts"][1];
    assert!(
        r["a"].as_f64().unwrap() < -0.1 && r["b"].as_f64().unwrap() < -0.3,
        "{r}"
    );
    // A custom set at another incidence: no flop index (defined at 45° only).
    let j = json(&[
        "model",
        "--multi-angle",
        "--theta-i",
        "30",
        "--aspecular",
        "15,45,75",
        "--json",
    ]);
    assert_eq!(j["geometry_set"], "custom");
    assert_eq!(j["readouts"].as_array().unwrap().len(), 3);
    assert_eq!(j["readouts"][0]["theta_s_deg"], -15.0);
    assert!(j["flop_index"].is_null());
}

#[test]
fn topo_multi_angle_reports_colour_and_lightness_errors() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures");
    let j = json(&[
        "topo",
        &format!("{dir}/synth-hwhm6-rough.height.x3p"),
        "--multi-angle",
        "--aspecular",
        "-15,25,75",
        "--wavelengths",
        "400:700:20",
        "--json",
    ]);
    assert_eq!(j["model"], "topographic");
    let r = j["readouts"].as_array().unwrap();
    assert_eq!(r.len(), 3);
    for x in r {
        assert!(
            x["a"].as_f64().unwrap().abs() < 1e-6,
            "a perfect conductor is neutral"
        );
    }
    assert!(r.iter().any(|x| x["lightness_std_err"].is_number()));
}

#[test]
fn compare_and_fit_measured_multiangle() {
    let d = scratch("colour", "cmp");
    // A "measured" CIELAB file: the model CLI's own --multi-angle table at hwhm 7°,
    // which holds theta_i_deg, aspecular_deg, L, a, b (a known truth for the plumbing).
    let lab = d.join("lab.csv");
    let (code, _, err) = run(&[
        "model",
        "--multi-angle",
        "--flake-material",
        "aluminium",
        "--hwhm",
        "7",
        "--wavelengths",
        "400:700:20",
        "--out",
        lab.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let j = json(&[
        "compare",
        "--measured-multiangle",
        lab.to_str().unwrap(),
        "--flake-material",
        "aluminium",
        "--hwhm",
        "7",
        "--wavelengths",
        "400:700:20",
        "--json",
    ]);
    for g in j["geometries"].as_array().unwrap() {
        assert!(g["delta_e_2000"].as_f64().unwrap() < 1e-9, "{g}");
    }
    // The fit finds the width back (start 4°).
    let j = json(&[
        "fit",
        "--measured-multiangle",
        lab.to_str().unwrap(),
        "--flake-material",
        "aluminium",
        "--wavelengths",
        "400:700:20",
        "--json",
    ]);
    assert!((j["hwhm_deg"].as_f64().unwrap() - 7.0).abs() < 1e-4, "{j}");
    assert!((j["scale"].as_f64().unwrap() - 1.0).abs() < 1e-4);
    assert_eq!(j["dof"], 4);
    // Flags that do not apply are refused.
    for (extra, needle) in [
        (vec!["--theta-s", "10"], "--theta-s"),
        (vec!["--region", "5:30"], "--region"),
        (vec!["--nonparametric"], "--nonparametric"),
    ] {
        let mut a = vec!["fit", "--measured-multiangle", lab.to_str().unwrap()];
        a.extend(extra);
        let (code, _, err) = run(&a);
        assert_eq!(code, 2, "{a:?}");
        assert!(err.contains(needle), "{err}");
    }
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn bad_spectral_input_names_file_line_and_column() {
    let d = scratch("colour", "bad");
    let write = |name: &str, text: &str| {
        let p = d.join(name);
        std::fs::write(&p, text).unwrap();
        p.to_str().unwrap().to_string()
    };
    let nk = write("nk.csv", "wavelength_nm,n,k\n400,0.5,4.9\n500,-0.7,6.1\n");
    let coat = write("coat.csv", "wavelength_nm,n,k\n380,1.5,0\n780,1.48,0.001\n");
    let alpha = write(
        "alpha.csv",
        "wavelength_nm,alpha_per_um\n380,0.1\n780,-0.2\n",
    );
    let spec = write(
        "spec.csv",
        "wavelength_nm,reflectance_factor\n400,0.5\n410,abc\n",
    );
    let multi = write("multi.csv", "theta_i_deg,aspecular_deg,L,a\n45,15,100,0\n");
    let short = write(
        "short.csv",
        "wavelength_nm,reflectance_factor\n500,0.5\n600,0.5\n",
    );
    let cases: Vec<(Vec<&str>, Vec<&str>)> = vec![
        (
            vec!["model", "--multi-angle", "--flake-nk", &nk],
            vec![&nk, "line 3", "column n"],
        ),
        (
            vec!["model", "--multi-angle", "--coat-index", &coat],
            vec![&coat, "line 3", "column k"],
        ),
        (
            vec![
                "model",
                "--multi-angle",
                "--binder-absorption",
                &alpha,
                "--film-um",
                "20",
            ],
            vec![&alpha, "line 3", "column alpha_per_um"],
        ),
        (
            vec!["colour", "--reflectance", &spec],
            vec![&spec, "line 3", "column reflectance_factor"],
        ),
        (
            vec!["compare", "--measured-multiangle", &multi],
            vec![&multi, "line 1", "L, a, b"],
        ),
        (
            vec!["colour", "--reflectance", &short],
            vec![&short, "400 to 700 nm"],
        ),
        (
            vec!["model", "--multi-angle", "--coat-cauchy", "1.5,x"],
            vec!["--coat-cauchy", "µm²"],
        ),
        (
            vec!["model", "--multi-angle", "--coat-cauchy", "0.9,0.004"],
            vec!["--coat-cauchy", "below 1"],
        ),
        (
            vec!["model", "--multi-angle", "--binder-absorption", &alpha],
            vec!["--flake-depth-um", "--film-um"],
        ),
        (
            vec!["model", "--wavelengths", "600,500"],
            vec!["--wavelengths", "strictly increasing"],
        ),
        (
            vec!["model", "--flake-material", "aluminium"],
            vec!["--wavelengths LIST"],
        ),
        (
            vec![
                "model",
                "--wavelengths",
                "200:300:50",
                "--flake-material",
                "aluminium",
            ],
            vec!["200 nm", "outside the table"],
        ),
        (
            vec!["model", "--multi-angle", "--wavelengths", "500:600:10"],
            vec!["400 to 700 nm"],
        ),
        (
            vec![
                "model",
                "--flake-material",
                "aluminium",
                "--flake-index",
                "1,6",
            ],
            vec!["--flake-index"],
        ),
        (
            vec!["model", "--coat-cauchy", "1.5,0.004", "--n", "1.5"],
            vec!["--n"],
        ),
        (vec!["model", "--illuminant", "d50"], vec!["--multi-angle"]),
        (
            vec![
                "compare",
                "--measured-multiangle",
                &multi,
                "--plot",
                "x.svg",
            ],
            vec!["--plot"],
        ),
    ];
    for (args, needles) in cases {
        let (code, out, err) = run(&args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(out.is_empty(), "{args:?} wrote to stdout");
        for n in needles {
            assert!(err.contains(n), "{args:?}: `{err}` lacks `{n}`");
        }
        assert!(!err.contains("panicked"), "{err}");
    }
    std::fs::remove_dir_all(&d).ok();
}

/// The colour section of docs/guide.md, run as written (in a temporary directory for
/// `out/`); the guide must keep these lines.
#[test]
fn the_guide_colour_report_runs_as_written() {
    let guide =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/guide.md"))
            .unwrap();
    let d = scratch("colour", "guide");
    let o = |f: &str| d.join(f).to_str().unwrap().to_string();
    let lines: [(&str, Vec<String>); 5] = [
        (
            "model --multi-angle --flake-material aluminium --coat-cauchy 1.49,0.0045 --hwhm 6 --spectra-out out/standard.csv",
            vec![
                "model",
                "--multi-angle",
                "--flake-material",
                "aluminium",
                "--coat-cauchy",
                "1.49,0.0045",
                "--hwhm",
                "6",
                "--spectra-out",
                &o("standard.csv"),
            ]
            .into_iter()
            .map(String::from)
            .collect(),
        ),
        (
            "model --multi-angle --flake-material aluminium --coat-cauchy 1.49,0.0045 --hwhm 7 --spectra-out out/sample.csv --out out/sample-lab.csv",
            vec![
                "model",
                "--multi-angle",
                "--flake-material",
                "aluminium",
                "--coat-cauchy",
                "1.49,0.0045",
                "--hwhm",
                "7",
                "--spectra-out",
                &o("sample.csv"),
                "--out",
                &o("sample-lab.csv"),
            ]
            .into_iter()
            .map(String::from)
            .collect(),
        ),
        (
            "colour --reflectance out/sample.csv --reference out/standard.csv --illuminant D65 --observer 10",
            vec![
                "colour",
                "--reflectance",
                &o("sample.csv"),
                "--reference",
                &o("standard.csv"),
                "--illuminant",
                "D65",
                "--observer",
                "10",
            ]
            .into_iter()
            .map(String::from)
            .collect(),
        ),
        (
            "compare --measured-multiangle out/sample-lab.csv --flake-material aluminium --coat-cauchy 1.49,0.0045 --hwhm 6",
            vec![
                "compare",
                "--measured-multiangle",
                &o("sample-lab.csv"),
                "--flake-material",
                "aluminium",
                "--coat-cauchy",
                "1.49,0.0045",
                "--hwhm",
                "6",
            ]
            .into_iter()
            .map(String::from)
            .collect(),
        ),
        (
            "fit --measured-multiangle out/sample-lab.csv --flake-material aluminium --coat-cauchy 1.49,0.0045",
            vec![
                "fit",
                "--measured-multiangle",
                &o("sample-lab.csv"),
                "--flake-material",
                "aluminium",
                "--coat-cauchy",
                "1.49,0.0045",
            ]
            .into_iter()
            .map(String::from)
            .collect(),
        ),
    ];
    let mut report = String::new();
    let mut fitted = String::new();
    for (k, (text, args)) in lines.iter().enumerate() {
        assert!(guide.contains(text), "docs/guide.md lacks `{text}`");
        let a: Vec<&str> = args.iter().map(String::as_str).collect();
        let (code, out, err) = run(&a);
        assert_eq!(code, 0, "{text}: {err}");
        if k == 2 {
            report = out;
        } else if k == 4 {
            fitted = out;
        }
    }
    // The report has one row per E2194 geometry with the ΔE columns and the flop indices.
    assert!(
        report.contains("dE2000") && report.contains("flop index"),
        "{report}"
    );
    assert_eq!(
        report.lines().filter(|l| l.starts_with("45 ")).count(),
        6,
        "{report}"
    );
    assert!(fitted.starts_with("hwhm_deg = 7.0000"), "{fitted}");
    std::fs::remove_dir_all(&d).ok();
}
