//! `--flake-stack` in `model` and `topo` (docs/cli.md "Spectral flags", physics.md §13):
//! a 1 µm aluminium layer is the built-in aluminium table's bulk metal, so every row
//! equals `--flake-material aluminium`'s (a different code path: the table's complex
//! index in the single-interface Fresnel formula) to 1e-9 relative; stacks run spectrally
//! by default; bad specs exit 2 naming the layer.

mod common;

use common::{fixture, run, s, stderr};

fn rows(o: &std::process::Output) -> Vec<Vec<f64>> {
    assert!(o.status.success(), "{}", stderr(o));
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .skip(1)
        .map(|l| {
            l.split(',')
                .map(|x| x.parse().unwrap_or(f64::NAN))
                .collect()
        })
        .collect()
}

fn same(a: &[Vec<f64>], b: &[Vec<f64>], min_lit: usize) {
    assert_eq!(a.len(), b.len());
    let mut lit = 0;
    for (x, y) in a.iter().zip(b) {
        for (p, q) in x.iter().zip(y) {
            if p.is_nan() {
                assert!(q.is_nan());
                continue;
            }
            assert!(
                (p - q).abs() <= 1e-9 * p.abs().max(1e-300),
                "{x:?} vs {y:?}"
            );
        }
        lit += usize::from(x[5] > 0.0);
    }
    assert!(lit >= min_lit, "{lit} lit rows");
}

#[test]
fn thick_aluminium_stack_is_the_aluminium_table_in_both_models() {
    let common = [
        "--theta-i",
        "15,45",
        "--theta-s",
        "-70:70:10",
        "--wavelengths",
        "400,550,700",
    ];
    let mut a = vec!["model", "--hwhm", "6", "--flake-stack", "aluminium:1000"];
    a.extend(common);
    let mut b = vec!["model", "--hwhm", "6", "--flake-material", "aluminium"];
    b.extend(common);
    same(&rows(&run(&a)), &rows(&run(&b)), 60);

    let h = fixture("synth-hwhm3-smooth.height.x3p");
    let i = fixture("synth-hwhm3-smooth.intensity.x3p");
    let base = ["topo", s(&h), "--intensity", s(&i), "--cutoff", "0.5"];
    let mut a: Vec<&str> = base.to_vec();
    a.extend(["--flake-stack", "Al:1000"]);
    a.extend(common);
    let mut b: Vec<&str> = base.to_vec();
    b.extend(["--flake-material", "aluminium"]);
    b.extend(common);
    // A smooth narrow map lights only the detectors near specular.
    same(&rows(&run(&a)), &rows(&run(&b)), 6);
}

#[test]
fn a_stack_runs_spectrally_by_default_and_echoes_itself() {
    let o = run(&[
        "model",
        "--hwhm",
        "6",
        "--theta-i",
        "45",
        "--theta-s",
        "-60,-45,-30",
        "--flake-stack",
        "TiO2:120/mica:400/TiO2:120",
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let text = v.to_string();
    assert!(text.contains("TiO2:120/mica:400/TiO2:120"), "{text}");
    // 380:780:10 is 41 wavelengths × 3 detectors.
    let n = run(&[
        "model",
        "--hwhm",
        "6",
        "--theta-i",
        "45",
        "--theta-s",
        "-60,-45,-30",
        "--flake-stack",
        "TiO2:120/mica:400/TiO2:120",
    ]);
    assert_eq!(rows(&n).len(), 41 * 3);
}

#[test]
fn bad_stacks_exit_2_naming_the_layer() {
    for (stack, want) in [
        ("TiO2:120/kryptonite:40", "layer 2"),
        ("TiO2:-5", "layer 1"),
        ("TiO2:12//mica:4", "layer 2"),
    ] {
        let o = run(&["model", "--hwhm", "6", "--flake-stack", stack]);
        assert_eq!(o.status.code(), Some(2), "{stack}");
        let e = stderr(&o);
        assert!(
            e.contains("--flake-stack") && e.contains(want),
            "{stack}: {e}"
        );
    }
    // A wavelength outside a layer's table, before any work.
    let o = run(&[
        "model",
        "--hwhm",
        "6",
        "--flake-stack",
        "anatase:50",
        "--wavelengths",
        "850",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("850") && stderr(&o).contains("layer 1"),
        "{}",
        stderr(&o)
    );
    // --flake-core needs a stack; a stack excludes the other flake flags.
    let o = run(&["model", "--hwhm", "6", "--flake-core", "Al"]);
    assert_eq!(o.status.code(), Some(2));
    let o = run(&[
        "model",
        "--hwhm",
        "6",
        "--flake-stack",
        "TiO2:50",
        "--flake-material",
        "aluminium",
    ]);
    assert_eq!(o.status.code(), Some(2));
    let o = run(&[
        "model",
        "--hwhm",
        "6",
        "--flake-stack",
        "TiO2:50",
        "--flake-core",
        "unobtainium",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--flake-core"), "{}", stderr(&o));
}
