//! The paint model: clear coat + flakes + base, one BRDF per colour channel
//! (physics.md §12).
//!
//! Conventions: radians; the frame, `θi` and the exit directions `r` of
//! `flakescatter_optics` (source on the `−x` side, `r.z > 0`, `φr = 0` the specular
//! half-plane); BRDFs in sr⁻¹. For channel `k`,
//!
//! `f_k(θi, r) = f_coat + c s_k A_k G1(θt) G1(θ2) τ(θi) τ(θo) f_D,k + f_base,k`
//!
//! * `f_coat`: the coat surface's rough reflection ([`crate::coat`]); a flat coat adds a
//!   delta at specular (not in the point BRDF);
//! * `f_D,k`: the distribution model's point BRDF (physics.md §4, exact unpolarised
//!   Fresnel factors, flakes of the metal's complex index at the channel's wavelength),
//!   for a fully covering layer; `c` the coverage, `s_k ∈ [0, 1]` the flake reflectance
//!   scale, `A_k = exp(−t_k (1/cos θt + 1/cos θ2))` the binder's tint over the flakes
//!   (`t_k` its Napierian optical depth at normal incidence, physics.md §12.9; the path
//!   of [`PathAbsorption`] with the refracted inside angles), `G1` the flake layer's
//!   shadowing ([`crate::layer`]), `τ` the coat surface's
//!   [`transmission_factor`](crate::coat::CoatSurface::transmission_factor);
//! * `f_base,k`: the Lambertian base ([`crate::base`]) of albedo `ρ_k`.
//!
//! Every term is reciprocal, and the sum conserves energy for every valid parameter set
//! (physics.md §12.4; tests integrate it).

use flakescatter_gaussian::{DistributionModel, Incidence, ModelOptions};
use flakescatter_optics::absorption::{FlakeDepth, PathAbsorption};
use flakescatter_optics::{Vec3, fresnel};
use flakescatter_stats::Orientation;

use crate::PaintError;
use crate::base::base_brdf;
use crate::channel::Channel;
use crate::coat::{CoatParams, CoatSurface};
use crate::layer::FlakeShadowing;
pub use crate::metal::FlakeMetal;

/// The parameters of one channel.
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelParams {
    /// The channel.
    pub channel: Channel,
    /// Flake reflectance scale `s ∈ [0, 1]`: the flakes reflect `s` times the metal's
    /// Fresnel reflectance (a tint of the binder over them, or duller flakes).
    pub flake_scale: f64,
    /// Albedo `ρ ∈ [0, 1]` of the Lambertian base coat.
    pub base_albedo: f64,
    /// Tint `t ≥ 0` of the binder over the flakes: its Napierian optical depth above
    /// them at normal incidence, at the channel's wavelength (`α d`, dimensionless);
    /// the flake term is multiplied by `exp(−t (1/cos θt + 1/cos θ2))` with the inside
    /// angles of the incident and the exit ray (physics.md §12.9). 0: no tint (the
    /// model without the factor, to the bit). The base term is not tinted: its fitted
    /// albedo carries what the binder takes from the light that reaches it.
    pub tint: f64,
}

/// A paint: coat, flakes and base, with one parameter set for all incidences and one
/// flake scale and base albedo per channel.
#[derive(Debug, Clone, PartialEq)]
pub struct PaintParams {
    /// The coat and its surface.
    pub coat: CoatParams,
    /// The flakes' orientation distribution (not a delta).
    pub orientation: Orientation,
    /// The flakes' coverage `c ∈ [0, 1]`: the fraction of the coating's area they cover
    /// (seen along any direction: flakes lie nearly flat).
    pub coverage: f64,
    /// The flake metal.
    pub flake_metal: FlakeMetal,
    /// The channels, at least one, with distinct names.
    pub channels: Vec<ChannelParams>,
}

/// A paint model ready to evaluate.
#[derive(Debug, Clone)]
pub struct PaintModel {
    params: PaintParams,
    coat: CoatSurface,
    /// One distribution model per channel (their flake optics differ).
    flakes: Vec<DistributionModel>,
    shadowing: FlakeShadowing,
    /// Internal diffuse reflectance of the coat's surface.
    r_i: f64,
    /// Per channel, the binder's absorption over the flakes (`None`: no tint).
    tints: Vec<Option<PathAbsorption>>,
}

/// The three terms of a point BRDF, sr⁻¹.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Terms {
    /// The coat surface's rough reflection.
    pub coat: f64,
    /// The flakes.
    pub flakes: f64,
    /// The base.
    pub base: f64,
}

impl Terms {
    /// `coat + flakes + base`.
    #[must_use]
    pub fn total(&self) -> f64 {
        self.coat + self.flakes + self.base
    }
}

/// What depends only on the incidence angle.
#[derive(Debug, Clone)]
pub struct PaintIncidence {
    /// Incidence angle, radians.
    pub theta_i: f64,
    /// Toward the source, `(−sin θi, 0, cos θi)`.
    pub wi: Vec3,
    /// Per channel, the distribution model's incidence.
    flakes: Vec<Incidence>,
    /// `T'(θi) = τ(θi) T_av(θi)`.
    t_in: f64,
    /// `τ(θi)`.
    tau_in: f64,
    /// `G1(θt)`.
    g1_in: f64,
    /// `cos θt`, the inside cosine of the refracted incident ray.
    cos_t: f64,
}

impl PaintModel {
    /// The model of `params`.
    ///
    /// # Errors
    /// [`PaintError::Parameter`] for a value out of range (named), a delta orientation,
    /// no channels or two with one name; [`PaintError::Channel`] is not raised here (the
    /// channels are already parsed).
    pub fn new(params: PaintParams) -> Result<Self, PaintError> {
        let coat = CoatSurface::new(params.coat.clone())?;
        if !(0.0..=1.0).contains(&params.coverage) {
            return Err(PaintError::Parameter(format!(
                "coverage = {}: expected a fraction in [0, 1]",
                params.coverage
            )));
        }
        if params.channels.is_empty() {
            return Err(PaintError::Parameter("no channels".into()));
        }
        for (i, c) in params.channels.iter().enumerate() {
            if params.channels[..i]
                .iter()
                .any(|d| d.channel.name == c.channel.name)
            {
                return Err(PaintError::Parameter(format!(
                    "channel `{}` is given twice",
                    c.channel.name
                )));
            }
            if !(0.0..=1.0).contains(&c.flake_scale) {
                return Err(PaintError::Parameter(format!(
                    "flake scale of channel `{}` = {}: expected [0, 1] (a flake cannot reflect more than its metal)",
                    c.channel.name, c.flake_scale
                )));
            }
            if !(0.0..=1.0).contains(&c.base_albedo) {
                return Err(PaintError::Parameter(format!(
                    "base albedo of channel `{}` = {}: expected [0, 1]",
                    c.channel.name, c.base_albedo
                )));
            }
            if !(c.tint.is_finite() && c.tint >= 0.0) {
                return Err(PaintError::Parameter(format!(
                    "tint of channel `{}` = {}: expected a finite optical depth >= 0",
                    c.channel.name, c.tint
                )));
            }
        }
        let tints = params
            .channels
            .iter()
            .map(|c| tint_absorption(c.tint))
            .collect::<Result<Vec<_>, _>>()?;
        let n = params.coat.n;
        let mut flakes = Vec::with_capacity(params.channels.len());
        for c in &params.channels {
            let options = ModelOptions {
                flake: params.flake_metal.at(&c.channel, n)?,
                ..ModelOptions::default()
            };
            flakes.push(
                DistributionModel::new(params.orientation.clone(), n, options)
                    .map_err(|e| PaintError::Parameter(format!("flakes: {e}")))?,
            );
        }
        let shadowing = FlakeShadowing::new(&params.orientation, n);
        Ok(Self {
            r_i: coat.internal_diffuse_reflectance(),
            tints,
            coat,
            flakes,
            shadowing,
            params,
        })
    }

    /// The parameters.
    #[must_use]
    pub fn params(&self) -> &PaintParams {
        &self.params
    }

    /// The coat surface.
    #[must_use]
    pub fn coat(&self) -> &CoatSurface {
        &self.coat
    }

    /// The flakes' shadowing table.
    #[must_use]
    pub fn shadowing(&self) -> &FlakeShadowing {
        &self.shadowing
    }

    /// The coat surface's internal diffuse reflectance `r_i`.
    #[must_use]
    pub fn internal_reflectance(&self) -> f64 {
        self.r_i
    }

    /// The index of the channel named `name`.
    #[must_use]
    pub fn channel_index(&self, name: &str) -> Option<usize> {
        self.params
            .channels
            .iter()
            .position(|c| c.channel.name == name)
    }

    /// Precompute the incidence `theta_i`.
    ///
    /// # Errors
    /// [`PaintError::Geometry`] unless `θi ∈ [0, π/2)`.
    pub fn incidence(&self, theta_i: f64) -> Result<PaintIncidence, PaintError> {
        let flakes = self
            .flakes
            .iter()
            .map(|m| m.incidence(theta_i))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| PaintError::Geometry(e.to_string()))?;
        let n = self.params.coat.n;
        let mu = theta_i.cos();
        let tau_in = self.coat.transmission_factor(mu);
        let t_in = tau_in * fresnel::air_to_coating(theta_i, n).t_av();
        let cos_t = flakes[0].cos_t;
        let g1_in = self.shadowing.g1(cos_t.clamp(-1.0, 1.0).acos());
        Ok(PaintIncidence {
            cos_t,
            theta_i,
            wi: Vec3::new(-theta_i.sin(), 0.0, mu),
            flakes,
            t_in,
            tau_in,
            g1_in,
        })
    }

    /// The three terms of the point BRDF of channel `k` at the exit direction `r` (a
    /// unit vector), sr⁻¹; zero below the horizon. `k` must be below the number of
    /// channels.
    #[must_use]
    pub fn terms(&self, inc: &PaintIncidence, r: &Vec3, k: usize) -> Terms {
        if r.z <= 0.0 {
            return Terms {
                coat: 0.0,
                flakes: 0.0,
                base: 0.0,
            };
        }
        let n = self.params.coat.n;
        let ch = &self.params.channels[k];
        let coat = self.coat.brdf(&inc.wi, r);
        let tau_out = self.coat.transmission_factor(r.z);
        // Inside exit angle: cos θ2 = sqrt(n² − 1 + r.z²)/n (as the distribution model).
        let c2 = (n * n - 1.0 + r.z * r.z).max(0.0).sqrt() / n;
        let fd = self.flakes[k].brdf(&inc.flakes[k], r);
        let flakes = if fd == 0.0 {
            0.0
        } else {
            self.params.coverage
                * ch.flake_scale
                * inc.g1_in
                * self.shadowing.g1(c2.clamp(-1.0, 1.0).acos())
                * inc.tau_in
                * tau_out
                * fd
                * self.tints[k].map_or(1.0, |a| a.factor(inc.cos_t, c2))
        };
        let t_out = tau_out * fresnel::power_from_cosines(r.z, c2, n).t_av();
        let gap = 1.0 - self.params.coverage;
        let base = base_brdf(gap * gap, ch.base_albedo, inc.t_in, t_out, n, self.r_i);
        Terms { coat, flakes, base }
    }

    /// The point BRDF of channel `k`, sr⁻¹ (the sum of [`PaintModel::terms`]).
    #[must_use]
    pub fn brdf(&self, inc: &PaintIncidence, r: &Vec3, k: usize) -> f64 {
        self.terms(inc, r, k).total()
    }

    /// The delta the flat coat reflects into the specular direction, a fraction of the
    /// beam (0 unless the coat's own roughness is 0).
    #[must_use]
    pub fn specular_delta(&self, theta_i: f64) -> f64 {
        self.coat.specular_delta(theta_i)
    }
}

/// The binder's absorption over the flakes for the tint `t` (physics.md §12.9): the
/// path factor of [`PathAbsorption`] with `α = t` per µm and the flakes 1 µm deep, so
/// that `α d = t`; `None` for `t = 0` (no factor at all, so an untinted paint is the
/// model without it to the bit).
///
/// # Errors
/// [`PaintError::Parameter`] for a negative or non-finite `t`.
pub fn tint_absorption(t: f64) -> Result<Option<PathAbsorption>, PaintError> {
    if t == 0.0 {
        return Ok(None);
    }
    PathAbsorption::new(t, FlakeDepth::At { depth_um: 1.0 })
        .map(Some)
        .map_err(|e| PaintError::Parameter(format!("tint {t}: {e}")))
}
