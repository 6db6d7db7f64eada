//! Parameters of a synthetic flake layer, validated once.
//!
//! Units: lengths in micrometres (µm), angles in radians, intensities unit-less on
//! `[0, 1]` (an 8-bit detector's full scale). The frame is that of `physics.md` §1: `z`
//! is the coating normal pointing into the air; heights are measured upward from the
//! substrate (`z = 0`), so the film's top surface is at `z = film_um`.
//! Map axes follow the stats crate's `HeightMap`: `x = col * dx`, `y = row * dy`.

use flakescatter_stats::distribution::Orientation;

use crate::SynthError;

/// The largest map the generator accepts, in pixels (`nx * ny`): 2²⁸ (2 GiB per `f64`
/// map).
pub const MAX_PIXELS: usize = 1 << 28;

/// How flake diameters are drawn.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DiameterDistribution {
    /// Every flake has this diameter, µm.
    Fixed(f64),
    /// Log-normal with the given mean (µm) and relative standard deviation (sd / mean),
    /// clipped to `[mean / 4, 3 mean]` by redrawing (the clip removes less than 1e-7 of the
    /// mass for `rel_sd ≤ 0.25`). Parameters of `ln d`: `σ² = ln(1 + rel_sd²)`,
    /// `μ = ln(mean) - σ²/2`.
    LogNormal {
        /// Mean diameter, µm.
        mean_um: f64,
        /// Relative standard deviation (sd / mean), ≥ 0.
        rel_sd: f64,
    },
}

impl DiameterDistribution {
    /// Largest diameter that can be drawn, µm.
    pub fn max_um(&self) -> f64 {
        match *self {
            Self::Fixed(d) => d,
            Self::LogNormal { mean_um, .. } => 3.0 * mean_um,
        }
    }
}

/// How many flakes are placed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FlakeAmount {
    /// Coverage `c = Σ (π d²/4) / A`, the summed true disc area per unit area of the
    /// *placement region* `A` (the map plus a margin of half the largest diameter on each
    /// side, so that flakes overlapping an edge are cut naturally). Flakes are drawn until
    /// the sum of their true areas first reaches `c · A`. For flat flakes dropped at random
    /// (a Boolean model) the fraction of the map covered is about `1 - exp(-c)`.
    Coverage(f64),
    /// Exactly this many flakes, centres uniform over the placement region.
    Count(usize),
}

/// Roughness of the flake surfaces: a correlated Gaussian random field added to the
/// flake heights (background pixels are left alone).
///
/// The field has `C(Δx, Δy) = rms² exp(-(Δx² + Δy²) / ℓ²)` (see the `field` module).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Roughness {
    /// Root-mean-square height, µm; `0` = smooth (default 0).
    pub rms_um: f64,
    /// Correlation length `ℓ` (lag where the correlation falls to `1/e`), µm; `0` = white
    /// noise (default 1.0 µm).
    pub correlation_um: f64,
}

impl Default for Roughness {
    fn default() -> Self {
        Self {
            rms_um: 0.0,
            correlation_um: 1.0,
        }
    }
}

/// Instrument effects of a confocal microscope, applied in this order: lateral
/// blur, z quantisation, height noise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Confocal {
    /// Lateral resolution: standard deviation of a Gaussian point-spread function, µm;
    /// `0` = perfect (default 0). The height field is convolved with it (a linear model;
    /// a real confocal picks the axial peak, which differs from the mean at steps). The
    /// paper's 155 nm transverse resolution, read as a FWHM, is `sd = 0.155 / 2.355 ≈
    /// 0.066 µm`.
    pub psf_sd_um: f64,
    /// z quantisation step, µm: heights are rounded to the nearest multiple; `0` = off
    /// (default 0.3 µm, the paper's z step).
    pub z_step_um: f64,
    /// Standard deviation of Gaussian height noise added last, µm (default 0).
    pub noise_sd_um: f64,
}

impl Default for Confocal {
    fn default() -> Self {
        Self {
            psf_sd_um: 0.0,
            z_step_um: 0.3,
            noise_sd_um: 0.0,
        }
    }
}

/// Levels of the intensity map. A pixel gets `flake` or `background`, plus Gaussian noise
/// of sd `noise_sd`, then is clipped to `[0, 1]` and rounded to a multiple of `1/255` (an
/// 8-bit detector).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IntensityLevels {
    /// Level on a visible flake, in `(0, 1]` (default 0.9).
    pub flake: f64,
    /// Level between flakes, in `[0, 1)` and below `flake` (default 0.08).
    pub background: f64,
    /// Standard deviation of the noise, ≥ 0 (default 0.03).
    pub noise_sd: f64,
}

impl Default for IntensityLevels {
    fn default() -> Self {
        Self {
            flake: 0.9,
            background: 0.08,
            noise_sd: 0.03,
        }
    }
}

impl IntensityLevels {
    /// A cutoff half-way between the two levels: with the default noise it separates
    /// flakes from background with an error rate below 1e-40.
    pub fn midpoint(&self) -> f64 {
        0.5 * (self.flake + self.background)
    }
}

/// Everything that defines a synthetic layer. Build with [`LayerSpec::new`], adjust the
/// public fields, then validate with [`LayerParams::new`].
#[derive(Debug, Clone, PartialEq)]
pub struct LayerSpec {
    /// Number of columns (points along `x`), ≥ 1.
    pub nx: usize,
    /// Number of rows (points along `y`), ≥ 1.
    pub ny: usize,
    /// Pixel pitch along `x`, µm (default 0.18, the paper's microscope).
    pub dx_um: f64,
    /// Pixel pitch along `y`, µm (default 0.18).
    pub dy_um: f64,
    /// Film (coating) thickness, µm (default 38). Flake mid-plane centres are uniform in
    /// `[0, film_um]` above the substrate.
    pub film_um: f64,
    /// Flake diameters (default log-normal, mean 16 µm, relative sd 0.25).
    pub diameter: DiameterDistribution,
    /// Flake thickness, µm (default 1).
    pub thickness_um: f64,
    /// How many flakes (default coverage 1.5: about 78 % of the map shows a flake).
    pub amount: FlakeAmount,
    /// Area-weighted distribution of flake normals.
    pub orientation: Orientation,
    /// Flake surface roughness (default smooth).
    pub roughness: Roughness,
    /// Confocal instrument effects (default: 0.3 µm z step only).
    pub confocal: Confocal,
    /// Intensity levels (default flake 0.9, background 0.08, noise 0.03).
    pub intensity: IntensityLevels,
    /// Seed of every random draw; equal seeds give bit-identical layers.
    pub seed: u64,
}

impl LayerSpec {
    /// A layer of `nx × ny` pixels with the given orientation distribution and seed, and
    /// every other field at its documented default.
    pub fn new(nx: usize, ny: usize, orientation: Orientation, seed: u64) -> Self {
        Self {
            nx,
            ny,
            dx_um: 0.18,
            dy_um: 0.18,
            film_um: 38.0,
            diameter: DiameterDistribution::LogNormal {
                mean_um: 16.0,
                rel_sd: 0.25,
            },
            thickness_um: 1.0,
            amount: FlakeAmount::Coverage(1.5),
            orientation,
            roughness: Roughness::default(),
            confocal: Confocal::default(),
            intensity: IntensityLevels::default(),
            seed,
        }
    }
}

/// A validated [`LayerSpec`].
#[derive(Debug, Clone, PartialEq)]
pub struct LayerParams {
    spec: LayerSpec,
}

fn check(
    field: &'static str,
    value: f64,
    ok: bool,
    expected: &'static str,
) -> Result<(), SynthError> {
    if ok && value.is_finite() {
        Ok(())
    } else {
        Err(SynthError::InvalidParameter {
            field,
            value,
            expected,
        })
    }
}

impl LayerParams {
    /// Validates `spec`.
    ///
    /// # Errors
    /// [`SynthError::EmptyMap`] / [`SynthError::TooLarge`] for a bad size, and
    /// [`SynthError::InvalidParameter`] naming the first field that is not finite or out
    /// of range.
    pub fn new(spec: LayerSpec) -> Result<Self, SynthError> {
        let s = &spec;
        if s.nx == 0 || s.ny == 0 {
            return Err(SynthError::EmptyMap { nx: s.nx, ny: s.ny });
        }
        if s.nx.checked_mul(s.ny).is_none_or(|n| n > MAX_PIXELS) {
            return Err(SynthError::TooLarge { nx: s.nx, ny: s.ny });
        }
        check("dx_um", s.dx_um, s.dx_um > 0.0, "finite and > 0")?;
        check("dy_um", s.dy_um, s.dy_um > 0.0, "finite and > 0")?;
        check("film_um", s.film_um, s.film_um >= 0.0, "finite and >= 0")?;
        check(
            "thickness_um",
            s.thickness_um,
            s.thickness_um >= 0.0,
            "finite and >= 0",
        )?;
        match s.diameter {
            DiameterDistribution::Fixed(d) => check("diameter_um", d, d > 0.0, "finite and > 0")?,
            DiameterDistribution::LogNormal { mean_um, rel_sd } => {
                check("diameter_mean_um", mean_um, mean_um > 0.0, "finite and > 0")?;
                check(
                    "diameter_rel_sd",
                    rel_sd,
                    (0.0..=2.0).contains(&rel_sd),
                    "finite, in [0, 2]",
                )?;
            }
        }
        match s.amount {
            FlakeAmount::Coverage(c) => {
                check("coverage", c, c > 0.0 && c <= 100.0, "finite, in (0, 100]")?;
            }
            FlakeAmount::Count(n) => {
                if n == 0 || n > 10_000_000 {
                    return Err(SynthError::InvalidParameter {
                        field: "count",
                        value: n as f64,
                        expected: "in [1, 10^7]",
                    });
                }
            }
        }
        let r = s.roughness;
        check(
            "roughness_rms_um",
            r.rms_um,
            r.rms_um >= 0.0,
            "finite and >= 0",
        )?;
        check(
            "roughness_correlation_um",
            r.correlation_um,
            r.correlation_um >= 0.0,
            "finite and >= 0",
        )?;
        let c = s.confocal;
        check(
            "psf_sd_um",
            c.psf_sd_um,
            c.psf_sd_um >= 0.0,
            "finite and >= 0",
        )?;
        check(
            "z_step_um",
            c.z_step_um,
            c.z_step_um >= 0.0,
            "finite and >= 0",
        )?;
        check(
            "height_noise_sd_um",
            c.noise_sd_um,
            c.noise_sd_um >= 0.0,
            "finite and >= 0",
        )?;
        let i = s.intensity;
        check(
            "intensity_flake",
            i.flake,
            i.flake > 0.0 && i.flake <= 1.0,
            "finite, in (0, 1]",
        )?;
        check(
            "intensity_background",
            i.background,
            (0.0..i.flake).contains(&i.background),
            "finite, >= 0 and below the flake level",
        )?;
        check(
            "intensity_noise_sd",
            i.noise_sd,
            i.noise_sd >= 0.0,
            "finite and >= 0",
        )?;
        // Keep the blur and roughness kernels (radius 4 sd) and the margin within reason.
        let pitch = s.dx_um.min(s.dy_um);
        check(
            "psf_sd_um",
            c.psf_sd_um,
            c.psf_sd_um / pitch <= 256.0,
            "at most 256 pixels",
        )?;
        check(
            "roughness_correlation_um",
            r.correlation_um,
            r.correlation_um / pitch <= 512.0,
            "at most 512 pixels",
        )?;
        Ok(Self { spec })
    }

    /// The validated specification.
    pub fn spec(&self) -> &LayerSpec {
        &self.spec
    }
}
