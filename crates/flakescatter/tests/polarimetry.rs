//! The facade's polarimetry (physics.md §11): what the CLI will show for
//! `--polarization mueller`, `--incident`, `--analyzer` — checked against the scalar
//! curves (verified elsewhere), closed forms for flat flakes and for the plane of
//! incidence, and the refusal of settings it cannot honour.

use flakescatter::optics::flake::FlakeReflectance;
use flakescatter::optics::mueller::{Analyzer, Stokes};
use flakescatter::optics::polarization::Transmission;
use flakescatter::stats::{GaussianWidth, HeightMap, Orientation};
use flakescatter::{
    Coating, DetectorSet, Instrument, OrientationSource, PipelineError, Polarimetry, Settings,
    TopoSettings, distribution_curves, distribution_mueller, topographic_curves,
    topographic_mueller,
};

fn source(hwhm_deg: f64) -> OrientationSource {
    OrientationSource::Distribution(
        Orientation::gaussian(GaussianWidth::Hwhm(hwhm_deg.to_radians())).unwrap(),
    )
}

fn instrument(aperture_deg: f64) -> Instrument {
    let mut dets: Vec<(f64, f64)> = (0..=8)
        .map(|k| (f64::from(k * 10).to_radians(), 0.0))
        .collect();
    dets.extend((0..6).map(|k| (0.6, f64::from(k) * 0.9)));
    Instrument::new(
        vec![0.0, 45f64.to_radians(), 70f64.to_radians()],
        DetectorSet::OutOfPlane(dets),
        aperture_deg.to_radians(),
    )
    .unwrap()
}

#[test]
fn unpolarised_and_s_light_read_what_the_scalar_curves_give() {
    // With no analyser, unpolarised incidence reads m00 (the default scalar curve) and
    // s incidence m00 + m01 (the scalar curve with `s`), relative values likewise.
    let coating = Coating {
        flake: FlakeReflectance::aluminium_550nm(),
        ..Coating::default()
    };
    let inst = instrument(2.0);
    let src = source(8.0);
    for (stokes, transmission) in [
        (Stokes::UNPOLARIZED, Transmission::ExactUnpolarized),
        (Stokes::S, Transmission::S),
        (Stokes::P, Transmission::P),
    ] {
        for clearcoat in [false, true] {
            let settings = Settings {
                clearcoat,
                ..Settings::default()
            };
            let pol = Polarimetry {
                incident: stokes,
                analyzer: Analyzer::None,
            };
            let mu = distribution_mueller(&coating, &inst, &settings, &src, &pol).unwrap();
            let scalar = distribution_curves(
                &coating,
                &inst,
                &Settings {
                    transmission,
                    ..settings
                },
                &src,
            )
            .unwrap();
            assert_eq!(mu.rows.len(), scalar.rows.len());
            // The detected reading as scalar curves (what the CLI writes) row by row.
            let detected = mu.detected_curves();
            assert_eq!(detected.rows.len(), scalar.rows.len());
            for ((a, b), m) in detected.rows.iter().zip(&scalar.rows).zip(&mu.rows) {
                assert_eq!((a.theta_i, a.detector), (b.theta_i, b.detector));
                assert!(
                    (a.brdf - b.brdf).abs() < 1e-10 * b.brdf.max(1e-300),
                    "{transmission:?}: {} vs {}",
                    a.brdf,
                    b.brdf
                );
                let (ra, rb) = (a.reflectance.unwrap(), b.reflectance.unwrap());
                assert!((ra - rb).abs() < 1e-10 * rb.max(1e-300), "{ra} vs {rb}");
                assert!((a.relative - b.relative).abs() < 1e-9 * b.relative.abs().max(1e-300));
                assert_eq!(a.std_err, m.detected_std_err);
                assert!(m.brdf_std_err.unwrap()[0] >= 0.0 && a.std_err.unwrap() >= 0.0);
            }
        }
    }
}

#[test]
fn the_degree_of_polarisation_of_flat_flakes_is_the_fresnel_closed_form() {
    // All flakes (nearly) flat: the specular detector sees the flat path diag(−Ts, Tp)
    // (physics.md §11), so unpolarised light leaves with S = ½(Ts² + Tp², Ts² − Tp², 0, 0):
    // DOP = |Ts² − Tp²| / (Ts² + Tp²), with Ts, Tp the air → coating transmittances.
    let n = 1.5;
    let inst = Instrument::new(
        vec![60f64.to_radians()],
        DetectorSet::InPlane(vec![-60f64.to_radians()]),
        1.5f64.to_radians(),
    )
    .unwrap();
    let mu = distribution_mueller(
        &Coating::default(),
        &inst,
        &Settings::default(),
        &source(1e-4),
        &Polarimetry::default(),
    )
    .unwrap();
    let (si, ci) = 60f64.to_radians().sin_cos();
    let ct = (1.0 - (si / n).powi(2)).sqrt();
    let ts = 1.0 - ((ci - n * ct) / (ci + n * ct)).powi(2);
    let tp = 1.0 - ((n * ci - ct) / (n * ci + ct)).powi(2);
    let want = (ts * ts - tp * tp).abs() / (ts * ts + tp * tp);
    let got = mu.rows[0].dop_unpolarized;
    assert!((got - want).abs() < 1e-9, "{got} vs {want}");
    assert!((mu.rows[0].relative - 1.0).abs() < 1e-12);
}

#[test]
fn crossed_polarisers_read_nothing_in_the_plane_and_something_out_of_it() {
    // Point detectors: in the plane of incidence s light stays s (|J_ps| = 0), so an
    // analyser passing p reads 0; out of the plane the tilted flakes turn the frame and
    // it does not.
    let inst = Instrument::new(
        vec![45f64.to_radians()],
        DetectorSet::OutOfPlane(vec![(0.5, 0.0), (0.9, std::f64::consts::PI), (0.7, 0.5)]),
        0.0,
    )
    .unwrap();
    let pol = Polarimetry {
        incident: Stokes::S,
        analyzer: Analyzer::polarizer(Stokes::P).unwrap(),
    };
    let mu = distribution_mueller(
        &Coating::default(),
        &inst,
        &Settings::default(),
        &source(15.0),
        &pol,
    )
    .unwrap();
    let m00 = |r: &flakescatter::MuellerRow| r.brdf[0];
    assert!(mu.rows[0].detected_brdf.abs() < 1e-15 * m00(&mu.rows[0]));
    assert!(mu.rows[1].detected_brdf.abs() < 1e-15 * m00(&mu.rows[1]));
    assert!(
        mu.rows[2].detected_brdf > 1e-3 * m00(&mu.rows[2]),
        "{}",
        mu.rows[2].detected_brdf
    );
    // ½(m00 + m01 − m10 − m11) by hand.
    let b = mu.rows[2].brdf;
    assert!((mu.rows[2].detected_brdf - 0.5 * (b[0] + b[1] - b[4] - b[5])).abs() < 1e-15 * b[0]);
}

#[test]
fn settings_without_a_mueller_form_are_refused() {
    for transmission in [Transmission::Paper, Transmission::S, Transmission::P] {
        let err = distribution_mueller(
            &Coating::default(),
            &instrument(1.0),
            &Settings {
                transmission,
                ..Settings::default()
            },
            &source(5.0),
            &Polarimetry::default(),
        )
        .unwrap_err();
        assert!(matches!(err, PipelineError::Polarization(_)));
        let msg = err.to_string();
        assert!(
            msg.contains(transmission.name()) && msg.contains("Stokes"),
            "{msg}"
        );
    }
}

#[test]
fn the_topographic_mueller_curves_read_the_scalar_curves() {
    // A smooth wavy map: unpolarised light with no analyser reads the scalar
    // topographic curve (m00), with the same ray counts; the DOP is within [0, 1].
    let (nx, ny) = (160, 140);
    let z: Vec<f64> = (0..nx * ny)
        .map(|i| {
            let (x, y) = ((i % nx) as f64 * 0.5, (i / nx) as f64 * 0.5);
            0.4 * (0.21 * x + 0.3).sin() + 0.3 * (0.17 * y + 0.11 * x).cos()
        })
        .collect();
    let map = HeightMap::new(nx, ny, 0.5, 0.5, z).unwrap();
    let inst = instrument(3.0);
    let (coating, settings) = (Coating::default(), Settings::default());
    let topo = TopoSettings::default();
    let (mu, totals) = topographic_mueller(
        &coating,
        &inst,
        &settings,
        &topo,
        &[&map],
        &Polarimetry::default(),
        &|_, _| {},
    )
    .unwrap();
    let (scalar, t2) =
        topographic_curves(&coating, &inst, &settings, &topo, &[&map], &|_, _| {}).unwrap();
    assert_eq!(totals.rays_traced, t2.rays_traced);
    let mut lit = 0;
    for (a, b) in mu.rows.iter().zip(&scalar.rows) {
        assert_eq!(a.rays, b.rays);
        assert!((a.detected_brdf - b.brdf).abs() <= 1e-12 * b.brdf);
        let (ra, rb) = (a.detected_reflectance.unwrap(), b.reflectance.unwrap());
        assert!((ra - rb).abs() <= 1e-12 * rb, "{ra} vs {rb}");
        // Both absent (a detector no ray reached) or equal to rounding.
        match (a.detected_std_err, b.std_err) {
            (Some(x), Some(y)) => assert!((x - y).abs() <= 1e-9 * y + 1e-18),
            (x, y) => assert!(x.is_none() && y.is_none(), "{x:?} vs {y:?}"),
        }
        if a.brdf[0] > 0.0 {
            lit += 1;
            assert!((0.0..=1.0 + 1e-12).contains(&a.dop_unpolarized));
        }
    }
    assert!(lit > 10, "{lit}");
    let err = topographic_mueller(
        &coating,
        &inst,
        &Settings {
            transmission: Transmission::Paper,
            ..settings
        },
        &topo,
        &[&map],
        &Polarimetry::default(),
        &|_, _| {},
    )
    .unwrap_err();
    assert!(matches!(err, PipelineError::Polarization(_)));
}
