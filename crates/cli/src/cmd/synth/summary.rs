//! `synth --json`: the summary of a synthetic layer (its inputs, as given and as used,
//! and what was placed), and of its z-stack with --stack-out.

use std::path::PathBuf;

use flakescatter::stats::GaussianWidth;
use flakescatter::synth::{BitDepth, LayerParams, SyntheticLayer, SyntheticStack};
use serde_json::{Value, json};

use super::{Args, AxialKind};

/// The JSON summary of `layer` (made from `params`, of orientation width `width`) and
/// of `stack` when one was rendered.
pub(super) fn summary(
    args: &Args,
    width: GaussianWidth,
    params: &LayerParams,
    layer: &SyntheticLayer,
    stack: Option<&SyntheticStack>,
) -> Value {
    let s = params.spec();
    let show = |p: &Option<PathBuf>| p.as_ref().map(|p| p.display().to_string());
    let stack_json = stack.map(|st| {
        let sp = st.spec();
        let (_, _, nz) = st.size();
        json!({
            "file": show(&args.stack.stack_out),
            "z_step_um": sp.z_step_um,
            "slices": nz,
            "z_first_um": sp.z_first_um,
            "z_last_um": st.slice_z_um(nz - 1),
            "axial": match args.stack.axial { AxialKind::Gaussian => "gaussian", AxialKind::Sinc2 => "sinc2" },
            "axial_fwhm_um": sp.axial.fwhm_um(),
            "photons": sp.photons,
            "read_noise_electrons": sp.read_noise,
            "bit_depth": if sp.bit_depth == BitDepth::Eight { 8 } else { 16 },
            "aperture_sin": sp.aperture_sin,
            "first_page": args.stack.stack_first_page.order().name(),
            "heights": "the stack's heights (flakescatter stack) are above the lowest slice: add z_first_um for heights above the substrate; the map of --out is the exact surface",
        })
    });
    json!({
        "version": env!("CARGO_PKG_VERSION"),
        "input": {
            "orientation": "gaussian",
            // Echo the value given exactly; derive the other one.
            "hwhm_deg": args.sigma.map_or(args.hwhm.unwrap_or(6.0), |_| width.hwhm().to_degrees()),
            "sigma_deg": args.sigma.unwrap_or(width.sigma().to_degrees()),
            "nx": s.nx,
            "ny": s.ny,
            "dx_um": s.dx_um,
            "dy_um": s.dy_um,
            "seed": s.seed,
            "film_um": s.film_um,
            "diameter_mean_um": args.diameter_um,
            "diameter_rel_sd": args.diameter_rel_sd,
            "diameter_distribution": "log-normal, clipped to [mean/4, 3 mean]",
            "thickness_um": s.thickness_um,
            "coverage": args.count.is_none().then_some(args.coverage.unwrap_or(1.5)),
            "count": args.count,
            "roughness_rms_um": s.roughness.rms_um,
            "roughness_correlation_um": s.roughness.correlation_um,
            "psf_sd_um": s.confocal.psf_sd_um,
            "z_step_um": args.z_step_um,
            "map_z_quantisation_um": s.confocal.z_step_um,
            "height_noise_sd_um": s.confocal.noise_sd_um,
            "intensity_flake": s.intensity.flake,
            "intensity_background": s.intensity.background,
            "intensity_noise_sd": s.intensity.noise_sd,
        },
        "width_um": s.nx as f64 * s.dx_um,
        "height_um": s.ny as f64 * s.dy_um,
        "flakes_placed": layer.truth.len(),
        "flakes_visible": layer.visible_flakes().count(),
        "flakes_redrawn_to_fit_the_film": layer.redrawn_flakes,
        "covered_fraction": layer.covered_fraction(),
        "suggested_cutoff": s.intensity.midpoint(),
        "height_file": show(&args.out),
        "intensity_file": show(&args.intensity_out),
        "truth_file": show(&args.truth_out),
        "stack": stack_json,
    })
}
