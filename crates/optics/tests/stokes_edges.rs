//! Stokes vectors at the edges of the doubles (issue 52, item 10) and the rounding
//! tolerance on the degree of polarisation (item 23). A Stokes vector and any positive
//! multiple of it describe the same state of polarisation (the multiple is the power),
//! so every scaled copy must give the normalised vector of the unscaled one; expected
//! values are the unscaled vectors' normalised forms, written out.

use flakescatter_optics::OpticsError;
use flakescatter_optics::mueller::{Analyzer, Mueller, STOKES_TOL, Stokes};
use flakescatter_optics::stokes::dop_text;

#[test]
fn subnormal_and_huge_vectors_are_the_states_of_their_unscaled_copies() {
    // (scaled, the normalised state it is).
    let cases: [([f64; 4], [f64; 4]); 8] = [
        ([1e-310, 1e-310, 0.0, 0.0], [1.0, 1.0, 0.0, 0.0]),
        ([1e200, 1e200, 0.0, 0.0], [1.0, 1.0, 0.0, 0.0]),
        ([f64::MAX, f64::MAX, 0.0, 0.0], [1.0, 1.0, 0.0, 0.0]),
        ([5e-324, -5e-324, 0.0, 0.0], [1.0, -1.0, 0.0, 0.0]),
        ([4e-320, 0.0, 0.0, 4e-320], [1.0, 0.0, 0.0, 1.0]),
        ([2e300, 0.0, 2e300, 0.0], [1.0, 0.0, 1.0, 0.0]),
        // Partly polarised, huge: DoP 0.5 along S1.
        ([1e300, 5e299, 0.0, 0.0], [1.0, 0.5, 0.0, 0.0]),
        // Unpolarised, subnormal.
        ([1e-315, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]),
    ];
    for (s, want) in cases {
        let got = Stokes::new(s)
            .unwrap_or_else(|e| panic!("{s:?}: {e}"))
            .parameters();
        for k in 0..4 {
            assert!(
                (got[k] - want[k]).abs() <= 1e-15,
                "{s:?}: {got:?} vs {want:?}"
            );
        }
    }
    assert_eq!(Stokes::new([1e-310, 1e-310, 0.0, 0.0]).unwrap(), Stokes::S);
    assert_eq!(Stokes::new([1e200, 1e200, 0.0, 0.0]).unwrap(), Stokes::S);
    // What a detector reads does not depend on the scale: the identity passes S0 = 1.
    let id = Mueller::identity();
    let huge = Stokes::new([1e200, 1e200, 0.0, 0.0]).unwrap();
    let tiny = Stokes::new([1e-310, 1e-310, 0.0, 0.0]).unwrap();
    let p = Analyzer::polarizer(Stokes::S).unwrap();
    assert_eq!(id.detected(&huge, &p), 1.0);
    assert_eq!(id.detected(&tiny, &p), 1.0);
    // A subnormal analyser state is an s polariser too: row ½(1, 1, 0, 0).
    let a = Analyzer::polarizer(tiny).unwrap();
    assert_eq!(a.row(), [0.5, 0.5, 0.0, 0.0]);
}

#[test]
fn only_what_cannot_be_normalised_is_refused() {
    for s in [
        [0.0, 0.0, 0.0, 0.0],
        [-1e-310, 0.0, 0.0, 0.0],
        [f64::INFINITY, 1.0, 0.0, 0.0],
        [1.0, f64::NAN, 0.0, 0.0],
    ] {
        assert!(
            matches!(Stokes::new(s), Err(OpticsError::InvalidStokes { .. })),
            "{s:?}"
        );
    }
    // Huge S1 beside a subnormal S0: DoP far above 1 (it overflows), still named.
    let e = Stokes::new([1e-310, 1e300, 0.0, 0.0]).unwrap_err();
    assert!(
        matches!(e, OpticsError::OverPolarizedStokes { .. }),
        "{e:?}"
    );
    assert!(e.to_string().contains("infinite"), "{e}");
}

#[test]
fn the_degree_of_polarisation_has_a_stated_rounding_tolerance() {
    assert_eq!(STOKES_TOL, 1e-9);
    // 1 + 1e-8: beyond the tolerance, refused with the digits that differ from 1.
    let e = Stokes::new([1.0, 1.0 + 1e-8, 0.0, 0.0]).unwrap_err();
    let text = e.to_string();
    assert!(
        text.contains("is 1.00000001") && text.contains("(1 + 1.0e-8), above 1"),
        "{text}"
    );
    assert!(!text.contains("1.000000 >"), "{text}");
    // 1 + 1e-10: within it, accepted as fully polarised with DoP exactly 1 (to
    // rounding), and usable as an analyser.
    let s = Stokes::new([1.0, 1.0 + 1e-10, 0.0, 0.0]).unwrap();
    assert!((s.dop() - 1.0).abs() <= 2.0 * f64::EPSILON, "{}", s.dop());
    assert!(s.parameters()[1] <= 1.0 + 2.0 * f64::EPSILON);
    assert!(Analyzer::polarizer(s).is_ok());
    // Elliptical, 1/√2 typed to 10 digits: DoP 1 + 1.9e-11, a polariser. (The typed
    // approximation is the point of the test.)
    #[allow(clippy::approx_constant)]
    let typed = Stokes::new([1.0, 0.0, 0.707_106_781_2, 0.707_106_781_2]).unwrap();
    assert!(Analyzer::polarizer(typed).is_ok());
    // 1 − 1e-8: a beam, but not an ideal polariser; the message shows the digits.
    let partly = Stokes::new([1.0, 1.0 - 1e-8, 0.0, 0.0]).unwrap();
    let e = Analyzer::polarizer(partly).unwrap_err();
    assert!(matches!(e, OpticsError::NotFullyPolarized { .. }));
    let text = e.to_string();
    assert!(
        text.contains("0.99999999") && text.contains("(1 - 1.0e-8)"),
        "{text}"
    );
    assert_eq!(dop_text(2.0), "2");
    assert_eq!(dop_text(0.5), "0.5");
    assert_eq!(dop_text(1.0), "1");
}
