//! Colour channels with a band (physics.md §12.7, "Channels with a band").
//!
//! * The band's weights: a Gaussian of the given full width at half maximum about the
//!   channel's wavelength (its value at ±FWHM/2 is half the centre's), nodes every 5 nm
//!   out to one width on each side and inside 380–780 nm, summing to 1.
//! * At normal incidence and normal exit the flakes that reflect are the level ones:
//!   the flake term of a banded stack paint over a perfect-conductor paint's is the
//!   band's weighted mean of Airy's single-layer reflectance, both written here (the
//!   Gaussian from its definition, Airy in closed form), for the named channels; a
//!   channel named by its wavelength stays monochromatic.
//! * The band smooths the angular colour travel of a thick film: the flake term's
//!   relative change between two tilts is smaller with a band than at one wavelength.
//! * Bad widths and flakes that are not a stack are refused.

use flakescatter_optics::Vec3;
use flakescatter_optics::catalogue::Catalogue;
use flakescatter_optics::nalgebra::Complex;
use flakescatter_optics::stack_spec::StackSpec;
use flakescatter_paint::metal::{BAND_STEP_NM, channel_band};
use flakescatter_paint::{Channel, ChannelParams, CoatParams, FlakeMetal, PaintModel, PaintParams};
use flakescatter_stats::Orientation;

fn stack(text: &str) -> FlakeMetal {
    FlakeMetal::stack(StackSpec::parse(text, &Catalogue::builtin()).unwrap(), None)
}

fn paint(metal: FlakeMetal, channels: &[&str]) -> PaintParams {
    PaintParams {
        coat: CoatParams::flat(1.5),
        orientation: Orientation::trowbridge_reitz(0.1).unwrap(),
        coverage: 0.6,
        flake_metal: metal,
        channels: channels
            .iter()
            .map(|c| ChannelParams {
                channel: Channel::parse(c).unwrap(),
                flake_scale: 1.0,
                base_albedo: 0.0,
                tint: 0.0,
            })
            .collect(),
    }
}

/// Airy at normal incidence: a film of index `n1`, `d` nm, in `n0` on both sides.
fn airy(n0: f64, n1: f64, d: f64, wl: f64) -> f64 {
    let r01 = (n0 - n1) / (n0 + n1);
    let e = Complex::from_polar(1.0, 4.0 * std::f64::consts::PI * n1 * d / wl);
    let r = (Complex::new(r01, 0.0) - r01 * e) / (Complex::new(1.0, 0.0) - r01 * r01 * e);
    r.norm_sqr()
}

/// The band of the module docs, from its definition: `(λ, w)`.
fn gaussian_band(centre: f64, fwhm: f64) -> Vec<(f64, f64)> {
    let sigma = fwhm / (8.0 * 2f64.ln()).sqrt();
    let mut nodes = Vec::new();
    let mut wl = centre - (fwhm / 5.0).floor() * 5.0;
    while wl <= centre + fwhm + 1e-9 {
        if (380.0..=780.0).contains(&wl) {
            nodes.push((wl, (-0.5 * ((wl - centre) / sigma).powi(2)).exp()));
        }
        wl += 5.0;
    }
    let total: f64 = nodes.iter().map(|n| n.1).sum();
    nodes.into_iter().map(|(l, w)| (l, w / total)).collect()
}

#[test]
fn the_band_is_the_stated_gaussian() {
    assert_eq!(BAND_STEP_NM, 5.0);
    for (centre, fwhm) in [(612.0, 40.0), (547.0, 100.0), (464.0, 180.0), (400.0, 60.0)] {
        let got = channel_band(centre, fwhm);
        let want = gaussian_band(centre, fwhm);
        assert_eq!(got.len(), want.len(), "{centre} {fwhm}");
        for ((l, w), (l2, w2)) in got.iter().zip(&want) {
            assert!(
                (l - l2).abs() < 1e-9 && (w - w2).abs() < 1e-14,
                "{l} {w} vs {l2} {w2}"
            );
        }
        assert!((got.iter().map(|n| n.1).sum::<f64>() - 1.0).abs() < 1e-14);
        assert!(got.iter().all(|(l, _)| (380.0..=780.0).contains(l)));
    }
    // Half maximum at ±FWHM/2: 40 nm wide about 600, the nodes at 580 and 620.
    let b = channel_band(600.0, 40.0);
    let at = |l: f64| b.iter().find(|n| (n.0 - l).abs() < 1e-9).unwrap().1;
    assert!((at(580.0) / at(600.0) - 0.5).abs() < 1e-12);
    assert!((at(620.0) / at(600.0) - 0.5).abs() < 1e-12);
}

#[test]
fn normal_flake_term_is_the_bands_mean_of_airy() {
    let channels = ["r", "g", "b", "500nm"];
    let fwhm = 60.0;
    let film = PaintModel::new(paint(
        stack("2.6:300").with_band(Some(fwhm)).unwrap(),
        &channels,
    ))
    .unwrap();
    let mirror = PaintModel::new(paint(FlakeMetal::PerfectConductor, &channels)).unwrap();
    let (fi, mi) = (film.incidence(0.0).unwrap(), mirror.incidence(0.0).unwrap());
    let up = Vec3::new(0.0, 0.0, 1.0);
    for (k, (name, wl)) in [("r", 612.0), ("g", 547.0), ("b", 464.0), ("500nm", 500.0)]
        .into_iter()
        .enumerate()
    {
        let ratio = film.terms(&fi, &up, k).flakes / mirror.terms(&mi, &up, k).flakes;
        let want = if name.ends_with("nm") {
            airy(1.5, 2.6, 300.0, wl)
        } else {
            gaussian_band(wl, fwhm)
                .iter()
                .map(|(l, w)| w * airy(1.5, 2.6, 300.0, *l))
                .sum()
        };
        assert!(
            (ratio - want).abs() < 1e-12,
            "channel {name}: {ratio} vs the band's Airy {want}"
        );
        if !name.ends_with("nm") {
            // Not the one wavelength's: the band matters for a 300 nm film.
            assert!((want - airy(1.5, 2.6, 300.0, wl)).abs() > 1e-3, "{name}");
        }
    }
}

#[test]
fn a_band_smooths_the_colour_travel_of_a_thick_film() {
    // A thick film's reflectance at one wavelength swings with angle (a fringe every
    // λ/(2 n d cos θ)); over a band the fringes average out: the flake term's change
    // between two exit directions, relative to the perfect conductor's, shrinks.
    let ch = ["g"];
    let one = PaintModel::new(paint(stack("2.6:600"), &ch)).unwrap();
    let band =
        PaintModel::new(paint(stack("2.6:600").with_band(Some(100.0)).unwrap(), &ch)).unwrap();
    let mirror = PaintModel::new(paint(FlakeMetal::PerfectConductor, &ch)).unwrap();
    let swing = |m: &PaintModel| {
        let vals: Vec<f64> = (0..8)
            .map(|i| {
                let t = (10.0 * i as f64).to_radians();
                let (a, b) = (m.incidence(t).unwrap(), mirror.incidence(t).unwrap());
                let r = Vec3::new(t.sin(), 0.0, t.cos());
                m.terms(&a, &r, 0).flakes / mirror.terms(&b, &r, 0).flakes
            })
            .collect();
        let (lo, hi) = vals
            .iter()
            .fold((f64::MAX, 0f64), |(a, b), &v| (a.min(v), b.max(v)));
        hi - lo
    };
    let (s1, sb) = (swing(&one), swing(&band));
    assert!(
        sb < 0.5 * s1,
        "swing at one wavelength {s1}, over the band {sb}"
    );
}

#[test]
fn bad_bands_are_refused() {
    for w in [0.0, -10.0, f64::NAN, f64::INFINITY, 401.0] {
        let e = stack("2.6:300").with_band(Some(w)).unwrap_err();
        assert!(e.to_string().contains("channel band"), "{w}: {e}");
    }
    let e = FlakeMetal::Aluminium.with_band(Some(50.0)).unwrap_err();
    assert!(e.to_string().contains("interference flakes"), "{e}");
    assert_eq!(
        FlakeMetal::Aluminium.with_band(None).unwrap(),
        FlakeMetal::Aluminium
    );
}
