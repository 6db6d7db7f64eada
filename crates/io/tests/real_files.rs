//! Every real file in `fixtures/real` loads, and its dimensions, pitch and
//! invalid-point count match what the file itself declares.
//!
//! Expected numbers come from the files, not from the reader: X3P headers are read in
//! this test with a plain string search over `main.xml` (not the reader's XML parser),
//! text headers are quoted in comments, and NaN counts and height statistics were computed
//! independently with Python's `struct` module over the unzipped `bindata/data.bin`.

use std::io::Read;
use std::path::PathBuf;

use flakescatter_io::{MapError, MapFormat, ReadOptions, ZUnit, read_intensity, read_map};

fn data(name: &str) -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/real")).join(name)
}

/// `main.xml` of an X3P file, found with the zip crate and no XML parsing.
fn main_xml(name: &str) -> String {
    let bytes = std::fs::read(data(name)).unwrap();
    let mut zip = zip::ZipArchive::new(std::io::Cursor::new(bytes)).unwrap();
    let member = zip
        .file_names()
        .map(|n| n.unwrap().into_owned())
        .find(|n| n.ends_with("main.xml") && !n.contains("MACOSX"))
        .unwrap();
    let mut s = String::new();
    zip.by_name(&member)
        .unwrap()
        .read_to_string(&mut s)
        .unwrap();
    s
}

/// Text of the first `<tag>...</tag>` after `<after>` (string search).
fn tag(xml: &str, after: &str, tag: &str) -> String {
    let start = xml.find(&format!("<{after}>")).unwrap();
    let rest = &xml[start..];
    let open = format!("<{tag}>");
    let a = rest.find(&open).unwrap() + open.len();
    let b = a + rest[a..].find('<').unwrap();
    rest[a..b].trim().to_string()
}

fn assert_close(a: f64, b: f64, rel: f64) {
    assert!(
        (a - b).abs() <= rel * b.abs().max(1e-300),
        "{a} vs {b} (rel {rel})"
    );
}

/// Checks an X3P against its own header: sizes and pitch (metres → µm).
fn check_x3p(name: &str, options: &ReadOptions, invalid: usize) {
    let xml = main_xml(name);
    let nx: usize = tag(&xml, "MatrixDimension", "SizeX").parse().unwrap();
    let ny: usize = tag(&xml, "MatrixDimension", "SizeY").parse().unwrap();
    let dx_m: f64 = tag(&xml, "CX", "Increment").parse().unwrap();
    let dy_m: f64 = tag(&xml, "CY", "Increment").parse().unwrap();
    let (map, format) = read_map(data(name), options).unwrap();
    assert_eq!(format, MapFormat::X3p);
    assert_eq!((map.nx(), map.ny()), (nx, ny), "{name}");
    assert_close(map.dx(), dx_m * 1e6, 1e-14);
    assert_close(map.dy(), dy_m * 1e6, 1e-14);
    assert_eq!(map.len() - map.valid_count(), invalid, "{name}");
    assert_eq!(map.metadata()["format"], "x3p");
}

#[test]
fn sample_land_sensofar() {
    // README: 918 x 256, 2.58 µm pitch, float64, many NaN; Python counted 25292 NaN.
    check_x3p("sample-land.x3p", &ReadOptions::default(), 25292);
    let (map, _) = read_map(data("sample-land.x3p"), &ReadOptions::default()).unwrap();
    assert_eq!((map.nx(), map.ny()), (918, 256));
    assert_eq!(map.dx(), 2.58);
    assert_eq!(map.dy(), 2.58);
    // Python over data.bin: mean -5.352068347547571e-07 m, rms 3.4334274890691285e-05 m,
    // min -7.947348058223724e-05 m, max 5.249858077149838e-05 m.
    let s = map.summary().unwrap();
    assert_close(s.mean, -5.352068347547571e-07 * 1e6, 1e-9);
    assert_close(s.rms, 3.4334274890691285e-05 * 1e6, 1e-12);
    assert_close(s.min, -79.47348058223724, 1e-14);
    assert_close(s.max, 52.49858077149838, 1e-14);
    let m = map.metadata();
    assert_eq!(m["x3p.root"], "ISO5436");
    assert_eq!(m["x3p.folder"], "sample-land");
    assert_eq!(m["x3p.instrument.manufacturer"], "Sensofar");
    assert_eq!(m["x3p.date"], "2018-09-15T17:46:09");
    assert_eq!(m["x3p.cz.datatype"], "D");
    assert_eq!(m["x3p.md5"], "ok");
}

#[test]
fn csafe_logo_has_a_stale_md5() {
    // md5sum of csafe-logo/main.xml is 478a53a5eba1607c2c1f5e4acce01cfb, but
    // md5checksum.hex says 51f0b43f25b587b72aa51b954c2134eb (checked with md5sum): the
    // header was edited after the checksum was written. Default: refuse, naming both.
    let err = read_map(data("csafe-logo.x3p"), &ReadOptions::default()).unwrap_err();
    let msg = err.to_string();
    assert!(msg.contains("csafe-logo.x3p"), "{msg}");
    assert!(msg.contains("478a53a5eba1607c2c1f5e4acce01cfb"), "{msg}");
    assert!(msg.contains("51f0b43f25b587b72aa51b954c2134eb"), "{msg}");
    let accept = ReadOptions {
        accept_md5_mismatch: true,
        ..ReadOptions::default()
    };
    // README: 741 x 419, 0.645 µm pitch, float64; no NaN (Python).
    check_x3p("csafe-logo.x3p", &accept, 0);
    let (map, _) = read_map(data("csafe-logo.x3p"), &accept).unwrap();
    assert_eq!((map.nx(), map.ny()), (741, 419));
    assert_close(map.dx(), 0.645, 1e-12);
    assert_eq!(map.metadata()["x3p.md5"], "mismatch accepted");
    assert!(map.metadata()["x3p.md5_mismatch"].contains("478a53a5"));
    // Python: raw min 2.078431372549019e-07, max 8.274509803921565e-07; the Z Increment
    // is 1e-06 m, so in µm the heights equal the raw values.
    let s = map.summary().unwrap();
    assert_close(s.min, 2.078431372549019e-7, 1e-14);
    assert_close(s.max, 8.274509803921565e-7, 1e-14);
}

#[test]
fn testing_x3p() {
    // README: 30 x 20; increments as stored (0.0274999996026357 "m").
    check_x3p("testing.x3p", &ReadOptions::default(), 0);
    let (map, _) = read_map(data("testing.x3p"), &ReadOptions::default()).unwrap();
    assert_eq!((map.nx(), map.ny()), (30, 20));
    assert_close(map.dx(), 27499.9996026357, 1e-15);
    // Python: mean -0.009498989882540627 (Z increment 1 m).
    assert_close(map.summary().unwrap().mean, -9498.989882540627, 1e-12);
}

#[test]
fn pyramid_float32() {
    // README: 5 x 5 float32 synthetic pyramid; Z increment 1.
    check_x3p("pyramid.x3p", &ReadOptions::default(), 0);
    let (map, _) = read_map(data("pyramid.x3p"), &ReadOptions::default()).unwrap();
    assert_eq!(map.metadata()["x3p.cz.datatype"], "F");
    // Python: values 2 .. 10, mean 3.6, rms 2.2627416997969525 (metres, as stored).
    let s = map.summary().unwrap();
    assert_eq!((s.min, s.max), (2e6, 10e6));
    assert_close(s.mean, 3.6e6, 1e-15);
    assert_close(s.rms, 2.2627416997969525e6, 1e-12);
}

#[test]
fn mountainsmap_non_square_no_z_increment() {
    // README: 650 x 650, about 0.128 µm x 0.315 µm, float64, no Z Increment/Offset,
    // upper-case MD5 (both the data MD5 in main.xml and md5checksum.hex).
    check_x3p("surfacetopography-x3p-2.x3p", &ReadOptions::default(), 0);
    let (map, _) = read_map(data("surfacetopography-x3p-2.x3p"), &ReadOptions::default()).unwrap();
    assert_close(map.dx(), 0.127656509837346, 1e-15);
    assert_close(map.dy(), 0.314582113527746, 1e-15);
    // Python: mean -2.4918241693055942e-09 m, rms 7.728033273597748e-08 m.
    let s = map.summary().unwrap();
    assert_close(s.mean, -2.4918241693055942e-3, 1e-9);
    assert_close(s.rms, 7.728033273597748e-2, 1e-12);
    assert_eq!(map.metadata()["x3p.instrument.version"], "6.2");
}

#[test]
fn sdf_ascii() {
    // Header: NumPoints = 7, NumProfiles = 4, Xscale = Yscale = 1.0E-6, Zscale = 1.0E-6.
    // First row "1.00000 0.99874 0.99495 0.98865 0.97986 0.96858 1.00000",
    // last row "0.97986 0.97862 0.97491 0.96874 0.96012 0.94907 0.97986".
    let (map, format) =
        read_map(data("surfacetopography-sdf-1.sdf"), &ReadOptions::default()).unwrap();
    assert_eq!(format, MapFormat::Sdf);
    assert_eq!((map.nx(), map.ny(), map.dx(), map.dy()), (7, 4, 1.0, 1.0));
    assert_eq!(map.valid_count(), 28);
    assert_eq!(map.get(0, 0), Some(1.0));
    assert_eq!(map.get(5, 0), Some(0.96858));
    assert_eq!(map.get(5, 3), Some(0.94907));
    assert_eq!(map.metadata()["sdf.ManufacID"], "ISOTC213");
    assert!(map.metadata()["sdf.trailer"].contains("Tom Jones"));
}

/// Checks a 30 x 20 sdfio / MountainsMap SDF: 1 µm pitch, one `BAD` point (index 29, the
/// last of the first profile), mean and rms of the other 599 heights in µm.
fn check_sdfio(name: &str, mean_um: f64, rms_um: f64) {
    let (map, format) = read_map(data(name), &ReadOptions::default()).unwrap();
    assert_eq!(format, MapFormat::Sdf);
    assert_eq!((map.nx(), map.ny()), (30, 20), "{name}");
    assert_close(map.dx(), 1.0, 1e-15);
    assert_close(map.dy(), 1.0, 1e-15);
    assert_eq!(map.valid_count(), 599, "{name}");
    assert_eq!(map.get(29, 0), None, "{name}: BAD is invalid");
    let s = map.summary().unwrap();
    assert_close(s.mean, mean_um, 1e-12);
    assert_close(s.rms, rms_um, 1e-12);
}

#[test]
fn sdfio_files_with_crlf_bad_points_and_iso2_headers() {
    // SurfaceTopography 1.27.1 (`open_topography(f).topography()`) reads the aISO-1.0
    // file as 30 x 20 points, 1 masked, mean 0.29995158597662774 µm, rms (population)
    // 0.17299607528330785 µm. It ignores the scales of the aISO-2.0 headers and returns
    // the raw values: mean 299.9515859766277 and rms 172.99607528330785 (input_iso2, raw
    // 0..599 with Zscale 1e-9 m, so µm = raw x 1e-3) and mean 299951.58195362776, rms
    // 172996.07528330784 (mm11_iso2, Zscale 1e-12 m, µm = raw x 1e-6). The mean excluding
    // index 29 is (0 + ... + 599 - 29) / 599 = 299.95158597662771 raw units.
    check_sdfio(
        "sdfio-mm11_iso1_ascii_int32.sdf",
        0.29995158597662774,
        0.17299607528330785,
    );
    check_sdfio(
        "sdfio-input_iso2_ascii.sdf",
        0.2999515859766277,
        0.17299607528330785,
    );
    check_sdfio(
        "sdfio-mm11_iso2_ascii_binary64.sdf",
        0.29995158195362776,
        0.17299607528330784,
    );
    let (map, _) = read_map(data("sdfio-input_iso2_ascii.sdf"), &ReadOptions::default()).unwrap();
    assert_eq!(map.metadata()["sdf.version"], "aISO-2.0");
    assert!(map.metadata()["sdf.trailer"].contains("OperatorName = Tester"));
}

#[test]
fn gwyddion_english_and_german() {
    // "# Width: 12.34 µm", "# Height: 5678.9 nm" (German: Breite, Höhe),
    // "# Value units: m", then 4 rows of 3 values; Gwyddion's width is nx * dx.
    for name in [
        "surfacetopography-gwyddion-export-english.txt",
        "surfacetopography-gwyddion-export-german.txt",
    ] {
        let (map, format) = read_map(data(name), &ReadOptions::default()).unwrap();
        assert_eq!(format, MapFormat::Text);
        assert_eq!((map.nx(), map.ny()), (3, 4), "{name}");
        assert_close(map.dx(), 12.34 / 3.0, 1e-15);
        assert_close(map.dy(), 5.6789 / 4.0, 1e-15);
        // Row 0 is "1 1.5 3", row 1 "-2 -3 -6", in metres.
        assert_eq!(map.get(1, 0), Some(1.5e6));
        assert_eq!(map.get(2, 1), Some(-6e6));
        assert_eq!(map.valid_count(), 12);
    }
}

#[test]
fn gwyddion_txt_example() {
    // "# Width: 1.0e-6 m", "# Height: 0.5e-6 m", "# Value units: m", 3 rows of 6 values,
    // tab separated, first value 1.0e-007 m = 0.1 µm.
    let name = "surfacetopography-txt_example.txt";
    let (map, _) = read_map(data(name), &ReadOptions::default()).unwrap();
    assert_eq!((map.nx(), map.ny()), (6, 3));
    assert_close(map.dx(), 1.0 / 6.0, 1e-15);
    assert_close(map.dy(), 0.5 / 3.0, 1e-15);
    assert_close(map.get(0, 0).unwrap(), 0.1, 1e-15);
    assert_close(map.get(1, 1).unwrap(), 0.05, 1e-15);
}

#[test]
fn csv_profile_needs_a_z_unit() {
    // "X_(microns),y1" then 8 rows, x from 0.0386 to 0.3089 µm: mean step
    // (0.3089 - 0.0386) / 7 µm. The y1 column has no unit: the reader must ask.
    let name = "surfacetopography-csv-1.csv";
    let err = read_map(data(name), &ReadOptions::default()).unwrap_err();
    assert!(matches!(
        err,
        flakescatter_io::ReadMapError::Format {
            error: MapError::Text(flakescatter_io::text::TextError::MissingZUnit),
            ..
        }
    ));
    assert!(err.to_string().contains("--z-unit"), "{err}");
    let options = ReadOptions {
        z_unit: Some(ZUnit::Um),
        ..ReadOptions::default()
    };
    let (map, _) = read_map(data(name), &options).unwrap();
    assert_eq!((map.nx(), map.ny()), (8, 1));
    assert_close(map.dx(), (0.3089 - 0.0386) / 7.0, 1e-12);
    assert_eq!(map.get(0, 0), Some(2.10425));
    assert_eq!(map.get(7, 0), Some(1.94981));
}

#[test]
fn every_file_in_the_folder_is_covered() {
    // Guards against a new file being added without a test above.
    let covered = [
        "sample-land.x3p",
        "csafe-logo.x3p",
        "testing.x3p",
        "pyramid.x3p",
        "surfacetopography-x3p-2.x3p",
        "surfacetopography-sdf-1.sdf",
        "surfacetopography-gwyddion-export-english.txt",
        "surfacetopography-gwyddion-export-german.txt",
        "surfacetopography-txt_example.txt",
        "surfacetopography-csv-1.csv",
        "sdfio-input_iso2_ascii.sdf",
        "sdfio-mm11_iso1_ascii_int32.sdf",
        "sdfio-mm11_iso2_ascii_binary64.sdf",
    ];
    let dir = data("");
    for entry in std::fs::read_dir(&dir).unwrap() {
        let entry = entry.unwrap();
        // `instruments/` has its own coverage check in `instruments.rs`.
        if entry.file_type().unwrap().is_dir() {
            continue;
        }
        let name = entry.file_name().into_string().unwrap();
        if name.ends_with(".md") || name.starts_with("LICENSE") || name == ".gitattributes" {
            continue;
        }
        assert!(covered.contains(&name.as_str()), "untested file {name}");
    }
}

#[test]
fn pitch_override_applies_to_x3p() {
    let options = ReadOptions {
        pixel_um: Some((1.5, 2.5)),
        ..ReadOptions::default()
    };
    let (map, _) = read_map(data("pyramid.x3p"), &options).unwrap();
    assert_eq!((map.dx(), map.dy()), (1.5, 2.5));
    assert_eq!(map.metadata()["pitch_source"], "option");
    let bad = ReadOptions {
        pixel_um: Some((f64::NAN, 1.0)),
        ..ReadOptions::default()
    };
    let err = read_map(data("pyramid.x3p"), &bad).unwrap_err();
    assert!(err.to_string().contains("pixel pitch"), "{err}");
}

#[test]
fn intensity_values_come_back_as_stored() {
    // pyramid.x3p as an intensity image: Offset 0 + raw x Increment 1 gives the stored
    // values 2 .. 10 (Python over data.bin), not µm-converted heights.
    let (i, _) = read_intensity(data("pyramid.x3p"), &ReadOptions::default()).unwrap();
    let s = i.summary().unwrap();
    assert_eq!((s.min, s.max), (2.0, 10.0));
    // Gwyddion text "Value units: m" is ignored for intensities: row 0 is "1 1.5 3".
    let (i, _) = read_intensity(
        data("surfacetopography-gwyddion-export-english.txt"),
        &ReadOptions::default(),
    )
    .unwrap();
    assert_eq!(i.get(1, 0), Some(1.5));
    // SDF "Zscale = 1.0E-6", first value 1.00000 and sixth 0.96858: stored values
    // 1.0 x 1e-6 and 0.96858 x 1e-6 (one rounding each).
    let (i, _) =
        read_intensity(data("surfacetopography-sdf-1.sdf"), &ReadOptions::default()).unwrap();
    assert_eq!(i.get(0, 0), Some(1e-6));
    assert_eq!(i.get(5, 0), Some(0.96858 * 1e-6));
}
