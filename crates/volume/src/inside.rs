//! Keeping every flake inside the film (physics.md §10, "Flakes the film cannot hold").
//!
//! Conventions: µm and radians; depths below the top interface. A flake of radius `r`,
//! thickness `t` and tilt `θ` (its normal's angle from `z`) reaches
//! `h = r sin θ + (t/2) cos θ` above and below its centre, so it lies inside the film
//! when its centre depth is in `[h, film − h]`, which needs `2h ≤ film`.
//!
//! # Rules (applied to each flake after its diameter and normal are drawn)
//! 1. **Taller than the film** (`2h > film`, a large flake in the orientation's tail):
//!    the normal is kept and the diameter is drawn again from the diameter distribution
//!    restricted to the diameters that fit at this tilt, `d ≤ d_fit = (film − t cos θ) /
//!    sin θ` (exact inverse-CDF draw of the log-normal truncated to
//!    `[mean/4, min(3 mean, d_fit)]`, one uniform number of the layer's stream); when no
//!    diameter of the distribution fits (`d_fit < mean/4`, or a fixed diameter), the
//!    flake gets `d_fit` itself. The flake is counted as *resized*.
//! 2. **Fits the film, but not where the depth rule puts centres** (`--depth-um A:B` or
//!    a profile with no depth in `[h, film − h]`): its centre is put at the depth of
//!    `[h, film − h]` nearest to the rule's depths (the nearer end). The flake is
//!    counted as *moved*.
//!
//! Rule 1 keeps every drawn normal, so the number-weighted orientation distribution of
//! the placed flakes is exactly the requested one; only the resized flakes' area
//! shrinks, so the area-weighted distribution loses that area from its tail (reported
//! as [`crate::LayerStats::resized_area_fraction`]). Redrawing the normal instead, or
//! dropping the flake, would cut the tail of the orientation distribution itself,
//! which is what the reflection depends on. Rule 2 changes depths only.
//!
//! A layer is refused ([`VolumeError::DepthRange`]) only when the film or the depth
//! rule cannot hold a **typical flake**: the flake of the median diameter (of the
//! truncated distribution) at the median tilt (of the area-weighted orientation
//! distribution).

use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use statrs::distribution::{ContinuousCDF, Normal};

use crate::VolumeError;
use crate::params::{DepthBins, Diameter, LayerParams};

/// Half the vertical extent of a flake of radius `r`, thickness `t`, with unit normal
/// z-component `cos_t`: `r sin θ + (t/2) cos θ`, µm.
pub(crate) fn half_extent(r: f64, t: f64, cos_t: f64) -> f64 {
    r * (1.0 - cos_t * cos_t).max(0.0).sqrt() + 0.5 * t * cos_t
}

/// The median tilt of an orientation distribution (area-weighted, radians), by
/// bisection on its cumulative mass.
fn median_tilt(o: &flakescatter_stats::Orientation) -> f64 {
    if o.is_delta() {
        return 0.0;
    }
    let top = o.max_theta();
    let total = o.mass_between(0.0, top);
    let (mut lo, mut hi) = (0.0, top);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if o.mass_between(0.0, mid) < 0.5 * total {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The log-normal diameters as `ln d ~ N(μ, σ²)` truncated to `[mean/4, 3 mean]`, for
/// medians and restricted redraws.
struct LogNormalDiameters {
    mu: f64,
    sigma: f64,
    unit: Normal,
    lo: f64,
    hi: f64,
}

impl LogNormalDiameters {
    fn new(d: &Diameter) -> Option<Self> {
        match *d {
            Diameter::LogNormal { mean_um, rel_sd } if rel_sd > 0.0 => {
                let s2 = rel_sd.mul_add(rel_sd, 1.0).ln();
                Some(Self {
                    mu: mean_um.ln() - 0.5 * s2,
                    sigma: s2.sqrt(),
                    unit: Normal::standard(),
                    lo: 0.25 * mean_um,
                    hi: 3.0 * mean_um,
                })
            }
            _ => None,
        }
    }

    /// `P(ln d ≤ ln x)` of the untruncated log-normal.
    fn cdf(&self, x: f64) -> f64 {
        self.unit.cdf((x.ln() - self.mu) / self.sigma)
    }

    /// The diameter at cumulative probability `p` of the untruncated log-normal.
    fn at(&self, p: f64) -> f64 {
        (self.mu + self.sigma * self.unit.inverse_cdf(p)).exp()
    }
}

/// How the flakes of one layer are kept inside the film; counts what it did.
pub(crate) struct Inside {
    film: f64,
    thickness: f64,
    lognormal: Option<LogNormalDiameters>,
    /// Flakes given a smaller diameter (rule 1).
    pub resized: usize,
    /// Flakes whose centre was put at the nearest allowed depth (rule 2).
    pub moved: usize,
    /// Face area the resized flakes had as drawn, and have now, µm².
    pub area_drawn: f64,
    pub area_resized: f64,
}

impl Inside {
    /// The rules for `params`, after checking that the film and the depth rule hold a
    /// typical flake.
    ///
    /// # Errors
    /// [`VolumeError::DepthRange`] when they do not.
    pub(crate) fn new(params: &LayerParams) -> Result<Self, VolumeError> {
        let spec = params.spec();
        let inside = Self {
            film: spec.film_um,
            thickness: spec.thickness_um,
            lognormal: LogNormalDiameters::new(&spec.diameter),
            resized: 0,
            moved: 0,
            area_drawn: 0.0,
            area_resized: 0.0,
        };
        let d = match &inside.lognormal {
            Some(ln) => ln.at(0.5 * (ln.cdf(ln.lo) + ln.cdf(ln.hi))),
            None => spec.diameter.mean_um(),
        };
        let tilt = median_tilt(&spec.orientation);
        let h = half_extent(0.5 * d, spec.thickness_um, tilt.cos());
        let (lo, hi) = (h, spec.film_um - h);
        let err = |reason| VolumeError::DepthRange {
            diameter_um: d,
            tilt,
            min_depth_um: lo,
            max_depth_um: hi,
            reason,
        };
        if lo > hi {
            return Err(err("the film is too thin for"));
        }
        if !allows(params.depth_bins(), lo, hi) {
            return Err(err("the depth range or profile does not allow"));
        }
        Ok(inside)
    }

    /// Rule 1: the diameter of a flake with normal z-component `cos_t` drawn as `d`,
    /// redrawn (or reduced) when the flake is taller than the film.
    pub(crate) fn diameter(&mut self, d: f64, cos_t: f64, rng: &mut ChaCha8Rng) -> f64 {
        let (f, t) = (self.film, self.thickness);
        if 2.0 * half_extent(0.5 * d, t, cos_t) <= f {
            return d;
        }
        let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        // The largest diameter that fits, a hair inside so that rounding keeps it in.
        let fit = (f - t * cos_t) / sin_t * (1.0 - 1e-12);
        let new = match &self.lognormal {
            Some(ln) if fit > ln.lo => {
                let (a, b) = (ln.cdf(ln.lo), ln.cdf(fit.min(ln.hi)));
                let u: f64 = rng.random();
                ln.at(a + u * (b - a)).clamp(ln.lo, fit.min(ln.hi))
            }
            _ => fit,
        };
        self.resized += 1;
        let area = |d: f64| 0.25 * std::f64::consts::PI * d * d;
        self.area_drawn += area(d);
        self.area_resized += area(new);
        new
    }
}

/// Whether the depth rule has a depth in `[lo, hi]`.
fn allows(depth: &DepthBins, lo: f64, hi: f64) -> bool {
    match depth {
        DepthBins::Fixed(z) => (lo..=hi).contains(z),
        DepthBins::Bins(b) => b.iter().any(|&(a, c, _)| a.max(lo) <= c.min(hi)),
    }
}

/// Rule 2: the depth of `[lo, hi]` nearest to the depth rule's depths (the nearer end;
/// the shallower on a tie), for a flake the rule has no depth for.
pub(crate) fn nearest_allowed(depth: &DepthBins, lo: f64, hi: f64) -> f64 {
    let ranges: Vec<(f64, f64)> = match depth {
        DepthBins::Fixed(z) => vec![(*z, *z)],
        DepthBins::Bins(b) => b.iter().map(|&(a, c, _)| (a, c)).collect(),
    };
    let distance = |x: f64| {
        ranges
            .iter()
            .map(|&(a, c)| if x < a { a - x } else { (x - c).max(0.0) })
            .fold(f64::INFINITY, f64::min)
    };
    if distance(lo) <= distance(hi) { lo } else { hi }
}
