//! Stokes vectors, ideal analysers and Mueller matrices of Jones matrices on arbitrary
//! numbers (any bit pattern, subnormals, infinities and NaN included): a beam is refused
//! or normalised to a physical Stokes vector, an analyser refused or given a finite row,
//! and the Mueller matrix of any Jones matrix maps a physical beam to a physical beam
//! (a non-depolarising matrix never raises the degree of polarisation above 1). Never a
//! panic, never a non-finite number from finite input.
#![no_main]

use flakescatter_optics::jones::{C64, JonesMatrix};
use flakescatter_optics::mueller::{Analyzer, Mueller, STOKES_TOL, Stokes};
use libfuzzer_sys::fuzz_target;

fn f64s(data: &[u8]) -> Vec<f64> {
    data.chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
        .collect()
}

fn degree(p: &[f64; 4]) -> f64 {
    p[1].hypot(p[2]).hypot(p[3]) / p[0]
}

fuzz_target!(|data: &[u8]| {
    let v = f64s(data);
    if v.len() < 4 {
        return;
    }
    let s = [v[0], v[1], v[2], v[3]];
    let Ok(beam) = Stokes::new(s) else {
        // Refused only for what is not a beam.
        let finite = s.iter().all(|x| x.is_finite());
        let m = s.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        assert!(
            !finite
                || !(s[0] > 0.0)
                || degree(&s.map(|x| x / m)) > 1.0 + 0.5 * STOKES_TOL,
            "{s:?} refused"
        );
        return;
    };
    let p = beam.parameters();
    assert!(p[0] == 1.0 && p.iter().all(|x| x.is_finite()), "{s:?} -> {p:?}");
    assert!(degree(&p) <= 1.0 + 1e-12 && beam.dop() <= 1.0, "{s:?} -> {p:?}");
    // Scaling by a power of two (exact for normal numbers) gives the same beam.
    if s.iter().all(|x| *x == 0.0 || (x.abs() > 1e-290 && x.abs() < 1e290)) {
        let half = Stokes::new(s.map(|x| x * 0.5)).expect("the same beam at half power");
        assert_eq!(half, beam, "{s:?}");
    }
    if let Ok(a) = Analyzer::polarizer(beam) {
        let row = a.row();
        assert!(row.iter().all(|x| x.is_finite()) && row[0] == 0.5, "{row:?}");
        let r = row[1].hypot(row[2]).hypot(row[3]);
        assert!((r - 0.5).abs() <= 1e-12, "{row:?}");
    }
    // A Jones matrix of eight further numbers, each folded into [-8, 8].
    if v.len() >= 12 {
        let c = |k: usize| {
            let x = v[k];
            if x.is_finite() { x % 8.0 } else { 0.0 }
        };
        let j = JonesMatrix([
            [C64::new(c(4), c(5)), C64::new(c(6), c(7))],
            [C64::new(c(8), c(9)), C64::new(c(10), c(11))],
        ]);
        let m = Mueller::from_jones(&j);
        let out = m.apply(&beam);
        assert!(out.iter().all(|x| x.is_finite()), "{out:?}");
        // Rounding bound: each output parameter is a sum of four products, so its
        // absolute error is a few ulp of the sum of |M_ij| (near extinction, S0' is a
        // small difference of large terms and its relative error grows accordingly).
        let size: f64 = m.to_row_major().iter().map(|x| x.abs()).sum();
        let ulp = 16.0 * f64::EPSILON * size;
        assert!(out[0] >= -ulp, "{out:?}");
        if out[0] > 0.0 && out[0] > 1e-200 {
            assert!(
                degree(&out) <= 1.0 + 1e-12 + 2.0 * ulp / out[0],
                "{j:?} {p:?} -> {out:?}"
            );
        }
    }
});
