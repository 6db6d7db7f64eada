//! Colour at the edges (issue 52): spectra whose XYZ overflow are refused naming the
//! file and line, huge but representable ones give numbers throughout (never an empty
//! cell or a ΔE2000 of 0 beside a ΔE*ab of 1e102), with a caution (item 11); colour
//! targets outside a surface colour's range and zero uncertainties are refused naming
//! the file, line and column, by every command that reads them (item 12).

mod common;

use common::{run_text as run, scratch};

/// A flat spectrum of `value`, 380–780 nm every 10 nm.
fn flat(value: f64) -> String {
    let mut s = String::from("wavelength_nm,reflectance_factor\n");
    for w in (380..=780).step_by(10) {
        s.push_str(&format!("{w},{value:e}\n"));
    }
    s
}

#[test]
fn spectra_beyond_the_doubles_are_refused_and_huge_ones_are_numbers() {
    let d = scratch("colour-edges", "overflow");
    let write = |name: &str, text: &str| {
        let p = d.join(name);
        std::fs::write(&p, text).unwrap();
        p.to_str().unwrap().to_owned()
    };
    let big = write("big.csv", &flat(1e308));
    let huge = write("huge.csv", &flat(1e300));
    let grey = write("grey.csv", &flat(0.5));
    // XYZ of a 1e308 spectrum (Y ≈ 1e310) does not exist: exit 2, file and line named,
    // nothing written; as sample and as reference.
    for args in [
        vec!["colour", "--reflectance", &big],
        vec![
            "colour",
            "--reflectance",
            &big,
            "--reference",
            &grey,
            "--json",
        ],
        vec!["colour", "--reflectance", &grey, "--reference", &big],
    ] {
        let (code, out, err) = run(&args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(out.is_empty(), "{args:?}: {out}");
        assert!(
            err.contains(&big) && err.contains("line 2") && err.contains("largest double"),
            "{args:?}: {err}"
        );
    }
    // 1e300: Y = 1e302 and L* = 116·(1e300)^(1/3) − 16 = 1.16e102 are doubles. Every
    // cell is a number, the differences too (ΔE2000 is dominated by its lightness term
    // ΔL*/S_L = 1.16e102/(1 + 0.015·5.8e101) = 133.3; its chroma term is rounding at
    // that scale, hence the caution), never 0.
    let (code, out, err) = run(&[
        "colour",
        "--reflectance",
        &huge,
        "--reference",
        &grey,
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("far beyond any surface colour"), "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    for k in [
        "X",
        "Y",
        "Z",
        "L",
        "a",
        "b",
        "C",
        "h",
        "delta_e_ab",
        "delta_e_94",
        "delta_e_2000",
    ] {
        assert!(v[k].as_f64().is_some_and(f64::is_finite), "{k}: {}", v[k]);
    }
    assert!((v["L"].as_f64().unwrap() / 1.16e102 - 1.0).abs() < 1e-12);
    let e00 = v["delta_e_2000"].as_f64().unwrap();
    assert!(e00 > 100.0, "{e00}");
    assert_eq!(v["warnings"].as_array().unwrap().len(), 1);
    // The CSV has no empty cell.
    let (code, out, err) = run(&[
        "colour",
        "--reflectance",
        &huge,
        "--reference",
        &grey,
        "--out",
        "-",
    ]);
    assert_eq!(code, 0, "{err}");
    let row = out.lines().nth(1).unwrap();
    assert!(row.split(',').all(|c| !c.is_empty()), "{row}");
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn colour_targets_outside_a_surface_colours_range_are_refused() {
    let d = scratch("colour-edges", "targets");
    let lab = |l: &str, a: &str, u: Option<&str>| {
        let mut s = String::from("theta_i_deg,aspecular_deg,L,a,b");
        s.push_str(if u.is_some() {
            ",L_uncertainty\n"
        } else {
            "\n"
        });
        for (k, asp) in [15, 45, 110].iter().enumerate() {
            // The bad value on the second data row (line 3).
            let (l, a) = if k == 1 { (l, a) } else { ("60", "1") };
            s.push_str(&format!("45,{asp},{l},{a},2"));
            match u {
                Some(u) if k == 1 => s.push_str(&format!(",{u}\n")),
                Some(_) => s.push_str(",0.5\n"),
                None => s.push('\n'),
            }
        }
        s
    };
    let cases: Vec<(String, &str)> = vec![
        (lab("-5", "1", None), "column L"),
        // Below 0 by more than noise: max(1, 5 u) (-0.7 with u = 0.3 is noise, accepted
        // by the fits' simulations in crates/flakescatter/tests/spectral_fit.rs).
        (lab("-1.01", "1", None), "column L"),
        (lab("-1.6", "1", Some("0.3")), "column L"),
        (lab("1e300", "1", None), "column L"),
        (lab("1000.5", "1", None), "column L"),
        (lab("60", "1e300", None), "column a"),
        (lab("60", "1", Some("0")), "column L_uncertainty"),
        (lab("60", "1", Some("-0.2")), "column L_uncertainty"),
        // A huge uncertainty must not open the floor of L*: at most 100, and L* never
        // below -20 (with u = 1e300 the floor was -5e300, and L* = -1e300 gave a
        // delta E of 1e300).
        (lab("-1e300", "1", Some("1e300")), "column L_uncertainty"),
        (lab("60", "1", Some("100.5")), "column L_uncertainty"),
        (lab("-20.5", "1", Some("50")), "column L"),
    ];
    // A measured spectrum whose colour is no surface's: L* = 116·1e4^(1/3) − 16 = 2483.
    let mut spectral = String::from("theta_i_deg,aspecular_deg,wavelength_nm,reflectance_factor\n");
    for asp in [15, 45, 110] {
        let r = if asp == 45 { 1e4 } else { 0.5 };
        for w in (380..=780).step_by(20) {
            spectral.push_str(&format!("45,{asp},{w},{r}\n"));
        }
    }
    for (i, (text, column)) in cases.iter().enumerate() {
        let f = d.join(format!("t{i}.csv"));
        std::fs::write(&f, text).unwrap();
        let f = f.to_str().unwrap();
        for cmd in ["compare", "fit"] {
            let (code, out, err) = run(&[cmd, "--measured-multiangle", f, "--json"]);
            assert_eq!(code, 2, "{cmd} {text}: {err}");
            assert!(out.is_empty());
            assert!(
                err.contains(f) && err.contains("line 3") && err.contains(column),
                "{cmd} {text}: {err}"
            );
        }
    }
    let f = d.join("spectral.csv");
    std::fs::write(&f, &spectral).unwrap();
    let f = f.to_str().unwrap();
    for cmd in ["compare", "fit"] {
        let (code, _, err) = run(&[
            cmd,
            "--measured-multiangle",
            f,
            "--wavelengths",
            "380:780:20",
        ]);
        assert_eq!(code, 2, "{cmd}: {err}");
        assert!(
            err.contains(f) && err.contains("line 23") && err.contains("L* = 2483"),
            "{cmd}: {err}"
        );
    }
    // Metallic lightness above 100 (near specular) is a surface colour: accepted.
    let ok = d.join("metallic.csv");
    std::fs::write(
        &ok,
        "theta_i_deg,aspecular_deg,L,a,b,L_uncertainty\n45,15,140,1,2,0.5\n45,45,60,1,2,0.5\n45,110,30,1,2,0.5\n",
    )
    .unwrap();
    let (code, _, err) = run(&[
        "compare",
        "--measured-multiangle",
        ok.to_str().unwrap(),
        "--wavelengths",
        "380:780:20",
    ]);
    assert_eq!(code, 0, "{err}");
    std::fs::remove_dir_all(&d).ok();
}
