//! `--binder-absorption ALPHA` as a constant (issue 47, tinted binders; physics.md §8.1):
//! every flake at depth d, each point BRDF (`--aperture 0`) is the clear run's times `exp(−α d (1/cos θt + 1/cos θ2))`
//! with Snell's angles inside written here; and the same run with a CSV table holding α
//! at every row gives the same bytes.

mod common;

use std::fs;

use common::{run, s, scratch, stderr};

fn brdf_rows(o: &std::process::Output) -> Vec<(f64, f64)> {
    assert!(o.status.success(), "{}", stderr(o));
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .skip(1)
        .map(|l| {
            let v: Vec<f64> = l
                .split(',')
                .map(|x| x.parse().unwrap_or(f64::NAN))
                .collect();
            (v[2], v[5]) // theta_s_deg, brdf_per_sr
        })
        .collect()
}

#[test]
fn constant_absorption_is_beer_lambert_on_the_refracted_path() {
    let (alpha, depth, n) = (0.05f64, 4.0f64, 1.5f64);
    let base = [
        "model",
        "--hwhm",
        "6",
        "--theta-i",
        "40",
        "--theta-s",
        "-70:30:10",
        "--wavelengths",
        "550",
        "--n",
        "1.5",
        "--aperture",
        "0",
    ];
    let clear = brdf_rows(&run(&base));
    let mut a = base.to_vec();
    a.extend(["--binder-absorption", "0.05", "--flake-depth-um", "4"]);
    let tinted = run(&a);
    let tinted_rows = brdf_rows(&tinted);
    let ct = (1.0 - (40f64.to_radians().sin() / n).powi(2)).sqrt();
    let mut checked = 0;
    for ((ts, c), (_, t)) in clear.iter().zip(&tinted_rows) {
        if *c == 0.0 {
            continue;
        }
        let c2 = (1.0 - (ts.to_radians().sin() / n).powi(2)).sqrt();
        let want = (-alpha * depth * (1.0 / ct + 1.0 / c2)).exp();
        assert!((t / c - want).abs() < 1e-12, "θs {ts}: {} vs {want}", t / c);
        checked += 1;
    }
    assert!(checked >= 8);

    let d = scratch("tinted", "table");
    let table = d.join("alpha.csv");
    fs::write(&table, "wavelength_nm,alpha_per_um\n300,0.05\n900,0.05\n").unwrap();
    let mut b = base.to_vec();
    b.extend(["--binder-absorption", s(&table), "--flake-depth-um", "4"]);
    let from_table = run(&b);
    assert!(from_table.status.success(), "{}", stderr(&from_table));
    assert_eq!(from_table.stdout, tinted.stdout);
}

#[test]
fn bad_constants_are_refused() {
    for bad in ["-0.05", "nan", "inf", "1e400"] {
        let o = run(&[
            "model",
            "--hwhm",
            "6",
            "--wavelengths",
            "550",
            "--flake-depth-um",
            "4",
            "--binder-absorption",
            bad,
        ]);
        assert_eq!(o.status.code(), Some(2), "{bad}");
        assert!(
            stderr(&o).contains("--binder-absorption"),
            "{bad}: {}",
            stderr(&o)
        );
    }
    // The depth is still required.
    let o = run(&[
        "model",
        "--hwhm",
        "6",
        "--wavelengths",
        "550",
        "--binder-absorption",
        "0.1",
    ]);
    assert_eq!(o.status.code(), Some(2));
}
