//! Map inputs that would count one measurement wrongly (issue 52, items 6, 7, 8 and the
//! empty `--height-suffix` of item 23): a map given as its own intensity image, one map
//! pooled twice (a byte-identical copy, a hard link, the same file by another name), a
//! dangling symbolic link in a maps folder or a pattern, and an empty height suffix.
//! Each is exit status 2 naming the files (or flag), before any output is written.

use std::path::{Path, PathBuf};
use std::process::Output;

mod common;
use common::{fixture, run, s, scratch};

/// Exit status 2, every needle in stderr, no panic; the stderr.
fn refused(o: &Output, needles: &[&str]) -> String {
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    for n in needles {
        assert!(err.contains(n), "{n:?} not in: {err}");
    }
    err
}

/// `d/<name>.height.x3p` and `d/<name>.intensity.x3p`, copies of the hwhm-3 fixture.
fn copy_pair(d: &Path, name: &str) -> (PathBuf, PathBuf) {
    let h = d.join(format!("{name}.height.x3p"));
    let i = d.join(format!("{name}.intensity.x3p"));
    std::fs::copy(fixture("synth-hwhm3-smooth.height.x3p"), &h).unwrap();
    std::fs::copy(fixture("synth-hwhm3-smooth.intensity.x3p"), &i).unwrap();
    (h, i)
}

#[test]
fn a_map_is_never_its_own_intensity_image() {
    let d = scratch("mapinputs", "own");
    let (map, _) = copy_pair(&d, "a");
    let sym = d.join("sym.x3p");
    std::os::unix::fs::symlink(&map, &sym).unwrap();
    let hard = d.join("hard.x3p");
    std::fs::hard_link(&map, &hard).unwrap();
    std::fs::create_dir_all(d.join("sub")).unwrap();
    let dotted = d.join("sub/../a.height.x3p");
    let out = d.join("flakes.csv");
    for other in [&map, &sym, &hard, &dotted] {
        let o = run(&["info", s(&map), "--intensity", s(other), "--cutoff", "0.49"]);
        refused(&o, &[s(other), "height map file itself"]);
        let o = run(&[
            "segment",
            s(&map),
            "--intensity",
            s(other),
            "--cutoff",
            "0.49",
            "--out",
            s(&out),
        ]);
        refused(&o, &[s(other), "height map file itself"]);
        let o = run(&[
            "stats",
            "--map",
            s(&map),
            "--intensity",
            s(other),
            "--cutoff",
            "0.49",
        ]);
        refused(&o, &["height map file itself"]);
        let o = run(&["topo", s(&map), "--intensity", s(other), "--cutoff", "0.49"]);
        refused(&o, &["height map file itself"]);
    }
    // A byte-identical copy of the map as its intensity image.
    let copy = d.join("copy.x3p");
    std::fs::copy(&map, &copy).unwrap();
    let o = run(&["info", s(&map), "--intensity", s(&copy), "--cutoff", "0.49"]);
    refused(&o, &[s(&copy), "byte-identical copy"]);
    let o = run(&[
        "stats",
        "--map",
        s(&map),
        "--intensity",
        s(&copy),
        "--cutoff",
        "0.49",
    ]);
    refused(&o, &[s(&copy), "byte-identical copy"]);
    // The suffix rule pairing each map with itself, or with a link to itself.
    let o = run(&[
        "segment",
        s(&map),
        "--intensity-suffix",
        ".height",
        "--cutoff",
        "0.49",
        "--out",
        s(&out),
    ]);
    refused(&o, &["--intensity-suffix", "height suffix itself"]);
    let b = d.join("b.height.x3p");
    std::fs::copy(&map, &b).unwrap();
    std::os::unix::fs::symlink(&b, d.join("b.mirror.x3p")).unwrap();
    let o = run(&[
        "segment",
        s(&b),
        "--intensity-suffix",
        ".mirror",
        "--cutoff",
        "0.49",
        "--out",
        s(&out),
    ]);
    refused(&o, &["b.mirror.x3p", "height map file itself"]);
    assert!(!out.exists());
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn one_map_pooled_twice_is_refused_unless_allowed() {
    let d = scratch("mapinputs", "dup");
    let (a, _) = copy_pair(&d, "a");
    let (b, _) = copy_pair(&d, "b");
    let hard = d.join("c.height.x3p");
    std::fs::hard_link(&a, &hard).unwrap();
    std::fs::copy(
        fixture("synth-hwhm3-smooth.intensity.x3p"),
        d.join("c.intensity.x3p"),
    )
    .unwrap();
    let stats = |maps: &[&Path], extra: &[&str]| {
        let mut args = vec!["stats", "--map"];
        args.extend(maps.iter().map(|p| s(p)));
        args.extend([
            "--intensity-suffix",
            ".intensity",
            "--cutoff",
            "0.49",
            "--json",
        ]);
        args.extend(extra);
        run(&args)
    };
    // A byte-identical copy, and the same file through a hard link.
    refused(
        &stats(&[&a, &b], &[]),
        &[s(&a), s(&b), "byte-identical", "--allow-duplicate-maps"],
    );
    refused(&stats(&[&a, &hard], &[]), &[s(&a), s(&hard), "same file"]);
    // In a folder, and in a pattern.
    refused(
        &stats(&[&d], &[]),
        &["byte-identical", "--allow-duplicate-maps"],
    );
    let pattern = format!("{}/*.height.x3p", d.display());
    refused(&stats(&[Path::new(&pattern)], &[]), &["byte-identical"]);
    // segment pools too.
    let out = d.join("flakes.csv");
    let o = run(&[
        "segment",
        s(&a),
        s(&b),
        "--intensity-suffix",
        ".intensity",
        "--cutoff",
        "0.49",
        "--out",
        s(&out),
    ]);
    refused(&o, &["byte-identical"]);
    assert!(!out.exists());
    // Allowed: pooled twice, with a warning; twice the flakes of one map.
    let one = stats(&[&a], &[]);
    assert!(
        one.status.success(),
        "{}",
        String::from_utf8_lossy(&one.stderr)
    );
    let two = stats(&[&a, &b], &["--allow-duplicate-maps"]);
    let err = String::from_utf8_lossy(&two.stderr);
    assert!(two.status.success(), "{err}");
    assert!(err.contains("pooled twice"), "{err}");
    let n = |o: &Output| {
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        v["flakes"].as_u64().unwrap()
    };
    assert_eq!(n(&two), 2 * n(&one));
    // topo keeps repeats with a warning already: the flag is refused there.
    let o = run(&["topo", s(&a), "--allow-duplicate-maps"]);
    refused(&o, &["--allow-duplicate-maps"]);
    // analyze: refused up front naming the manifest key, nothing written.
    let manifest = d.join("sample.toml");
    std::fs::write(
        &manifest,
        "[maps]\nfiles = [\"a.height.x3p\", \"b.height.x3p\"]\nintensity_suffix = \".intensity\"\ncutoff = 0.49\n[models]\nfit = false\n",
    )
    .unwrap();
    let report = d.join("report");
    let o = run(&["analyze", s(&manifest), "--out", s(&report)]);
    refused(&o, &["byte-identical", "maps.allow_duplicates"]);
    assert!(!report.exists());
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_dangling_link_among_the_maps_is_named() {
    let d = scratch("mapinputs", "dangling");
    let maps = d.join("maps");
    std::fs::create_dir_all(&maps).unwrap();
    copy_pair(&maps, "a");
    let link = maps.join("gone.height.x3p");
    std::os::unix::fs::symlink(d.join("moved-away.height.x3p"), &link).unwrap();
    for args in [
        vec!["stats", "--map", s(&maps)],
        vec![
            "stats",
            "--map",
            s(&maps),
            "--intensity-suffix",
            ".intensity",
            "--cutoff",
            "0.49",
        ],
    ] {
        refused(&run(&args), &[s(&link), "symbolic link", "does not exist"]);
    }
    let pattern = format!("{}/*.x3p", maps.display());
    refused(
        &run(&["stats", "--map", &pattern]),
        &[s(&link), "does not exist"],
    );
    refused(
        &run(&["stats", "--map", s(&link)]),
        &[s(&link), "does not exist"],
    );
    // Commands that read one file name the link and its target too.
    let out = d.join("out.x3p");
    for args in [
        vec!["info", s(&link)],
        vec!["convert", s(&link), s(&out)],
        vec!["stack", s(&link), "--height-out", s(&out)],
    ] {
        refused(
            &run(&args),
            &[s(&link), "symbolic link to", "moved-away.height.x3p"],
        );
    }
    assert!(!out.exists());
    // A dangling intensity partner is named as such.
    std::fs::remove_file(&link).unwrap();
    let b = maps.join("b.height.x3p");
    std::fs::copy(fixture("synth-hwhm6-rough.height.x3p"), &b).unwrap();
    std::os::unix::fs::symlink(d.join("nowhere.x3p"), maps.join("b.intensity.x3p")).unwrap();
    let o = run(&[
        "stats",
        "--map",
        s(&b),
        "--intensity-suffix",
        ".intensity",
        "--cutoff",
        "0.49",
    ]);
    refused(&o, &["b.intensity.x3p", "symbolic link"]);
    // analyze: a maps folder with a dangling link, and a folder of manifests with one.
    std::fs::remove_file(maps.join("b.intensity.x3p")).unwrap();
    std::fs::remove_file(&b).unwrap();
    std::os::unix::fs::symlink(d.join("moved-away.height.x3p"), &link).unwrap();
    let manifests = d.join("samples");
    std::fs::create_dir_all(&manifests).unwrap();
    let manifest = manifests.join("one.toml");
    std::fs::write(
        &manifest,
        "[maps]\nfiles = [\"../maps\"]\n[models]\nfit = false\n",
    )
    .unwrap();
    let report = d.join("report");
    refused(
        &run(&["analyze", s(&manifest), "--out", s(&report)]),
        &["maps/gone.height.x3p", "does not exist"],
    );
    std::fs::remove_file(&link).unwrap();
    let toml_link = manifests.join("two.toml");
    std::os::unix::fs::symlink(d.join("gone.toml"), &toml_link).unwrap();
    refused(
        &run(&["analyze", s(&manifests), "--out", s(&report)]),
        &[s(&toml_link)],
    );
    assert!(!report.exists());
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn an_empty_height_suffix_is_refused_once() {
    let d = scratch("mapinputs", "suffix");
    copy_pair(&d, "a");
    copy_pair(&d, "b");
    let o = run(&[
        "stats",
        "--map",
        s(&d),
        "--intensity-suffix",
        ".intensity",
        "--height-suffix",
        "",
        "--cutoff",
        "0.49",
    ]);
    let err = refused(&o, &["--height-suffix", "empty"]);
    assert_eq!(err.matches("empty").count(), 1, "{err}");
    let manifest = d.join("sample.toml");
    std::fs::write(
        &manifest,
        "[maps]\nfiles = [\"a.height.x3p\"]\nintensity_suffix = \".intensity\"\nheight_suffix = \"\"\ncutoff = 0.49\n[models]\nfit = false\n",
    )
    .unwrap();
    refused(
        &run(&["analyze", s(&manifest), "--out", s(&d.join("r"))]),
        &["maps.height_suffix", "empty"],
    );
    let _ = std::fs::remove_dir_all(&d);
}
