//! The CIE colour-matching functions and illuminants, at 1 nm from 360 to 830 nm.
//!
//! Conventions: wavelengths are integer **nanometres** (the CIE tables' own grid); the
//! colour-matching functions are the CIE's dimensionless `x̄, ȳ, z̄` (`ȳ(555) = 1`); the
//! illuminants are relative spectral power distributions normalised to 100 at 560 nm.
//!
//! Sources (see `data/README.md` for DOIs, checksums and licences):
//! * CIE 1931 2° and CIE 1964 10° observers: the CIE datasets, 1 nm, 360–830 nm, shipped
//!   byte-identical (`CIE_xyz_1931_2deg.csv`, `CIE_xyz_1964_10deg.csv`). The 10° file
//!   leaves `z̄10` empty (`NaN`) above 559 nm, where ISO/CIE 11664-1 tabulates zero; it is
//!   read as zero.
//! * Illuminants D65 and D50: the CIE datasets, 1 nm, 300–830 nm (`CIE_std_illum_D65.csv`,
//!   `CIE_std_illum_D50.csv`); only 360–830 nm is used.
//! * Illuminant A: computed from its defining formula (ISO/CIE 11664-2:2022, eq. 1),
//!   `S_A(λ) = 100 (560/λ)⁵ (exp(c₂/(2848·560)) − 1) / (exp(c₂/(2848·λ)) − 1)` with
//!   `c₂ = 1.435 × 10⁷ nm·K`, λ in nm. The CIE's 1 nm table is this formula rounded to
//!   six significant figures.
//!
//! The files are parsed once, on first use.

use std::sync::OnceLock;

/// First wavelength of the CIE tables used here, nm.
pub const START_NM: u32 = 360;
/// Last wavelength of the CIE tables used here, nm.
pub const END_NM: u32 = 830;
/// Number of 1 nm rows from [`START_NM`] to [`END_NM`] inclusive.
pub const ROWS: usize = (END_NM - START_NM + 1) as usize;

const CIE_1931_2: &str = include_str!("../data/CIE_xyz_1931_2deg.csv");
const CIE_1964_10: &str = include_str!("../data/CIE_xyz_1964_10deg.csv");
const CIE_D65: &str = include_str!("../data/CIE_std_illum_D65.csv");
const CIE_D50: &str = include_str!("../data/CIE_std_illum_D50.csv");

/// The embedded CIE data files, byte for byte, for checks against the CIE's published
/// checksums: `(file name, contents)`.
pub const EMBEDDED_FILES: [(&str, &str); 4] = [
    ("CIE_xyz_1931_2deg.csv", CIE_1931_2),
    ("CIE_xyz_1964_10deg.csv", CIE_1964_10),
    ("CIE_std_illum_D65.csv", CIE_D65),
    ("CIE_std_illum_D50.csv", CIE_D50),
];

/// A CIE standard colorimetric observer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Observer {
    /// CIE 1931 standard colorimetric observer (2° field).
    Cie1931TwoDegree,
    /// CIE 1964 supplementary standard colorimetric observer (10° field), the usual
    /// choice for industrial colour (and multi-angle instruments).
    Cie1964TenDegree,
}

impl Observer {
    /// Colour-matching functions `[x̄, ȳ, z̄]` at 1 nm from 360 nm (index 0) to 830 nm
    /// (index 470), dimensionless.
    #[must_use]
    pub fn colour_matching_functions(self) -> &'static [[f64; 3]] {
        static TWO: OnceLock<Vec<[f64; 3]>> = OnceLock::new();
        static TEN: OnceLock<Vec<[f64; 3]>> = OnceLock::new();
        match self {
            Self::Cie1931TwoDegree => TWO.get_or_init(|| parse_cmfs(CIE_1931_2)),
            Self::Cie1964TenDegree => TEN.get_or_init(|| parse_cmfs(CIE_1964_10)),
        }
    }

    /// Short name, as used in reports: `"2"` or `"10"` (degrees of the field).
    #[must_use]
    pub fn label(self) -> &'static str {
        match self {
            Self::Cie1931TwoDegree => "2",
            Self::Cie1964TenDegree => "10",
        }
    }
}

/// A CIE illuminant.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Illuminant {
    /// CIE standard illuminant D65 (average daylight, about 6500 K).
    D65,
    /// CIE standard illuminant D50 (daylight, about 5000 K; graphic arts).
    D50,
    /// CIE standard illuminant A (tungsten filament, 2856 K).
    A,
}

impl Illuminant {
    /// Relative spectral power distribution at 1 nm from 360 nm (index 0) to 830 nm
    /// (index 470), normalised to 100 at 560 nm.
    #[must_use]
    pub fn relative_spd(self) -> &'static [f64] {
        static D65: OnceLock<Vec<f64>> = OnceLock::new();
        static D50: OnceLock<Vec<f64>> = OnceLock::new();
        static A: OnceLock<Vec<f64>> = OnceLock::new();
        match self {
            Self::D65 => D65.get_or_init(|| parse_illuminant(CIE_D65)),
            Self::D50 => D50.get_or_init(|| parse_illuminant(CIE_D50)),
            Self::A => A.get_or_init(|| {
                (START_NM..=END_NM)
                    .map(|nm| illuminant_a(f64::from(nm)))
                    .collect()
            }),
        }
    }

    /// Short name, as used in reports: `"D65"`, `"D50"`, `"A"`.
    #[must_use]
    pub fn label(self) -> &'static str {
        match self {
            Self::D65 => "D65",
            Self::D50 => "D50",
            Self::A => "A",
        }
    }
}

/// CIE standard illuminant A at wavelength `lambda_nm` (nm), from its defining formula
/// (ISO/CIE 11664-2:2022, eq. 1), normalised to 100 at 560 nm.
#[must_use]
pub fn illuminant_a(lambda_nm: f64) -> f64 {
    const C2: f64 = 1.435e7; // nm·K, the value fixed by the standard
    const T: f64 = 2848.0; // K
    100.0 * (560.0 / lambda_nm).powi(5) * (C2 / (T * 560.0)).exp_m1()
        / (C2 / (T * lambda_nm)).exp_m1()
}

/// Rows `(wavelength_nm, columns...)` of a CIE CSV (no header, CRLF), restricted to
/// 360–830 nm. `NaN` fields are read as zero (the 10° `z̄` above 559 nm). The files are
/// embedded and checked by the test suite, so a malformed row is a build defect.
fn rows(text: &str, columns: usize) -> Vec<Vec<f64>> {
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let mut out = Vec::with_capacity(ROWS);
    for record in reader.records() {
        let record = record.expect("embedded CIE table is valid CSV (checked by the tests)");
        let fields: Vec<f64> = record
            .iter()
            .map(|f| {
                let v: f64 = f
                    .parse()
                    .expect("embedded CIE table holds numbers (checked by the tests)");
                if v.is_nan() { 0.0 } else { v }
            })
            .collect();
        assert_eq!(
            fields.len(),
            columns + 1,
            "embedded CIE table has {columns} data columns"
        );
        let nm = fields[0];
        if nm >= f64::from(START_NM) && nm <= f64::from(END_NM) {
            assert_eq!(
                nm,
                f64::from(START_NM) + out.len() as f64,
                "embedded CIE table is on a 1 nm grid"
            );
            out.push(fields[1..].to_vec());
        }
    }
    assert_eq!(out.len(), ROWS, "embedded CIE table covers 360-830 nm");
    out
}

fn parse_cmfs(text: &str) -> Vec<[f64; 3]> {
    rows(text, 3)
        .into_iter()
        .map(|r| [r[0], r[1], r[2]])
        .collect()
}

fn parse_illuminant(text: &str) -> Vec<f64> {
    rows(text, 1).into_iter().map(|r| r[0]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_cover_the_grid() {
        for o in [Observer::Cie1931TwoDegree, Observer::Cie1964TenDegree] {
            assert_eq!(o.colour_matching_functions().len(), ROWS);
        }
        for i in [Illuminant::D65, Illuminant::D50, Illuminant::A] {
            assert_eq!(i.relative_spd().len(), ROWS);
        }
    }
}
