//! `flakescatter volume --flake-stack SPEC --wavelength NM` (issue 47): interference
//! flakes in the volume model, the light they transmit followed on through the flake.
//!
//! * The energy balance of a clear stack sums to 1 within 1e-12 and its layers absorb
//!   nothing (the transmitted share is counted where it ends: substrate, escape, another
//!   flake).
//! * A 1 µm layer of the aluminium index is opaque (`T ≈ e^{−4π k d/λ} ≈ 1e-66`), so its
//!   curves equal `--flake-index` of the same index to 1e-9 (the stack's reflectance
//!   equals bulk Fresnel to 1e-9, physics.md §13; with a black substrate and absorbing
//!   rims the extra draw at each flake changes no later direction).
//! * Bad flags exit 2 naming the flag.

use std::process::Command;

fn run(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_flakescatter"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

const BASE: [&str; 17] = [
    "volume",
    "--theta-i",
    "0,40",
    "--theta-s",
    "-60:60:10",
    "--aperture",
    "2",
    "--hwhm",
    "8",
    "--tile-um",
    "200",
    "--rays",
    "12800",
    "--layers",
    "2",
    "--seed",
    "3",
];

fn json_run(extra: &[&str]) -> serde_json::Value {
    let mut args: Vec<&str> = BASE.to_vec();
    args.extend_from_slice(extra);
    args.push("--json");
    let (code, out, err) = run(&args);
    assert_eq!(code, 0, "{err}");
    serde_json::from_str(&out).unwrap()
}

#[test]
fn a_clear_stack_conserves_energy_and_absorbs_nothing() {
    let v = json_run(&["--flake-stack", "TiO2:53/SiO2:100", "--wavelength", "550"]);
    assert_eq!(v["inputs"]["flake_stack"], "TiO2:53/SiO2:100");
    assert_eq!(v["inputs"]["wavelength_nm"], 550.0);
    assert!(v["inputs"]["flake_index"].is_null());
    for e in v["energy"].as_array().unwrap() {
        let f = |k: &str| e[k].as_f64().unwrap();
        let sum = f("coat_reflected")
            + f("escaped_single")
            + f("escaped_multiple")
            + f("absorbed_substrate")
            + f("absorbed_flakes")
            + f("absorbed_other");
        eprintln!("{e}");
        assert!((sum - 1.0).abs() < 1e-12, "sum {sum}");
        assert!(f("absorbed_flakes").abs() < 1e-12);
        assert!(f("absorbed_substrate") > 0.0);
    }
}

#[test]
fn an_opaque_aluminium_stack_is_the_aluminium_flake() {
    let stack = json_run(&["--flake-stack", "0.96+6.69i:1000", "--wavelength", "550"]);
    let metal = json_run(&["--flake-index", "0.96,6.69"]);
    let (a, b) = (
        stack["rows"].as_array().unwrap(),
        metal["rows"].as_array().unwrap(),
    );
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(b) {
        for key in ["reflectance", "brdf_per_sr"] {
            let (p, q) = (x[key].as_f64().unwrap(), y[key].as_f64().unwrap());
            assert!(
                (p - q).abs() <= 1e-9 * q.abs().max(1e-300),
                "{key}: {p} vs {q}"
            );
        }
    }
    for (x, y) in stack["energy"]
        .as_array()
        .unwrap()
        .iter()
        .zip(metal["energy"].as_array().unwrap())
    {
        let (p, q) = (
            x["absorbed_flakes"].as_f64().unwrap(),
            y["absorbed_flakes"].as_f64().unwrap(),
        );
        assert!(q > 0.0 && (p - q).abs() < 1e-9, "{p} vs {q}");
    }
}

#[test]
fn bad_stack_flags_exit_2_naming_the_flag() {
    for (extra, needle) in [
        (
            vec!["--flake-stack", "TiO2:53", "--wavelength", "0"],
            "--wavelength 0",
        ),
        (
            vec!["--flake-stack", "TiO2:53", "--wavelength", "nan"],
            "--wavelength NaN",
        ),
        (
            vec!["--flake-stack", "unobtainium:53", "--wavelength", "550"],
            "--flake-stack",
        ),
        (
            vec!["--flake-stack", "TiO2:-5", "--wavelength", "550"],
            "--flake-stack",
        ),
        (
            vec!["--flake-stack", "anatase:50", "--wavelength", "900"],
            "--flake-stack",
        ),
        (
            vec![
                "--flake-stack",
                "TiO2:53",
                "--wavelength",
                "550",
                "--flake-core",
                "kryptonite",
            ],
            "--flake-core",
        ),
        (vec!["--wavelength", "550"], "--flake-stack"),
        (vec!["--flake-core", "aluminium"], "--flake-stack"),
        (
            vec![
                "--flake-stack",
                "TiO2:53",
                "--wavelength",
                "550",
                "--flake-index",
                "1,2",
            ],
            "--flake-index",
        ),
    ] {
        let mut args: Vec<&str> = BASE.to_vec();
        args.extend_from_slice(&extra);
        let (code, out, err) = run(&args);
        assert_eq!(code, 2, "{extra:?}: {err}");
        assert!(out.is_empty(), "{extra:?}: {out}");
        assert!(err.contains(needle), "{extra:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}
