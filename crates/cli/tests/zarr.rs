//! Zarr v3 stores as maps on the command line (docs/formats.md "Zarr v3 maps"): a
//! shipped X3P map converted to `.zarr` gives `topo` the same output as the X3P itself
//! (the heights are kept bit for bit), with its intensity map converted too; `info`,
//! `segment` and `stats` read the store; `synth --out MAP.zarr` writes one; the store is
//! an owned output directory; a bad store exits 2 naming the array.

mod common;

use std::path::Path;

use common::{fixture, run, s, scratch, stderr};

fn ok(args: &[&str]) -> String {
    let o = run(args);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    String::from_utf8(o.stdout).unwrap()
}

fn fails(args: &[&str]) -> String {
    let o = run(args);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
    stderr(&o)
}

#[test]
fn converted_store_gives_topo_the_same_output() {
    let d = scratch("zarr", "convert");
    let height = fixture("synth-hwhm3-smooth.height.x3p");
    let intensity = fixture("synth-hwhm3-smooth.intensity.x3p");
    let (hz, iz) = (d.join("h.zarr"), d.join("i.zarr"));
    ok(&["convert", s(&height), s(&hz)]);
    ok(&["convert", s(&intensity), s(&iz)]);
    assert!(hz.join("zarr.json").is_file() && hz.join("height/zarr.json").is_file());
    // The intensity image is a store holding `intensity` alone.
    assert!(iz.join("intensity/zarr.json").is_file() && !iz.join("height").exists());
    let topo = |map: &Path, i: &Path| {
        ok(&[
            "topo",
            s(map),
            "--intensity",
            s(i),
            "--cutoff",
            "0.5",
            "--theta-i",
            "45",
        ])
    };
    let from_x3p = topo(&height, &intensity);
    assert!(from_x3p.lines().count() > 10, "{from_x3p}");
    assert_eq!(topo(&hz, &iz), from_x3p);
    // Mixed: the X3P map with the store's intensity.
    assert_eq!(topo(&height, &iz), from_x3p);
    // A folder holding the store stands for it.
    let folder = d.join("folder");
    std::fs::create_dir(&folder).unwrap();
    ok(&["convert", s(&height), s(&folder.join("only.zarr"))]);
    assert_eq!(
        ok(&["topo", s(&folder), "--theta-i", "45"]),
        ok(&["topo", s(&height), "--theta-i", "45"])
    );
    // info names the format and the size; segment and stats read the store as the X3P
    // (their tables name the map: the store's name is put back to the X3P's).
    let info = ok(&["info", s(&hz)]);
    assert!(info.contains("zarr") && info.contains("512"), "{info}");
    for cmd in [&["segment"][..], &["stats", "--map"][..]] {
        let run_on = |m: &Path| {
            let mut a: Vec<&str> = cmd.to_vec();
            a.push(s(m));
            ok(&a)
        };
        let from_store = run_on(&hz);
        assert!(from_store.lines().count() > 2, "{from_store}");
        assert_eq!(
            from_store.replace(s(&hz), s(&height)),
            run_on(&height),
            "{cmd:?}"
        );
    }
    // Converting again over the store: an earlier output of convert is replaced.
    ok(&["convert", s(&height), s(&hz)]);
    assert!(hz.join(".flakescatter-output.json").is_file());
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn synth_writes_stores_and_a_foreign_directory_is_kept() {
    let d = scratch("zarr", "synth");
    let base = [
        "synth",
        "--size",
        "96",
        "--pixel-um",
        "0.5",
        "--seed",
        "4",
        "--hwhm",
        "5",
    ];
    let with = |out: &Path, i: &Path| {
        let mut a: Vec<&str> = base.to_vec();
        a.extend(["--out", s(out), "--intensity-out", s(i)]);
        ok(&a);
    };
    let (hx, ix, hz, iz) = (
        d.join("h.x3p"),
        d.join("i.x3p"),
        d.join("h.zarr"),
        d.join("i.zarr"),
    );
    with(&hx, &ix);
    with(&hz, &iz);
    let topo = |m: &Path, i: &Path| {
        ok(&[
            "topo",
            s(m),
            "--intensity",
            s(i),
            "--cutoff",
            "0.5",
            "--theta-i",
            "30",
        ])
    };
    assert_eq!(topo(&hz, &iz), topo(&hx, &ix));
    // A directory named .zarr that is not an output of synth is not written over.
    let mine = d.join("mine.zarr");
    std::fs::create_dir(&mine).unwrap();
    std::fs::write(mine.join("notes.txt"), b"keep").unwrap();
    let mut a: Vec<&str> = base.to_vec();
    a.extend(["--out", s(&mine)]);
    let e = fails(&a);
    assert!(e.contains("mine.zarr") && e.contains("notes.txt"), "{e}");
    assert_eq!(std::fs::read(mine.join("notes.txt")).unwrap(), b"keep");
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn bad_stores_exit_2_naming_the_array_or_attribute() {
    let d = scratch("zarr", "bad");
    let store = d.join("m.zarr");
    ok(&[
        "convert",
        s(&fixture("synth-hwhm6-rough.height.x3p")),
        s(&store),
    ]);
    let meta = store.join("height/zarr.json");
    let good = std::fs::read_to_string(&meta).unwrap();
    assert!(good.contains("\"float64\""), "{good}");
    std::fs::write(&meta, good.replace("\"float64\"", "\"int32\"")).unwrap();
    for cmd in ["info", "topo", "segment"] {
        let e = fails(&[cmd, s(&store)]);
        assert!(
            e.contains("m.zarr") && e.contains("`height`") && e.contains("int32"),
            "{e}"
        );
    }
    let e = fails(&["stats", "--map", s(&store)]);
    assert!(e.contains("`height`"), "{e}");
    std::fs::write(&meta, &good).unwrap();
    let root = store.join("zarr.json");
    let attrs = std::fs::read_to_string(&root).unwrap();
    std::fs::write(&root, attrs.replace("pitch_y_um", "pitch_q")).unwrap();
    let e = fails(&["info", s(&store)]);
    assert!(e.contains("`pitch_y_um`") && e.contains("missing"), "{e}");
    // A `.zarr` directory without zarr.json.
    let empty = d.join("empty.zarr");
    std::fs::create_dir(&empty).unwrap();
    let e = fails(&["topo", s(&empty)]);
    assert!(e.contains("no zarr.json"), "{e}");
    std::fs::remove_dir_all(&d).unwrap();
}
