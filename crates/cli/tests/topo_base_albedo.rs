//! `topo --flake-stack SPEC --base-albedo RHO` (docs/cli.md, physics.md §13 "The base
//! under a map's flakes"). The term itself is checked against its derivation in
//! `crates/flakescatter/tests/topo_base.rs`; here: `--base-albedo 0` writes the black
//! base's bytes; a base raises every row, the rows far from specular (which no flake
//! ray reaches) most, in proportion to `ρ/(1 − ρ r̄)` — so that two albedos' gains have
//! the ratio that fixes `r̄` in (0, 1); the JSON echoes the albedo; `--multi-angle`
//! honours it; bad uses exit 2 naming the flag.

mod common;

use common::{fixture, run, run_text, s};

fn rows(o: &std::process::Output) -> Vec<Vec<String>> {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

fn base_args() -> Vec<String> {
    let h = fixture("synth-hwhm3-smooth.height.x3p");
    let i = fixture("synth-hwhm3-smooth.intensity.x3p");
    [
        "topo",
        s(&h),
        "--intensity",
        s(&i),
        "--cutoff",
        "0.5",
        "--flake-stack",
        "TiO2:120",
        "--wavelengths",
        "450,600",
        "--theta-i",
        "45",
        "--theta-s",
        "-70:70:10",
    ]
    .iter()
    .map(|a| (*a).to_string())
    .collect()
}

fn with(extra: &[&str]) -> Vec<String> {
    let mut a = base_args();
    a.extend(extra.iter().map(|x| (*x).to_string()));
    a
}

/// Column `k` of every row, as numbers (empty cells as NaN).
fn column(rows: &[Vec<String>], k: usize) -> Vec<f64> {
    rows.iter()
        .map(|r| r[k].parse().unwrap_or(f64::NAN))
        .collect()
}

#[test]
fn a_base_raises_every_row_and_zero_is_the_black_base() {
    let black = run(&base_args());
    let zero = run(&with(&["--base-albedo", "0"]));
    assert_eq!(
        black.stdout, zero.stdout,
        "--base-albedo 0 is the black base"
    );
    let black = rows(&black);
    let half = rows(&run(&with(&["--base-albedo", "0.5"])));
    let full = rows(&run(&with(&["--base-albedo", "1"])));
    // Columns: wavelength_nm, theta_i_deg, theta_s_deg, phi_s_deg, aperture_deg,
    // brdf_per_sr, reflectance, relative, rays, std_err.
    let (rb, rh, rf) = (column(&black, 6), column(&half, 6), column(&full, 6));
    let (nb, nh) = (column(&black, 8), column(&half, 8));
    let mut far = 0;
    for k in 0..rb.len() {
        assert_eq!(nb[k], nh[k], "row {k}: the flakes' rays are unchanged");
        let (gh, gf) = (rh[k] - rb[k], rf[k] - rb[k]);
        assert!(gh > 0.0 && gf > gh, "row {k}: {gh} {gf}");
        // gain(ρ) ∝ ρ/(1 − ρ r̄): gf/gh = 2 (1 − r̄/2)/(1 − r̄) = (2 − r̄)/(1 − r̄), so
        // r̄ = (q − 2)/(q − 1) with q = gf/gh, the same for every row of a wavelength
        // and in (0, 1).
        let q = gf / gh;
        let r_bar = (q - 2.0) / (q - 1.0);
        assert!(r_bar > 0.0 && r_bar < 1.0, "row {k}: r̄ = {r_bar}");
        if nb[k] == 0.0 {
            far += 1;
            assert_eq!(rb[k], 0.0);
        }
    }
    assert!(far >= 10, "{far} rows with no flake ray");
    // One r̄ per wavelength (rows of a wavelength share it, to rounding).
    let nrows = rb.len() / 2;
    for w in 0..2 {
        let r: Vec<f64> = (w * nrows..(w + 1) * nrows)
            .map(|k| {
                let q = (rf[k] - rb[k]) / (rh[k] - rb[k]);
                (q - 2.0) / (q - 1.0)
            })
            .collect();
        let (lo, hi) = r
            .iter()
            .fold((1.0f64, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
        assert!(hi - lo < 1e-9, "wavelength {w}: r̄ from {lo} to {hi}");
    }
}

#[test]
fn the_summary_echoes_the_albedo_and_multi_angle_honours_it() {
    let o = run(&with(&["--base-albedo", "0.4", "--json"]));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["inputs"]["base_albedo"], 0.4);

    let h = fixture("synth-hwhm3-smooth.height.x3p");
    let ma = |extra: &[&str]| {
        let mut a = vec![
            "topo",
            s(&h),
            "--flake-stack",
            "TiO2:120",
            "--multi-angle",
            "--wavelengths",
            "400:700:20",
            "--json",
        ];
        a.extend(extra);
        let o = run(&a);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        serde_json::from_slice::<serde_json::Value>(&o.stdout).unwrap()
    };
    let black = ma(&[]);
    let based = ma(&["--base-albedo", "0.8"]);
    assert_eq!(based["inputs"]["base_albedo"], 0.8);
    let lightness = |j: &serde_json::Value| -> Vec<f64> {
        j["readouts"]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| r["L"].as_f64().unwrap())
            .collect()
    };
    for (b, w) in lightness(&black).iter().zip(lightness(&based)) {
        assert!(w > *b, "L* {b} → {w}");
    }
}

#[test]
fn bad_uses_exit_2_naming_the_flag() {
    let h = fixture("synth-hwhm3-smooth.height.x3p");
    let binder = [
        "--binder-absorption",
        "0.1",
        "--film-um",
        "10",
        "--base-albedo",
        "0.5",
    ];
    for (extra, needle) in [
        (vec!["--base-albedo", "1.2"], "[0, 1]"),
        (vec!["--base-albedo", "x"], "[0, 1]"),
        (
            vec!["--flake-core", "aluminium", "--base-albedo", "0.5"],
            "transmit",
        ),
        (binder.to_vec(), "--binder-absorption"),
        (vec!["--isotropic", "--base-albedo", "0.5"], "--isotropic"),
    ] {
        let mut a = vec!["topo", s(&h), "--flake-stack", "TiO2:120"];
        a.extend(&extra);
        let (code, _, err) = run_text(&a);
        assert_eq!(code, 2, "{extra:?}: {err}");
        assert!(err.contains(needle), "{extra:?}: {err}");
    }
    let mut a = vec!["model", "--flake-stack", "TiO2:120"];
    a.extend(binder);
    let (code, _, err) = run_text(&a);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--binder-absorption"), "{err}");
    let (code, _, err) = run_text(&["topo", s(&h), "--base-albedo", "0.5"]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("--base-albedo") && err.contains("--flake-stack"),
        "{err}"
    );
}
