//! The volume model through the facade: what it returns for the CLI, checked against
//! closed forms (the coat reflection, the mass-loading conversion, the energy balance).

use flakescatter::optics::fresnel;
use flakescatter::stats::{GaussianWidth, Orientation};
use flakescatter::volume::{Amount, Diameter};
use flakescatter::{
    Coating, DetectorSet, Instrument, OrientationSource, PipelineError, VolumeSettings,
    volume_curves,
};

fn settings() -> VolumeSettings {
    VolumeSettings {
        tile_um: 300.0,
        rays: 64 * 500,
        seed: 4,
        ..VolumeSettings::default()
    }
}

#[test]
fn facade_returns_split_curves_energy_and_layer_statistics() {
    let ts: Vec<f64> = (-14..=14).map(|k| f64::from(k * 5).to_radians()).collect();
    let alpha = 1.5f64.to_radians();
    let theta_i = vec![30f64.to_radians(), 60f64.to_radians()];
    let instrument =
        Instrument::new(theta_i.clone(), DetectorSet::InPlane(ts.clone()), alpha).unwrap();
    let source = OrientationSource::Distribution(
        Orientation::gaussian(GaussianWidth::Hwhm(8f64.to_radians())).unwrap(),
    );
    let last = std::sync::Mutex::new((0, 0));
    let curves = volume_curves(
        &Coating::default(),
        &instrument,
        &settings(),
        &source,
        &|d, t| *last.lock().unwrap() = (d, t),
    )
    .unwrap();
    // Progress reaches its total (at least one piece of work per incidence).
    let (done, total) = *last.lock().unwrap();
    assert!(done == total && total >= 2, "{done} of {total}");
    assert_eq!(curves.rows.len(), theta_i.len() * ts.len());
    // 32 000 rays over the default 8 layers: 4000 each, rounded up to whole batches of
    // 64 (4032).
    assert_eq!(curves.layers.len(), 8);
    assert_eq!(curves.rays_per_layer, 4032);
    assert_eq!(curves.rays_per_incidence, 8 * 4032);
    assert!(curves.segments >= 2 * 8 * 4032);
    // 5 % aluminium by mass in a 1.2 g/cm³ binder is φ = 0.0228571 (derivation in the
    // volume crate's placement tests); placement stops within one flake's volume of it.
    let phi = curves.layer.volume_fraction;
    let v_max = std::f64::consts::PI * 24.0 * 24.0 * 1.0 / (300.0 * 300.0 * 38.0);
    assert!(phi >= 0.022_857 && phi < 0.022_858 + v_max, "φ {phi}");
    assert!(curves.layer.flakes > 100);
    for (k, row) in curves.rows.iter().enumerate() {
        let ii = k / ts.len();
        assert_eq!(row.detector, k % ts.len());
        assert_eq!(row.theta_i, theta_i[ii]);
        let parts = row.coat_brdf + row.single_bounce_brdf + row.multiple_bounce_brdf;
        assert!((row.brdf - parts).abs() <= 1e-12 * row.brdf.max(1.0));
        // The coat is R_av(θi) over the projected solid angle cos θj π sin²α, in the
        // specular detector only (5° apart, 1.5° cones).
        let specular = (ts[row.detector] + theta_i[ii]).abs() < 1e-9;
        if specular {
            let r = fresnel::air_to_coating(theta_i[ii], 1.5).r_av();
            let proj = theta_i[ii].cos() * std::f64::consts::PI * alpha.sin().powi(2);
            assert!((row.coat_brdf - r / proj).abs() < 1e-9 * row.coat_brdf);
            assert!((row.relative - 1.0).abs() < 1e-12);
        } else {
            assert_eq!(row.coat_brdf, 0.0);
        }
    }
    for (t, e) in &curves.energy {
        assert!((e.total() - 1.0).abs() < 1e-12, "θi {t}: {e:?}");
        assert!(e.escaped_multiple > 0.0 && e.escaped_single > 0.0);
    }
}

#[test]
fn facade_refuses_point_detectors_and_bad_layers() {
    let instrument = Instrument::new(vec![0.5], DetectorSet::InPlane(vec![-0.5]), 0.0).unwrap();
    let source = OrientationSource::Distribution(Orientation::flat());
    let err = volume_curves(
        &Coating::default(),
        &instrument,
        &settings(),
        &source,
        &|_, _| {},
    )
    .unwrap_err();
    assert!(matches!(err, PipelineError::Instrument(_)), "{err}");
    let instrument = Instrument::new(vec![0.5], DetectorSet::InPlane(vec![-0.5]), 0.02).unwrap();
    let bad = VolumeSettings {
        diameter: Diameter::Fixed(400.0),
        ..settings()
    };
    let err =
        volume_curves(&Coating::default(), &instrument, &bad, &source, &|_, _| {}).unwrap_err();
    assert!(err.to_string().contains("tile_um"), "{err}");
    let heavy = VolumeSettings {
        amount: Amount::VolumeFraction(0.9),
        ..settings()
    };
    let err = volume_curves(
        &Coating::default(),
        &instrument,
        &heavy,
        &source,
        &|_, _| {},
    )
    .unwrap_err();
    assert!(err.to_string().contains("loading too high"), "{err}");
}
