//! Polarimetry inputs at the edges (issue 52): Stokes vectors of subnormal or huge
//! numbers are the states of their unscaled copies (item 10), the degree of
//! polarisation is refused with the digits that tell it from 1 (item 23), and a
//! detector at the pole θr = 0 takes the basis of its own azimuth φr, the limit
//! θr → 0 at fixed φr (item 13).

use std::process::Command;

fn run(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_flakescatter"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

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
