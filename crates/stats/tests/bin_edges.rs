//! Histogram bin edges are the exact decimals `i × width` (issue 52, item 16): with a
//! width typed in degrees, edge `i` is the decimal `i × width` converted to radians, so
//! it reads back as `1.5`, `3`, `4.5`, never `1.5000000000000002`, `3.0000000000000004`
//! or `7.499999999999999`. The expected edges are made here from integers: `i × w`
//! hundredths written out as decimal text and parsed.

use std::f64::consts::FRAC_PI_2;

use flakescatter_stats::histogram::{AreaHistogram, bin_edges};

/// The decimal `n / 100` as text, from integers.
fn hundredths(n: i64) -> String {
    format!("{}.{:02}", n / 100, n % 100)
}

#[test]
fn edges_are_the_decimals_of_the_typed_width() {
    for w in [150, 250, 10, 70, 100, 25, 700, 4500, 33] {
        let width: f64 = hundredths(w).parse().unwrap();
        let edges = bin_edges(width.to_radians()).unwrap();
        let inner: Vec<i64> = (0..).map(|i| i * w).take_while(|&e| e < 9000).collect();
        assert_eq!(edges.len(), inner.len() + 1, "width {width}");
        for (e, n) in edges.iter().zip(&inner) {
            let want: f64 = hundredths(*n).parse().unwrap();
            assert_eq!(
                *e,
                want.to_radians(),
                "width {width}, edge {}",
                hundredths(*n)
            );
            // And back: the degrees print as the decimal.
            assert_eq!(
                flakescatter_stats::decimal::degrees_text(*e),
                format!("{want}"),
                "width {width}"
            );
        }
        assert_eq!(*edges.last().unwrap(), FRAC_PI_2);
    }
}

#[test]
fn a_tilt_on_an_edge_counts_in_the_bin_that_starts_there() {
    // θ = 3° (as typed) with 1.5° bins: bins [1.5, 3) and [3, 4.5); 3° belongs to the
    // second. i × Δθ in floating point put edge 2 above 3° (3.0000000000000004).
    let w = 1.5f64.to_radians();
    let h = AreaHistogram::new([(3f64.to_radians(), 1.0), (7.5f64.to_radians(), 1.0)], w).unwrap();
    let f = h.area_fractions();
    assert_eq!((f[1], f[2], f[4], f[5]), (0.0, 0.5, 0.0, 0.5));
}
