//! Where a ring of exit directions crosses a cone's rim ([`super::response`]): the root
//! of `f(φ) = k_out(φ)·r − cos α` between two samples of opposite signs (Newton's method
//! from the secant point, safeguarded by bisection), and the extremum of `f` on a step
//! whose end slopes change sign (the Illinois method on `f'`), which finds a hidden
//! visit of the cone (or a dip out of it) between two samples on the same side.

use super::ring::{Axis, Ring, RingPoint};

/// Appends `[u, w]` to `iv`, merging with the last interval when they touch.
pub(crate) fn push(u: f64, w: f64, iv: &mut Vec<(f64, f64)>) {
    if w <= u {
        return;
    }
    if let Some(last) = iv.last_mut()
        && last.1 == u
    {
        last.1 = w;
        return;
    }
    iv.push((u, w));
}

/// Slope of `f` at a step end for the extremum tests. At the horizon end of an arc
/// (`k_out.z = 0`) the exit direction rises vertically: `+∞` at the start of a step,
/// `−∞` at its end.
pub(crate) fn end_slope(axis: &Axis, p: &RingPoint, at_start: bool) -> f64 {
    if p.o[2] > 0.0 {
        axis.df(p)
    } else if at_start {
        f64::INFINITY
    } else {
        f64::NEG_INFINITY
    }
}

/// The root of `f` between `(a, f(a))` and `(b, f(b))`, which have opposite signs
/// (`f ≤ 0` counts as outside): Newton's method from the secant point, safeguarded by
/// bisection, to 1e-13 rad or `|f| ≤ 1e-16`.
pub(crate) fn root(ring: &Ring, axis: &Axis, (a, fa): (f64, f64), (b, fb): (f64, f64)) -> f64 {
    // Keep `lo` on the outside (f ≤ 0) and `hi` on the inside.
    let (mut lo, mut hi) = if fa > 0.0 { (b, a) } else { (a, b) };
    let (flo, fhi) = if fa > 0.0 { (fb, fa) } else { (fa, fb) };
    let mut x = lo + (hi - lo) * (flo / (flo - fhi)).clamp(0.01, 0.99);
    for _ in 0..100 {
        let p = ring.at(x);
        let f = axis.f(&p);
        if f > 0.0 {
            hi = x;
        } else {
            lo = x;
        }
        if f.abs() <= 1e-16 || (hi - lo).abs() < 1e-13 {
            break;
        }
        let newton = x - f / axis.df(&p);
        let next = if newton.is_finite() && (newton - lo) * (newton - hi) < 0.0 {
            newton
        } else {
            0.5 * (lo + hi)
        };
        if (next - x).abs() < 1e-14 {
            x = next;
            break;
        }
        x = next;
    }
    x
}

/// The azimuth between `(a, f'(a))` and `(b, f'(b))` (slopes of opposite signs, from
/// [`end_slope`]) where `f'` vanishes: the Illinois variant of regula falsi, bisection
/// while an end slope is infinite, to 1e-13 rad.
pub(crate) fn extremum(
    ring: &Ring,
    axis: &Axis,
    (mut a, mut sa): (f64, f64),
    (mut b, mut sb): (f64, f64),
) -> f64 {
    let mut side = 0i8;
    for _ in 0..100 {
        if b - a < 1e-13 {
            break;
        }
        let x = if sa.is_finite() && sb.is_finite() {
            (a * sb - b * sa) / (sb - sa)
        } else {
            0.5 * (a + b)
        };
        let x = if x > a && x < b { x } else { 0.5 * (a + b) };
        let p = ring.at(x);
        let sx = if p.o[2] > 0.0 { axis.df(&p) } else { sa };
        if sx == 0.0 {
            return x;
        }
        if (sx > 0.0) == (sa > 0.0) {
            a = x;
            sa = sx;
            if side == -1 {
                sb *= 0.5;
            }
            side = -1;
        } else {
            b = x;
            sb = sx;
            if side == 1 {
                sa *= 0.5;
            }
            side = 1;
        }
    }
    0.5 * (a + b)
}
