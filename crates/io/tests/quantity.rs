//! A map carries its quantity, heights or intensities, through every reader and writer
//! (issue 52, item 5): an intensity image written by this crate says so in each format,
//! is read back as intensities (values unchanged), and is refused where heights are
//! expected instead of being read as heights ×10⁶.

use std::io::{Read, Write};

use flakescatter_io::quantity::{SDF_INTENSITY_LINE, X3P_INTENSITY_MARK};
use flakescatter_io::{MapError, MapFormat, ReadOptions, ValueKind, read_bytes, sdf, text, x3p};
use flakescatter_stats::heightmap::{HeightMap, Quantity};

/// A small intensity image with one invalid point.
fn image() -> HeightMap {
    let mut m = HeightMap::new(3, 2, 0.5, 0.25, vec![0.1, 0.9, f64::NAN, 0.08, 1.0, 0.0]).unwrap();
    m.set_quantity(Quantity::Intensity);
    m
}

fn as_stored() -> ReadOptions {
    ReadOptions {
        as_stored: true,
        ..ReadOptions::default()
    }
}

/// The member `name` of a zip archive, read with the zip crate (not the X3P reader).
fn member(bytes: &[u8], name: &str) -> Vec<u8> {
    let mut z = zip::ZipArchive::new(std::io::Cursor::new(bytes)).unwrap();
    let mut out = Vec::new();
    z.by_name(name).unwrap().read_to_end(&mut out).unwrap();
    out
}

#[test]
fn every_writer_marks_an_intensity_image_and_every_reader_knows_it() {
    let map = image();
    let mut written: Vec<(&str, Vec<u8>)> = vec![
        ("x3p", x3p::write_intensity_x3p_bytes(&map).unwrap()),
        (
            "sdf",
            sdf::write_sdf_text(&map, ValueKind::Intensity).into_bytes(),
        ),
        (
            "sdf",
            sdf::write_sdf_binary(&map, ValueKind::Intensity).unwrap(),
        ),
        ("txt", text::write_intensity_text_string(&map).into_bytes()),
    ];
    // The marks, as written (checked on the bytes, not through the readers).
    let xml = String::from_utf8(member(&written[0].1, "main.xml")).unwrap();
    assert!(
        xml.contains(&format!("<Comment>{X3P_INTENSITY_MARK}")),
        "{xml}"
    );
    assert!(xml.contains("<Increment>1</Increment>\n        <Offset>0</Offset>\n      </CZ>"));
    let sdf_text = String::from_utf8_lossy(&written[1].1).into_owned();
    assert!(
        sdf_text.ends_with(&format!("*\n{SDF_INTENSITY_LINE}\n")),
        "{sdf_text}"
    );
    assert!(sdf_text.contains("Zscale      = 1\n"));
    assert!(
        written[2]
            .1
            .ends_with(format!("{SDF_INTENSITY_LINE}\n").as_bytes())
    );
    assert!(String::from_utf8_lossy(&written[3].1).starts_with("# Channel: intensity\n"));
    // `write_map` of a map whose quantity is intensity writes the same bytes.
    let dir = std::env::temp_dir().join(format!("fs-io-quantity-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (ext, format) in [
        ("x3p", MapFormat::X3p),
        ("sdf", MapFormat::Sdf),
        ("txt", MapFormat::Text),
    ] {
        let p = dir.join(format!("m.{ext}"));
        flakescatter_io::write_map(&map, &p, format).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        let same = written.iter().find(|(e, _)| *e == ext).unwrap();
        assert_eq!(bytes, same.1, "{ext}");
        written.push((ext, bytes));
    }
    std::fs::remove_dir_all(&dir).unwrap();
    for (ext, bytes) in &written {
        // As stored: intensities, values exactly as written.
        let (back, _) = read_bytes(bytes, Some(ext), &as_stored(), ValueKind::Height).unwrap();
        assert_eq!(back.quantity(), Quantity::Intensity, "{ext}");
        for i in 0..map.len() {
            assert_eq!(
                back.get(i % 3, i / 3),
                map.get(i % 3, i / 3),
                "{ext} point {i}"
            );
        }
        // Where an intensity is expected: the same.
        let (back, _) = read_bytes(
            bytes,
            Some(ext),
            &ReadOptions::default(),
            ValueKind::Intensity,
        )
        .unwrap();
        assert_eq!(back.get(1, 0), Some(0.9));
        // Where heights are expected: refused, saying what the file holds and why.
        let e =
            read_bytes(bytes, Some(ext), &ReadOptions::default(), ValueKind::Height).unwrap_err();
        assert!(matches!(e, MapError::Quantity { .. }), "{ext}: {e:?}");
        let msg = e.to_string();
        assert!(
            msg.contains("holds intensities") && msg.contains("not heights"),
            "{msg}"
        );
    }
}

#[test]
fn heights_stay_heights_and_a_height_file_is_no_intensity() {
    let mut map = image();
    map.set_quantity(Quantity::Height);
    // A height map whose metadata carries the intensity mark (read from elsewhere) is
    // written without it.
    map.set_metadata("x3p.comment", format!("{X3P_INTENSITY_MARK}. copied"));
    let bytes = x3p::write_x3p_bytes(&map).unwrap();
    let xml = String::from_utf8(member(&bytes, "main.xml")).unwrap();
    assert!(xml.contains("<Comment>copied</Comment>"), "{xml}");
    let (back, _) = read_bytes(&bytes, None, &as_stored(), ValueKind::Height).unwrap();
    assert_eq!(back.quantity(), Quantity::Height);
    assert_eq!(back.get(1, 0), Some(0.9));
    // A text file that says it holds heights is refused as an intensity image.
    let t = text::write_text_string(&map);
    let e = read_bytes(
        t.as_bytes(),
        None,
        &ReadOptions::default(),
        ValueKind::Intensity,
    )
    .unwrap_err();
    assert!(
        e.to_string().contains("holds heights") && e.to_string().contains("line 1"),
        "{e}"
    );
    // A file that declares nothing is read as what is asked.
    let plain = b"# Pitch x: 1 um\n# Pitch y: 1 um\n1 2\n3 4\n";
    let (i, _) = read_bytes(plain, None, &ReadOptions::default(), ValueKind::Intensity).unwrap();
    assert_eq!(i.quantity(), Quantity::Intensity);
    // `--z-unit` for a file read as the intensities it declares is refused.
    let opts = ReadOptions {
        z_unit: Some(flakescatter_io::ZUnit::Um),
        ..as_stored()
    };
    let it = text::write_intensity_text_string(&image());
    let e = read_bytes(it.as_bytes(), None, &opts, ValueKind::Height).unwrap_err();
    assert!(
        e.to_string().contains("z_unit") && e.to_string().contains("intensities"),
        "{e}"
    );
}

/// An X3P intensity image of an earlier version of this crate: Z Increment 1, the
/// default comment, `ProbingSystem/Identification` flakescatter (its height files
/// always have 1e-6).
#[test]
fn earlier_intensity_x3p_files_are_recognised() {
    let bytes = x3p::write_intensity_x3p_bytes(&image()).unwrap();
    let xml = String::from_utf8(member(&bytes, "main.xml")).unwrap();
    let start = xml.find("<Comment>").unwrap();
    let end = xml.find("</Comment>").unwrap();
    let old_xml = format!(
        "{}<Comment>written by flakescatter 0.1.0{}",
        &xml[..start],
        &xml[end..]
    );
    let data = member(&bytes, "bindata/data.bin");
    // Re-assembled; the checksum of the new main.xml is not recomputed (read with
    // accept_md5_mismatch).
    let digest = "0".repeat(32);
    let mut z = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let o = zip::write::SimpleFileOptions::default();
    for (name, b) in [
        ("main.xml", old_xml.as_bytes().to_vec()),
        (
            "md5checksum.hex",
            format!("{digest} *main.xml\n").into_bytes(),
        ),
        ("bindata/data.bin", data),
        ("bindata/valid.bin", member(&bytes, "bindata/valid.bin")),
    ] {
        z.start_file(name, o).unwrap();
        z.write_all(&b).unwrap();
    }
    let old = z.finish().unwrap().into_inner();
    let accept = ReadOptions {
        accept_md5_mismatch: true,
        ..ReadOptions::default()
    };
    let stored = ReadOptions {
        as_stored: true,
        ..accept
    };
    let (back, _) = read_bytes(&old, None, &stored, ValueKind::Height).unwrap();
    assert_eq!(back.quantity(), Quantity::Intensity);
    let e = read_bytes(&old, None, &accept, ValueKind::Height).unwrap_err();
    assert!(e.to_string().contains("Z Increment of 1"), "{e}");
}
