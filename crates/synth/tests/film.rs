//! The film rule: every flake lies inside the film; parameters where flakes cannot are
//! refused, and the few flakes that need a new draw are counted (issue 13, item 9).

use flakescatter_stats::distribution::{GaussianWidth, Orientation};
use flakescatter_synth::{
    DiameterDistribution, Disc, FlakeAmount, LayerParams, LayerSpec, MAX_REDRAWN_FRACTION,
    SynthError, generate, generate_from_discs,
};
use nalgebra::{Unit, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

fn gaussian(hwhm_deg: f64) -> Orientation {
    Orientation::gaussian(GaussianWidth::Hwhm(hwhm_deg.to_radians())).unwrap()
}

/// Half the height span of a disc tilted to normal `z` component `nz`:
/// `(t cos θ + d sin θ)/2` (the faces add `t/2 cos θ`, the rim `d/2 sin θ`).
fn half(d: f64, t: f64, nz: f64) -> f64 {
    0.5 * (t * nz + d * (1.0 - nz * nz).sqrt())
}

#[test]
fn flakes_thicker_than_the_film_are_refused() {
    // The case: `synth --film-um 0.5` with 1 µm thick flakes.
    let mut s = LayerSpec::new(64, 64, gaussian(6.0), 1);
    s.film_um = 0.5;
    let e = LayerParams::new(s).unwrap_err();
    assert_eq!(
        e,
        SynthError::FilmThinnerThanFlakes {
            film_um: 0.5,
            thickness_um: 1.0
        }
    );
    let msg = e.to_string();
    assert!(msg.contains("0.5 um") && msg.contains("1 um"), "{msg}");
    // A film exactly as thick as flat flakes: they fit (centred), nothing sticks out.
    let mut s = LayerSpec::new(64, 64, Orientation::flat(), 1);
    s.film_um = 1.0;
    s.diameter = DiameterDistribution::Fixed(8.0);
    let layer = generate(&LayerParams::new(s).unwrap()).unwrap();
    assert!(
        layer
            .truth
            .iter()
            .all(|f| (f.centre_z_um - 0.5).abs() < 1e-12)
    );
}

/// Fraction of (diameter, tilt) draws from the generator's distributions, drawn here
/// with `rand_distr` and the stats sampler, whose height span exceeds the film.
fn misfit_by_sampling(spec: &LayerSpec, draws: usize) -> f64 {
    use rand_distr::{Distribution, LogNormal};
    let mut rng = ChaCha8Rng::seed_from_u64(77);
    let DiameterDistribution::LogNormal { mean_um, rel_sd } = spec.diameter else {
        panic!("log-normal expected");
    };
    let var = (1.0 + rel_sd * rel_sd).ln();
    let ln = LogNormal::new(mean_um.ln() - 0.5 * var, var.sqrt()).unwrap();
    let mut bad = 0;
    for _ in 0..draws {
        let d = loop {
            let d: f64 = ln.sample(&mut rng);
            if (0.25 * mean_um..=3.0 * mean_um).contains(&d) {
                break d;
            }
        };
        let m = spec.orientation.sample_normal(&mut rng);
        if 2.0 * half(d, spec.thickness_um, m.z) > spec.film_um {
            bad += 1;
        }
    }
    f64::from(bad) / draws as f64
}

#[test]
fn flakes_too_large_or_too_tilted_for_the_film_are_refused() {
    // 16 µm flakes (log-normal, rel. sd 0.25) at hwhm 30° in a 10 µm film: a large share
    // is tilted too far to fit. The stated fraction agrees with sampling (2·10⁵ draws, sd
    // of the estimate ≤ 0.12 %).
    let mut s = LayerSpec::new(64, 64, gaussian(30.0), 1);
    s.film_um = 10.0;
    let sampled = misfit_by_sampling(&s, 200_000);
    let e = LayerParams::new(s).unwrap_err();
    let SynthError::FlakesDoNotFit {
        film_um, fraction, ..
    } = e
    else {
        panic!("{e:?}");
    };
    assert_eq!(film_um, 10.0);
    assert!(
        (fraction - sampled).abs() < 0.005,
        "{fraction} vs sampled {sampled}"
    );
    let msg = e.to_string();
    assert!(msg.contains("10 um film") && msg.contains("16 um"), "{msg}");
    // The defaults (38 µm film, hwhm 6°) fit: the largest 48 µm flake fits up to 51°.
    assert!(LayerParams::new(LayerSpec::new(64, 64, gaussian(6.0), 1)).is_ok());
}

#[test]
fn every_flake_lies_inside_the_film_and_the_rare_misfits_are_redrawn() {
    // A 12 µm film with 16 µm flakes at hwhm 9°: a flake of diameter d fits while
    // cos θ + d sin θ ≤ 12, so only the largest flakes at the largest tilts need a new
    // draw; sampling gives the expected share, below the 0.1 % refusal threshold. Every
    // placed flake lies inside [0, 12], and the count of redrawn flakes is consistent
    // with Binomial(N, share) (4 sd).
    let mut s = LayerSpec::new(64, 64, gaussian(9.0), 3);
    s.film_um = 12.0;
    s.amount = FlakeAmount::Count(20_000);
    let share = misfit_by_sampling(&s, 1_000_000);
    assert!(share > 1e-4 && share < MAX_REDRAWN_FRACTION, "{share}");
    let layer = generate(&LayerParams::new(s.clone()).unwrap()).unwrap();
    for f in &layer.truth {
        let h = half(f.diameter_um, 1.0, f.normal.z);
        assert!(
            f.centre_z_um - h >= -1e-9 && f.centre_z_um + h <= 12.0 + 1e-9,
            "{f:?}"
        );
        assert!((f.depth_um - (12.0 - f.centre_z_um)).abs() < 1e-12);
    }
    let n = 20_000.0;
    let (mean, sd) = (n * share, (n * share * (1.0 - share)).sqrt());
    let got = layer.redrawn_flakes as f64;
    assert!(
        (got - mean).abs() < 4.0 * sd + 1.0,
        "redrawn {got}, expected {mean} ± {sd}"
    );
    // The default layer needs no redraw.
    let default =
        generate(&LayerParams::new(LayerSpec::new(128, 128, gaussian(6.0), 3)).unwrap()).unwrap();
    assert_eq!(default.redrawn_flakes, 0);
}

#[test]
fn given_discs_must_lie_inside_the_film() {
    let params = LayerParams::new(LayerSpec::new(32, 32, gaussian(6.0), 1)).unwrap();
    let flat = |z: f64| Disc {
        centre_x_um: 2.0,
        centre_y_um: 2.0,
        centre_z_um: z,
        diameter_um: 4.0,
        thickness_um: 1.0,
        normal: Unit::new_normalize(Vector3::z()),
    };
    // Film 38 µm: a flat 1 µm disc fits with its centre in [0.5, 37.5].
    assert!(generate_from_discs(&params, &[flat(0.5), flat(37.5)]).is_ok());
    for z in [0.4, 37.6] {
        let e = generate_from_discs(&params, &[flat(1.0), flat(z)]).unwrap_err();
        assert!(
            matches!(e, SynthError::InvalidDisc { index: 1, .. }),
            "{e:?}"
        );
        assert!(e.to_string().contains("film"));
    }
}

#[test]
fn the_truth_keeps_the_digits_of_tiny_tilts() {
    // θn from atan2(|m_xy|, m_z), not acos(m_z), which cannot tell 1e-9 rad from 0.
    let params = LayerParams::new(LayerSpec::new(32, 32, gaussian(6.0), 1)).unwrap();
    let tilt = 1e-9f64;
    let disc = Disc {
        centre_x_um: 2.0,
        centre_y_um: 2.0,
        centre_z_um: 10.0,
        diameter_um: 4.0,
        thickness_um: 1.0,
        normal: Unit::new_normalize(Vector3::new(tilt.sin(), 0.0, tilt.cos())),
    };
    let layer = generate_from_discs(&params, &[disc]).unwrap();
    assert!((layer.truth[0].theta_n / tilt - 1.0).abs() < 1e-9);
}

#[test]
fn a_coverage_that_takes_too_many_flakes_is_refused() {
    // 0.01 µm flakes at coverage 1 on 4096² pixels of 0.18 µm: (737 µm)² / (π 0.01²/4)
    // ≈ 7·10⁹ flakes, far beyond the 10⁷ a count may ask for (it used to try).
    let mut s = LayerSpec::new(4096, 4096, gaussian(6.0), 1);
    s.diameter = DiameterDistribution::Fixed(0.01);
    s.thickness_um = 0.001;
    s.amount = FlakeAmount::Coverage(1.0);
    let e = LayerParams::new(s).unwrap_err();
    assert!(
        matches!(
            e,
            SynthError::InvalidParameter {
                param: flakescatter_synth::Param::Coverage,
                ..
            }
        ),
        "{e:?}"
    );
}
