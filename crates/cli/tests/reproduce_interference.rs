//! `reproduce`'s interference-pigment figure (issue 47, physics.md §13): its files, and
//! its colours against what the trade sells these TiO2-on-mica thicknesses as (first-order
//! interference colours: a near-neutral silver, a yellow gold, a blue; e.g. Pfaff,
//! "Special Effect Pigments", 2nd ed., 2008, ch. 3) — hue ranges wide enough to hold
//! whatever dataset of TiO2 is used, narrow enough to catch a wrong thickness or order.

mod common;

use std::fs;

use common::{fixture, run, s, scratch, stderr};

#[test]
fn silver_gold_and_blue_pearls() {
    let out = scratch("repro-interference", "quick");
    let fixtures = fixture("");
    let o = run(&[
        "reproduce",
        "--quick",
        "--out",
        s(&out.join("r")),
        "--fixtures",
        s(&fixtures),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let dir = out.join("r");
    for stem in ["interference_spectra", "interference_travel"] {
        for ext in ["svg", "png"] {
            assert!(dir.join(format!("{stem}.{ext}")).exists(), "{stem}.{ext}");
        }
    }
    let index = fs::read_to_string(dir.join("index.md")).unwrap();
    assert!(index.contains("interference (pearlescent) flakes"));
    let csv = fs::read_to_string(dir.join("interference.csv")).unwrap();
    let mut seen = 0;
    for line in csv.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let (name, asp) = (f[0], f[3]);
        let (l, c, h): (f64, f64, f64) = (
            f[5].parse().unwrap(),
            f[8].parse().unwrap(),
            f[9].parse().unwrap(),
        );
        if asp != "15" {
            continue;
        }
        seen += 1;
        match name {
            "silver" => assert!(c < 25.0 && l > 80.0, "silver: L* {l} C* {c}"),
            "gold" => assert!(c > 40.0 && (60.0..110.0).contains(&h), "gold: C* {c} h {h}"),
            "blue" => assert!(
                c > 40.0 && (220.0..290.0).contains(&h),
                "blue: C* {c} h {h}"
            ),
            other => panic!("unexpected pigment {other}"),
        }
    }
    assert_eq!(seen, 3);
    // Each pigment's spectrum at every geometry: 3 × 6 × 41 rows.
    let spectra = fs::read_to_string(dir.join("interference_spectra.csv")).unwrap();
    assert_eq!(spectra.lines().count(), 1 + 3 * 6 * 41);
}
