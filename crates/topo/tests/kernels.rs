//! The model's key runs with the processor's best kernels ([`Kernels::Auto`]: AVX-512 or
//! AVX2 where the processor has them) and with the portable code alone
//! ([`Kernels::Portable`], what `FLAKESCATTER_SIMD=portable` selects) give the same
//! bits: the scalar model's fast paths (runs of consecutive in-plane detectors, the
//! vectorised weight loop) and its general ones (paper-printed factors, the clear coat,
//! a metal flake, binder absorption, out-of-plane detectors, a cell of more than 64
//! cones), the Mueller run, the isotropic average, the normals and the pixel tilts.
//!
//! No tolerance: every kernel uses additions, multiplications, compares and selects in
//! the same order in every form, never a fused multiply–add, and the functions of the
//! standard library (`sqrt`, `atan`, `sin_cos`, …) are the same calls whatever the
//! instruction set, so the portable path may not differ by a single bit. The portable
//! runs are the independent reference here: code written lane by lane, without any
//! vector instruction chosen at run time.

use flakescatter_optics::absorption::{FlakeDepth, PathAbsorption};
use flakescatter_optics::detector::Cone;
use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_optics::polarization::{Transmission, Weighting};
use flakescatter_stats::HeightMap;
use flakescatter_stats::distribution::{GaussianWidth, Orientation};
use flakescatter_synth::{DiameterDistribution, LayerParams, LayerSpec, generate};
use flakescatter_topo::{IsotropicOptions, Kernels, TopoModel, TopoOptions};

/// A layer of 5 µm flakes (hwhm 6°, the synthetic confocal microscope's defaults) seen
/// by a map of 200 × 170 pixels of 0.25 µm.
fn flakes() -> HeightMap {
    let orientation = Orientation::gaussian(GaussianWidth::Hwhm(6f64.to_radians())).unwrap();
    let mut spec = LayerSpec::new(200, 170, orientation, 7);
    spec.dx_um = 0.25;
    spec.dy_um = 0.25;
    spec.diameter = DiameterDistribution::Fixed(5.0);
    generate(&LayerParams::new(spec).unwrap()).unwrap().height
}

/// A smooth random surface (sum of plane waves, slopes up to ~10°), `nx × ny` pixels.
fn rough(nx: usize, ny: usize, seed: u64) -> HeightMap {
    let waves: Vec<(f64, f64, f64)> = (0..8)
        .map(|k| {
            let t = (seed * 31 + k) as f64;
            (
                0.3 + 0.2 * (1.7 * t).sin(),
                0.3 + 0.2 * (2.3 * t).cos(),
                1.1 * t,
            )
        })
        .collect();
    let z = (0..nx * ny)
        .map(|i| {
            let (x, y) = ((i % nx) as f64 * 0.5, (i / nx) as f64 * 0.5);
            waves
                .iter()
                .map(|&(kx, ky, ph)| 0.06 / kx.hypot(ky) * (kx * x + ky * y + ph).sin())
                .sum()
        })
        .collect();
    HeightMap::new(nx, ny, 0.5, 0.5, z).unwrap()
}

/// The in-plane sweep of the CLI's default, −70° to 70° every 0.5°, α = 1.5°.
fn sweep() -> Vec<Cone> {
    (-140..=140)
        .map(|d| Cone::in_plane((f64::from(d) * 0.5).to_radians(), 1.5f64.to_radians()).unwrap())
        .collect()
}

/// Out-of-plane cones of 2°, and 80 wide cones of 40° about nearly the same axis,
/// whose cells list more than 64 cones (tested one by one, not by the blocks).
fn out_of_plane_and_crowded() -> Vec<Cone> {
    let mut cones: Vec<Cone> = (-40..=40)
        .step_by(4)
        .map(|d| {
            Cone::out_of_plane(
                f64::from(d).abs().to_radians(),
                f64::from(d).to_radians(),
                2f64.to_radians(),
            )
            .unwrap()
        })
        .collect();
    for k in 0..80 {
        let t = 0.2 + 0.001 * f64::from(k);
        cones.push(Cone::out_of_plane(t, 0.5, 0.7).unwrap());
    }
    cones
}

fn degrees(list: &[f64]) -> Vec<f64> {
    list.iter().map(|d| d.to_radians()).collect()
}

/// `what` with the portable kernels and with the processor's best, as their `Debug`
/// text: every `f64` is written in the shortest form that reads back to its bits, so
/// equal texts are equal bits (NaN included, which `==` would not compare).
fn both_ways<T: std::fmt::Debug>(model: &TopoModel, what: impl Fn(&TopoModel) -> T) -> [String; 2] {
    [Kernels::Auto, Kernels::Portable]
        .map(|k| format!("{:?}", what(&model.clone().with_kernels(k))))
}

/// Says which instruction set [`Kernels::Auto`] ran, so that a comparison that is
/// trivial on a processor without AVX2 is never taken for a real one.
fn note_instruction_set() {
    #[cfg(target_arch = "x86_64")]
    {
        let (v4, v3) = (
            std::arch::is_x86_feature_detected!("avx512f"),
            std::arch::is_x86_feature_detected!("avx2"),
        );
        if !v4 && !v3 {
            eprintln!(
                "note: this processor has neither AVX-512 nor AVX2: Kernels::Auto ran the portable code too, and the comparisons of tests/kernels.rs compare it with itself"
            );
        } else if !v4 {
            eprintln!(
                "note: this processor has no AVX-512: Kernels::Auto ran AVX2, and the AVX-512 kernels were not compared"
            );
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    eprintln!(
        "note: not x86-64: Kernels::Auto runs the portable code, the comparisons are trivial"
    );
}

#[test]
fn plain_runs_are_the_same_bits_with_the_portable_kernels() {
    note_instruction_set();
    let maps = [flakes(), rough(150, 130, 1)];
    let refs: Vec<&HeightMap> = maps.iter().collect();
    let ti = degrees(&[0.0, 30.0, 45.0, 60.0, 75.0]);
    let metal = FlakeReflectance::aluminium_550nm();
    let cases: Vec<(&str, TopoOptions, Vec<Cone>)> = vec![
        ("default, in-plane sweep", TopoOptions::default(), sweep()),
        (
            "paper, paper-printed, clear coat",
            TopoOptions {
                transmission: Transmission::Paper,
                weighting: Weighting::PaperPrinted,
                clearcoat: true,
                ..TopoOptions::default()
            },
            sweep(),
        ),
        (
            "s, metal flake, window 7, out of plane and crowded",
            TopoOptions {
                transmission: Transmission::S,
                flake: metal,
                window: 7,
                ..TopoOptions::default()
            },
            out_of_plane_and_crowded(),
        ),
    ];
    let mut rays = 0;
    for (name, options, cones) in &cases {
        let model = TopoModel::new(options.clone())
            .unwrap()
            .with_block_um(12.0)
            .unwrap();
        let [auto, portable] = both_ways(&model, |m| m.run(&refs, &ti, cones).unwrap());
        assert_eq!(auto, portable, "{name}");
        rays += model
            .run(&refs, &ti, cones)
            .unwrap()
            .points
            .iter()
            .map(|p| p.rays)
            .sum::<u64>();
    }
    // Binder absorption multiplies every ray's weight.
    let absorbing = TopoModel::new(TopoOptions::default())
        .unwrap()
        .with_absorption(
            PathAbsorption::new(0.05, FlakeDepth::UniformInFilm { film_um: 20.0 }).unwrap(),
        );
    let [auto, portable] = both_ways(&absorbing, |m| m.run(&refs, &ti, &sweep()).unwrap());
    assert_eq!(auto, portable, "absorption");
    // The comparison must have counted many rays, or it proves nothing.
    assert!(rays > 100_000, "{rays} rays counted");
}

#[test]
fn mueller_isotropic_normals_and_tilts_are_the_same_bits_with_the_portable_kernels() {
    note_instruction_set();
    let maps = [flakes(), rough(120, 110, 2)];
    let refs: Vec<&HeightMap> = maps.iter().collect();
    let ti = degrees(&[10.0, 45.0, 70.0]);
    let model = TopoModel::new(TopoOptions::default())
        .unwrap()
        .with_block_um(12.0)
        .unwrap();
    // An analyser row that mixes every element.
    let readout = [
        1.0, 0.3, -0.2, 0.1, 0.3, 0.09, -0.06, 0.03, -0.2, -0.06, 0.04, -0.02, 0.1, 0.03, -0.02,
        0.01,
    ];
    let cones = out_of_plane_and_crowded();
    let [auto, portable] = both_ways(&model, |m| {
        m.run_mueller(&refs, &ti, &cones, &readout, &|_, _| {})
            .unwrap()
    });
    assert_eq!(auto, portable, "Mueller");

    let coarse = IsotropicOptions {
        node_spacing: Some(0.004),
    };
    for options in [
        TopoOptions::default(),
        TopoOptions {
            weighting: Weighting::PaperPrinted,
            flake: FlakeReflectance::aluminium_550nm(),
            clearcoat: true,
            ..TopoOptions::default()
        },
    ] {
        let model = TopoModel::new(options.clone())
            .unwrap()
            .with_block_um(12.0)
            .unwrap();
        let [auto, portable] = both_ways(&model, |m| {
            m.run_isotropic_with(&refs, &ti, &sweep(), &coarse, &|_, _| {})
                .unwrap()
        });
        assert_eq!(auto, portable, "isotropic, {options:?}");
    }

    for map in &maps {
        let [auto, portable] = both_ways(&model, |m| m.normals(map).unwrap());
        assert_eq!(auto, portable, "normals");
    }
    let [auto, portable] = both_ways(&model, |m| {
        m.pixel_tilts(&refs, 0.2f64.to_radians()).unwrap()
    });
    assert_eq!(auto, portable, "pixel tilts");
}

/// `TopoModel::new` takes its kernels from `FLAKESCATTER_SIMD`: `.ci/run` runs these
/// tests once more with `FLAKESCATTER_SIMD=portable`, and this test fails there if the
/// switch were not honoured.
#[test]
fn new_models_take_their_kernels_from_the_environment() {
    let model = TopoModel::new(TopoOptions::default()).unwrap();
    let want = match std::env::var(Kernels::ENV).as_deref() {
        Err(std::env::VarError::NotPresent) | Ok("" | "auto") => Kernels::Auto,
        Ok("portable") => Kernels::Portable,
        other => panic!(
            "the tests were run with {}={other:?}, which the models refuse",
            Kernels::ENV
        ),
    };
    assert_eq!(model.kernels(), want);
    assert_eq!(Kernels::from_env(), Ok(want));
    // with_kernels overrides the environment either way.
    for k in [Kernels::Auto, Kernels::Portable] {
        assert_eq!(model.clone().with_kernels(k).kernels(), k);
    }
}
