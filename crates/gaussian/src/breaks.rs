//! Break points for quadratures over angles that must see peaks of any width
//! (radians): the geometric ladder shared by the hemispherical totals
//! (`hemisphere`) and the base's facet averages (`base`).

/// Geometric break points `x0 · 2^k` below `hi` with `x0 = min(1e-4, scale/8)`, so that
/// peaks of any width from `scale` (or 0.1 mrad) up are seen by the first panels, plus
/// the `extra` points (bin edges of a table) inside `(0, hi)`.
pub(crate) fn scale_breaks(hi: f64, scale: f64, extra: &[f64]) -> Vec<f64> {
    let mut v: Vec<f64> = extra
        .iter()
        .copied()
        .filter(|&e| e > 0.0 && e < hi)
        .collect();
    let mut x = (scale / 8.0).clamp(1e-300, 1e-4);
    while x < hi {
        v.push(x);
        x *= 2.0;
    }
    v
}
