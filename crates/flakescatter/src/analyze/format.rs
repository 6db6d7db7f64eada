//! How the report writes numbers: `num` for the tables (shortest round-trip exponent
//! form, empty for a non-finite value), degrees without float noise, intervals.

/// A table cell: the shortest exponent form that reads back to the same `f64`, `0`
/// for zero, empty for a non-finite value.
pub(super) fn num(x: f64) -> String {
    if !x.is_finite() {
        String::new()
    } else if x == 0.0 {
        "0".into()
    } else {
        format!("{x:e}")
    }
}

/// [`num`] of a value that may be missing (empty then).
pub(super) fn opt(x: Option<f64>) -> String {
    x.map(num).unwrap_or_default()
}

/// Degrees without float noise.
pub(super) fn deg(rad: f64) -> f64 {
    (rad.to_degrees() * 1e9).round() / 1e9 + 0.0
}

/// An interval in radians as degrees, `None` for an infinite end.
pub(super) use crate::pooled_json::ci_deg_ends as ci_deg;

/// An interval in degrees as `[lo, hi]` with two decimals, `∞` for an open end.
pub(super) fn fmt_ci(ci: (Option<f64>, Option<f64>)) -> String {
    let f = |x: Option<f64>| x.map_or_else(|| "∞".to_owned(), |v| format!("{v:.2}"));
    format!("[{}, {}]", f(ci.0), f(ci.1))
}
