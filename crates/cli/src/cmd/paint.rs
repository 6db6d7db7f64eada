//! A fitted paint (`P.json` from `fit --paint --params-out`) in `model --params` (its BRDF
//! per channel at the instrument's geometry) and `compare --params` (against a table).

use std::path::Path;

use anyhow::{Context, bail};
use flakescatter::paint::file::read_params;
use flakescatter::paint::report::{comparison_json, groups_text, points_csv, worst_ratio};
use flakescatter::paint::{PaintCurves, Selection, paint_curves};
use flakescatter::paint_model::PaintModel;
use serde_json::{Value, json};

use crate::output::{Dest, Plan, print, print_json};

/// The paint of `--params`.
pub fn model_of(path: &Path) -> anyhow::Result<PaintModel> {
    let params = read_params(path).with_context(|| format!("--params {}", path.display()))?;
    PaintModel::new(params).with_context(|| format!("--params {}", path.display()))
}

/// The CSV of a paint's curves: `theta_i_deg, theta_s_deg` (in-plane detectors),
/// `theta_r_deg, phi_r_deg, aperture_deg`, then `brdf_<channel>_per_sr` per channel (so
/// that a curve at `--detectors` reads back as a BRDF table).
fn curves_csv(c: &PaintCurves, aperture_deg: f64, in_plane: bool) -> String {
    let mut s = String::from("theta_i_deg,");
    if in_plane {
        s.push_str("theta_s_deg,");
    }
    s.push_str("theta_r_deg,phi_r_deg,aperture_deg");
    for ch in &c.channels {
        s.push_str(&format!(",brdf_{ch}_per_sr"));
    }
    s.push('\n');
    for r in &c.rows {
        let a = r.cone.axis();
        let theta_r = a.z.clamp(-1.0, 1.0).acos().to_degrees();
        let phi_r = if a.x == 0.0 && a.y == 0.0 {
            0.0
        } else {
            a.y.atan2(a.x).to_degrees()
        };
        let round = |v: f64| (v * 1e9).round() / 1e9;
        s.push_str(&format!("{},", round(r.theta_i.to_degrees())));
        if in_plane {
            let ts = if a.x > 0.0 { -theta_r } else { theta_r };
            s.push_str(&format!("{},", round(ts)));
        }
        s.push_str(&format!(
            "{},{},{}",
            round(theta_r),
            round(phi_r.rem_euclid(360.0)),
            aperture_deg
        ));
        for v in &r.brdf {
            s.push_str(&format!(",{v}"));
        }
        s.push('\n');
    }
    s
}

/// `model --params P.json` or `model --paint` (a paint from flags).
pub fn model(
    args: &crate::cmd::model::Args,
    mut plan: Plan,
    table: Option<Dest>,
) -> anyhow::Result<()> {
    if args.spectral.any() || args.colour.any() || args.geometry.any() {
        bail!(
            "--params: the spectral, colour and multi-angle flags do not apply to a paint (its channels are in P.json)"
        );
    }
    if args.plot.is_some() {
        bail!("--plot does not apply to --params; plot a fit with `fit --paint --plot DIR`");
    }
    if let Some(path) = &args.params {
        plan.input("--params", path);
    }
    args.source.inputs(&mut plan);
    let instrument = args.instrument.instrument()?;
    let aperture_deg = args.instrument.optics.aperture_deg();
    if args.paint.paint {
        args.source.validate()?;
        if args
            .polarization
            .polarimetry(args.instrument.optics.transmission)?
            .is_some()
            || args.instrument.optics.transmission != Default::default()
            || args.instrument.optics.weighting != Default::default()
            || args.instrument.clearcoat
            || args.cone != crate::cmd::model::ConeKind::Exact
        {
            bail!(
                "--paint: the polarisation, --transmission, --weighting, --clearcoat and --cone flags do not apply (a paint uses exact unpolarised Fresnel factors, includes its coat and integrates cones exactly)"
            );
        }
    }
    plan.check()?;
    let (paint, source) = match &args.params {
        Some(path) => (
            model_of(path)?,
            json!({"params": path.display().to_string()}),
        ),
        None => {
            let (orientation, echo) = args.source.orientation()?;
            let n = args.instrument.optics.coating()?.n;
            let metal = crate::flags::flake_metal(&args.instrument.optics)?;
            let m = args.paint.model(orientation, n, metal)?;
            let file = flakescatter::paint::file::ParamsFile::new(m.params(), None);
            (m, json!({"paint": file, "orientation": echo}))
        }
    };
    let curves = paint_curves(&paint, &instrument)?;
    let in_plane = matches!(
        instrument.detectors(),
        flakescatter::DetectorSet::InPlane(_)
    );
    let text = curves_csv(&curves, aperture_deg, in_plane);
    if let Some(dest) = &table {
        plan.write(
            dest,
            |w| Ok(w.write_all(text.as_bytes())?),
            Some(format!("{} rows", curves.rows.len())),
        )?;
    }
    plan.finish()?;
    if args.json {
        // The coating, flake and model settings are the paint's (in "paint").
        let mut geometry = args.instrument.echo();
        if let Some(o) = geometry.as_object_mut() {
            for k in ["n", "flake_index", "transmission", "weighting", "clearcoat"] {
                o.remove(k);
            }
        }
        let rows: Vec<Value> = if table.is_some() {
            Vec::new()
        } else {
            curves
                .rows
                .iter()
                .map(|r| {
                    let a = r.cone.axis();
                    json!({
                        "theta_i_deg": r.theta_i.to_degrees(),
                        "theta_r_deg": a.z.clamp(-1.0, 1.0).acos().to_degrees(),
                        "phi_r_deg": a.y.atan2(a.x).to_degrees().rem_euclid(360.0),
                        "brdf_per_sr": r.brdf,
                        "reflectance": r.power,
                    })
                })
                .collect()
        };
        print_json(&json!({
            "command": "model --paint",
            "paint": source,
            "channels": curves.channels,
            "units": {"angles": "degrees", "brdf_per_sr": "1/sr, averaged over the detector cone (point BRDF at aperture 0)", "reflectance": "fraction of the beam the cone collects"},
            "aperture_deg": aperture_deg,
            "instrument": geometry,
            "rows": rows,
        }))?;
    }
    Ok(())
}

/// The `--region`, `--max-theta-r`, `--min-value` selection of `compare --params`.
pub fn selection(
    region: Option<&str>,
    max_theta_r: Option<f64>,
    min_value: Option<f64>,
) -> anyhow::Result<Selection> {
    let mut sel = Selection::default();
    if let Some(text) = region {
        match text
            .split_once(':')
            .map(|(a, b)| (a.trim().parse::<f64>(), b.trim().parse::<f64>()))
        {
            Some((Ok(lo), Ok(hi))) if lo >= 0.0 && hi > lo && hi <= 180.0 => {
                sel.aspecular = (lo.to_radians(), hi.to_radians());
            }
            _ => bail!("--region `{text}`: expected LO:HI in degrees with 0 <= LO < HI <= 180"),
        }
    }
    if let Some(t) = max_theta_r {
        if !(t > 0.0 && t <= 90.0) {
            bail!("--max-theta-r {t}: expected a polar angle in (0, 90] degrees");
        }
        sel.max_theta_r = t.to_radians();
    }
    if let Some(v) = min_value {
        if !(v.is_finite() && v >= 0.0) {
            bail!("--min-value {v}: expected a BRDF >= 0 (1/sr)");
        }
        sel.min_value = v;
    }
    Ok(sel)
}

/// `compare --measured TABLE --params P.json` (or `--paint` from flags).
pub fn compare(
    args: &crate::cmd::compare::Args,
    mut plan: Plan,
    out: Option<Dest>,
) -> anyhow::Result<()> {
    if args.plot.is_some() {
        bail!(
            "--plot does not apply to a paint comparison; plot a fit with `fit --paint --plot DIR`"
        );
    }
    if args.measured.optics.aperture.is_some_and(|a| a != 0.0) {
        bail!(
            "--aperture does not apply to a paint comparison: it compares point BRDFs with the table's point detectors"
        );
    }
    if let Some(path) = &args.params {
        plan.input("--params", path);
    }
    args.orientation.inputs(&mut plan);
    let sel = selection(args.region.as_deref(), args.max_theta_r, args.min_value)?;
    if args.paint.paint {
        args.orientation.validate()?;
    }
    plan.check()?;
    let (paint, name) = match &args.params {
        Some(path) => (model_of(path)?, format!("--params {}", path.display())),
        None => {
            let (orientation, _) = args.orientation.orientation()?;
            let n = args.measured.optics.coating()?.n;
            let metal = crate::flags::flake_metal(&args.measured.optics)?;
            (
                args.paint.model(orientation, n, metal)?,
                "--paint".to_string(),
            )
        }
    };
    let m = args.measured.read_paint()?;
    let c = flakescatter::paint::compare(&paint, &m, &sel)
        .with_context(|| format!("comparing {} with {name}", m.file))?;
    if let Some(dest) = &out {
        let text = points_csv(&m, &c.points, &c.model);
        plan.write(
            dest,
            |w| Ok(w.write_all(text.as_bytes())?),
            Some(format!("{} points", c.points.len())),
        )?;
    }
    plan.finish()?;
    if args.json {
        let mut v = comparison_json(&c, &m, &sel);
        v["command"] = json!("compare --params");
        v["paint"] = json!(name);
        v["worst_ratio_to_target"] = json!(worst_ratio(&c.groups));
        print_json(&v)
    } else if out != Some(Dest::Stdout) {
        let mut lines = vec![format!(
            "{} points of {} against the paint of {name}; rms log10(model/measured) by region:",
            c.points.len(),
            m.file,
        )];
        lines.extend(groups_text(&c.groups).into_iter().map(|l| format!("  {l}")));
        lines.push(format!(
            "worst group / target = {:.2} (<= 1 meets every target)",
            worst_ratio(&c.groups)
        ));
        print(&(lines.join("\n") + "\n"))
    } else {
        Ok(())
    }
}
