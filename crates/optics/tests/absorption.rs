//! The binder's path factor (physics.md §8.1) against its closed forms: Beer–Lambert
//! along the two legs of the path for flakes at one depth, and the depth average for
//! flakes spread over the film checked by direct quadrature of the one-depth factor.

use flakescatter_optics::absorption::{FlakeDepth, PathAbsorption};

#[test]
fn flakes_at_one_depth_follow_beer_lambert_on_both_legs() {
    // α = 0.2 /µm, d = 3 µm, cos θt = 0.8, cos θ2 = 0.6: the path is 3/0.8 + 3/0.6 =
    // 8.75 µm, so the factor is exp(−0.2 · 8.75) = exp(−1.75) = 0.17377394345044514.
    let a = PathAbsorption::new(0.2, FlakeDepth::At { depth_um: 3.0 }).unwrap();
    assert!((a.factor(0.8, 0.6) - 0.173_773_943_450_445_14).abs() < 1e-15);
    // Flat flake at the specular return: both legs at θt, path 2d / cos θt.
    let ct = (1.0f64 - (45f64.to_radians().sin() / 1.5).powi(2)).sqrt();
    assert!((a.factor(ct, ct) - (-0.2 * 2.0 * 3.0 / ct).exp()).abs() < 1e-15);
    // At the horizon the path is infinite.
    assert_eq!(a.factor(0.8, 0.0), 0.0);
    // Depth 0: nothing absorbed.
    let top = PathAbsorption::new(0.2, FlakeDepth::At { depth_um: 0.0 }).unwrap();
    assert_eq!(top.factor(0.8, 0.6), 1.0);
}

/// Composite Simpson rule of `f` on `[a, b]` with `n` (even) intervals.
fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    let h = (b - a) / n as f64;
    let mut s = f(a) + f(b);
    for i in 1..n {
        s += f(a + h * i as f64) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    s * h / 3.0
}

#[test]
fn uniform_depths_average_the_one_depth_factor() {
    for (alpha, film, ct, c2) in [
        (0.05, 20.0, 0.9, 0.7),
        (0.3, 20.0, 0.74, 0.95),
        (1.5, 8.0, 0.8, 0.2),
        (1e-4, 30.0, 1.0, 1.0),
    ] {
        let uniform = PathAbsorption::new(alpha, FlakeDepth::UniformInFilm { film_um: film })
            .unwrap()
            .factor(ct, c2);
        let at = |d: f64| {
            PathAbsorption::new(alpha, FlakeDepth::At { depth_um: d })
                .unwrap()
                .factor(ct, c2)
        };
        let mean = simpson(at, 0.0, film, 20_000) / film;
        assert!(
            // Simpson's error at 20 000 intervals is ~1e-12 relative for the steepest case.
            (uniform - mean).abs() < 1e-10 * mean,
            "α {alpha} T {film}: {uniform} vs quadrature {mean}"
        );
    }
    // Small x: (1 − e^−x)/x = 1 − x/2 + x²/6 − …; x = α T L = 1e-9 · 10 · 2.
    let a = PathAbsorption::new(1e-9, FlakeDepth::UniformInFilm { film_um: 10.0 }).unwrap();
    let x = 2e-8;
    // (Within a few units in the last place of a number next to 1.)
    assert!((a.factor(1.0, 1.0) - (1.0 - x / 2.0 + x * x / 6.0)).abs() < 5e-16);
}
