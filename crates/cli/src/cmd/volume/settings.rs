//! `volume`'s argument validation: the flags checked and turned into the facade's
//! settings (instrument, orientation, layer), and the facade's errors explained in
//! terms of the flags they are about.

use anyhow::bail;
use flakescatter::film::{StackFlakeError, stack_flake};
use flakescatter::optics::flake::FlakeReflectance;
use flakescatter::volume::{Amount, Depth, Diameter, RimRule, Substrate};
use flakescatter::{PipelineError, VolumeSettings};

use super::{Args, Rims, SubstrateKind};
use crate::flags::{InstrumentArgs, OpticsArgs};

/// Largest number of rays per incidence (the tracer's limit, 2^40).
/// Largest `--rays`.
pub(super) const MAX_RAYS: u64 = 1 << 40;

/// Checks a length flag: finite and > 0 µm.
fn positive(flag: &str, v: f64) -> anyhow::Result<f64> {
    if !(v.is_finite() && v > 0.0) {
        bail!("{flag} {v}: expected a finite length > 0 µm");
    }
    Ok(v)
}

/// A fraction flag in [0, 1).
fn fraction(flag: &str, v: f64, what: &str) -> anyhow::Result<f64> {
    if !(v.is_finite() && (0.0..1.0).contains(&v)) {
        bail!("{flag} {v}: expected {what} in [0, 1)");
    }
    Ok(v)
}

impl Args {
    /// The instrument and coating flags in the shape `model` parses them.
    pub(super) fn instrument_args(&self) -> InstrumentArgs {
        InstrumentArgs {
            optics: OpticsArgs {
                n: self.n,
                aperture: Some(self.aperture),
                transmission: Default::default(),
                weighting: Default::default(),
                flake_index: self.flake_index.clone(),
            },
            theta_i: self.theta_i.clone(),
            theta_s: self.theta_s.clone(),
            detectors: self.detectors.clone(),
            clearcoat: false,
        }
    }

    /// `--flake-stack` (with `--flake-core`) at `--wavelength` as the flake's
    /// reflectance, or `None` without `--flake-stack`.
    pub(super) fn stack_flake(&self) -> anyhow::Result<Option<FlakeReflectance>> {
        let Some(text) = self.flake_stack.as_deref() else {
            return Ok(None);
        };
        let Some(wl) = self.wavelength else {
            bail!(
                "--flake-stack needs --wavelength NM: an interference flake reflects differently at each wavelength (one wavelength per volume run)"
            );
        };
        let c = self.flake_core.as_deref();
        let flake = stack_flake(text, c, wl).map_err(|e| {
            let flag = match &e {
                StackFlakeError::Wavelength(_) => {
                    return anyhow::anyhow!(
                        "--wavelength {wl}: expected a finite wavelength > 0 nm"
                    );
                }
                StackFlakeError::Spec(_) => "--flake-stack".to_string(),
                StackFlakeError::AtWavelength(_) => format!("--flake-stack at --wavelength {wl}"),
                StackFlakeError::Core(_) => {
                    format!(
                        "--flake-core {} at --wavelength {wl}",
                        c.unwrap_or_default()
                    )
                }
            };
            anyhow::Error::new(e).context(flag)
        })?;
        Ok(Some(flake))
    }

    /// The layer and tracing settings; every error names its flag.
    pub(super) fn settings(&self) -> anyhow::Result<VolumeSettings> {
        let film = positive("--film-um", self.film_um)?;
        let d = positive("--diameter-um", self.diameter_um)?;
        let sd = self.diameter_rel_sd;
        if !(sd.is_finite() && (0.0..=1.0).contains(&sd)) {
            bail!("--diameter-rel-sd {sd}: expected a relative standard deviation in [0, 1]");
        }
        let t = positive("--thickness-um", self.thickness_um)?;
        if t >= film {
            bail!("--thickness-um {t}: a flake must be thinner than the film (--film-um {film})");
        }
        let amount = match (self.volume_fraction, self.mass_loading) {
            (Some(v), _) => {
                if let Some(b) = self.binder_density {
                    bail!(
                        "--binder-density {b} applies to --mass-loading only; --volume-fraction {v} needs no density"
                    );
                }
                Amount::VolumeFraction(fraction("--volume-fraction", v, "a volume fraction")?)
            }
            (None, m) => {
                let m = fraction("--mass-loading", m.unwrap_or(0.05), "a mass fraction")?;
                let b = self.binder_density.unwrap_or(1.2);
                if !(b.is_finite() && b > 0.0) {
                    bail!("--binder-density {b}: expected a finite density > 0 g/cm³");
                }
                Amount::MassLoading {
                    fraction: m,
                    binder_density_g_cm3: b,
                }
            }
        };
        let depth = match &self.depth_um {
            None => Depth::WholeFilm,
            Some(text) => {
                let parts: Vec<&str> = text.split(':').map(str::trim).collect();
                let values: Option<Vec<f64>> = parts.iter().map(|p| p.parse().ok()).collect();
                let Some([a, b]) = values.as_deref() else {
                    bail!("--depth-um {text}: expected two depths `A:B` in µm, e.g. 0:10");
                };
                let (a, b) = (*a, *b);
                if !(a.is_finite() && b.is_finite() && 0.0 <= a && a <= b) {
                    bail!(
                        "--depth-um {text}: expected finite depths 0 <= A <= B (µm below the top interface)"
                    );
                }
                if b > film {
                    bail!(
                        "--depth-um {text}: B = {b} µm is below the bottom of the film (--film-um {film})"
                    );
                }
                Depth::Uniform {
                    top_um: a,
                    bottom_um: b,
                }
            }
        };
        let tile = positive("--tile-um", self.tile_um)?;
        if self.rays == 0 || self.rays > MAX_RAYS {
            bail!(
                "--rays {}: expected a whole number from 1 to {MAX_RAYS}",
                self.rays
            );
        }
        let r = self.substrate_reflectance;
        if !(r.is_finite() && (0.0..=1.0).contains(&r)) {
            bail!("--substrate-reflectance {r}: expected a reflectance in [0, 1]");
        }
        let substrate = match (r > 0.0, self.substrate) {
            (false, _) => Substrate::Black,
            (true, SubstrateKind::Lambertian) => Substrate::Lambertian(r),
            (true, SubstrateKind::Mirror) => Substrate::Specular(r),
        };
        Ok(VolumeSettings {
            film_um: film,
            diameter: if sd == 0.0 {
                Diameter::Fixed(d)
            } else {
                Diameter::LogNormal {
                    mean_um: d,
                    rel_sd: sd,
                }
            },
            thickness_um: t,
            amount,
            depth,
            tile_um: tile,
            substrate,
            rims: match self.rims {
                Rims::Absorb => RimRule::Absorb,
                Rims::Ignore => RimRule::Ignore,
                Rims::Diffuse => RimRule::Diffuse,
            },
            rays: self.rays,
            layers: self.layers,
            seed: self.seed,
            ..VolumeSettings::default()
        })
    }

    /// The flag a loading error is about, as typed.
    pub(super) fn loading_flag(&self) -> String {
        match (self.volume_fraction, self.mass_loading) {
            (Some(v), _) => format!("--volume-fraction {v}"),
            (None, Some(m)) => format!("--mass-loading {m}"),
            (None, None) => "--mass-loading 0.05 (the default)".to_owned(),
        }
    }
}

/// The facade's error with the flags it is about named.
pub(super) fn explain(err: PipelineError, args: &Args) -> anyhow::Error {
    use flakescatter::volume::VolumeError as V;
    let flags = match &err {
        PipelineError::Volume(V::LoadingTooHigh { .. } | V::TooManyFlakes { .. }) => format!(
            "{}, --tile-um {}, --film-um {}, --depth-um {}",
            args.loading_flag(),
            args.tile_um,
            args.film_um,
            args.depth_um.as_deref().unwrap_or("(whole film)")
        ),
        PipelineError::Volume(V::TileTooSmall { .. }) => format!(
            "--tile-um {} with --diameter-um {} (largest drawn: 3 × the mean unless --diameter-rel-sd 0)",
            args.tile_um, args.diameter_um
        ),
        PipelineError::Volume(V::DepthRange { .. }) => format!(
            "--depth-um {} with --film-um {}, --diameter-um {} and the orientation",
            args.depth_um.as_deref().unwrap_or("(whole film)"),
            args.film_um,
            args.diameter_um
        ),
        PipelineError::Volume(V::Parameter { name, .. }) => format!("--{}", name.replace('_', "-")),
        _ => return err.into(),
    };
    anyhow::anyhow!("{flags}: {err}")
}
