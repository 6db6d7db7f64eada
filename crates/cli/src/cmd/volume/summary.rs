//! The `volume --json` summary (without the rows).

use flakescatter::VolumeCurves;
use flakescatter::volume::{Amount, Depth, Substrate};
use serde_json::{Value, json};

use super::Args;
use super::rows::energy_json;
use crate::flags::InstrumentArgs;
use crate::parse::deg_num;

/// The energy balance of each incidence of `c` as JSON (`absorbed_binder` with
/// `binder`).
pub(super) fn energy_list(c: &VolumeCurves, binder: bool) -> Vec<Value> {
    c.energy
        .iter()
        .zip(&c.energy_std_err)
        .map(|((ti, e), se)| {
            let mut v = energy_json(e, binder);
            v["theta_i_deg"] = json!(deg_num(*ti));
            v["total"] = json!(e.total());
            v["std_err"] = energy_json(se, binder);
            v
        })
        .collect()
}

/// What the energy balance holds, for `units.energy`.
fn energy_units(binder: bool) -> &'static str {
    if binder {
        "fractions of the incident power per incidence, means over the layers (std_err: over the layers): coat_reflected (exact) + escaped_single + escaped_multiple + absorbed_substrate + absorbed_flakes + absorbed_binder + absorbed_other = 1; absorbed_binder is what the tinted binder took along the paths inside the film (Beer-Lambert); absorbed_other = absorbed_rims + cut_off; escaped_via_substrate is the part of escaped_multiple whose path met the substrate (not in the sum)"
    } else {
        "fractions of the incident power per incidence, means over the layers (std_err: over the layers): coat_reflected (exact) + escaped_single + escaped_multiple + absorbed_substrate + absorbed_flakes + absorbed_other = 1; absorbed_other = absorbed_rims + cut_off; escaped_via_substrate is the part of escaped_multiple whose path met the substrate (not in the sum)"
    }
}

/// The `--json` summary (without the rows).
pub(super) fn summary(
    args: &Args,
    ia: &InstrumentArgs,
    c: &VolumeCurves,
    orientation: Value,
) -> Value {
    let binder = args.binder_absorption.is_some();
    let energy = energy_list(c, binder);
    let s = &c.settings;
    let amount = match s.amount {
        Amount::VolumeFraction(v) => json!({"volume_fraction": v}),
        Amount::MassLoading {
            fraction,
            binder_density_g_cm3,
        } => json!({
            "mass_loading": fraction,
            "binder_density_g_cm3": binder_density_g_cm3,
            "aluminium_density_g_cm3": flakescatter::volume_layer::ALUMINIUM_DENSITY_G_CM3,
            "volume_fraction": s.amount.volume_fraction(),
        }),
        Amount::Count(n) => json!({"flakes": n}),
    };
    let depth = match &s.depth {
        Depth::Uniform { top_um, bottom_um } => json!({"top_um": top_um, "bottom_um": bottom_um}),
        _ => json!("whole film"),
    };
    let substrate = match s.substrate {
        Substrate::Black => json!({"kind": "black"}),
        Substrate::Specular(r) => json!({"kind": "mirror", "reflectance": r}),
        Substrate::Lambertian(r) => json!({"kind": "lambertian", "reflectance": r}),
    };
    let l = &c.layer;
    // A sum over no flakes is -0 in floating point; print it as 0.
    let z = |x: f64| x + 0.0;
    json!({
        "version": env!("CARGO_PKG_VERSION"),
        "command": "volume",
        "model": "volume",
        "inputs": {
            "film_um": s.film_um,
            "n": c.coating.n,
            "flake_index": args.flake_index.clone().unwrap_or_else(|| "perfect-conductor".into()),
            "diameter_um": args.diameter_um,
            "diameter_rel_sd": args.diameter_rel_sd,
            "thickness_um": s.thickness_um,
            "amount": amount,
            "depth_um": depth,
            "orientation": orientation,
            "theta_i_deg": ia.theta_i_text(),
            "theta_s_deg": if ia.detectors.is_some() { Value::Null } else { json!(ia.theta_s.as_deref().unwrap_or(crate::flags::DEFAULT_THETA_S)) },
            "detectors_file": ia.detectors.as_ref().map(|p| p.display().to_string()),
            "aperture_deg": args.aperture,
            "rays_requested": args.rays,
            "layers": s.layers,
            "seed": c.seed,
            "tile_um": s.tile_um,
            "substrate": substrate,
            "rims": s.rims.name(),
        },
        "layer": {
            "flakes": l.flakes,
            "requested_volume_fraction": l.requested_volume_fraction,
            "volume_fraction": z(l.volume_fraction),
            "projected_coverage": z(l.projected_coverage),
            "area_coverage": z(l.area_coverage),
            "placement_attempts": l.attempts,
            "flakes_resized": l.resized,
            "flakes_moved": l.moved,
            "resized_area_fraction": l.resized_area_fraction,
            "layers": s.layers,
            "per_layer": c.layers.iter().map(|l| json!({
                "flakes": l.flakes,
                "volume_fraction": z(l.volume_fraction),
                "projected_coverage": z(l.projected_coverage),
                "placement_attempts": l.attempts,
                "flakes_resized": l.resized,
                "flakes_moved": l.moved,
            })).collect::<Vec<_>>(),
        },
        "seed": c.seed,
        "rays_per_incidence": c.rays_per_incidence,
        "rays_per_layer": c.rays_per_layer,
        "t975": c.t975.is_finite().then_some(c.t975),
        "segments": c.segments,
        "energy": energy,
        "units": {
            "columns": {
                "theta_i_deg": "degree, incidence angle from the film normal",
                "theta_s_deg": "degree, signed in-plane detector angle (theta_s = -theta_i is specular); theta_r for out-of-plane detectors",
                "phi_s_deg": "degree, detector azimuth (0 = specular half-plane); 0 for in-plane detectors",
                "aperture_deg": "degree, detector cone half-angle",
                "brdf_per_sr": "1/sr, total BRDF averaged over the detector cone (coat + single + multiple)",
                "reflectance": "fraction of the incident beam power collected by the detector",
                "relative": "collected power relative to the same detector at the specular direction (coat reflection included)",
                "rays": "escapes counted in the detector (rays, not weight)",
                "std_err_per_sr": "1/sr, standard error of brdf_per_sr over the layers: s/sqrt(K), s the sample sd of the K layer estimates, which holds the rays' and the layers' scatter; with --layers 1 the rays' part only (64 batches); null (empty) where no ray reached the detector",
                "ray_std_err_per_sr": "1/sr, the rays' part of std_err_per_sr: sqrt(sum of the layers' squared batch errors)/K",
                "layer_std_err_per_sr": "1/sr, the between-layer part: sqrt(max(0, std_err^2 - ray_std_err^2)); null (empty) with --layers 1",
                "ci95_per_sr": "1/sr, half-width of the 95 % interval of brdf_per_sr: t975 * std_err_per_sr, Student's t on K - 1 degrees of freedom; null (empty) with --layers 1",
                "single_bounce_std_err_per_sr": "1/sr, standard error over the layers, as std_err_per_sr",
                "multiple_bounce_std_err_per_sr": "1/sr, standard error over the layers, as std_err_per_sr",
                "coat_brdf_per_sr": "1/sr, first-surface (top interface) reflection, exact; 0 outside the specular cone",
                "single_bounce_brdf_per_sr": "1/sr, light that met exactly one flake face and nothing else",
                "multiple_bounce_brdf_per_sr": "1/sr, every other escaping history: two or more interactions, or an internal reflection at the top interface",
            },
            "energy": energy_units(binder),
            "layer": "over all layers (per_layer: each): counts summed, fractions averaged; flakes placed; volume fractions (flake volume per film volume); projected_coverage = sum of pi r^2 cos(theta_n) over the tile area, area_coverage = sum of pi r^2 over the tile area (overlaps in projection counted twice); flakes_resized: flakes taller than the film at their tilt, given a diameter that fits (normal kept), resized_area_fraction the flake area they lost over all flake area as drawn; flakes_moved: flakes --depth-um could not put inside the film, placed at the nearest depth that is (physics.md §10)",
            "segments": "straight ray segments traced, all incidences and layers",
            "layers": "every value is the mean over the --layers independent layers of the seed, each traced with rays_per_layer rays per incidence (rays_per_incidence in all); t975 is Student's t quantile on layers - 1 degrees of freedom (null with one layer)",
        },
        "out": args.out.as_ref().map(|p| p.display().to_string()),
        "plot": args.plot.as_ref().map(|p| p.display().to_string()),
    })
}
