//! `synth --stack-out`: the flags of the synthetic confocal z-stack (axial response,
//! noise, slices, page order), their checks, and the stack specification they give.

use std::path::PathBuf;

use flakescatter::io::stack::PageOrder;
use flakescatter::stack::covering_slices;
use flakescatter::synth::{AxialResponse, BitDepth, LayerParams, StackSpec, SyntheticStack};

use super::errors::invalid;

/// The axial response of a synthetic stack.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum AxialKind {
    /// exp(-4 ln2 u²/W²).
    Gaussian,
    /// (sin(a u)/(a u))², the paraxial plane-mirror response of a confocal microscope.
    Sinc2,
}

/// Which end of the stack page 0 is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum FirstPage {
    /// Page 0 is the lowest slice (ImageJ's convention).
    Bottom,
    /// Page 0 is the highest slice.
    Top,
}

impl FirstPage {
    /// The io crate's page order.
    pub fn order(self) -> PageOrder {
        match self {
            Self::Bottom => PageOrder::BottomFirst,
            Self::Top => PageOrder::TopFirst,
        }
    }
}

/// The confocal z-stack of the layer (`--stack-out`, docs/physics.md §9): each pixel's
/// axial response at its surface height, scaled by the flake's reflectivity and tilt,
/// with photon (Poisson) and read (Gaussian) noise.
#[derive(Debug, clap::Args)]
pub struct StackOutArgs {
    /// Write the layer's confocal z-stack here: a multi-page TIFF (.tif) with ImageJ
    /// metadata (pixel size, z step), one page per slice, --z-step-um apart, covering
    /// every height with 3 axial FWHM to spare (or --z-first-um/--slices). Read it with
    /// `flakescatter stack`; its heights are above the lowest slice (the JSON's
    /// stack.z_first_um above the substrate).
    #[arg(long, value_name = "STACK.tif")]
    pub stack_out: Option<PathBuf>,
    /// Axial response of a reflecting surface (docs/physics.md §9).
    #[arg(long, value_enum, default_value = "gaussian", requires = "stack_out")]
    pub axial: AxialKind,
    /// Full width at half maximum of the axial response, µm (0.5-0.7 µm for a high-NA
    /// objective).
    #[arg(
        long,
        value_name = "UM",
        default_value_t = 0.6,
        requires = "stack_out",
        allow_negative_numbers = true
    )]
    pub axial_fwhm_um: f64,
    /// Photoelectrons of a level-1, untilted mirror in focus (the shot noise: 2000 gives
    /// 2.2 % at the peak); a mirror in focus fills the sample scale.
    #[arg(
        long,
        value_name = "N",
        default_value_t = 2000.0,
        requires = "stack_out",
        allow_negative_numbers = true
    )]
    pub photons: f64,
    /// Read noise, sd in electrons.
    #[arg(
        long,
        value_name = "E",
        default_value_t = 4.0,
        requires = "stack_out",
        allow_negative_numbers = true
    )]
    pub read_noise: f64,
    /// Bits per sample: 8 or 16.
    #[arg(long, value_name = "BITS", default_value = "16", value_parser = ["8", "16"], requires = "stack_out")]
    pub bit_depth: String,
    /// sin α of the objective's half-angle in the medium around the flakes (NA / n), in
    /// (0, 1]: how far a flake may tilt and still return light (default 1.3/1.5, the
    /// paper's 100×/1.3 oil objective in a coat of index 1.5).
    #[arg(
        long,
        value_name = "S",
        default_value_t = 1.3 / 1.5,
        requires = "stack_out",
        allow_negative_numbers = true
    )]
    pub aperture_sin: f64,
    /// Height of the lowest slice above the substrate, µm (with --slices; default: 3
    /// FWHM below the lowest surface point, on a multiple of the step).
    #[arg(
        long,
        value_name = "UM",
        requires = "slices",
        allow_negative_numbers = true
    )]
    pub z_first_um: Option<f64>,
    /// Number of slices (with --z-first-um; default: enough to reach 3 FWHM above the
    /// highest surface point).
    #[arg(long, value_name = "N", value_parser = crate::parse::count_in::<3, MAX_SLICES>, requires = "z_first_um")]
    pub slices: Option<usize>,
    /// Which end of the stack page 0 holds (ImageJ has no field for it: read a `top`
    /// file with `stack --first-page top`).
    #[arg(long, value_enum, default_value = "bottom", requires = "stack_out")]
    pub stack_first_page: FirstPage,
}

/// Largest number of slices of a synthetic stack (the synth crate's limit).
const MAX_SLICES: usize = 100_000;

impl StackOutArgs {
    /// Checks the stack flags that need no layer (the library checks them again).
    pub(super) fn validate(&self, z_step_um: f64, height_noise_um: f64) -> anyhow::Result<()> {
        if self.stack_out.is_none() {
            if self.z_first_um.is_some() {
                anyhow::bail!("--z-first-um and --slices need --stack-out");
            }
            return Ok(());
        }
        if !(z_step_um.is_finite() && z_step_um > 0.0) {
            anyhow::bail!(
                "--z-step-um {z_step_um}: with --stack-out it is the distance between slices, a finite length > 0 µm"
            );
        }
        if height_noise_um != 0.0 {
            anyhow::bail!(
                "--height-noise-um {height_noise_um}: not with --stack-out; the stack has its own noise (--photons, --read-noise)"
            );
        }
        let positive = |flag: &str, v: f64, what: &str| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(anyhow::anyhow!("{flag} {v}: expected {what}"))
            }
        };
        positive(
            "--axial-fwhm-um",
            self.axial_fwhm_um,
            "a finite width > 0 µm",
        )?;
        positive("--photons", self.photons, "a finite number > 0")?;
        if !(self.read_noise.is_finite() && self.read_noise >= 0.0) {
            anyhow::bail!(
                "--read-noise {}: expected a finite sd >= 0 electrons",
                self.read_noise
            );
        }
        if !(self.aperture_sin > 0.0 && self.aperture_sin <= 1.0) {
            anyhow::bail!(
                "--aperture-sin {}: expected a value in (0, 1]",
                self.aperture_sin
            );
        }
        if let Some(z) = self.z_first_um
            && !z.is_finite()
        {
            anyhow::bail!("--z-first-um {z}: expected a finite height (µm)");
        }
        if let Some(n) = self.slices
            && !(3..=MAX_SLICES).contains(&n)
        {
            anyhow::bail!("--slices {n}: expected 3 to {MAX_SLICES} slices");
        }
        Ok(())
    }

    pub(super) fn axial(&self) -> AxialResponse {
        match self.axial {
            AxialKind::Gaussian => AxialResponse::Gaussian {
                fwhm_um: self.axial_fwhm_um,
            },
            AxialKind::Sinc2 => AxialResponse::Sinc2 {
                fwhm_um: self.axial_fwhm_um,
            },
        }
    }

    /// The stack of `layer` as these flags record it (slices `z_step_um` apart).
    pub(super) fn stack(
        &self,
        z_step_um: f64,
        seed: u64,
        params: &LayerParams,
        layer: &flakescatter::synth::SyntheticLayer,
    ) -> anyhow::Result<SyntheticStack> {
        let margin = 3.0 * self.axial_fwhm_um;
        let (z_first, slices) = match (self.z_first_um, self.slices) {
            (Some(z), Some(n)) => (z, n),
            _ => covering_slices(&layer.height, z_step_um, margin).ok_or_else(|| {
                anyhow::anyhow!("the layer has no surface point to cover with slices")
            })?,
        };
        if slices > MAX_SLICES {
            let s = layer.height.summary();
            anyhow::bail!(
                "--z-step-um {z_step_um}: covering the layer's heights ({} to {} µm) takes {slices} slices, more than {MAX_SLICES}; use a larger step",
                s.map_or(f64::NAN, |s| s.min),
                s.map_or(f64::NAN, |s| s.max)
            );
        }
        let mut spec = StackSpec::new(z_step_um, slices, z_first, seed);
        spec.axial = self.axial();
        spec.photons = self.photons;
        spec.read_noise = self.read_noise;
        spec.aperture_sin = self.aperture_sin;
        spec.bit_depth = if self.bit_depth == "8" {
            BitDepth::Eight
        } else {
            BitDepth::Sixteen
        };
        SyntheticStack::new(&spec, params, layer).map_err(|e| invalid(&e))
    }
}
