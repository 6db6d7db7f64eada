//! `flakescatter film` (docs/cli.md "film", physics.md §13): the table against closed
//! forms written here, and every bad spec exiting 2 naming its layer.

mod common;

use std::fs;

use common::{run, s, scratch, stderr};

fn stdout(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// A free quarter-wave layer of index 2.5 in a binder of 1.5 at its design wavelength,
/// normal incidence: R = ((n₀² − n₁²)/(n₀² + n₁²))² (the layer turns the admittance
/// n₀ into n₁²/n₀), and at twice the thickness (a half wave, an absentee layer) R = 0.
/// Then an oblique single layer against the Airy formula with real trigonometry.
#[test]
fn csv_rows_match_closed_forms() {
    let d = scratch("film", "csv");
    let out = d.join("f.csv");
    let o = run(&[
        "film",
        "--stack",
        "2.5:55",
        "--theta-deg",
        "0,30",
        "--wavelengths",
        "550",
        "--out",
        s(&out),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = fs::read_to_string(&out).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "wavelength_nm,theta_deg,rs_re,rs_im,rp_re,rp_im,ts_re,ts_im,tp_re,tp_im,R_s,R_p,T_s,T_p"
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 2);
    let quarter = ((2.25f64 - 6.25) / (2.25 + 6.25)).powi(2);
    assert_eq!((rows[0][0], rows[0][1]), (550.0, 0.0));
    assert!((rows[0][10] - quarter).abs() < 1e-12 && (rows[0][11] - quarter).abs() < 1e-12);
    assert!((rows[0][12] - (1.0 - quarter)).abs() < 1e-12);
    // |r|² from the amplitude columns equals the power column.
    assert!((rows[0][2].powi(2) + rows[0][3].powi(2) - rows[0][10]).abs() < 1e-15);
    // 30° in the ambient: Airy with r01 = −r12 for s, β = 2π n₁ d cos θ₁ / λ.
    let (n0, n1, dd, wl) = (1.5f64, 2.5f64, 55.0f64, 550.0f64);
    let c0 = 30f64.to_radians().cos();
    let c1 = (1.0 - (n0 * 30f64.to_radians().sin() / n1).powi(2)).sqrt();
    let r01 = (n0 * c0 - n1 * c1) / (n0 * c0 + n1 * c1);
    let beta = 2.0 * std::f64::consts::PI * n1 * dd * c1 / wl;
    let cb = (2.0 * beta).cos();
    let airy =
        (2.0 * r01 * r01 - 2.0 * r01 * r01 * cb) / (1.0 + r01.powi(4) - 2.0 * r01 * r01 * cb);
    assert!(
        (rows[1][10] - airy).abs() < 1e-12,
        "{} vs {airy}",
        rows[1][10]
    );

    let o = run(&[
        "film",
        "--stack",
        "2.5:110",
        "--theta-deg",
        "0",
        "--wavelengths",
        "550",
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let r = &v["rows"][0];
    assert!(r[10].as_f64().unwrap() < 1e-28, "{r}");
    assert_eq!(v["columns"][13], "T_p");
    assert_eq!(v["inputs"]["exit_medium"], "ambient (a free flake)");
}

/// A 2 µm aluminium layer and a bare aluminium substrate reflect alike (bulk metal), and
/// a substrate's `T` is what it absorbs: R + T = 1 over a lossless layer on aluminium.
#[test]
fn substrate_and_named_materials() {
    let a = run(&[
        "film",
        "--stack",
        "aluminium:2000",
        "--theta-deg",
        "20",
        "--wavelengths",
        "500",
        "--json",
    ]);
    let b = run(&[
        "film",
        "--stack",
        "SiO2:100",
        "--substrate",
        "Al",
        "--theta-deg",
        "20",
        "--wavelengths",
        "500",
        "--json",
    ]);
    assert!(
        a.status.success() && b.status.success(),
        "{}{}",
        stderr(&a),
        stderr(&b)
    );
    let va: serde_json::Value = serde_json::from_slice(&a.stdout).unwrap();
    let vb: serde_json::Value = serde_json::from_slice(&b.stdout).unwrap();
    let rb = vb["rows"][0].as_array().unwrap();
    let f = |i: usize| rb[i].as_f64().unwrap();
    assert!((f(10) + f(12) - 1.0).abs() < 1e-12 && (f(11) + f(13) - 1.0).abs() < 1e-12);
    assert!(f(12) > 0.01, "aluminium absorbs a few per cent");
    assert!(va["rows"][0][12].as_f64().unwrap() < 1e-30);
    assert_eq!(vb["inputs"]["substrate"], "aluminium");
}

#[test]
fn user_material_table() {
    let d = scratch("film", "user");
    let t = d.join("oxide.csv");
    fs::write(&t, "wavelength_nm,n,k\n400,2.0,0\n800,2.0,0\n").unwrap();
    let o = run(&[
        "film",
        "--stack",
        "myoxide:68.75",
        "--material",
        &format!("myoxide={}", s(&t)),
        "--theta-deg",
        "0",
        "--wavelengths",
        "550",
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    // Quarter wave of n = 2 at 550 nm: R = ((2.25 − 4)/(2.25 + 4))².
    let want = ((2.25f64 - 4.0) / (2.25 + 4.0)).powi(2);
    assert!((v["rows"][0][10].as_f64().unwrap() - want).abs() < 1e-12);
    // The table's range is enforced, naming the layer.
    let o = run(&[
        "film",
        "--stack",
        "SiO2:10/myoxide:68.75",
        "--material",
        &format!("myoxide={}", s(&t)),
        "--wavelengths",
        "850",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("layer 2") && stderr(&o).contains("850"),
        "{}",
        stderr(&o)
    );
    // Its own table cannot be the output.
    let o = run(&[
        "film",
        "--stack",
        "myoxide:68.75",
        "--material",
        &format!("myoxide={}", s(&t)),
        "--out",
        s(&t),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert_eq!(
        fs::read_to_string(&t).unwrap(),
        "wavelength_nm,n,k\n400,2.0,0\n800,2.0,0\n"
    );
    for bad in ["myoxide", "=x.csv", "a=", "1.5=x.csv"] {
        let o = run(&["film", "--stack", "SiO2:10", "--material", bad]);
        assert_eq!(o.status.code(), Some(2), "{bad}");
    }
}

/// The list: unknown material, negative or zero thickness, a thickness with no
/// number, an empty layer, more than 200 layers, a wavelength outside a table's range —
/// and the angles and ambient.
#[test]
fn bad_specs_exit_2_naming_the_layer() {
    let many = vec!["SiO2:10"; 201].join("/");
    let cases: Vec<(Vec<&str>, &[&str])> = vec![
        (
            vec!["--stack", "TiO2:120/kryptonite:40"],
            &["layer 2", "kryptonite"],
        ),
        (vec!["--stack", "TiO2:120/mica:-400"], &["layer 2", "-400"]),
        (vec!["--stack", "TiO2:0"], &["layer 1", "thickness"]),
        (vec!["--stack", "TiO2:nm"], &["layer 1", "thickness"]),
        (vec!["--stack", "TiO2"], &["layer 1", "no thickness"]),
        (vec!["--stack", "TiO2:12//mica:40"], &["layer 2", "empty"]),
        (vec!["--stack", ""], &["empty"]),
        (vec!["--stack", &many], &["201 layers", "200"]),
        (
            vec!["--stack", "anatase:50", "--wavelengths", "850"],
            &["layer 1", "anatase", "850"],
        ),
        (
            vec!["--stack", "TiO2:50", "--wavelengths", "300"],
            &["layer 1", "TiO2", "300"],
        ),
        (vec!["--stack", "2.6-0.1i:50"], &["layer 1", "2.6-0.1i"]),
        (
            vec!["--stack", "TiO2:50", "--substrate", "gold"],
            &["--substrate", "gold"],
        ),
        (
            vec!["--stack", "TiO2:50", "--ambient", "0.5"],
            &["--ambient"],
        ),
        (
            vec!["--stack", "TiO2:50", "--ambient", "nan"],
            &["--ambient"],
        ),
        (
            vec!["--stack", "TiO2:50", "--theta-deg", "95"],
            &["--theta-deg", "95"],
        ),
        (
            vec!["--stack", "TiO2:50", "--theta-deg", "-5"],
            &["--theta-deg"],
        ),
        (
            vec!["--stack", "TiO2:50", "--wavelengths", "0"],
            &["--wavelengths"],
        ),
    ];
    for (args, wants) in cases {
        let mut a = vec!["film"];
        a.extend(args.iter().copied());
        let o = run(&a);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {e}");
        assert!(!e.contains("panicked"), "{e}");
        for w in wants {
            assert!(e.contains(w), "{args:?}: {e:?} lacks {w:?}");
        }
    }
}

#[test]
fn default_grid_prints_a_table() {
    let o = run(&["film", "--stack", "TiO2:120/mica:400/TiO2:120"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let t = stdout(&o);
    // 41 wavelengths × 9 angles + 2 header lines.
    assert_eq!(t.lines().count(), 41 * 9 + 2, "{t}");
    assert!(t.starts_with("stack TiO2:120/mica:400/TiO2:120 in an ambient of 1.5 (a free flake)"));
}
