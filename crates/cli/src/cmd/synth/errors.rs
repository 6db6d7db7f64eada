//! `synth`'s refusals in the user's terms: which flag a library parameter comes from,
//! and a refused specification restated in the flags and units the user typed.

use flakescatter::synth::{Param, SynthError};

/// The flag a library parameter comes from, if it has one.
fn flag(param: Param) -> Option<&'static str> {
    Some(match param {
        Param::DxUm | Param::DyUm => "--pixel-um",
        Param::FilmUm => "--film-um",
        Param::ThicknessUm => "--thickness-um",
        Param::DiameterMeanUm => "--diameter-um",
        Param::DiameterRelSd => "--diameter-rel-sd",
        Param::Coverage => "--coverage",
        Param::Count => "--count",
        Param::RoughnessRmsUm => "--roughness-um",
        Param::RoughnessCorrelationUm => "--correlation-um",
        Param::PsfSdUm => "--psf-sd-um",
        Param::ZStepUm => "--z-step-um",
        Param::HeightNoiseSdUm => "--height-noise-um",
        Param::StackZStepUm => "--z-step-um",
        Param::StackSlices => "--slices",
        Param::StackZFirstUm => "--z-first-um",
        Param::AxialFwhmUm => "--axial-fwhm-um",
        Param::Photons => "--photons",
        Param::ReadNoise => "--read-noise",
        Param::ApertureSin => "--aperture-sin",
        _ => return None,
    })
}

/// A refused specification, in the flags and units the user typed (µm for lengths).
pub(super) fn invalid(e: &SynthError) -> anyhow::Error {
    match *e {
        SynthError::InvalidParameter {
            param,
            value,
            expected,
        } => match flag(param) {
            Some(f) => anyhow::anyhow!(
                "{f} {value}: expected {expected}{}",
                if param.name().ends_with("_um") {
                    " (µm)"
                } else {
                    ""
                }
            ),
            None => anyhow::anyhow!("invalid synth parameters (see --help): {e}"),
        },
        SynthError::FilmThinnerThanFlakes {
            film_um,
            thickness_um,
        } => anyhow::anyhow!(
            "--film-um {film_um}: the film is thinner than the flakes (--thickness-um {thickness_um}); every flake must lie inside the film"
        ),
        SynthError::FlakesDoNotFit {
            film_um,
            diameter_um,
            max_diameter_um,
            thickness_um,
            fraction,
        } => anyhow::anyhow!(
            "--film-um {film_um}: flakes of --diameter-um {diameter_um} (up to {max_diameter_um} um) and --thickness-um {thickness_um} do not fit: {:.2} % of them are tilted too far to lie inside the film (at most {:.1} % may be drawn again); use a thicker --film-um, a smaller --diameter-um or a narrower --hwhm",
            100.0 * fraction,
            100.0 * flakescatter::synth::MAX_REDRAWN_FRACTION
        ),
        SynthError::EmptyMap { .. } | SynthError::TooLarge { .. } => {
            anyhow::anyhow!("--size: {e}")
        }
        _ => anyhow::anyhow!("invalid synth parameters (see --help): {e}"),
    }
}
