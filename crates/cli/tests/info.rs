//! `flakescatter info` end to end on real instrument files: numbers checked against the
//! files' own declarations, exit status 2 and the file named on bad input.

mod common;

use common::run;
use std::path::PathBuf;
use std::process::Output;

fn data(name: &str) -> String {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/real"))
        .join(name)
        .display()
        .to_string()
}

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * b.abs()
}

#[test]
fn json_for_the_sensofar_scan() {
    // sample-land.x3p declares SizeX 918, SizeY 256, CX/CY Increment 2.58e-06 (m);
    // Python over its data.bin counted 25292 NaN of 235008 points, mean
    // -5.352068347547571e-07 m and rms about the mean 3.4334274890691285e-05 m.
    let file = data("sample-land.x3p");
    let o = run(&["info", &file, "--json"]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["nx"], 918);
    assert_eq!(v["ny"], 256);
    assert!(close(v["dx_m"].as_f64().unwrap(), 2.58e-6, 1e-12));
    assert!(close(v["dy_m"].as_f64().unwrap(), 2.58e-6, 1e-12));
    assert_eq!(v["invalid_points"], 25292);
    assert_eq!(v["valid_points"], 235008 - 25292);
    assert!(close(
        v["mean_m"].as_f64().unwrap(),
        -5.352068347547571e-07,
        1e-9
    ));
    assert!(close(
        v["rms_m"].as_f64().unwrap(),
        3.4334274890691285e-05,
        1e-9
    ));
    assert!(close(
        v["min_m"].as_f64().unwrap(),
        -7.947348058223724e-05,
        1e-12
    ));
    assert!(close(
        v["max_m"].as_f64().unwrap(),
        5.249858077149838e-05,
        1e-12
    ));
    assert_eq!(v["format"], "x3p");
    assert_eq!(v["file"], file);
    assert_eq!(v["version"], env!("CARGO_PKG_VERSION"));
    assert_eq!(v["metadata"]["x3p.instrument.manufacturer"], "Sensofar");

    // The readable table says the same.
    let o = run(&["info", &file]);
    assert_eq!(o.status.code(), Some(0));
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(text.contains("918 x 256"), "{text}");
    assert!(text.contains("25292 invalid"), "{text}");
}

#[test]
fn text_matrix_needs_and_takes_calibration() {
    // surfacetopography-csv-1.csv: a profile whose height column carries no unit.
    let file = data("surfacetopography-csv-1.csv");
    let o = run(&["info", &file, "--json"]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("surfacetopography-csv-1.csv") && err.contains("--z-unit"),
        "{err}"
    );

    // With --z-unit nm and --pixel-um 0.5: 8 points, heights 2.10425 nm .. 1.94981 nm.
    let o = run(&[
        "info",
        &file,
        "--json",
        "--z-unit",
        "nm",
        "--pixel-um",
        "0.5",
    ]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!((v["nx"].as_u64(), v["ny"].as_u64()), (Some(8), Some(1)));
    assert!(close(v["dx_m"].as_f64().unwrap(), 0.5e-6, 1e-12));
    assert!(close(v["max_m"].as_f64().unwrap(), 2.10425e-9, 1e-12));
    assert!(close(v["min_m"].as_f64().unwrap(), 1.94981e-9, 1e-12));
    assert_eq!(v["inputs"]["z_unit"], "nm");
}

#[test]
fn bad_files_and_flags_exit_2_naming_them() {
    let dir = std::env::temp_dir().join(format!("flakescatter-info-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("ragged.txt");
    std::fs::write(
        &bad,
        "# Width: 1 um\n# Height: 1 um\n# Value units: nm\n1 2 3\n4 5\n",
    )
    .unwrap();
    let o = run(&["info", bad.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("ragged.txt") && err.contains("line 5"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");

    let o = run(&["info", dir.join("missing.x3p").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("missing.x3p"));
    std::fs::remove_dir_all(&dir).unwrap();

    // csafe-logo.x3p's main.xml does not match its md5checksum.hex (checked with md5sum).
    let logo = data("csafe-logo.x3p");
    let o = run(&["info", &logo]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("csafe-logo.x3p") && err.contains("MD5"),
        "{err}"
    );
    let o = run(&["info", &logo, "--json", "--accept-md5-mismatch"]);
    assert_eq!(o.status.code(), Some(0));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    // Declared: SizeX 741, SizeY 419.
    assert_eq!((v["nx"].as_u64(), v["ny"].as_u64()), (Some(741), Some(419)));
    assert!(v["metadata"]["x3p.md5_mismatch"].is_string());

    for flag in [
        ["--pixel-um", "-1"],
        ["--pixel-um", "1,2,3"],
        ["--z-unit", "inch"],
        // Honoured or refused: X3P heights are calibrated, so --z-unit is refused.
        ["--z-unit", "um"],
        ["--accept-md5-mismatch", "--decimal-comma"],
    ] {
        let o = run(&["info", &logo, flag[0], flag[1]]);
        assert_eq!(o.status.code(), Some(2), "{flag:?}");
        let err = String::from_utf8_lossy(&o.stderr);
        let named = if flag[1].starts_with("--") {
            flag[1]
        } else {
            flag[0]
        };
        assert!(err.contains(named), "{flag:?}: {err}");
    }
}

#[test]
fn intensity_cutoff_masks_points() {
    let dir = std::env::temp_dir().join(format!("flakescatter-info-i-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // Heights (nm) 10, 20 / 30, NaN; intensities 0.1, 0.9 / 0.5, 0.8. With cutoff 0.5 the
    // points kept are (1,0) = 20 nm and (0,1) = 30 nm (0.5 is not below the cutoff):
    // 2 valid of the 3 valid before, mean 25 nm, rms 5 nm.
    let h = dir.join("h.txt");
    std::fs::write(&h, "10 20\n30 NaN\n").unwrap();
    let i = dir.join("i.txt");
    std::fs::write(&i, "0.1 0.9\n0.5 0.8\n").unwrap();
    let (h, i) = (h.to_str().unwrap(), i.to_str().unwrap());
    let base = ["info", h, "--json", "--z-unit", "nm", "--pixel-um", "1"];
    let o = run(&[&base[..], &["--intensity", i, "--cutoff", "0.5"]].concat());
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["valid_points_before_cutoff"], 3);
    assert_eq!(v["valid_points"], 2);
    assert_eq!(v["invalid_points"], 2);
    assert!(close(v["mean_m"].as_f64().unwrap(), 25e-9, 1e-12));
    assert!(close(v["rms_m"].as_f64().unwrap(), 5e-9, 1e-9));

    // A cutoff above every intensity leaves nothing: exit 2 with the library's message.
    let o = run(&[&base[..], &["--intensity", i, "--cutoff", "2"]].concat());
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("cutoff 2 leaves 0 of 4 pixels usable"),
        "{err}"
    );
    // --cutoff without --intensity is a usage error.
    let o = run(&[&base[..], &["--cutoff", "2"]].concat());
    assert_eq!(o.status.code(), Some(2));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn decimal_commas_are_read_detected_or_refused() {
    let dir = std::env::temp_dir().join(format!("flakescatter-info-dc-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let json = |o: &Output| -> serde_json::Value {
        assert_eq!(
            o.status.code(),
            Some(0),
            "{}",
            String::from_utf8_lossy(&o.stderr)
        );
        serde_json::from_slice(&o.stdout).unwrap()
    };
    // A German export: 2 x 2 values 1.5, 2.25 / -0.5, 4 µm with decimal commas. Read as
    // decimal points it would be 4 columns (1, 5, 2, 25): nx must be 2, max 4 µm.
    let german = dir.join("de.txt");
    std::fs::write(
        &german,
        "# Breite: 2,0 µm\n# Höhe: 2,0 µm\n# Werteinheiten: µm\n1,5 2,25\n-0,5 4\n",
    )
    .unwrap();
    let g = german.to_str().unwrap();
    let v = json(&run(&["info", g, "--json"]));
    assert_eq!((v["nx"].as_u64(), v["ny"].as_u64()), (Some(2), Some(2)));
    assert!(close(v["max_m"].as_f64().unwrap(), 4e-6, 1e-12));
    assert!(close(v["min_m"].as_f64().unwrap(), -0.5e-6, 1e-12));
    assert!(close(v["dx_m"].as_f64().unwrap(), 1e-6, 1e-12));
    assert!(
        v["metadata"]["text.decimal_mark"]
            .as_str()
            .unwrap()
            .starts_with("comma (detected"),
        "{v}"
    );
    // The flag gives the same numbers and says it was the option.
    let v = json(&run(&["info", g, "--json", "--decimal-comma"]));
    assert_eq!(v["nx"], 2);
    assert_eq!(v["metadata"]["text.decimal_mark"], "comma (option)");
    assert_eq!(v["inputs"]["decimal"], "comma");

    // One token per line (`10,5`): 10.5 or two columns? Refused, naming the flag; the
    // flag settles it (1 column of 10.5 and 20.25 nm).
    let one = dir.join("one.txt");
    std::fs::write(&one, "10,5\n20,25\n").unwrap();
    let o = one.to_str().unwrap();
    let base = ["info", o, "--json", "--z-unit", "nm", "--pixel-um", "1"];
    let out = run(&base);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("one.txt") && err.contains("--decimal-comma") && err.contains("line 1"),
        "{err}"
    );
    let v = json(&run(&[&base[..], &["--decimal-comma"]].concat()));
    assert_eq!((v["nx"].as_u64(), v["ny"].as_u64()), (Some(1), Some(2)));
    assert!(close(v["max_m"].as_f64().unwrap(), 20.25e-9, 1e-12));
    let v = json(&run(&[&base[..], &["--decimal-point"]].concat()));
    assert_eq!((v["nx"].as_u64(), v["ny"].as_u64()), (Some(2), Some(2)));

    // The flag against content with decimal points is an error naming the line.
    let point = dir.join("point.txt");
    std::fs::write(&point, "1 2\n3.5 4\n").unwrap();
    let out = run(&[
        "info",
        point.to_str().unwrap(),
        "--z-unit",
        "um",
        "--pixel-um",
        "1",
        "--decimal-comma",
    ]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("line 2") && err.contains("\"3.5\""), "{err}");
    // Both flags at once is a usage error.
    let out = run(&["info", g, "--decimal-comma", "--decimal-point"]);
    assert_eq!(out.status.code(), Some(2));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn intensity_maps_need_the_same_pitch_but_no_unit() {
    let dir = std::env::temp_dir().join(format!("flakescatter-info-ip-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let write = |name: &str, text: &str| {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p.display().to_string()
    };
    let h = write(
        "h.txt",
        "# Pitch x: 0.5 µm\n# Pitch y: 0.5 µm\n# Value units: nm\n10 20\n30 40\n",
    );
    // Same shape, pitch 0.25 µm: a different area, refused with both pitches named.
    let coarse = write(
        "i-coarse.txt",
        "# Pitch x: 0.25 µm\n# Pitch y: 0.25 µm\n# Value units: a.u.\n0.1 0.9\n0.5 0.8\n",
    );
    let o = run(&["info", &h, "--intensity", &coarse, "--cutoff", "0.5"]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("0.25 µm x 0.25 µm") && err.contains("0.5 µm x 0.5 µm"),
        "{err}"
    );
    // The same pitch with an `a.u.`, an empty and no unit header: accepted; cutoff 0.5
    // keeps 20, 30, 40 nm (0.1 is below it).
    for unit in ["# Value units: a.u.\n", "# Value units:\n", ""] {
        let i = write(
            "i.txt",
            &format!("# Pitch x: 0.5 µm\n# Pitch y: 0.5 µm\n{unit}0.1 0.9\n0.5 0.8\n"),
        );
        let o = run(&["info", &h, "--json", "--intensity", &i, "--cutoff", "0.5"]);
        assert_eq!(
            o.status.code(),
            Some(0),
            "{unit:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(v["valid_points"], 3, "{unit:?}");
    }
    // A height map with an `a.u.` unit is refused, naming --z-unit.
    let au = write(
        "h-au.txt",
        "# Pitch x: 1 µm\n# Pitch y: 1 µm\n# Value units: a.u.\n1 2\n",
    );
    let o = run(&["info", &au]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("h-au.txt") && err.contains("\"a.u.\"") && err.contains("--z-unit"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn instrument_file_lists_channels_and_reads_the_one_chosen() {
    // opd-1.opd (Wyko): SurfaceTopography 1.27.1 gives 640 x 480, pitch
    // 1.9673303177114576e-7 m, 116 invalid points, mean -2.722895251054526e-7 m; the
    // directory (walked with Python's struct) has three array blocks: Raw, SecArr_0, Image.
    let file = data("instruments/opd-1.opd");
    let o = run(&["info", &file, "--json"]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["format"], "opd");
    assert_eq!((v["nx"].as_u64(), v["ny"].as_u64()), (Some(640), Some(480)));
    assert_eq!(v["invalid_points"], 116);
    assert!(close(
        v["dx_m"].as_f64().unwrap(),
        1.9673303177114576e-07,
        1e-12
    ));
    assert!(close(
        v["mean_m"].as_f64().unwrap(),
        -2.722895251054526e-07,
        1e-9
    ));
    let names: Vec<&str> = v["channels"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["Raw", "SecArr_0", "Image"]);
    assert_eq!(v["channel"], 0);
    assert_eq!(v["metadata"]["opd.Date"], "7/7/2015");
    // A channel the file does not have: exit 2, the file and its channels named.
    let o = run(&["info", &file, "--channel", "5"]);
    assert_eq!(o.status.code(), Some(2));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("opd-1.opd") && e.contains("2 = Image"), "{e}");
    // The Image array is not heights: refused as a height map, with the reason.
    let o = run(&["info", &file, "--channel", "2"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("not a height array"));
}

#[test]
fn convert_instrument_file_to_sdf_and_x3p_keeps_the_numbers() {
    // sur-2.sur (Digital Surf): SurfaceTopography and surfalize agree on 563 x 484,
    // pitch 3.4840002190321683e-6 m, 117 invalid points, mean 1.015737639515718e-5 m.
    // Converted to SDF and to X3P, `info` of each output must give the same numbers.
    let dir = std::env::temp_dir().join(format!("flakescatter-convert-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let input = data("instruments/sur-2.sur");
    for ext in ["sdf", "x3p", "txt"] {
        let out = dir.join(format!("sur-2.{ext}")).display().to_string();
        let o = run(&["convert", &input, &out]);
        assert_eq!(
            o.status.code(),
            Some(0),
            "{}",
            String::from_utf8_lossy(&o.stderr)
        );
        let o = run(&["info", &out, "--json"]);
        assert_eq!(
            o.status.code(),
            Some(0),
            "{}",
            String::from_utf8_lossy(&o.stderr)
        );
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(
            (v["nx"].as_u64(), v["ny"].as_u64()),
            (Some(563), Some(484)),
            "{ext}"
        );
        assert_eq!(v["invalid_points"], 117, "{ext}");
        assert!(
            close(v["dx_m"].as_f64().unwrap(), 3.4840002190321683e-06, 1e-12),
            "{ext}"
        );
        assert!(
            close(v["mean_m"].as_f64().unwrap(), 1.015737639515718e-05, 1e-9),
            "{ext}"
        );
    }
    // An output extension that names no writable format: exit 2, before reading.
    let o = run(&["convert", &input, &dir.join("x.gwy").display().to_string()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains(".sdf"));
    std::fs::remove_dir_all(&dir).unwrap();
}
