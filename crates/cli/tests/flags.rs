//! Flags that act only in another mode are refused, never silently ignored (issue 52,
//! item 14): one table of command lines, each with a flag typed outside the mode it
//! acts in, and the words its refusal must hold (the flag, its value, what it needs);
//! then the same flags in their own mode, accepted. And a measured curve with one
//! uncertainty of 0 is refused naming its line and column, not read as "no
//! uncertainties".

mod common;

use common::{root, run};
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Output;
use std::sync::OnceLock;

fn s(p: &Path) -> String {
    p.to_str().unwrap().to_owned()
}

/// Exit status `code`, every needle in stderr, no panic.
fn expect(o: &Output, code: i32, needles: &[&str], what: &str) {
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(code), "{what}: {err}");
    assert!(!err.contains("panicked"), "{what}: {err}");
    for n in needles {
        assert!(err.contains(n), "{what}: {n:?} not in: {err}");
    }
}

/// Scratch files shared by the tests of this file: a fitted paint, a model curve, a
/// CIELAB file and a small z-stack.
struct Files {
    dir: PathBuf,
    params: String,
    model: String,
    lab: String,
    stack: String,
}

fn files() -> &'static Files {
    static FILES: OnceLock<Files> = OnceLock::new();
    FILES.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("fs-flags-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).unwrap();
        let f = Files {
            params: s(&dir.join("p.json")),
            model: s(&dir.join("model.csv")),
            lab: s(&dir.join("lab.csv")),
            stack: s(&dir.join("st.tif")),
            dir,
        };
        let paint = s(&root().join("fixtures/real/paints/gold-metallic-paint2.csv"));
        for args in [
            vec![
                "fit",
                "--measured",
                &paint,
                "--paint",
                "--family",
                "gaussian",
                "--params-out",
                &f.params,
            ],
            vec!["model", "--theta-i", "30,60", "--out", &f.model],
            vec![
                "model",
                "--multi-angle",
                "--wavelengths",
                "400:700:20",
                "--out",
                &f.lab,
            ],
            vec![
                "synth",
                "--size",
                "32",
                "--out",
                &s(&f.dir.join("s.x3p")),
                "--stack-out",
                &f.stack,
            ],
        ] {
            let o = run(&args);
            assert_eq!(
                o.status.code(),
                Some(0),
                "{args:?}: {}",
                String::from_utf8_lossy(&o.stderr)
            );
        }
        f
    })
}

#[test]
fn flags_outside_their_mode_are_refused_naming_the_flag_and_what_it_needs() {
    let f = files();
    let m = s(&root().join("docs/figures/measured.csv"));
    let paint = s(&root().join("fixtures/real/paints/gold-metallic-paint2.csv"));
    let flakes = s(&root().join("fixtures/synth-hwhm3-smooth.truth.csv"));
    let map = s(&root().join("fixtures/synth-hwhm3-smooth.height.x3p"));
    let imap = s(&root().join("fixtures/synth-hwhm3-smooth.intensity.x3p"));
    let out = s(&f.dir.join("never.csv"));
    let ovl = s(&f.dir.join("never-overlays"));
    let mut cases: Vec<(Vec<&str>, Vec<&str>)> = vec![
        // A value that starts with `-` elsewhere on the line must not switch the rules
        // off (the rules once re-parsed the line without the negative-value rule, and
        // gave up silently when that parse failed).
        (
            vec![
                "segment",
                &map,
                "--intensity",
                &imap,
                "--peak",
                "argmax",
                "--cutoff",
                "-1e-3",
            ],
            vec!["--peak", "z-stacks", "leave --peak out"],
        ),
        (
            vec![
                "fit",
                "--measured",
                &m,
                "--theta-s",
                "-.5,10",
                "--lambda",
                "5",
            ],
            vec!["--lambda 5", "--nonparametric"],
        ),
        (
            vec!["stats", "--flakes", &flakes, "--allow-duplicate-maps"],
            vec!["--allow-duplicate-maps", "--map"],
        ),
        // fit: the Gaussian fit has no bins and no smoothness weight.
        (
            vec!["fit", "--measured", &m, "--lambda", "5"],
            vec!["--lambda 5", "--nonparametric"],
        ),
        (
            vec!["fit", "--measured", &m, "--bins", "0:30:2"],
            vec!["--bins 0:30:2", "--nonparametric"],
        ),
        (
            vec!["fit", "--measured", &m, "--lambda", "0.05"],
            vec!["--lambda 0.05", "--nonparametric"],
        ),
        // A negative weight is refused in any mode, as a value.
        (
            vec!["fit", "--measured", &m, "--lambda", "-1"],
            vec!["--lambda", "-1", ">= 0"],
        ),
        (
            vec!["fit", "--measured", &m, "--nonparametric", "--lambda", "-1"],
            vec!["--lambda", "-1", ">= 0"],
        ),
        (
            vec![
                "fit",
                "--measured",
                &m,
                "--nonparametric",
                "--hwhm-start",
                "6",
            ],
            vec!["--hwhm-start 6", "--nonparametric"],
        ),
        (
            vec!["fit", "--measured-multiangle", &f.lab, "--common-scale"],
            vec!["--common-scale", "--measured-multiangle"],
        ),
        (
            vec!["fit", "--measured-multiangle", &f.lab, "--lambda", "1"],
            vec!["--lambda 1", "--nonparametric"],
        ),
        (
            vec!["fit", "--measured", &paint, "--paint", "--bins", "0:20:2"],
            vec!["--bins 0:20:2", "--nonparametric"],
        ),
        (
            vec![
                "fit",
                "--measured",
                &paint,
                "--paint",
                "--measured-kind",
                "relative",
            ],
            vec!["--measured-kind relative", "--paint"],
        ),
        (
            vec![
                "fit",
                "--measured",
                &paint,
                "--paint",
                "--family",
                "gaussian",
                "--smoothing",
                "0.1",
            ],
            vec!["--smoothing 0.1", "--family table"],
        ),
        (
            vec!["fit", "--measured", &paint, "--paint", "--hwhm-start", "4"],
            vec!["--hwhm-start 4", "--paint"],
        ),
        (
            vec!["fit", "--measured", &m, "--family", "auto"],
            vec!["--family auto", "--paint"],
        ),
        (
            vec!["fit", "--measured", &m, "--smoothing", "0.01"],
            vec!["--smoothing 0.01", "--paint"],
        ),
        // compare: a paint's table, a result CSV, a paint from flags.
        (
            vec![
                "compare",
                "--measured",
                &paint,
                "--params",
                &f.params,
                "--measured-kind",
                "relative",
            ],
            vec!["--measured-kind relative", "--params"],
        ),
        (
            vec![
                "compare",
                "--measured",
                &paint,
                "--paint",
                "--measured-kind",
                "relative",
            ],
            vec!["--measured-kind relative", "--paint"],
        ),
        (
            vec!["compare", "--measured", &m, "--model", &f.model, "--paint"],
            vec!["--model", "--paint"],
        ),
        (
            vec!["compare", "--measured", &paint, "--paint", "--clearcoat"],
            vec!["--clearcoat", "--paint"],
        ),
        (
            vec!["compare", "--measured", &paint, "--paint", "--no-clearcoat"],
            vec!["--no-clearcoat", "--paint"],
        ),
        (
            vec![
                "compare",
                "--measured",
                &paint,
                "--paint",
                "--transmission",
                "s",
            ],
            vec!["--transmission s", "--paint"],
        ),
        (
            vec![
                "compare",
                "--measured",
                &paint,
                "--paint",
                "--weighting",
                "paper-printed",
            ],
            vec!["--weighting paper-printed", "--paint"],
        ),
        (
            vec![
                "compare",
                "--measured",
                &m,
                "--model",
                &f.model,
                "--alpha",
                "0.1",
            ],
            vec!["--alpha 0.1", "--model"],
        ),
        (
            vec![
                "compare",
                "--measured",
                &paint,
                "--params",
                &f.params,
                "--shape",
                "2",
            ],
            vec!["--shape 2", "--params"],
        ),
        (
            vec![
                "compare",
                "--measured",
                &paint,
                "--paint",
                "--haze-roughness",
                "0.2",
            ],
            vec!["--haze-roughness 0.2", "--haze > 0"],
        ),
        // model.
        (
            vec!["model", "--params", &f.params, "--alpha", "0.1"],
            vec!["--alpha 0.1", "--params"],
        ),
        (
            vec!["model", "--paint", "--multi-angle"],
            vec!["--multi-angle", "--paint"],
        ),
        (
            vec!["model", "--paint", "--haze-roughness", "0.2"],
            vec!["--haze-roughness 0.2", "--haze > 0"],
        ),
        (
            vec!["model", "--paint", "--haze", "0", "--haze-roughness", "0.2"],
            vec!["--haze-roughness 0.2", "--haze > 0"],
        ),
        // Map inputs: a height suffix without the suffix pairing, stack flags without a stack.
        (
            vec![
                "segment",
                &map,
                "--height-suffix",
                ".foo",
                "--intensity",
                &imap,
                "--cutoff",
                "0.1",
            ],
            vec!["--height-suffix .foo", "--intensity-suffix"],
        ),
        (
            vec!["segment", &map, "--peak", "argmax"],
            vec!["--peak", "z-stacks", "synth-hwhm3-smooth.height.x3p"],
        ),
        (
            vec![
                "topo",
                &map,
                "--theta-i",
                "30",
                "--theta-s",
                "0",
                "--min-signal",
                "0.1",
            ],
            vec!["--min-signal", "z-stacks"],
        ),
        (
            vec!["stats", "--map", &map, "--first-page", "top"],
            vec!["--first-page", "z-stacks"],
        ),
        (
            vec!["info", &map, "--stack-z-step-um", "0.2"],
            vec!["--stack-z-step-um", "z-stacks"],
        ),
        (
            vec!["segment", &map, "--overlay-max-deg", "30"],
            vec!["--overlay-max-deg 30", "--overlay"],
        ),
        // synth, volume.
        (
            vec!["synth", "--size", "32", "--correlation-um", "3"],
            vec!["--correlation-um 3", "--roughness-um"],
        ),
        (
            vec!["volume", "--substrate", "mirror"],
            vec!["--substrate mirror", "--substrate-reflectance"],
        ),
        (
            vec![
                "volume",
                "--substrate-reflectance",
                "0",
                "--substrate",
                "lambertian",
            ],
            vec!["--substrate lambertian", "--substrate-reflectance"],
        ),
    ];
    // stats --flakes reads a flake table: no flag that reads or segments maps acts.
    let map_flags: [&[&str]; 22] = [
        &["--pixel-um", "0.5"],
        &["--z-unit", "nm"],
        &["--accept-md5-mismatch"],
        &["--decimal-comma"],
        &["--channel", "0"],
        &["--intensity", &imap],
        &["--intensity-suffix", ".intensity"],
        &["--intensity-channel", "0"],
        &["--cutoff", "0.5"],
        &["--peak", "argmax"],
        &["--min-signal", "0.1"],
        &["--stack-z-step-um", "0.2"],
        &["--first-page", "top"],
        &["--z-step-um", "0.2"],
        &["--noise-um", "0.05"],
        &["--min-pixels", "50"],
        &["--flakes-out", &out],
        &["--per-map", &out],
        &["--pixel-normals"],
        &["--pixel-normals-only"],
        &["--window", "7"],
        &["--tile-um", "20"],
    ];
    for extra in map_flags {
        let mut args = vec!["stats", "--flakes", &flakes];
        args.extend_from_slice(extra);
        cases.push((args, vec![extra[0], "--map"]));
    }
    for (args, needles) in &cases {
        let o = run(args);
        expect(&o, 2, needles, &format!("{args:?}"));
        assert!(o.stdout.is_empty(), "{args:?}: no output on a refusal");
    }
    assert!(!Path::new(&out).exists() && !Path::new(&ovl).exists());
}

#[test]
fn the_same_flags_in_their_own_mode_are_accepted() {
    let f = files();
    let m = s(&root().join("docs/figures/measured.csv"));
    let paint = s(&root().join("fixtures/real/paints/gold-metallic-paint2.csv"));
    let flakes = s(&root().join("fixtures/synth-hwhm3-smooth.truth.csv"));
    let map = s(&root().join("fixtures/synth-hwhm3-smooth.height.x3p"));
    let ovl = s(&f.dir.join("overlays"));
    let synth_out = s(&f.dir.join("rough.x3p"));
    let cases: Vec<Vec<&str>> = vec![
        vec![
            "fit",
            "--measured",
            &m,
            "--nonparametric",
            "--lambda",
            "5",
            "--bins",
            "0:30:2",
        ],
        vec!["fit", "--measured", &m, "--hwhm-start", "6"],
        vec!["fit", "--measured", &m, "--nonparametric", "--common-scale"],
        vec![
            "compare",
            "--measured",
            &m,
            "--measured-kind",
            "brdf",
            "--clearcoat",
        ],
        vec![
            "compare",
            "--measured",
            &paint,
            "--paint",
            "--channels",
            "r,g,b",
            "--haze",
            "0.1",
            "--haze-roughness",
            "0.2",
        ],
        vec![
            "model",
            "--paint",
            "--theta-i",
            "30",
            "--theta-s",
            "0",
            "--haze",
            "0.1",
            "--haze-roughness",
            "0.2",
        ],
        vec![
            "model",
            "--orientation",
            "pearson-vii",
            "--alpha",
            "0.1",
            "--shape",
            "2",
            "--theta-i",
            "30",
            "--theta-s",
            "0",
        ],
        vec!["stats", "--flakes", &flakes],
        vec![
            "stats",
            "--map",
            &map,
            "--min-pixels",
            "50",
            "--z-step-um",
            "0.3",
        ],
        vec![
            "segment",
            &map,
            "--overlay",
            &ovl,
            "--overlay-max-deg",
            "30",
        ],
        vec![
            "info",
            &f.stack,
            "--peak",
            "argmax",
            "--min-signal",
            "0.01",
            "--first-page",
            "top",
        ],
        vec![
            "synth",
            "--size",
            "32",
            "--roughness-um",
            "0.1",
            "--correlation-um",
            "3",
            "--out",
            &synth_out,
        ],
        vec![
            "volume",
            "--substrate-reflectance",
            "0.5",
            "--substrate",
            "mirror",
            "--rays",
            "640",
            "--tile-um",
            "200",
            "--theta-i",
            "30",
            "--theta-s",
            "-30",
        ],
    ];
    for args in &cases {
        expect(&run(args), 0, &[], &format!("{args:?}"));
    }
}

#[test]
fn a_zero_uncertainty_is_refused_naming_line_and_column() {
    let f = files();
    // The shipped measured curve with one uncertainty set to 0: the fit used to drop the
    // whole column for it and report that the file gave no uncertainties.
    let text = fs::read_to_string(root().join("docs/figures/measured.csv")).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
    let cells: Vec<&str> = lines[40].split(',').collect();
    lines[40] = format!("{},{},{},0", cells[0], cells[1], cells[2]);
    let zero = f.dir.join("zero.csv");
    fs::write(&zero, lines.join("\n") + "\n").unwrap();
    let zero = s(&zero);
    for args in [
        vec!["fit", "--measured", &zero],
        vec!["fit", "--measured", &zero, "--nonparametric"],
        vec!["compare", "--measured", &zero],
    ] {
        let o = run(&args);
        expect(
            &o,
            2,
            &["zero.csv", "line 41", "column uncertainty", "not positive"],
            &format!("{args:?}"),
        );
    }
    // With every uncertainty positive the fit says it used them.
    let o = run(&[
        "fit",
        "--measured",
        &s(&root().join("docs/figures/measured.csv")),
        "--json",
    ]);
    expect(&o, 0, &[], "fit");
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(
        j["uncertainty_basis"]
            .as_str()
            .unwrap()
            .starts_with("the file's uncertainties"),
        "{}",
        j["uncertainty_basis"]
    );
}
