//! Parameters of a synthetic flake layer, validated once.
//!
//! Units: lengths in micrometres (µm), angles in radians, intensities unit-less on
//! `[0, 1]` (an 8-bit detector's full scale). The frame is that of `physics.md` §1: `z`
//! is the coating normal pointing into the air; heights are measured upward from the
//! substrate (`z = 0`), so the film's top surface is at `z = film_um`.
//! Map axes follow the stats crate's `HeightMap`: `x = col * dx`, `y = row * dy`.
//!
//! # The film rule
//! Every flake lies wholly inside the film `[0, film_um]`. A disc of diameter `d` and
//! thickness `t` tilted by `θ` spans `2h = t cos θ + d sin θ` in height, so its mid-plane
//! centre is drawn uniformly in `[h, film − h]`. A flake whose drawn tilt and diameter
//! do not fit (`2h > film`) gets a new diameter and normal from the same distributions
//! until it does (a thin film aligns its large flakes), and
//! [`SyntheticLayer::redrawn_flakes`](crate::SyntheticLayer::redrawn_flakes) counts them.
//! Parameters are refused when the flakes are thicker than the film
//! ([`SynthError::FilmThinnerThanFlakes`]) or when more than
//! [`MAX_REDRAWN_FRACTION`] of the flakes would need a new draw
//! ([`SynthError::FlakesDoNotFit`]), so that the layer's orientation and diameter
//! distributions differ from the requested ones by at most that much.

use flakescatter_stats::distribution::Orientation;

use crate::SynthError;

/// The largest map the generator accepts, in pixels (`nx * ny`): 2²⁸ (2 GiB per `f64`
/// map).
pub const MAX_PIXELS: usize = 1 << 28;

/// The most flakes a layer may hold (given as a count, or taken by a coverage).
pub const MAX_FLAKES: usize = 10_000_000;

/// The largest expected fraction of flakes that may need a new draw to fit inside the
/// film (module docs, the film rule).
pub const MAX_REDRAWN_FRACTION: f64 = 1e-3;

/// A parameter of [`LayerSpec`], as named by [`SynthError::InvalidParameter`]. Its
/// `Display` is the field name with its unit suffix (`dx_um`, `film_um`, ...); callers
/// with their own names for the parameters (command-line flags) match on the variant.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Param {
    /// [`LayerSpec::dx_um`].
    DxUm,
    /// [`LayerSpec::dy_um`].
    DyUm,
    /// [`LayerSpec::film_um`].
    FilmUm,
    /// [`LayerSpec::thickness_um`].
    ThicknessUm,
    /// [`DiameterDistribution::Fixed`].
    DiameterUm,
    /// The mean of [`DiameterDistribution::LogNormal`].
    DiameterMeanUm,
    /// The relative sd of [`DiameterDistribution::LogNormal`].
    DiameterRelSd,
    /// [`FlakeAmount::Coverage`].
    Coverage,
    /// [`FlakeAmount::Count`].
    Count,
    /// [`Roughness::rms_um`].
    RoughnessRmsUm,
    /// [`Roughness::correlation_um`].
    RoughnessCorrelationUm,
    /// [`Confocal::psf_sd_um`].
    PsfSdUm,
    /// [`Confocal::z_step_um`].
    ZStepUm,
    /// [`Confocal::noise_sd_um`].
    HeightNoiseSdUm,
    /// [`IntensityLevels::flake`].
    IntensityFlake,
    /// [`IntensityLevels::background`].
    IntensityBackground,
    /// [`IntensityLevels::noise_sd`].
    IntensityNoiseSd,
    /// [`crate::StackSpec::z_step_um`].
    StackZStepUm,
    /// [`crate::StackSpec::slices`].
    StackSlices,
    /// [`crate::StackSpec::z_first_um`].
    StackZFirstUm,
    /// The FWHM of [`crate::StackSpec::axial`].
    AxialFwhmUm,
    /// [`crate::StackSpec::photons`].
    Photons,
    /// [`crate::StackSpec::read_noise`].
    ReadNoise,
    /// [`crate::StackSpec::aperture_sin`].
    ApertureSin,
    /// A slice index asked of a synthetic stack.
    Slice,
}

impl Param {
    /// The field name with its unit suffix.
    pub fn name(self) -> &'static str {
        match self {
            Self::DxUm => "dx_um",
            Self::DyUm => "dy_um",
            Self::FilmUm => "film_um",
            Self::ThicknessUm => "thickness_um",
            Self::DiameterUm => "diameter_um",
            Self::DiameterMeanUm => "diameter_mean_um",
            Self::DiameterRelSd => "diameter_rel_sd",
            Self::Coverage => "coverage",
            Self::Count => "count",
            Self::RoughnessRmsUm => "roughness_rms_um",
            Self::RoughnessCorrelationUm => "roughness_correlation_um",
            Self::PsfSdUm => "psf_sd_um",
            Self::ZStepUm => "z_step_um",
            Self::HeightNoiseSdUm => "height_noise_sd_um",
            Self::IntensityFlake => "intensity_flake",
            Self::IntensityBackground => "intensity_background",
            Self::IntensityNoiseSd => "intensity_noise_sd",
            Self::StackZStepUm => "stack_z_step_um",
            Self::StackSlices => "stack_slices",
            Self::StackZFirstUm => "stack_z_first_um",
            Self::AxialFwhmUm => "axial_fwhm_um",
            Self::Photons => "photons",
            Self::ReadNoise => "read_noise",
            Self::ApertureSin => "aperture_sin",
            Self::Slice => "slice",
        }
    }
}

impl std::fmt::Display for Param {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

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

    /// The typical diameter, µm: the fixed value or the log-normal mean.
    pub fn typical_um(&self) -> f64 {
        match *self {
            Self::Fixed(d) => d,
            Self::LogNormal { mean_um, .. } => mean_um,
        }
    }

    /// Probability that a drawn diameter exceeds `x_um` (exact for the clipped
    /// log-normal: `(Φ(z(3m)) − Φ(z(max(x, m/4)))) / (Φ(z(3m)) − Φ(z(m/4)))` with
    /// `z(x) = (ln x − μ)/σ`).
    fn exceeds(&self, x_um: f64) -> f64 {
        match *self {
            Self::Fixed(d) => {
                if d > x_um {
                    1.0
                } else {
                    0.0
                }
            }
            Self::LogNormal { mean_um, rel_sd } => {
                let (lo, hi) = (0.25 * mean_um, 3.0 * mean_um);
                if x_um >= hi {
                    return 0.0;
                }
                if rel_sd == 0.0 {
                    return if mean_um > x_um { 1.0 } else { 0.0 };
                }
                let var = (1.0 + rel_sd * rel_sd).ln();
                let (mu, sd) = (mean_um.ln() - 0.5 * var, var.sqrt());
                let phi = |x: f64| {
                    use statrs::distribution::{ContinuousCDF, Normal};
                    Normal::standard().cdf((x.ln() - mu) / sd)
                };
                let total = phi(hi) - phi(lo);
                if total <= 0.0 {
                    return if mean_um > x_um { 1.0 } else { 0.0 };
                }
                ((phi(hi) - phi(x_um.max(lo))) / total).clamp(0.0, 1.0)
            }
        }
    }
}

/// Half the height a disc of diameter `d` and thickness `t` (µm) spans when its normal
/// has `z` component `nz` (the cosine of its tilt): `(t cos θ + d sin θ)/2`, µm.
pub(crate) fn half_height(diameter_um: f64, thickness_um: f64, nz: f64) -> f64 {
    let nz = nz.clamp(0.0, 1.0);
    0.5 * (thickness_um * nz + diameter_um * (1.0 - nz * nz).sqrt())
}

/// The expected fraction of flakes that cannot lie inside the film at their tilt
/// (module docs, the film rule): `∫ p(θ) P(D > (film − t cos θ)/sin θ) dθ`, by 2000
/// panels of `Orientation::mass_between` (exact per panel) times the diameter tail at the
/// panel's midpoint.
fn misfit_fraction(spec: &LayerSpec) -> f64 {
    let (film, t) = (spec.film_um, spec.thickness_um);
    if spec.orientation.is_delta() {
        // All flakes flat: they fit when t ≤ film, which is checked before.
        return if t > film { 1.0 } else { 0.0 };
    }
    let panels = 2000;
    let step = std::f64::consts::FRAC_PI_2 / f64::from(panels);
    (0..panels)
        .map(|k| {
            let (a, b) = (f64::from(k) * step, f64::from(k + 1) * step);
            let mid = 0.5 * (a + b);
            let mass = spec.orientation.mass_between(a, b);
            if mass == 0.0 {
                return 0.0;
            }
            let room = film - t * mid.cos();
            let tail = if room <= 0.0 {
                1.0
            } else {
                spec.diameter.exceeds(room / mid.sin())
            };
            mass * tail
        })
        .sum::<f64>()
        .min(1.0)
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
    /// Film (coating) thickness, µm (default 38). Every flake lies inside `[0, film_um]`
    /// (module docs, the film rule).
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

fn check(param: Param, value: f64, ok: bool, expected: &'static str) -> Result<(), SynthError> {
    if ok && value.is_finite() {
        Ok(())
    } else {
        Err(SynthError::InvalidParameter {
            param,
            value,
            expected,
        })
    }
}

/// The checks of [`LayerParams::new`] on the flakes' sizes and amount, in the order
/// it reports them: the diameter distribution, then the coverage (at most
/// [`MAX_FLAKES`] flakes of this size on this map) or the count.
fn check_flakes(s: &LayerSpec) -> Result<(), SynthError> {
    match s.diameter {
        DiameterDistribution::Fixed(d) => check(Param::DiameterUm, d, d > 0.0, "finite and > 0")?,
        DiameterDistribution::LogNormal { mean_um, rel_sd } => {
            check(
                Param::DiameterMeanUm,
                mean_um,
                mean_um > 0.0,
                "finite and > 0",
            )?;
            check(
                Param::DiameterRelSd,
                rel_sd,
                (0.0..=2.0).contains(&rel_sd),
                "finite, in [0, 2]",
            )?;
        }
    }
    match s.amount {
        FlakeAmount::Coverage(c) => {
            check(
                Param::Coverage,
                c,
                c > 0.0 && c <= 100.0,
                "finite, in (0, 100]",
            )?;
            // The number of flakes that coverage takes, as for a count: c · A over the
            // mean true area π E[d²]/4 (E[d²] = m²(1 + rel_sd²) for the log-normal).
            let margin = s.diameter.max_um();
            let region = (s.nx as f64 * s.dx_um + margin) * (s.ny as f64 * s.dy_um + margin);
            let mean_d2 = match s.diameter {
                DiameterDistribution::Fixed(d) => d * d,
                DiameterDistribution::LogNormal { mean_um, rel_sd } => {
                    mean_um * mean_um * (1.0 + rel_sd * rel_sd)
                }
            };
            let expected = c * region / (std::f64::consts::PI * mean_d2 / 4.0);
            check(
                Param::Coverage,
                c,
                expected <= MAX_FLAKES as f64,
                "a coverage that takes at most 10^7 flakes of this size on this map",
            )?;
        }
        FlakeAmount::Count(n) => {
            if n == 0 || n > MAX_FLAKES {
                return Err(SynthError::InvalidParameter {
                    param: Param::Count,
                    value: n as f64,
                    expected: "in [1, 10^7]",
                });
            }
        }
    }
    Ok(())
}

impl LayerParams {
    /// Validates `spec`.
    ///
    /// # Errors
    /// [`SynthError::EmptyMap`] / [`SynthError::TooLarge`] for a bad size,
    /// [`SynthError::InvalidParameter`] naming the first field that is not finite or out
    /// of range, [`SynthError::FilmThinnerThanFlakes`] and [`SynthError::FlakesDoNotFit`]
    /// for flakes that cannot lie inside the film (module docs, the film rule).
    pub fn new(spec: LayerSpec) -> Result<Self, SynthError> {
        let s = &spec;
        if s.nx == 0 || s.ny == 0 {
            return Err(SynthError::EmptyMap { nx: s.nx, ny: s.ny });
        }
        if s.nx.checked_mul(s.ny).is_none_or(|n| n > MAX_PIXELS) {
            return Err(SynthError::TooLarge { nx: s.nx, ny: s.ny });
        }
        check(Param::DxUm, s.dx_um, s.dx_um > 0.0, "finite and > 0")?;
        check(Param::DyUm, s.dy_um, s.dy_um > 0.0, "finite and > 0")?;
        check(
            Param::FilmUm,
            s.film_um,
            s.film_um >= 0.0,
            "finite and >= 0",
        )?;
        check(
            Param::ThicknessUm,
            s.thickness_um,
            s.thickness_um >= 0.0,
            "finite and >= 0",
        )?;
        check_flakes(s)?;
        let r = s.roughness;
        check(
            Param::RoughnessRmsUm,
            r.rms_um,
            r.rms_um >= 0.0,
            "finite and >= 0",
        )?;
        check(
            Param::RoughnessCorrelationUm,
            r.correlation_um,
            r.correlation_um >= 0.0,
            "finite and >= 0",
        )?;
        let c = s.confocal;
        check(
            Param::PsfSdUm,
            c.psf_sd_um,
            c.psf_sd_um >= 0.0,
            "finite and >= 0",
        )?;
        check(
            Param::ZStepUm,
            c.z_step_um,
            c.z_step_um >= 0.0,
            "finite and >= 0",
        )?;
        check(
            Param::HeightNoiseSdUm,
            c.noise_sd_um,
            c.noise_sd_um >= 0.0,
            "finite and >= 0",
        )?;
        let i = s.intensity;
        check(
            Param::IntensityFlake,
            i.flake,
            i.flake > 0.0 && i.flake <= 1.0,
            "finite, in (0, 1]",
        )?;
        check(
            Param::IntensityBackground,
            i.background,
            (0.0..i.flake).contains(&i.background),
            "finite, >= 0 and below the flake level",
        )?;
        check(
            Param::IntensityNoiseSd,
            i.noise_sd,
            i.noise_sd >= 0.0,
            "finite and >= 0",
        )?;
        // Keep the blur and roughness kernels (radius 4 sd) and the margin within reason.
        let pitch = s.dx_um.min(s.dy_um);
        check(
            Param::PsfSdUm,
            c.psf_sd_um,
            c.psf_sd_um / pitch <= 256.0,
            "at most 256 pixels",
        )?;
        check(
            Param::RoughnessCorrelationUm,
            r.correlation_um,
            r.correlation_um / pitch <= 512.0,
            "at most 512 pixels",
        )?;
        // The film rule (module docs).
        if s.thickness_um > s.film_um {
            return Err(SynthError::FilmThinnerThanFlakes {
                film_um: s.film_um,
                thickness_um: s.thickness_um,
            });
        }
        let fraction = misfit_fraction(s);
        if fraction > MAX_REDRAWN_FRACTION {
            return Err(SynthError::FlakesDoNotFit {
                film_um: s.film_um,
                diameter_um: s.diameter.typical_um(),
                max_diameter_um: s.diameter.max_um(),
                thickness_um: s.thickness_um,
                fraction,
            });
        }
        Ok(Self { spec })
    }

    /// The validated specification.
    pub fn spec(&self) -> &LayerSpec {
        &self.spec
    }
}
