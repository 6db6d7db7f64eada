//! Decimal commas in plain-text matrices are read correctly, detected only when the
//! content settles it, and otherwise refused (issue 13 item 1: `1,000 1,300 …` used to be
//! read as twice the columns).
//!
//! Expected values are the numbers written in each file, read by eye: `1,5` is 1.5.

use flakescatter_io::text::TextError;
use flakescatter_io::{DecimalMark, MapError, ReadOptions, ZUnit, read_map, read_map_bytes};
use flakescatter_stats::heightmap::HeightMap;

fn opts(decimal: DecimalMark) -> ReadOptions {
    ReadOptions {
        pixel_um: Some((1.0, 1.0)),
        z_unit: Some(ZUnit::Um),
        decimal,
        ..ReadOptions::default()
    }
}

fn read(text: &str, decimal: DecimalMark) -> Result<HeightMap, MapError> {
    read_map_bytes(text.as_bytes(), &opts(decimal)).map(|(m, _)| m)
}

fn text_err(text: &str, decimal: DecimalMark) -> TextError {
    match read(text, decimal) {
        Err(MapError::Text(e)) => e,
        other => panic!("expected a text error, got {other:?}"),
    }
}

fn rows(map: &HeightMap) -> Vec<Vec<f64>> {
    (0..map.ny())
        .map(|r| (0..map.nx()).map(|c| map.get(c, r).unwrap()).collect())
        .collect()
}

#[test]
fn german_whitespace_matrix_is_read_with_decimal_commas() {
    // The case: 3 x 2 values with three decimals; as decimal points with commas
    // as separators it would be 6 x 2 with a maximum of 400.
    let text = "1,000 1,300 1,400\n2,000 0,250 -1,125\n";
    let map = read(text, DecimalMark::Auto).unwrap();
    assert_eq!((map.nx(), map.ny()), (3, 2));
    assert_eq!(rows(&map), [[1.0, 1.3, 1.4], [2.0, 0.25, -1.125]]);
    assert_eq!(
        map.metadata()["text.decimal_mark"],
        "comma (detected: whitespace separates values like `1,5`)"
    );
    // Integers without a comma among decimal-comma values are fine (`2` is 2).
    let map = read("1,5 2\t3,25\n", DecimalMark::Auto).unwrap();
    assert_eq!(rows(&map), [[1.5, 2.0, 3.25]]);
}

#[test]
fn semicolon_separated_with_decimal_commas() {
    // Excel in a German locale: `;` between values, a trailing `;`, CRLF, exponents.
    let text = "1,5;2,25;3\r\n-0,5;4;1,5e-3;\r\n";
    let map = read(text, DecimalMark::Auto).unwrap();
    assert_eq!(rows(&map), [[1.5, 2.25, 3.0], [-0.5, 4.0, 0.0015]]);
    assert_eq!(
        map.metadata()["text.decimal_mark"],
        "comma (detected: `;` separates values)"
    );
    // `;` with decimal points is read with points.
    let map = read("1.5;2.25\n3;4\n", DecimalMark::Auto).unwrap();
    assert_eq!(rows(&map), [[1.5, 2.25], [3.0, 4.0]]);
    assert_eq!(map.metadata()["text.decimal_mark"], "point (detected)");
}

#[test]
fn comma_separated_files_keep_decimal_points() {
    // `1, 2` (comma next to a space), `1.5,2.5` (points), `1,2,3` (two commas in a token):
    // commas separate values.
    for (text, expected) in [
        (
            "1, 2, 3\n4, 5, 6\n",
            vec![vec![1.0, 2.0, 3.0], vec![4.0, 5.0, 6.0]],
        ),
        ("1.5,2.5\n3,4.25\n", vec![vec![1.5, 2.5], vec![3.0, 4.25]]),
        (
            "1,2,3\n4,5,6\n",
            vec![vec![1.0, 2.0, 3.0], vec![4.0, 5.0, 6.0]],
        ),
    ] {
        let map = read(text, DecimalMark::Auto).unwrap();
        assert_eq!(rows(&map), expected, "{text:?}");
        assert!(map.metadata()["text.decimal_mark"].starts_with("point"));
    }
}

#[test]
fn undecidable_content_is_refused_naming_the_flag() {
    // One token per line: `10,5` is 10.5 or the two values 10 and 5.
    let e = text_err("10,5\n20,25\n", DecimalMark::Auto);
    assert!(
        matches!(&e, TextError::AmbiguousDecimal { line: 1, token, .. } if token == "10,5"),
        "{e:?}"
    );
    let msg = e.to_string();
    assert!(
        msg.contains("--decimal-comma") && msg.contains("single token"),
        "{msg}"
    );
    // Both kinds of evidence in one file.
    let e = text_err("1,5 2,5\n1, 2\n", DecimalMark::Auto);
    assert!(matches!(e, TextError::AmbiguousDecimal { .. }), "{e:?}");
    // `;` separators with `.` and `,` in numbers (thousands separators?): as points it
    // would silently be 3 columns (1, 5, 2).
    for text in [
        "1.000,5;2\n3.000,5;4\n",
        // A decimal comma beside a decimal point on one whitespace-separated line.
        "1,5 2.5\n",
        // Whitespace between values that each hold `.` and `,`.
        "1.5,2.5 3.5,4.5\n",
        // `;` between values and a comma that separates.
        "1,2,3;4\n",
    ] {
        let e = text_err(text, DecimalMark::Auto);
        assert!(
            matches!(e, TextError::AmbiguousDecimal { .. }),
            "{text:?}: {e:?}"
        );
    }
    // The explicit marks settle the first case either way.
    let map = read("10,5\n20,25\n", DecimalMark::Comma).unwrap();
    assert_eq!(rows(&map), [[10.5], [20.25]]);
    assert_eq!(map.metadata()["text.decimal_mark"], "comma (option)");
    let map = read("10,5\n20,25\n", DecimalMark::Point).unwrap();
    assert_eq!(rows(&map), [[10.0, 5.0], [20.0, 25.0]]);
    assert_eq!(map.metadata()["text.decimal_mark"], "point (option)");
}

#[test]
fn an_explicit_mark_that_contradicts_the_content_is_an_error() {
    let e = text_err("1 2\n3.5 4\n", DecimalMark::Comma);
    assert_eq!(
        e,
        TextError::DecimalContradiction {
            line: 2,
            token: "3.5".into(),
            mark: "comma",
            why: "it has a decimal point",
        }
    );
    let e = text_err("1, 2\n", DecimalMark::Comma);
    assert!(
        matches!(&e, TextError::DecimalContradiction { line: 1, token, .. } if token == "1,"),
        "{e:?}"
    );
    let e = text_err("1,5;2,5\n", DecimalMark::Point);
    assert!(
        matches!(
            &e,
            TextError::DecimalContradiction {
                line: 1,
                mark: "point",
                ..
            }
        ),
        "{e:?}"
    );
}

#[test]
fn header_lengths_with_decimal_commas() {
    // `# Breite: 12,34 µm` over 2 columns: dx = 6.17 µm; `# Höhe: 5678,9 nm` over 1 row.
    let text = "# Breite: 12,34 µm\n# Höhe: 5678,9 nm\n# Werteinheiten: nm\n1,5 2,5\n";
    let (map, _) = read_map_bytes(text.as_bytes(), &ReadOptions::default()).unwrap();
    assert!((map.dx() - 6.17).abs() < 1e-12, "{}", map.dx());
    assert!((map.dy() - 5.6789).abs() < 1e-12, "{}", map.dy());
    assert_eq!(map.get(1, 0), Some(2.5e-3));
    // With decimal points asked for, the header's comma is an error naming its line.
    let point = ReadOptions {
        decimal: DecimalMark::Point,
        ..ReadOptions::default()
    };
    match read_map_bytes(
        b"# Width: 1,5 um\n# Height: 1 um\n# Value units: um\n1 2\n",
        &point,
    ) {
        Err(MapError::Text(TextError::BadHeader { line: 1, .. })) => {}
        other => panic!("{other:?}"),
    }
}

#[test]
fn empty_values_between_separators_are_errors_not_dropped_columns() {
    // `1,,3` would otherwise be a 2-column row in a file of 2-column rows.
    let e = text_err("1,,3\n4,,6\n", DecimalMark::Auto);
    assert_eq!(e, TextError::EmptyValue { line: 1, column: 2 });
    assert!(e.to_string().contains("NaN"), "{e}");
    let e = text_err("1,5;;2,5\n", DecimalMark::Auto);
    assert_eq!(e, TextError::EmptyValue { line: 1, column: 2 });
}

#[test]
fn the_real_german_gwyddion_export_is_detected_as_decimal_points() {
    // SurfaceTopography's German Gwyddion export (fixtures/real): German header words,
    // numbers with points (`1 1.5 3`): must read as 3 x 4 with points.
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../fixtures/real/surfacetopography-gwyddion-export-german.txt"
    );
    let (map, _) = read_map(path, &ReadOptions::default()).unwrap();
    assert_eq!((map.nx(), map.ny()), (3, 4));
    assert_eq!(map.get(1, 0), Some(1.5e6));
    assert_eq!(map.metadata()["text.decimal_mark"], "point (detected)");
    // The same file rewritten as a German-locale export (decimal commas, `;`) reads to the
    // same numbers.
    let text = std::fs::read_to_string(path).unwrap();
    let german: String = text
        .lines()
        .map(|l| {
            if l.starts_with('#') {
                l.replace("12.34", "12,34").replace("5678.9", "5678,9")
            } else {
                l.replace('.', ",").replace(' ', ";")
            }
        })
        .collect::<Vec<_>>()
        .join("\r\n");
    let (back, _) = read_map_bytes(german.as_bytes(), &ReadOptions::default()).unwrap();
    assert_eq!(back.heights(), map.heights());
    assert_eq!((back.dx(), back.dy()), (map.dx(), map.dy()));
    assert!(back.metadata()["text.decimal_mark"].starts_with("comma (detected"));
}
