//! The width of the Gaussian family in its three forms (module docs of the parent).

/// Width of the Gaussian family `p̃(θ) ∝ exp(-θ²/(2 s²))` on `[0, π/2)`, radians.
///
/// The three forms describe the same shape: `w = s·sqrt(2 ln 2)` (half-width at half
/// maximum of `p̃`, the paper's "half-width"), `s` (standard deviation of each tilt
/// component for small tilts), `σt = s·√2` (`p̃ ∝ exp(-θ²/σt²)`, the facet-model
/// software's rms tilt).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GaussianWidth {
    /// Half-width at half-maximum `w` of `p̃`, radians.
    Hwhm(f64),
    /// The standard deviation `s`, radians.
    Sigma(f64),
    /// The rms tilt `σt = s·√2`, radians.
    RmsTilt(f64),
}

/// The smallest Gaussian width accepted (as `hwhm`, `sigma` or `rms-tilt`), radians.
///
/// Below it a detector cone collects the all-flat (delta) value to double precision
/// wherever it contains the specular direction with a margin; only cones whose edge
/// passes within ~1e-9 rad of specular still see the width, and there the answer is
/// set by the last bits of the detector geometry, not by the width.
pub const MIN_GAUSSIAN_WIDTH: f64 = 1e-10;

/// `sqrt(2 ln 2)`: `hwhm = s · HWHM_PER_SIGMA`.
pub const HWHM_PER_SIGMA: f64 = 1.177_410_022_515_474_7;

impl GaussianWidth {
    /// The value as given, radians.
    pub fn value(self) -> f64 {
        match self {
            Self::Hwhm(v) | Self::Sigma(v) | Self::RmsTilt(v) => v,
        }
    }

    /// The standard deviation `s`, radians.
    pub fn sigma(self) -> f64 {
        match self {
            Self::Hwhm(w) => w / HWHM_PER_SIGMA,
            Self::Sigma(s) => s,
            Self::RmsTilt(t) => t / std::f64::consts::SQRT_2,
        }
    }

    /// The half-width at half-maximum `w = s·sqrt(2 ln 2)`, radians (a width given as
    /// a hwhm returns exactly that value, not its round trip through `s`).
    pub fn hwhm(self) -> f64 {
        match self {
            Self::Hwhm(w) => w,
            _ => self.sigma() * HWHM_PER_SIGMA,
        }
    }

    /// The rms tilt `σt = s·√2`, radians.
    pub fn rms_tilt(self) -> f64 {
        match self {
            Self::RmsTilt(t) => t,
            _ => self.sigma() * std::f64::consts::SQRT_2,
        }
    }

    pub(super) fn name(self) -> &'static str {
        match self {
            Self::Hwhm(_) => "hwhm",
            Self::Sigma(_) => "sigma",
            Self::RmsTilt(_) => "rms-tilt",
        }
    }
}
