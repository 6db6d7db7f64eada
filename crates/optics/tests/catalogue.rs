//! Named layer materials and stack specs (physics.md §13): the built-in tables against
//! the formulas they were evaluated from (written out here), and every way a spec can be
//! wrong naming its layer.

use flakescatter_optics::catalogue::{Catalogue, CatalogueError, MaterialSpec, embedded_files};
use flakescatter_optics::material::ComplexIndexTable;
use flakescatter_optics::nalgebra::Complex;
use flakescatter_optics::stack_spec::{StackSpec, StackSpecError};

/// Every built-in name and alias resolves, and every embedded file is a valid table
/// whose header names its source and licence.
#[test]
fn every_builtin_parses_and_cites_its_source() {
    let cat = Catalogue::builtin();
    for name in [
        "TiO2",
        "rutile",
        "anatase",
        "TiO2-anatase",
        "Fe2O3",
        "hematite",
        "SiO2",
        "silica",
        "Al2O3",
        "alumina",
        "sapphire",
        "mica",
        "muscovite",
        "aluminium",
        "aluminum",
        "Al",
        "Cr",
        "chromium",
        "Ag",
        "silver",
        "tio2",
        "SILVER",
    ] {
        let m = cat.parse(name).unwrap_or_else(|e| panic!("{name}: {e}"));
        let (lo, hi) = m.range_nm();
        assert!(
            lo <= 380.0 && hi >= 780.0,
            "{name}: {lo}..{hi} does not cover the visible"
        );
    }
    for (file, text) in embedded_files() {
        assert!(text.contains("# Source:"), "{file}");
        assert!(text.contains("Licence"), "{file}");
    }
    assert_eq!(embedded_files().len(), 9);
}

/// Rutile (Devore 1951, ordinary ray): n² = 5.913 + 0.2441/(λ² − 0.0803), λ in µm; fused
/// silica (Malitson 1965): n² − 1 = Σ Bᵢλ²/(λ² − Cᵢ²) with B = (0.6961663, 0.4079426,
/// 0.8974794), C = (0.0684043, 0.1162414, 9.896161) µm; sapphire (Malitson 1962,
/// ordinary ray, 24 °C, the coefficients refractiveindex.info gives for it): B =
/// (1.023798, 1.058264, 5.280792), C = (0.06144821, 0.1106997, 17.92656) µm. The tables
/// hold these to 6 decimals at their 5 nm rows.
#[test]
fn formula_tables_hold_their_formulas() {
    let cat = Catalogue::builtin();
    let sellmeier = |b: [f64; 3], c: [f64; 3], l: f64| {
        (1.0 + (0..3)
            .map(|i| b[i] * l * l / (l * l - c[i] * c[i]))
            .sum::<f64>())
        .sqrt()
    };
    for wl in [400.0f64, 500.0, 550.0, 650.0, 780.0] {
        let l = wl / 1000.0;
        let rutile = (5.913 + 0.2441 / (l * l - 0.0803)).sqrt();
        let silica = sellmeier(
            [0.6961663, 0.4079426, 0.8974794],
            [0.0684043, 0.1162414, 9.896161],
            l,
        );
        let sapphire = sellmeier(
            [1.023798, 1.058264, 5.280792],
            [0.06144821, 0.1106997, 17.92656],
            l,
        );
        for (name, want) in [("TiO2", rutile), ("SiO2", silica), ("Al2O3", sapphire)] {
            let got = cat.parse(name).unwrap().index_at(wl).unwrap();
            assert!(
                (got.re - want).abs() < 6e-7,
                "{name} {wl}: {} vs {want}",
                got.re
            );
            assert_eq!(got.im, 0.0);
        }
    }
    // Published: fused silica n_d = 1.4585 at 587.6 nm (Malitson 1965, Table 1).
    let nd = cat.parse("silica").unwrap().index_at(587.6).unwrap().re;
    assert!((nd - 1.4585).abs() < 1e-4, "{nd}");
    // Published: sapphire n_o = 1.7682 at 587.6 nm (Malitson 1962).
    let no = cat.parse("sapphire").unwrap().index_at(587.6).unwrap().re;
    assert!((no - 1.7682).abs() < 1e-4, "{no}");
}

#[test]
fn constants_and_user_tables() {
    let mut cat = Catalogue::builtin();
    assert_eq!(
        cat.parse("2.6+0.01i").unwrap(),
        MaterialSpec::Constant(Complex::new(2.6, 0.01))
    );
    assert_eq!(
        cat.parse(" 1.5 ").unwrap(),
        MaterialSpec::Constant(Complex::new(1.5, 0.0))
    );
    assert_eq!(
        cat.parse("1e0+2e-1i").unwrap(),
        MaterialSpec::Constant(Complex::new(1.0, 0.2))
    );
    for bad in [
        "2.6-0.01i",
        "-1.5",
        "0",
        "2.6+i",
        "2.6+xi",
        "nan",
        "inf+0i",
        "1.5.2",
    ] {
        assert!(
            matches!(
                cat.parse(bad),
                Err(CatalogueError::BadIndex { .. } | CatalogueError::Unknown { .. })
            ),
            "{bad}: {:?}",
            cat.parse(bad)
        );
    }
    assert!(matches!(
        cat.parse("-1.5"),
        Err(CatalogueError::BadIndex { .. })
    ));
    let e = cat.parse("unobtainium").unwrap_err().to_string();
    assert!(
        e.contains("unobtainium") && e.contains("TiO2") && e.contains("mica"),
        "{e}"
    );
    let t = ComplexIndexTable::new(vec![400.0, 800.0], vec![2.0, 2.4], vec![0.0, 0.2]).unwrap();
    cat.add("MyOxide", t.clone()).unwrap();
    let n = cat.parse("myoxide").unwrap().index_at(600.0).unwrap();
    assert!((n - Complex::new(2.2, 0.1)).norm() < 1e-15);
    assert!(matches!(
        cat.add("1.5", t.clone()),
        Err(CatalogueError::BadName(_))
    ));
    assert!(matches!(
        cat.add("", t.clone()),
        Err(CatalogueError::BadName(_))
    ));
    assert!(matches!(cat.add("a/b", t), Err(CatalogueError::BadName(_))));
}

/// Each bad spec names its layer.
#[test]
fn bad_specs_name_the_layer() {
    let cat = Catalogue::builtin();
    let err = |s: &str| StackSpec::parse(s, &cat).unwrap_err();
    assert_eq!(err(""), StackSpecError::Empty);
    assert_eq!(err("  "), StackSpecError::Empty);
    assert!(matches!(
        err("TiO2:120/unobtainium:5"),
        StackSpecError::Material { layer: 2, .. }
    ));
    assert!(matches!(
        err("TiO2:120/mica:-4"),
        StackSpecError::BadThickness { layer: 2, .. }
    ));
    assert!(matches!(
        err("TiO2:0"),
        StackSpecError::BadThickness { layer: 1, .. }
    ));
    assert!(matches!(
        err("TiO2:abc"),
        StackSpecError::BadThickness { layer: 1, .. }
    ));
    assert!(matches!(
        err("TiO2:"),
        StackSpecError::BadThickness { layer: 1, .. }
    ));
    assert!(matches!(
        err("TiO2:inf"),
        StackSpecError::BadThickness { layer: 1, .. }
    ));
    assert!(matches!(
        err("TiO2"),
        StackSpecError::MissingThickness { layer: 1, .. }
    ));
    assert!(matches!(
        err("TiO2:1//mica:4"),
        StackSpecError::EmptyLayer { layer: 2 }
    ));
    assert!(matches!(
        err("TiO2:1/"),
        StackSpecError::EmptyLayer { layer: 2 }
    ));
    assert!(matches!(
        err(":40"),
        StackSpecError::EmptyLayer { layer: 1 }
    ));
    assert!(matches!(
        err("2.6-1i:40"),
        StackSpecError::Material { layer: 1, .. }
    ));
    let many = vec!["SiO2:10"; 201].join("/");
    assert_eq!(err(&many), StackSpecError::TooManyLayers(201));
    assert!(StackSpec::parse(&vec!["SiO2:10"; 200].join("/"), &cat).is_ok());
    let msg = err("TiO2:120/mica:-4").to_string();
    assert!(msg.contains("layer 2") && msg.contains("-4"), "{msg}");
    // A wavelength outside a layer's table: anatase's rows end at 826.56 nm.
    let s = StackSpec::parse("TiO2:100/anatase:50 nm", &cat).unwrap();
    assert_eq!(s.range_nm(), (380.0, 826.56));
    let e = s.at(850.0).unwrap_err();
    assert!(
        matches!(e, StackSpecError::Material { layer: 2, .. }),
        "{e}"
    );
    assert!(e.to_string().contains("850"), "{e}");
    assert_eq!(s.at(550.0).unwrap().layers().len(), 2);
    assert_eq!(s.label(), "TiO2:100/anatase:50");
}

/// A thickness fit moves named layers together: the other layers, the materials and the
/// order stay; layer numbers outside the stack and bad thicknesses are refused.
#[test]
fn with_thickness_moves_the_named_layers() {
    let cat = Catalogue::builtin();
    let s = StackSpec::parse("TiO2:120/mica:400/TiO2:120", &cat).unwrap();
    let t = s.with_thickness(&[1, 3], 85.5).unwrap();
    assert_eq!(t.label(), "TiO2:85.5/mica:400/TiO2:85.5");
    assert_eq!(s.label(), "TiO2:120/mica:400/TiO2:120");
    assert_eq!(
        s.with_thickness(&[2], 10.0).unwrap().label(),
        "TiO2:120/mica:10/TiO2:120"
    );
    assert_eq!(
        s.with_thickness(&[4], 10.0).unwrap_err(),
        StackSpecError::NoSuchLayer {
            layer: 4,
            layers: 3
        }
    );
    assert!(matches!(
        s.with_thickness(&[0], 10.0).unwrap_err(),
        StackSpecError::NoSuchLayer { layer: 0, .. }
    ));
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(matches!(
            s.with_thickness(&[1], bad).unwrap_err(),
            StackSpecError::BadThickness { layer: 1, .. }
        ));
    }
}
