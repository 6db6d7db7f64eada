//! Channels by name or index (`--channel NAME|INDEX`) and the intensity channel of the
//! same file (`--intensity-channel`), end to end on the real instrument files.
//!
//! The expected counts come from `fixtures/real/instruments/expected_channels.py`
//! (output in `expected-channels.txt`, how it was made in the README there): Gwyddion
//! 2.62 and surfalize 0.19.2 read each intensity image, and the script counts its
//! values below the cutoff. Every height of these files is valid, so the points left
//! are all points minus those below the cutoff.

mod common;

use common::run;
use std::path::{Path, PathBuf};

fn data(name: &str) -> String {
    PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../fixtures/real/instruments"
    ))
    .join(name)
    .display()
    .to_string()
}

fn json(args: &[&str]) -> serde_json::Value {
    let o = run(args);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    serde_json::from_slice(&o.stdout).unwrap()
}

fn fails(args: &[&str]) -> String {
    let o = run(args);
    assert_eq!(o.status.code(), Some(2), "{args:?} should fail with 2");
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn channel_by_name_or_index_reads_the_same_channel() {
    let plu = data("plu-1.plu");
    // The height layer by exact name, by name in another case, and by index; the grey
    // image is listed beside it (unit a.u.).
    for sel in ["layer0", "LAYER0", "0"] {
        let v = json(&["info", &plu, "--channel", sel, "--json"]);
        assert_eq!(v["channel"], 0, "{sel}");
        assert_eq!(v["valid_points"], 768 * 576, "{sel}");
        // SurfaceTopography 1.27.1 and Gwyddion 2.62: mean -1.0623766881448251e-4 m.
        let mean = v["mean_m"].as_f64().unwrap();
        assert!(
            (mean + 1.0623766881448251e-4).abs() < 1e-13,
            "{sel}: {mean}"
        );
    }
    let v = json(&["info", &plu, "--json"]);
    let names: Vec<(&str, &str)> = v["channels"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| (c["name"].as_str().unwrap(), c["unit"].as_str().unwrap()))
        .collect();
    assert_eq!(names, [("layer0", "µm"), ("image0", "a.u.")]);
    // OPD arrays by name: SecArr_0 is not a height array, and says so (not "no such").
    let e = fails(&["info", &data("opd-1.opd"), "--channel", "secarr_0"]);
    assert!(e.contains("not a height array"), "{e}");
    // The text listing marks the channel read.
    let o = run(&["info", &data("metropro-1.dat"), "--channel", "Phase"]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("* 0  phase"), "{text}");
    assert!(
        text.contains("  1  intensity            a.u.   640 x 480"),
        "{text}"
    );
}

#[test]
fn unknown_channel_name_lists_the_channels_of_the_file() {
    let plu = data("plu-1.plu");
    let e = fails(&["info", &plu, "--channel", "phase"]);
    assert!(
        e.contains("plu-1.plu")
            && e.contains("no channel is named \"phase\"")
            && e.contains("0 = layer0 (µm, 768 x 576), 1 = image0 (a.u., 768 x 576)"),
        "{e}"
    );
    let e = fails(&["info", &plu, "--channel", "7"]);
    assert!(
        e.contains("channel 7 was asked for, but the file has 2 channel(s)"),
        "{e}"
    );
    // The same through a map-reading subcommand and through convert.
    let e = fails(&["topo", &plu, "--intensity-channel", "grey", "--cutoff", "1"]);
    assert!(
        e.contains("no channel is named \"grey\"") && e.contains("1 = image0"),
        "{e}"
    );
    let out = std::env::temp_dir().join(format!("fs-channels-{}.sdf", std::process::id()));
    let e = fails(&[
        "convert",
        &plu,
        out.to_str().unwrap(),
        "--channel",
        "height",
    ]);
    assert!(e.contains("0 = layer0"), "{e}");
    assert!(!out.exists());
    let e = fails(&["info", &plu, "--channel", ""]);
    assert!(
        e.contains("--channel") && e.contains("empty channel"),
        "{e}"
    );
}

#[test]
fn intensity_channel_with_a_cutoff_masks_the_expected_points() {
    // (file, channel, cutoff, points below the cutoff by expected_channels.py, total)
    for (file, channel, cutoff, below, total) in [
        ("plu-1.plu", "image0", "170", 212_266, 768 * 576),
        ("metropro-1.dat", "intensity", "100", 150_521, 640 * 480),
        ("al3d-1.al3d", "texture", "90", 37_555, 200 * 296),
    ] {
        let f = data(file);
        let v = json(&[
            "info",
            &f,
            "--intensity-channel",
            channel,
            "--cutoff",
            cutoff,
            "--json",
        ]);
        assert_eq!(v["valid_points_before_cutoff"], total, "{file}");
        assert_eq!(v["valid_points"], total - below, "{file}");
        assert_eq!(v["channel"], 0, "{file}");
        assert_eq!(v["intensity_channel"], 1, "{file}");
        assert_eq!(v["inputs"]["intensity_channel"], channel, "{file}");
    }
    // topo (a MapInputArgs subcommand) masks the same points: 307200 - 150521.
    let v = json(&[
        "topo",
        &data("metropro-1.dat"),
        "--intensity-channel",
        "INTENSITY",
        "--cutoff",
        "100",
        "--json",
    ]);
    assert_eq!(v["inputs"]["maps"][0]["valid_pixels"], 156_679);
}

#[test]
fn intensity_channel_conflicts_and_mismatches_are_refused() {
    let plu = data("plu-1.plu");
    // With a second intensity file for the same map.
    let e = fails(&[
        "info",
        &plu,
        "--intensity",
        &plu,
        "--intensity-channel",
        "image0",
        "--cutoff",
        "1",
    ]);
    assert!(
        e.contains("--intensity-channel") && e.contains("--intensity"),
        "{e}"
    );
    let e = fails(&[
        "segment",
        &plu,
        "--intensity-suffix",
        ".i",
        "--intensity-channel",
        "1",
        "--cutoff",
        "1",
    ]);
    assert!(e.contains("--intensity-channel"), "{e}");
    // Without a cutoff.
    let e = fails(&["topo", &plu, "--intensity-channel", "image0"]);
    assert!(
        e.contains("--intensity-channel \"image0\" needs --cutoff X"),
        "{e}"
    );
    // The height channel itself.
    let e = fails(&[
        "info",
        &plu,
        "--intensity-channel",
        "layer0",
        "--cutoff",
        "1",
    ]);
    assert!(e.contains("is the height channel itself"), "{e}");
    // A height channel of the format's own kind read as intensity is refused by name.
    let e = fails(&[
        "info",
        &plu,
        "--channel",
        "image0",
        "--intensity-channel",
        "layer0",
        "--cutoff",
        "1",
    ]);
    assert!(e.contains("image0 holds an intensity image"), "{e}");
}

// ---- a GWY file with two channels of different sizes --------------------------------
//
// Written here from Gwyddion's published GWY layout (the one `crates/io/src/gwy.rs`
// documents): "GWYP", then a serialized GwyContainer; an object is its NUL-terminated
// type name, a u32 byte size and its components (NUL-terminated name, type character,
// value; little-endian).

fn component(name: &str, ty: u8, value: &[u8]) -> Vec<u8> {
    let mut v = name.as_bytes().to_vec();
    v.push(0);
    v.push(ty);
    v.extend_from_slice(value);
    v
}

fn object(ty: &str, components: &[Vec<u8>]) -> Vec<u8> {
    let body: Vec<u8> = components.concat();
    let mut v = ty.as_bytes().to_vec();
    v.push(0);
    v.extend_from_slice(&(body.len() as u32).to_le_bytes());
    v.extend(body);
    v
}

fn unit(s: &str) -> Vec<u8> {
    let mut z = s.as_bytes().to_vec();
    z.push(0);
    object("GwySIUnit", &[component("unitstr", b's', &z)])
}

fn field(nx: i32, ny: i32, values: &[f64], z_unit: &str) -> Vec<u8> {
    let mut data = (values.len() as u32).to_le_bytes().to_vec();
    for v in values {
        data.extend_from_slice(&v.to_le_bytes());
    }
    object(
        "GwyDataField",
        &[
            component("xres", b'i', &nx.to_le_bytes()),
            component("yres", b'i', &ny.to_le_bytes()),
            component("xreal", b'd', &(f64::from(nx) * 1e-6).to_le_bytes()),
            component("yreal", b'd', &(f64::from(ny) * 1e-6).to_le_bytes()),
            component("si_unit_xy", b'o', &unit("m")),
            component("si_unit_z", b'o', &unit(z_unit)),
            component("data", b'D', &data),
        ],
    )
}

fn title(s: &str) -> Vec<u8> {
    let mut z = s.as_bytes().to_vec();
    z.push(0);
    z
}

fn write_gwy(path: &Path) {
    let heights = field(3, 2, &[1e-6, 2e-6, 3e-6, 4e-6, 5e-6, 6e-6], "m");
    let same = field(3, 2, &[10.0, 20.0, 30.0, 40.0, 50.0, 60.0], "");
    let small = field(2, 2, &[1.0, 2.0, 3.0, 4.0], "");
    let container = object(
        "GwyContainer",
        &[
            component("/0/data", b'o', &heights),
            component("/0/data/title", b's', &title("Height")),
            component("/1/data", b'o', &same),
            component("/1/data/title", b's', &title("Intensity")),
            component("/2/data", b'o', &small),
            component("/2/data/title", b's', &title("Small")),
        ],
    );
    let mut bytes = b"GWYP".to_vec();
    bytes.extend(container);
    std::fs::write(path, bytes).unwrap();
}

#[test]
fn intensity_channel_of_another_size_is_refused_by_name() {
    let path = std::env::temp_dir().join(format!("fs-channels-{}.gwy", std::process::id()));
    write_gwy(&path);
    let p = path.to_str().unwrap();
    // Same size: intensities 10..60, cutoff 35 keeps 40, 50, 60 (three points).
    let v = json(&[
        "info",
        p,
        "--intensity-channel",
        "intensity",
        "--cutoff",
        "35",
        "--json",
    ]);
    assert_eq!(
        (v["valid_points"].as_u64(), v["intensity_channel"].as_u64()),
        (Some(3), Some(1))
    );
    // Another size: refused, naming the channel and both sizes.
    let e = fails(&["info", p, "--intensity-channel", "Small", "--cutoff", "1"]);
    assert!(e.contains("channel 2 (Small) of the same file"), "{e}");
    assert!(
        e.contains("intensity map is 2 x 2 (nx x ny), height map is 3 x 2"),
        "{e}"
    );
    std::fs::remove_file(&path).unwrap();
}

#[test]
fn a_directory_of_instrument_files_is_read_by_their_extensions() {
    // A directory argument takes the instrument formats with an extension of their own
    // (`.plu`, `.frt`, …) beside the ISO ones; `.dat` (MetroPro, but also text and
    // other data) and other files are left to be named explicitly.
    let dir = std::env::temp_dir().join(format!("flakescatter-dir-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for f in ["plu-1.plu", "frt-2.frt", "metropro-1.dat", "README.md"] {
        std::fs::copy(data(f), dir.join(f)).unwrap();
    }
    let per = dir.join("per-map.csv");
    let o = run(&[
        "stats",
        "--map",
        &dir.display().to_string(),
        "--per-map",
        &per.display().to_string(),
        "--json",
    ]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let table = std::fs::read_to_string(&per).unwrap();
    let maps: Vec<&str> = table
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap().rsplit('/').next().unwrap())
        .collect();
    assert_eq!(maps, ["frt-2.frt", "plu-1.plu"], "{table}");
    let _ = std::fs::remove_dir_all(&dir);
}
