//! Reproducibility (seed, thread count) and typed errors on bad input.

use flakescatter_stats::distribution::{GaussianWidth, Orientation};
use flakescatter_synth::{
    DiameterDistribution, Disc, FlakeAmount, LayerParams, LayerSpec, SynthError, SyntheticLayer,
    generate, generate_from_discs,
};
use nalgebra::{Unit, Vector3};

fn spec(seed: u64) -> LayerSpec {
    let o = Orientation::gaussian(GaussianWidth::Hwhm(6f64.to_radians())).unwrap();
    let mut s = LayerSpec::new(300, 170, o, seed);
    s.roughness.rms_um = 0.05;
    s.confocal.psf_sd_um = 0.07;
    s.confocal.noise_sd_um = 0.02;
    s
}

fn bits(l: &SyntheticLayer) -> (Vec<u64>, Vec<u64>, Vec<u32>) {
    (
        l.height.heights().iter().map(|v| v.to_bits()).collect(),
        l.intensity.heights().iter().map(|v| v.to_bits()).collect(),
        l.labels.clone(),
    )
}

fn in_pool(threads: usize, s: &LayerSpec) -> SyntheticLayer {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let p = LayerParams::new(s.clone()).unwrap();
    pool.install(|| generate(&p).unwrap())
}

#[test]
fn same_seed_gives_identical_bits_whatever_the_thread_count() {
    let a = in_pool(1, &spec(99));
    let b = in_pool(2, &spec(99));
    let c = in_pool(5, &spec(99));
    assert_eq!(bits(&a), bits(&b));
    assert_eq!(bits(&a), bits(&c));
    assert_eq!(a.truth, b.truth);
    let d = in_pool(2, &spec(100));
    let (ha, ia, la) = bits(&a);
    let (hd, id, ld) = bits(&d);
    assert_ne!(ha, hd);
    assert_ne!(ia, id);
    assert_ne!(la, ld);
}

/// A change to a valid specification.
type Edit = Box<dyn Fn(&mut LayerSpec)>;

fn err(f: impl FnOnce(&mut LayerSpec)) -> SynthError {
    let mut s = spec(1);
    f(&mut s);
    LayerParams::new(s).unwrap_err()
}

fn field_of(e: &SynthError) -> &'static str {
    match e {
        SynthError::InvalidParameter { param, .. } => param.name(),
        other => panic!("expected InvalidParameter, got {other:?}"),
    }
}

#[test]
fn bad_parameters_give_typed_errors_naming_the_field() {
    assert!(matches!(
        err(|s| s.nx = 0),
        SynthError::EmptyMap { nx: 0, .. }
    ));
    assert!(matches!(
        err(|s| s.ny = 0),
        SynthError::EmptyMap { ny: 0, .. }
    ));
    assert!(matches!(
        err(|s| {
            s.nx = usize::MAX;
            s.ny = 2;
        }),
        SynthError::TooLarge { .. }
    ));
    let cases: Vec<(&str, Edit)> = vec![
        ("dx_um", Box::new(|s| s.dx_um = 0.0)),
        ("dx_um", Box::new(|s| s.dx_um = f64::NAN)),
        ("dy_um", Box::new(|s| s.dy_um = -0.1)),
        ("dy_um", Box::new(|s| s.dy_um = f64::INFINITY)),
        ("film_um", Box::new(|s| s.film_um = -1.0)),
        ("thickness_um", Box::new(|s| s.thickness_um = f64::NAN)),
        (
            "diameter_um",
            Box::new(|s| s.diameter = DiameterDistribution::Fixed(0.0)),
        ),
        (
            "diameter_mean_um",
            Box::new(|s| {
                s.diameter = DiameterDistribution::LogNormal {
                    mean_um: -16.0,
                    rel_sd: 0.25,
                }
            }),
        ),
        (
            "diameter_rel_sd",
            Box::new(|s| {
                s.diameter = DiameterDistribution::LogNormal {
                    mean_um: 16.0,
                    rel_sd: -0.1,
                }
            }),
        ),
        (
            "coverage",
            Box::new(|s| s.amount = FlakeAmount::Coverage(0.0)),
        ),
        (
            "coverage",
            Box::new(|s| s.amount = FlakeAmount::Coverage(-1.0)),
        ),
        ("count", Box::new(|s| s.amount = FlakeAmount::Count(0))),
        ("roughness_rms_um", Box::new(|s| s.roughness.rms_um = -0.1)),
        (
            "roughness_correlation_um",
            Box::new(|s| s.roughness.correlation_um = f64::NAN),
        ),
        ("psf_sd_um", Box::new(|s| s.confocal.psf_sd_um = -1.0)),
        ("z_step_um", Box::new(|s| s.confocal.z_step_um = -0.3)),
        (
            "height_noise_sd_um",
            Box::new(|s| s.confocal.noise_sd_um = f64::NAN),
        ),
        ("intensity_flake", Box::new(|s| s.intensity.flake = 1.5)),
        (
            "intensity_background",
            Box::new(|s| s.intensity.background = 0.95),
        ),
        (
            "intensity_noise_sd",
            Box::new(|s| s.intensity.noise_sd = -0.01),
        ),
    ];
    for (name, f) in cases {
        let e = err(f);
        assert_eq!(field_of(&e), name, "{e}");
        assert!(e.to_string().contains(name));
    }
}

#[test]
fn bad_discs_give_typed_errors_naming_the_disc() {
    let p = LayerParams::new(spec(1)).unwrap();
    let good = Disc {
        centre_x_um: 1.0,
        centre_y_um: 1.0,
        centre_z_um: 1.0,
        diameter_um: 4.0,
        thickness_um: 1.0,
        normal: Unit::new_normalize(Vector3::z()),
    };
    let bad = [
        Disc {
            diameter_um: 0.0,
            ..good
        },
        Disc {
            centre_x_um: f64::NAN,
            ..good
        },
        Disc {
            thickness_um: -1.0,
            ..good
        },
        Disc {
            normal: Unit::new_normalize(Vector3::new(0.0, 1.0, -0.1)),
            ..good
        },
        Disc {
            normal: Unit::new_unchecked(Vector3::new(0.0, 0.0, 2.0)),
            ..good
        },
    ];
    for b in bad {
        let e = generate_from_discs(&p, &[good, b]).unwrap_err();
        assert!(
            matches!(e, SynthError::InvalidDisc { index: 1, .. }),
            "{e:?}"
        );
    }
    assert!(generate_from_discs(&p, &[good]).is_ok());
    assert!(generate_from_discs(&p, &[]).is_ok());
}
