//! Errors of the colorimetry crate.

/// Why a spectrum, a colour or a geometry was refused. Each variant names the offending
/// sample (by index and wavelength) or field, and what was expected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ColourError {
    /// Fewer wavelengths than a spectrum needs.
    #[error("a spectrum needs at least {min} samples, got {got}")]
    TooFewSamples {
        /// Samples given.
        got: usize,
        /// Minimum accepted.
        min: usize,
    },
    /// A wavelength that is NaN or infinite.
    #[error("wavelength #{index} is {value}: expected a finite number of nanometres")]
    NonFiniteWavelength {
        /// Position in the wavelength list (0-based).
        index: usize,
        /// The value given.
        value: f64,
    },
    /// Wavelengths must increase strictly (no repeats, no reversals).
    #[error(
        "wavelength #{index} ({value} nm) does not follow #{} ({previous} nm): \
         wavelengths must increase strictly",
        index - 1
    )]
    NotIncreasing {
        /// Position of the offending wavelength (0-based, ≥ 1).
        index: usize,
        /// The wavelength before it, nm.
        previous: f64,
        /// The offending wavelength, nm.
        value: f64,
    },
    /// A wavelength outside the CIE tables (360–830 nm).
    #[error("wavelength #{index} ({value} nm) is outside the CIE tables: expected 360 to 830 nm")]
    WavelengthOutOfRange {
        /// Position in the wavelength list (0-based).
        index: usize,
        /// The value given, nm.
        value: f64,
    },
    /// The spectrum does not cover the range colorimetry needs.
    #[error(
        "the spectrum covers {first} to {last} nm: colorimetry needs at least \
         {need_first} to {need_last} nm"
    )]
    InsufficientCoverage {
        /// First wavelength, nm.
        first: f64,
        /// Last wavelength, nm.
        last: f64,
        /// Latest accepted first wavelength, nm.
        need_first: f64,
        /// Earliest accepted last wavelength, nm.
        need_last: f64,
    },
    /// Two neighbouring samples too far apart to integrate (ASTM E308 stops at 20 nm).
    #[error(
        "samples at {from} nm and {to} nm are {} nm apart: the largest spacing accepted is {max} nm",
        to - from
    )]
    GapTooLarge {
        /// Lower wavelength of the gap, nm.
        from: f64,
        /// Upper wavelength of the gap, nm.
        to: f64,
        /// Largest accepted spacing, nm.
        max: f64,
    },
    /// The reflectance list and the wavelength list differ in length.
    #[error(
        "{values} reflectance values for {wavelengths} wavelengths: expected one value per wavelength"
    )]
    LengthMismatch {
        /// Number of wavelengths.
        wavelengths: usize,
        /// Number of values.
        values: usize,
    },
    /// A reflectance factor that is NaN or infinite.
    #[error("reflectance factor at {wavelength_nm} nm is {value}: expected a finite number")]
    NonFiniteReflectance {
        /// Where, nm.
        wavelength_nm: f64,
        /// The value given.
        value: f64,
    },
    /// A negative reflectance factor (values above 1 are allowed: metallic coatings
    /// exceed the perfect diffuser near specular).
    #[error("reflectance factor at {wavelength_nm} nm is {value}: expected a value >= 0")]
    NegativeReflectance {
        /// Where, nm.
        wavelength_nm: f64,
        /// The value given.
        value: f64,
    },
    /// A spectrum whose tristimulus values exceed the largest double (about 1.8e308):
    /// `Y` is about 100 times the mean reflectance factor, so factors above about 1e306
    /// have no XYZ in double precision.
    #[error(
        "the CIE XYZ of this spectrum exceed the largest double (about 1.8e308): its largest reflectance factor is {value:e} at {wavelength_nm} nm, and Y is about 100 times the mean reflectance factor (Y = 100 for the perfect diffuser), so reflectance factors above about 1e306 cannot be integrated"
    )]
    TristimulusOverflow {
        /// Where the largest reflectance factor is, nm.
        wavelength_nm: f64,
        /// The largest reflectance factor.
        value: f64,
    },
    /// A colour coordinate or parameter that is NaN or infinite, or out of its domain.
    #[error("{name} = {value} is not valid: expected {expected}")]
    InvalidValue {
        /// Which quantity.
        name: &'static str,
        /// The value given.
        value: f64,
        /// The accepted range in words.
        expected: &'static str,
    },
}
