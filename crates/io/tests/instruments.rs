//! Native instrument files in `fixtures/real/instruments`: each reader against numbers
//! established outside this project (see `fixtures/real/instruments/README.md`, which
//! says how they were made, by which independent reader, and where those readers
//! disagree). The statistics compared are of the valid points only: mean and RMS
//! (population, about the mean), heights in metres as the independent readers report.

use std::path::PathBuf;

use flakescatter_io::{
    MapError, MapFormat, ReadMapError, ReadOptions, ZUnit, list_channels, list_channels_bytes,
    read_map,
};

fn data(name: &str) -> PathBuf {
    PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../fixtures/real/instruments"
    ))
    .join(name)
}

/// Expected numbers, all lengths in metres.
struct Expect {
    nx: usize,
    ny: usize,
    dx: f64,
    dy: f64,
    invalid: usize,
    mean: f64,
    rms: f64,
}

fn close(what: &str, got: f64, want: f64, rel: f64) {
    assert!(
        (got - want).abs() <= rel * want.abs(),
        "{what}: got {got:e}, expected {want:e} (relative tolerance {rel:e})"
    );
}

/// Reads `name` with `options` and compares it with `e` (µm in the map, m in `e`).
fn check(name: &str, options: &ReadOptions, format: MapFormat, e: &Expect) {
    let (map, found) = read_map(data(name), options).unwrap_or_else(|err| panic!("{name}: {err}"));
    assert_eq!(found, format, "{name}");
    assert_eq!((map.nx(), map.ny()), (e.nx, e.ny), "{name} size");
    close("dx", map.dx() * 1e-6, e.dx, 1e-12);
    close("dy", map.dy() * 1e-6, e.dy, 1e-12);
    assert_eq!(
        map.len() - map.valid_count(),
        e.invalid,
        "{name} invalid points"
    );
    let v: Vec<f64> = map
        .heights()
        .iter()
        .zip(map.valid())
        .filter(|(_, ok)| **ok)
        .map(|(z, _)| z * 1e-6)
        .collect();
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let rms = (v.iter().map(|z| (z - mean).powi(2)).sum::<f64>() / n).sqrt();
    // numpy sums pairwise, we sum in order: agreement to ~1e-10 relative, far below
    // any unit or scale-factor error (which would be a factor of 10 or more).
    close("mean", mean, e.mean, 1e-9);
    close("rms", rms, e.rms, 1e-8);
}

#[test]
fn gwyddion_gwy() {
    // tuxu/gwyfile's test.gwy: one data field "Test", 128 x 128, xreal = yreal = 128,
    // and neither a lateral nor a z unit (empty unitstr). SurfaceTopography 1.27.1 finds
    // no channel in it, surfalize 0.19.2 refuses it ("does not contain height data");
    // the numbers are from the `gwyfile` Python package (the same author's reference
    // reader): mean 0.0005152968462939743, std 0.00018771126171581148, no NaN.
    // Without units the file is uncalibrated, so the reader refuses it unless the user
    // says what the numbers are: here metres and 1 µm pixels (128 / 128 = 1 unit).
    let name = "gwyfile-test.gwy";
    let err = read_map(data(name), &ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("gwyfile-test.gwy") && err.contains("--pixel-um"),
        "{err}"
    );
    let with_pitch = ReadOptions {
        pixel_um: Some((1.0, 1.0)),
        ..ReadOptions::default()
    };
    let err = read_map(data(name), &with_pitch).unwrap_err().to_string();
    assert!(
        err.contains("no z unit") && err.contains("--z-unit"),
        "{err}"
    );
    let options = ReadOptions {
        pixel_um: Some((1.0, 1.0)),
        z_unit: Some(ZUnit::M),
        ..ReadOptions::default()
    };
    check(
        name,
        &options,
        MapFormat::Gwy,
        &Expect {
            nx: 128,
            ny: 128,
            dx: 1e-6,
            dy: 1e-6,
            invalid: 0,
            mean: 0.0005152968462939743,
            rms: 0.00018771126171581148,
        },
    );
    let (channels, format) = list_channels(data(name), &ReadOptions::default()).unwrap();
    assert_eq!(format, MapFormat::Gwy);
    assert_eq!(channels.len(), 1);
    assert_eq!(
        (channels[0].name.as_str(), channels[0].nx, channels[0].ny),
        ("Test", 128, 128)
    );
    assert_eq!(
        (channels[0].unit.clone(), channels[0].pitch_um),
        (None, None)
    );
}

/// Every prefix of a real file is refused (never a panic), and the error names a byte
/// offset inside the file.
fn truncations_refused(name: &str, cuts: &[usize]) {
    let bytes = std::fs::read(data(name)).unwrap();
    let options = ReadOptions {
        pixel_um: Some((1.0, 1.0)),
        z_unit: None,
        ..ReadOptions::default()
    };
    for &cut in cuts {
        let cut = cut.min(bytes.len() - 1);
        let err = flakescatter_io::read_bytes(
            &bytes[..cut],
            None,
            &options,
            flakescatter_io::ValueKind::Height,
        )
        .map(|_| ())
        .unwrap_err();
        let text = err.to_string();
        assert!(
            text.contains("truncated") && text.contains(&format!("ends at byte {cut}")),
            "{name} cut at {cut}: {text}"
        );
    }
}

#[test]
fn gwy_truncated_refused_with_offset() {
    // Inside the container header, a component name, the data array, the last byte.
    truncations_refused(
        "gwyfile-test.gwy",
        &[20, 150, 300, 70_000, 131_000, usize::MAX],
    );
}

/// `gwyfile-test.gwy` (one 128 x 128 data field) with its `xres` and `yres` components
/// (`i`, at bytes 141 and 151) replaced by `kind` components holding `value`; the sizes of
/// the data field and of the container grow by what the new components add.
fn gwy_with_sizes(kind: u8, value: &[u8]) -> Vec<u8> {
    let b = std::fs::read(data("gwyfile-test.gwy")).unwrap();
    let find = |key: &[u8]| b.windows(key.len()).position(|w| w == key).unwrap();
    let (x, y) = (find(b"xres\0i"), find(b"yres\0i"));
    assert_eq!(y, x + 10, "xres, then yres");
    let mut out = b[..x].to_vec();
    for name in [&b"xres\0"[..], b"yres\0"] {
        out.extend(name);
        out.push(kind);
        out.extend(value);
    }
    out.extend(&b[y + 10..]);
    let grow = 2 * (value.len() as u32 - 4);
    for at in [17, find(b"GwyDataField\0") + 13] {
        let size = u32::from_le_bytes(out[at..at + 4].try_into().unwrap()) + grow;
        out[at..at + 4].copy_from_slice(&size.to_le_bytes());
    }
    out
}

#[test]
fn gwy_sizes_too_large_for_u64_are_refused() {
    // Found by review while adding the per-reader fuzz targets: xres x yres x 8 bytes
    // overflowed u64 (a panic in debug builds, a wrapped size in release that a crafted
    // data array could match).
    // The file stores no units: give them, so that only the sizes can be at fault.
    let options = ReadOptions {
        pixel_um: Some((1.0, 1.0)),
        z_unit: Some(ZUnit::Nm),
        ..ReadOptions::default()
    };
    let read =
        |b: &[u8]| flakescatter_io::gwy::read(b, &options, flakescatter_io::ValueKind::Height);
    let err = |b: &[u8]| read(b).unwrap_err().to_string();
    // The rebuilding itself is right: with the file's own sizes, as 4-byte components it
    // gives the file back, and as 8-byte `q` components a file that reads as 128 x 128.
    let same = gwy_with_sizes(b'i', &128i32.to_le_bytes());
    assert_eq!(same, std::fs::read(data("gwyfile-test.gwy")).unwrap());
    let m = read(&gwy_with_sizes(b'q', &128i64.to_le_bytes())).unwrap();
    assert_eq!((m.nx(), m.ny()), (128, 128));
    // i32::MAX x i32::MAX = (2³¹ - 1)² = 2⁶² - 2³² + 1 points: 8 bytes each overflow u64.
    let e = err(&gwy_with_sizes(b'i', &i32::MAX.to_le_bytes()));
    assert!(
        e.contains("data holds 16384 values, expected xres 2147483647 x yres 2147483647 = 4611686014132420609"),
        "{e}"
    );
    // 8-byte `q` sizes of 2³³ each: the point count itself, 2⁶⁶, overflows.
    let e = err(&gwy_with_sizes(b'q', &(1i64 << 33).to_le_bytes()));
    assert!(
        e.contains("expected xres 8589934592 x yres 8589934592 = more than 2⁶⁴"),
        "{e}"
    );
}

#[test]
fn extension_contradicting_content_is_refused() {
    // A GWY file named .sdf: the magic decides, and the message says both.
    let dir = std::env::temp_dir().join(format!("flakescatter-instruments-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("really-gwy.sdf");
    std::fs::copy(data("gwyfile-test.gwy"), &p).unwrap();
    let err = read_map(&p, &ReadOptions::default()).unwrap_err();
    let ReadMapError::Format {
        error: MapError::NotThisFormat { .. },
        ..
    } = &err
    else {
        panic!("{err}")
    };
    assert!(err.to_string().contains("Gwyddion"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn sensofar_plu() {
    // SurfaceTopography 1.27.1: 768 x 576, 1.6600000858306884 µm pitch (the f32 1.66),
    // no invalid point, mean -1.0623766881448251e-4 m, rms 2.834390987634884e-6 m.
    // surfalize 0.19.2 agrees on size and pitch but gives mean -1.0623721090495685e-4,
    // rms 2.843358186074485e-6: it starts the heights at byte 500, where the layer's own
    // size (u32 576, u32 768) is stored, so its first two "heights" are those integers
    // read as f32 (8.1e-43, 1.1e-42) and every later point is shifted by two. The bytes
    // at 500..508 are 0x240, 0x300 = 576, 768 (checked with xxd), so the heights start
    // at 508: SurfaceTopography's numbers.
    check(
        "plu-1.plu",
        &ReadOptions::default(),
        MapFormat::Plu,
        &Expect {
            nx: 768,
            ny: 576,
            dx: 1.6600000858306884e-06,
            dy: 1.6600000858306884e-06,
            invalid: 0,
            mean: -0.00010623766881448251,
            rms: 2.834390987634884e-06,
        },
    );
    let (map, _) = read_map(data("plu-1.plu"), &ReadOptions::default()).unwrap();
    // The header's first 128 bytes, as text: "Fri Mar 10 16:35:59 2023".
    assert_eq!(map.metadata()["plu.date"], "Fri Mar 10 16:35:59 2023");
    // The heights at byte 508.. as f32 (numpy): -111.2265625, -111.21484375 µm.
    assert_eq!(map.get(0, 0), Some(-111.2265625));
    assert_eq!(map.get(1, 0), Some(-111.21484375));
    let (channels, _) = list_channels(data("plu-1.plu"), &ReadOptions::default()).unwrap();
    // One layer and, after it, its one image (`plu_grey_image_is_an_intensity_channel`).
    assert_eq!(channels.len(), 2);
    assert_eq!((channels[0].nx, channels[0].ny), (768, 576));
}

#[test]
fn plu_layer_sizes_too_large_for_u64_are_refused() {
    // Found by the `plu` fuzz target in its first minute (tests/data/fuzz/README.md): a
    // layer of 2627509415 x 2812785073 points (x by y, stored as y, x at bytes 500..508)
    // with 174 RGB images (byte 492) needs more than 2⁶⁴ bytes; the byte count overflowed
    // u64 (a panic in debug builds, a wrapped size in release). It is refused as
    // truncated, naming the layer and its byte, in the channel listing and the read alike.
    let input = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/fuzz/plu-layer-size-overflow"
    ))
    .unwrap();
    let (options, kind) = (ReadOptions::default(), flakescatter_io::ValueKind::Height);
    let bytes = &input[1..]; // the options byte is 0: the default options, heights
    let want = "truncated: layer 0 (2627509415 x 2812785073 heights, min/max, 174 RGB image(s)) at byte 508";
    let e = flakescatter_io::plu::channels(bytes, &options)
        .unwrap_err()
        .to_string();
    assert!(e.contains(want), "{e}");
    let e = flakescatter_io::plu::read(bytes, &options, kind)
        .unwrap_err()
        .to_string();
    assert!(e.contains(want), "{e}");
    // The same with the real file's own single image and the largest sizes.
    let mut b = std::fs::read(data("plu-1.plu")).unwrap();
    b[500..508].copy_from_slice(&[0xff; 8]); // layer 0: y, x (u32 each)
    let e = flakescatter_io::plu::read(&b, &options, kind)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("truncated: layer 0 (4294967295 x 4294967295 heights, min/max, 1 RGB image(s)) at byte 508"),
        "{e}"
    );
}

#[test]
fn plu_truncated_refused_with_offset() {
    // Inside the header, inside the heights, inside the RGB image, one byte short.
    // (The file holds 134133 bytes after the image that the format does not define;
    // those are not needed, so the cuts stay below 3096092 = 508 + 4n + 8 + 3n.)
    truncations_refused("plu-1.plu", &[499, 600, 1_000_000, 2_000_000, 3_096_091]);
}

#[test]
fn every_file_in_the_folder_is_covered() {
    let tested = [
        "gwyfile-test.gwy",
        "plu-1.plu",
        "metropro-1.dat",
        "opd-1.opd",
        "sur-2.sur",
        "sur-3.sur",
        "al3d-1.al3d",
        "frt-1.frt",
        "frt-2.frt",
    ];
    for entry in std::fs::read_dir(data("")).unwrap() {
        let name = entry.unwrap().file_name().into_string().unwrap();
        if name.ends_with(".md")
            || name.ends_with(".py")
            || name.ends_with(".txt")
            || name.starts_with("LICENSE")
            || name == ".gitattributes"
        {
            continue;
        }
        assert!(tested.contains(&name.as_str()), "untested file {name}");
    }
}

#[test]
fn zygo_metropro_dat() {
    // SurfaceTopography 1.27.1: 640 x 480, lateral_res 1.0982520279867458e-6 m, no
    // invalid point, mean 5.074040590166325e-5 m, rms 7.528822204734589e-8 m.
    // surfalize 0.19.2 gives the same size and pitch but 8 times the heights (mean
    // 4.059e-4 m): the header has phase_res = 1 (bytes 218..220 = 00 01), and the height
    // is raw × S × W × O / R with R = 4096, 32768, 131072 for phase_res 0, 1, 2 (Zygo's
    // MetroPro reference guide); surfalize's table starts at 1 (1 → 4096), so it divides
    // by 4096 instead of 32768. SurfaceTopography (and numpy by hand with R = 32768:
    // S = 0.5, W = 5.6999999742402e-7 m, O = 1) gives the numbers below.
    check(
        "metropro-1.dat",
        &ReadOptions::default(),
        MapFormat::MetroPro,
        &Expect {
            nx: 640,
            ny: 480,
            dx: 1.0982520279867458e-06,
            dy: 1.0982520279867458e-06,
            invalid: 0,
            mean: 5.074040590166325e-05,
            rms: 7.528822204734589e-08,
        },
    );
    let (map, _) = read_map(data("metropro-1.dat"), &ReadOptions::default()).unwrap();
    // Header text fields (xxd): objective " 20X  Mirau" at byte 246, date at byte 12.
    assert_eq!(map.metadata()["metropro.objective"], "20X  Mirau");
    assert_eq!(
        map.metadata()["metropro.software_date"],
        "Fri Jun 23 15:37:19 2006"
    );
}

#[test]
fn metropro_truncated_refused_with_offset() {
    // Inside the 834-byte header, inside the intensity frame, inside the phase frame,
    // one byte short.
    truncations_refused("metropro-1.dat", &[100, 833, 5_000, 700_000, 1_844_033]);
}

#[test]
fn wyko_opd() {
    // SurfaceTopography 1.27.1 (the only independent reader that opens it; surfalize
    // 0.19.2 stops at block type 15): 640 x 480, Pixel_size 0.00019673303177114576 mm,
    // Aspect 1, 116 invalid points (f32 values >= 1e38), mean -2.722895251054526e-7 m,
    // rms 8.356451162720974e-9 m, from Raw x Wavelength (577.2949829101562 nm) / Mult
    // (no Mult block: 1). The same numbers come from numpy over the raw f32 array at
    // byte 24026 (directory walked by hand with `struct`).
    check(
        "opd-1.opd",
        &ReadOptions::default(),
        MapFormat::Opd,
        &Expect {
            nx: 640,
            ny: 480,
            dx: 1.9673303177114576e-07,
            dy: 1.9673303177114576e-07,
            invalid: 116,
            mean: -2.722895251054526e-07,
            rms: 8.356451162720974e-09,
        },
    );
    let (map, _) = read_map(data("opd-1.opd"), &ReadOptions::default()).unwrap();
    // Orientation: the file stores y fastest and reversed; SurfaceTopography's
    // heights[0][0..3] (x = 0, y = 0, 1, 2) are raw[479], raw[478], raw[477] =
    // -0.00026551, -0.00026971, -0.00026898 mm.
    for (row, want_mm) in [(0, -0.00026551), (1, -0.00026971), (2, -0.00026898)] {
        let got_mm = map.get(0, row).unwrap() * 1e-3;
        assert!((got_mm - want_mm).abs() < 1e-8, "row {row}: {got_mm}");
    }
    assert_eq!(map.metadata()["opd.Date"], "7/7/2015");
    let (channels, _) = list_channels(data("opd-1.opd"), &ReadOptions::default()).unwrap();
    let names: Vec<&str> = channels.iter().map(|c| c.name.as_str()).collect();
    // Array blocks of the directory (walked with `struct`): Raw, SecArr_0, Image.
    assert_eq!(names, ["Raw", "SecArr_0", "Image"]);
    // Image is not a height array: a height read is refused, an intensity read gives
    // its u8 values.
    let img = ReadOptions {
        channel: Some(2),
        ..ReadOptions::default()
    };
    let err = read_map(data("opd-1.opd"), &img).unwrap_err().to_string();
    assert!(err.contains("not a height array"), "{err}");
    let (i, _) = flakescatter_io::read_intensity(data("opd-1.opd"), &img).unwrap();
    assert_eq!((i.nx(), i.ny(), i.valid_count()), (640, 480, 640 * 480));
}

#[test]
fn opd_truncated_refused_with_offset() {
    // Inside the directory entry (the magic name itself must be whole to be recognised),
    // the directory, the Raw array, the last block.
    truncations_refused("opd-1.opd", &[20, 5_000, 500_000, 4_020_869]);
}

#[test]
fn digital_surf_sur() {
    // sur-2.sur: 563 x 484, 32-bit, spacing 0.0034840002 mm (f32) in x and y, z spacing
    // 1e-7 mm, non-measured flag 1 and minimum 89120, so raw 89118 is invalid: 117
    // points. SurfaceTopography 1.27.1 and surfalize 0.19.2 agree: mean
    // 1.015737639515718e-5 m, rms 1.7517881243588177e-8 m (its z offset is 0).
    check(
        "sur-2.sur",
        &ReadOptions::default(),
        MapFormat::Sur,
        &Expect {
            nx: 563,
            ny: 484,
            dx: 3.4840002190321683e-06,
            dy: 3.4840002190321683e-06,
            invalid: 117,
            mean: 1.015737639515718e-05,
            rms: 1.7517881243588177e-08,
        },
    );
    // sur-3.sur: 512 x 512, spacing 295546 nm, z spacing 1e-9 m, minimum 0 (raw -2
    // invalid: 233009 points), z offset -0.00341433 (header byte 474). Both readers
    // agree on everything but the mean: SurfaceTopography 5.9936367307114715e-3 m,
    // surfalize 5.9936333163813985e-3 m, 3.4e-9 m lower = the offset -0.00341433 added
    // to heights already in µm (surfalize adds it after converting to µm, as if it were
    // µm, while the header's z unit is m). Digital Surf's offset is a display origin;
    // Gwyddion and SurfaceTopography leave it out, and so do we (it is kept in
    // `sur.offset_z`): SurfaceTopography's mean.
    check(
        "sur-3.sur",
        &ReadOptions::default(),
        MapFormat::Sur,
        &Expect {
            nx: 512,
            ny: 512,
            dx: 0.000295546,
            dy: 0.000295546,
            invalid: 233009,
            mean: 0.0059936367307114715,
            rms: 0.0011131994265859693,
        },
    );
    let (map, _) = read_map(data("sur-3.sur"), &ReadOptions::default()).unwrap();
    // Header bytes 306..318 (struct): 53 s, 8 min, 10 h, day 22, month 6, year 2023.
    assert_eq!(map.metadata()["sur.date"], "2023-06-22 10:08:53");
    let (channels, _) = list_channels(data("sur-2.sur"), &ReadOptions::default()).unwrap();
    assert_eq!(channels.len(), 1);
    assert_eq!(
        (channels[0].name.as_str(), channels[0].unit.as_deref()),
        ("Z", Some("mm"))
    );
}

#[test]
fn sur_truncated_refused_with_offset() {
    // Inside the header, inside the data, one byte short.
    truncations_refused("sur-2.sur", &[100, 511, 600_000, 1_090_479]);
}

#[test]
fn alicona_al3d() {
    // SurfaceTopography 1.27.1 and surfalize 0.19.2 agree: 200 x 296, 4.38027e-7 m
    // pixels, no invalid point (no depth >= InvalidPixelValue 3.000000028082e+15, and
    // the repeatability plane 3 has codes <= 107, 107 x 2.35294e-9 + 0 < 6.06e-7, so
    // surfalize's repeatability filter masks none either), mean 0.07634093332028873 m
    // (the stage's absolute z), rms 7.688265843362921e-6 m.
    check(
        "al3d-1.al3d",
        &ReadOptions::default(),
        MapFormat::Al3d,
        &Expect {
            nx: 200,
            ny: 296,
            dx: 4.38027e-07,
            dy: 4.38027e-07,
            invalid: 0,
            mean: 0.07634093332028873,
            rms: 7.688265843362921e-06,
        },
    );
    let (map, _) = read_map(data("al3d-1.al3d"), &ReadOptions::default()).unwrap();
    // Tag 7 of the header (read with `struct`): CreatingApplication = MeasureSuite 5.3.6.
    assert_eq!(
        map.metadata()["al3d.CreatingApplication"],
        "MeasureSuite 5.3.6"
    );
    assert_eq!(map.metadata()["al3d.repeatability_mask"], "applied");
}

#[test]
fn al3d_truncated_refused_with_offset() {
    // Inside a tag, before the depth image ends, inside the repeatability plane (plane 3
    // of 200 x 296 bytes from 238061: up to 238061 + 4 x 59200 = 474861, the file end).
    truncations_refused("al3d-1.al3d", &[30, 500, 100_000, 400_000, 474_860]);
}

/// `al3d-1.al3d` with the values of the tags `(key, value)` replaced (the 30-byte value
/// field after the 20-byte key of each 52-byte tag from byte 17).
fn al3d_with_tags(tags: &[(&str, &str)]) -> Vec<u8> {
    let mut b = std::fs::read(data("al3d-1.al3d")).unwrap();
    for (key, value) in tags {
        let at = (17..b.len() - 52)
            .step_by(52)
            .find(|&a| b[a..a + 20].split(|&c| c == 0).next() == Some(key.as_bytes()))
            .unwrap_or_else(|| panic!("no tag {key}"));
        let mut field = [0u8; 30];
        field[..value.len()].copy_from_slice(value.as_bytes());
        b[at + 20..at + 50].copy_from_slice(&field);
    }
    b
}

#[test]
fn al3d_counts_and_offsets_too_large_for_u64_are_refused() {
    // Found by review while adding the per-reader fuzz targets: 20-digit tag values
    // parse as usize and overflowed the size arithmetic (a panic in debug builds, a
    // wrapped size in release). Each is now refused as truncated: no file holds 2⁶⁴ bytes.
    let read = |tags: &[(&str, &str)]| {
        let b = al3d_with_tags(tags);
        flakescatter_io::al3d::read(
            &b,
            &ReadOptions::default(),
            flakescatter_io::ValueKind::Height,
        )
        .unwrap_err()
        .to_string()
    };
    let max = u64::MAX.to_string(); // 18446744073709551615, 20 digits
    let e = read(&[("TagCount", &max)]);
    assert!(
        e.contains("truncated") && e.contains(&format!("{max} tags at byte 17")),
        "{e}"
    );
    // 2³² - 1 columns and rows: lines of (2³² - 1) x 4 bytes rounded up to 8 = 2³⁴ bytes,
    // and 2³⁴ x (2³² - 2) > 2⁶⁴.
    let e = read(&[("Cols", "4294967295"), ("Rows", "4294967295")]);
    assert!(
        e.contains("the depth image (4294967295 x 4294967295 f32, lines of 17179869184 bytes)"),
        "{e}"
    );
    // An offset of 2⁶⁴ - 1: the error names the file's end (474861 bytes) as the offset.
    let e = read(&[("DepthImageOffset", &max)]);
    assert!(
        e.contains("the depth image (200 x 296 f32") && e.contains("at byte 474861"),
        "{e}"
    );
}

#[test]
fn frt_microprof_frt2() {
    // SurfaceTopography 1.27.1 (the only independent reader that opens FRT; surfalize
    // 0.19.2 has no FRT reader), from `expected.txt`: heights of shape (ny, nx) =
    // (300, 150) (expected.py transposes SurfaceTopography's (nx, ny) array), dx = dy =
    // 2e-4 m, 12314 invalid points, mean 7.262714207028706e-5 m and RMS (numpy `std`:
    // population, about the mean) 8.826763181113768e-6 m of the valid heights.
    // Here every invalid point is the raw value 1 and no raw value lies outside the
    // valid range 5..65529 of block 0x0070 (checked with Python `array` over the 16-bit
    // data), so both readers' rules mask the same points.
    check(
        "frt-2.frt",
        &ReadOptions::default(),
        MapFormat::Frt,
        &Expect {
            nx: 150,
            ny: 300,
            dx: 0.00019999999999999998,
            dy: 0.00019999999999999998,
            invalid: 12314,
            mean: 7.262714207028706e-05,
            rms: 8.826763181113768e-06,
        },
    );
    let (map, _) = read_map(data("frt-2.frt"), &ReadOptions::default()).unwrap();
    // Block 0x0067 (Python `struct`): range x 0.03 m, y 0.06 m over 150 x 300 points,
    // so an x/y swap would show in the pitch as well as in the size.
    assert_eq!((map.dx(), map.dy()), (0.03e6 / 150.0, 0.06e6 / 300.0));
    // The first two raw values of the image (xxd: `821d 821d 781d`) are 7554, and the z
    // scale of block 0x006c is the f64 9.765923032319103e-9 m (struct), so the first
    // height is 7554 x 9.765923032319103e-9 m = 73.77178...µm.
    let want = 7554.0 * 9.765923032319103e-9 * 1e6;
    assert!(
        (map.get(0, 0).unwrap() - want).abs() < 1e-12 * want,
        "{:?}",
        map.get(0, 0)
    );
    let m = map.metadata();
    // Block 0x0077 is the text "TexSimEx_Pin_New"; block 0x0072 holds 1687796545 and
    // 1687797050 (struct), which `date -u -d @N` gives as below; 0x008e the serial.
    assert_eq!(m["frt.parameter_set"], "TexSimEx_Pin_New");
    assert_eq!(m["frt.measurement_started"], "2023-06-26 16:22:25 UTC");
    assert_eq!(m["frt.measurement_ended"], "2023-06-26 16:30:50 UTC");
    assert_eq!(m["frt.sensor_serial"], "SN_1036");
    assert_eq!(m["frt.channel"], "Topography");
    assert_eq!(m["format"], "frt");
}

#[test]
fn frt_microprof_frt1_interrupted_last_row_is_invalid() {
    // SurfaceTopography 1.27.1 gives frt-1.frt as (ny, nx) = (500, 500), dx = dy =
    // 2.4e-5 m, 76456 invalid points, mean 7.87308203748581e-5 m, RMS
    // 4.915785774480653e-6 m: it masks only the raw value 1. But the file's last row
    // (row 499, 500 points) is raw 0 in both images (Python `array`), the measurement
    // end time in block 0x0072 is 0xFFFFFFFF (never written: the scan was interrupted),
    // and block 0x0070 says the valid raw values are 5..65529. FRT's own valid range
    // decides: raw 0 is not a measurement, and read as one it would put 500 points at
    // z = 0 under a surface at ~79 µm and double the RMS. So we mask 500 more points.
    //
    // Our expected numbers follow from SurfaceTopography's alone, by removing 500 heights
    // that are exactly 0 (raw 0 x z scale): with n1 = 250000 - 76456 valid points, the
    // sum n1 m1 and the sum of squares n1 (r1² + m1²) do not change, so with n2 = n1 -
    // 500, m2 = n1 m1 / n2 and r2² = n1 (r1² + m1²) / n2 - m2². (A pure-Python pass over
    // the raw data, outside this project, gives 76956 invalid, mean
    // 7.895830824029983e-5, RMS 2.5045390627769134e-6: the same to 2e-14.)
    let (m1, r1) = (7.87308203748581e-05_f64, 4.915785774480653e-06_f64);
    let n1 = (250_000 - 76_456) as f64;
    let n2 = n1 - 500.0;
    let m2 = n1 * m1 / n2;
    let r2 = (n1 * (r1 * r1 + m1 * m1) / n2 - m2 * m2).sqrt();
    check(
        "frt-1.frt",
        &ReadOptions::default(),
        MapFormat::Frt,
        &Expect {
            nx: 500,
            ny: 500,
            dx: 2.4e-05,
            dy: 2.4e-05,
            invalid: 76_456 + 500,
            mean: m2,
            rms: r2,
        },
    );
    close("python mean", m2, 7.895830824029983e-05, 1e-12);
    close("python rms", r2, 2.5045390627769134e-06, 1e-12);
    let (map, _) = read_map(data("frt-1.frt"), &ReadOptions::default()).unwrap();
    assert!((0..500).all(|col| map.get(col, 499).is_none()));
    let m = map.metadata();
    assert_eq!(m["frt.valid_range"], "5..65529 (block 0x0070), and not 1");
    // Start 1678463840 (`date -u -d @1678463840`); the end was never written.
    assert_eq!(m["frt.measurement_started"], "2023-03-10 15:57:20 UTC");
    assert!(!m.contains_key("frt.measurement_ended"));
    // The intensity image of the same file, as stored: the value 1 is the undefined
    // marker there too (the same 76456 points), and the last row's 0 is kept as the
    // intensity it is (the valid range is the height sensor's).
    let (i, _) =
        flakescatter_io::read_intensity(data("frt-1.frt"), &ReadOptions::default()).unwrap();
    assert_eq!(i.metadata()["frt.channel"], "Intensity");
    assert_eq!(i.len() - i.valid_count(), 76_456);
    assert_eq!(i.get(0, 499), Some(0.0));
}

#[test]
fn frt_channels_are_topography_and_intensity() {
    // Block 0x007d of both files holds two images (walked with `struct`): type 4
    // (topography) and type 2 (intensity), 16 bits each; its first image is byte for
    // byte the single image of block 0x000b.
    for (name, nx, ny, d) in [
        ("frt-1.frt", 500, 500, 24.0),
        ("frt-2.frt", 150, 300, 200.0),
    ] {
        let (ch, format) = list_channels(data(name), &ReadOptions::default()).unwrap();
        assert_eq!(format, MapFormat::Frt);
        let names: Vec<&str> = ch.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["Topography", "Intensity"], "{name}");
        for c in &ch {
            assert_eq!((c.nx, c.ny), (nx, ny), "{name}");
            let (px, py) = c.pitch_um.unwrap();
            assert!((px - d).abs() < 1e-9 && (py - d).abs() < 1e-9, "{name}");
        }
        assert_eq!(ch[0].unit.as_deref(), Some("m"));
        assert_eq!(ch[1].unit, None);
        let intensity = ReadOptions {
            channel: Some(1),
            ..ReadOptions::default()
        };
        let err = read_map(data(name), &intensity).unwrap_err().to_string();
        assert!(
            err.contains("not a height image") && err.contains("Intensity"),
            "{err}"
        );
    }
    // frt-2's intensities (Python `array`): 1..907, the 12314 ones undefined.
    let (i, _) =
        flakescatter_io::read_intensity(data("frt-2.frt"), &ReadOptions::default()).unwrap();
    let max = i.heights().iter().copied().fold(f64::MIN, f64::max);
    assert_eq!((i.len() - i.valid_count(), max), (12_314, 907.0));
}

#[test]
fn frt_truncated_refused_with_offset() {
    // frt-1: inside the 18-byte header, inside block 0x0067 (bytes 56..100), inside the
    // 0x000b image (124..500124), inside the 0x007d images (502530..1502570), inside the
    // last block (0x00a5, payload 1504360..1504364).
    truncations_refused("frt-1.frt", &[17, 60, 300_000, 1_000_000, 1_504_363]);
}

/// An FRT file from blocks `(id, payload)`: version 1.00 (u32 sizes) or 1.01 (u64).
fn frt_file(version: &str, blocks: &[(u16, Vec<u8>)]) -> Vec<u8> {
    let mut b = b"FRTM_GLIDERV".to_vec();
    b.extend(version.as_bytes());
    b.extend((blocks.len() as u16).to_le_bytes());
    for (id, payload) in blocks {
        b.extend(id.to_le_bytes());
        if version == "1.00" {
            b.extend((payload.len() as u32).to_le_bytes());
        } else {
            b.extend((payload.len() as u64).to_le_bytes());
        }
        b.extend(payload);
    }
    b
}

fn le(words: &[u32]) -> Vec<u8> {
    words.iter().flat_map(|w| w.to_le_bytes()).collect()
}

fn f64s(values: &[f64]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

/// Scan range block 0x0067: ranges and offsets (m), y/x ratio, scan direction.
fn range(x: f64, y: f64) -> Vec<u8> {
    let mut v = f64s(&[x, y, 0.0, 0.0, y / x]);
    v.extend(le(&[1]));
    v
}

/// Z scale block 0x006c: range code 5, scale in m.
fn zscale(s: f64) -> Vec<u8> {
    let mut v = le(&[5]);
    v.extend(f64s(&[s]));
    v
}

fn u16s(values: &[u16]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

#[test]
fn frt_hand_built_files() {
    use flakescatter_io::{ValueKind, read_bytes};
    let read = |bytes: &[u8], options: &ReadOptions, kind| {
        read_bytes(bytes, Some("frt"), options, kind).map(|(m, _)| m)
    };
    let opts = ReadOptions::default();
    // Version 1.01 (64-bit block sizes), a single 0x000b image of 3 x 2 points, 16 bits:
    // pitch 3 µm / 3 = 1 µm, 4 µm / 2 = 2 µm; heights raw x 1e-8 m; valid 5..65529, so 1
    // (undefined), 3 (below) and 65530 (above) are invalid.
    let single = frt_file(
        "1.01",
        &[
            (0x0066, le(&[3, 2, 16])),
            (0x0067, range(3e-6, 4e-6)),
            (0x006c, zscale(1e-8)),
            (0x0070, le(&[5, 65529])),
            (0x0042, vec![7; 5]), // an unknown block, skipped by its size
            (0x000b, u16s(&[100, 1, 3, 65530, 7, 65529])),
        ],
    );
    let m = read(&single, &opts, ValueKind::Height).unwrap();
    assert_eq!((m.nx(), m.ny(), m.dx(), m.dy()), (3, 2, 1.0, 2.0));
    let want = [Some(1.0), None, None, None, Some(0.07), Some(655.29)];
    for (k, w) in want.iter().enumerate() {
        let got = m.get(k % 3, k / 3);
        assert_eq!(got.is_some(), w.is_some(), "point {k}: {got:?}");
        if let (Some(g), Some(w)) = (got, w) {
            assert!((g - w).abs() < 1e-12 * w, "point {k}: {g} vs {w}");
        }
    }
    assert_eq!(m.metadata()["frt.version"], "1.01");

    // Version 1.00, block 0x007d with a 32-bit topography of the bottom sensor and a
    // 16-bit intensity: the valid range is not applied to 32-bit data (-5 stays), 1 is
    // undefined in both; the intensities are returned as stored.
    let mut images = u16s(&[0, 0, 4, 0]);
    images.extend(le(&[0x1000_0004, 2, 1, 32]));
    images.extend(le(&[(-5i32) as u32, 1]));
    images.extend(le(&[2, 2, 1, 16]));
    images.extend(u16s(&[3, 1]));
    let multi = |images: Vec<u8>| {
        frt_file(
            "1.00",
            &[
                (0x0067, range(2e-6, 1e-6)),
                (0x006c, zscale(1e-8)),
                (0x0070, le(&[5, 65529])),
                (0x007d, images),
            ],
        )
    };
    let f = multi(images.clone());
    let (ch, _) = list_channels_bytes(&f, Some("frt"), &opts).unwrap();
    let names: Vec<&str> = ch.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["Topography (bottom sensor)", "Intensity"]);
    let h = read(&f, &opts, ValueKind::Height).unwrap();
    assert_eq!((h.get(0, 0), h.get(1, 0)), (Some(-0.05), None));
    let i = read(&f, &opts, ValueKind::Intensity).unwrap();
    assert_eq!((i.get(0, 0), i.get(1, 0)), (Some(3.0), None));
    // Two images of the same type and sensor get their index appended.
    let mut twice = images.clone();
    twice.extend(le(&[2, 1, 1, 16]));
    twice.extend(u16s(&[9]));
    let (ch, _) = list_channels_bytes(&multi(twice), Some("frt"), &opts).unwrap();
    let names: Vec<&str> = ch.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "Topography (bottom sensor)",
            "Intensity [1]",
            "Intensity [2]"
        ]
    );

    // Lying or unusable blocks: an error naming the block and byte, never a panic.
    let err = |bytes: &[u8], options: &ReadOptions| {
        read(bytes, options, ValueKind::Height)
            .unwrap_err()
            .to_string()
    };
    let mut long = images.clone();
    long.truncate(long.len() - 1); // the intensity image now lacks a byte
    let e = err(&multi(long), &opts);
    // Header 18 + blocks of 50, 18 and 14 bytes: block 0x007d at 100, its payload at
    // 106, the ids, the first image (16 + 8 bytes) from 114, the second's header at 138.
    assert!(
        e.contains("block 0x007d (byte 138)") && e.contains("needs 4 bytes from byte 154"),
        "{e}"
    );
    let mut eight = images.clone();
    eight[20..24].copy_from_slice(&8u32.to_le_bytes());
    let e = err(&multi(eight), &opts);
    assert!(e.contains("8 bits per point: expected 16 or 32"), "{e}");
    let mut tail = images.clone();
    tail.extend([0; 5]);
    let e = err(&multi(tail), &opts);
    assert!(e.contains("5 bytes left"), "{e}");
    let e = err(
        &frt_file(
            "1.00",
            &[(0x0067, range(1e-6, 1e-6)), (0x0067, range(1e-6, 1e-6))],
        ),
        &opts,
    );
    assert!(
        e.contains("block 0x0067 (byte 68): appears a second time (first at byte 18)"),
        "{e}"
    );
    let e = err(&frt_file("1.00", &[(0x0067, range(1e-6, 1e-6))]), &opts);
    assert!(
        e.contains("block 0x000b (the image data) is missing"),
        "{e}"
    );
    let mut v102 = single.clone();
    v102[12..16].copy_from_slice(b"1.02");
    assert!(err(&v102, &opts).contains("version (byte 12) = \"1.02\""));
    let mut size = single.clone();
    size[20..28].copy_from_slice(&u64::MAX.to_le_bytes()); // block 0x0066's size
    let e = err(&size, &opts);
    assert!(e.contains("truncated") && e.contains("block 0x0066"), "{e}");
    let wrong = frt_file(
        "1.00",
        &[
            (0x0066, le(&[3, 2, 16])),
            (0x0067, range(3e-6, 4e-6)),
            (0x006c, zscale(1e-8)),
            (0x000b, u16s(&[1, 2, 3, 4, 5])),
        ],
    );
    assert!(err(&wrong, &opts).contains("holds 10 bytes, but block 0x0066 says 3 x 2"));
    // Without a scan range the pitch must be given; without a z scale, no heights.
    let bare = frt_file("1.00", &[(0x006c, zscale(1e-8)), (0x007d, images.clone())]);
    assert!(err(&bare, &opts).contains("block 0x0067 (the scan range) is missing"));
    let pitch = ReadOptions {
        pixel_um: Some((1.0, 1.0)),
        ..ReadOptions::default()
    };
    assert!(read(&bare, &pitch, ValueKind::Height).is_ok());
    let no_z = frt_file("1.00", &[(0x0067, range(2e-6, 1e-6)), (0x007d, images)]);
    assert!(err(&no_z, &opts).contains("block 0x006c (the z scale) is missing"));
    assert!(read(&no_z, &opts, ValueKind::Intensity).is_ok());
}

// ---- Intensity channels of the same file (issue 14) ----------------------------------
//
// The numbers are from `fixtures/real/instruments/expected_channels.py` (output in
// `expected-channels.txt`): Gwyddion 2.62's importers (run as `gwyddion
// --convert-to-gwy`, the result opened with gwyfile) and surfalize 0.19.2
// (`read_image_layers=True`). Besides the statistics, each channel is checked at one
// point (x = 11, y = 7) and by the mean of its first row, which a transposed, flipped or
// shifted image would not match.

/// (mean, min, max, rms about the mean) of the valid values, and the first row's mean.
fn value_stats(map: &flakescatter_stats::heightmap::HeightMap) -> (f64, f64, f64, f64, f64) {
    let v: Vec<f64> = map
        .heights()
        .iter()
        .zip(map.valid())
        .filter(|(_, ok)| **ok)
        .map(|(z, _)| *z)
        .collect();
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let rms = (v.iter().map(|z| (z - mean).powi(2)).sum::<f64>() / n).sqrt();
    let min = v.iter().copied().fold(f64::INFINITY, f64::min);
    let max = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let row0 = map.heights()[..map.nx()].iter().sum::<f64>() / map.nx() as f64;
    (mean, min, max, rms, row0)
}

/// What an intensity channel must hold: the independent readers' numbers.
struct Intensity {
    name: &'static str,
    nx: usize,
    ny: usize,
    mean: f64,
    min: f64,
    max: f64,
    rms: f64,
    row0_mean: f64,
    at_11_7: f64,
}

/// Reads channel `want.name` of `file` as intensity (selected by name) beside the
/// height channel 0, and compares it with `want`.
fn check_intensity(file: &str, want: &Intensity) -> flakescatter_io::SelectedRead {
    use flakescatter_io::{ChannelSelector, read_selected};
    let sel = ChannelSelector::Name(want.name.into());
    let r = read_selected(data(file), &ReadOptions::default(), None, Some(&sel))
        .unwrap_or_else(|e| panic!("{file}: {e}"));
    let (map, index) = r.intensity.as_ref().expect("an intensity channel");
    assert_eq!(r.channels[*index].name, want.name, "{file}");
    assert_eq!(r.channels[*index].unit.as_deref(), Some("a.u."), "{file}");
    assert_eq!((map.nx(), map.ny()), (want.nx, want.ny), "{file} size");
    assert_eq!(
        (r.map.dx(), r.map.dy()),
        (map.dx(), map.dy()),
        "{file} pitch"
    );
    assert_eq!(map.valid_count(), map.len(), "{file}: every point valid");
    let (mean, min, max, rms, row0) = value_stats(map);
    close(
        &format!("{file} {} mean", want.name),
        mean,
        want.mean,
        1e-12,
    );
    close(&format!("{file} {} rms", want.name), rms, want.rms, 1e-10);
    close(
        &format!("{file} {} row 0", want.name),
        row0,
        want.row0_mean,
        1e-12,
    );
    assert_eq!((min, max), (want.min, want.max), "{file} {}", want.name);
    assert_eq!(map.get(11, 7), Some(want.at_11_7), "{file} {}", want.name);
    assert_eq!(
        map.metadata()["values"],
        "intensity as stored in the file (unit-less)"
    );
    r
}

#[test]
fn plu_grey_image_is_an_intensity_channel() {
    // Gwyddion "Gray" and surfalize "Grayscale" agree: 768 x 576 grey levels (R = G = B
    // at every point, checked in numpy), mean 172.70937997323495, min 0, max 255, rms
    // 22.29511928287382, first row's mean 164.3125, 160 at x = 11, y = 7.
    let r = check_intensity(
        "plu-1.plu",
        &Intensity {
            name: "image0",
            nx: 768,
            ny: 576,
            mean: 172.70937997323495,
            min: 0.0,
            max: 255.0,
            rms: 22.29511928287382,
            row0_mean: 164.3125,
            at_11_7: 160.0,
        },
    );
    let names: Vec<&str> = r.channels.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["layer0", "image0"]);
    assert_eq!(r.channels[0].unit.as_deref(), Some("µm"));
    // The cutoff: expected_channels.py counts 212266 of the 442368 grey levels below 170,
    // so 442368 - 212266 = 230102 points stay valid (every height is valid).
    let mut map = r.map;
    let (grey, _) = r.intensity.unwrap();
    assert_eq!(map.apply_intensity_cutoff(&grey, 170.0).unwrap(), 230_102);
    assert_eq!(map.valid_count(), 230_102);
}

#[test]
fn metropro_intensity_frame_is_an_intensity_channel() {
    // Gwyddion "Intensity" and surfalize "Intensity" agree: 640 x 480 (ac_width x
    // ac_height at bytes 52, 54; one bucket), mean 99.83694986979167, min 35, max 140,
    // rms 19.787925083448343, first row's mean 131.3953125, 116 at x = 11, y = 7.
    let r = check_intensity(
        "metropro-1.dat",
        &Intensity {
            name: "intensity",
            nx: 640,
            ny: 480,
            mean: 99.83694986979167,
            min: 35.0,
            max: 140.0,
            rms: 19.787925083448343,
            row0_mean: 131.3953125,
            at_11_7: 116.0,
        },
    );
    let names: Vec<&str> = r.channels.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["phase", "intensity"]);
    // 150521 of the 307200 values are below 100 (expected_channels.py): 156679 stay.
    let mut map = r.map;
    let (i, _) = r.intensity.unwrap();
    assert_eq!(map.apply_intensity_cutoff(&i, 100.0).unwrap(), 156_679);
    assert!(i.metadata().contains_key("metropro.ac_range"));
}

#[test]
fn al3d_texture_planes_are_intensity_channels() {
    // Gwyddion imports the planes TexturePtr = 0;1;2 as "Texture (R)", "(G)", "(B)",
    // each byte / 256; times 256 (expected_channels.py): R mean 91.14765202702702, first
    // row 45.01, 123 at x = 11, y = 7; G 91.15194256756757, 88.225, 131; B
    // 90.90038851351352, 66.375, 127; their mean per point: mean 91.06666103603602, min
    // 43.333333333333336, max 255, rms 21.198850620791003, first row 66.53666666666668,
    // 127 at (11, 7). surfalize and SurfaceTopography read no AL3D texture.
    let (channels, _) = list_channels(data("al3d-1.al3d"), &ReadOptions::default()).unwrap();
    let names: Vec<&str> = channels.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(
        names,
        ["depth", "texture", "texture-r", "texture-g", "texture-b"]
    );
    for (name, mean, row0, v) in [
        ("texture-r", 91.14765202702702, 45.01, 123.0),
        ("texture-g", 91.15194256756757, 88.225, 131.0),
        ("texture-b", 90.90038851351352, 66.375, 127.0),
    ] {
        use flakescatter_io::{ChannelSelector, read_selected};
        let sel = ChannelSelector::Name(name.into());
        let r = read_selected(
            data("al3d-1.al3d"),
            &ReadOptions::default(),
            None,
            Some(&sel),
        )
        .unwrap();
        let (m, _) = r.intensity.unwrap();
        let (got_mean, _, _, _, got_row0) = value_stats(&m);
        close(name, got_mean, mean, 1e-12);
        close(name, got_row0, row0, 1e-12);
        assert_eq!(m.get(11, 7), Some(v), "{name}");
    }
    let r = check_intensity(
        "al3d-1.al3d",
        &Intensity {
            name: "texture",
            nx: 200,
            ny: 296,
            mean: 91.06666103603602,
            min: 43.333333333333336,
            max: 255.0,
            rms: 21.198850620791003,
            row0_mean: 66.53666666666668,
            at_11_7: 127.0,
        },
    );
    // The depth at (11, 7) is Gwyddion's too (0.07635712623596191 m), so both readers
    // orient the rows alike and the texture comparison above is point for point.
    close(
        "depth",
        r.map.get(11, 7).unwrap() * 1e-6,
        0.07635712623596191,
        1e-12,
    );
    // 37555 of the 59200 texture means are below 90 (expected_channels.py): 21645 stay.
    let mut map = r.map;
    let (t, _) = r.intensity.unwrap();
    assert_eq!(map.apply_intensity_cutoff(&t, 90.0).unwrap(), 21_645);
}

#[test]
fn channels_by_name_and_kind_mismatches_are_refused_with_the_list() {
    use flakescatter_io::{ChannelError, ChannelSelector, read_selected};
    let plu = data("plu-1.plu");
    let name = |n: &str| ChannelSelector::Name(n.into());
    // Case-insensitive when unique; the index of a name is its place in the list.
    let r = read_selected(
        &plu,
        &ReadOptions::default(),
        Some(&name("LAYER0")),
        Some(&name("Image0")),
    )
    .unwrap();
    assert_eq!((r.channel, r.intensity.map(|(_, i)| i)), (0, Some(1)));
    // An unknown name: the error lists every channel with unit and size.
    let e = read_selected(&plu, &ReadOptions::default(), Some(&name("phase")), None).unwrap_err();
    let text = e.to_string();
    assert!(
        text.contains("plu-1.plu")
            && text.contains("\"phase\"")
            && text.contains("0 = layer0 (µm, 768 x 576), 1 = image0 (a.u., 768 x 576)"),
        "{text}"
    );
    // The image as heights, the layer as intensity: refused, naming the channel.
    let e = read_selected(&plu, &ReadOptions::default(), Some(&name("image0")), None).unwrap_err();
    assert!(
        e.to_string().contains("image0 holds an intensity image"),
        "{e}"
    );
    let e = read_selected(
        &plu,
        &ReadOptions::default(),
        None,
        Some(&ChannelSelector::Index(0)),
    )
    .unwrap_err();
    assert!(
        matches!(
            e,
            ReadMapError::Format {
                error: MapError::Channel(ChannelError::SameAsHeight { index: 0, .. }),
                ..
            }
        ),
        "{e:?}"
    );
    // MetroPro and AL3D: the height channel read as intensity, and the other way round.
    let dat = data("metropro-1.dat");
    let e = flakescatter_io::read_intensity(&dat, &ReadOptions::default()).unwrap_err();
    assert!(e.to_string().contains("phase holds heights"), "{e}");
    let one = ReadOptions {
        channel: Some(1),
        ..ReadOptions::default()
    };
    let e = read_map(&dat, &one).unwrap_err();
    assert!(
        e.to_string().contains("intensity holds an intensity frame"),
        "{e}"
    );
    let e = read_map(data("al3d-1.al3d"), &one).unwrap_err();
    assert!(
        e.to_string().contains("texture is an intensity image"),
        "{e}"
    );
    let e =
        flakescatter_io::read_intensity(data("al3d-1.al3d"), &ReadOptions::default()).unwrap_err();
    assert!(e.to_string().contains("depth channel holds heights"), "{e}");
}

#[test]
fn converted_files_keep_date_maker_and_serial() {
    // What the ISO writers carry over from each instrument file (io::provenance). Every
    // acquisition date, maker and serial here is SurfaceTopography 1.27.1's too
    // (`open_topography(f).channels[0].info`: `acquisition_time`, `instrument`), seen on
    // the raw bytes as well: `strings plu-1.plu` shows `Fri Mar 10 16:35:59 2023`,
    // `strings opd-1.opd` `16:19:48` and `7/7/2015`; sur-3.sur's date words (u16 LE:
    // 53 s, 8 min, 10 h, day 22, month 6, year 0x07e7); metropro-1.dat's big-endian time
    // stamp at byte 76 is 1311439776, GNU `date -u -d @1311439776` 2011-07-23 16:49:36
    // UTC; frt-2 starts at 1687796545 s (block 0x72), 2023-06-26 16:22:25 UTC. The
    // SUR file names no maker (SurfaceTopography's "Digital Surf" is the software's).
    use flakescatter_io::{read_map_bytes, sdf, x3p};
    let cases = [
        ("plu-1.plu", "2023-03-10T16:35:59", "Sensofar", "N/A"),
        ("opd-1.opd", "2015-07-07T16:19:48", "Wyko", "N/A"),
        ("sur-3.sur", "2023-06-22T10:08:53", "N/A", "N/A"),
        ("metropro-1.dat", "2011-07-23T16:49:36Z", "Zygo", "N/A"),
        ("frt-2.frt", "2023-06-26T16:22:25Z", "FRT", "SN_1036"),
    ];
    for (file, date, maker, serial) in cases {
        let (map, _) = read_map(data(file), &ReadOptions::default()).unwrap();
        let bytes = x3p::write_x3p_bytes(&map).unwrap();
        let (back, _) = read_map_bytes(&bytes, &ReadOptions::default()).unwrap();
        let m = back.metadata();
        let get = |k: &str| m.get(k).map(String::as_str);
        assert_eq!(get("x3p.date"), Some(date), "{file}");
        assert_eq!(get("x3p.instrument.manufacturer"), Some(maker), "{file}");
        assert_eq!(get("x3p.instrument.serial"), Some(serial), "{file}");
        // The comment names the source format and holds its other fields.
        let comment = get("x3p.comment").unwrap();
        let format = map.metadata()["format"].clone();
        assert!(
            comment.contains(&format!("from a {format} file")),
            "{comment}"
        );
        let (some_key, some_value) = map
            .metadata()
            .iter()
            .find(|(k, _)| k.starts_with(&format!("{format}.")))
            .unwrap();
        assert!(
            comment.contains(&format!("{some_key}={}", some_value.trim())),
            "{comment}"
        );
        // SDF holds the date to the minute and ten characters of the maker.
        let text = sdf::write_sdf_text(&map, flakescatter_io::ValueKind::Height);
        let sdf_date = format!(
            "{}{}{}{}{}",
            &date[8..10],
            &date[5..7],
            &date[..4],
            &date[11..13],
            &date[14..16]
        );
        assert!(
            text.contains(&format!("CreateDate  = {sdf_date}\n")),
            "{file}"
        );
        let id = if maker == "N/A" { "flakescat" } else { maker };
        assert!(text.contains(&format!("ManufacID   = {id}\n")), "{file}");
    }
    // Round trips within a format change nothing: an X3P's own fields win.
    let (x, _) = read_map(data("../testing.x3p"), &ReadOptions::default()).unwrap();
    let (back, _) =
        read_map_bytes(&x3p::write_x3p_bytes(&x).unwrap(), &ReadOptions::default()).unwrap();
    for k in ["x3p.date", "x3p.comment", "x3p.instrument.manufacturer"] {
        assert_eq!(back.metadata().get(k), x.metadata().get(k), "{k}");
    }
}
