//! Bad input gives a clear typed error naming the problem, never a panic.
//!
//! The X3P archives here are assembled in the test with the zip crate from a `main.xml`
//! written from ISO 25178-72 (the layout of the real files in `fixtures/real`),
//! so each one differs from a valid file in exactly one way.

use std::io::Write;

use flakescatter_io::map::MapError;
use flakescatter_io::sdf::SdfError;
use flakescatter_io::text::TextError;
use flakescatter_io::x3p::X3pError;
use flakescatter_io::{ReadMapError, ReadOptions, ZUnit, read_map, read_map_bytes};
use md5::{Digest, Md5};

fn md5_hex(b: &[u8]) -> String {
    Md5::digest(b).iter().map(|x| format!("{x:02x}")).collect()
}

/// A `main.xml` for an `nx` x `ny` map with Z data type `dtype` and X increment `incx`.
fn xml(nx: &str, ny: &str, dtype: &str, incx: &str) -> String {
    format!(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<p:ISO5436_2 xmlns:p="http://www.opengps.eu/2008/ISO5436_2">
  <Record1><Revision>ISO5436 - 2000</Revision><FeatureType>SUR</FeatureType>
    <Axes>
      <CX><AxisType>I</AxisType><DataType>D</DataType><Increment>{incx}</Increment><Offset>0</Offset></CX>
      <CY><AxisType>I</AxisType><DataType>D</DataType><Increment>1e-6</Increment><Offset>0</Offset></CY>
      <CZ><AxisType>A</AxisType><DataType>{dtype}</DataType><Increment>1e-6</Increment><Offset>0</Offset></CZ>
    </Axes></Record1>
  <Record2><Date>2024-01-01T00:00:00</Date><Creator>test</Creator></Record2>
  <Record3><MatrixDimension><SizeX>{nx}</SizeX><SizeY>{ny}</SizeY><SizeZ>1</SizeZ></MatrixDimension>
    <DataLink><PointDataLink>bindata/data.bin</PointDataLink></DataLink></Record3>
  <Record4><ChecksumFile>md5checksum.hex</ChecksumFile></Record4>
</p:ISO5436_2>
"#
    )
}

/// Zips the given members; `main.xml` gets a correct `md5checksum.hex` unless one is given.
fn zip_members(members: &[(&str, &[u8])]) -> Vec<u8> {
    let mut zip = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let opts = zip::write::SimpleFileOptions::default();
    let has_md5 = members.iter().any(|(n, _)| *n == "md5checksum.hex");
    for (name, bytes) in members {
        zip.start_file(*name, opts).unwrap();
        zip.write_all(bytes).unwrap();
        if *name == "main.xml" && !has_md5 {
            zip.start_file("md5checksum.hex", opts).unwrap();
            zip.write_all(format!("{} *main.xml\n", md5_hex(bytes)).as_bytes())
                .unwrap();
        }
    }
    zip.finish().unwrap().into_inner()
}

fn x3p(main: &str, data: &[u8]) -> Vec<u8> {
    zip_members(&[("main.xml", main.as_bytes()), ("bindata/data.bin", data)])
}

fn f64_data(values: &[f64]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

fn x3p_err(bytes: &[u8]) -> X3pError {
    match read_map_bytes(bytes, &ReadOptions::default()) {
        Err(MapError::X3p(e)) => e,
        other => panic!("expected an X3P error, got {other:?}"),
    }
}

fn text_err(bytes: &[u8], options: &ReadOptions) -> TextError {
    match read_map_bytes(bytes, options) {
        Err(MapError::Text(e)) => e,
        other => panic!("expected a text error, got {other:?}"),
    }
}

fn sdf_err(bytes: &[u8]) -> SdfError {
    match read_map_bytes(bytes, &ReadOptions::default()) {
        Err(MapError::Sdf(e)) => e,
        other => panic!("expected an SDF error, got {other:?}"),
    }
}

#[test]
fn hand_built_x3p_is_read() {
    // The control: a 2 x 2 float64 map of 1, 2, 3, NaN raw values with Z Increment 1e-6 m,
    // so heights are 1, 2, 3 µm and one invalid point; pitch 0.5 µm x 1 µm.
    let bytes = x3p(
        &xml("2", "2", "D", "0.5e-6"),
        &f64_data(&[1.0, 2.0, 3.0, f64::NAN]),
    );
    let (map, _) = read_map_bytes(&bytes, &ReadOptions::default()).unwrap();
    assert_eq!((map.nx(), map.ny(), map.dx(), map.dy()), (2, 2, 0.5, 1.0));
    assert_eq!(map.get(0, 1), Some(3.0));
    assert_eq!(map.valid_count(), 3);
}

#[test]
fn integer_data_types_scale_by_increment() {
    // int16 raw -3, 7 and int32 raw 100000 with Z Increment 1e-6 m: heights in µm equal the
    // raw values.
    let data: Vec<u8> = [-3i16, 7].iter().flat_map(|v| v.to_le_bytes()).collect();
    let (map, _) = read_map_bytes(
        &x3p(&xml("2", "1", "I", "1e-6"), &data),
        &ReadOptions::default(),
    )
    .unwrap();
    assert_eq!(map.heights(), &[-3.0, 7.0]);
    let data = 100_000i32.to_le_bytes();
    let (map, _) = read_map_bytes(
        &x3p(&xml("1", "1", "L", "1e-6"), &data),
        &ReadOptions::default(),
    )
    .unwrap();
    assert_eq!(map.heights(), &[100_000.0]);
}

#[test]
fn truncated_zip() {
    let bytes = x3p(&xml("2", "2", "D", "1e-6"), &f64_data(&[0.0; 4]));
    for len in [0, 4, 30, bytes.len() / 2, bytes.len() - 1] {
        let e = read_map_bytes(&bytes[..len], &ReadOptions::default());
        assert!(e.is_err(), "truncated to {len} bytes was accepted");
    }
    assert!(matches!(
        x3p_err(&bytes[..bytes.len() / 2]),
        X3pError::Zip(_)
    ));
}

#[test]
fn corrupt_zip() {
    let mut bytes = x3p(&xml("2", "2", "D", "1e-6"), &f64_data(&[0.0; 4]));
    // Overwrite the end-of-central-directory record's offset field.
    let n = bytes.len();
    for b in &mut bytes[n - 6..n - 2] {
        *b = 0xff;
    }
    assert!(matches!(x3p_err(&bytes), X3pError::Zip(_)));
}

#[test]
fn missing_main_xml() {
    let bytes = zip_members(&[("bindata/data.bin", &f64_data(&[0.0]))]);
    let e = x3p_err(&bytes);
    assert_eq!(e, X3pError::MissingMember("main.xml".into()));
    assert!(e.to_string().contains("main.xml"));
}

#[test]
fn missing_data_member() {
    let main = xml("1", "1", "D", "1e-6");
    let bytes = zip_members(&[("main.xml", main.as_bytes())]);
    assert_eq!(
        x3p_err(&bytes),
        X3pError::MissingMember("bindata/data.bin".into())
    );
}

#[test]
fn wrong_data_length() {
    // 3 x 2 float64 needs 48 bytes; give 40.
    let e = x3p_err(&x3p(&xml("3", "2", "D", "1e-6"), &f64_data(&[0.0; 5])));
    assert!(
        matches!(
            e,
            X3pError::DataLength {
                expected: 48,
                found: 40,
                ..
            }
        ),
        "{e:?}"
    );
    assert!(e.to_string().contains("bindata/data.bin"));
}

#[test]
fn data_longer_than_declared_is_not_inflated_whole() {
    // A 1 x 1 float64 header over 64 MiB of zeros (a few kB deflated): the reader stops
    // after 9 bytes and reports the size the archive declares.
    let main = xml("1", "1", "D", "1e-6");
    let big = vec![0u8; 64 << 20];
    let mut zip = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let opts = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated);
    zip.start_file("main.xml", opts).unwrap();
    zip.write_all(main.as_bytes()).unwrap();
    zip.start_file("md5checksum.hex", opts).unwrap();
    zip.write_all(md5_hex(main.as_bytes()).as_bytes()).unwrap();
    zip.start_file("bindata/data.bin", opts).unwrap();
    zip.write_all(&big).unwrap();
    let bytes = zip.finish().unwrap().into_inner();
    assert!(bytes.len() < 1 << 20);
    let e = x3p_err(&bytes);
    assert!(
        matches!(
            e,
            X3pError::DataLength {
                expected: 8,
                found: 67_108_864,
                ..
            }
        ),
        "{e:?}"
    );
}

#[test]
fn unknown_data_type() {
    let e = x3p_err(&x3p(&xml("1", "1", "Q", "1e-6"), &[0; 8]));
    assert!(matches!(&e, X3pError::BadValue { element, value, .. }
        if element == "Record1/Axes/CZ/DataType" && value == "Q"));
}

#[test]
fn bad_xml() {
    let e = x3p_err(&x3p("<ISO5436_2><Record1>", &[]));
    assert!(matches!(e, X3pError::Xml(_)), "{e:?}");
    let e = x3p_err(&x3p("<Surface/>", &[]));
    assert!(e.to_string().contains("<Surface>"), "{e}");
    let e = x3p_err(&x3p(&xml("two", "2", "D", "1e-6"), &[]));
    assert!(matches!(&e, X3pError::BadValue { value, .. } if value == "two"));
    let e = x3p_err(&x3p(&xml("0", "2", "D", "1e-6"), &[]));
    assert!(
        matches!(&e, X3pError::BadValue { element, value, .. }
            if element == "Record3/MatrixDimension/SizeX" && value == "0"),
        "{e:?}"
    );
}

#[test]
fn non_finite_or_negative_pitch() {
    // Every unusable CX Increment is refused naming the element (an empty one is missing).
    for inc in ["inf", "NaN", "-1e-6", "0", "abc", "1e-400"] {
        let bytes = x3p(&xml("1", "1", "D", inc), &f64_data(&[0.0]));
        let e = x3p_err(&bytes);
        assert!(
            matches!(&e, X3pError::BadValue { element, value, .. }
                if element == "Record1/Axes/CX/Increment" && value == inc),
            "increment {inc:?}: {e:?}"
        );
        assert!(e.to_string().contains("> 0"), "{e}");
    }
    let e = x3p_err(&x3p(&xml("1", "1", "D", ""), &f64_data(&[0.0])));
    assert_eq!(
        e,
        X3pError::MissingElement("Record1/Axes/CX/Increment".into())
    );
    let e = text_err(
        b"# Width: inf m\n# Height: 1 m\n# Value units: m\n1 2\n",
        &ReadOptions::default(),
    );
    assert!(matches!(e, TextError::BadHeader { line: 1, .. }), "{e:?}");
    let options = ReadOptions {
        pixel_um: Some((1.0, f64::INFINITY)),
        z_unit: Some(ZUnit::Um),
        ..ReadOptions::default()
    };
    let e = read_map_bytes(b"1 2\n", &options).unwrap_err();
    assert!(matches!(e, MapError::Pitch(_)), "{e:?}");
}

#[test]
fn md5_mismatch_is_refused_unless_accepted() {
    let main = xml("1", "1", "D", "1e-6");
    let bytes = zip_members(&[
        ("main.xml", main.as_bytes()),
        (
            "md5checksum.hex",
            b"00000000000000000000000000000000 *main.xml\n",
        ),
        ("bindata/data.bin", &f64_data(&[1.0])),
    ]);
    let e = x3p_err(&bytes);
    assert!(matches!(e, X3pError::Md5Mismatch { .. }));
    assert!(e.to_string().contains("--accept-md5-mismatch"), "{e}");
    let accept = ReadOptions {
        accept_md5_mismatch: true,
        ..ReadOptions::default()
    };
    let (map, _) = read_map_bytes(&bytes, &accept).unwrap();
    assert!(map.metadata()["x3p.md5_mismatch"].contains("00000000"));
}

#[test]
fn valid_bin_masks_points_lsb_first() {
    // 3 x 3 map, valid.bin = 0b1111_0101, 0b0000_0001: points 1 and 3 invalid (bits clear,
    // least significant bit first), point 8 valid from the second byte.
    let mut main = xml("3", "3", "D", "1e-6");
    main = main.replace(
        "<PointDataLink>bindata/data.bin</PointDataLink>",
        "<PointDataLink>bindata/data.bin</PointDataLink><ValidPointsLink>bindata/valid.bin</ValidPointsLink>",
    );
    let bytes = zip_members(&[
        ("main.xml", main.as_bytes()),
        ("bindata/data.bin", &f64_data(&[1.0; 9])),
        ("bindata/valid.bin", &[0b1111_0101, 0b0000_0001]),
    ]);
    let (map, _) = read_map_bytes(&bytes, &ReadOptions::default()).unwrap();
    assert_eq!(
        map.valid(),
        &[true, false, true, false, true, true, true, true, true]
    );
    // Too short a valid.bin is an error.
    let bytes = zip_members(&[
        ("main.xml", main.as_bytes()),
        ("bindata/data.bin", &f64_data(&[1.0; 9])),
        ("bindata/valid.bin", &[0xff]),
    ]);
    assert!(matches!(x3p_err(&bytes), X3pError::DataLength { .. }));
}

#[test]
fn ragged_text_rows() {
    let options = ReadOptions {
        pixel_um: Some((1.0, 1.0)),
        z_unit: Some(ZUnit::Nm),
        ..ReadOptions::default()
    };
    let e = text_err(b"1 2 3\n4 5 6\n7 8\n", &options);
    assert_eq!(
        e,
        TextError::Ragged {
            line: 3,
            expected: 3,
            found: 2
        }
    );
    // One comma per line and nothing else: `1,2` is 1.2 or two values; refused unless said.
    let e = text_err(b"1,2\n3,x\n", &options);
    assert!(
        matches!(&e, TextError::AmbiguousDecimal { line: 1, token, .. } if token == "1,2"),
        "{e:?}"
    );
    assert!(e.to_string().contains("--decimal-comma"), "{e}");
    let point = ReadOptions {
        decimal: flakescatter_io::DecimalMark::Point,
        ..options
    };
    let e = text_err(b"1,2\n3,x\n", &point);
    assert_eq!(
        e,
        TextError::BadNumber {
            line: 2,
            column: 2,
            token: "x".into()
        }
    );
    // The same matrix without errors reads, in nm -> µm.
    let (map, _) = read_map_bytes(b"1000, 2000\n3000, 4000\n", &options).unwrap();
    assert_eq!(map.heights(), &[1.0, 2.0, 3.0, 4.0]);
}

#[test]
fn profile_header_over_one_column_rows() {
    // Found by the fuzz test (it used to index past the end of the row).
    let options = ReadOptions {
        z_unit: Some(ZUnit::Um),
        ..ReadOptions::default()
    };
    let e = text_err(b"x_um,z\n0.1\n0.2\n", &options);
    assert_eq!(
        e,
        TextError::Ragged {
            line: 2,
            expected: 2,
            found: 1
        }
    );
}

#[test]
fn profile_x_column_must_increase() {
    let options = ReadOptions {
        z_unit: Some(ZUnit::Um),
        ..ReadOptions::default()
    };
    for text in [
        &b"x_um,z\n0.3,1\n0.2,2\n0.1,3\n"[..],
        b"x_um,z\n0.1,1\n0.1,2\n",
    ] {
        let e = text_err(text, &options);
        assert!(
            matches!(e, TextError::ProfileNotIncreasing { line: 2, .. }),
            "{e:?}"
        );
    }
}

#[test]
fn xyz_point_lists_are_not_read_as_three_column_maps() {
    let options = ReadOptions {
        pixel_um: Some((1.0, 1.0)),
        z_unit: Some(ZUnit::Um),
        ..ReadOptions::default()
    };
    // x = 0, 1, 2 times y = 0, 1 (Gwyddion's XYZ export order): a map of coordinates if
    // read as a matrix.
    let xyz = b"0 0 1.5\n1 0 1.25\n2 0 1\n0 1 1.75\n1 1 1.5\n2 1 1.25\n";
    let e = text_err(xyz, &options);
    assert_eq!(
        e,
        TextError::PointList {
            line: 1,
            nx: 3,
            ny: 2
        }
    );
    // A 3-column height matrix reads (its first two columns repeat a pair).
    let (map, _) = read_map_bytes(b"0 0 1\n0 0 2\n1 1 3\n1 1 4\n", &options).unwrap();
    assert_eq!((map.nx(), map.ny()), (3, 4));
}

#[test]
fn text_needs_calibration() {
    let e = text_err(b"1 2\n3 4\n", &ReadOptions::default());
    assert_eq!(e, TextError::MissingZUnit);
    let only_z = ReadOptions {
        z_unit: Some(ZUnit::M),
        ..ReadOptions::default()
    };
    let e = text_err(b"1 2\n3 4\n", &only_z);
    assert_eq!(e, TextError::MissingPitch);
    assert!(e.to_string().contains("--pixel-um"));
}

#[test]
fn empty_files() {
    let options = ReadOptions {
        pixel_um: Some((1.0, 1.0)),
        z_unit: Some(ZUnit::Um),
        ..ReadOptions::default()
    };
    for bytes in [&b"\n\n"[..], b"# Width: 1 m\n", b"  \n"] {
        assert_eq!(text_err(bytes, &options), TextError::Empty);
    }
    // Zero bytes is no format at all, and says so.
    let e = read_map_bytes(b"", &options).unwrap_err();
    assert!(matches!(e, MapError::Empty { expected: None }), "{e:?}");
    assert_eq!(e.to_string(), "the file is empty (0 bytes)");
    let e = read_map_bytes(b"\x00\x01\x02", &options).unwrap_err();
    assert!(matches!(e, MapError::Unrecognised { .. }), "{e:?}");
    assert!(e.to_string().contains("byte 0 is 0x00"), "{e}");
}

#[test]
fn sdf_errors() {
    // Text SDF with 2 x 2 declared and 3 values.
    let e = sdf_err(
        b"aISO-1.0\nNumPoints = 2\nNumProfiles = 2\nXscale = 1e-6\nYscale = 1e-6\nZscale = 1e-6\n*\n1 2 3\n*\n",
    );
    assert!(
        matches!(
            e,
            SdfError::DataLength {
                found: 3,
                expected: 4,
                ..
            }
        ),
        "{e:?}"
    );
    let e = sdf_err(b"aISO-1.0\nNumPoints = 2\n*\n1 2\n");
    assert_eq!(e, SdfError::MissingField("NumProfiles"));
    let e = sdf_err(b"aISO-1.0\nthis is not a header\n*\n");
    assert!(matches!(e, SdfError::BadHeaderLine { line: 2, .. }));
    let e = sdf_err(b"bISO-1.0\x00\x00");
    assert!(matches!(e, SdfError::TruncatedHeader { found: 10, .. }));
    let e = sdf_err(b"aISO-9.9\n");
    assert!(matches!(e, SdfError::Version(_)));
}

/// An 81-byte binary SDF header, written from ISO 25178-71 (fields little-endian:
/// magic 8, ManufacID 10, CreateDate 12, ModDate 12, NumPoints u16, NumProfiles u16,
/// Xscale, Yscale, Zscale, Zresolution f64, Compression, DataType, CheckType u8).
fn sdf_header(magic: &[u8; 8], nx: u16, ny: u16, scales: [f64; 4], dtype: u8) -> Vec<u8> {
    let mut h = Vec::new();
    h.extend_from_slice(magic);
    h.extend_from_slice(b"TESTMAKER\0");
    h.extend_from_slice(b"010120240000");
    h.extend_from_slice(b"020120240000");
    h.extend_from_slice(&nx.to_le_bytes());
    h.extend_from_slice(&ny.to_le_bytes());
    for s in scales {
        h.extend_from_slice(&s.to_le_bytes());
    }
    h.extend_from_slice(&[0, dtype, 0]);
    assert_eq!(h.len(), 81);
    h
}

#[test]
fn binary_sdf_written_from_the_spec() {
    // No real binary SDF is available; these files are written here from the spec.
    // 3 x 2 int16 (DataType 5) raw values -1..4 with Zscale 2e-9 m: heights raw * 0.002 µm;
    // Xscale 0.5e-6 m and Yscale 0.25e-6 m give a 0.5 µm x 0.25 µm pitch.
    let mut b = sdf_header(b"bISO-1.0", 3, 2, [0.5e-6, 0.25e-6, 2e-9, 1e-9], 5);
    for v in [-1i16, 0, 1, 2, 3, 4] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    let (map, format) = read_map_bytes(&b, &ReadOptions::default()).unwrap();
    assert_eq!(format, flakescatter_io::MapFormat::Sdf);
    assert_eq!((map.nx(), map.ny()), (3, 2));
    assert!((map.dx() - 0.5).abs() < 1e-15 && (map.dy() - 0.25).abs() < 1e-15);
    let expected = [-0.002, 0.0, 0.002, 0.004, 0.006, 0.008];
    for (z, e) in map.heights().iter().zip(expected) {
        assert!((z - e).abs() < 1e-15, "{z} vs {e}");
    }
    assert_eq!(map.metadata()["sdf.ManufacID"], "TESTMAKER");

    // bISO-2.0, float64 (DataType 7), 2 x 1, Zscale 1e-6: heights equal raw values (µm),
    // NaN invalid.
    let mut b = sdf_header(b"bISO-2.0", 2, 1, [1e-6, 1e-6, 1e-6, 0.0], 7);
    b.extend_from_slice(&1.25f64.to_le_bytes());
    b.extend_from_slice(&f64::NAN.to_le_bytes());
    let (map, _) = read_map_bytes(&b, &ReadOptions::default()).unwrap();
    assert_eq!(map.get(0, 0), Some(1.25));
    assert_eq!(map.valid_count(), 1);

    // Short data and an unknown DataType.
    let mut b = sdf_header(b"bISO-1.0", 2, 2, [1e-6, 1e-6, 1e-6, 0.0], 7);
    b.extend_from_slice(&[0; 16]);
    // The data of 2 x 2 float64 values starts after the 81-byte header and would end at
    // byte 81 + 32 = 113; the file ends at 81 + 16 = 97.
    let e = sdf_err(&b);
    assert_eq!(
        e,
        SdfError::TruncatedData {
            end: 97,
            start: 81,
            needed_end: 113,
            detail: "NumPoints 2 x NumProfiles 2 x 8 bytes".into()
        }
    );
    assert!(e.to_string().contains("ends at byte 97"), "{e}");
    let b = sdf_header(b"bISO-1.0", 1, 1, [1e-6, 1e-6, 1e-6, 0.0], 9);
    assert!(matches!(sdf_err(&b), SdfError::BadField { .. }));
    let b = sdf_header(b"bISO-1.0", 1, 1, [f64::NAN, 1e-6, 1e-6, 0.0], 7);
    assert!(matches!(sdf_err(&b), SdfError::BadField { .. }));
}

#[test]
fn file_errors_name_the_file() {
    let missing = std::env::temp_dir().join("flakescatter-io-no-such-file.x3p");
    let e = read_map(&missing, &ReadOptions::default()).unwrap_err();
    assert!(matches!(e, ReadMapError::Io { .. }));
    assert!(e.to_string().contains("flakescatter-io-no-such-file.x3p"));

    let path = std::env::temp_dir().join(format!("flakescatter-io-bad-{}.txt", std::process::id()));
    std::fs::write(&path, "1 2\n3\n").unwrap();
    let e = read_map(&path, &ReadOptions::default()).unwrap_err();
    std::fs::remove_file(&path).unwrap();
    let msg = e.to_string();
    assert!(msg.contains(&path.display().to_string()), "{msg}");
    assert!(msg.contains("line 2"), "{msg}");
}

/// `xml()` with the CZ `<Increment>` and `<Offset>` replaced.
fn xml_z(increment: &str, offset: &str) -> String {
    xml("2", "1", "D", "1e-6").replace(
        "<CZ><AxisType>A</AxisType><DataType>D</DataType><Increment>1e-6</Increment><Offset>0</Offset></CZ>",
        &format!("<CZ><AxisType>A</AxisType><DataType>D</DataType><Increment>{increment}</Increment><Offset>{offset}</Offset></CZ>"),
    )
}

#[test]
fn zero_or_bad_z_increment_is_refused_naming_the_element() {
    // A zero increment made every height 0 and `topo` a perfect mirror (issue 13 item 6).
    let data = f64_data(&[1.0, 2.0]);
    for inc in [
        "0", "0.0", "-0", "-1e-6", "NaN", "inf", "-inf", "1e-400", "x",
    ] {
        let e = x3p_err(&x3p(&xml_z(inc, "0"), &data));
        assert!(
            matches!(&e, X3pError::BadValue { element, .. } if element == "Record1/Axes/CZ/Increment"),
            "{inc:?}: {e:?}"
        );
    }
    // Also for intensity images, whose increment is not converted.
    let bytes = x3p(&xml_z("0", "0"), &data);
    let e = flakescatter_io::read_intensity_bytes(&bytes, &ReadOptions::default()).unwrap_err();
    assert!(e.to_string().contains("CZ/Increment"), "{e}");
    // A non-finite offset likewise; a negative offset is fine (2 µm - 5 µm = -3 µm).
    let e = x3p_err(&x3p(&xml_z("1e-6", "NaN"), &data));
    assert!(
        matches!(&e, X3pError::BadValue { element, .. } if element == "Record1/Axes/CZ/Offset"),
        "{e:?}"
    );
    let (map, _) = read_map_bytes(
        &x3p(&xml_z("1e-6", "-5e-6"), &data),
        &ReadOptions::default(),
    )
    .unwrap();
    assert_eq!(map.heights(), &[-4.0, -3.0]);
}

#[test]
fn x3p_sizes_that_overflow_or_exceed_the_data() {
    // 10^10 x 10^10 points: refused from the data size, nothing of that size allocated.
    let e = x3p_err(&x3p(
        &xml("10000000000", "10000000000", "D", "1e-6"),
        &f64_data(&[0.0]),
    ));
    assert!(
        matches!(e, X3pError::Map(_) | X3pError::DataLength { .. }),
        "{e:?}"
    );
    // nx * ny overflows usize.
    let e = x3p_err(&x3p(&xml("18446744073709551615", "2", "D", "1e-6"), &[]));
    assert!(matches!(e, X3pError::Map(_)), "{e:?}");
    // 100000 x 100000 points is beyond the 2^28-point cap: refused from the header.
    let e = x3p_err(&x3p(
        &xml("100000", "100000", "D", "1e-6"),
        &f64_data(&[0.0]),
    ));
    assert!(
        matches!(&e, X3pError::BadValue { element, .. } if element == "Record3/MatrixDimension"),
        "{e:?}"
    );
    // 10000 x 10000 float64 (800 MB) over 8 bytes of data, 5 bytes deflated: 5 bytes
    // cannot inflate to 800 MB (deflate's ratio is below 1032:1), refused before
    // anything is inflated.
    let e = x3p_err(&x3p(&xml("10000", "10000", "D", "1e-6"), &f64_data(&[0.0])));
    assert_eq!(
        e,
        X3pError::Implausible {
            member: "bindata/data.bin".into(),
            expected: 800_000_000,
            compressed: 5,
            detail: "10000 x 10000 points of 8 bytes, DataType D".into()
        }
    );
    // Negative and non-integer sizes name the element.
    for size in ["-1", "1.5", ""] {
        let e = x3p_err(&x3p(&xml(size, "1", "D", "1e-6"), &f64_data(&[0.0])));
        assert!(
            matches!(&e, X3pError::BadValue { element, .. } if element.ends_with("SizeX")),
            "{size:?}: {e:?}"
        );
    }
}

#[test]
fn inline_data_list_is_refused_by_name() {
    let main = xml("2", "1", "D", "1e-6").replace(
        "<DataLink><PointDataLink>bindata/data.bin</PointDataLink></DataLink>",
        "<DataList><Datum>1</Datum><Datum>2</Datum></DataList>",
    );
    let e = x3p_err(&zip_members(&[("main.xml", main.as_bytes())]));
    assert!(
        matches!(&e, X3pError::BadValue { element, .. } if element == "Record3/DataList"),
        "{e:?}"
    );
}

#[test]
fn missing_checksum_member_names_the_option() {
    let main = xml("1", "1", "D", "1e-6");
    let bytes = zip_members(&[
        ("main.xml", main.as_bytes()),
        ("md5checksum.hex", b""),
        ("bindata/data.bin", &f64_data(&[1.0])),
    ]);
    let e = x3p_err(&bytes);
    assert!(matches!(e, X3pError::MissingChecksum { .. }), "{e:?}");
    assert!(e.to_string().contains("--accept-md5-mismatch"), "{e}");
}

fn sdf_text(fields: &[(&str, &str)], data: &str) -> Vec<u8> {
    let mut s = String::from("aISO-1.0\n");
    for (k, v) in fields {
        s.push_str(&format!("{k} = {v}\n"));
    }
    s.push_str("*\n");
    s.push_str(data);
    s.into_bytes()
}

const SDF_OK: [(&str, &str); 5] = [
    ("NumPoints", "2"),
    ("NumProfiles", "1"),
    ("Xscale", "1e-6"),
    ("Yscale", "1e-6"),
    ("Zscale", "1e-6"),
];

fn with(field: &str, value: &str) -> Vec<(String, String)> {
    SDF_OK
        .iter()
        .map(|(k, v)| {
            (
                k.to_string(),
                if *k == field { value } else { v }.to_string(),
            )
        })
        .collect()
}

#[test]
fn sdf_zero_or_bad_scales_and_counts_are_refused_naming_the_field() {
    // Control: the header as given reads (1 and 2 µm).
    let (map, _) = read_map_bytes(&sdf_text(&SDF_OK, "1 2\n"), &ReadOptions::default()).unwrap();
    assert_eq!(map.heights(), &[1.0, 2.0]);
    for (field, value) in [
        ("Zscale", "0"),
        ("Zscale", "-1e-6"),
        ("Zscale", "NaN"),
        ("Zscale", "inf"),
        ("Xscale", "0"),
        ("Yscale", "-2e-6"),
        ("NumPoints", "0"),
        ("NumProfiles", "-1"),
    ] {
        let h = with(field, value);
        let pairs: Vec<(&str, &str)> = h.iter().map(|(k, v)| (k.as_str(), v.as_str())).collect();
        let e = sdf_err(&sdf_text(&pairs, "1 2\n"));
        assert!(
            matches!(&e, SdfError::BadField { field: f, value: v, .. } if f == field && v == value),
            "{field} = {value}: {e:?}"
        );
    }
    // Binary: Zscale 0, a negative Xscale, NumPoints 0.
    let e = sdf_err(&sdf_header(b"bISO-1.0", 1, 1, [1e-6, 1e-6, 0.0, 0.0], 7));
    assert!(
        matches!(&e, SdfError::BadField { field, .. } if field == "Zscale"),
        "{e:?}"
    );
    let e = sdf_err(&sdf_header(b"bISO-1.0", 1, 1, [-1e-6, 1e-6, 1e-6, 0.0], 7));
    assert!(
        matches!(&e, SdfError::BadField { field, .. } if field == "Xscale"),
        "{e:?}"
    );
    let e = sdf_err(&sdf_header(b"bISO-1.0", 0, 1, [1e-6, 1e-6, 1e-6, 0.0], 7));
    assert!(
        matches!(&e, SdfError::BadField { field, .. } if field == "NumPoints"),
        "{e:?}"
    );
}

#[test]
fn sdf_duplicate_fields_bad_points_and_too_many_values() {
    let mut fields = SDF_OK.to_vec();
    fields.push(("Zscale", "1e-9"));
    let e = sdf_err(&sdf_text(&fields, "1 2\n"));
    assert_eq!(
        e,
        SdfError::DuplicateField {
            field: "Zscale".into(),
            first: 6,
            second: 7
        }
    );
    // `BAD` marks a missing point.
    let (map, _) = read_map_bytes(&sdf_text(&SDF_OK, "BAD 2\n"), &ReadOptions::default()).unwrap();
    assert_eq!((map.get(0, 0), map.get(1, 0)), (None, Some(2.0)));
    // One value too many names the line it is on.
    let e = sdf_err(&sdf_text(&SDF_OK, "1 2\n3\n"));
    assert!(
        matches!(
            e,
            SdfError::DataLength {
                found: 3,
                expected: 2,
                ..
            }
        ),
        "{e:?}"
    );
    assert!(e.to_string().contains("line 9"), "{e}");
    // A header that claims 65535 x 65535 points over two values.
    let h = [
        ("NumPoints", "65535"),
        ("NumProfiles", "65535"),
        ("Xscale", "1e-6"),
        ("Yscale", "1e-6"),
        ("Zscale", "1e-6"),
    ];
    let e = sdf_err(&sdf_text(&h, "1 2\n"));
    assert!(matches!(e, SdfError::DataLength { found: 2, .. }), "{e:?}");
}

fn temp(name: &str, bytes: &[u8]) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("flakescatter-io-ext-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

#[test]
fn extension_that_contradicts_the_content_is_an_error() {
    use flakescatter_io::MapFormat;
    let opts = ReadOptions {
        pixel_um: Some((1.0, 1.0)),
        z_unit: Some(ZUnit::Um),
        ..ReadOptions::default()
    };
    let msg = |name: &str, bytes: &[u8]| {
        let p = temp(name, bytes);
        let e = read_map(&p, &opts).unwrap_err();
        std::fs::remove_file(&p).unwrap();
        let s = e.to_string();
        assert!(s.contains(name), "{s}");
        (e, s)
    };
    // A zero-byte .x3p (issue 13 item 12): empty, and so not an X3P file.
    let (e, s) = msg("zero.x3p", b"");
    assert!(matches!(
        e,
        ReadMapError::Format {
            error: MapError::Empty {
                expected: Some(MapFormat::X3p)
            },
            ..
        }
    ));
    assert!(
        s.contains("empty (0 bytes)") && s.contains("not an X3P file"),
        "{s}"
    );
    // A plain-text .x3p: not a zip archive, and what it is.
    let (_, s) = msg("text.x3p", b"1 2 3\n4 5 6\n");
    assert!(
        s.contains("not a zip archive, so not an X3P file")
            && s.contains("plain text")
            && s.contains("\"1 2 3\""),
        "{s}"
    );
    assert!(!s.contains("text matrix:"), "{s}");
    // An SDF named .x3p, an X3P named .txt, a text matrix named .sdf, binary named .txt.
    let (_, s) = msg("sdf.x3p", &sdf_text(&SDF_OK, "1 2\n"));
    assert!(
        s.contains("not a zip archive") && s.contains("an SDF file"),
        "{s}"
    );
    let (_, s) = msg(
        "x3p.txt",
        &x3p(&xml("1", "1", "D", "1e-6"), &f64_data(&[1.0])),
    );
    assert!(
        s.contains(".txt says a plain-text matrix") && s.contains("an X3P file"),
        "{s}"
    );
    let (_, s) = msg("text.sdf", b"1 2\n");
    assert!(s.contains("does not start with aISO- or bISO-"), "{s}");
    let (_, s) = msg("bin.txt", b"1 2\x00\x01\n");
    assert!(
        s.contains("not a text matrix") && s.contains("byte 3 is 0x00"),
        "{s}"
    );
    // Upper-case extensions count; an extension no format claims leaves it to the content.
    let (_, s) = msg("TEXT.X3P", b"1 2\n");
    assert!(s.contains("not an X3P file"), "{s}");
    for name in ["map.dat", "map"] {
        let p = temp(name, b"1 2\n");
        let (map, f) = read_map(&p, &opts).unwrap();
        std::fs::remove_file(&p).unwrap();
        assert_eq!((f, map.nx()), (MapFormat::Text, 2));
    }
    // Binary content of no known format, no extension.
    let e = read_map_bytes(b"\x89PNG\r\n\x1a\n\x00\x00", &opts).unwrap_err();
    assert!(matches!(e, MapError::Unrecognised { .. }), "{e:?}");
}

#[test]
fn text_line_endings_and_encodings() {
    let opts = ReadOptions {
        pixel_um: Some((1.0, 1.0)),
        z_unit: Some(ZUnit::Um),
        ..ReadOptions::default()
    };
    // Old Mac line endings (a lone CR): 2 rows of 2, not one row of 4.
    let (map, _) = read_map_bytes(b"1 2\r3 4\r", &opts).unwrap();
    assert_eq!((map.nx(), map.ny()), (2, 2));
    // Line numbers count CR-only and CRLF lines alike.
    let e = text_err(b"1 2\r3 4\r5\r", &opts);
    assert_eq!(
        e,
        TextError::Ragged {
            line: 3,
            expected: 2,
            found: 1
        }
    );
    let e = text_err(b"1 2\r\n3 4\r\n5\r\n", &opts);
    assert_eq!(
        e,
        TextError::Ragged {
            line: 3,
            expected: 2,
            found: 1
        }
    );
    // Latin-1 (a Windows export): `Höhe` and `µm` are recognised.
    let latin1 = b"# Breite: 2 \xb5m\n# H\xf6he: 3 \xb5m\n# Werteinheiten: \xb5m\n1 2\n3 4\n5 6\n";
    let (map, _) = read_map_bytes(latin1, &ReadOptions::default()).unwrap();
    assert_eq!((map.dx(), map.dy()), (1.0, 1.0));
    assert_eq!(map.metadata()["text.encoding"], "Latin-1");
    // UTF-16 with a byte-order mark (Notepad's "Unicode").
    let utf16: Vec<u8> = [0xfeff_u16]
        .into_iter()
        .chain("# Width: 2 µm\n# Height: 1 µm\n# Value units: nm\n1000 2000\n".encode_utf16())
        .flat_map(|u| u.to_le_bytes())
        .collect();
    let (map, _) = read_map_bytes(&utf16, &ReadOptions::default()).unwrap();
    assert_eq!(map.heights(), &[1.0, 2.0]);
    assert_eq!(map.metadata()["text.encoding"], "UTF-16LE");
    // A header key given twice is refused (which width is meant?).
    let e = text_err(b"# Width: 1 um\n# Width: 2 um\n1 2\n", &opts);
    assert_eq!(
        e,
        TextError::DuplicateHeader {
            key: "Width".into(),
            first: 1,
            second: 2
        }
    );
}

#[test]
fn value_units_heights_need_a_length_intensities_do_not() {
    let text = b"# Width: 2 um\n# Height: 1 um\n# Value units: a.u.\n0.5 0.75\n";
    let e = text_err(text, &ReadOptions::default());
    assert_eq!(
        e,
        TextError::NotALength {
            line: 3,
            unit: "a.u.".into()
        }
    );
    assert!(e.to_string().contains("--z-unit"), "{e}");
    // An empty unit is as good as none.
    let e = text_err(
        b"# Width: 2 um\n# Height: 1 um\n# Value units:\n1 2\n",
        &ReadOptions::default(),
    );
    assert_eq!(e, TextError::MissingZUnit);
    // --z-unit overrides a unit that is not a length.
    let um = ReadOptions {
        z_unit: Some(ZUnit::Nm),
        ..ReadOptions::default()
    };
    let (map, _) = read_map_bytes(text, &um).unwrap();
    assert_eq!(map.heights(), &[0.0005, 0.00075]);
    // Intensities: the numbers as written, whatever the unit says.
    let (i, _) = flakescatter_io::read_intensity_bytes(text, &ReadOptions::default()).unwrap();
    assert_eq!(i.heights(), &[0.5, 0.75]);
    assert_eq!(i.metadata()["text.value_units"], "a.u.");
}

#[test]
fn channels_are_listed_and_a_missing_one_refused() {
    use flakescatter_io::{MapFormat, list_channels_bytes};
    let x = x3p(&xml("2", "1", "D", "0.5e-6"), &f64_data(&[1.0, 2.0]));
    let (ch, f) = list_channels_bytes(&x, None, &ReadOptions::default()).unwrap();
    assert_eq!(f, MapFormat::X3p);
    assert_eq!(
        (ch.len(), ch[0].name.as_str(), ch[0].nx, ch[0].ny),
        (1, "Z", 2, 1)
    );
    assert_eq!(ch[0].pitch_um, Some((0.5, 1.0)));
    let (ch, _) =
        list_channels_bytes(&sdf_text(&SDF_OK, "1 2\n"), None, &ReadOptions::default()).unwrap();
    assert_eq!(
        (ch[0].nx, ch[0].ny, ch[0].pitch_um),
        (2, 1, Some((1.0, 1.0)))
    );
    let t = b"# Channel: Topography\n# Value units: nm\n1 2 3\n4 5 6\n";
    let (ch, _) = list_channels_bytes(t, Some("txt"), &ReadOptions::default()).unwrap();
    assert_eq!(ch[0].name, "Topography");
    assert_eq!(ch[0].unit.as_deref(), Some("nm"));
    assert_eq!((ch[0].nx, ch[0].ny, ch[0].pitch_um), (3, 2, None));
    let one = ReadOptions {
        channel: Some(1),
        ..ReadOptions::default()
    };
    let e = read_map_bytes(&x, &one).unwrap_err();
    assert!(
        matches!(
            e,
            MapError::Channel(flakescatter_io::ChannelError::NoSuchIndex { requested: 1, .. })
        ),
        "{e:?}"
    );
    assert!(e.to_string().contains("0 = Z"), "{e}");
    let zero = ReadOptions {
        channel: Some(0),
        ..ReadOptions::default()
    };
    assert!(read_map_bytes(&x, &zero).is_ok());
}

#[test]
fn text_only_options_are_refused_for_calibrated_formats() {
    use flakescatter_io::DecimalMark;
    let x = x3p(&xml("2", "1", "D", "1e-6"), &f64_data(&[1.0, 2.0]));
    let sdf = sdf_text(&SDF_OK, "1 2\n");
    for bytes in [&x[..], &sdf[..]] {
        let unit = ReadOptions {
            z_unit: Some(ZUnit::Nm),
            ..ReadOptions::default()
        };
        let e = read_map_bytes(bytes, &unit).unwrap_err();
        assert!(matches!(e, MapError::NotApplicable { .. }), "{e:?}");
        assert!(e.to_string().contains("--z-unit"), "{e}");
        let comma = ReadOptions {
            decimal: DecimalMark::Comma,
            ..ReadOptions::default()
        };
        let e = read_map_bytes(bytes, &comma).unwrap_err();
        assert!(e.to_string().contains("--decimal-comma"), "{e}");
        // The same options for an intensity image (they are the height map's flags) are
        // ignored: the values are as stored (1e-6 x raw for both files).
        let (i, _) = flakescatter_io::read_intensity_bytes(bytes, &unit).unwrap();
        assert_eq!(i.heights(), &[1e-6, 2e-6]);
    }
}

#[test]
fn write_errors_name_the_file() {
    use flakescatter_io::{MapFormat, write_map};
    let map = flakescatter_stats::heightmap::HeightMap::new(1, 1, 1.0, 1.0, vec![0.0]).unwrap();
    let missing = std::env::temp_dir().join("flakescatter-no-such-dir/sub/out.x3p");
    for format in [MapFormat::X3p, MapFormat::Text, MapFormat::Sdf] {
        let e = write_map(&map, &missing, format).unwrap_err();
        assert!(
            e.to_string()
                .contains("flakescatter-no-such-dir/sub/out.x3p"),
            "{e}"
        );
    }
}

#[test]
fn many_header_lines_columns_and_deep_nesting_stay_cheap() {
    // Duplicate checks use hash maps: 100 000 distinct text header keys, then a repeat
    // of the first (quadratic scans took minutes at this size).
    let n = 100_000;
    let mut text = String::with_capacity(n * 16);
    for k in 0..n {
        text.push_str(&format!("# key{k}: v\n"));
    }
    text.push_str("# key0: again\n1 2\n");
    let e = text_err(text.as_bytes(), &ReadOptions::default());
    assert_eq!(
        e,
        TextError::DuplicateHeader {
            key: "key0".into(),
            first: 1,
            second: n + 1
        }
    );
    // SDF: the same with header fields.
    let mut sdf = String::from("aISO-1.0\n");
    for k in 0..n {
        sdf.push_str(&format!("F{k} = 1\n"));
    }
    sdf.push_str("f0 = 2\n*\n");
    let e = sdf_err(sdf.as_bytes());
    assert_eq!(
        e,
        SdfError::DuplicateField {
            field: "f0".into(),
            first: 2,
            second: n + 2
        }
    );
    // CSV: 100 000 columns, the last a repeat of the first.
    let mut header: Vec<String> = (0..n).map(|k| format!("c{k}")).collect();
    header.push("c0".into());
    let csv = format!("{}\n", header.join(","));
    let e = flakescatter_io::measured::read_measured_from(csv.as_bytes(), "m.csv")
        .unwrap_err()
        .to_string();
    assert!(e.contains(&format!("fields 1 and {}", n + 1)), "{e}");
    // X3P: a Record2 comb 5000 levels deep (each level a leaf and a deeper branch) adds
    // only the shallow leaves to the metadata, not 5000 keys of up to 5000 parts.
    let mut comb = String::new();
    for k in 0..5000 {
        comb.push_str(&format!("<L{k}><V>x</V>"));
    }
    for k in (0..5000).rev() {
        comb.push_str(&format!("</L{k}>"));
    }
    let main = xml("1", "1", "D", "1e-6").replace(
        "<Creator>test</Creator>",
        &format!("<Creator>test</Creator>{comb}"),
    );
    let (map, _) = read_map_bytes(&x3p(&main, &f64_data(&[1.0])), &ReadOptions::default()).unwrap();
    assert_eq!(map.metadata()["x3p.creator"], "test");
    assert_eq!(map.metadata()["x3p.l0.v"], "x");
    assert_eq!(map.metadata()["x3p.l0.l1.l2.l3.l4.v"], "x");
    assert!(!map.metadata().contains_key("x3p.l0.l1.l2.l3.l4.l5.v"));
    assert!(map.metadata().len() < 40, "{}", map.metadata().len());
}

#[test]
fn a_large_member_is_decoded_as_it_is_inflated_and_its_md5_checked() {
    // 1200 x 1000 int32 points (4.8 MB) and 1100 x 1100 float64 points (9.7 MB, above
    // the 8 MiB where the MD5 runs on a second thread while the next 1 MiB chunk is
    // inflated): every point is the value it was written as (`raw × 1e-6 m` in µm,
    // raw = 7i − 3 000 000), the data MD5 (md-5 crate) is checked, and one flipped byte
    // in the last chunk is a checksum error naming the member.
    for (nx, ny, dtype, width) in [(1200usize, 1000usize, "L", 4usize), (1100, 1100, "D", 8)] {
        let raw: Vec<i64> = (0..nx * ny).map(|i| 7 * i as i64 - 3_000_000).collect();
        let data: Vec<u8> = raw
            .iter()
            .flat_map(|&r| {
                if width == 4 {
                    i32::try_from(r).unwrap().to_le_bytes().to_vec()
                } else {
                    (r as f64).to_le_bytes().to_vec()
                }
            })
            .collect();
        let with_md5 = |data: &[u8]| {
            xml(&nx.to_string(), &ny.to_string(), dtype, "1e-6").replace(
                "<PointDataLink>bindata/data.bin</PointDataLink>",
                &format!(
                    "<PointDataLink>bindata/data.bin</PointDataLink><MD5ChecksumPointData>{}</MD5ChecksumPointData>",
                    md5_hex(data)
                ),
            )
        };
        let bytes = x3p(&with_md5(&data), &data);
        let (map, _) = read_map_bytes(&bytes, &ReadOptions::default()).unwrap();
        assert_eq!((map.nx(), map.ny()), (nx, ny));
        for (i, (&z, &r)) in map.heights().iter().zip(&raw).enumerate() {
            // 1e-6 m per count is 1 µm per count: the µm value is the raw count
            // (the product by 1e-6 and back by 1e6 is exact for these integers to 1 ulp).
            assert!(
                (z - r as f64).abs() <= 1e-9 * (r as f64).abs().max(1.0),
                "{i}: {z} vs {r}"
            );
        }
        assert_eq!(
            map.metadata().get("x3p.md5").map(String::as_str),
            Some("ok")
        );
        let mut bad = data.clone();
        let k = bad.len() - 5;
        bad[k] ^= 0x40;
        let e = x3p_err(&x3p(&with_md5(&data), &bad));
        assert!(
            matches!(&e, X3pError::Md5Mismatch { .. })
                && e.to_string().contains("bindata/data.bin"),
            "{e:?}"
        );
    }
}
