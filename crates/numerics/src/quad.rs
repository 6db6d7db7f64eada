//! Quadrature rules: Gauss–Kronrod 15 (with its embedded Gauss 7) and an adaptive
//! integrator built on it, for any [`QuadValue`] (a number, or the 16 elements of a
//! Mueller matrix integrated on the same nodes).
//!
//! Nodes and weights are those of QUADPACK's `qk15` (Piessens et al. 1983).

/// A value the rules can integrate: `f64`, or a fixed-size vector of numbers integrated
/// element by element on the same nodes.
pub trait QuadValue: Copy {
    /// The zero value.
    fn zero() -> Self;
    /// `self + other`.
    #[must_use]
    fn plus(self, other: Self) -> Self;
    /// `self · k`.
    #[must_use]
    fn times(self, k: f64) -> Self;
    /// The size that relative tolerances refer to (`|x|` for a number).
    fn size(&self) -> f64;
    /// The distance between two estimates, the unit of error estimates (`|x − y|` for
    /// a number; the largest element difference for a vector).
    fn distance(&self, other: &Self) -> f64;
    /// The integrand's value at the mirror image `y → −y` of a direction, given its
    /// value there (the integrands are mirror-symmetric problems: isotropic flakes, the
    /// incidence in the xz-plane). A number is its own mirror image; a Mueller matrix in
    /// the `(s, p)` bases becomes `D M D`, `D = diag(1, 1, −1, −1)`.
    #[must_use]
    fn mirrored(self) -> Self;
    /// Whether the value is expressed in a polarisation basis chosen per direction (a
    /// Mueller matrix is, a number is not): the mirror symmetry `y → −y` then holds
    /// only when the mirror maps that basis onto itself (up to sign), which the caller
    /// must check before using [`QuadValue::mirrored`].
    const BASIS_DEPENDENT: bool = false;
    /// Runs `f` with an empty vector of values to fill: for `f64` one kept per thread
    /// and reused from call to call (a curve fills one for each of thousands of
    /// cones), otherwise a new one.
    fn with_values<R>(f: impl FnOnce(&mut Vec<Self>) -> R) -> R {
        f(&mut Vec::new())
    }
}

thread_local! {
    static F64_VALUES: std::cell::RefCell<Vec<f64>> = const { std::cell::RefCell::new(Vec::new()) };
}

impl QuadValue for f64 {
    #[inline]
    fn zero() -> Self {
        0.0
    }
    #[inline]
    fn plus(self, other: Self) -> Self {
        self + other
    }
    #[inline]
    fn times(self, k: f64) -> Self {
        self * k
    }
    #[inline]
    fn size(&self) -> f64 {
        self.abs()
    }
    #[inline]
    fn distance(&self, other: &Self) -> f64 {
        (self - other).abs()
    }
    #[inline]
    fn mirrored(self) -> Self {
        self
    }
    fn with_values<R>(f: impl FnOnce(&mut Vec<Self>) -> R) -> R {
        // Taken out for the call (a nested call finds it empty and allocates), put back
        // after.
        let mut values = F64_VALUES.with_borrow_mut(std::mem::take);
        values.clear();
        let result = f(&mut values);
        F64_VALUES.with_borrow_mut(|v| *v = values);
        result
    }
}

/// The sum of the values of an iterator.
fn total<V: QuadValue>(values: impl Iterator<Item = V>) -> V {
    values.fold(V::zero(), V::plus)
}

/// Positive Kronrod abscissae on `[-1, 1]`, largest first; the last is 0.
const XGK: [f64; 8] = [
    0.991_455_371_120_812_6,
    0.949_107_912_342_758_5,
    0.864_864_423_359_769_1,
    0.741_531_185_599_394_4,
    0.586_087_235_467_691_1,
    0.405_845_151_377_397_2,
    0.207_784_955_007_898_5,
    0.0,
];

/// Kronrod weights matching [`XGK`].
const WGK: [f64; 8] = [
    0.022_935_322_010_529_22,
    0.063_092_092_629_978_55,
    0.104_790_010_322_250_18,
    0.140_653_259_715_525_92,
    0.169_004_726_639_267_9,
    0.190_350_578_064_785_4,
    0.204_432_940_075_298_9,
    0.209_482_141_084_727_83,
];

/// Gauss-7 weights for the abscissae `XGK[1], XGK[3], XGK[5], XGK[7]`.
const WG: [f64; 4] = [
    0.129_484_966_168_869_7,
    0.279_705_391_489_276_7,
    0.381_830_050_505_118_9,
    0.417_959_183_673_469_4,
];

/// Gauss–Kronrod 7 abscissae on `[0, 1]` (positive half), largest first; the Gauss-3
/// rule uses `XGK7[1]` and `XGK7[3]`.
const XGK7: [f64; 4] = [
    0.960_491_268_708_020_3,
    0.774_596_669_241_483_4,
    0.434_243_749_346_802_6,
    0.0,
];

/// Kronrod-7 weights matching [`XGK7`].
const WGK7: [f64; 4] = [
    0.104_656_226_026_467_27,
    0.268_488_089_868_333_44,
    0.401_397_414_775_962_2,
    0.450_916_538_658_474_14,
];

/// Gauss-3 weights for `XGK7[1]` (5/9) and `XGK7[3]` (8/9).
const WG3: [f64; 2] = [5.0 / 9.0, 8.0 / 9.0];

/// The 7 Kronrod nodes mapped to `[a, b]` with their Kronrod and Gauss-3 weights.
#[must_use]
pub fn gk7_nodes(a: f64, b: f64) -> [(f64, f64, f64); 7] {
    mapped(&XGK7, &WGK7, &WG3, a, b)
}

/// The 15 Kronrod nodes mapped to `[a, b]` with their Kronrod and Gauss weights
/// (Gauss weight 0 for nodes that belong only to the Kronrod rule).
#[must_use]
pub fn gk15_nodes(a: f64, b: f64) -> [(f64, f64, f64); 15] {
    mapped(&XGK, &WGK, &WG, a, b)
}

/// A Gauss–Kronrod rule's `N = 2 xs.len() − 1` nodes mapped to `[a, b]`, from its
/// non-negative abscissae `xs` on [−1, 1] (largest first, the centre last) with Kronrod
/// weights `wk` and Gauss weights `wg` of the odd-indexed abscissae; the pair of `xs[j]`
/// lands at `2j, 2j + 1`, the centre at `N − 1`.
fn mapped<const N: usize>(
    xs: &[f64],
    wk: &[f64],
    wg: &[f64],
    a: f64,
    b: f64,
) -> [(f64, f64, f64); N] {
    debug_assert_eq!(2 * xs.len() - 1, N);
    let c = 0.5 * (a + b);
    let h = 0.5 * (b - a);
    let centre = xs.len() - 1;
    let mut out = [(0.0, 0.0, 0.0); N];
    for (j, (&x, &k)) in xs.iter().zip(wk).enumerate() {
        let g = if j % 2 == 1 { wg[j / 2] } else { 0.0 };
        if j == centre {
            out[N - 1] = (c, k * h, g * h);
        } else {
            out[2 * j] = (c - h * x, k * h, g * h);
            out[2 * j + 1] = (c + h * x, k * h, g * h);
        }
    }
    out
}

/// One GK15 panel: `(kronrod, distance(kronrod, gauss))`.
pub fn gk15<V: QuadValue, F: FnMut(f64) -> V>(f: &mut F, a: f64, b: f64) -> (V, f64) {
    let mut k = V::zero();
    let mut g = V::zero();
    for (x, wk, wg) in gk15_nodes(a, b) {
        let y = f(x);
        k = k.plus(y.times(wk));
        g = g.plus(y.times(wg));
    }
    (k, k.distance(&g))
}

/// Adaptive GK15 over `[a, b]` split first at `breaks` (any order; points outside
/// `(a, b)` are ignored). Panels are bisected, largest error first, until the summed
/// error estimate is below `max(abs_tol, rel_tol·|I|)` or `max_panels` is reached.
/// Returns `(integral, error estimate)`; for a vector value the tolerance refers to
/// [`QuadValue::size`] and the error to [`QuadValue::distance`]. A panel too small to
/// split is accepted as it is (its error counted as 0) and refinement goes on.
pub fn adaptive<V: QuadValue, F: FnMut(f64) -> V>(
    mut f: F,
    a: f64,
    b: f64,
    breaks: &[f64],
    abs_tol: f64,
    rel_tol: f64,
    max_panels: usize,
) -> (V, f64) {
    let tol = Tolerance {
        abs: abs_tol,
        rel: rel_tol,
        max_panels,
    };
    refine(
        |lo, hi| gk15(&mut f, lo, hi),
        a,
        b,
        breaks,
        tol,
        TooSmall::Accept,
    )
}

/// As [`adaptive`] for an integrand that returns `(value, absolute error of the value)`
/// (an inner integral with its own error estimate): a panel's error is the Kronrod–Gauss
/// difference plus the Kronrod-weighted integral of the inner errors, so the returned
/// estimate bounds both levels. Returns `(integral, error estimate)`. A panel too small
/// to split ends the refinement, its error kept in the estimate.
pub fn adaptive_nested<V: QuadValue, F: FnMut(f64) -> (V, f64)>(
    mut f: F,
    a: f64,
    b: f64,
    breaks: &[f64],
    abs_tol: f64,
    rel_tol: f64,
    max_panels: usize,
) -> (V, f64) {
    let panel = |lo: f64, hi: f64| {
        let (mut k, mut g, mut inner) = (V::zero(), V::zero(), 0.0);
        for (x, wk, wg) in gk15_nodes(lo, hi) {
            let (y, e) = f(x);
            k = k.plus(y.times(wk));
            g = g.plus(y.times(wg));
            inner += wk * e.abs();
        }
        (k, k.distance(&g) + inner)
    };
    let tol = Tolerance {
        abs: abs_tol,
        rel: rel_tol,
        max_panels,
    };
    refine(panel, a, b, breaks, tol, TooSmall::Stop)
}

/// When [`refine`] stops.
#[derive(Debug, Clone, Copy)]
struct Tolerance {
    abs: f64,
    rel: f64,
    max_panels: usize,
}

/// What [`refine`] does with the worst panel when its midpoint is one of its ends.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum TooSmall {
    /// Keep its value with an error of 0 and go on with the others.
    Accept,
    /// Stop: the estimate keeps this panel's error.
    Stop,
}

/// The adaptive loop of [`adaptive`] and [`adaptive_nested`]: `panel(lo, hi)` gives a
/// panel's `(value, error estimate)`; the initial panels are `[a, b]` cut at `breaks`;
/// the panel of largest error is bisected until the summed error is below
/// `max(abs, rel·|I|)` or there are `max_panels` panels.
fn refine<V: QuadValue>(
    mut panel: impl FnMut(f64, f64) -> (V, f64),
    a: f64,
    b: f64,
    breaks: &[f64],
    tol: Tolerance,
    too_small: TooSmall,
) -> (V, f64) {
    if b <= a {
        return (V::zero(), 0.0);
    }
    let mut pts: Vec<f64> = breaks.iter().copied().filter(|&x| x > a && x < b).collect();
    pts.push(a);
    pts.push(b);
    pts.sort_by(f64::total_cmp);
    pts.dedup();
    let mut panels: Vec<(f64, f64, V, f64)> = pts
        .windows(2)
        .map(|w| {
            let (v, e) = panel(w[0], w[1]);
            (w[0], w[1], v, e)
        })
        .collect();
    loop {
        let total = total(panels.iter().map(|p| p.2));
        let err: f64 = panels.iter().map(|p| p.3).sum();
        if err <= tol.abs.max(tol.rel * total.size()) || panels.len() >= tol.max_panels {
            return (total, err);
        }
        let (worst, _) = panels
            .iter()
            .enumerate()
            .max_by(|x, y| x.1.3.total_cmp(&y.1.3))
            .expect("at least one panel");
        let (lo, hi, _, _) = panels[worst];
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            if too_small == TooSmall::Stop {
                return (total, err);
            }
            let (lo, hi, v, _) = panels.swap_remove(worst);
            panels.push((lo, hi, v, 0.0));
            continue;
        }
        panels.swap_remove(worst);
        let (v1, e1) = panel(lo, mid);
        let (v2, e2) = panel(mid, hi);
        panels.push((lo, mid, v1, e1));
        panels.push((mid, hi, v2, e2));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_sum_to_the_interval_length() {
        let nodes = gk15_nodes(-1.0, 1.0);
        let wk: f64 = nodes.iter().map(|n| n.1).sum();
        let wg: f64 = nodes.iter().map(|n| n.2).sum();
        assert!((wk - 2.0).abs() < 1e-15);
        assert!((wg - 2.0).abs() < 1e-15);
    }

    #[test]
    fn exact_for_polynomials_of_their_degree() {
        // Kronrod-15 integrates x^22 exactly, Gauss-7 x^13: ∫_0^1 x^k dx = 1/(k+1).
        let (k, _) = gk15(&mut |x: f64| x.powi(22), 0.0, 1.0);
        assert!((k - 1.0 / 23.0).abs() < 1e-15);
        let nodes = gk15_nodes(0.0, 1.0);
        let g: f64 = nodes.iter().map(|&(x, _, wg)| wg * x.powi(13)).sum();
        assert!((g - 1.0 / 14.0).abs() < 1e-15);
    }

    #[test]
    fn gk7_is_exact_to_degree_10_and_g3_to_degree_5() {
        let nodes = gk7_nodes(0.0, 1.0);
        let k: f64 = nodes.iter().map(|&(x, wk, _)| wk * x.powi(10)).sum();
        let g: f64 = nodes.iter().map(|&(x, _, wg)| wg * x.powi(5)).sum();
        assert!((k - 1.0 / 11.0).abs() < 1e-15, "{k}");
        assert!((g - 1.0 / 6.0).abs() < 1e-15, "{g}");
        let wk: f64 = nodes.iter().map(|n| n.1).sum();
        assert!((wk - 1.0).abs() < 1e-15);
    }

    #[test]
    fn adaptive_handles_a_narrow_peak() {
        // ∫_0^π/2 exp(-θ²/(2s²)) dθ = s sqrt(π/2) erf(π/(2√2 s)) ≈ s sqrt(π/2) for small s.
        let s = 0.005_f64;
        let (v, e) = adaptive(
            |t| (-t * t / (2.0 * s * s)).exp(),
            0.0,
            1.5,
            &[],
            1e-15,
            1e-12,
            2000,
        );
        let exact = s * (std::f64::consts::PI / 2.0).sqrt();
        assert!((v - exact).abs() < 1e-12 * exact, "{v} vs {exact}, err {e}");
    }
}
