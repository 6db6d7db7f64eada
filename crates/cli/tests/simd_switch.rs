//! The one kernel switch, `FLAKESCATTER_SIMD` (crates/numerics/src/simd.rs): a value
//! other than unset, empty, `auto` or `portable` is refused by every command that runs
//! a model — exit status 2, the value named, nothing written — rather than silently
//! running the processor's kernels (or, for `analyze`, reporting every model as failed
//! and exiting 0, as it did before issue 45).

mod common;

use std::path::Path;

use common::{fixture, root, s, scratch};

/// The refusal's text: the variable and the value as given.
const NAMED: &str = "FLAKESCATTER_SIMD=\"avx2\" is not valid";

/// Runs `args` with `FLAKESCATTER_SIMD=avx2` in `dir`; asserts the refusal and that
/// nothing went to standard output.
fn refused(dir: &Path, args: &[&str]) {
    let o = common::bin()
        .current_dir(dir)
        .env("FLAKESCATTER_SIMD", "avx2")
        .args(args)
        .output()
        .unwrap();
    let err = common::stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    assert!(err.contains(NAMED), "{args:?}: {err}");
    assert!(o.stdout.is_empty(), "{args:?} wrote to stdout");
    assert!(!err.contains("panicked"), "{args:?}: {err}");
}

/// A paint parameter file (docs/formats.md) and a small BRDF table of its channel `g`,
/// written by hand: 30 in-plane points at θi = 45°.
fn paint_inputs(d: &Path) {
    std::fs::write(
        d.join("p.json"),
        r#"{"format": "flakescatter paint parameters", "version": 1,
 "coat": {"n": 1.5, "roughness": 0.02, "haze": 0.0, "haze_roughness": 0.3},
 "orientation": {"family": "gaussian", "hwhm_deg": 6},
 "flakes": {"metal": "aluminium", "coverage": 0.5},
 "channels": [{"name": "g", "wavelength_nm": 547.0, "flake_scale": 0.06, "base_albedo": 0.02}]}
"#,
    )
    .unwrap();
    let rows: String = (0..30)
        .map(|k| format!("45,{},0,{}\n", 2 * k + 1, 0.5 / f64::from(k + 1)))
        .collect();
    std::fs::write(
        d.join("g.csv"),
        format!("theta_i_deg,theta_r_deg,phi_r_deg,brdf_g_per_sr\n{rows}"),
    )
    .unwrap();
}

#[test]
fn distribution_model_commands_refuse_a_bad_switch() {
    let d = scratch("simd", "dist");
    let measured = root().join("docs/figures/measured.csv");
    let m = s(&measured);
    refused(
        &d,
        &[
            "model",
            "--hwhm",
            "6",
            "--theta-i",
            "30",
            "--theta-s",
            "-80:80:20",
        ],
    );
    refused(
        &d,
        &[
            "model",
            "--multi-angle",
            "--flake-material",
            "aluminium",
            "--hwhm",
            "7",
        ],
    );
    refused(
        &d,
        &[
            "model",
            "--hwhm",
            "6",
            "--theta-i",
            "45",
            "--theta-s",
            "-70:70:10",
            "--wavelengths",
            "450,550",
            "--flake-material",
            "aluminium",
        ],
    );
    refused(&d, &["fit", "--measured", m]);
    refused(&d, &["fit", "--measured", m, "--nonparametric"]);
    refused(&d, &["compare", "--measured", m, "--hwhm", "6"]);
    refused(
        &d,
        &[
            "reproduce",
            "--out",
            "repro",
            "--fixtures",
            s(&root().join("fixtures")),
        ],
    );
    assert!(!d.join("repro").exists(), "reproduce left its directory");
}

#[test]
fn paint_commands_refuse_a_bad_switch() {
    let d = scratch("simd", "paint");
    paint_inputs(&d);
    refused(
        &d,
        &[
            "model",
            "--params",
            "p.json",
            "--theta-i",
            "45",
            "--theta-s",
            "-80:80:40",
        ],
    );
    refused(
        &d,
        &["compare", "--measured", "g.csv", "--params", "p.json"],
    );
    refused(
        &d,
        &[
            "fit",
            "--measured",
            "g.csv",
            "--paint",
            "--family",
            "gaussian",
            "--params-out",
            "q.json",
        ],
    );
    assert!(
        !d.join("q.json").exists(),
        "fit --paint wrote its parameters"
    );
}

#[test]
fn map_model_commands_refuse_a_bad_switch() {
    let d = scratch("simd", "maps");
    let (h, i) = (
        fixture("synth-hwhm3-smooth.height.x3p"),
        fixture("synth-hwhm3-smooth.intensity.x3p"),
    );
    let map = ["--intensity", s(&i), "--cutoff", "0.5"];
    let angles = ["--theta-i", "45", "--theta-s", "-80:80:40"];
    let topo: Vec<&str> = [&["topo", s(&h)][..], &map, &angles].concat();
    refused(&d, &topo);
    let iso: Vec<&str> = [&topo[..], &["--isotropic"]].concat();
    refused(&d, &iso);
    let pixels: Vec<&str> = [&["stats", "--map", s(&h)][..], &map, &["--pixel-normals"]].concat();
    refused(&d, &pixels);
    refused(
        &d,
        &[
            "volume",
            "--hwhm",
            "8",
            "--rays",
            "200",
            "--seed",
            "5",
            "--theta-i",
            "45",
            "--theta-s",
            "-80:80:40",
            "--film-um",
            "20",
        ],
    );
}

/// `analyze` refuses before any work: no report directory, not a report whose models
/// all failed.
#[test]
fn analyze_refuses_a_bad_switch() {
    let d = scratch("simd", "analyze");
    let manifest = fixture("sample.toml");
    refused(&d, &["analyze", s(&manifest), "--out", "report"]);
    assert!(
        !d.join("report/summary.json").exists(),
        "analyze wrote a report"
    );
}
