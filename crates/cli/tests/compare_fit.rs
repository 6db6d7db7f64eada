//! `compare`, `fit` and `model --multi-angle` end to end.

mod common;

use common::{run_text as run, scratch};
use std::path::{Path, PathBuf};

/// A "measured" BRDF file: the model CLI's output at hwhm `w` (clear coat on), scaled
/// by `scale` — a known truth for the plumbing of compare and fit.
fn measured_from_model(dir: &Path, w: &str, scale: f64) -> PathBuf {
    let (code, out, err) = run(&[
        "model",
        "--hwhm",
        w,
        "--theta-i",
        "30,60",
        "--theta-s",
        "-70:70:1",
        "--clearcoat",
    ]);
    assert_eq!(code, 0, "{err}");
    let mut text = String::from("theta_i_deg,theta_s_deg,value\n");
    for line in out.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let brdf: f64 = f[4].parse().unwrap();
        text.push_str(&format!("{},{},{:e}\n", f[0], f[1], brdf * scale));
    }
    let p = dir.join("measured.csv");
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn compare_recovers_the_scale_and_reports_three_regions() {
    let dir = scratch("cf", "compare");
    let m = measured_from_model(&dir, "6", 0.25);
    let m = m.to_str().unwrap();
    let (code, out, err) = run(&["compare", "--measured", m, "--hwhm", "6", "--json"]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let inc = v["incidences"].as_array().unwrap();
    assert_eq!(inc.len(), 2);
    for i in inc {
        assert!((i["scale"].as_f64().unwrap() - 0.25).abs() < 1e-6);
        let regions = i["regions"].as_array().unwrap();
        assert_eq!(regions.len(), 3);
        for r in regions {
            assert!(r["rms_log10"].as_f64().unwrap() < 1e-6, "{r}");
        }
    }
    // A different width leaves residuals away from specular.
    let (code, out, _) = run(&["compare", "--measured", m, "--hwhm", "3", "--json"]);
    assert_eq!(code, 0);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let far = &v["incidences"][0]["regions"][2]["rms_log10"];
    assert!(far.as_f64().unwrap() > 0.1, "{far}");
    // Per-point CSV and a plot.
    let csv = dir.join("points.csv");
    let svg = dir.join("cmp.svg");
    let (code, _, err) = run(&[
        "compare",
        "--measured",
        m,
        "--out",
        csv.to_str().unwrap(),
        "--plot",
        svg.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text.starts_with("theta_i_deg,theta_s_deg,region,measured,model,residual_log10\n"));
    assert_eq!(text.lines().count(), 1 + 2 * 141);
    assert!(std::fs::read_to_string(&svg).unwrap().contains("<svg"));
    // Against a model result file computed at the same angles.
    let model_csv = dir.join("model.csv");
    let (code, _, err) = run(&[
        "model",
        "--hwhm",
        "6",
        "--theta-i",
        "30,60",
        "--theta-s",
        "-70:70:1",
        "--clearcoat",
        "--out",
        model_csv.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let (code, out, err) = run(&[
        "compare",
        "--measured",
        m,
        "--model",
        model_csv.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert!((v["incidences"][1]["scale"].as_f64().unwrap() - 0.25).abs() < 1e-6);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn fit_returns_the_width_of_the_data() {
    let dir = scratch("cf", "fit");
    let m = measured_from_model(&dir, "6", 3.0);
    let m = m.to_str().unwrap();
    let (code, out, err) = run(&["fit", "--measured", m, "--json"]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let w = v["hwhm_deg"].as_f64().unwrap();
    assert!((w - 6.0).abs() < 1e-3, "{w}");
    for s in v["scales"].as_array().unwrap() {
        assert!((s["scale"].as_f64().unwrap() - 3.0).abs() < 1e-3);
    }
    // Non-parametric: a histogram CSV that `model --orientation table` accepts.
    let hist = dir.join("hist.csv");
    let (code, _, err) = run(&[
        "fit",
        "--measured",
        m,
        "--nonparametric",
        "--out",
        hist.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let (code, out, err) = run(&[
        "model",
        "--orientation",
        "table",
        "--distribution",
        hist.to_str().unwrap(),
        "--theta-i",
        "30",
        "--theta-s",
        "-30",
    ]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(out.lines().count(), 2);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn measurement_problems_are_reported() {
    let dir = scratch("cf", "bad");
    let only_spec = dir.join("spec.csv");
    std::fs::write(
        &only_spec,
        "theta_i_deg,theta_s_deg,value\n30,-30,1\n30,-29,0.5\n",
    )
    .unwrap();
    let (code, _, err) = run(&["fit", "--measured", only_spec.to_str().unwrap()]);
    assert_eq!(code, 2);
    assert!(
        err.contains("spec.csv") && err.contains("from specular"),
        "{err}"
    );
    let (code, _, err) = run(&["compare", "--measured", only_spec.to_str().unwrap()]);
    assert_eq!(code, 2);
    assert!(err.contains("5°–40°"), "{err}");
    let neg = dir.join("neg.csv");
    std::fs::write(&neg, "theta_i_deg,theta_s_deg,value\n30,-20,-1\n30,-15,1\n").unwrap();
    let (code, _, err) = run(&["compare", "--measured", neg.to_str().unwrap()]);
    assert_eq!(code, 2);
    assert!(err.contains("line 2") && err.contains("log"), "{err}");
    let (code, _, err) = run(&[
        "fit",
        "--measured",
        neg.to_str().unwrap(),
        "--region",
        "40:5",
    ]);
    assert_eq!(code, 2);
    assert!(err.contains("--region"), "{err}");
    let (code, _, err) = run(&["compare", "--measured", "/nonexistent/m.csv"]);
    assert_eq!(code, 2);
    assert!(err.contains("/nonexistent/m.csv"), "{err}");
    // A model file without the measured angles.
    let model_csv = dir.join("model.csv");
    run(&[
        "model",
        "--theta-i",
        "60",
        "--out",
        model_csv.to_str().unwrap(),
    ]);
    let ok = dir.join("ok.csv");
    std::fs::write(&ok, "theta_i_deg,theta_s_deg,value\n30,-20,1\n30,-15,1\n").unwrap();
    let (code, _, err) = run(&[
        "compare",
        "--measured",
        ok.to_str().unwrap(),
        "--model",
        model_csv.to_str().unwrap(),
    ]);
    assert_eq!(code, 2);
    assert!(err.contains("not computed at this measured angle"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn multi_angle_readout() {
    let (code, out, err) = run(&["model", "--multi-angle", "--json"]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let r = v["readouts"].as_array().unwrap();
    let asp: Vec<f64> = r
        .iter()
        .map(|x| x["aspecular_deg"].as_f64().unwrap())
        .collect();
    assert_eq!(asp, vec![-15.0, 15.0, 25.0, 45.0, 75.0, 110.0]);
    let ts: Vec<f64> = r
        .iter()
        .map(|x| x["theta_s_deg"].as_f64().unwrap())
        .collect();
    assert_eq!(ts, vec![-60.0, -30.0, -20.0, 0.0, 30.0, 65.0]);
    // L* from the reflectance factor by the CIE closed form, and the flop index from L*.
    let lstar = |y: f64| {
        if y > (6.0f64 / 29.0).powi(3) {
            116.0 * y.cbrt() - 16.0
        } else {
            116.0 * (y / (3.0 * (6.0f64 / 29.0).powi(2)) + 4.0 / 29.0) - 16.0
        }
    };
    let l: Vec<f64> = r
        .iter()
        .map(|x| lstar(x["reflectance_factor"].as_f64().unwrap()))
        .collect();
    for (a, x) in l.iter().zip(r) {
        assert!((a - x["lightness_l_star"].as_f64().unwrap()).abs() < 1e-9);
    }
    let fi = 2.69 * (l[1] - l[5]).powf(1.11) / l[3].powf(0.86);
    assert!((fi - v["flop_index"].as_f64().unwrap()).abs() < 1e-9 * fi);
    assert_eq!(v["aperture_deg"], 1.5);
    let (code, _, err) = run(&["model", "--multi-angle", "--aperture", "0"]);
    assert_eq!(code, 2, "{err}");
}

#[test]
fn undefined_relative_is_an_empty_cell_with_a_warning() {
    // Flakes tilted 2°–3° only: the specular detector (1.5° cone) sees none of them, so
    // `relative` has no reference.
    let dir = scratch("cf", "relative");
    let hist = dir.join("h.csv");
    std::fs::write(&hist, "theta_lo_deg,theta_hi_deg,area_fraction\n2,3,1\n").unwrap();
    let (code, out, err) = run(&[
        "model",
        "--orientation",
        "table",
        "--distribution",
        hist.to_str().unwrap(),
        "--theta-i",
        "30",
        "--theta-s",
        "-36",
        "--aperture",
        "0.5",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(
        err.contains("relative") && err.contains("undefined"),
        "{err}"
    );
    let row = out.lines().nth(1).unwrap();
    assert!(row.ends_with(','), "{row}");
    // Both CSV and JSON on stdout is a usage error for compare and fit too.
    let m = measured_from_model(&dir, "6", 1.0);
    for cmd in ["compare", "fit"] {
        let (code, _, err) = run(&[
            cmd,
            "--measured",
            m.to_str().unwrap(),
            "--out",
            "-",
            "--json",
            "--nonparametric",
        ][..if cmd == "fit" { 7 } else { 6 }]);
        assert_eq!(code, 2, "{cmd}: {err}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_poor_fit_warns_on_stderr_and_in_the_json() {
    // The model's curve with every other point off by a factor e (so the data scatter by
    // ±1 in ln) and 1 % stated uncertainties: chi2/dof is in the thousands. The fit
    // still runs, scales its uncertainty by sqrt(chi2/dof) and says why.
    let dir = scratch("cf", "poor");
    let m = measured_from_model(&dir, "6", 1.0);
    let text = std::fs::read_to_string(&m).unwrap();
    let mut out = String::from("theta_i_deg,theta_s_deg,value,uncertainty\n");
    for (k, line) in text.lines().skip(1).enumerate() {
        let f: Vec<&str> = line.split(',').collect();
        let v: f64 =
            f[2].parse::<f64>().unwrap() * if k % 2 == 0 { std::f64::consts::E } else { 1.0 };
        out.push_str(&format!("{},{},{v:e},{:e}\n", f[0], f[1], 0.01 * v));
    }
    std::fs::write(&m, out).unwrap();
    let (code, stdout, err) = run(&["fit", "--measured", m.to_str().unwrap(), "--json"]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("warning") && err.contains("poor fit"), "{err}");
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let warnings = v["warnings"].as_array().unwrap();
    assert!(
        warnings
            .iter()
            .any(|w| w.as_str().unwrap().contains("poor fit"))
    );
    assert!(v["uncertainty_basis"].as_str().unwrap().contains("scaled"));
    let chi2_dof = v["chi2"].as_f64().unwrap() / v["dof"].as_f64().unwrap();
    assert!((v["uncertainty_scale"].as_f64().unwrap() - chi2_dof.sqrt()).abs() < 1e-9 * chi2_dof);
    std::fs::remove_dir_all(&dir).ok();
}
