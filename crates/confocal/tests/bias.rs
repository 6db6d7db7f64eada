//! Systematic peak errors of the four estimators, derived numerically, and the streaming
//! localiser against the whole-profile estimator.
//!
//! References: closed forms (argmax errors are uniform on ±Δ/2; the log-parabola is
//! exact for a Gaussian response) and an independent numpy implementation,
//! `tests/reference/bias.py`, whose output `tests/reference/bias.txt` lists the maximum
//! and rms error over 201 peak positions across one step for Gaussian and sinc² axial
//! responses of FWHM 0.5, 0.6, 0.7 µm at Δ = 0.3 µm.

use flakescatter_confocal::{
    ConfocalError, Localiser, PeakMethod, PeakOptions, SliceOrder, StackGeometry, locate_peak,
};

const DZ: f64 = 0.3;
const SINC2_HALF: f64 = 1.391_557_378_251_51;

fn response(kind: &str, u: f64, w: f64) -> f64 {
    match kind {
        "gaussian" => (-4.0 * 2f64.ln() * u * u / (w * w)).exp(),
        _ => {
            let x = 2.0 * SINC2_HALF * u / w;
            if x.abs() < 1e-8 {
                1.0
            } else {
                (x.sin() / x).powi(2)
            }
        }
    }
}

/// Max |error| and rms error (µm) of `method` over the 201 offsets of `bias.py`.
fn bias(kind: &str, w: f64, method: PeakMethod) -> (f64, f64) {
    let mut max = 0.0f64;
    let mut ss = 0.0;
    for j in 0..=200 {
        let d = -0.5 + f64::from(j) / 200.0;
        let z0 = (20.0 + d) * DZ;
        let profile: Vec<f64> = (0..40)
            .map(|k| response(kind, f64::from(k) * DZ - z0, w))
            .collect();
        let p = locate_peak(&profile, method, 0.5, 0.0).unwrap();
        let e = p.position * DZ - z0;
        max = max.max(e.abs());
        ss += e * e;
    }
    (max, (ss / 201.0).sqrt())
}

#[test]
fn estimator_bias_matches_the_numpy_reference() {
    let text = include_str!("reference/bias.txt");
    let mut rows = 0;
    for line in text.lines() {
        let f: Vec<&str> = line.split_whitespace().collect();
        let (kind, w, method) = (
            f[0],
            f[1].parse::<f64>().unwrap(),
            PeakMethod::from_name(f[2]).unwrap(),
        );
        let (max_ref, rms_ref): (f64, f64) = (f[3].parse().unwrap(), f[4].parse().unwrap());
        let (max, rms) = bias(kind, w, method);
        // The reference prints 6 decimals.
        assert!((max - max_ref).abs() < 2e-6, "{line}: max {max}");
        assert!((rms - rms_ref).abs() < 2e-6, "{line}: rms {rms}");
        rows += 1;
    }
    assert_eq!(rows, 24);
}

#[test]
fn closed_form_biases() {
    for kind in ["gaussian", "sinc2"] {
        for w in [0.5, 0.6, 0.7] {
            // Argmax: the error is −d Δ for |d| < ½, so its largest magnitude is Δ/2.
            let (max, _) = bias(kind, w, PeakMethod::Argmax);
            assert!((max - DZ / 2.0).abs() < 1e-12);
        }
        // The log-parabola through a Gaussian is exact.
        let (max, _) = bias("gaussian", 0.6, PeakMethod::Gaussian);
        assert!(max < 1e-12, "{max}");
    }
    // Default = the smallest systematic error of the four for both responses.
    for kind in ["gaussian", "sinc2"] {
        for w in [0.5, 0.6, 0.7] {
            let (g, _) = bias(kind, w, PeakMethod::default());
            for m in [
                PeakMethod::Argmax,
                PeakMethod::Parabolic,
                PeakMethod::Centroid,
            ] {
                assert!(g < bias(kind, w, m).0, "{kind} {w} {m}");
            }
        }
    }
}

fn geometry(nx: usize, ny: usize, nz: usize, order: SliceOrder) -> StackGeometry {
    StackGeometry {
        nx,
        ny,
        nz,
        dx_um: 0.2,
        dy_um: 0.2,
        dz_um: DZ,
        order,
    }
}

#[test]
fn streaming_equals_the_whole_profile() {
    // 50 pixels with peaks spread over the stack (some on the first or last slice, some
    // dim), broad enough that the window of 3 slices limits some of them.
    let (nx, ny, nz) = (10, 5, 25);
    let profiles: Vec<Vec<f64>> = (0..nx * ny)
        .map(|i| {
            let z0 = -0.2 + 7.6 * i as f64 / 49.0;
            let w = 0.4 + 0.03 * (i % 17) as f64;
            let a = if i % 11 == 3 { 0.05 } else { 1.0 };
            (0..nz)
                .map(|k| f64::from(((a * response("sinc2", k as f64 * DZ - z0, w)) + 0.01) as f32))
                .collect()
        })
        .collect();
    for method in [
        PeakMethod::Argmax,
        PeakMethod::Parabolic,
        PeakMethod::Gaussian,
        PeakMethod::Centroid,
    ] {
        for order in [SliceOrder::BottomFirst, SliceOrder::TopFirst] {
            let options = PeakOptions {
                method,
                min_signal: flakescatter_confocal::MinSignal::Level(0.1),
                half_window: 3,
                ..PeakOptions::default()
            };
            let mut loc = Localiser::new(geometry(nx, ny, nz, order), options).unwrap();
            for k in 0..nz {
                let slice: Vec<f32> = profiles.iter().map(|p| p[k] as f32).collect();
                loc.push_slice(&slice).unwrap();
            }
            let maps = loc.finish().unwrap();
            let mut valid = 0;
            for (i, p) in profiles.iter().enumerate() {
                let h = maps.height.get(i % nx, i / nx);
                // The whole-profile estimate restricted to the localiser's window.
                let whole = locate_peak(p, method, 0.5, 0.1);
                match whole {
                    Ok(peak) => {
                        let k = p
                            .iter()
                            .enumerate()
                            .fold(0, |b, (j, &v)| if v > p[b] { j } else { b });
                        let lo = k.saturating_sub(3);
                        let hi = (k + 3).min(nz - 1);
                        let windowed = locate_peak(&p[lo..=hi], method, 0.5, 0.1)
                            .map(|q| q.position + lo as f64)
                            .unwrap_or(peak.position);
                        let z = match order {
                            SliceOrder::BottomFirst => windowed * DZ,
                            SliceOrder::TopFirst => (nz as f64 - 1.0 - windowed) * DZ,
                        };
                        let h = h.unwrap_or_else(|| panic!("{method} pixel {i} invalid"));
                        assert!(
                            (h - z).abs() < 1e-12,
                            "{method} {order:?} pixel {i}: {h} vs {z}"
                        );
                        valid += 1;
                    }
                    Err(_) => assert!(h.is_none(), "{method} pixel {i}"),
                }
            }
            assert_eq!(valid, maps.report.valid);
            assert!(
                maps.report.below_signal >= 4
                    && maps.report.first_slice + maps.report.last_slice >= 2,
                "{:?}",
                maps.report
            );
        }
    }
}

#[test]
fn bad_geometry_options_and_slices() {
    let g = geometry(2, 2, 5, SliceOrder::BottomFirst);
    let ok = PeakOptions::default();
    assert_eq!(
        Localiser::new(StackGeometry { nz: 2, ..g }, ok).unwrap_err(),
        ConfocalError::TooFewSlices { nz: 2 }
    );
    for (bad, name) in [
        (StackGeometry { dz_um: 0.0, ..g }, "dz_um"),
        (
            StackGeometry {
                dx_um: f64::NAN,
                ..g
            },
            "dx_um",
        ),
    ] {
        let e = Localiser::new(bad, ok).unwrap_err().to_string();
        assert!(e.starts_with(name), "{e}");
    }
    for (bad, name) in [
        (
            PeakOptions {
                fraction: 0.0,
                ..ok
            },
            "fraction",
        ),
        (
            PeakOptions {
                half_window: 0,
                ..ok
            },
            "half_window",
        ),
        (
            PeakOptions {
                min_signal: flakescatter_confocal::MinSignal::Level(f64::NAN),
                ..ok
            },
            "min_signal",
        ),
    ] {
        let e = Localiser::new(g, bad).unwrap_err().to_string();
        assert!(e.starts_with(name), "{e}");
    }
    assert!(matches!(
        Localiser::new(
            StackGeometry {
                nx: 1 << 14,
                ny: 1 << 14,
                ..g
            },
            ok
        ),
        Err(ConfocalError::TooLarge { .. })
    ));
    let mut loc = Localiser::new(g, ok).unwrap();
    assert_eq!(
        loc.push_slice(&[0.0; 3]).unwrap_err().to_string(),
        "slice 0 (0-based) has 3 samples, expected nx * ny = 4"
    );
    for _ in 0..5 {
        loc.push_slice(&[0.5; 4]).unwrap();
    }
    assert_eq!(
        loc.push_slice(&[0.5; 4]).unwrap_err(),
        ConfocalError::TooManySlices { nz: 5 }
    );
    let mut short = Localiser::new(g, ok).unwrap();
    short.push_slice(&[0.5; 4]).unwrap();
    assert_eq!(
        short.finish().unwrap_err(),
        ConfocalError::MissingSlices {
            expected: 5,
            found: 1
        }
    );
}
