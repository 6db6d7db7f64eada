//! The CSV readers (flake tables, histograms, measured curves, detector lists) on bad
//! input: duplicate columns, malformed rows, CRLF line numbers, other delimiters, range
//! checks. Every expected line number is counted by hand in the text next to it.

use flakescatter_io::TableError;
use flakescatter_io::curves::read_curve_from;
use flakescatter_io::detectors::read_detectors_from;
use flakescatter_io::flakes::{read_flakes_from, read_histogram_from, write_flakes};
use flakescatter_io::measured::read_measured_from;

/// Each reader by name, returning only its error text.
type Reader = fn(&str) -> Result<(), String>;

const READERS: [(&str, &str, Reader); 5] = [
    ("flakes", "nx,ny,nz,area_um2", |t| {
        read_flakes_from(t.as_bytes(), "f.csv")
            .map(|_| ())
            .map_err(|e| e.to_string())
    }),
    (
        "histogram",
        "theta_lo_deg,theta_hi_deg,area_fraction",
        |t| {
            read_histogram_from(t.as_bytes(), "f.csv")
                .map(|_| ())
                .map_err(|e| e.to_string())
        },
    ),
    ("measured", "theta_i_deg,theta_s_deg,value", |t| {
        read_measured_from(t.as_bytes(), "f.csv")
            .map(|_| ())
            .map_err(|e| e.to_string())
    }),
    ("detectors", "theta_r_deg,phi_r_deg", |t| {
        read_detectors_from(t.as_bytes(), "f.csv")
            .map(|_| ())
            .map_err(|e| e.to_string())
    }),
    (
        "curves",
        "theta_i_deg,theta_s_deg,aperture_deg,brdf_per_sr,relative",
        |t| {
            read_curve_from(t.as_bytes(), "f.csv")
                .map(|_| ())
                .map_err(|e| e.to_string())
        },
    ),
];

/// A valid data row for each reader's header.
fn row(reader: &str, k: usize) -> String {
    match reader {
        "flakes" => "0,0,1,2".into(),
        "histogram" => format!("{k},{},0.5", k + 1),
        "measured" => "30,-30,1.5".into(),
        "curves" => format!("30,-{k}5,1.5,0.25,1"),
        _ => "30,45".into(),
    }
}

#[test]
fn every_reader_accepts_its_control_file() {
    for (name, header, read) in READERS {
        let text = format!("{header}\n{}\n{}\n", row(name, 0), row(name, 1));
        read(&text).unwrap_or_else(|e| panic!("{name}: {e}"));
    }
}

#[test]
fn duplicate_columns_are_an_error_naming_column_and_file() {
    // Before, the first of two `value` columns was used silently.
    for (name, header, read) in READERS {
        let first = header.split(',').next().unwrap();
        // The same name again, in another case and with spaces: still the same column.
        let text = format!("{header}, {}\n{},9\n", first.to_uppercase(), row(name, 0));
        let e = read(&text).unwrap_err();
        let fields = header.split(',').count();
        assert!(
            e.contains("f.csv")
                && e.contains("line 1")
                && e.contains(&format!("column {first} appears twice"))
                && e.contains(&format!("fields 1 and {}", fields + 1)),
            "{name}: {e}"
        );
    }
}

#[test]
fn malformed_rows_say_expected_and_found_fields() {
    for (name, header, read) in READERS {
        let text = format!("{header}\n{}\n1\n", row(name, 0));
        let e = read(&text).unwrap_err();
        let n = header.split(',').count();
        assert!(
            e.contains("f.csv, line 3")
                && e.contains(&format!("expected {n} fields"))
                && e.contains("found 1"),
            "{name}: {e}"
        );
        assert!(
            !e.contains("UnequalLengths") && !e.contains("Position"),
            "{name}: {e}"
        );
    }
}

#[test]
fn crlf_and_comment_lines_give_the_right_line_numbers() {
    // Line 1 a comment, 2 the header, 3 a good row, 4 a comment, 5 a bad value.
    for (name, header, read) in READERS {
        let bad = row(name, 1).replacen(|c: char| c.is_ascii_digit(), "x", 1);
        for eol in ["\n", "\r\n", "\r"] {
            let text = ["# exported", header, &row(name, 0), "# note", &bad, ""].join(eol);
            let e = read(&text).unwrap_err();
            assert!(e.contains("f.csv, line 5"), "{name} {eol:?}: {e}");
        }
    }
}

#[test]
fn other_delimiters_get_a_hint() {
    for (name, header, read) in READERS {
        for (sep, hint) in [(";", "`;`"), ("\t", "tabs")] {
            let text = format!(
                "{}\n{}\n",
                header.replace(',', sep),
                row(name, 0).replace(',', sep)
            );
            let e = read(&text).unwrap_err();
            assert!(
                e.contains("f.csv, line 1") && e.contains(hint) && e.contains("comma-separated"),
                "{name} {sep:?}: {e}"
            );
        }
    }
}

#[test]
fn decimal_comma_cells_say_how_to_write_them() {
    let e = read_measured_from(
        "theta_i_deg,theta_s_deg,value\n30,-30,\"1,5\"\n".as_bytes(),
        "m.csv",
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("line 2, column value") && e.contains("(1.5)"),
        "{e}"
    );
}

#[test]
fn missing_columns_name_the_header_line_and_what_was_found() {
    // After two comment lines the header is line 3.
    let e = read_detectors_from("# a\n# b\ntheta_r_deg,phi_deg\n1,2\n".as_bytes(), "d.csv")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("d.csv, line 3, column phi_r_deg") && e.contains("found: theta_r_deg, phi_deg"),
        "{e}"
    );
    let e = read_flakes_from("# a\nnx,ny\n1,2\n".as_bytes(), "f.csv")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("f.csv, line 2") && e.contains("closest is normals"),
        "{e}"
    );
}

#[test]
fn detector_ranges() {
    let read = |body: &str| {
        read_detectors_from(format!("theta_r_deg,phi_r_deg\n{body}").as_bytes(), "d.csv")
    };
    // phi_r_deg 400 was accepted before (issue 13 item 8).
    for (body, needle) in [
        (
            "30,400\n",
            "line 2, column phi_r_deg: 400 is outside [-360, 360]",
        ),
        ("30,-360.5\n", "line 2, column phi_r_deg"),
        (
            "90,0\n",
            "line 2, column theta_r_deg: 90 is outside [0, 90)",
        ),
        ("-1,0\n", "column theta_r_deg"),
        (
            "30,0\n30,NaN\n",
            "line 3, column phi_r_deg: NaN is not a finite number",
        ),
        ("30,inf\n", "not a finite number"),
        ("30,\n", "empty cell"),
        ("", "no data rows"),
    ] {
        let e = read(body).unwrap_err().to_string();
        assert!(
            e.contains("d.csv") && e.contains(needle),
            "{body:?}: `{e}` lacks `{needle}`"
        );
    }
    // The bounds themselves are accepted; angles come back in radians.
    let d = read("0,-360\n89.5,360\n").unwrap();
    assert_eq!(d.len(), 2);
    assert_eq!(d[0].phi_r, (-360f64).to_radians());
    assert_eq!(d[1].theta_r, 89.5f64.to_radians());
    assert_eq!(d[1].line, 3);
}

#[test]
fn result_curves_allow_empty_relative_cells_only() {
    let head = "theta_i_deg,theta_s_deg,phi_s_deg,aperture_deg,brdf_per_sr,reflectance,relative\n";
    let rows = read_curve_from(format!("{head}30,-30,0,1.5,0.25,,\n").as_bytes(), "m.csv").unwrap();
    assert!(rows[0].relative.is_nan() && rows[0].reflectance.is_none());
    assert_eq!(rows[0].phi_s, Some(0.0));
    for (row, needle) in [
        ("30,-30,0,1.5,,,1", "line 2, column brdf_per_sr: empty cell"),
        ("30,-30,0,1.5,-1,,1", "column brdf_per_sr: -1 is negative"),
        ("30,-30,400,1.5,1,,1", "column phi_s_deg"),
        ("95,-30,0,1.5,1,,1", "column theta_i_deg"),
        ("30,-30,0,1.5,1,,x", "column relative"),
    ] {
        let e = read_curve_from(format!("{head}{row}\n").as_bytes(), "m.csv")
            .unwrap_err()
            .to_string();
        assert!(e.contains(needle), "{row}: `{e}` lacks `{needle}`");
    }
}

#[test]
fn latin1_tables_are_read() {
    // A header comment and an extra column in Latin-1 (`Höhe`): not UTF-8, read anyway.
    let text = b"# H\xf6he\ntheta_r_deg,phi_r_deg,Bemerkung\n10,20,gr\xfcn\n";
    let d = read_detectors_from(&text[..], "d.csv").unwrap();
    assert_eq!(d[0].line, 3);
}

#[test]
fn write_errors_name_the_file() {
    // A writer that always fails: the error names the destination.
    struct Full;
    impl std::io::Write for Full {
        fn write(&mut self, _: &[u8]) -> std::io::Result<usize> {
            Err(std::io::Error::other("device full"))
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Err(std::io::Error::other("device full"))
        }
    }
    let f = flakescatter_stats::flake::Flake::new(
        flakescatter_stats::nalgebra::Vector3::new(0.0, 0.0, 1.0),
        1.0,
    )
    .unwrap();
    let e = write_flakes(Full, "out/flakes.csv", &[f]).unwrap_err();
    assert!(matches!(e, TableError::Io { .. }), "{e:?}");
    assert!(e.to_string().contains("out/flakes.csv"), "{e}");
}

#[test]
fn empty_files_and_utf16_tables() {
    for (name, header, read) in READERS {
        for text in ["", "\n\n", "# only a comment\n"] {
            let e = read(text).unwrap_err();
            assert!(
                e.contains("f.csv: the file is empty"),
                "{name} {text:?}: {e}"
            );
        }
        // UTF-16 with a byte-order mark, comma-separated: read; tab-separated (a
        // spreadsheet's "Unicode text"): the tab hint, not garbage.
        let utf16 = |s: &str| -> Vec<u8> {
            [0xfeff_u16]
                .into_iter()
                .chain(s.encode_utf16())
                .flat_map(|u| u.to_le_bytes())
                .collect()
        };
        let good = utf16(&format!("{header}\r\n{}\r\n", row(name, 0)));
        let e = match name {
            "flakes" => read_flakes_from(&good[..], "f.csv")
                .err()
                .map(|e| e.to_string()),
            "histogram" => read_histogram_from(&good[..], "f.csv")
                .err()
                .map(|e| e.to_string()),
            "measured" => read_measured_from(&good[..], "f.csv")
                .err()
                .map(|e| e.to_string()),
            "detectors" => read_detectors_from(&good[..], "f.csv")
                .err()
                .map(|e| e.to_string()),
            _ => read_curve_from(&good[..], "f.csv")
                .err()
                .map(|e| e.to_string()),
        };
        assert_eq!(e, None, "{name}");
        let tabs = utf16(&format!(
            "{}\r\n{}\r\n",
            header.replace(',', "\t"),
            row(name, 0).replace(',', "\t")
        ));
        let e = read_detectors_from(&tabs[..], "f.csv")
            .unwrap_err()
            .to_string();
        assert!(e.contains("tabs"), "{e}");
    }
}
