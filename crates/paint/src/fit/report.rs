//! How well a paint model explains a measured table: rms `log10` residuals per group of
//! geometries (the paper's regions, relative to specular), and the information criteria
//! that choose between orientation families.
//!
//! Groups: in the plane of incidence, per incidence angle, the *specular* (aspecular
//! angle below 5°), *near* (5°–40°, both ends included) and *far* (beyond 40°) regions of
//! physics.md §7; out
//! of the plane, all incidences together, the same three regions by the angle from the
//! specular direction, and all out-of-plane points. Every channel's points are pooled in
//! a group. The residual of a point is `log10(model/measured)`.

use super::data::{Measurement, Point};

/// The specular region ends here (radians), the near one at [`FAR_FROM`].
pub const NEAR_FROM: f64 = 5.0 * std::f64::consts::PI / 180.0;
/// The far region starts here (radians).
pub const FAR_FROM: f64 = 40.0 * std::f64::consts::PI / 180.0;

/// A region by the angle from the specular direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Region {
    /// Within 5° of specular.
    Specular,
    /// 5°–40° from specular.
    Near,
    /// Beyond 40° from specular.
    Far,
    /// Every angle (out of plane only).
    All,
}

impl Region {
    /// The region of an aspecular angle (radians). Points exactly on a boundary (5°,
    /// 40°) belong to the near region; the 1e-12 rad slack absorbs rounding of degree
    /// inputs (as the in-plane comparison of physics.md §7).
    #[must_use]
    pub fn of(aspecular: f64) -> Self {
        if aspecular < NEAR_FROM - 1e-12 {
            Self::Specular
        } else if aspecular <= FAR_FROM + 1e-12 {
            Self::Near
        } else {
            Self::Far
        }
    }

    /// Its name in reports.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Specular => "specular",
            Self::Near => "near",
            Self::Far => "far",
            Self::All => "all",
        }
    }
}

/// The residuals of one group.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GroupResidual {
    /// `Some(θi)` (radians) for an in-plane group, `None` out of the plane.
    pub theta_i: Option<f64>,
    /// The region.
    pub region: Region,
    /// Points (channel values) in it.
    pub points: usize,
    /// `sqrt(mean(log10(model/measured)²))`.
    pub rms_log10: f64,
    /// `mean(log10(model/measured))` (positive: the model is too high).
    pub mean_log10: f64,
}

/// The groups of the points `points` of `m` with model values `model` (one per point).
#[must_use]
pub fn group_residuals(m: &Measurement, points: &[Point], model: &[f64]) -> Vec<GroupResidual> {
    // (in plane, θi bits or 0, region) → (n, Σr, Σr²).
    let mut acc: Vec<(bool, u64, Region, usize, f64, f64)> = Vec::new();
    let mut add = |in_plane: bool, ti: u64, region: Region, r: f64| match acc
        .iter_mut()
        .find(|a| a.0 == in_plane && a.1 == ti && a.2 == region)
    {
        Some(a) => {
            a.3 += 1;
            a.4 += r;
            a.5 += r * r;
        }
        None => acc.push((in_plane, ti, region, 1, r, r * r)),
    };
    for (p, v) in points.iter().zip(model) {
        let o = &m.rows[p.row];
        let r = (v / p.value).log10();
        let region = Region::of(o.aspecular());
        if o.in_plane() {
            add(true, o.theta_i.to_bits(), region, r);
        } else {
            add(false, 0, region, r);
            add(false, 0, Region::All, r);
        }
    }
    let mut out: Vec<GroupResidual> = acc
        .into_iter()
        .map(|(in_plane, ti, region, n, s, s2)| GroupResidual {
            theta_i: in_plane.then(|| f64::from_bits(ti)),
            region,
            points: n,
            rms_log10: (s2 / n as f64).sqrt(),
            mean_log10: s / n as f64,
        })
        .collect();
    out.sort_by(|a, b| {
        let key = |g: &GroupResidual| (g.theta_i.is_none(), g.theta_i.unwrap_or(0.0));
        let (ka, kb) = (key(a), key(b));
        ka.0.cmp(&kb.0)
            .then(ka.1.total_cmp(&kb.1))
            .then(a.region.cmp(&b.region))
    });
    out
}

/// The evidence of a least-squares fit for choosing between models.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Evidence {
    /// `Σ r²` over the data (penalty rows excluded).
    pub chi2: f64,
    /// Points (channel values) fitted.
    pub points: usize,
    /// Parameters fitted.
    pub parameters: usize,
    /// Akaike's criterion: `χ² + 2k` with stated uncertainties, else
    /// `N ln(χ²/N) + 2k` (the Gaussian likelihood with the scatter estimated).
    pub aic: f64,
    /// Schwarz's criterion: the same with `k ln N` for `2k`.
    pub bic: f64,
}

impl Evidence {
    /// From `χ²` of `points` points and `parameters` parameters (see the fields).
    #[must_use]
    pub fn new(chi2: f64, points: usize, parameters: usize, uncertainties_given: bool) -> Self {
        let n = points as f64;
        let k = parameters as f64;
        let fit = if uncertainties_given {
            chi2
        } else {
            n * (chi2 / n).ln()
        };
        Self {
            chi2,
            points,
            parameters,
            aic: fit + 2.0 * k,
            bic: fit + k * n.ln(),
        }
    }
}
