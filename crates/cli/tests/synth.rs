//! `flakescatter synth`: outputs, reproducibility, exit codes.

mod common;

use std::path::PathBuf;
use std::process::Output;
use std::sync::OnceLock;

use common::bin;

/// `name` in this file's one scratch directory (made empty once per test binary).
fn tmp(name: &str) -> PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| common::scratch("synth", "cli"))
        .join(name)
}

fn run(args: &[&str]) -> Output {
    bin().arg("synth").args(args).output().unwrap()
}

#[test]
fn writes_maps_truth_and_json_and_is_reproducible() {
    let (h, i, t) = (tmp("h.x3p"), tmp("i.txt"), tmp("t.csv"));
    let args = [
        "--size",
        "120,80",
        "--pixel-um",
        "0.25",
        "--hwhm",
        "4",
        "--seed",
        "7",
        "--out",
        h.to_str().unwrap(),
        "--intensity-out",
        i.to_str().unwrap(),
        "--truth-out",
        t.to_str().unwrap(),
        "--json",
    ];
    let out = run(&args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["version"], env!("CARGO_PKG_VERSION"));
    assert_eq!(json["input"]["nx"], 120);
    assert_eq!(json["input"]["ny"], 80);
    assert_eq!(json["input"]["seed"], 7);
    assert!((json["input"]["hwhm_deg"].as_f64().unwrap() - 4.0).abs() < 1e-12);
    // 120 × 0.25 µm = 30 µm.
    assert!((json["width_um"].as_f64().unwrap() - 30.0).abs() < 1e-12);

    let truth = std::fs::read_to_string(&t).unwrap();
    let mut lines = truth.lines();
    let header = lines.next().unwrap();
    assert!(header.starts_with("id,x_um,y_um,nx,ny,nz,area_um2,theta_n_deg,phi_n_deg"));
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len() as u64, json["flakes_visible"].as_u64().unwrap());
    // The intensity text map: 80 data rows of 120 values in [0, 1].
    let itext = std::fs::read_to_string(&i).unwrap();
    let data: Vec<&str> = itext.lines().filter(|l| !l.starts_with('#')).collect();
    assert_eq!(data.len(), 80);
    assert!(data.iter().all(|l| l.split_whitespace().count() == 120));
    let x3p = std::fs::read(&h).unwrap();
    assert_eq!(&x3p[..2], b"PK", "X3P is a zip archive");

    // Same seed, same bytes; another seed, other bytes.
    let (h2, t2) = (tmp("h2.x3p"), tmp("t2.csv"));
    let mut again = args.to_vec();
    again[9] = h2.to_str().unwrap();
    again[13] = t2.to_str().unwrap();
    again.pop();
    assert!(run(&again).status.success());
    assert_eq!(std::fs::read(&h2).unwrap(), x3p);
    assert_eq!(std::fs::read_to_string(&t2).unwrap(), truth);
    again[7] = "8";
    assert!(run(&again).status.success());
    assert_ne!(std::fs::read_to_string(&t2).unwrap(), truth);

    // The truth table is a valid flake table for `stats`.
    let stats = bin()
        .args(["stats", "--flakes", t.to_str().unwrap(), "--json"])
        .output()
        .unwrap();
    assert!(
        stats.status.success(),
        "{}",
        String::from_utf8_lossy(&stats.stderr)
    );
}

#[test]
fn stats_recovers_the_requested_width_from_the_truth_table() {
    // 1500 flakes at hwhm 6°: the visible-area-weighted normals follow the requested
    // law (visibility does not depend on the tilt for these small angles), and the ML
    // width of ~1000 visible flakes has a relative sd of about 1/sqrt(2 · n_eff) ≈ 3 %.
    let t = tmp("big.csv");
    let out = run(&[
        "--size",
        "400",
        "--pixel-um",
        "1.0",
        "--count",
        "1500",
        "--seed",
        "3",
        "--truth-out",
        t.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stats = bin()
        .args(["stats", "--flakes", t.to_str().unwrap(), "--json"])
        .output()
        .unwrap();
    assert!(
        stats.status.success(),
        "{}",
        String::from_utf8_lossy(&stats.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&stats.stdout).unwrap();
    let hwhm = json["hwhm_deg"].as_f64().unwrap();
    assert!((hwhm - 6.0).abs() < 0.6, "{hwhm}");
}

#[test]
fn truth_to_stdout_and_bad_input_exit_codes() {
    let out = run(&["--size", "40", "--truth-out", "-"]);
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stdout).starts_with("id,x_um,"));
    for bad in [
        vec!["--size", "0"],
        vec!["--size", "10,x"],
        vec!["--size", "1,2,3"],
        vec!["--pixel-um", "-0.1"],
        vec!["--pixel-um", "nan"],
        vec!["--hwhm", "-3"],
        vec!["--hwhm", "3", "--sigma", "2"],
        vec!["--roughness-um", "-1"],
        vec!["--coverage", "0"],
        vec!["--truth-out", "-", "--json"],
    ] {
        let out = run(&bad);
        assert_eq!(out.status.code(), Some(2), "{bad:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!err.contains("panicked"), "{err}");
    }
    // An output that cannot be written is a failure, exit 1.
    let out = run(&["--size", "20", "--out", "/nonexistent-dir/x.x3p"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--out"));
}

#[test]
fn refusals_name_the_flag_in_the_units_typed() {
    // Each refusal names the flag and speaks degrees or µm, never rad or `dx_um`.
    for (args, needles) in [
        (vec!["--hwhm", "0"], vec!["--hwhm 0", "degrees"]),
        (vec!["--sigma", "1e-12"], vec!["--sigma", "degrees"]),
        (vec!["--pixel-um", "0"], vec!["--pixel-um 0"]),
        (vec!["--pixel-um", "0.18,0"], vec!["--pixel-um 0"]),
        (
            vec!["--film-um", "0.5"],
            vec!["--film-um 0.5", "--thickness-um 1"],
        ),
        (
            vec!["--film-um", "10", "--hwhm", "30"],
            vec!["--film-um 10", "--diameter-um 16", "%"],
        ),
    ] {
        let mut all = vec!["--size", "16"];
        all.extend(&args);
        let out = run(&all);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        for n in needles {
            assert!(err.contains(n), "{args:?}: {err}");
        }
        assert!(
            !err.contains("rad") && !err.contains("dx_um"),
            "{args:?}: {err}"
        );
    }
}
