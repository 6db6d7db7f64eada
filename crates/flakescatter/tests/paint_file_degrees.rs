//! A paint parameter file gives its angles as the degrees they were typed as (issue 52,
//! item 16, the parameter-file sibling of the histogram edges): a histogram on 1.5° bins
//! has `edges_deg` 0, 1.5, 3, 4.5, … and a Gaussian of hwhm 3.3° says 3.3, never
//! `4.499999999999999` or `3.3000000000000003`. Expected values are decimals made here
//! from integers (`k × w` hundredths as text, parsed).

use flakescatter::paint::file::{OrientationSection, orientation_section};
use flakescatter::stats::{GaussianWidth, Orientation};

fn hundredths(n: i64) -> f64 {
    format!("{}.{:02}", n / 100, n % 100).parse().unwrap()
}

#[test]
fn histogram_edges_and_widths_read_back_as_typed() {
    for w in [10, 15, 25, 30, 70, 150, 330] {
        let typed: Vec<f64> = (0..=20).map(|k| hundredths(k * w)).collect();
        let edges = typed.iter().map(|d| d.to_radians()).collect();
        let o = Orientation::tabulated(edges, vec![1.0; 20]).unwrap();
        match orientation_section(&o) {
            OrientationSection::Histogram { edges_deg, .. } => {
                assert_eq!(edges_deg, typed, "width {}", hundredths(w));
            }
            other => panic!("{other:?}"),
        }
    }
    for h in (1..=400).map(|k| hundredths(k * 10)) {
        let o = Orientation::gaussian(GaussianWidth::Hwhm(h.to_radians())).unwrap();
        match orientation_section(&o) {
            OrientationSection::Gaussian { hwhm_deg } => assert_eq!(hwhm_deg, h),
            other => panic!("{other:?}"),
        }
    }
}
