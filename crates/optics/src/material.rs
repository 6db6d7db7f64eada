//! Optical constants of flake metals: the complex refractive index `N(λ) = n + i k`
//! versus wavelength, from a table.
//!
//! Conventions: wavelengths in vacuum, **nanometres** (named `_nm`; the unit of every
//! spectral table and of the colorimetry). `n > 0` is the real part and `k ≥ 0` the
//! extinction coefficient, relative to vacuum, as [`FlakeReflectance::complex`] takes
//! them. Between rows, `n` and `k` are interpolated **linearly in wavelength**; outside
//! the table's range a lookup is an error (no extrapolation).
//!
//! Built-in tables (files in `data/`, with their source and licence in each file's
//! header and in `data/README.md`; both CC0 via the refractiveindex.info database):
//! * [`ComplexIndexTable::aluminium_rakic_1995`] — Rakić, Appl. Opt. 34, 4755 (1995),
//!   evaporated films, 17 rows 310–886 nm: the default [`ComplexIndexTable::aluminium`];
//! * [`ComplexIndexTable::aluminium_mcpeak_2015`] — McPeak et al., ACS Photonics 2, 326
//!   (2015), template-stripped evaporated film, 5 nm rows 300–900 nm.
//!
//! At 550 nm the two give `1.015 + 6.627i` and `0.789 + 5.852i`. physics.md's
//! `0.96 + 6.69i` is close to the first (within 0.06 in each part, far less than the
//! two datasets differ from each other).

use std::sync::OnceLock;

use crate::flake::FlakeReflectance;

/// Errors from building or looking up a table of optical constants. Row numbers are
/// 0-based positions in the vectors given.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MaterialError {
    /// The three columns differ in length.
    #[error(
        "{wavelengths} wavelengths, {n} values of n and {k} values of k: expected equal lengths"
    )]
    LengthMismatch {
        /// Number of wavelengths.
        wavelengths: usize,
        /// Number of `n` values.
        n: usize,
        /// Number of `k` values.
        k: usize,
    },
    /// Fewer than two rows.
    #[error("a table of optical constants needs at least 2 rows, got {0}")]
    TooFewRows(usize),
    /// A wavelength that is not finite and positive.
    #[error("row {row}: wavelength {value} nm is not valid: expected a finite number > 0")]
    InvalidWavelength {
        /// Row (0-based).
        row: usize,
        /// The value given.
        value: f64,
    },
    /// Wavelengths must increase strictly.
    #[error(
        "row {row}: wavelength {value} nm does not follow {previous} nm: expected strictly increasing wavelengths"
    )]
    NotIncreasing {
        /// Row (0-based).
        row: usize,
        /// The previous wavelength, nm.
        previous: f64,
        /// The offending wavelength, nm.
        value: f64,
    },
    /// An index with `n ≤ 0`, `k < 0` or a non-finite part.
    #[error("row {row}: index {n} + {k}i is not valid: expected finite n > 0 and k >= 0")]
    InvalidIndex {
        /// Row (0-based).
        row: usize,
        /// Real part.
        n: f64,
        /// Extinction coefficient.
        k: f64,
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
}

/// A table of the complex refractive index `n + i k` versus vacuum wavelength (nm),
/// validated once: strictly increasing finite wavelengths, `n > 0`, `k ≥ 0`.
#[derive(Debug, Clone, PartialEq)]
pub struct ComplexIndexTable {
    wavelengths_nm: Vec<f64>,
    n: Vec<f64>,
    k: Vec<f64>,
}

const RAKIC_1995: &str = include_str!("../data/aluminium_rakic1995.csv");
const MCPEAK_2015: &str = include_str!("../data/aluminium_mcpeak2015.csv");

/// The embedded aluminium tables, byte for byte: `(file name, contents)`.
pub const EMBEDDED_FILES: [(&str, &str); 2] = [
    ("aluminium_rakic1995.csv", RAKIC_1995),
    ("aluminium_mcpeak2015.csv", MCPEAK_2015),
];

impl ComplexIndexTable {
    /// A table from its columns: wavelengths (nm), `n`, `k`.
    ///
    /// # Errors
    /// [`MaterialError`] naming the first row that breaks the rules above.
    pub fn new(wavelengths_nm: Vec<f64>, n: Vec<f64>, k: Vec<f64>) -> Result<Self, MaterialError> {
        if wavelengths_nm.len() != n.len() || n.len() != k.len() {
            return Err(MaterialError::LengthMismatch {
                wavelengths: wavelengths_nm.len(),
                n: n.len(),
                k: k.len(),
            });
        }
        if wavelengths_nm.len() < 2 {
            return Err(MaterialError::TooFewRows(wavelengths_nm.len()));
        }
        for row in 0..wavelengths_nm.len() {
            let value = wavelengths_nm[row];
            if !(value.is_finite() && value > 0.0) {
                return Err(MaterialError::InvalidWavelength { row, value });
            }
            if row > 0 && value <= wavelengths_nm[row - 1] {
                return Err(MaterialError::NotIncreasing {
                    row,
                    previous: wavelengths_nm[row - 1],
                    value,
                });
            }
            if FlakeReflectance::complex(n[row], k[row]).is_err() {
                return Err(MaterialError::InvalidIndex {
                    row,
                    n: n[row],
                    k: k[row],
                });
            }
        }
        Ok(Self {
            wavelengths_nm,
            n,
            k,
        })
    }

    /// Aluminium, the built-in default: [`ComplexIndexTable::aluminium_rakic_1995`].
    #[must_use]
    pub fn aluminium() -> &'static Self {
        Self::aluminium_rakic_1995()
    }

    /// Aluminium after Rakić (1995), 309.96–885.61 nm, 17 rows.
    #[must_use]
    pub fn aluminium_rakic_1995() -> &'static Self {
        static T: OnceLock<ComplexIndexTable> = OnceLock::new();
        T.get_or_init(|| parse_embedded(RAKIC_1995))
    }

    /// Aluminium after McPeak et al. (2015), 300–900 nm in 5 nm steps, 121 rows.
    #[must_use]
    pub fn aluminium_mcpeak_2015() -> &'static Self {
        static T: OnceLock<ComplexIndexTable> = OnceLock::new();
        T.get_or_init(|| parse_embedded(MCPEAK_2015))
    }

    /// `(n, k)` at `wavelength_nm`, linearly interpolated between rows (exact at a row).
    ///
    /// # Errors
    /// [`MaterialError::OutOfRange`] outside the table (or for a non-finite wavelength).
    pub fn index_at(&self, wavelength_nm: f64) -> Result<(f64, f64), MaterialError> {
        let wl = &self.wavelengths_nm;
        let (min_nm, max_nm) = self.range_nm();
        if !(wavelength_nm >= min_nm && wavelength_nm <= max_nm) {
            return Err(MaterialError::OutOfRange {
                wavelength_nm,
                min_nm,
                max_nm,
            });
        }
        // First row at or above the wavelength (≥ 1 unless it is the first row).
        let hi = wl.partition_point(|&w| w < wavelength_nm);
        if wl[hi] == wavelength_nm {
            return Ok((self.n[hi], self.k[hi]));
        }
        let lo = hi - 1;
        let t = (wavelength_nm - wl[lo]) / (wl[hi] - wl[lo]);
        Ok((
            self.n[lo] + t * (self.n[hi] - self.n[lo]),
            self.k[lo] + t * (self.k[hi] - self.k[lo]),
        ))
    }

    /// The flake reflectance at `wavelength_nm` (the complex index there).
    ///
    /// # Errors
    /// As [`ComplexIndexTable::index_at`].
    pub fn flake_at(&self, wavelength_nm: f64) -> Result<FlakeReflectance, MaterialError> {
        let (n, k) = self.index_at(wavelength_nm)?;
        // Interpolation keeps n > 0 and k ≥ 0, so the variant is valid by construction.
        Ok(FlakeReflectance::Complex { n, k })
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

    /// Tabulated real parts `n`.
    #[must_use]
    pub fn n(&self) -> &[f64] {
        &self.n
    }

    /// Tabulated extinction coefficients `k`.
    #[must_use]
    pub fn k(&self) -> &[f64] {
        &self.k
    }
}

/// Parse an embedded `wavelength_nm,n,k` file (`#` comment lines, one header row). The
/// files are compiled in and checked by the test suite, so a malformed one is a build
/// defect, not user input.
pub(crate) fn parse_embedded(text: &str) -> ComplexIndexTable {
    let mut reader = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let (mut wl, mut n, mut k) = (Vec::new(), Vec::new(), Vec::new());
    for record in reader.records() {
        let record =
            record.expect("embedded optical-constants table is valid CSV (checked by the tests)");
        let v: Vec<f64> = record
            .iter()
            .map(|f| {
                f.parse()
                    .expect("embedded optical-constants table holds numbers")
            })
            .collect();
        wl.push(v[0]);
        n.push(v[1]);
        k.push(v[2]);
    }
    ComplexIndexTable::new(wl, n, k)
        .expect("embedded optical-constants table is valid (checked by the tests)")
}
