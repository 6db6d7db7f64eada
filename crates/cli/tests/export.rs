//! `flakescatter export --format merl` (docs/cli.md "export", docs/formats.md "MERL"):
//! the file read here by the test's own parser, each bin's centre geometry computed
//! here from MERL's layout, and the value compared with `model --aperture 0` (the
//! point BRDF) at that geometry.
//!
//! Bin centre (docs/formats.md): `θh = (π/2)((h + ½)/90)²`, `θd = (π/2)(d + ½)/90`,
//! `φd = π(p + ½)/180`, `φh = 0`. The incident direction is the difference vector
//! `(sin θd cos φd, sin θd sin φd, cos θd)` rotated by `θh` about the binormal `y`
//! (the inverse of the reference reader's `−θh` turn), the outgoing one its mirror
//! image about the half vector `(sin θh, 0, cos θh)`. The models put the source at
//! azimuth 180°, so the detector azimuth is `φo − φi + 180°`.

mod common;

use std::f64::consts::{FRAC_PI_2, PI};
use std::fs;
use std::path::Path;

use common::{bin, run, s, scratch, stderr};

const BINS: usize = 90 * 90 * 180;
const SCALES: [f64; 3] = [1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0];

/// The stored numbers of a MERL file, parsed here: header, then 3 × BINS float64.
fn parse(path: &Path) -> Vec<f64> {
    let b = fs::read(path).unwrap();
    assert_eq!(b.len(), 12 + 3 * BINS * 8, "file length");
    let dims: Vec<i32> = b[..12]
        .chunks(4)
        .map(|c| i32::from_le_bytes(c.try_into().unwrap()))
        .collect();
    assert_eq!(dims, [90, 90, 180]);
    b[12..]
        .chunks(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
        .collect()
}

/// `(θi, θr, φr)` in degrees of flat bin `i`'s centre, `None` below the horizon.
fn centre_geometry(i: usize) -> Option<(f64, f64, f64)> {
    let (h, d, p) = (i / 16200, (i / 180) % 90, i % 180);
    let u = (h as f64 + 0.5) / 90.0;
    let th = FRAC_PI_2 * u * u;
    let td = FRAC_PI_2 * (d as f64 + 0.5) / 90.0;
    let pd = PI * (p as f64 + 0.5) / 180.0;
    let diff = [td.sin() * pd.cos(), td.sin() * pd.sin(), td.cos()];
    // Rotation by +θh about y: x' = x cos + z sin, z' = −x sin + z cos.
    let wi = [
        diff[0] * th.cos() + diff[2] * th.sin(),
        diff[1],
        -diff[0] * th.sin() + diff[2] * th.cos(),
    ];
    let half = [th.sin(), 0.0, th.cos()];
    let k = 2.0 * (wi[0] * half[0] + wi[1] * half[1] + wi[2] * half[2]);
    let wo = [0, 1, 2].map(|j| k * half[j] - wi[j]);
    if wi[2] <= 0.0 || wo[2] <= 0.0 {
        return None;
    }
    let theta_i = wi[2].acos().to_degrees();
    let theta_r = wo[2].acos().to_degrees();
    let phi_i = wi[1].atan2(wi[0]).to_degrees();
    let phi_o = wo[1].atan2(wo[0]).to_degrees();
    Some((theta_i, theta_r, (phi_o - phi_i + 180.0).rem_euclid(360.0)))
}

/// Bins spread over the table, denser near the mirror direction (small `h`), all above
/// the horizon: a fixed pseudo-random walk (no generator needed).
fn sample_bins(n: usize) -> Vec<usize> {
    let mut out = Vec::new();
    let mut x: u64 = 0x2003_1500;
    while out.len() < n {
        x = x
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let h = ((x >> 33) % 90) as usize * ((x >> 20) % 2) as usize; // half of them h = 0
        let h = h.min(((x >> 40) % 90) as usize);
        let d = ((x >> 13) % 85) as usize;
        let p = ((x >> 45) % 180) as usize;
        let i = p + 180 * d + 16200 * h;
        if centre_geometry(i).is_some() && centre_geometry(i).unwrap().0 < 89.0 {
            out.push(i);
        }
    }
    out
}

/// The point BRDF columns of `model --aperture 0` at one geometry, with `extra` flags.
fn model_at(extra: &[&str], dir: &Path, g: (f64, f64, f64)) -> Vec<f64> {
    let det = dir.join("det.csv");
    fs::write(&det, format!("theta_r_deg,phi_r_deg\n{},{}\n", g.1, g.2)).unwrap();
    let mut args: Vec<String> = vec![
        "model".into(),
        "--aperture".into(),
        "0".into(),
        "--theta-i".into(),
        format!("{}", g.0),
        "--detectors".into(),
        s(&det).into(),
    ];
    args.extend(extra.iter().map(|a| a.to_string()));
    let o = run(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    // Every row's brdf columns: one row, or one per wavelength of a spectral run.
    let text = String::from_utf8(o.stdout).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    lines
        .flat_map(|line| {
            let row: Vec<String> = line.split(',').map(str::to_owned).collect();
            header
                .iter()
                .zip(row)
                .filter(|(h, _)| h.starts_with("brdf_"))
                .map(|(_, v)| v.parse::<f64>().unwrap())
                .collect::<Vec<_>>()
        })
        .collect()
}

fn check_against_model(dir: &Path, table: &[f64], extra: &[&str], rgb_columns: bool) {
    let mut near = 0;
    for i in sample_bins(60) {
        let g = centre_geometry(i).unwrap();
        let want = model_at(extra, dir, g);
        for c in 0..3 {
            let stored = table[c * BINS + i];
            let got = stored * SCALES[c];
            let w = if rgb_columns { want[c] } else { want[0] };
            let tol = 1e-9 * w.abs().max(1e-300);
            assert!(
                (got - w).abs() <= tol,
                "bin {i} (θi {}, θr {}, φr {}) channel {c}: table {got}, model {w}",
                g.0,
                g.1,
                g.2
            );
        }
        if i < 16200 {
            near += 1;
        }
    }
    assert!(near >= 10, "{near} bins with θh index 0");
}

#[test]
fn a_grey_table_is_the_point_brdf_of_model_at_every_bin_centre() {
    let d = scratch("export", "grey");
    let out = d.join("g.binary");
    let flags = ["--hwhm", "4", "--n", "1.52", "--flake-index", "1.2,7.0"];
    let mut args = vec!["export", "--format", "merl", "--out", s(&out)];
    args.extend(flags);
    let o = run(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let table = parse(&out);
    check_against_model(&d, &table, &flags, false);
    // Below the horizon exactly −1, above it a value >= 0, in every channel.
    for i in 0..BINS {
        let above = centre_geometry(i).is_some();
        for c in 0..3 {
            let v = table[c * BINS + i];
            assert!(if above { v >= 0.0 } else { v == -1.0 }, "bin {i}: {v}");
        }
    }
    // The same bytes with one thread and with two.
    let one = d.join("one.binary");
    let mut a1 = vec!["export", "--format", "merl", "--out", s(&one)];
    a1.extend(flags);
    let o = bin()
        .args(&a1)
        .env("RAYON_NUM_THREADS", "1")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(fs::read(&one).unwrap() == fs::read(&out).unwrap());
}

/// A paint from flags: flakes of hwhm 8° with coverage 0.5 (the default), flake scales
/// and base albedos per channel, a slightly rough coat.
const PAINT: [&str; 11] = [
    "--paint",
    "--channels",
    "r,g,b",
    "--hwhm",
    "8",
    "--flake-scale",
    "0.9,0.7,0.5",
    "--base-albedo",
    "0.02,0.05,0.2",
    "--coat-roughness",
    "0.05",
];

#[test]
fn a_paint_table_holds_its_r_g_b_channels() {
    let d = scratch("export", "paint");
    let out = d.join("p.binary");
    let flags = PAINT;
    let mut args = vec!["export", "--format", "merl", "--out", s(&out)];
    args.extend(flags);
    let o = run(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let table = parse(&out);
    check_against_model(&d, &table, &flags, true);
}

#[test]
fn bad_export_flags_exit_2_naming_the_flag_and_write_nothing() {
    let d = scratch("export", "bad");
    let out = d.join("x.binary");
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["--out", "-"], "cannot go to stdout"),
        (vec!["--out", "x.csv"], "must end in .binary"),
        (
            vec!["--out", s(&out), "--aperture", "1"],
            "--aperture does not apply",
        ),
        (
            vec!["--out", s(&out), "--paint", "--channels", "r,g"],
            "the paint's channels are r, g",
        ),
        (vec!["--out", s(&out), "--hwhm", "-3"], "--hwhm"),
    ];
    for (extra, want) in cases {
        let mut args = vec!["export", "--format", "merl"];
        args.extend(extra.iter());
        let o = run(&args);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {e}");
        assert!(e.contains(want), "{args:?}: {e}");
        assert!(!out.exists(), "{args:?} wrote {}", out.display());
    }
}

/// A paint built from known parameters, exported, then fitted from its MERL table
/// (`--measured FILE.binary`, looked up on the paint tables' grid): the fit must give
/// back what went in. The BRDF fixes coverage × flake scale and (1 − coverage)² × base
/// albedo (physics.md §12), so those products are checked: 0.5 × (0.9, 0.7, 0.5) and
/// 0.25 × (0.02, 0.05, 0.2). The table's bins (about 1° in θd, φd) blur the peak a
/// little, hence 2 % on the width and the flakes, 5 % on the base.
#[test]
fn a_fit_to_an_exported_table_gives_back_the_paint() {
    let d = scratch("export", "fit");
    let out = d.join("p.binary");
    let o = run(&["export", "--format", "merl", "--out", s(&out)]
        .into_iter()
        .chain(PAINT)
        .collect::<Vec<_>>());
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run(&[
        "fit",
        "--paint",
        "--measured",
        s(&out),
        "--family",
        "gaussian",
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let physical = v["fit"]["physical"].as_array().unwrap();
    let get = |name: &str| {
        physical
            .iter()
            .find(|p| p["name"] == name)
            .unwrap_or_else(|| panic!("{name} in {physical:?}"))["value"]
            .as_f64()
            .unwrap()
    };
    let rel = |a: f64, b: f64| (a - b).abs() / b;
    assert!(rel(get("hwhm (rad)").to_degrees(), 8.0) < 0.02);
    for (c, flake, base) in [("r", 0.45, 0.005), ("g", 0.35, 0.0125), ("b", 0.25, 0.05)] {
        let f = get(&format!("flake amplitude {c}"));
        let b = get(&format!("base amplitude {c}"));
        assert!(rel(f, flake) < 0.02, "flake amplitude {c} {f}");
        assert!(rel(b, base) < 0.05, "base amplitude {c} {b}");
    }
    // A MERL table is not a curve: the distribution fit says where it belongs.
    let o = run(&["fit", "--measured", s(&out)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("a MERL BRDF table"), "{}", stderr(&o));
    // A corrupt MERL file is refused naming it.
    let bad = d.join("bad.binary");
    let mut bytes = fs::read(&out).unwrap();
    bytes.truncate(1000);
    fs::write(&bad, bytes).unwrap();
    let o = run(&["compare", "--paint", "--measured", s(&bad)]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(e.contains("bad.binary") && e.contains("truncated"), "{e}");
}

/// Interference flakes exported as linear sRGB: at sampled bins, the table equals the
/// spectrum `model --flake-stack … --aperture 0` gives at the bin's centre, weighted with
/// colour-science's linear-sRGB weights of 380…780 nm (made independently;
/// crates/flakescatter/tests/data/export/README.md). The two colour pipelines differ in
/// the fourth decimal of their matrices and weights, hence 2e-3 relative to the
/// brightest channel; a negative component (outside the gamut) must be written as 0.
#[test]
fn a_spectral_table_is_the_linear_srgb_of_the_models_spectrum() {
    let weights: Vec<[f64; 3]> =
        include_str!("../../flakescatter/tests/data/export/srgb_weights_380_780_10.csv")
            .lines()
            .filter(|l| !l.starts_with('#') && !l.starts_with("wavelength"))
            .map(|l| {
                let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
                [v[1], v[2], v[3]]
            })
            .collect();
    let d = scratch("export", "spectral");
    let out = d.join("s.binary");
    let flags = ["--flake-stack", "TiO2:125/mica:400/TiO2:125", "--hwhm", "8"];
    let mut args = vec!["export", "--format", "merl", "--out", s(&out)];
    args.extend(flags);
    let o = run(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("outside the sRGB gamut"),
        "{}",
        stderr(&o)
    );
    let table = parse(&out);
    for i in sample_bins(12) {
        let g = centre_geometry(i).unwrap();
        let spectrum = model_at(&flags, &d, g);
        assert_eq!(spectrum.len(), 41, "one BRDF per wavelength");
        let rgb = spectrum
            .iter()
            .zip(&weights)
            .fold([0.0f64; 3], |a, (f, w)| [0, 1, 2].map(|c| a[c] + f * w[c]));
        let top = rgb.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for c in 0..3 {
            let got = table[c * BINS + i] * SCALES[c];
            assert!(got >= 0.0);
            assert!(
                (got - rgb[c].max(0.0)).abs() <= 2e-3 * top,
                "bin {i} channel {c}: table {got}, colour-science {rgb:?}"
            );
        }
    }
}
