//! Polarimetry inputs at the edges (issue 52): Stokes vectors of subnormal or huge
//! numbers are the states of their unscaled copies (item 10), the degree of
//! polarisation is refused with the digits that tell it from 1 (item 23), and a
//! detector at the pole θr = 0 takes the basis of its own azimuth φr, the limit
//! θr → 0 at fixed φr (item 13).

mod common;

use common::run_text as run;

/// The `brdf_per_sr` column of a model CSV.
fn brdf(csv: &str) -> Vec<String> {
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let c = header.iter().position(|h| *h == "brdf_per_sr").unwrap();
    lines
        .map(|l| l.split(',').nth(c).unwrap().to_owned())
        .collect()
}

#[test]
fn scaled_stokes_vectors_give_the_brdf_of_the_unscaled_one() {
    let base = [
        "model",
        "--theta-i",
        "0,30,60",
        "--theta-s",
        "-70:70:10",
        "--aperture",
        "0",
    ];
    let with = |incident: &str, analyzer: &str| {
        let mut a = base.to_vec();
        a.extend(["--incident", incident, "--analyzer", analyzer]);
        let (code, out, err) = run(&a);
        assert_eq!(code, 0, "{incident} {analyzer}: {err}");
        brdf(&out)
    };
    // The reference: the s polariser as typed, S0 = 1.
    let s = with("1,1,0,0", "none");
    assert!(s.iter().all(|v| !v.is_empty()), "{s:?}");
    // Positive multiples are the same beam (a Stokes vector's scale is its power, and
    // the BRDF is per unit incident power): the same numbers, bit for bit.
    for scaled in [
        "1e-310,1e-310,0,0",
        "1e200,1e200,0,0",
        "5e-324,5e-324,0,0",
        "s",
    ] {
        assert_eq!(with(scaled, "none"), s, "--incident {scaled}");
    }
    // And as analyser states.
    let p = with("1,1,0,0", "1,-1,0,0");
    for scaled in ["1e-310,-1e-310,0,0", "1e300,-1e300,0,0", "p"] {
        assert_eq!(with("1,1,0,0", scaled), p, "--analyzer {scaled}");
    }
}

#[test]
fn over_polarised_states_show_the_digits_that_differ_from_one() {
    for (flag, state) in [
        ("--incident", "1,1.00000001,0,0"),
        ("--analyzer", "1,1.00000001,0,0"),
    ] {
        let (code, _, err) = run(&["model", "--theta-i", "30", "--theta-s", "-30", flag, state]);
        assert_eq!(code, 2, "{err}");
        assert!(err.contains(&format!("{flag} {state}")), "{err}");
        assert!(
            err.contains("1.00000001") && err.contains("(1 + 1.0e-8), above 1"),
            "{err}"
        );
        assert!(err.contains("within 1e-9 of 1 counts as 1"), "{err}");
        assert!(!err.contains("1.000000 > 1"), "{err}");
    }
    // Within the tolerance: fully polarised, the same as 1,1,0,0.
    let a = run(&[
        "model",
        "--theta-i",
        "30",
        "--theta-s",
        "-30",
        "--analyzer",
        "1,1.0000000001,0,0",
    ]);
    let b = run(&[
        "model",
        "--theta-i",
        "30",
        "--theta-s",
        "-30",
        "--analyzer",
        "1,1,0,0",
    ]);
    assert_eq!(a.0, 0, "{}", a.2);
    assert_eq!(brdf(&a.1), brdf(&b.1));
    // A state that cannot be normalised is still refused, naming the flag.
    let (code, _, err) = run(&["model", "--incident", "0,0,0,0"]);
    assert_eq!(code, 2);
    assert!(err.contains("--incident 0,0,0,0"), "{err}");
}

#[test]
fn detectors_at_the_pole_follow_their_azimuth() {
    // `--detectors` rows at θr = 0 and at θr = 1e-6° for several φr, point detectors,
    // normal incidence. The Mueller elements at the pole must be those 1e-6° away (the
    // limit at fixed φr; they differ by O(θr) ≈ 2e-8 of m00), and m11/m00 must follow
    // cos 2φr, the outgoing basis turned by φr (at normal incidence on an isotropic layer
    // the light at the pole keeps the incident s/p split: m11 = m00 at φr = 0).
    let dir = std::env::temp_dir().join(format!("fs-pol-pole-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let det = dir.join("det.csv");
    let phis = [0.0f64, 30.0, 90.0, 135.0, 270.0];
    let mut text = String::from("theta_r_deg,phi_r_deg\n");
    for p in phis {
        text.push_str(&format!("0,{p}\n1e-6,{p}\n"));
    }
    std::fs::write(&det, text).unwrap();
    let (code, out, err) = run(&[
        "model",
        "--theta-i",
        "0",
        "--detectors",
        det.to_str().unwrap(),
        "--aperture",
        "0",
        "--polarization",
        "mueller",
    ]);
    assert_eq!(code, 0, "{err}");
    let mut lines = out.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let rows: Vec<Vec<f64>> = lines
        .map(|l| {
            l.split(',')
                .map(|v| v.parse().unwrap_or(f64::NAN))
                .collect()
        })
        .collect();
    let m = |row: &[f64], e: &str| row[header.iter().position(|h| *h == e).unwrap()];
    assert_eq!(rows.len(), 2 * phis.len());
    for (k, phi) in phis.iter().enumerate() {
        let (pole, near) = (&rows[2 * k], &rows[2 * k + 1]);
        let m00 = m(pole, "m00");
        for i in 0..4 {
            for j in 0..4 {
                let e = format!("m{i}{j}");
                assert!(
                    (m(pole, &e) - m(near, &e)).abs() <= 1e-6 * m00,
                    "φ {phi}°: {e} {} at the pole, {} at 1e-6°",
                    m(pole, &e),
                    m(near, &e)
                );
            }
        }
        let want = (2.0 * phi.to_radians()).cos();
        assert!(
            (m(pole, "m11") / m00 - want).abs() < 1e-9,
            "φ {phi}°: m11/m00 {}",
            m(pole, "m11") / m00
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}
