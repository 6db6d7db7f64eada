//! Rendered confocal stacks: axial responses, the tilt factor and the noise statistics
//! against closed forms; reproducibility and bad input.
//!
//! References: `exp(−4 ln 2 u²/W²)` and `sinc²` are ½ at `u = W/2` (definition of the
//! FWHM; `sinc²(x) = ½` at `x = 1.391557…`); the tilt factor is the lens-shaped overlap
//! of two unit discs, `(2/π)(acos q − q √(1 − q²))`, evaluated here by hand at
//! `q = ½`; photon counts are Poisson, so counts have mean `g λ` and variance
//! `g² (λ + r²) + 1/12` (rounding) for gain `g`, read noise `r`.

use flakescatter_stats::distribution::{GaussianWidth, Orientation};
use flakescatter_synth::stack::tilt_factor;
use flakescatter_synth::{
    AxialResponse, BitDepth, DiameterDistribution, Disc, LayerParams, LayerSpec, Param, StackSpec,
    SynthError, SyntheticStack, generate, generate_from_discs,
};
use nalgebra::{Unit, Vector3};

#[test]
fn axial_responses_have_the_stated_width() {
    for w in [0.3, 0.6, 1.1] {
        for r in [
            AxialResponse::Gaussian { fwhm_um: w },
            AxialResponse::Sinc2 { fwhm_um: w },
        ] {
            assert_eq!(r.at(0.0), 1.0);
            assert!((r.at(0.5 * w) - 0.5).abs() < 1e-12, "{r:?}");
            assert!((r.at(-0.5 * w) - 0.5).abs() < 1e-12, "{r:?}");
            assert_eq!(r.fwhm_um(), w);
        }
        // First zero of sinc² at x = π, i.e. u = π W / (2 · 1.391557).
        let r = AxialResponse::Sinc2 { fwhm_um: w };
        assert!(r.at(std::f64::consts::PI * w / (2.0 * 1.391_557_378_251_51)) < 1e-24);
    }
}

#[test]
fn tilt_factor_is_the_pupil_overlap() {
    assert_eq!(tilt_factor(0.0, 0.8), 1.0);
    // q = sin 2θ / (2 s) = ½ for s = 1 and 2θ = 90° is excluded (θ = 45° gives 0), so
    // take s = 0.6, sin 2θ = 0.6: q = ½, acos ½ = π/3, ½ √(3/4) = √3/4:
    // T = (2/π)(π/3 − √3/4) = 2/3 − √3/(2π) = 0.391002...
    let theta = 0.5 * 0.6f64.asin();
    let expect = 2.0 / 3.0 - 3f64.sqrt() / (2.0 * std::f64::consts::PI);
    assert!((tilt_factor(theta, 0.6) - expect).abs() < 1e-14);
    // Decreasing in θ, zero once the cones no longer overlap (q ≥ 1) and past 45°.
    let s = 1.3 / 1.5;
    let mut last = 1.0;
    for d in 1..45 {
        let t = tilt_factor(f64::from(d).to_radians(), s);
        assert!(t <= last && t >= 0.0);
        last = t;
    }
    assert_eq!(tilt_factor(0.5 * 0.5f64.asin(), 0.25), 0.0);
    assert_eq!(tilt_factor(46f64.to_radians(), 1.0), 0.0);
}

/// A map fully covered by one flat disc centred at height 2 µm (tilted by `theta`).
fn flat(theta: f64, n: usize) -> (LayerParams, flakescatter_synth::SyntheticLayer) {
    let o = Orientation::gaussian(GaussianWidth::Hwhm(0.05)).unwrap();
    let mut spec = LayerSpec::new(n, n, o, 1);
    spec.confocal.z_step_um = 0.0;
    spec.intensity.flake = 0.8;
    let params = LayerParams::new(spec).unwrap();
    let normal = Unit::new_normalize(Vector3::new(theta.sin(), 0.0, theta.cos()));
    let c = 0.5 * n as f64 * 0.18;
    let disc = Disc {
        centre_x_um: c,
        centre_y_um: c,
        centre_z_um: 2.0,
        // Twice the map's diagonal: the disc covers every pixel and, tilted, still lies
        // inside the film (the generator refuses a disc poking out of it).
        diameter_um: 2.0 * (2.0 * c) * std::f64::consts::SQRT_2,
        thickness_um: 0.0,
        normal,
    };
    let layer = generate_from_discs(&params, &[disc]).unwrap();
    (params, layer)
}

#[test]
fn counts_have_poisson_and_read_noise_statistics() {
    let (params, layer) = flat(0.0, 96);
    let mut spec = StackSpec::new(0.3, 12, 0.5, 7);
    spec.photons = 1500.0;
    spec.read_noise = 6.0;
    let stack = SyntheticStack::new(&spec, &params, &layer).unwrap();
    let g = 65535.0 / 1500.0;
    for k in [4, 5, 6] {
        // Slice 5 is at 0.5 + 1.5 = 2.0 µm: in focus.
        let u = stack.slice_z_um(k) - 2.0;
        let lambda = 1500.0 * 0.8 * spec.axial.at(u);
        let counts = stack.slice(k).unwrap();
        let n = counts.len() as f64;
        let mean = counts.iter().map(|&c| f64::from(c)).sum::<f64>() / n;
        let var = counts
            .iter()
            .map(|&c| (f64::from(c) - mean).powi(2))
            .sum::<f64>()
            / (n - 1.0);
        let (m_exp, v_exp) = (g * lambda, g * g * (lambda + 36.0) + 1.0 / 12.0);
        // 9216 samples: the mean is good to sqrt(v/n) (5 sd allowed), the variance to
        // sqrt(2/n) relative (Gaussian approximation, 5 sd allowed).
        assert!(
            (mean - m_exp).abs() < 5.0 * (v_exp / n).sqrt(),
            "slice {k}: {mean} vs {m_exp}"
        );
        assert!(
            (var / v_exp - 1.0).abs() < 5.0 * (2.0 / n).sqrt(),
            "slice {k}: {var} vs {v_exp}"
        );
    }
    // A tilted flake returns T(θ) of the light: expected peak counts scale with it.
    let (p2, l2) = flat(8f64.to_radians(), 16);
    let s2 = SyntheticStack::new(&spec, &p2, &l2).unwrap();
    let peak = s2.expected_peak_counts()[0];
    assert!(
        (peak - g * 1500.0 * 0.8 * tilt_factor(8f64.to_radians(), spec.aperture_sin)).abs() < 1e-9
    );
}

#[test]
fn stacks_are_reproducible_and_bad_input_is_refused() {
    let o = Orientation::gaussian(GaussianWidth::Hwhm(6f64.to_radians())).unwrap();
    let mut ls = LayerSpec::new(48, 40, o, 3);
    ls.confocal.z_step_um = 0.0;
    ls.diameter = DiameterDistribution::Fixed(5.0);
    ls.film_um = 3.0;
    let params = LayerParams::new(ls.clone()).unwrap();
    let layer = generate(&params).unwrap();
    let mut spec = StackSpec::new(0.3, 20, -1.0, 9);
    spec.bit_depth = BitDepth::Eight;
    let stack = SyntheticStack::new(&spec, &params, &layer).unwrap();
    let a = stack.slice(7).unwrap();
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    assert_eq!(one.install(|| stack.slice(7).unwrap()), a);
    assert!(a.iter().all(|&c| c <= 255));
    assert_ne!(stack.slice(8).unwrap(), a);
    assert!(matches!(
        stack.slice(20),
        Err(SynthError::InvalidParameter {
            param: Param::Slice,
            ..
        })
    ));
    // A quantised or noisy layer is not an exact surface.
    for (z, noise, field) in [(0.3, 0.0, "z_step_um"), (0.0, 0.01, "height_noise_sd_um")] {
        let mut q = ls.clone();
        q.confocal.z_step_um = z;
        q.confocal.noise_sd_um = noise;
        let p = LayerParams::new(q).unwrap();
        let l = generate(&p).unwrap();
        let e = SyntheticStack::new(&spec, &p, &l).unwrap_err();
        assert!(
            matches!(e, SynthError::InvalidParameter { param: p, .. } if p.name() == field),
            "{e}"
        );
    }
    for (bad, field) in [
        (
            StackSpec {
                z_step_um: 0.0,
                ..spec
            },
            "stack_z_step_um",
        ),
        (StackSpec { slices: 2, ..spec }, "stack_slices"),
        (
            StackSpec {
                photons: -1.0,
                ..spec
            },
            "photons",
        ),
        (
            StackSpec {
                aperture_sin: 1.5,
                ..spec
            },
            "aperture_sin",
        ),
        (
            StackSpec {
                axial: AxialResponse::Gaussian { fwhm_um: f64::NAN },
                ..spec
            },
            "axial_fwhm_um",
        ),
    ] {
        let e = SyntheticStack::new(&bad, &params, &layer).unwrap_err();
        assert!(
            matches!(e, SynthError::InvalidParameter { param: p, .. } if p.name() == field),
            "{e}"
        );
    }
}
