//! Number flags refused once, by their own check, with one message (issue 52, item 23):
//! `--wavelengths -550` is a wavelength outside (0, inf) nanometres, not an unknown flag
//! `-5`; `--wavelengths 0` speaks of nanometres, not degrees; `volume --rays` gives the
//! same message for 0, −1, 1e20, 1.5 and text.

mod common;

use common::run_text as run;

#[test]
fn negative_and_zero_wavelengths_are_refused_in_nanometres() {
    for (list, shown) in [
        ("-550", "-550 nm"),
        ("-550,600", "-550 nm"),
        ("-.5", "-0.5 nm"),
        ("-1e-3", "-0.001 nm"),
        ("0", "0 nm"),
        ("0:700:100", "0 nm"),
    ] {
        // The check is SpectralArgs', shared by model, topo, compare and fit.
        {
            let cmd = "model";
            let (code, out, err) = run(&[cmd, "--wavelengths", list]);
            assert_eq!(code, 2, "{cmd} --wavelengths {list}: {err}");
            assert!(out.is_empty());
            assert!(
                err.contains("--wavelengths")
                    && err.contains(&format!("{shown} is outside (0, inf) nanometres")),
                "{cmd} --wavelengths {list}: {err}"
            );
            assert!(!err.contains('°') && !err.contains("degrees"), "{err}");
            assert!(!err.contains("unexpected argument"), "{err}");
        }
    }
}

#[test]
fn rays_out_of_range_get_one_message() {
    let mut messages = Vec::new();
    for rays in [
        "0",
        "-1",
        "1e20",
        "1.5",
        "many",
        "1099511627777",
        "18446744073709551616",
    ] {
        let (code, out, err) = run(&["volume", "--rays", rays]);
        assert_eq!(code, 2, "--rays {rays}: {err}");
        assert!(out.is_empty());
        assert!(
            err.contains(&format!("invalid value '{rays}' for '--rays <N>'")),
            "--rays {rays}: {err}"
        );
        // The message after the value, the same for every case.
        let tail = err
            .lines()
            .next()
            .unwrap()
            .split(": ")
            .last()
            .unwrap()
            .to_owned();
        messages.push(tail);
    }
    messages.dedup();
    assert_eq!(
        messages,
        ["expected a whole number from 1 to 1099511627776"],
        "{messages:?}"
    );
}

#[test]
fn every_bounded_count_flag_gives_one_message_for_every_bad_value() {
    // (command and flag, the message, a value just outside at the top if there is one)
    for (args, message, above) in [
        (
            &["volume", "--rays"][..],
            "from 1 to 1099511627776",
            Some("1099511627777"),
        ),
        (
            &["stack", "x.tif", "--half-window"][..],
            "from 1 to 32",
            Some("33"),
        ),
        (
            &["synth", "--count"][..],
            "from 1 to 10000000",
            Some("10000001"),
        ),
        (
            &["synth", "--z-first-um", "0", "--slices"][..],
            "from 3 to 100000",
            Some("100001"),
        ),
        (&["stats", "--min-pixels"][..], ">= 3", None),
        (&["segment", "m.x3p", "--min-pixels"][..], ">= 3", None),
        (
            &["topo", "m.x3p", "--window"][..],
            "an odd whole number of pixels >= 3",
            None,
        ),
        (
            &["stats", "--pixel-normals", "--window"][..],
            "an odd whole number of pixels >= 3",
            None,
        ),
    ] {
        let flag = args.last().unwrap();
        let mut values = vec![
            "0",
            "-1",
            "1.5",
            "1e20",
            "2.",
            "many",
            "18446744073709551616",
        ];
        values.extend(above);
        if *flag == "--window" {
            values.extend(["4", "1"]);
        }
        if *flag == "--min-pixels" || *flag == "--slices" {
            values.push("2");
        }
        for v in values {
            let mut a = args.to_vec();
            a.push(v);
            let (code, out, err) = run(&a);
            assert_eq!(code, 2, "{a:?}: {err}");
            assert!(out.is_empty());
            let first = err.lines().next().unwrap();
            assert!(
                first.contains(&format!("invalid value '{v}' for '{flag} <"))
                    && first.ends_with(message),
                "{a:?}: {err}"
            );
        }
    }
}
