//! The built-in aluminium tables against their source (values typed in from the
//! refractiveindex.info YAML files `Al/nk/Rakic.yml` and `Al/nk/McPeak.yml`), the parse
//! against the embedded files, the 550 nm value against physics.md, interpolation and
//! errors.

use flakescatter_optics::material::{ComplexIndexTable, EMBEDDED_FILES, MaterialError};

#[test]
fn tables_reproduce_their_source_at_tabulated_wavelengths() {
    // Rakic.yml rows "4.1328E-01 5.2135E-01 5.0008E+00", "5.6357E-01 1.0728E+00 6.7839E+00",
    // "8.1569E-01 2.7668E+00 8.2573E+00" (µm, n, k).
    let rakic = ComplexIndexTable::aluminium_rakic_1995();
    for (nm, n, k) in [
        (413.28, 0.52135, 5.0008),
        (563.57, 1.0728, 6.7839),
        (815.69, 2.7668, 8.2573),
    ] {
        assert_eq!(rakic.index_at(nm).unwrap(), (n, k), "Rakić {nm} nm");
    }
    // McPeak.yml rows "0.3 0.204991638 3.100858199", "0.55 0.789405353 5.851936501",
    // "0.9 1.64715608 7.393045594".
    let mcpeak = ComplexIndexTable::aluminium_mcpeak_2015();
    for (nm, n, k) in [
        (300.0, 0.204991638, 3.100858199),
        (550.0, 0.789405353, 5.851936501),
        (900.0, 1.64715608, 7.393045594),
    ] {
        assert_eq!(mcpeak.index_at(nm).unwrap(), (n, k), "McPeak {nm} nm");
    }
    assert_eq!(rakic.wavelengths_nm().len(), 17);
    assert_eq!(mcpeak.wavelengths_nm().len(), 121);
    // Both cover the colorimetric range 360–830 nm.
    for t in [rakic, mcpeak] {
        let (lo, hi) = t.range_nm();
        assert!(lo <= 360.0 && hi >= 830.0);
    }
    assert_eq!(ComplexIndexTable::aluminium(), rakic);
}

#[test]
fn parse_equals_the_embedded_file() {
    // An independent read of each file: skip '#' lines and the header, split on commas.
    let tables = [
        ComplexIndexTable::aluminium_rakic_1995(),
        ComplexIndexTable::aluminium_mcpeak_2015(),
    ];
    for ((name, text), table) in EMBEDDED_FILES.iter().zip(tables) {
        let rows: Vec<Vec<f64>> = text
            .lines()
            .filter(|l| !l.starts_with('#') && !l.starts_with("wavelength_nm"))
            .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
            .collect();
        assert_eq!(rows.len(), table.wavelengths_nm().len(), "{name}");
        for (i, r) in rows.iter().enumerate() {
            assert_eq!(
                [table.wavelengths_nm()[i], table.n()[i], table.k()[i]],
                [r[0], r[1], r[2]],
                "{name} row {i}"
            );
        }
        assert!(
            text.contains("CC0 1.0") && text.contains("doi:"),
            "{name} names its source and licence"
        );
    }
}

#[test]
fn aluminium_at_550_nm_is_physics_md_value_within_the_datasets_spread() {
    // physics.md §2: aluminium at 550 nm is about 0.96 + 6.69i. Rakić 1995 interpolated
    // linearly between 516.60 nm (0.8734 + 6.2418i) and 563.57 nm (1.0728 + 6.7839i):
    // t = 33.40/46.97, n = 1.0152, k = 6.6273 (by hand).
    let (n, k) = ComplexIndexTable::aluminium().index_at(550.0).unwrap();
    let t = (550.0 - 516.60) / (563.57 - 516.60);
    assert!((n - (0.8734 + t * (1.0728 - 0.8734))).abs() < 1e-12);
    assert!((k - (6.2418 + t * (6.7839 - 6.2418))).abs() < 1e-12);
    assert!((n - 1.0152).abs() < 1e-4 && (k - 6.6273).abs() < 1e-4);
    // physics.md's value is within 0.06 of Rakić in each part; the two shipped datasets
    // differ from each other by 0.23 in n and 0.78 in k at this wavelength.
    let (n2, k2) = ComplexIndexTable::aluminium_mcpeak_2015()
        .index_at(550.0)
        .unwrap();
    assert!((n - 0.96).abs() < 0.06 && (k - 6.69).abs() < 0.07);
    assert!((n - 0.96).abs() < (n - n2).abs() && (k - 6.69).abs() < (k - k2).abs());
    // Normal-incidence reflectance in air, ((n−1)² + k²)/((n+1)² + k²) = 0.9154: the
    // familiar ~91.5 % of aluminium in the green.
    let r = ComplexIndexTable::aluminium()
        .flake_at(550.0)
        .unwrap()
        .average(1.0, 1.0);
    let closed = ((n - 1.0).powi(2) + k * k) / ((n + 1.0).powi(2) + k * k);
    assert!(
        (r - closed).abs() < 1e-12 && (r - 0.9154).abs() < 1e-3,
        "{r}"
    );
}

#[test]
fn interpolation_is_linear_between_rows() {
    let t = ComplexIndexTable::new(
        vec![400.0, 500.0, 700.0],
        vec![1.0, 2.0, 4.0],
        vec![5.0, 6.0, 6.0],
    )
    .unwrap();
    assert_eq!(t.index_at(450.0).unwrap(), (1.5, 5.5));
    assert_eq!(t.index_at(650.0).unwrap(), (3.5, 6.0));
    assert_eq!(t.index_at(700.0).unwrap(), (4.0, 6.0));
    assert_eq!(t.index_at(400.0).unwrap(), (1.0, 5.0));
}

#[test]
fn bad_tables_and_lookups_are_refused() {
    let e = ComplexIndexTable::new(vec![400.0, 500.0], vec![1.0], vec![5.0, 6.0]).unwrap_err();
    assert!(matches!(e, MaterialError::LengthMismatch { .. }));
    assert_eq!(
        ComplexIndexTable::new(vec![400.0], vec![1.0], vec![5.0]).unwrap_err(),
        MaterialError::TooFewRows(1)
    );
    let e = ComplexIndexTable::new(vec![400.0, 400.0], vec![1.0, 1.0], vec![5.0, 5.0]).unwrap_err();
    assert!(
        matches!(e, MaterialError::NotIncreasing { row: 1, .. }),
        "{e}"
    );
    let e =
        ComplexIndexTable::new(vec![400.0, f64::NAN], vec![1.0, 1.0], vec![5.0, 5.0]).unwrap_err();
    assert!(
        matches!(e, MaterialError::InvalidWavelength { row: 1, .. }),
        "{e}"
    );
    let e =
        ComplexIndexTable::new(vec![400.0, 500.0], vec![1.0, -1.0], vec![5.0, 5.0]).unwrap_err();
    assert!(
        e.to_string().contains("row 1") && e.to_string().contains("n > 0"),
        "{e}"
    );
    let e =
        ComplexIndexTable::new(vec![400.0, 500.0], vec![1.0, 1.0], vec![-0.1, 5.0]).unwrap_err();
    assert!(matches!(e, MaterialError::InvalidIndex { row: 0, .. }));
    let al = ComplexIndexTable::aluminium();
    let e = al.index_at(200.0).unwrap_err();
    assert!(
        e.to_string()
            .contains("outside the table (309.96 to 885.61 nm)"),
        "{e}"
    );
    assert!(al.index_at(f64::NAN).is_err());
}
