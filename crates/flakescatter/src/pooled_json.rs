//! The JSON of a pooled sample's width, one writer for what `stats --json` and
//! `analyze`'s `summary.json` both say: the interval in degrees, the map-level interval,
//! the heterogeneity of the maps, and one entry per map. Degrees throughout; an
//! infinite end of an interval is `null`.

use flakescatter_stats::pool::PooledWidth;
use serde_json::{Value, json};

/// The ends of a hwhm interval (radians) in degrees, `None` for an infinite end.
#[must_use]
pub fn ci_deg_ends(ci: (f64, f64)) -> (Option<f64>, Option<f64>) {
    let f = |x: f64| x.is_finite().then(|| x.to_degrees());
    (f(ci.0), f(ci.1))
}

/// `[lo, hi]` of a hwhm interval (radians) in degrees, `null` for an infinite end.
#[must_use]
pub fn ci_deg(ci: (f64, f64)) -> Value {
    json!(ci_deg_ends(ci))
}

/// The map-level interval (`null` with fewer than two maps with a fit): its hwhm
/// interval, method, maps, degrees of freedom, t quantile and the standard error of the
/// mean square tilt (rad²).
#[must_use]
pub fn map_level(p: &PooledWidth) -> Value {
    p.map_level.map_or(Value::Null, |m| {
        json!({
            "hwhm_ci95_deg": ci_deg(m.hwhm_ci95()),
            "method": m.describe(),
            "maps": m.maps,
            "dof": m.dof,
            "t_quantile": m.t_quantile,
            "mean_square_tilt_std_err_rad2": m.mean_square_tilt_std_err,
        })
    })
}

/// Cochran's Q of the maps, its degrees of freedom, p value and I² (`null` without).
#[must_use]
pub fn heterogeneity(p: &PooledWidth) -> Value {
    p.heterogeneity.map_or(
        Value::Null,
        |h| json!({"cochran_q": h.q, "dof": h.dof, "p": h.p, "i2": h.i2}),
    )
}

/// Which interval a report quotes: `"map_level"` where there is one.
#[must_use]
pub fn quoted_interval(p: &PooledWidth) -> &'static str {
    if p.map_level.is_some() {
        "map_level"
    } else {
        "flake_level"
    }
}

/// One entry per map, named by `names`: flakes, area (µm²), effective flakes, its own
/// hwhm and interval where it has a fit, its z score and whether it is flagged.
#[must_use]
pub fn maps(p: &PooledWidth, names: &[String]) -> Value {
    p.maps
        .iter()
        .zip(names)
        .map(|(m, name)| {
            json!({
                "map": name,
                "flakes": m.flakes,
                "area_um2": m.area_um2,
                "effective_flakes": m.effective_n,
                "hwhm_deg": m.fit.map(|f| f.hwhm().to_degrees()),
                "hwhm_ci95_deg": m.fit.map(|f| ci_deg(f.hwhm_ci95())),
                "z": m.z,
                "flagged": m.flagged,
            })
        })
        .collect()
}
