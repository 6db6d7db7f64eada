//! The TIFF z-stack reader: voxel sizes and page order from ImageJ, OME-TIFF and LSM
//! metadata, decoded samples, and clear errors for bad stacks.
//!
//! References: the fixtures in `tests/data/stack` were written by tifffile (ImageJ,
//! OME-TIFF) and byte by byte from the TIFF 6.0 and `CZ_LSMINFO` layouts (LSM), and read
//! back by tifffile's own readers (see that folder's README); their samples follow the
//! closed form in `make_stacks.py`, recomputed here. The other stacks are written in this
//! file with the `tiff` crate's encoder, their metadata typed from the documented
//! layouts (ImageJ's description keys, the OME 2016-06 schema, Zeiss `CZ_LSMINFO`).

use std::io::Cursor;

use flakescatter_io::stack::{
    ImageJStackWriter, PageOrder, SampleType, Source, StackError, StackFormat, StackLayout,
    StackOptions, StackReader, TAG_CZ_LSMINFO,
};
use tiff::encoder::colortype::{Gray8, Gray16, RGB8};
use tiff::encoder::{Rational, TiffEncoder};
use tiff::tags::Tag;

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/stack");

fn fixture(name: &str) -> Vec<u8> {
    std::fs::read(format!("{DATA}/{name}")).unwrap()
}

fn open<'a>(
    bytes: &'a [u8],
    options: &StackOptions,
) -> Result<StackReader<Cursor<&'a [u8]>>, StackError> {
    StackReader::new(Cursor::new(bytes), options)
}

/// The analytic stack of `make_stacks.py`: `round(A exp(-4 ln2 (z_k - h)² / 0.6²))`.
fn analytic(k: usize, col: usize, row: usize, dz: f64, amplitude: f64) -> f64 {
    let h = 0.6 + 0.04 * col as f64 + 0.02 * row as f64;
    let z = k as f64 * dz;
    (amplitude * (-4.0 * 2f64.ln() * (z - h).powi(2) / 0.36).exp()).round()
}

fn all_slices<R: std::io::Read + std::io::Seek>(r: &mut StackReader<R>) -> Vec<Vec<f32>> {
    let mut out = Vec::new();
    while let Some(s) = r.next_slice().unwrap() {
        out.push(s.to_vec());
    }
    out
}

fn check_samples(slices: &[Vec<f32>], full: f64, dz: f64, amp: f64, reversed: bool) {
    assert_eq!(slices.len(), 9);
    for (p, s) in slices.iter().enumerate() {
        let k = if reversed { 8 - p } else { p };
        for row in 0..12 {
            for col in 0..16 {
                let expect = analytic(k, col, row, dz, amp);
                let got = f64::from(s[row * 16 + col]) * full;
                assert!(
                    (got - expect).abs() < 1e-2,
                    "page {p} ({col}, {row}): {got} vs {expect}"
                );
            }
        }
    }
}

#[test]
fn imagej_stack_written_by_tifffile() {
    let bytes = fixture("imagej-u16.tif");
    let mut r = open(&bytes, &StackOptions::default()).unwrap();
    let i = r.info().clone();
    assert_eq!(i.format, StackFormat::ImageJ);
    assert_eq!((i.nx, i.ny, i.nz, i.sample), (16, 12, 9, SampleType::U16));
    // XResolution 5/1 pixels per um -> 0.2 µm; spacing=0.25 with unit=um.
    assert_eq!(i.pixel_um.as_ref().unwrap().value, (0.2, 0.2));
    assert!(matches!(
        i.pixel_um.as_ref().unwrap().source,
        Source::File(_)
    ));
    assert_eq!(i.z_step_um.as_ref().unwrap().value, 0.25);
    assert_eq!(i.first_page.value, PageOrder::BottomFirst);
    assert_eq!(i.first_page.source, Source::Default);
    assert_eq!(i.full_scale.value, 65535.0);
    assert_eq!(
        i.metadata.get("imagej.spacing").map(String::as_str),
        Some("0.25")
    );
    check_samples(&all_slices(&mut r), 65535.0, 0.25, 60000.0, false);
}

#[test]
fn ome_tiff_written_by_tifffile_is_read_top_first() {
    let bytes = fixture("ome-u16-topfirst.ome.tif");
    let mut r = open(&bytes, &StackOptions::default()).unwrap();
    let i = r.info().clone();
    assert_eq!(i.format, StackFormat::OmeTiff);
    assert_eq!((i.nx, i.ny, i.nz), (16, 12, 9));
    // PhysicalSizeX = 180 nm.
    let (dx, dy) = i.pixel_um.as_ref().unwrap().value;
    assert!((dx - 0.18).abs() < 1e-15 && (dy - 0.18).abs() < 1e-15);
    assert_eq!(i.z_step_um.as_ref().unwrap().value, 0.3);
    // PositionZ decreases with TheZ: page 0 is the top slice.
    assert_eq!(i.first_page.value, PageOrder::TopFirst);
    assert!(matches!(&i.first_page.source, Source::File(s) if s.contains("PositionZ")));
    check_samples(&all_slices(&mut r), 65535.0, 0.3, 50000.0, true);
    // An option overrides the metadata.
    let o = StackOptions {
        first_page: Some(PageOrder::BottomFirst),
        z_step_um: Some(0.5),
        ..StackOptions::default()
    };
    let r = open(&bytes, &o).unwrap();
    assert_eq!(r.info().first_page.value, PageOrder::BottomFirst);
    assert_eq!(r.info().first_page.source, Source::Option);
    assert_eq!(r.info().z_step_um.as_ref().unwrap().value, 0.5);
    assert_eq!(r.info().z_step_um.as_ref().unwrap().source, Source::Option);
}

#[test]
fn lsm_file_built_from_the_layout_skips_thumbnails() {
    let bytes = fixture("zeiss-u8.lsm");
    let mut r = open(&bytes, &StackOptions::default()).unwrap();
    let i = r.info().clone();
    assert_eq!(i.format, StackFormat::Lsm);
    assert_eq!((i.nx, i.ny, i.nz, i.sample), (16, 12, 9, SampleType::U8));
    assert_eq!((i.pages, i.skipped_pages), (18, 9));
    // 1.8e-7 m and 3e-7 m, times 1e6.
    let (dx, _) = i.pixel_um.as_ref().unwrap().value;
    assert!((dx - 0.18).abs() < 1e-12);
    assert!((i.z_step_um.as_ref().unwrap().value - 0.3).abs() < 1e-12);
    check_samples(&all_slices(&mut r), 255.0, 0.3, 250.0, false);
}

/// A grey 16-bit stack with `description` on page 0 and optional resolution and extra
/// tag, written with the tiff encoder.
fn write_stack(
    pages: &[(u32, u32)],
    description: Option<&str>,
    resolution: Option<Rational>,
    extra: Option<(u16, Vec<u8>)>,
) -> Vec<u8> {
    let mut buf = Cursor::new(Vec::new());
    {
        let mut enc = TiffEncoder::new(&mut buf).unwrap();
        for (p, &(w, h)) in pages.iter().enumerate() {
            let mut img = enc.new_image::<Gray16>(w, h).unwrap();
            if p == 0 {
                if let Some(d) = description {
                    img.encoder().write_tag(Tag::ImageDescription, d).unwrap();
                }
                if let Some((tag, bytes)) = &extra {
                    img.encoder()
                        .write_tag(Tag::Unknown(*tag), &bytes[..])
                        .unwrap();
                }
            }
            if let Some(r) = &resolution {
                img.encoder()
                    .write_tag(Tag::XResolution, r.clone())
                    .unwrap();
                img.encoder()
                    .write_tag(Tag::YResolution, r.clone())
                    .unwrap();
            }
            let data: Vec<u16> = (0..w * h)
                .map(|i| (i * 7 + p as u32 * 100) as u16)
                .collect();
            img.write_data(&data).unwrap();
        }
    }
    buf.into_inner()
}

#[test]
fn imagej_writer_round_trip_all_sample_types() {
    let layout = |sample| StackLayout {
        nx: 5,
        ny: 3,
        nz: 4,
        dx_um: 0.18,
        dy_um: 0.25,
        dz_um: 0.3,
        sample,
    };
    // 8-bit: value v reads back as v / 255.
    let mut buf = Cursor::new(Vec::new());
    let mut w = ImageJStackWriter::new(&mut buf, layout(SampleType::U8)).unwrap();
    for k in 0..4u8 {
        w.write_u8(&(0..15u8).map(|i| i * 10 + k).collect::<Vec<_>>())
            .unwrap();
    }
    w.finish().unwrap();
    let bytes = buf.into_inner();
    let mut r = open(&bytes, &StackOptions::default()).unwrap();
    let i = r.info().clone();
    assert_eq!(i.format, StackFormat::ImageJ);
    // 10^6 / 180000 pixels per micron reads back as exactly 0.18 µm (one rounding).
    assert_eq!(i.pixel_um.unwrap().value, (0.18, 0.25));
    assert_eq!(i.z_step_um.unwrap().value, 0.3);
    let s = all_slices(&mut r);
    assert_eq!(s.len(), 4);
    assert_eq!(s[3][14], (140.0f32 + 3.0) / 255.0);

    // 16-bit and float.
    let mut buf = Cursor::new(Vec::new());
    let mut w = ImageJStackWriter::new(&mut buf, layout(SampleType::U16)).unwrap();
    for k in 0..4u16 {
        w.write_u16(&[65535 - k; 15]).unwrap();
    }
    w.finish().unwrap();
    let bytes = buf.into_inner();
    let s = all_slices(&mut open(&bytes, &StackOptions::default()).unwrap());
    assert_eq!(s[2][0], 65533.0 / 65535.0);
    let mut buf = Cursor::new(Vec::new());
    let mut w = ImageJStackWriter::new(&mut buf, layout(SampleType::F32)).unwrap();
    for k in 0..4 {
        w.write_f32(&[k as f32 * 1.5 - 2.0; 15]).unwrap();
    }
    w.finish().unwrap();
    let bytes = buf.into_inner();
    let mut r = open(&bytes, &StackOptions::default()).unwrap();
    assert_eq!(r.info().sample, SampleType::F32);
    assert_eq!(r.info().full_scale.value, 1.0);
    let s = all_slices(&mut r);
    assert_eq!(s[3][7], 2.5);
}

#[test]
fn writer_refuses_bad_slices_and_layouts() {
    let layout = StackLayout {
        nx: 2,
        ny: 2,
        nz: 3,
        dx_um: 0.1,
        dy_um: 0.1,
        dz_um: 0.2,
        sample: SampleType::U16,
    };
    let mut buf = Cursor::new(Vec::new());
    let mut w = ImageJStackWriter::new(&mut buf, layout).unwrap();
    let e = w.write_u16(&[1, 2, 3]).unwrap_err().to_string();
    assert!(e.contains("3 samples given, expected nx * ny = 4"), "{e}");
    let e = w.write_u8(&[1, 2, 3, 4]).unwrap_err().to_string();
    assert!(
        e.contains("uint8 samples given, the layout says uint16"),
        "{e}"
    );
    w.write_u16(&[1, 2, 3, 4]).unwrap();
    let e = w.finish().unwrap_err().to_string();
    assert_eq!(e, "the layout declares 3 slices but 1 were written");
    for (bad, name) in [
        (
            StackLayout {
                dz_um: 0.0,
                ..layout
            },
            "dz_um",
        ),
        (
            StackLayout {
                dx_um: 1e-9,
                ..layout
            },
            "dx_um",
        ),
        (StackLayout { nz: 0, ..layout }, "nz"),
    ] {
        let e = ImageJStackWriter::new(Cursor::new(Vec::new()), bad).unwrap_err();
        assert!(e.to_string().contains(name), "{e}");
    }
}

#[test]
fn ome_xml_written_here() {
    // OME 2016-06: PhysicalSizeX in µm by default, Z in nm; no Plane positions, so page
    // 0 is the lowest slice by default.
    let xml = r#"<?xml version="1.0" encoding="UTF-8"?><OME xmlns="http://www.openmicroscopy.org/Schemas/OME/2016-06"><Image ID="Image:0"><Pixels ID="Pixels:0" DimensionOrder="XYZCT" Type="uint16" SizeX="6" SizeY="4" SizeZ="3" SizeC="1" SizeT="1" PhysicalSizeX="0.1" PhysicalSizeY="0.15" PhysicalSizeZ="250" PhysicalSizeZUnit="nm"><Channel ID="Channel:0:0" SamplesPerPixel="1"/><TiffData/></Pixels></Image></OME>"#;
    let bytes = write_stack(&[(6, 4); 3], Some(xml), None, None);
    let r = open(&bytes, &StackOptions::default()).unwrap();
    let i = r.info();
    assert_eq!(i.format, StackFormat::OmeTiff);
    assert_eq!(i.pixel_um.as_ref().unwrap().value, (0.1, 0.15));
    assert_eq!(i.z_step_um.as_ref().unwrap().value, 0.25);
    assert_eq!(i.first_page.source, Source::Default);
    // SizeZ disagreeing with the pages, and several channels, are refused.
    let bytes = write_stack(&[(6, 4); 4], Some(xml), None, None);
    let e = open(&bytes, &StackOptions::default()).unwrap_err();
    assert_eq!(
        e,
        StackError::DeclaredCount {
            field: "OME-XML SizeZ",
            declared: 3,
            found: 4
        }
    );
    let two = xml.replace(r#"SizeC="1""#, r#"SizeC="2""#);
    let bytes = write_stack(&[(6, 4); 3], Some(&two), None, None);
    let e = open(&bytes, &StackOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("SizeC=2") && e.contains("single-channel"), "{e}");
    let bad = xml.replace(r#"PhysicalSizeZUnit="nm""#, r#"PhysicalSizeZUnit="parsec""#);
    let bytes = write_stack(&[(6, 4); 3], Some(&bad), None, None);
    let e = open(&bytes, &StackOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("parsec"), "{e}");
    // ... unless the option replaces the unusable field.
    let r = open(
        &bytes,
        &StackOptions {
            z_step_um: Some(0.2),
            ..StackOptions::default()
        },
    )
    .unwrap();
    assert_eq!(r.info().z_step_um.as_ref().unwrap().value, 0.2);
}

/// `CZ_LSMINFO` as the Zeiss layout has it: magic, size, dimensions (i32 at 8..40),
/// voxel sizes (f64 metres at 40, 48, 56).
fn lsminfo(nx: i32, ny: i32, nz: i32, channels: i32, voxel_m: [f64; 3]) -> Vec<u8> {
    let mut rec = vec![0u8; 224];
    rec[0..4].copy_from_slice(&0x0400_494Cu32.to_le_bytes());
    rec[4..8].copy_from_slice(&224i32.to_le_bytes());
    for (o, v) in [
        (8, nx),
        (12, ny),
        (16, nz),
        (20, channels),
        (24, 1),
        (28, 2),
    ] {
        rec[o..o + 4].copy_from_slice(&v.to_le_bytes());
    }
    for (k, v) in voxel_m.iter().enumerate() {
        rec[40 + 8 * k..48 + 8 * k].copy_from_slice(&v.to_le_bytes());
    }
    rec
}

#[test]
fn lsm_record_written_here() {
    // DataType 2 (12-bit data in 16-bit pages): full scale 4095.
    let rec = lsminfo(6, 4, 3, 1, [2.5e-7, 2.0e-7, 4.0e-7]);
    let bytes = write_stack(&[(6, 4); 3], None, None, Some((TAG_CZ_LSMINFO, rec)));
    let mut r = open(&bytes, &StackOptions::default()).unwrap();
    let i = r.info().clone();
    assert_eq!(i.format, StackFormat::Lsm);
    let (dx, dy) = i.pixel_um.as_ref().unwrap().value;
    assert!((dx - 0.25).abs() < 1e-12 && (dy - 0.2).abs() < 1e-12);
    assert!((i.z_step_um.as_ref().unwrap().value - 0.4).abs() < 1e-12);
    assert_eq!(i.full_scale.value, 4095.0);
    // Sample 7 of page 1 is 7 * 7 + 100 = 149 (see write_stack), read as 149 / 4095.
    let s = all_slices(&mut r);
    assert_eq!(s[1][7], 149.0 / 4095.0);
    // Two channels, a wrong size, a zero voxel size.
    let rec = lsminfo(6, 4, 3, 2, [2.5e-7, 2.0e-7, 4.0e-7]);
    let bytes = write_stack(&[(6, 4); 3], None, None, Some((TAG_CZ_LSMINFO, rec)));
    assert!(matches!(
        open(&bytes, &StackOptions::default()),
        Err(StackError::Unsupported(_))
    ));
    let rec = lsminfo(7, 4, 3, 1, [2.5e-7, 2.0e-7, 4.0e-7]);
    let bytes = write_stack(&[(6, 4); 3], None, None, Some((TAG_CZ_LSMINFO, rec)));
    let e = open(&bytes, &StackOptions::default())
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        "CZ_LSMINFO DimensionX/DimensionY says 7 x 4 pixels but the pages are 6 x 4"
    );
    let rec = lsminfo(6, 4, 3, 1, [2.5e-7, 2.0e-7, 0.0]);
    let bytes = write_stack(&[(6, 4); 3], None, None, Some((TAG_CZ_LSMINFO, rec)));
    let e = open(&bytes, &StackOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("VoxelSizeZ = 0 m is not a positive length"),
        "{e}"
    );
}

#[test]
fn plain_tiff_needs_both_sizes_as_options() {
    // 72 pixels per inch is a display resolution, not a calibration.
    let bytes = write_stack(&[(4, 4); 3], None, Some(Rational { n: 72, d: 1 }), None);
    let r = open(&bytes, &StackOptions::default()).unwrap();
    assert_eq!(r.info().format, StackFormat::PlainTiff);
    let e = r.info().calibration().unwrap_err();
    assert!(matches!(e, StackError::MissingPixelSize { .. }));
    let msg = e.to_string();
    assert!(
        msg.contains("display resolution") && msg.contains("pixel_um"),
        "{msg}"
    );
    let r = open(
        &bytes,
        &StackOptions {
            pixel_um: Some((0.2, 0.2)),
            ..StackOptions::default()
        },
    )
    .unwrap();
    let e = r.info().calibration().unwrap_err();
    assert_eq!(
        e,
        StackError::MissingZStep {
            format: StackFormat::PlainTiff
        }
    );
    assert!(e.to_string().contains("z_step_um"));
    let r = open(
        &bytes,
        &StackOptions {
            pixel_um: Some((0.2, 0.3)),
            z_step_um: Some(0.1),
            first_page: None,
        },
    )
    .unwrap();
    let c = r.info().calibration().unwrap();
    assert_eq!((c.dx_um, c.dy_um, c.dz_um), (0.2, 0.3, 0.1));
    // Bad options are refused by name.
    let e = open(
        &bytes,
        &StackOptions {
            z_step_um: Some(-0.3),
            ..StackOptions::default()
        },
    )
    .unwrap_err();
    assert!(e.to_string().contains("z_step_um = -0.3"), "{e}");
}

#[test]
fn bad_stacks_get_clear_errors() {
    let ok = StackOptions::default();
    // A single page is an image, not a stack; two pages are too few.
    let e = open(&write_stack(&[(4, 4)], None, None, None), &ok).unwrap_err();
    assert_eq!(e, StackError::TooFewSlices { slices: 1 });
    assert!(e.to_string().contains("single page"));
    let e = open(&write_stack(&[(4, 4); 2], None, None, None), &ok).unwrap_err();
    assert!(e.to_string().contains("2 slices"), "{e}");
    // Pages of different sizes.
    let e = open(
        &write_stack(&[(4, 4), (4, 4), (5, 4)], None, None, None),
        &ok,
    )
    .unwrap_err();
    assert_eq!(
        e,
        StackError::PageSize {
            page: 2,
            expected: (4, 4),
            found: (5, 4)
        }
    );
    // Pages of different types (16-bit then 8-bit).
    let mut buf = Cursor::new(Vec::new());
    {
        let mut enc = TiffEncoder::new(&mut buf).unwrap();
        enc.write_image::<Gray16>(2, 2, &[1, 2, 3, 4]).unwrap();
        enc.write_image::<Gray16>(2, 2, &[1, 2, 3, 4]).unwrap();
        enc.write_image::<Gray8>(2, 2, &[1, 2, 3, 4]).unwrap();
    }
    let e = open(buf.get_ref(), &ok).unwrap_err();
    assert_eq!(
        e,
        StackError::PageType {
            page: 2,
            expected: SampleType::U16,
            found: SampleType::U8
        }
    );
    // Colour pages.
    let mut buf = Cursor::new(Vec::new());
    {
        let mut enc = TiffEncoder::new(&mut buf).unwrap();
        for _ in 0..3 {
            enc.write_image::<RGB8>(1, 1, &[1, 2, 3]).unwrap();
        }
    }
    let e = open(buf.get_ref(), &ok).unwrap_err().to_string();
    assert!(e.contains("page 0") && e.contains("one grey sample"), "{e}");
    // Not a TIFF; an empty file.
    assert!(matches!(
        open(b"PK\x03\x04 not a tiff", &ok),
        Err(StackError::NotTiff(_))
    ));
    assert!(matches!(open(b"", &ok), Err(StackError::NotTiff(_))));
    // ImageJ declares more images than there are pages.
    let d = "ImageJ=1.11a\nimages=5\nslices=5\nunit=micron\nspacing=0.3\n";
    let e = open(
        &write_stack(&[(4, 4); 4], Some(d), Some(Rational { n: 5, d: 1 }), None),
        &ok,
    )
    .unwrap_err();
    assert_eq!(
        e.to_string(),
        "ImageJ slices= says 5 slices but the file holds 4 (truncated or inconsistent?)"
    );
    // ImageJ's over-4-GB layout: one directory for many images.
    let e = open(
        &write_stack(&[(4, 4)], Some(d), Some(Rational { n: 5, d: 1 }), None),
        &ok,
    )
    .unwrap_err();
    assert!(
        matches!(&e, StackError::Unsupported(m) if m.contains("single TIFF directory")),
        "{e}"
    );
}

/// Overwrites the value of `tag` in the `ifd`-th directory of a little-endian classic
/// TIFF (TIFF 6.0: header offset at byte 4; 12-byte entries after a 2-byte count; SHORT
/// values in the first two bytes of the value field, LONG in four).
fn patch_tag(bytes: &mut [u8], ifd: usize, tag: u16, value: u32) {
    let u16_at = |b: &[u8], o: usize| u16::from_le_bytes([b[o], b[o + 1]]);
    let u32_at = |b: &[u8], o: usize| u32::from_le_bytes(b[o..o + 4].try_into().unwrap());
    let mut off = u32_at(bytes, 4) as usize;
    for _ in 0..ifd {
        let n = u16_at(bytes, off) as usize;
        off = u32_at(bytes, off + 2 + 12 * n) as usize;
    }
    let n = u16_at(bytes, off) as usize;
    for e in 0..n {
        let o = off + 2 + 12 * e;
        if u16_at(bytes, o) == tag {
            match u16_at(bytes, o + 2) {
                3 => bytes[o + 8..o + 10].copy_from_slice(&(value as u16).to_le_bytes()),
                _ => bytes[o + 8..o + 12].copy_from_slice(&value.to_le_bytes()),
            }
            return;
        }
    }
    panic!("tag {tag} not in directory {ifd}");
}

#[test]
fn truncated_and_corrupt_stacks_name_the_page() {
    let d = "ImageJ=1.11a\nimages=4\nslices=4\nunit=micron\nspacing=0.3\n";
    let bytes = write_stack(&[(8, 8); 4], Some(d), Some(Rational { n: 5, d: 1 }), None);
    // The encoder writes each page's data before its directory, so a cut file loses a
    // directory first: the error names the page whose directory is cut.
    for (cut, page) in [(bytes.len() - 1, 3), (bytes.len() / 2, 1), (40, 0)] {
        let e = open(&bytes[..cut], &StackOptions::default()).unwrap_err();
        assert_eq!(
            e.to_string(),
            format!(
                "page {page} (0-based): the file ends inside this page's directory or data (truncated?)"
            ),
            "cut at {cut}"
        );
    }
    // A strip that runs past the end of the file (page 2's StripByteCounts, tag 279).
    let mut bad = bytes.clone();
    patch_tag(&mut bad, 2, 279, 1 << 20);
    let e = open(&bad, &StackOptions::default()).unwrap_err();
    assert!(matches!(e, StackError::Truncated { page: 2, .. }), "{e}");
    assert!(e.to_string().contains("truncated"), "{e}");
    // Too few bytes for an uncompressed 8 x 8 16-bit page.
    let mut bad = bytes.clone();
    patch_tag(&mut bad, 1, 279, 100);
    let e = open(&bad, &StackOptions::default()).unwrap_err();
    assert_eq!(
        e.to_string(),
        "page 1 (0-based): its strips hold 100 bytes, a 8 x 8 uint16 page needs 128"
    );
    // 12 bits per sample (tag 258) is not a stack sample type.
    let mut bad = bytes.clone();
    patch_tag(&mut bad, 0, 258, 12);
    let e = open(&bad, &StackOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("page 0 (0-based)"), "{e}");
    // A huge declared width is refused before any allocation.
    let mut bad = bytes.clone();
    patch_tag(&mut bad, 0, 256, 1 << 30);
    let e = open(&bad, &StackOptions::default()).unwrap_err();
    assert!(
        matches!(
            e,
            StackError::TooLarge { .. } | StackError::Decode { page: 0, .. }
        ),
        "{e}"
    );
}
