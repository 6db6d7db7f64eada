//! Parameters of a three-dimensional flake layer, validated once.
//!
//! Units: lengths in micrometres, angles in radians, densities in g/cm³. The film
//! occupies `−film_um ≤ z ≤ 0` under its top interface `z = 0`; depths are measured
//! downward from the top interface (`depth = −z`). The tile is `[0, tile_um)²` and
//! periodic in `x` and `y`.

use flakescatter_stats::Orientation;

use crate::VolumeError;

/// Density of aluminium used by [`Amount::MassLoading`], g/cm³.
pub const ALUMINIUM_DENSITY_G_CM3: f64 = 2.70;

/// A typical density of a dry acrylic or polyester–melamine binder, g/cm³ (a default
/// for callers; [`Amount::MassLoading`] always takes the binder density explicitly).
pub const TYPICAL_BINDER_DENSITY_G_CM3: f64 = 1.2;

/// Default number of centre positions tried for one flake before placement gives up
/// ([`LayerSpec::max_attempts`]).
pub const DEFAULT_MAX_ATTEMPTS: u32 = 2000;

/// Largest number of flakes a layer may hold (memory guard: about 100 bytes each). The
/// tracer takes at most `2²⁴ − 1` (its grid keeps a flake's index in 24 bits).
pub const MAX_FLAKES: usize = 20_000_000;

/// How flake diameters are drawn.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Diameter {
    /// Every flake has this diameter, µm.
    Fixed(f64),
    /// Log-normal with mean `mean_um` and relative standard deviation `rel_sd`
    /// (`ln d` has `σ² = ln(1 + rel_sd²)`, `μ = ln(mean) − σ²/2`), truncated to
    /// `[mean/4, 3 mean]` by redrawing (the same truncation as the synthetic layers of
    /// `flakescatter-synth`; it removes less than 1e-7 of the mass for `rel_sd ≤ 0.25`).
    LogNormal {
        /// Mean diameter before truncation, µm.
        mean_um: f64,
        /// Relative standard deviation (sd / mean), in `[0, 1]`.
        rel_sd: f64,
    },
}

impl Diameter {
    /// Largest diameter that can be drawn, µm.
    #[must_use]
    pub fn max_um(&self) -> f64 {
        match *self {
            Self::Fixed(d) => d,
            Self::LogNormal { mean_um, rel_sd } => {
                if rel_sd == 0.0 {
                    mean_um
                } else {
                    3.0 * mean_um
                }
            }
        }
    }

    /// Mean diameter (before truncation), µm.
    #[must_use]
    pub fn mean_um(&self) -> f64 {
        match *self {
            Self::Fixed(d) => d,
            Self::LogNormal { mean_um, .. } => mean_um,
        }
    }
}

/// How much pigment the film holds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Amount {
    /// Flake volume per film volume, in `[0, 1)`. Flakes are added while their summed
    /// volume is below `fraction · tile² · film`, so the realised fraction exceeds the
    /// request by less than one flake's volume over the film volume.
    VolumeFraction(f64),
    /// Mass fraction `w` of aluminium in the dry film (pigment + binder solids, voids
    /// ignored), converted to a volume fraction with
    /// `φ = (w/ρ_Al) / (w/ρ_Al + (1 − w)/ρ_binder)`, `ρ_Al` =
    /// [`ALUMINIUM_DENSITY_G_CM3`].
    MassLoading {
        /// Mass fraction of aluminium, in `[0, 1)`.
        fraction: f64,
        /// Density of the dry binder, g/cm³ (> 0).
        binder_density_g_cm3: f64,
    },
    /// Exactly this many flakes.
    Count(usize),
}

impl Amount {
    /// The volume fraction this amount stands for (`None` for [`Amount::Count`]).
    #[must_use]
    pub fn volume_fraction(&self) -> Option<f64> {
        match *self {
            Self::VolumeFraction(f) => Some(f),
            Self::MassLoading {
                fraction,
                binder_density_g_cm3,
            } => {
                let al = fraction / ALUMINIUM_DENSITY_G_CM3;
                let binder = (1.0 - fraction) / binder_density_g_cm3;
                Some(if al > 0.0 { al / (al + binder) } else { 0.0 })
            }
            Self::Count(_) => None,
        }
    }
}

/// Where flake centres lie in depth (µm below the top interface). Every flake must lie
/// wholly inside the film: a flake whose half-extent in `z` is
/// `h = r sin θn + (t/2) cos θn` can only have its centre at depths `[h, film − h]`,
/// so each flake's centre is drawn from the rule below **restricted to that range**
/// (exact inverse-CDF sampling of the restricted density); a flake for which the rule
/// has no depth in that range is put at the nearest depth that is, and one taller than
/// the film gets a smaller diameter (module [`crate::inside`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Depth {
    /// Uniform over the whole film (the default): `[h, film − h]` for each flake.
    WholeFilm,
    /// Uniform between `top_um` and `bottom_um` (`0 ≤ top ≤ bottom ≤ film`;
    /// `top = bottom` puts every centre at that depth).
    Uniform {
        /// Shallowest centre depth, µm.
        top_um: f64,
        /// Deepest centre depth, µm.
        bottom_um: f64,
    },
    /// A piecewise-constant density of centre depth: `n + 1` increasing edges in
    /// `[0, film]` (µm) and `n` non-negative weights (relative probability of each bin).
    Profile {
        /// Bin edges, µm below the top interface.
        edges_um: Vec<f64>,
        /// Relative weight of each bin.
        weights: Vec<f64>,
    },
}

/// Everything that defines the flake layer's geometry. Build with [`LayerSpec::new`],
/// adjust the fields, validate with [`LayerParams::new`].
#[derive(Debug, Clone, PartialEq)]
pub struct LayerSpec {
    /// Film thickness, µm (> 0; default 38, the paper's film).
    pub film_um: f64,
    /// Flake diameters (default log-normal, mean 16 µm, relative sd 0.25).
    pub diameter: Diameter,
    /// Flake thickness, µm (> 0; default 1).
    pub thickness_um: f64,
    /// Area-weighted distribution of flake normals, sampled with
    /// [`Orientation::sample_normal`] once per flake (independent of its diameter, so
    /// area- and number-weighting agree).
    pub orientation: Orientation,
    /// How many flakes.
    pub amount: Amount,
    /// Where their centres lie in depth (default the whole film).
    pub depth: Depth,
    /// Side of the periodic square tile, µm (must exceed the largest flake's lateral
    /// extent, `d_max + t`).
    pub tile_um: f64,
    /// Centre positions tried per flake before placement fails with
    /// [`VolumeError::LoadingTooHigh`] (≥ 1; default [`DEFAULT_MAX_ATTEMPTS`]).
    pub max_attempts: u32,
    /// Seed of every draw of the layer.
    pub seed: u64,
}

impl LayerSpec {
    /// The paper's coating in a tile of side `tile_um`: 38 µm film, log-normal 16 µm
    /// flakes (relative sd 0.25), 1 µm thick, 5 % aluminium by mass in a binder of
    /// [`TYPICAL_BINDER_DENSITY_G_CM3`], centres anywhere in the film.
    #[must_use]
    pub fn new(orientation: Orientation, tile_um: f64, seed: u64) -> Self {
        Self {
            film_um: 38.0,
            diameter: Diameter::LogNormal {
                mean_um: 16.0,
                rel_sd: 0.25,
            },
            thickness_um: 1.0,
            orientation,
            amount: Amount::MassLoading {
                fraction: 0.05,
                binder_density_g_cm3: TYPICAL_BINDER_DENSITY_G_CM3,
            },
            depth: Depth::WholeFilm,
            tile_um,
            max_attempts: DEFAULT_MAX_ATTEMPTS,
            seed,
        }
    }
}

/// A validated [`LayerSpec`].
#[derive(Debug, Clone, PartialEq)]
pub struct LayerParams {
    spec: LayerSpec,
    /// Depth density as bins `(lo, hi, weight)`, or a single depth.
    depth: DepthBins,
}

#[derive(Debug, Clone, PartialEq)]
pub(crate) enum DepthBins {
    /// Every centre at this depth, µm.
    Fixed(f64),
    /// Piecewise-constant density: `(lo, hi, weight)`, weights > 0.
    Bins(Vec<(f64, f64, f64)>),
}

fn param(name: &'static str, value: f64, expected: &'static str) -> VolumeError {
    VolumeError::Parameter {
        name,
        value,
        expected,
    }
}

impl LayerParams {
    /// Validate a spec.
    ///
    /// # Errors
    /// [`VolumeError::Parameter`] naming the first invalid field (`film_um`,
    /// `thickness_um`, `diameter_um`, `diameter_rel_sd`, `volume_fraction`,
    /// `mass_loading`, `binder_density`, `depth_um`, `depth_profile`, `max_attempts`,
    /// `tile_um`); [`VolumeError::TileTooSmall`] when a flake would not fit in the tile;
    /// [`VolumeError::FilmTooThin`] when not even a flat flake fits in the film;
    /// [`VolumeError::TooManyFlakes`] when the amount asks for more than [`MAX_FLAKES`].
    pub fn new(spec: LayerSpec) -> Result<Self, VolumeError> {
        let f = spec.film_um;
        if !(f.is_finite() && f > 0.0) {
            return Err(param("film_um", f, "a finite thickness > 0 µm"));
        }
        let t = spec.thickness_um;
        if !(t.is_finite() && t > 0.0) {
            return Err(param("thickness_um", t, "a finite thickness > 0 µm"));
        }
        match spec.diameter {
            Diameter::Fixed(d) => {
                if !(d.is_finite() && d > 0.0) {
                    return Err(param("diameter_um", d, "a finite diameter > 0 µm"));
                }
            }
            Diameter::LogNormal { mean_um, rel_sd } => {
                if !(mean_um.is_finite() && mean_um > 0.0) {
                    return Err(param(
                        "diameter_um",
                        mean_um,
                        "a finite mean diameter > 0 µm",
                    ));
                }
                if !(rel_sd.is_finite() && (0.0..=1.0).contains(&rel_sd)) {
                    return Err(param("diameter_rel_sd", rel_sd, "a relative sd in [0, 1]"));
                }
            }
        }
        let l = spec.tile_um;
        if !(l.is_finite() && l > 0.0) {
            return Err(param("tile_um", l, "a finite tile side > 0 µm"));
        }
        let extent = spec.diameter.max_um() + t;
        if l <= extent {
            return Err(VolumeError::TileTooSmall {
                tile_um: l,
                flake_extent_um: extent,
            });
        }
        if t >= f {
            return Err(VolumeError::FilmTooThin {
                film_um: f,
                needed_um: t,
            });
        }
        if spec.max_attempts == 0 {
            return Err(param("max_attempts", 0.0, "at least 1"));
        }
        match spec.amount {
            Amount::VolumeFraction(v) => {
                if !(v.is_finite() && (0.0..1.0).contains(&v)) {
                    return Err(param("volume_fraction", v, "a fraction in [0, 1)"));
                }
            }
            Amount::MassLoading {
                fraction,
                binder_density_g_cm3,
            } => {
                if !(fraction.is_finite() && (0.0..1.0).contains(&fraction)) {
                    return Err(param("mass_loading", fraction, "a mass fraction in [0, 1)"));
                }
                if !(binder_density_g_cm3.is_finite() && binder_density_g_cm3 > 0.0) {
                    return Err(param(
                        "binder_density",
                        binder_density_g_cm3,
                        "a finite density > 0 g/cm³",
                    ));
                }
            }
            Amount::Count(_) => {}
        }
        // Memory guard on the number of flakes the amount asks for.
        let expected = match spec.amount {
            Amount::Count(c) => c as f64,
            _ => {
                let phi = spec.amount.volume_fraction().unwrap_or(0.0);
                let r = 0.5 * spec.diameter.mean_um();
                let v_min = std::f64::consts::PI * r * r * t / 16.0;
                phi * l * l * f / v_min
            }
        };
        if expected > MAX_FLAKES as f64 {
            return Err(VolumeError::TooManyFlakes {
                requested: expected,
                max: MAX_FLAKES,
            });
        }
        let depth = match &spec.depth {
            Depth::WholeFilm => DepthBins::Bins(vec![(0.0, f, 1.0)]),
            &Depth::Uniform { top_um, bottom_um } => {
                if !(top_um.is_finite() && top_um >= 0.0 && top_um <= f) {
                    return Err(param("depth_um", top_um, "a top depth in [0, film_um]"));
                }
                if !(bottom_um.is_finite() && bottom_um >= top_um && bottom_um <= f) {
                    return Err(param(
                        "depth_um",
                        bottom_um,
                        "a bottom depth in [top, film_um]",
                    ));
                }
                if bottom_um == top_um {
                    DepthBins::Fixed(top_um)
                } else {
                    DepthBins::Bins(vec![(top_um, bottom_um, 1.0)])
                }
            }
            Depth::Profile { edges_um, weights } => {
                if weights.is_empty() || edges_um.len() != weights.len() + 1 {
                    return Err(param(
                        "depth_profile",
                        edges_um.len() as f64,
                        "n + 1 edges for n >= 1 weights",
                    ));
                }
                for (i, &e) in edges_um.iter().enumerate() {
                    if !(e.is_finite() && (0.0..=f).contains(&e)) {
                        return Err(param("depth_profile", e, "edges in [0, film_um]"));
                    }
                    if i > 0 && e <= edges_um[i - 1] {
                        return Err(param("depth_profile", e, "strictly increasing edges"));
                    }
                }
                let mut bins = Vec::new();
                for (i, &w) in weights.iter().enumerate() {
                    if !(w.is_finite() && w >= 0.0) {
                        return Err(param("depth_profile", w, "finite weights >= 0"));
                    }
                    if w > 0.0 {
                        bins.push((edges_um[i], edges_um[i + 1], w));
                    }
                }
                if bins.is_empty() {
                    return Err(param("depth_profile", 0.0, "at least one weight > 0"));
                }
                DepthBins::Bins(bins)
            }
        };
        Ok(Self { spec, depth })
    }

    /// The validated spec.
    #[must_use]
    pub fn spec(&self) -> &LayerSpec {
        &self.spec
    }

    pub(crate) fn depth_bins(&self) -> &DepthBins {
        &self.depth
    }
}
