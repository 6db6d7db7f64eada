//! Energy balance, reproducibility for any thread count, and bad input.
//!
//! The energy balance is bookkeeping: every ray starts with weight `R_av + T_av = 1`
//! (Fresnel `R + T = 1` per channel at the entry) and each event moves weight from the
//! path to exactly one tally, so the six fractions must add up to the traced weight, 1,
//! to rounding, whatever the configuration.

use flakescatter_optics::detector::Cone;
use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_stats::{GaussianWidth, Orientation};
use flakescatter_volume::{
    Amount, Depth, Diameter, Flake, Layer, LayerParams, LayerSpec, RimRule, Substrate,
    TraceOptions, Tracer, VolumeError,
};

fn layer(seed: u64) -> Layer {
    let o = Orientation::gaussian(GaussianWidth::Hwhm(12f64.to_radians())).unwrap();
    let mut spec = LayerSpec::new(o, 150.0, seed);
    spec.film_um = 15.0;
    spec.diameter = Diameter::LogNormal {
        mean_um: 8.0,
        rel_sd: 0.25,
    };
    spec.thickness_um = 0.5;
    spec.amount = Amount::MassLoading {
        fraction: 0.1,
        binder_density_g_cm3: 1.2,
    };
    Layer::generate(&LayerParams::new(spec).unwrap()).unwrap()
}

fn cones() -> Vec<Cone> {
    let a = 2f64.to_radians();
    let mut c: Vec<Cone> = (-8..=8)
        .map(|k| Cone::in_plane(f64::from(k * 10).to_radians(), a).unwrap())
        .collect();
    c.push(Cone::out_of_plane(0.5, 1.0, a).unwrap());
    c
}

#[test]
fn energy_balance_sums_to_one_in_every_configuration() {
    let layer = layer(2);
    let angles = [0.0f64, 35.0, 70.0].map(f64::to_radians);
    let substrates = [
        Substrate::Black,
        Substrate::Specular(0.7),
        Substrate::Lambertian(0.5),
    ];
    let rims = [RimRule::Absorb, RimRule::Ignore, RimRule::Diffuse];
    let flakes = [
        FlakeReflectance::PerfectConductor,
        FlakeReflectance::aluminium_550nm(),
    ];
    let mut checked = 0;
    for (k, &substrate) in substrates.iter().enumerate() {
        for (m, &rim) in rims.iter().enumerate() {
            let n = if (k + m) % 2 == 0 { 1.5 } else { 1.0 };
            let options = TraceOptions {
                n,
                flake: flakes[(k + m) % 2].clone(),
                substrate,
                rims: rim,
                rays: 6400,
                seed: 3,
                // A short event limit in one case, so that cut-off weight is tallied.
                max_events: if k == 2 && m == 2 { 3 } else { 1000 },
                ..TraceOptions::default()
            };
            let res = Tracer::new(&layer, options)
                .unwrap()
                .run(&angles, &cones())
                .unwrap();
            for e in &res.energy {
                let total = e.total();
                assert!(
                    (total - 1.0).abs() < 1e-12,
                    "{substrate:?} {rim:?} n {n}: total {total:.17} {e:?}"
                );
                assert!((e.absorbed_other - e.absorbed_rims - e.cut_off).abs() < 1e-15);
                assert!(e.escaped_via_substrate <= e.escaped_multiple + 1e-15);
                for v in [
                    e.escaped_single,
                    e.escaped_multiple,
                    e.absorbed_substrate,
                    e.absorbed_flakes,
                    e.absorbed_rims,
                    e.cut_off,
                ] {
                    assert!(v >= 0.0);
                }
                if rim == RimRule::Ignore {
                    assert_eq!(e.absorbed_rims, 0.0);
                }
                if substrate == Substrate::Black {
                    assert_eq!(e.escaped_via_substrate, 0.0);
                }
                if flakes[(k + m) % 2].is_perfect() {
                    assert_eq!(e.absorbed_flakes, 0.0);
                }
                if k == 2 && m == 2 {
                    assert!(
                        e.cut_off > 1e-3,
                        "the event limit leaves weight: {}",
                        e.cut_off
                    );
                }
                checked += 1;
            }
        }
    }
    assert_eq!(checked, 27);
}

#[test]
fn results_are_bit_identical_for_any_thread_count() {
    let layer = layer(4);
    let options = TraceOptions {
        flake: FlakeReflectance::aluminium_550nm(),
        substrate: Substrate::Lambertian(0.3),
        rims: RimRule::Diffuse,
        rays: 20_000,
        seed: 9,
        ..TraceOptions::default()
    };
    let tracer = Tracer::new(&layer, options.clone()).unwrap();
    // Five incidences of a few chunks each: the tracer groups consecutive incidences
    // into rounds by the number of threads, which must not change a bit either.
    let angles = [20f64, 35.0, 45.0, 60.0, 75.0].map(f64::to_radians);
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| tracer.run(&angles, &cones()).unwrap())
    };
    // Inside a pool (`install`) the calling thread traces batches itself, alongside
    // the pool's other threads (none for a pool of one).
    let one = run(1);
    assert_eq!(one, run(2));
    assert_eq!(one, run(3));
    // Outside any pool (this test's own thread) the calling thread only reduces, and
    // the global pool traces (its size is RAYON_NUM_THREADS, or one per core).
    assert_eq!(one, tracer.run(&angles, &cones()).unwrap());
    // A different seed gives different numbers (the seed is used).
    let other = Tracer::new(
        &layer,
        TraceOptions {
            seed: 10,
            ..options
        },
    )
    .unwrap()
    .run(&angles, &cones())
    .unwrap();
    assert_ne!(one.energy, other.energy);
    // Requested rays are rounded up to whole batches.
    assert_eq!(one.rays_per_incidence, 20_032);
}

#[test]
fn progress_is_reported_to_completion() {
    let layer = layer(5);
    let tracer = Tracer::new(
        &layer,
        TraceOptions {
            rays: 640,
            ..TraceOptions::default()
        },
    )
    .unwrap();
    // Every call: one more piece done, of a total that does not change.
    let calls = std::sync::Mutex::new(Vec::new());
    tracer
        .run_with_progress(&[0.3, 0.6], &cones(), &|done, total| {
            calls.lock().unwrap().push((done, total));
        })
        .unwrap();
    let calls = calls.into_inner().unwrap();
    let total = calls[0].1;
    // At least one piece per incidence.
    assert!(total >= 2, "{calls:?}");
    let want: Vec<(u64, u64)> = (1..=total).map(|d| (d, total)).collect();
    assert_eq!(calls, want);
}

fn spec() -> LayerSpec {
    let mut s = LayerSpec::new(Orientation::flat(), 100.0, 1);
    s.diameter = Diameter::Fixed(10.0);
    s.film_um = 20.0;
    s.thickness_um = 1.0;
    s.amount = Amount::VolumeFraction(0.01);
    s
}

/// A change to a valid spec that makes one parameter invalid.
type Change = Box<dyn Fn(&mut LayerSpec)>;

fn param_name(r: Result<LayerParams, VolumeError>) -> &'static str {
    match r {
        Err(VolumeError::Parameter { name, .. }) => name,
        other => panic!("expected a parameter error, got {other:?}"),
    }
}

#[test]
fn bad_layer_parameters_are_named() {
    let cases: Vec<(&str, Change)> = vec![
        ("film_um", Box::new(|s| s.film_um = -1.0)),
        ("film_um", Box::new(|s| s.film_um = f64::NAN)),
        ("thickness_um", Box::new(|s| s.thickness_um = -0.5)),
        ("thickness_um", Box::new(|s| s.thickness_um = 0.0)),
        (
            "diameter_um",
            Box::new(|s| s.diameter = Diameter::Fixed(0.0)),
        ),
        (
            "diameter_um",
            Box::new(|s| {
                s.diameter = Diameter::LogNormal {
                    mean_um: -3.0,
                    rel_sd: 0.2,
                }
            }),
        ),
        (
            "diameter_rel_sd",
            Box::new(|s| {
                s.diameter = Diameter::LogNormal {
                    mean_um: 10.0,
                    rel_sd: -0.1,
                }
            }),
        ),
        (
            "volume_fraction",
            Box::new(|s| s.amount = Amount::VolumeFraction(1.2)),
        ),
        (
            "mass_loading",
            Box::new(|s| {
                s.amount = Amount::MassLoading {
                    fraction: -0.05,
                    binder_density_g_cm3: 1.2,
                }
            }),
        ),
        (
            "binder_density",
            Box::new(|s| {
                s.amount = Amount::MassLoading {
                    fraction: 0.05,
                    binder_density_g_cm3: 0.0,
                }
            }),
        ),
        (
            "depth_um",
            Box::new(|s| {
                s.depth = Depth::Uniform {
                    top_um: 5.0,
                    bottom_um: 2.0,
                }
            }),
        ),
        (
            "depth_um",
            Box::new(|s| {
                s.depth = Depth::Uniform {
                    top_um: 1.0,
                    bottom_um: 30.0,
                }
            }),
        ),
        (
            "depth_profile",
            Box::new(|s| {
                s.depth = Depth::Profile {
                    edges_um: vec![0.0, 5.0],
                    weights: vec![0.0],
                }
            }),
        ),
        (
            "depth_profile",
            Box::new(|s| {
                s.depth = Depth::Profile {
                    edges_um: vec![0.0, 5.0, 4.0],
                    weights: vec![1.0, 1.0],
                }
            }),
        ),
        ("tile_um", Box::new(|s| s.tile_um = f64::INFINITY)),
        ("max_attempts", Box::new(|s| s.max_attempts = 0)),
    ];
    for (name, change) in cases {
        let mut s = spec();
        change(&mut s);
        let err = LayerParams::new(s.clone());
        let msg = err.clone().unwrap_err().to_string();
        assert!(msg.starts_with(name), "{name}: {msg}");
        assert_eq!(param_name(err), name, "{s:?}");
    }
    // A tile smaller than a flake (10 µm + 1 µm thick).
    let mut s = spec();
    s.tile_um = 10.5;
    assert!(matches!(
        LayerParams::new(s),
        Err(VolumeError::TileTooSmall { flake_extent_um, .. }) if flake_extent_um == 11.0
    ));
    // A film thinner than a flake.
    let mut s = spec();
    s.film_um = 0.8;
    assert!(matches!(
        LayerParams::new(s),
        Err(VolumeError::FilmTooThin { .. })
    ));
    // Too many flakes for the memory guard.
    let mut s = spec();
    s.tile_um = 1e6;
    assert!(matches!(
        LayerParams::new(s),
        Err(VolumeError::TooManyFlakes { .. })
    ));
    // Centres at depth 0 cannot hold a flake inside the film.
    let mut s = spec();
    s.depth = Depth::Uniform {
        top_um: 0.0,
        bottom_um: 0.0,
    };
    let err = Layer::generate(&LayerParams::new(s).unwrap()).unwrap_err();
    assert!(matches!(err, VolumeError::DepthRange { .. }), "{err:?}");
    assert!(err.to_string().starts_with("depth_um"));
}

#[test]
fn bad_trace_options_and_geometry_are_refused() {
    let layer = Layer::generate(&LayerParams::new(spec()).unwrap()).unwrap();
    let bad = |o: TraceOptions| match Tracer::new(&layer, o.clone()) {
        Err(VolumeError::Parameter { name, .. }) => name,
        Err(e) => panic!("unexpected error {e:?}"),
        Ok(_) => panic!("accepted {o:?}"),
    };
    let d = TraceOptions::default();
    assert_eq!(
        bad(TraceOptions {
            n: 0.9,
            ..d.clone()
        }),
        "n"
    );
    assert_eq!(
        bad(TraceOptions {
            n: f64::NAN,
            ..d.clone()
        }),
        "n"
    );
    assert_eq!(
        bad(TraceOptions {
            substrate: Substrate::Specular(1.5),
            ..d.clone()
        }),
        "substrate_reflectance"
    );
    assert_eq!(
        bad(TraceOptions {
            substrate: Substrate::Lambertian(-0.1),
            ..d.clone()
        }),
        "substrate_reflectance"
    );
    assert_eq!(
        bad(TraceOptions {
            rays: 0,
            ..d.clone()
        }),
        "rays"
    );
    assert_eq!(
        bad(TraceOptions {
            max_events: 0,
            ..d.clone()
        }),
        "max_events"
    );
    assert_eq!(
        bad(TraceOptions {
            min_weight: 1.0,
            ..d.clone()
        }),
        "min_weight"
    );
    assert!(matches!(
        Tracer::new(
            &layer,
            TraceOptions {
                flake: FlakeReflectance::Complex { n: -1.0, k: 2.0 },
                ..d
            }
        ),
        Err(VolumeError::FlakeIndex(_))
    ));
    for cell in [0.0, -1.0, f64::NAN] {
        assert!(matches!(
            Tracer::with_cell(&layer, d.clone(), cell),
            Err(VolumeError::Parameter {
                name: "cell_um",
                ..
            })
        ));
    }
    assert_eq!(
        match Tracer::with_cell(
            &layer,
            TraceOptions {
                n: 0.5,
                ..d.clone()
            },
            5.0
        ) {
            Err(VolumeError::Parameter { name, .. }) => name,
            _ => "accepted",
        },
        "n"
    );
    let tracer = Tracer::new(&layer, TraceOptions { rays: 64, ..d }).unwrap();
    let cone = Cone::in_plane(-0.5, 0.02).unwrap();
    assert_eq!(
        tracer.run(&[], &[cone]).unwrap_err(),
        VolumeError::Empty("incidence angle")
    );
    assert_eq!(
        tracer.run(&[0.5], &[]).unwrap_err(),
        VolumeError::Empty("detector")
    );
    assert_eq!(
        tracer
            .run(&[std::f64::consts::FRAC_PI_2], &[cone])
            .unwrap_err(),
        VolumeError::Incidence(std::f64::consts::FRAC_PI_2)
    );
    let point = Cone::in_plane(-0.5, 0.0).unwrap();
    assert_eq!(
        tracer.run(&[0.5], &[cone, point]).unwrap_err(),
        VolumeError::PointDetector(1)
    );
    // Given flakes: outside the film, or bad sizes, are named.
    let flat = flakescatter_optics::UnitVec3::new_normalize(flakescatter_optics::Vec3::z());
    let k = Flake {
        centre: flakescatter_optics::Vec3::new(5.0, 5.0, -0.2),
        normal: flat,
        radius_um: 2.0,
        thickness_um: 1.0,
    };
    assert!(matches!(
        Layer::from_flakes(10.0, 20.0, vec![k]),
        Err(VolumeError::BadFlake { index: 0, reason }) if reason.contains("inside the film")
    ));
    let k2 = Flake {
        radius_um: -1.0,
        centre: flakescatter_optics::Vec3::new(5.0, 5.0, -5.0),
        ..k
    };
    assert!(matches!(
        Layer::from_flakes(10.0, 20.0, vec![k2]),
        Err(VolumeError::BadFlake { index: 0, .. })
    ));
    let k3 = Flake {
        centre: flakescatter_optics::Vec3::new(2.0, 2.0, -5.0),
        ..k
    };
    assert!(matches!(
        Layer::from_flakes(10.0, 4.5, vec![k3]),
        Err(VolumeError::TileTooSmall { .. })
    ));
}

/// The rays with the processor's best instruction set (`Kernels::Auto`) and with the
/// portable build alone (`Kernels::Portable`, what `FLAKESCATTER_SIMD=portable`
/// selects) give the same bits, in every substrate and rim rule and with a metal
/// flake: the path arithmetic has no fused multiply–add and the same operations in
/// the same order in every build (module docs of `trace`, "Order of work"). The
/// portable run, compiled for the baseline without any instruction chosen at run time,
/// is the reference. The tracer's kernels follow the switch: `with_kernels` sets them,
/// and `new` reads `FLAKESCATTER_SIMD` (unset or `auto` here unless CI sets
/// `portable`).
#[test]
fn portable_and_dispatched_rays_give_the_same_bits() {
    use flakescatter_volume::Kernels;
    let layer = layer(6);
    let angles = [15f64, 50.0, 72.0].map(f64::to_radians);
    let expected = match std::env::var("FLAKESCATTER_SIMD").as_deref() {
        Ok("portable") => Kernels::Portable,
        _ => Kernels::Auto,
    };
    for (substrate, rims, flake) in [
        (
            Substrate::Black,
            RimRule::Absorb,
            FlakeReflectance::PerfectConductor,
        ),
        (
            Substrate::Specular(0.6),
            RimRule::Ignore,
            FlakeReflectance::aluminium_550nm(),
        ),
        (
            Substrate::Lambertian(0.4),
            RimRule::Diffuse,
            FlakeReflectance::aluminium_550nm(),
        ),
    ] {
        let options = TraceOptions {
            substrate,
            rims,
            flake,
            rays: 8_000,
            seed: 3,
            ..TraceOptions::default()
        };
        let tracer = Tracer::new(&layer, options).unwrap();
        assert_eq!(tracer.kernels(), expected);
        let auto = tracer
            .clone()
            .with_kernels(Kernels::Auto)
            .run(&angles, &cones())
            .unwrap();
        let portable = tracer
            .with_kernels(Kernels::Portable)
            .run(&angles, &cones())
            .unwrap();
        // `Debug` of an f64 is its shortest round-trip decimal: equal text, equal bits
        // (NaN, in `relative` where the specular cone saw nothing, prints as NaN).
        assert_eq!(
            format!("{auto:?}"),
            format!("{portable:?}"),
            "{substrate:?}, {rims:?}"
        );
        assert!(auto.points.iter().any(|p| p.multiple_brdf > 0.0));
    }
}
