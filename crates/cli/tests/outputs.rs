//! No output of any command replaces an input or a file the run did not write (issue
//! 52, items 1 and 17, and the rule "no command, on any input, replaces or deletes a
//! file it did not create in this run"):
//! * every output flag of every command, naming one of the run's inputs by another
//!   spelling (`sub/..`, `./`, a symbolic link, a hard link), is refused with exit
//!   status 2 naming both, and nothing in the folder changes;
//! * every output directory (`segment --overlay`, `fit --paint --plot`,
//!   `reproduce --out`, `analyze --out`) holding an input is refused likewise, and one
//!   holding files the command did not write is refused and left as it was;
//! * a previous output directory is replaced whole (only this run's files);
//! * help and version text to a full stdout is exit status 1 with a message, to a
//!   closed pipe ends quietly.

use std::fs;
use std::path::Path;
use std::process::{Output, Stdio};

mod common;
use common::{bin, root, run_in, scratch, snapshot};

fn expect(o: &Output, code: i32, needles: &[&str], what: &str) {
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(code), "{what}: {err}");
    assert!(!err.contains("panicked"), "{what}: {err}");
    for n in needles {
        assert!(err.contains(n), "{what}: {n:?} not in: {err}");
    }
}

/// The inputs every case may use, in the scratch folder `d`.
fn inputs(d: &Path) {
    let fx = root().join("fixtures");
    fs::copy(fx.join("synth-hwhm6-rough.height.x3p"), d.join("map.x3p")).unwrap();
    fs::copy(root().join("docs/figures/measured.csv"), d.join("m.csv")).unwrap();
    fs::copy(fx.join("synth-hwhm6-rough.truth.csv"), d.join("flakes.csv")).unwrap();
    fs::copy(
        fx.join("real/paints/silver-metallic-paint2.csv"),
        d.join("paint.csv"),
    )
    .unwrap();
    fs::write(d.join("det.csv"), "theta_r_deg,phi_r_deg\n10,0\n20,0\n").unwrap();
    fs::write(d.join("p.json"), "{}\n").unwrap();
    fs::write(d.join("s.tif"), "not read: the check comes first\n").unwrap();
    fs::create_dir(d.join("sub")).unwrap();
}

/// Every output flag of every command that reads an input, as `(args, the input the
/// output names, the output's extension, the flags the message must name)`. `{IN}`
/// is the input as plainly named, `{OUT}` the output, spelled by each variant.
const FILE_CASES: &[(&str, &str, &str, &[&str])] = &[
    (
        "segment {IN} --out {OUT}",
        "map.x3p",
        "x3p",
        &["--out", "MAP"],
    ),
    (
        "segment map.x3p --intensity {IN} --cutoff 1 --out {OUT}",
        "m.csv",
        "csv",
        &["--out", "--intensity"],
    ),
    (
        "topo {IN} --theta-i 30 --out {OUT}",
        "map.x3p",
        "x3p",
        &["--out", "MAP"],
    ),
    (
        "topo map.x3p --theta-i 30 --detectors {IN} --out {OUT}",
        "det.csv",
        "csv",
        &["--out", "--detectors"],
    ),
    (
        "stats --map {IN} --out {OUT}",
        "map.x3p",
        "x3p",
        &["--out", "--map"],
    ),
    (
        "stats --map {IN} --flakes-out {OUT}",
        "map.x3p",
        "x3p",
        &["--flakes-out", "--map"],
    ),
    (
        "stats --map {IN} --per-map {OUT}",
        "map.x3p",
        "x3p",
        &["--per-map", "--map"],
    ),
    (
        "stats --flakes {IN} --out {OUT}",
        "flakes.csv",
        "csv",
        &["--out", "--flakes"],
    ),
    ("convert {IN} {OUT}", "map.x3p", "x3p", &["OUT", "IN"]),
    (
        "stack {IN} --height-out {OUT}",
        "s.tif",
        "txt",
        &["--height-out", "STACK"],
    ),
    (
        "stack {IN} --height-out h.x3p --intensity-out {OUT}",
        "s.tif",
        "txt",
        &["--intensity-out", "STACK"],
    ),
    (
        "stack {IN} --height-out h.x3p --quality-out {OUT}",
        "s.tif",
        "txt",
        &["--quality-out", "STACK"],
    ),
    (
        "compare --measured {IN} --hwhm 3 --out {OUT}",
        "m.csv",
        "csv",
        &["--out", "--measured"],
    ),
    (
        "compare --measured-multiangle {IN} --out {OUT}",
        "m.csv",
        "csv",
        &["--out", "--measured-multiangle"],
    ),
    (
        "compare --params {IN} --measured m.csv --out {OUT}",
        "p.json",
        "json",
        &["--out", "--params"],
    ),
    (
        "fit --measured {IN} --nonparametric --out {OUT}",
        "m.csv",
        "csv",
        &["--out", "--measured"],
    ),
    (
        "fit --paint --measured {IN} --params-out {OUT}",
        "paint.csv",
        "csv",
        &["--params-out", "--measured"],
    ),
    (
        "fit --paint --measured {IN} --out {OUT}",
        "paint.csv",
        "csv",
        &["--out", "--measured"],
    ),
    (
        "model --detectors {IN} --theta-i 30 --out {OUT}",
        "det.csv",
        "csv",
        &["--out", "--detectors"],
    ),
    (
        "model --orientation table --distribution {IN} --out {OUT}",
        "flakes.csv",
        "csv",
        &["--out", "--distribution"],
    ),
    (
        "model --params {IN} --out {OUT}",
        "p.json",
        "json",
        &["--out", "--params"],
    ),
    (
        "model --flake-nk {IN} --theta-i 30 --multi-angle --spectra-out {OUT}",
        "m.csv",
        "csv",
        &["--spectra-out", "--flake-nk"],
    ),
    (
        "colour --reflectance {IN} --out {OUT}",
        "m.csv",
        "csv",
        &["--out", "--reflectance"],
    ),
    (
        "volume --detectors {IN} --out {OUT}",
        "det.csv",
        "csv",
        &["--out", "--detectors"],
    ),
];

/// The spellings of the input `name` as an output with extension `ext`, made in `d`:
/// `sub/../name`, `./name` (same extension only), a symbolic link and a hard link.
fn spellings(d: &Path, name: &str, ext: &str) -> Vec<String> {
    let mut v = Vec::new();
    if name.ends_with(&format!(".{ext}")) {
        v.push(format!("sub/../{name}"));
        v.push(format!("./{name}"));
    }
    let (sym, hard) = (format!("sym.{ext}"), format!("hard.{ext}"));
    let _ = fs::remove_file(d.join(&sym));
    let _ = fs::remove_file(d.join(&hard));
    std::os::unix::fs::symlink(name, d.join(&sym)).unwrap();
    fs::hard_link(d.join(name), d.join(&hard)).unwrap();
    v.push(sym);
    v.push(hard);
    v
}

fn args(template: &str, input: &str, out: &str) -> Vec<String> {
    template
        .split_whitespace()
        .map(|a| a.replace("{IN}", input).replace("{OUT}", out))
        .collect()
}

#[test]
fn every_output_flag_naming_an_input_by_any_spelling_is_refused() {
    let d = scratch("outputs", "files");
    inputs(&d);
    for (template, input, ext, flags) in FILE_CASES {
        for out in spellings(&d, input, ext) {
            let before = snapshot(&d);
            let a = args(template, input, &out);
            let o = run_in(&d, &a);
            let what = a.join(" ");
            let mut needles = flags.to_vec();
            needles.extend(["refusing to overwrite an input", input, out.as_str()]);
            expect(&o, 2, &needles, &what);
            assert_eq!(snapshot(&d), before, "{what}: the folder changed");
        }
    }
    let _ = fs::remove_dir_all(&d);
}

/// A sample manifest `s.toml` in `d` over its map and its measured curve, named
/// `curves.csv` as in the issue (a report would write a `curves.csv` of its own).
fn sample(d: &Path) {
    let fx = root().join("fixtures");
    fs::copy(fx.join("synth-hwhm6-rough.height.x3p"), d.join("map.x3p")).unwrap();
    fs::copy(
        root().join("docs/figures/measured.csv"),
        d.join("curves.csv"),
    )
    .unwrap();
    fs::write(
        d.join("s.toml"),
        "[maps]\nfiles = [\"map.x3p\"]\n[measured]\nfiles = [\"curves.csv\"]\n[stats]\npixel_normals = false\n[models]\ntopographic = \"none\"\n",
    )
    .unwrap();
}

/// Output directories holding an input, named as the folder itself, through `sub/..`
/// and through a symbolic link: refused naming both, nothing written.
#[test]
fn every_output_directory_holding_an_input_is_refused() {
    let d = scratch("outputs", "dirs");
    inputs(&d);
    sample(&d);
    let fixtures = d.join("fx");
    fs::create_dir(&fixtures).unwrap();
    for f in fs::read_dir(root().join("fixtures")).unwrap() {
        let p = f.unwrap().path();
        if p.is_file() {
            fs::copy(&p, fixtures.join(p.file_name().unwrap())).unwrap();
        }
    }
    std::os::unix::fs::symlink(&d, d.join("here")).unwrap();
    let cases: &[(&str, &[&str])] = &[
        (
            "segment map.x3p --overlay {OUT}",
            &["--overlay", "MAP", "map.x3p"],
        ),
        (
            "fit --paint --measured paint.csv --plot {OUT}",
            &["--plot", "--measured", "paint.csv"],
        ),
        (
            "reproduce --quick --fixtures fx --out {OUT}",
            &["--out", "--fixtures"],
        ),
        ("analyze s.toml --out {OUT}", &["--out", "SAMPLE", "s.toml"]),
        (
            "analyze here/s.toml --out {OUT}",
            &["--out", "SAMPLE", "s.toml"],
        ),
    ];
    for (template, needles) in cases {
        for out in [".", "sub/..", "here", "./here/sub/.."] {
            let before = snapshot(&d);
            let a = args(template, "", out);
            let o = run_in(&d, &a);
            let what = a.join(" ");
            let mut n = needles.to_vec();
            n.extend(["holds the input", "refusing"]);
            expect(&o, 2, &n, &what);
            assert_eq!(snapshot(&d), before, "{what}: the folder changed");
        }
    }
    // The fixtures' own folder as reproduce's output.
    let before = snapshot(&d);
    let o = run_in(
        &d,
        &args("reproduce --quick --fixtures fx --out fx", "", ""),
    );
    expect(&o, 2, &["--out fx", "--fixtures"], "reproduce --out fx");
    assert_eq!(snapshot(&d), before);
    let _ = fs::remove_dir_all(&d);
}

/// An existing directory the command did not write (a user's folder, or an earlier
/// output with a file added) is refused and left as it was; an earlier output of the
/// same command is replaced whole: afterwards it holds exactly this run's files.
#[test]
fn only_an_earlier_output_is_replaced_and_then_whole() {
    let d = scratch("outputs", "owned");
    inputs(&d);
    fs::copy(d.join("map.x3p"), d.join("other.x3p")).unwrap();
    let ov = d.join("ov");
    fs::create_dir(&ov).unwrap();
    fs::write(ov.join("map.png"), "the user's picture").unwrap();
    let before = snapshot(&d);
    let o = run_in(&d, &args("segment map.x3p --overlay ov", "", ""));
    expect(
        &o,
        2,
        &["--overlay ov", "`map.png`", "refusing to replace it"],
        "user folder",
    );
    assert_eq!(snapshot(&d), before);
    // An empty folder is taken; a rerun with another map replaces the earlier overlay.
    fs::remove_file(ov.join("map.png")).unwrap();
    let o = run_in(&d, &args("segment map.x3p --overlay ov", "", ""));
    expect(&o, 0, &[], "empty folder");
    let o = run_in(&d, &args("segment other.x3p --overlay ov", "", ""));
    expect(&o, 0, &[], "rerun");
    let names: Vec<String> = snapshot(&ov).into_keys().collect();
    assert_eq!(names, [".flakescatter-output.json", "other.png"]);
    // A file added to an earlier output is never lost.
    fs::write(ov.join("notes.txt"), "mine").unwrap();
    let before = snapshot(&d);
    let o = run_in(&d, &args("segment map.x3p --overlay ov", "", ""));
    expect(&o, 2, &["`notes.txt`", "did not write"], "added file");
    assert_eq!(snapshot(&d), before);
    // Another command's output folder is not this command's to replace.
    fs::remove_file(ov.join("notes.txt")).unwrap();
    // An output file inside an output directory (which is replaced whole).
    let o = run_in(
        &d,
        &args("segment map.x3p --out ov/f.csv --overlay ov", "", ""),
    );
    expect(
        &o,
        2,
        &["--out ov/f.csv", "inside the output directory --overlay ov"],
        "inside",
    );
    let o = run_in(
        &d,
        &args("fit --paint --measured paint.csv --plot ov", "", ""),
    );
    expect(&o, 2, &["`flakescatter segment --overlay`"], "other owner");
    // An output through a symbolic link replaces the file it points to; the link stays.
    std::os::unix::fs::symlink("real.csv", d.join("link.csv")).unwrap();
    fs::write(d.join("real.csv"), "old").unwrap();
    let o = run_in(
        &d,
        &args("stats --flakes flakes.csv --out link.csv", "", ""),
    );
    expect(&o, 0, &[], "through a link");
    assert!(
        fs::symlink_metadata(d.join("link.csv"))
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert!(
        fs::read_to_string(d.join("real.csv"))
            .unwrap()
            .contains("theta")
    );
    let _ = fs::remove_dir_all(&d);
}

/// `--help`, `-h`, `--version`, `help CMD` and `CMD --help` to a full disk: exit
/// status 1 naming stdout (they exited 0 silently); to a closed pipe: quietly 0.
#[test]
fn help_and_version_to_a_full_stdout_fail_and_to_a_closed_pipe_end_quietly() {
    let cases: &[&[&str]] = &[
        &["--help"],
        &["-h"],
        &["--version"],
        &["-V"],
        &["help", "model"],
        &["model", "--help"],
        &["analyze", "-h"],
    ];
    for args in cases {
        let full = fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap();
        let o = bin()
            .args(*args)
            .stdout(Stdio::from(full))
            .output()
            .unwrap();
        expect(&o, 1, &["stdout", "No space left"], &args.join(" "));
        // A reader that closes the pipe at once.
        let mut child = bin()
            .args(*args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        drop(child.stdout.take());
        let o = child.wait_with_output().unwrap();
        assert_eq!(o.status.code(), Some(0), "{args:?}");
        assert!(
            o.stderr.is_empty(),
            "{}",
            String::from_utf8_lossy(&o.stderr)
        );
        // And to a working stdout, the text.
        let o = bin().args(*args).output().unwrap();
        assert_eq!(o.status.code(), Some(0));
        assert!(!o.stdout.is_empty());
    }
    // Usage errors still go to stderr with status 2.
    let o = bin().args(["model", "--bogus"]).output().unwrap();
    expect(&o, 2, &["--bogus"], "usage error");
}
