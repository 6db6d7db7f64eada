//! Dispersion of the clear coat: its real refractive index `n(λ)` versus wavelength,
//! and tables of any real quantity versus wavelength (the coat's index, the binder's
//! absorption coefficient).
//!
//! Conventions: wavelengths in vacuum, **nanometres** (named `_nm`, the unit of every
//! spectral file and of the colorimetry). The **Cauchy** form is written with the
//! wavelength in **micrometres**, as coating and glass datasheets give it:
//!
//! `n(λ) = A + B/λ² + C/λ⁴`, `λ` in µm, so `B` is in µm² and `C` in µm⁴
//! (`B = 0.0042 µm²` is `4200 nm²`).
//!
//! A [`SpectralTable`] is interpolated **linearly in wavelength** between its rows and is
//! exact at a row; outside its range a lookup is an error (no extrapolation), as for
//! [`crate::material::ComplexIndexTable`]. The coat is lossless: its index is real and
//! at least 1 at every wavelength it is evaluated at (physics.md §2); absorption in the
//! binder is [`crate::absorption`].

/// Errors from building or evaluating a dispersion. Row numbers are 0-based positions
/// in the vectors given.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DispersionError {
    /// The two columns differ in length.
    #[error("{wavelengths} wavelengths and {values} values: expected equal lengths")]
    LengthMismatch {
        /// Number of wavelengths.
        wavelengths: usize,
        /// Number of values.
        values: usize,
    },
    /// Fewer than two rows.
    #[error("a spectral table needs at least 2 rows, got {0}")]
    TooFewRows(usize),
    /// A wavelength that is not finite and positive, or not above the previous one.
    #[error(
        "row {row}: wavelength {value} nm is not valid: expected finite wavelengths > 0, strictly increasing"
    )]
    InvalidWavelength {
        /// Row (0-based).
        row: usize,
        /// The value given, nm.
        value: f64,
    },
    /// A value outside what the table may hold.
    #[error("row {row}: {name} {value} is not valid: expected {expected}")]
    InvalidValue {
        /// Row (0-based).
        row: usize,
        /// What the column holds.
        name: &'static str,
        /// The value given.
        value: f64,
        /// The accepted range in words.
        expected: &'static str,
    },
    /// A Cauchy coefficient that is not finite.
    #[error("Cauchy coefficient {name} = {value} is not a finite number")]
    InvalidCoefficient {
        /// `A`, `B` or `C`.
        name: &'static str,
        /// The value given.
        value: f64,
    },
    /// A lookup outside the table.
    #[error("wavelength {wavelength_nm} nm is outside the table ({min_nm} to {max_nm} nm)")]
    OutOfRange {
        /// The wavelength asked for, nm.
        wavelength_nm: f64,
        /// First tabulated wavelength, nm.
        min_nm: f64,
        /// Last tabulated wavelength, nm.
        max_nm: f64,
    },
    /// A wavelength that is not finite and positive.
    #[error("wavelength {0} nm is not valid: expected a finite number > 0")]
    BadWavelength(f64),
    /// The coat's index at a wavelength is below 1 (or not finite).
    #[error(
        "the clear coat's index at {wavelength_nm} nm is {index}: expected a finite real number >= 1"
    )]
    IndexBelowOne {
        /// Where, nm.
        wavelength_nm: f64,
        /// The index there.
        index: f64,
    },
}

/// The Cauchy dispersion `n(λ) = A + B/λ² + C/λ⁴` with `λ` in µm (`B` in µm², `C` in
/// µm⁴).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cauchy {
    a: f64,
    b_um2: f64,
    c_um4: f64,
}

impl Cauchy {
    /// The form with coefficients `A`, `B` (µm²) and `C` (µm⁴).
    ///
    /// # Errors
    /// [`DispersionError::InvalidCoefficient`] for a coefficient that is not finite.
    /// (Whether the index stays ≥ 1 is checked where it is evaluated.)
    pub fn new(a: f64, b_um2: f64, c_um4: f64) -> Result<Self, DispersionError> {
        for (name, value) in [("A", a), ("B", b_um2), ("C", c_um4)] {
            if !value.is_finite() {
                return Err(DispersionError::InvalidCoefficient { name, value });
            }
        }
        Ok(Self { a, b_um2, c_um4 })
    }

    /// `A` (dimensionless).
    #[must_use]
    pub fn a(&self) -> f64 {
        self.a
    }

    /// `B`, µm².
    #[must_use]
    pub fn b_um2(&self) -> f64 {
        self.b_um2
    }

    /// `C`, µm⁴.
    #[must_use]
    pub fn c_um4(&self) -> f64 {
        self.c_um4
    }

    /// `n(λ)` at `wavelength_nm` (nm; converted to µm for the form).
    #[must_use]
    pub fn index_at(&self, wavelength_nm: f64) -> f64 {
        let l = wavelength_nm * 1e-3;
        let l2 = l * l;
        self.a + self.b_um2 / l2 + self.c_um4 / (l2 * l2)
    }
}

/// A real quantity tabulated versus vacuum wavelength (nm), validated once: at least two
/// rows, strictly increasing finite positive wavelengths, finite values.
#[derive(Debug, Clone, PartialEq)]
pub struct SpectralTable {
    wavelengths_nm: Vec<f64>,
    values: Vec<f64>,
}

impl SpectralTable {
    /// A table from its columns; `name` and `min` say what the values are and their
    /// smallest accepted value (e.g. `("index", 1.0)`, `("absorption coefficient", 0.0)`).
    ///
    /// # Errors
    /// [`DispersionError`] naming the first row that breaks the rules.
    pub fn new(
        wavelengths_nm: Vec<f64>,
        values: Vec<f64>,
        name: &'static str,
        min: f64,
    ) -> Result<Self, DispersionError> {
        if wavelengths_nm.len() != values.len() {
            return Err(DispersionError::LengthMismatch {
                wavelengths: wavelengths_nm.len(),
                values: values.len(),
            });
        }
        if wavelengths_nm.len() < 2 {
            return Err(DispersionError::TooFewRows(wavelengths_nm.len()));
        }
        for (row, (&w, &v)) in wavelengths_nm.iter().zip(&values).enumerate() {
            if !(w.is_finite() && w > 0.0) || (row > 0 && w <= wavelengths_nm[row - 1]) {
                return Err(DispersionError::InvalidWavelength { row, value: w });
            }
            if !(v.is_finite() && v >= min) {
                return Err(DispersionError::InvalidValue {
                    row,
                    name,
                    value: v,
                    expected: if min == 0.0 {
                        "a finite number >= 0"
                    } else {
                        "a finite number >= 1"
                    },
                });
            }
        }
        Ok(Self {
            wavelengths_nm,
            values,
        })
    }

    /// The same value at every wavelength (a table of two rows spanning every positive
    /// finite wavelength, so [`SpectralTable::value_at`] returns `value` exactly).
    ///
    /// # Errors
    /// [`DispersionError::InvalidValue`] for a value that is not finite or below `min`.
    pub fn constant(value: f64, name: &'static str, min: f64) -> Result<Self, DispersionError> {
        Self::new(
            vec![f64::MIN_POSITIVE, f64::MAX],
            vec![value, value],
            name,
            min,
        )
    }

    /// Whether every row holds the same value (e.g. a [`SpectralTable::constant`]).
    #[must_use]
    pub fn is_constant(&self) -> bool {
        self.values.windows(2).all(|w| w[0] == w[1])
    }

    /// The value at `wavelength_nm`, linearly interpolated between rows (exact at a row).
    ///
    /// # Errors
    /// [`DispersionError::OutOfRange`] outside the table or for a non-finite wavelength.
    pub fn value_at(&self, wavelength_nm: f64) -> Result<f64, DispersionError> {
        let wl = &self.wavelengths_nm;
        let (min_nm, max_nm) = self.range_nm();
        if !(wavelength_nm >= min_nm && wavelength_nm <= max_nm) {
            return Err(DispersionError::OutOfRange {
                wavelength_nm,
                min_nm,
                max_nm,
            });
        }
        let hi = wl.partition_point(|&w| w < wavelength_nm);
        if wl[hi] == wavelength_nm {
            return Ok(self.values[hi]);
        }
        let lo = hi - 1;
        let t = (wavelength_nm - wl[lo]) / (wl[hi] - wl[lo]);
        Ok(self.values[lo] + t * (self.values[hi] - self.values[lo]))
    }

    /// First and last tabulated wavelength, nm.
    #[must_use]
    pub fn range_nm(&self) -> (f64, f64) {
        (
            self.wavelengths_nm[0],
            self.wavelengths_nm[self.wavelengths_nm.len() - 1],
        )
    }

    /// Tabulated wavelengths, nm.
    #[must_use]
    pub fn wavelengths_nm(&self) -> &[f64] {
        &self.wavelengths_nm
    }

    /// Tabulated values.
    #[must_use]
    pub fn values(&self) -> &[f64] {
        &self.values
    }
}

/// The clear coat's real index versus wavelength.
#[derive(Debug, Clone, PartialEq)]
pub enum CoatIndex {
    /// The same index at every wavelength (non-dispersive).
    Constant(f64),
    /// The Cauchy form.
    Cauchy(Cauchy),
    /// A table `wavelength_nm, n` (values ≥ 1).
    Table(SpectralTable),
}

impl CoatIndex {
    /// The index at `wavelength_nm` (nm).
    ///
    /// # Errors
    /// [`DispersionError::BadWavelength`] for a wavelength that is not finite and
    /// positive, [`DispersionError::OutOfRange`] outside a table,
    /// [`DispersionError::IndexBelowOne`] where the index is below 1 (a Cauchy form far
    /// outside the range it was fitted on).
    pub fn index_at(&self, wavelength_nm: f64) -> Result<f64, DispersionError> {
        if !(wavelength_nm.is_finite() && wavelength_nm > 0.0) {
            return Err(DispersionError::BadWavelength(wavelength_nm));
        }
        let n = match self {
            Self::Constant(n) => *n,
            Self::Cauchy(c) => c.index_at(wavelength_nm),
            Self::Table(t) => t.value_at(wavelength_nm)?,
        };
        if !(n.is_finite() && n >= 1.0) {
            return Err(DispersionError::IndexBelowOne {
                wavelength_nm,
                index: n,
            });
        }
        Ok(n)
    }

    /// Whether the index is the same at every wavelength.
    #[must_use]
    pub fn is_constant(&self) -> bool {
        matches!(self, Self::Constant(_))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cauchy_closed_form() {
        // A = 1.5, B = 0.0042 µm², C = 0.0001 µm⁴ at 500 nm = 0.5 µm:
        // 1.5 + 0.0042/0.25 + 0.0001/0.0625 = 1.5 + 0.0168 + 0.0016 = 1.5184.
        let c = Cauchy::new(1.5, 0.0042, 0.0001).unwrap();
        assert!((c.index_at(500.0) - 1.5184).abs() < 1e-14);
        // At 1000 nm = 1 µm the form is A + B + C.
        assert!((c.index_at(1000.0) - 1.5043).abs() < 1e-14);
        assert!(Cauchy::new(f64::NAN, 0.0, 0.0).is_err());
        // Far in the infrared a negative B drives it below 1: refused where evaluated.
        let bad = CoatIndex::Cauchy(Cauchy::new(1.0, -0.01, 0.0).unwrap());
        assert!(matches!(
            bad.index_at(550.0),
            Err(DispersionError::IndexBelowOne { .. })
        ));
    }

    #[test]
    fn table_interpolates_linearly_and_refuses_outside() {
        let t = SpectralTable::new(
            vec![400.0, 500.0, 700.0],
            vec![1.6, 1.5, 1.45],
            "index",
            1.0,
        )
        .unwrap();
        assert_eq!(t.value_at(500.0).unwrap(), 1.5);
        // A quarter of the way from 500 to 700 nm: 1.5 − 0.25 · 0.05.
        assert!((t.value_at(550.0).unwrap() - 1.4875).abs() < 1e-15);
        assert!(t.value_at(399.0).is_err() && t.value_at(f64::NAN).is_err());
        assert!(SpectralTable::new(vec![400.0, 400.0], vec![1.5, 1.5], "index", 1.0).is_err());
        assert!(SpectralTable::new(vec![400.0, 500.0], vec![1.5, 0.9], "index", 1.0).is_err());
        assert!(SpectralTable::new(vec![400.0], vec![1.5], "index", 1.0).is_err());
        assert!(SpectralTable::new(vec![400.0, 500.0], vec![0.0, -0.1], "alpha", 0.0).is_err());
    }
}
