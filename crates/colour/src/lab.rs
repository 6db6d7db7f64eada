//! CIE XYZ, CIELAB (CIE 1976 L*a*b*) and its cylindrical form L*C*h.
//!
//! Conventions: tristimulus values on the scale where the perfect reflecting diffuser
//! has `Y = 100`; the white point `(Xn, Yn, Zn)` is that of the same illuminant and
//! observer. CIELAB (CIE 015:2018 §8.2.1):
//!
//! `L* = 116 f(Y/Yn) − 16`, `a* = 500 [f(X/Xn) − f(Y/Yn)]`, `b* = 200 [f(Y/Yn) − f(Z/Zn)]`,
//! `f(t) = t^(1/3)` for `t > (6/29)³`, else `f(t) = t / (3 (6/29)²) + 4/29`.
//!
//! Chroma `C*ab = √(a*² + b*²)`; hue angle `hab = atan2(b*, a*)` in **radians** in
//! `[0, 2π)` (degrees only at the file and CLI boundary).

use std::f64::consts::TAU;

use crate::error::ColourError;

/// CIE XYZ tristimulus values (`Y = 100` for the perfect reflecting diffuser).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Xyz {
    /// X.
    pub x: f64,
    /// Y (luminance factor × 100).
    pub y: f64,
    /// Z.
    pub z: f64,
}

/// CIELAB coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lab {
    /// Lightness `L*` (100 for the white point; above 100 for samples brighter than the
    /// perfect diffuser, as metallic coatings near specular are).
    pub l: f64,
    /// Red–green `a*`.
    pub a: f64,
    /// Yellow–blue `b*`.
    pub b: f64,
}

/// CIELAB in cylindrical form.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lch {
    /// Lightness `L*`.
    pub l: f64,
    /// Chroma `C*ab ≥ 0`.
    pub c: f64,
    /// Hue angle `hab`, radians in `[0, 2π)` (0 when `C*ab = 0`).
    pub h: f64,
}

/// `6/29`, the CIELAB breakpoint of `f`.
const DELTA: f64 = 6.0 / 29.0;

/// The CIELAB compression `f(t)` (see the module header).
#[must_use]
pub fn lab_f(t: f64) -> f64 {
    if t > DELTA * DELTA * DELTA {
        t.cbrt()
    } else {
        t / (3.0 * DELTA * DELTA) + 4.0 / 29.0
    }
}

/// CIE 1976 lightness `L*` of a relative luminance `y_rel = Y/Yn`.
#[must_use]
pub fn lightness(y_rel: f64) -> f64 {
    116.0 * lab_f(y_rel) - 16.0
}

impl Xyz {
    /// CIELAB relative to the white point `white`.
    #[must_use]
    pub fn to_lab(&self, white: &Xyz) -> Lab {
        let fx = lab_f(self.x / white.x);
        let fy = lab_f(self.y / white.y);
        let fz = lab_f(self.z / white.z);
        Lab {
            l: 116.0 * fy - 16.0,
            a: 500.0 * (fx - fy),
            b: 200.0 * (fy - fz),
        }
    }

    /// Chromaticity coordinates `(x, y)`; `None` for `X + Y + Z = 0`.
    #[must_use]
    pub fn chromaticity(&self) -> Option<(f64, f64)> {
        let s = self.x + self.y + self.z;
        (s != 0.0).then(|| (self.x / s, self.y / s))
    }
}

impl Lab {
    /// A CIELAB colour from its coordinates.
    ///
    /// # Errors
    /// [`ColourError::InvalidValue`] if a coordinate is not finite.
    pub fn new(l: f64, a: f64, b: f64) -> Result<Self, ColourError> {
        for (name, value) in [("L*", l), ("a*", a), ("b*", b)] {
            if !value.is_finite() {
                return Err(ColourError::InvalidValue {
                    name,
                    value,
                    expected: "a finite number",
                });
            }
        }
        Ok(Self { l, a, b })
    }

    /// Chroma `C*ab`.
    #[must_use]
    pub fn chroma(&self) -> f64 {
        self.a.hypot(self.b)
    }

    /// Hue angle `hab`, radians in `[0, 2π)`.
    #[must_use]
    pub fn hue(&self) -> f64 {
        hue_angle(self.a, self.b)
    }

    /// The cylindrical form L*C*h.
    #[must_use]
    pub fn to_lch(&self) -> Lch {
        Lch {
            l: self.l,
            c: self.chroma(),
            h: self.hue(),
        }
    }

    /// Back to XYZ relative to `white` (the inverse of [`Xyz::to_lab`]).
    #[must_use]
    pub fn to_xyz(&self, white: &Xyz) -> Xyz {
        let fy = (self.l + 16.0) / 116.0;
        let fx = fy + self.a / 500.0;
        let fz = fy - self.b / 200.0;
        let inv = |f: f64| {
            if f > DELTA {
                f * f * f
            } else {
                3.0 * DELTA * DELTA * (f - 4.0 / 29.0)
            }
        };
        Xyz {
            x: white.x * inv(fx),
            y: white.y * inv(fy),
            z: white.z * inv(fz),
        }
    }
}

impl Lch {
    /// Back to rectangular CIELAB.
    #[must_use]
    pub fn to_lab(&self) -> Lab {
        Lab {
            l: self.l,
            a: self.c * self.h.cos(),
            b: self.c * self.h.sin(),
        }
    }
}

/// `atan2(b, a)` mapped to `[0, 2π)`; 0 for `a = b = 0`.
pub(crate) fn hue_angle(a: f64, b: f64) -> f64 {
    if a == 0.0 && b == 0.0 {
        return 0.0;
    }
    let h = b.atan2(a);
    if h < 0.0 { h + TAU } else { h }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lightness_closed_forms() {
        // L*(1) = 100; L*((6/29)³) = 116·6/29 − 16 = 8 on both branches; the linear
        // branch at Y/Yn = 0.001: 116 (0.001 · 841/108 + 4/29) − 16 = 0.903296.
        assert_eq!(lightness(1.0), 100.0);
        assert!((lightness(DELTA.powi(3)) - 8.0).abs() < 1e-12);
        assert!((lightness(0.001) - 0.903_296).abs() < 1e-6);
    }

    #[test]
    fn lab_round_trip_and_lch() {
        let white = Xyz {
            x: 94.811,
            y: 100.0,
            z: 107.304,
        };
        for xyz in [
            Xyz {
                x: 20.0,
                y: 15.0,
                z: 40.0,
            },
            Xyz {
                x: 0.3,
                y: 0.2,
                z: 0.5,
            },
            Xyz {
                x: 120.0,
                y: 130.0,
                z: 90.0,
            },
        ] {
            let back = xyz.to_lab(&white).to_xyz(&white);
            assert!(
                (back.x - xyz.x).abs() < 1e-10
                    && (back.y - xyz.y).abs() < 1e-10
                    && (back.z - xyz.z).abs() < 1e-10
            );
        }
        // a* = −3, b* = 4: C = 5, h = π − atan(4/3).
        let lch = Lab {
            l: 50.0,
            a: -3.0,
            b: 4.0,
        }
        .to_lch();
        assert!((lch.c - 5.0).abs() < 1e-12);
        assert!((lch.h - (std::f64::consts::PI - (4.0f64 / 3.0).atan())).abs() < 1e-12);
        let back = lch.to_lab();
        assert!((back.a + 3.0).abs() < 1e-12 && (back.b - 4.0).abs() < 1e-12);
        // Fourth quadrant maps into [0, 2π).
        let h = Lab {
            l: 50.0,
            a: 1.0,
            b: -1.0,
        }
        .hue();
        assert!((h - 7.0 * std::f64::consts::FRAC_PI_4).abs() < 1e-12);
        assert!(Lab::new(f64::NAN, 0.0, 0.0).is_err());
    }
}
