//! `analyze`'s report folder never loses data and never mixes runs (issue 52, items 1–4,
//! 15, 21): the sample folder as `--out` is refused with the inputs untouched; a run
//! that fails half-way leaves the previous report as it was; a rerun leaves exactly its
//! own files; a batch whose sample names collide with each other or with the batch's
//! own files is refused before any work; an optional statistic that fails is reported,
//! not fatal; a map too small for the tiles names itself, the key and the size that
//! works.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

mod common;
use common::{root, run_in, scratch, snapshot, stderr};

/// The files of a report (relative paths), without the marker and directories.
fn report_files(d: &Path) -> Vec<String> {
    snapshot(d)
        .into_keys()
        .filter(|k| !k.ends_with('/') && k != ".flakescatter-output.json")
        .collect()
}

fn summary(d: &Path) -> Value {
    serde_json::from_str(&fs::read_to_string(d.join("summary.json")).unwrap()).unwrap()
}

/// The issue's sample folder: the measured curve named `curves.csv`, a map named
/// `flakes.x3p`, the manifest beside them.
fn sample_folder(d: &Path, measured: bool) -> PathBuf {
    let fx = root().join("fixtures");
    fs::copy(
        fx.join("synth-hwhm6-rough.height.x3p"),
        d.join("flakes.x3p"),
    )
    .unwrap();
    fs::copy(
        root().join("docs/figures/measured.csv"),
        d.join("curves.csv"),
    )
    .unwrap();
    let m = d.join("s.toml");
    let measured = if measured {
        "[measured]\nfiles = [\"curves.csv\"]\n"
    } else {
        ""
    };
    let fit = if measured.is_empty() {
        "fit = false\n"
    } else {
        ""
    };
    fs::write(
        &m,
        format!(
            "[maps]\nfiles = [\"flakes.x3p\"]\n{measured}[stats]\npixel_normals = false\n[models]\ntopographic = \"none\"\n{fit}"
        ),
    )
    .unwrap();
    m
}

#[test]
fn the_sample_folder_as_out_is_refused_and_untouched() {
    let d = scratch("anaout", "here");
    sample_folder(&d, true);
    fs::create_dir(d.join("sub")).unwrap();
    std::os::unix::fs::symlink(&d, d.join("link")).unwrap();
    for out in [".", "sub/..", "link", "link/sub/.."] {
        let before = snapshot(&d);
        let o = run_in(&d, &["analyze", "s.toml", "--out", out]);
        assert_eq!(o.status.code(), Some(2), "{out}: {}", stderr(&o));
        let e = stderr(&o);
        assert!(e.contains(&format!("--out {out} holds the input")), "{e}");
        assert_eq!(snapshot(&d), before, "--out {out}");
    }
    let _ = fs::remove_dir_all(&d);
}

/// A rerun without `[measured]` drops `comparison.csv`; a rerun over another map drops
/// the old overlay; the folder then holds exactly the files `summary.json` lists (and
/// the marker); the cache of the earlier report is still reused.
#[test]
fn a_rerun_leaves_exactly_its_own_files() {
    let d = scratch("anaout", "rerun");
    let m = sample_folder(&d, true);
    let o = run_in(&d, &["analyze", "s.toml", "--out", "r"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(d.join("r/comparison.csv").is_file());
    assert!(d.join("r/overlays/flakes.png").is_file());
    sample_folder(&d, false);
    fs::rename(d.join("flakes.x3p"), d.join("other.x3p")).unwrap();
    let text = fs::read_to_string(&m)
        .unwrap()
        .replace("flakes.x3p", "other.x3p");
    fs::write(&m, text).unwrap();
    let o = run_in(&d, &["analyze", "s.toml", "--out", "r"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let s = summary(&d.join("r"));
    let mut listed: Vec<String> = s["files"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f.as_str().unwrap().to_owned())
        .collect();
    listed.sort();
    assert_eq!(report_files(&d.join("r")), listed);
    assert!(!d.join("r/comparison.csv").exists());
    assert!(!d.join("r/overlays/flakes.png").exists());
    assert!(d.join("r/overlays/other.png").is_file());
    // The same map bytes under another name: its segmentation is computed again (the
    // cache is per map name), but a third run reuses everything.
    let o = run_in(&d, &["analyze", "s.toml", "--out", "r"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(summary(&d.join("r"))["work"]["maps_reused"], 1);
    assert_eq!(summary(&d.join("r"))["work"]["models_reused"], true);
    let _ = fs::remove_dir_all(&d);
}

/// A run that fails while writing (a file-size limit, as a full disk) exits 1 and
/// leaves the previous report byte for byte, with no temporary folder beside it; an
/// earlier report holding a file it did not write (the issue's directory standing
/// where `cache/models.json` goes, with something in it) is refused, untouched.
#[test]
fn a_half_failed_run_leaves_the_previous_report() {
    let d = scratch("anaout", "half");
    sample_folder(&d, true);
    let o = run_in(&d, &["analyze", "s.toml", "--out", "r"]);
    assert!(o.status.success(), "{}", stderr(&o));
    // Another run (a changed setting) that cannot write files over 32 KiB.
    let m = d.join("s.toml");
    let text = fs::read_to_string(&m).unwrap() + "aperture_deg = 2\n";
    fs::write(&m, text).unwrap();
    let before = snapshot(&d.join("r"));
    let bin = env!("CARGO_BIN_EXE_flakescatter");
    let o = Command::new("sh")
        .current_dir(&d)
        .args([
            "-c",
            "trap '' XFSZ; ulimit -f 64; exec \"$0\" analyze s.toml --out r",
            bin,
        ])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("File too large"), "{}", stderr(&o));
    assert_eq!(snapshot(&d.join("r")), before);
    let mut left: Vec<String> = fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    left.sort();
    assert_eq!(left, ["curves.csv", "flakes.x3p", "r", "s.toml"]);
    // A directory where `cache/models.json` goes, holding a file.
    fs::remove_file(d.join("r/cache/models.json")).unwrap();
    fs::create_dir(d.join("r/cache/models.json")).unwrap();
    fs::write(d.join("r/cache/models.json/keep"), "x").unwrap();
    let before = snapshot(&d);
    let o = run_in(&d, &["analyze", "s.toml", "--out", "r"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("`cache/models.json/keep`"),
        "{}",
        stderr(&o)
    );
    assert_eq!(snapshot(&d), before);
    let _ = fs::remove_dir_all(&d);
}

/// Batch names that collide — with the batch's own files (`samples.csv`, `index.md`,
/// also in another case) or with each other apart from case — are refused before any
/// work: nothing is created.
#[test]
fn batch_names_that_collide_are_refused_before_any_work() {
    let d = scratch("anaout", "names");
    sample_folder(&d, false);
    let manifest = fs::read_to_string(d.join("s.toml")).unwrap();
    let write = |file: &str, name: &str| {
        fs::write(d.join(file), format!("name = \"{name}\"\n{manifest}")).unwrap();
    };
    for (a, b, needle) in [
        ("samples.csv", "x", "`samples.csv`"),
        ("Index.MD", "x", "`index.md`"),
        ("index.html", "x", "`index.html`"),
        ("A", "a", "`A` and `a`"),
        ("same", "same", "both named `same`"),
    ] {
        write("a.toml", a);
        write("b.toml", b);
        let before = snapshot(&d);
        let o = run_in(&d, &["analyze", "a.toml", "b.toml", "--out", "out"]);
        assert_eq!(o.status.code(), Some(2), "{a} {b}: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{}", stderr(&o));
        assert_eq!(snapshot(&d), before);
    }
    // A clean batch, then a second one with other samples: the folder holds exactly the
    // second batch (the first's sample folders removed) and its comparison.
    write("a.toml", "one");
    write("b.toml", "two");
    let o = run_in(&d, &["analyze", "a.toml", "b.toml", "--out", "out"]);
    assert!(o.status.success(), "{}", stderr(&o));
    write("b.toml", "three");
    let o = run_in(&d, &["analyze", "a.toml", "b.toml", "--out", "out"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut top: Vec<String> = fs::read_dir(d.join("out"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    top.sort();
    assert_eq!(
        top,
        [
            ".flakescatter-output.json",
            "index.html",
            "index.md",
            "one",
            "samples.csv",
            "three"
        ]
    );
    // A batch folder is not a single report, nor the reverse.
    let o = run_in(&d, &["analyze", "a.toml", "--out", "out"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let _ = fs::remove_dir_all(&d);
}

/// The shipped smooth fixture alone with its intensity cutoff and the defaults: the
/// pixel-level histogram fit fails (its 0.3 µm z step leaves most windows flat); the
/// report is still written with that statistic marked failed, exit status 0, one
/// warning, and the cause said once.
#[test]
fn the_smooth_fixture_alone_is_reported_with_its_failed_statistic() {
    let d = scratch("anaout", "fixture");
    let fx = root().join("fixtures").canonicalize().unwrap();
    fs::write(
        d.join("s.toml"),
        format!(
            "[maps]\nfiles = [\"{0}/synth-hwhm3-smooth.height.x3p\"]\nintensity_suffix = \".intensity\"\ncutoff = 0.49\n[models]\nfit = false\n",
            fx.display()
        ),
    )
    .unwrap();
    let o = run_in(&d, &["analyze", "s.toml", "--out", "r"]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(0), "{e}");
    assert_eq!(
        e.matches("lower end of the searched range").count(),
        1,
        "{e}"
    );
    let s = summary(&d.join("r"));
    assert_eq!(
        s["failed_statistics"][0]["statistic"],
        "statistics.pixel_level.histogram_fit"
    );
    let md = fs::read_to_string(d.join("r/index.md")).unwrap();
    assert!(md.contains("Statistics that failed"), "{md}");
    let _ = fs::remove_dir_all(&d);
}

/// A 64 × 64-pixel map (11.5 µm): the warning names the map, its size, the key
/// `models.tile_um` and the sizes that work; a map smaller than one flake
/// (8 × 8 pixels) is refused naming the map and `instrument.min_pixels`.
#[test]
fn a_tiny_map_names_itself_the_key_and_the_size_that_works() {
    let d = scratch("anaout", "tiny");
    for (size, code) in [("64", 0), ("8", 2)] {
        let o = run_in(
            &d,
            &[
                "synth",
                "--size",
                size,
                "--hwhm",
                "6",
                "--z-step-um",
                "0.001",
                "--out",
                "tiny.x3p",
            ],
        );
        assert!(o.status.success(), "{}", stderr(&o));
        fs::write(
            d.join("t.toml"),
            "[maps]\nfiles = [\"tiny.x3p\"]\n[models]\nfit = false\n",
        )
        .unwrap();
        let o = run_in(&d, &["analyze", "t.toml", "--out", "r"]);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(code), "{e}");
        let needles: &[&str] = if code == 0 {
            &[
                "map tiny (64 × 64 pixels, 11.5 × 11.5 µm)",
                "`models.tile_um` = 32 µm",
                "at least 2 tiles (`tile_um` ≤",
                "maps at least 64 µm (356 pixels)",
            ]
        } else {
            &[
                "map tiny (8 × 8 pixels, 1.4 × 1.4 µm)",
                "`instrument.min_pixels` = 100",
                "10 × 10 pixels",
            ]
        };
        for n in needles {
            assert!(e.contains(n), "{n:?} not in: {e}");
        }
    }
    let _ = fs::remove_dir_all(&d);
}
