//! `flakescatter model` end to end: output format, numbers against closed forms, and
//! bad input (exit status 2 with a message naming the flag).

mod common;

use common::{bin, run_text as run};

#[test]
fn defaults_give_the_documented_table() {
    let (code, out, err) = run(&["model"]);
    assert_eq!(code, 0, "{err}");
    let mut lines = out.lines();
    assert_eq!(
        lines.next().unwrap(),
        "theta_i_deg,theta_s_deg,phi_s_deg,aperture_deg,brdf_per_sr,reflectance,relative"
    );
    // 5 incidences × 281 detectors (−70:70:0.5).
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 5 * 281);
    // The specular detector is the reference of `relative`.
    for ti in [0.0, 30.0, 45.0, 60.0] {
        let spec = rows.iter().find(|r| r[0] == ti && r[1] == -ti).unwrap();
        assert!((spec[6] - 1.0).abs() < 1e-9, "θi={ti}: {}", spec[6]);
    }
    // BRDF × projected solid angle = reflectance for a cone above the horizon:
    // ∫cone cos θ dΩ = cos θj π sin²α (closed form).
    let alpha = 1.5f64.to_radians();
    for r in rows.iter().step_by(97) {
        let proj = r[1].to_radians().cos() * std::f64::consts::PI * alpha.sin().powi(2);
        assert!((r[4] * proj - r[5]).abs() <= 1e-6 * r[5] + 1e-300, "{r:?}");
    }
}

#[test]
fn bare_facets_at_n_1_are_symmetric_about_specular() {
    // n = 1: BRDF × cos θs ∝ p~((θs + θi)/2) (physics.md §4), symmetric about θs = −θi;
    // so the relative values at −θi ± d agree (point detectors).
    let (code, out, err) = run(&[
        "model",
        "--n",
        "1",
        "--theta-i",
        "30",
        "--theta-s",
        "-50:-10:1",
        "--aperture",
        "0",
        "--hwhm",
        "5",
    ]);
    assert_eq!(code, 0, "{err}");
    let rows: Vec<Vec<f64>> = out
        .lines()
        .skip(1)
        .map(|l| {
            l.split(',')
                .map(|v| v.parse().unwrap_or(f64::NAN))
                .collect()
        })
        .collect();
    assert_eq!(rows.len(), 41);
    for d in 1..=20 {
        let a = rows[20 - d][6];
        let b = rows[20 + d][6];
        assert!((a - b).abs() < 1e-9 * a.max(1e-300), "d={d}: {a} vs {b}");
    }
    // A point detector collects no finite power: the reflectance column is empty.
    assert!(out.lines().nth(1).unwrap().contains(",,"));
    // And at d = 2w the relative value is p~(w)/p~(0) = 1/2 exactly (hwhm definition).
    let half = rows[20 + 10][6];
    assert!((half - 0.5).abs() < 1e-9, "{half}");
}

#[test]
fn json_echoes_inputs_and_units() {
    let (code, out, err) = run(&[
        "model",
        "--theta-i",
        "45",
        "--theta-s",
        "-45",
        "--json",
        "--sigma",
        "4",
    ]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["command"], "model");
    assert_eq!(v["inputs"]["orientation"]["width"]["sigma_deg"], 4.0);
    assert_eq!(
        v["inputs"]["instrument"]["transmission"],
        "exact-unpolarized"
    );
    assert!(v["units"]["brdf_per_sr"].as_str().unwrap().contains("1/sr"));
    assert_eq!(v["rows"].as_array().unwrap().len(), 1);
    assert!(v["version"].is_string());
}

#[test]
fn table_distribution_and_plot() {
    let dir = std::env::temp_dir().join(format!("fs-model-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let hist = dir.join("hist.csv");
    std::fs::write(
        &hist,
        "theta_lo_deg,theta_hi_deg,area_fraction\n0,1,0.5\n1,2,0.3\n2,3,0.2\n",
    )
    .unwrap();
    let plot = dir.join("m.svg");
    let (code, out, err) = run(&[
        "model",
        "--orientation",
        "table",
        "--distribution",
        hist.to_str().unwrap(),
        "--theta-i",
        "30",
        "--plot",
        plot.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(out.lines().count(), 282);
    let svg = std::fs::read_to_string(&plot).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("relative reflectance"));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_input_exits_2_with_a_message() {
    let cases: &[(&[&str], &str)] = &[
        (&["model", "--theta-i", "90"], "--theta-i"),
        (&["model", "--theta-i", "-1"], "--theta-i"),
        (&["model", "--theta-s", "-90"], "--theta-s"),
        (&["model", "--theta-s", "10:0:1"], "--theta-s"),
        (&["model", "--theta-s", "0:10:0"], "step"),
        (&["model", "--theta-i", ""], "--theta-i"),
        (&["model", "--theta-i", "a,b"], "not a number"),
        (&["model", "--n", "0.9"], "--n"),
        (&["model", "--hwhm", "0"], "--hwhm"),
        (&["model", "--sigma", "90"], "--sigma"),
        (&["model", "--rms-tilt", "-3"], "--rms-tilt"),
        (&["model", "--hwhm", "3", "--sigma", "3"], "cannot be used"),
        (&["model", "--aperture", "21"], "--aperture"),
        (&["model", "--aperture", "-1"], "--aperture"),
        (&["model", "--transmission", "foo"], "transmission"),
        (&["model", "--orientation", "table"], "--distribution"),
        (
            &[
                "model",
                "--orientation",
                "table",
                "--distribution",
                "/nonexistent/h.csv",
            ],
            "/nonexistent/h.csv",
        ),
        (
            &["model", "--detectors", "/nonexistent/d.csv"],
            "/nonexistent/d.csv",
        ),
        (&["model", "--flake-index", "1"], "--flake-index"),
    ];
    for (args, needle) in cases {
        let (code, _, err) = run(args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: `{err}` lacks `{needle}`");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
}

#[test]
fn malformed_distribution_file_names_file_and_line() {
    let dir = std::env::temp_dir().join(format!("fs-model-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let hist = dir.join("bad.csv");
    std::fs::write(
        &hist,
        "theta_lo_deg,theta_hi_deg,area_fraction\n0,1,0.5\n1,2,x\n",
    )
    .unwrap();
    let (code, _, err) = run(&[
        "model",
        "--orientation",
        "table",
        "--distribution",
        hist.to_str().unwrap(),
    ]);
    assert_eq!(code, 2);
    assert!(err.contains("bad.csv") && err.contains('3'), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn out_of_plane_detectors_from_a_file() {
    let dir = std::env::temp_dir().join(format!("fs-model-oop-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let det = dir.join("det.csv");
    std::fs::write(&det, "theta_r_deg,phi_r_deg\n30,0\n30,90\n").unwrap();
    let (code, out, err) = run(&[
        "model",
        "--theta-i",
        "30",
        "--detectors",
        det.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let rows: Vec<&str> = out.lines().skip(1).collect();
    assert_eq!(rows.len(), 2);
    assert!(rows[1].starts_with("30,30,90,"));
    // The detector at (30°, 0) is the specular one: relative = 1 by definition.
    let relative: f64 = rows[0].rsplit(',').next().unwrap().parse().unwrap();
    assert!((relative - 1.0).abs() < 1e-12, "{}", rows[0]);
    std::fs::write(&det, "theta_r_deg,phi_r_deg\n95,0\n").unwrap();
    let (code, _, err) = run(&["model", "--detectors", det.to_str().unwrap()]);
    assert_eq!(code, 2);
    assert!(err.contains("line 2"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_large_curve_table_is_the_same_bytes_on_any_number_of_threads() {
    // 86 × 1781 = 153 166 rows: more than two waves of the parallel CSV formatter
    // (16 blocks of 4096 rows each), rows split across blocks mid-incidence. One thread
    // formats the blocks one after the other, as a sequential writer would.
    let args = [
        "model",
        "--theta-i",
        "0:85:1",
        "--theta-s",
        "-89:89:0.1",
        "--aperture",
        "0",
    ];
    let out = |threads: &str| {
        let o = bin()
            .args(args)
            .env("RAYON_NUM_THREADS", threads)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        o.stdout
    };
    let one = out("1");
    assert_eq!(one.iter().filter(|&&c| c == b'\n').count(), 1 + 86 * 1781);
    assert!(one == out("2") && one == out("3"));
    // Rows in order: incidence, then detector.
    let text = String::from_utf8(one).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert!(lines[1].starts_with("0,-89,0,0,"), "{}", lines[1]);
    assert!(lines[1781].starts_with("0,89,0,0,"), "{}", lines[1781]);
    assert!(lines[1782].starts_with("1,-89,0,0,"), "{}", lines[1782]);
    assert!(
        lines[86 * 1781].starts_with("85,89,0,0,"),
        "{}",
        lines[86 * 1781]
    );
}
