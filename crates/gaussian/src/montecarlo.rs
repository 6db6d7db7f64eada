//! A Monte Carlo estimator of what detectors collect, independent of the BRDF formula.
//!
//! Flake normals are drawn from the orientation distribution (area-weighted, `p2 dΩ`),
//! each ray is traced with the optics layer (refraction in, mirror reflection, refraction
//! out) and counted into every cone that contains it with weight
//! `F · R · γ / (⟨cos θn⟩ cos θt)` (so that its expectation is
//! `∫_cone-preimage D F R γ / cos θt dΩm`, the collected fraction of the beam). No
//! Jacobian appears: this is why it checks the point BRDF and the cone quadrature.
//!
//! Reproducible: samples are drawn in fixed chunks of [`CHUNK`], chunk `k` from a ChaCha8
//! stream seeded by `(seed, k)`, and chunk sums are added in chunk order, so the result
//! does not depend on the number of threads.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use flakescatter_optics::detector::Cone;

use crate::ModelError;
use crate::model::{DistributionModel, Incidence};

/// Samples per independently seeded chunk.
pub const CHUNK: u64 = 1 << 16;

/// Monte Carlo estimate for one detector.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct McEstimate {
    /// Estimated fraction of the beam collected (flakes only; the clear coat is added
    /// exactly when it is on and the cone contains the specular direction).
    pub reflectance: f64,
    /// Standard error of `reflectance` (flake part).
    pub std_err: f64,
    /// Number of rays that entered the cone.
    pub hits: u64,
}

/// Estimate what each cone collects at incidence `inc` from `samples` flake normals.
///
/// # Errors
/// [`ModelError::Empty`] for `samples == 0` (the estimate would be 0/0).
pub fn monte_carlo(
    model: &DistributionModel,
    inc: &Incidence,
    cones: &[Cone],
    samples: u64,
    seed: u64,
) -> Result<Vec<McEstimate>, ModelError> {
    if samples == 0 {
        return Err(ModelError::Empty("Monte Carlo sample"));
    }
    let chunks = samples.div_ceil(CHUNK);
    // Rays farther than every cone's aperture from the plane of incidence cannot enter an
    // in-plane cone: one comparison rejects them.
    let all_in_plane = cones.iter().all(|c| c.axis().y == 0.0);
    let max_sin = cones
        .iter()
        .map(|c| c.half_angle().sin())
        .fold(0.0, f64::max);
    let partial: Vec<Vec<(f64, f64, u64)>> = (0..chunks)
        .into_par_iter()
        .map(|k| {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            rng.set_stream(k);
            let count = CHUNK.min(samples - k * CHUNK);
            let mut acc = vec![(0.0, 0.0, 0u64); cones.len()];
            for _ in 0..count {
                let m = model.orientation().sample_normal(&mut rng);
                // Sampling density p2 cancels D = p2/⟨cos⟩: weight F R γ / (⟨cos⟩ cos θt).
                let Some((w, out)) = model.ray_weight(inc, &m) else {
                    continue;
                };
                let w = w * model.inv_mean_cos();
                if all_in_plane && out.y.abs() >= max_sin {
                    continue;
                }
                for (a, cone) in acc.iter_mut().zip(cones) {
                    if cone.contains(&out) {
                        a.0 += w;
                        a.1 += w * w;
                        a.2 += 1;
                    }
                }
            }
            acc
        })
        .collect();
    let mut total = vec![(0.0, 0.0, 0u64); cones.len()];
    for chunk in &partial {
        for (t, c) in total.iter_mut().zip(chunk) {
            t.0 += c.0;
            t.1 += c.1;
            t.2 += c.2;
        }
    }
    let nf = samples as f64;
    Ok(total
        .iter()
        .zip(cones)
        .map(|(&(s, s2, hits), cone)| {
            let mean = s / nf;
            let var = (s2 / nf - mean * mean).max(0.0);
            let clear = if model.options().clearcoat && cone.contains(&inc.specular) {
                inc.clearcoat
            } else {
                0.0
            };
            McEstimate {
                reflectance: mean + clear,
                std_err: (var / nf).sqrt(),
                hits,
            }
        })
        .collect())
}
