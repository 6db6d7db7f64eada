//! The six measured paint tables of `fixtures/real/paints`, read exactly as they are:
//! every row and value against a plain split of the file's own lines.

use std::path::PathBuf;

use flakescatter_io::brdf::read_brdf_table;

fn dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/real/paints")
}

const FILES: [&str; 6] = [
    "silver-metallic-paint2.csv",
    "blue-metallic-paint2.csv",
    "gold-metallic-paint2.csv",
    "ilm_l3_37_metallic_rgb.csv",
    "pearl-paint.csv",
    "color-changing-paint1.csv",
];

#[test]
fn the_shared_paints_read_as_they_are() {
    for f in FILES {
        let path = dir().join(f);
        let t = read_brdf_table(&path, &|n| {
            if ["r", "g", "b"].contains(&n) {
                Ok(())
            } else {
                Err(format!("unexpected channel {n}"))
            }
        })
        .unwrap_or_else(|e| panic!("{f}: {e}"));
        assert_eq!(t.channels, vec!["r", "g", "b"], "{f}");
        // The reference: the file's lines split at commas, header skipped.
        let text = std::fs::read_to_string(&path).unwrap();
        let lines: Vec<&str> = text
            .lines()
            .skip(1)
            .filter(|l| !l.trim().is_empty())
            .collect();
        assert_eq!(t.rows.len(), lines.len(), "{f}");
        for (row, line) in t.rows.iter().zip(&lines) {
            let v: Vec<f64> = line.split(',').map(|x| x.trim().parse().unwrap()).collect();
            assert!((row.theta_i.to_degrees() - v[0]).abs() < 1e-12, "{f}");
            assert!((row.theta_r.to_degrees() - v[1]).abs() < 1e-12, "{f}");
            assert!((row.phi_r.to_degrees() - v[2]).abs() < 1e-12, "{f}");
            assert_eq!(row.values, v[3..6].to_vec(), "{f}");
            assert_eq!(row.uncertainties, vec![None; 3]);
        }
    }
}
