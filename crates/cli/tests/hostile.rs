//! Hostile use of every subcommand through the output layer (issue 13, items 2, 3, 8,
//! 10, 11, 15, 17): outputs that name an input or each other, outputs that cannot be
//! written, a closed or full stdout, flags that do not apply, numbers out of range.
//! Each case checks the exit status, that the message names the flag or file, and that
//! nothing is left behind (no output file, no temporary file, input untouched).

mod common;

use common::{bin, fixtures, run, s, scratch};
use std::fs;
use std::path::Path;
use std::process::{Output, Stdio};

/// The binary run with `args` and its stdout on a full disk (`/dev/full`).
fn run_to_full_stdout(args: &[&str]) -> Output {
    let full = fs::OpenOptions::new()
        .write(true)
        .open("/dev/full")
        .unwrap();
    bin().args(args).stdout(Stdio::from(full)).output().unwrap()
}

fn measured() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../docs/figures/measured.csv")
        .display()
        .to_string()
}

fn listing(d: &Path) -> Vec<String> {
    let mut v: Vec<String> = fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// Exit status `code`, every needle in stderr, no panic.
fn expect(o: &Output, code: i32, needles: &[&str]) {
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(code), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    for n in needles {
        assert!(err.contains(n), "{n:?} not in: {err}");
    }
}

#[test]
fn an_output_that_is_an_input_is_refused_and_the_input_untouched() {
    let d = scratch("hostile", "inout");
    let map = d.join("map.x3p");
    fs::copy(fixtures().join("synth-hwhm6-rough.height.x3p"), &map).unwrap();
    let original = fs::read(&map).unwrap();
    // Same file by another spelling, and through a hard link (same device and inode).
    fs::hard_link(&map, d.join("link.x3p")).unwrap();
    let dotted = format!("{}/./map.x3p", d.display());
    let link = d.join("link.x3p");
    let cases: Vec<Vec<&str>> = vec![
        vec!["segment", s(&map), "--out", &dotted],
        vec!["segment", s(&map), "--out", s(&link)],
        vec!["topo", s(&map), "--theta-i", "30", "--out", s(&map)],
        vec!["stats", "--map", s(&map), "--out", s(&map)],
        vec!["stats", "--map", s(&map), "--flakes-out", s(&map)],
        vec!["info", s(&map)],
    ];
    for (k, args) in cases.iter().enumerate() {
        let o = run(args);
        if args[0] == "info" {
            assert_eq!(o.status.code(), Some(0));
            continue;
        }
        expect(&o, 2, &["refusing to overwrite an input", "map.x3p"]);
        assert_eq!(fs::read(&map).unwrap(), original, "case {k}: {args:?}");
        assert_eq!(listing(&d), ["link.x3p", "map.x3p"], "case {k}");
    }
    // compare: --out naming the measured file or the model file.
    let m = d.join("m.csv");
    fs::copy(measured(), &m).unwrap();
    let before = fs::read(&m).unwrap();
    let o = run(&["compare", "--measured", s(&m), "--out", s(&m)]);
    expect(&o, 2, &["--out", "--measured"]);
    let o = run(&[
        "fit",
        "--measured",
        s(&m),
        "--nonparametric",
        "--out",
        s(&m),
    ]);
    expect(&o, 2, &["--out", "--measured"]);
    assert_eq!(fs::read(&m).unwrap(), before);
    fs::remove_dir_all(&d).ok();
}

#[test]
fn two_outputs_naming_one_file_are_refused_before_any_work() {
    let d = scratch("hostile", "twice");
    let a = d.join("a.x3p");
    let o = run(&[
        "synth",
        "--size",
        "32",
        "--out",
        s(&a),
        "--intensity-out",
        s(&a),
    ]);
    expect(&o, 2, &["--out", "--intensity-out", "same file"]);
    let f = d.join("f.svg");
    let o = run(&["model", "--theta-i", "30", "--out", s(&f), "--plot", s(&f)]);
    expect(&o, 2, &["--out", "--plot", "same file"]);
    // Two uses of stdout.
    let o = run(&["synth", "--size", "32", "--truth-out", "-", "--json"]);
    expect(&o, 2, &["--truth-out -", "--json"]);
    let o = run(&["model", "--out", "-", "--json"]);
    expect(&o, 2, &["--out -", "--json"]);
    assert!(listing(&d).is_empty(), "{:?}", listing(&d));
    fs::remove_dir_all(&d).ok();
}

#[test]
fn bad_targets_are_refused_before_anything_is_written() {
    let d = scratch("hostile", "targets");
    let x = d.join("x.csv");
    // A plot name with an unknown extension: x.csv must not be written first.
    let o = run(&[
        "model",
        "--theta-i",
        "30",
        "--out",
        s(&x),
        "--plot",
        s(&d.join("p.jpg")),
    ]);
    expect(&o, 2, &["--plot", "p.jpg", ".svg or .png"]);
    let o = run(&[
        "model",
        "--theta-i",
        "30",
        "--out",
        s(&x),
        "--plot",
        s(&d.join("p")),
    ]);
    expect(&o, 2, &["--plot"]);
    // A plot or a map cannot go to stdout.
    let o = run(&["model", "--theta-i", "30", "--out", s(&x), "--plot", "-"]);
    expect(&o, 2, &["--plot -", "stdout"]);
    let o = run(&["synth", "--size", "32", "--out", "-"]);
    expect(&o, 2, &["--out -", "stdout"]);
    // A map output with an unknown extension.
    let o = run(&["synth", "--size", "32", "--out", s(&d.join("m.dat"))]);
    expect(&o, 2, &["--out", "m.dat", ".x3p", ".txt"]);
    // A directory where a file is wanted, a missing parent directory: cannot be written.
    let o = run(&["model", "--theta-i", "30", "--out", s(&d)]);
    expect(&o, 1, &["--out", "directory"]);
    let o = run(&[
        "model",
        "--theta-i",
        "30",
        "--out",
        s(&d.join("no/such/x.csv")),
    ]);
    expect(&o, 1, &["--out", "does not exist"]);
    let o = run(&[
        "topo",
        s(&fixtures().join("synth-hwhm6-rough.height.x3p")),
        "--plot",
        s(&d.join("none/p.svg")),
    ]);
    expect(&o, 1, &["--plot", "does not exist"]);
    assert!(listing(&d).is_empty(), "{:?}", listing(&d));
    fs::remove_dir_all(&d).ok();
}

#[test]
fn reproduce_without_fixtures_leaves_no_directory() {
    let d = scratch("hostile", "repro");
    let out = d.join("figs");
    let o = run(&[
        "reproduce",
        "--quick",
        "--out",
        s(&out),
        "--fixtures",
        s(&d.join("nofix")),
    ]);
    expect(&o, 2, &["--fixtures", "synth-hwhm3-smooth"]);
    assert!(listing(&d).is_empty(), "{:?}", listing(&d));
    // --out naming the fixtures folder itself is refused.
    let o = run(&[
        "reproduce",
        "--quick",
        "--out",
        s(&fixtures()),
        "--fixtures",
        s(&fixtures()),
    ]);
    expect(&o, 2, &["--out", "--fixtures"]);
    // An --out that is a file.
    let file = d.join("file");
    fs::write(&file, "x").unwrap();
    let o = run(&[
        "reproduce",
        "--quick",
        "--out",
        s(&file),
        "--fixtures",
        s(&fixtures()),
    ]);
    expect(&o, 1, &["--out", "not a directory"]);
    assert_eq!(listing(&d), ["file"]);
    fs::remove_dir_all(&d).ok();
}

#[test]
fn a_closed_stdout_ends_quietly_and_a_full_one_is_exit_1() {
    let big: Vec<Vec<&str>> = vec![
        vec!["model"],
        vec!["model", "--json"],
        vec![
            "compare",
            "--measured",
            "MEASURED",
            "--hwhm",
            "6",
            "--out",
            "-",
        ],
        vec!["synth", "--size", "128", "--truth-out", "-"],
        vec!["info", "MAP"],
        vec!["--help"],
    ];
    let m = measured();
    let map = fixtures()
        .join("synth-hwhm6-rough.height.x3p")
        .display()
        .to_string();
    for args in &big {
        let args: Vec<&str> = args
            .iter()
            .map(|a| match *a {
                "MEASURED" => m.as_str(),
                "MAP" => map.as_str(),
                x => x,
            })
            .collect();
        // The reader goes away before anything is read.
        let mut child = bin()
            .args(&args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        drop(child.stdout.take());
        let o = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(0), "{args:?}: {err}");
        assert!(err.is_empty(), "{args:?}: quiet, got {err}");
        if args[0] == "--help" {
            continue;
        }
        // A full disk: exit 1 naming stdout.
        let o = run_to_full_stdout(&args);
        expect(&o, 1, &["stdout"]);
    }
    // A full disk behind a file name (a device: written in place, never replaced).
    let o = run(&["model", "--theta-i", "30", "--out", "/dev/full"]);
    expect(&o, 1, &["/dev/full"]);
    assert!(Path::new("/dev/full").exists());
}

#[test]
fn successful_writes_say_what_they_wrote_and_json_is_the_summary() {
    let d = scratch("hostile", "wrote");
    let out = d.join("t.csv");
    let plot = d.join("t.svg");
    let o = run(&[
        "topo",
        s(&fixtures().join("synth-hwhm6-rough.height.x3p")),
        "--theta-i",
        "30,60",
        "--out",
        s(&out),
        "--plot",
        s(&plot),
        "--json",
    ]);
    expect(&o, 0, &["wrote", "t.csv (562 rows)", "t.svg"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(
        err.lines().filter(|l| l.starts_with("wrote")).count(),
        1,
        "{err}"
    );
    // With --out FILE, --json prints the summary, not the rows.
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(j.get("rows").is_none());
    assert_eq!(j["row_count"], 562);
    assert_eq!(j["counts"]["maps"], 1);
    // The CSV has 2 × 281 rows; no temporary file is left beside it.
    assert_eq!(fs::read_to_string(&out).unwrap().lines().count(), 563);
    assert_eq!(listing(&d), ["t.csv", "t.svg"]);
    fs::remove_dir_all(&d).ok();
}

#[test]
fn negative_and_odd_numbers_parse_and_are_refused_with_their_range() {
    let m = measured();
    let cases: Vec<(Vec<&str>, &[&str])> = vec![
        (
            vec!["fit", "--measured", &m, "--nonparametric", "--lambda", "-1"],
            &["--lambda", "-1", ">= 0"],
        ),
        (
            vec!["fit", "--measured", &m, "--hwhm-start", "-2"],
            &["--hwhm-start -2", "(0, 60)"],
        ),
        (vec!["model", "--n", "-1"], &["--n -1", ">= 1"]),
        (vec!["model", "--n", "nan"], &["--n", ">= 1"]),
        (
            vec!["model", "--aperture", "-1"],
            &["--aperture -1", "[0, 20] degrees"],
        ),
        (vec!["model", "--hwhm", "-3"], &["--hwhm -3", "degrees"]),
        (
            vec!["model", "--theta-i", "-5"],
            &["--theta-i", "-5°", "[0, 90)"],
        ),
        (
            vec!["model", "--theta-s", "-95"],
            &["--theta-s", "(-90, 90)"],
        ),
        (vec!["model", "--theta-s", ""], &["--theta-s", "empty"]),
        (
            vec!["model", "--theta-s", "-70:70:0.00001"],
            &["--theta-s", "more than"],
        ),
        (vec!["model", "--flake-index", "-1,inf"], &["--flake-index"]),
        (
            vec![
                "model",
                "--theta-i",
                "0:89:0.0001",
                "--theta-s",
                "-89:89:0.001",
            ],
            &["--theta-i", "rows", "limit"],
        ),
        (
            vec!["stats", "--flakes", "x.csv", "--bin", "-1"],
            &["--bin -1", "degrees"],
        ),
        (vec!["synth", "--hwhm", "0"], &["--hwhm 0", "degrees"]),
        (
            vec!["synth", "--pixel-um", "0", "--size", "8"],
            &["--pixel-um", "µm"],
        ),
        (vec!["synth", "--film-um", "-1"], &["--film-um -1"]),
        (vec!["synth", "--size", "-4"], &["--size"]),
        (vec!["synth", "--count", "-4"], &["--count"]),
        (vec!["synth", "--seed", "-1"], &["--seed"]),
        (vec!["topo", "m.x3p", "--window", "-1"], &["--window"]),
        (vec!["topo", "m.x3p", "--tile-um", "-1"], &["--tile-um -1"]),
        (
            vec!["segment", "m.x3p", "--min-pixels", "-3"],
            &["--min-pixels"],
        ),
        (
            vec![
                "segment",
                "m.x3p",
                "--intensity",
                "i.x3p",
                "--cutoff",
                "nan",
            ],
            &["--cutoff"],
        ),
    ];
    for (args, needles) in cases {
        let o = run(&args);
        expect(&o, 2, needles);
    }
}

#[test]
fn compare_and_fit_select_measured_angles_or_refuse() {
    let m = measured();
    // The file has θi = 30 and 60 with θs every 0.5° from -70 to 70 (281 each).
    let o = run(&[
        "compare",
        "--measured",
        &m,
        "--hwhm",
        "6",
        "--theta-i",
        "30",
        "--json",
    ]);
    expect(&o, 0, &["using 281 of 562 measured points"]);
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["incidences"].as_array().unwrap().len(), 1);
    assert_eq!(j["incidences"][0]["theta_i_deg"], 30.0);
    assert_eq!(j["inputs"]["selection"]["points_used"], 281);
    // θs from -40 to 40 in 1° steps at θi 30: 81 measured points.
    let o = run(&[
        "fit",
        "--measured",
        &m,
        "--theta-i",
        "30",
        "--theta-s",
        "-40:40:1",
        "--json",
    ]);
    expect(&o, 0, &["using 81 of 562"]);
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["inputs"]["selection"]["points_used"], 81);
    assert_eq!(j["scales"].as_array().unwrap().len(), 1);
    // The non-parametric histogram to stdout (one use of stdout, not two).
    let o = run(&[
        "fit",
        "--measured",
        &m,
        "--theta-i",
        "30",
        "--nonparametric",
        "--out",
        "-",
    ]);
    expect(&o, 0, &[]);
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(
        text.starts_with("theta_lo_deg,theta_hi_deg,area_fraction,p_per_rad,p_tilde\n"),
        "{text}"
    );
    // An incidence the file does not have, and a selection that matches nothing.
    let o = run(&["compare", "--measured", &m, "--theta-i", "45"]);
    expect(&o, 2, &["--theta-i", "45", "30, 60"]);
    let o = run(&["fit", "--measured", &m, "--theta-s", "0.25"]);
    expect(&o, 2, &["--theta-s", "match no measured point"]);
}

#[test]
fn compare_with_a_model_file_refuses_model_flags_and_names_dark_detectors() {
    let d = scratch("hostile", "cmpmodel");
    let model = d.join("topo.csv");
    let o = run(&[
        "topo",
        s(&fixtures().join("synth-hwhm6-rough.height.x3p")),
        "--theta-i",
        "30,60",
        "--clearcoat",
        "--out",
        s(&model),
    ]);
    expect(&o, 0, &[]);
    let m = measured();
    for flag in [
        ["--n", "1.4"],
        ["--clearcoat", ""],
        ["--no-clearcoat", ""],
        ["--weighting", "paper-printed"],
    ] {
        let mut args = vec!["compare", "--measured", &m, "--model", s(&model), flag[0]];
        if !flag[1].is_empty() {
            args.push(flag[1]);
        }
        let o = run(&args);
        expect(&o, 2, &["--model", flag[0]]);
    }
    // One fixture map leaves many detectors without a ray: they are counted and named.
    let o = run(&["compare", "--measured", &m, "--model", s(&model), "--json"]);
    expect(&o, 0, &["model value of zero", "θi 30 θs"]);
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let dark = j["points_without_model"].as_array().unwrap();
    let zero_rows = fs::read_to_string(&model)
        .unwrap()
        .lines()
        .skip(1)
        .filter(|l| l.split(',').nth(7) == Some("0"))
        .count();
    assert!(!dark.is_empty());
    assert_eq!(
        dark.len(),
        zero_rows,
        "every model row with zero rays is a dark point"
    );
    fs::remove_dir_all(&d).ok();
}

#[test]
fn multi_angle_honours_one_incidence_and_echoes_it() {
    let o = run(&["model", "--multi-angle", "--theta-i", "30", "--json"]);
    expect(&o, 0, &[]);
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["theta_i_deg"], 30.0);
    // θs = −θi + aspecular for aspecular −15, 15, 25, 45, 75, 110.
    let ts: Vec<f64> = j["readouts"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["theta_s_deg"].as_f64().unwrap())
        .collect();
    assert_eq!(ts, [-45.0, -15.0, -5.0, 15.0, 45.0, 80.0]);
    // Default: the standard 45°.
    let o = run(&["model", "--multi-angle", "--json"]);
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["theta_i_deg"], 45.0);
    // Several incidences, an incidence whose 110° detector is below the horizon, and
    // flags that do not apply.
    expect(
        &run(&["model", "--multi-angle", "--theta-i", "30,60"]),
        2,
        &["--theta-i 30,60", "one incidence"],
    );
    expect(
        &run(&["model", "--multi-angle", "--theta-i", "10"]),
        2,
        &["horizon"],
    );
    expect(
        &run(&["model", "--multi-angle", "--theta-s", "0"]),
        2,
        &["--theta-s"],
    );
}

#[test]
fn angles_print_as_typed() {
    // 0.1° steps: 0.30000000000000004 in floating point, printed as typed.
    let o = run(&["model", "--theta-i", "30", "--theta-s", "0:1:0.1"]);
    expect(&o, 0, &[]);
    let text = String::from_utf8(o.stdout).unwrap();
    let ts: Vec<&str> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap())
        .collect();
    assert_eq!(
        ts,
        [
            "0", "0.1", "0.2", "0.3", "0.4", "0.5", "0.6", "0.7", "0.8", "0.9", "1"
        ]
    );
    assert!(text.lines().skip(1).all(|l| l.starts_with("30,")), "{text}");
    // JSON echoes the same numbers.
    let o = run(&[
        "model",
        "--theta-i",
        "29.999",
        "--theta-s",
        "-29.999",
        "--json",
    ]);
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["rows"][0]["theta_i_deg"], 29.999);
    assert_eq!(j["rows"][0]["theta_s_deg"], -29.999);
}

#[test]
fn standard_errors_that_cannot_be_estimated_are_empty_cells_with_one_warning() {
    // One tile of 1e9 µm covers the whole 92 µm map: no spread between tiles.
    let map = fixtures().join("synth-hwhm6-rough.height.x3p");
    let o = run(&[
        "topo",
        s(&map),
        "--theta-i",
        "30",
        "--theta-s",
        "-30,0",
        "--tile-um",
        "1e9",
    ]);
    expect(&o, 0, &["standard errors not estimable", "--tile-um"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.matches("warning:").count(), 1, "{err}");
    let text = String::from_utf8(o.stdout).unwrap();
    for row in text.lines().skip(1) {
        assert!(row.ends_with(','), "empty std_err cell: {row}");
        assert!(!row.contains("NaN"), "{row}");
    }
    let o = run(&[
        "topo",
        s(&map),
        "--theta-i",
        "30",
        "--theta-s",
        "-30",
        "--tile-um",
        "1e9",
        "--json",
    ]);
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(j["rows"][0]["std_err"].is_null());
    assert_eq!(j["warnings"].as_array().unwrap().len(), 1);
}

#[test]
fn a_failure_after_the_work_leaves_no_output() {
    // No ray reaches detectors at 80° and 85°: the relative curve has nothing to draw on
    // a log axis, so the plot fails after the model ran; the CSV must not appear either.
    let d = scratch("hostile", "late");
    let o = run(&[
        "topo",
        s(&fixtures().join("synth-hwhm6-rough.height.x3p")),
        "--theta-i",
        "30",
        "--theta-s",
        "80,85",
        "--out",
        s(&d.join("x.csv")),
        "--plot",
        s(&d.join("p.svg")),
    ]);
    expect(&o, 2, &["p.svg", "nothing to draw"]);
    assert!(listing(&d).is_empty(), "{:?}", listing(&d));
    fs::remove_dir_all(&d).ok();
}

/// `model` writes a table without a plot or Mueller columns as it computes it, in waves
/// of rows: a grid of many waves (144,261 rows) read for one line and closed ends
/// quietly; a full stdout or target fails naming it once rows have been written; a
/// model error at a late incidence comes before any row (nothing on stdout, no file).
#[test]
fn a_streamed_table_fails_cleanly_at_any_point() {
    let grid = ["model", "--theta-i", "0:80:1", "--theta-s", "-89:89:0.1"];
    for json in [false, true] {
        let mut args = grid.to_vec();
        if json {
            args.push("--json");
        }
        let mut child = bin()
            .args(&args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let mut first = String::new();
        let mut reader = std::io::BufReader::new(child.stdout.take().unwrap());
        std::io::BufRead::read_line(&mut reader, &mut first).unwrap();
        drop(reader);
        let o = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(0), "{args:?}: {err}");
        assert!(err.is_empty(), "{args:?}: quiet, got {err}");
        assert_eq!(
            first,
            if json {
                "{\n"
            } else {
                "theta_i_deg,theta_s_deg,phi_s_deg,aperture_deg,brdf_per_sr,reflectance,relative\n"
            }
        );
        let o = run_to_full_stdout(&args);
        expect(&o, 1, &["writing stdout", "No space left"]);
    }
    let mut args = grid.to_vec();
    args.extend(["--out", "/dev/full"]);
    let o = run(&args);
    expect(&o, 1, &["writing /dev/full", "No space left"]);
    // The constant-integrand approximation holds for a 0.7° hwhm in a 3° cone up to
    // about 50° of incidence, not at 60°: 50 incidences of rows (89,050, more than a
    // wave) would come before the error if the checks were not all made first.
    let d = scratch("hostile", "stream-late");
    let out = d.join("x.csv");
    let late = [
        "model",
        "--cone",
        "constant",
        "--hwhm",
        "0.7",
        "--aperture",
        "3",
        "--theta-i",
        "0:70:1",
        "--theta-s",
        "-89:89:0.1",
    ];
    for extra in [&[][..], &["--json"], &["--out", s(&out)]] {
        let mut args = late.to_vec();
        args.extend(extra);
        let o = run(&args);
        expect(
            &o,
            2,
            &["constant-integrand approximation", "exact cone integral"],
        );
        assert!(o.stdout.is_empty(), "{extra:?}");
        assert!(listing(&d).is_empty(), "{:?}", listing(&d));
    }
    fs::remove_dir_all(&d).ok();
}
