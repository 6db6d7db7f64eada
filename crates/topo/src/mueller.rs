//! The topographic model's Mueller matrix per detector cone (physics.md §11).
//!
//! Conventions: those of [`crate::model`] for the rays and of
//! [`flakescatter_optics::jones`] / [`flakescatter_optics::mueller`] (SCATMECH's) for the
//! polarisation: Stokes vectors in the `(s, p)` basis of the incident direction
//! (`s = y`), and for each detector in the basis of its axis — for a ray arriving along
//! `k_out`, `s` is the axis's `s` projected perpendicular to `k_out`
//! ([`flakescatter_optics::jones::exit_frame`]), as in the distribution model's cones;
//! at the pole the axis's `s` is that of the detector's azimuth
//! ([`flakescatter_optics::detector::Cone::basis_s`]).
//!
//! Every ray adds its path Mueller matrix ([`flakescatter_optics::jones::Transfer`]) with
//! the scalar model's geometric weight, `M_path · γ / (m.z cos θt) / N_pixels`
//! (`physical`) or `M_path · γ · cos ϑ'/cos ϑ / N_pixels` (`paper-printed`), to every
//! detector whose cone contains it; so `m00` is the scalar model with
//! `exact-unpolarized`. The result does not depend on
//! [`TopoOptions::transmission`](crate::TopoOptions): the matrix is exact and the
//! incident polarisation is the Stokes vector it multiplies. A **readout** — 16 weights
//! `w_ij`, the detected value being `Σ w_ij m_ij` (for an analyser row `a` and an
//! incident Stokes vector `s`, `w_ij = a_i s_j`) — is accumulated as a 17th sum, so that
//! its standard error comes from the tiles like the elements' (module docs of
//! [`crate::model`]). With the clear coat on, the Mueller matrix of `diag(rs, rp)`,
//! turned into the cone's basis, is added to every cone that contains the specular
//! direction.

use flakescatter_optics::detector::{self, Cone};
use flakescatter_optics::jones::{clearcoat_jones, exit_frame};
use flakescatter_optics::mueller::Mueller;
use flakescatter_optics::polarization::Weighting;
use flakescatter_stats::HeightMap;

use crate::TopoError;
use crate::model::{
    Accumulator, Inc, Ray, TopoModel, TopoOptions, TopoResult, aperture_index, ray_path,
};

/// One incidence × one detector of a [`TopoMuellerResult`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TopoMuellerPoint {
    /// Incidence angle, radians.
    pub theta_i: f64,
    /// The detector.
    pub cone: Cone,
    /// Collected fraction of the incident beam power as a Mueller matrix (no unit), in
    /// the cone's basis (module docs); includes the clear coat when it is on and seen.
    pub reflectance: Mueller,
    /// Standard error of each element of `reflectance`, from the spread between tiles;
    /// `None` when not estimable (fewer than 2 tiles, or no ray), as in the scalar model.
    pub reflectance_std_err: Option<Mueller>,
    /// `reflectance / (cos θj · π sin²α)`, sr⁻¹.
    pub brdf: Mueller,
    /// Standard error of each element of `brdf`, sr⁻¹; `None` as for
    /// `reflectance_std_err`.
    pub brdf_std_err: Option<Mueller>,
    /// The readout `Σ w_ij m_ij` of `reflectance` (module docs).
    pub readout: f64,
    /// Standard error of `readout`, from the tiles; `None` as for `reflectance_std_err`.
    pub readout_std_err: Option<f64>,
    /// Number of rays counted in the detector.
    pub rays: u64,
    /// `readout` divided by that of a cone of the same aperture at the specular
    /// direction; NaN when that is not positive.
    pub relative: f64,
    /// Whether the clear coat's specular reflection was added.
    pub clearcoat_seen: bool,
}

/// What [`TopoModel::run_mueller`] gives: one point per incidence × detector
/// (incidence-major) and the run's totals (`totals.points` is empty).
#[derive(Debug, Clone, PartialEq)]
pub struct TopoMuellerResult {
    /// Rows, incidence-major.
    pub points: Vec<TopoMuellerPoint>,
    /// Pixels, rays, losses and tiles of the run.
    pub totals: TopoResult,
}

/// Sums: the 16 elements, then the readout.
const CHANNELS: usize = 17;

/// The Mueller accumulator (module docs).
struct MuellerSums<'a> {
    readout: &'a [f64; 16],
}

impl Accumulator for MuellerSums<'_> {
    type Weight = Mueller;

    fn channels(&self) -> usize {
        CHANNELS
    }

    #[inline(always)]
    fn weigh(&self, opts: &TopoOptions, inc: &Inc, ray: &Ray) -> Mueller {
        let (path, amps) = ray_path(opts, inc, ray);
        let t = path.transfer(&amps);
        let w = if opts.weighting == Weighting::Physical {
            t.power_scale * ray.gamma * ray.m[3] * (1.0 / inc.cos_t)
        } else {
            t.power_scale * ray.gamma
        };
        t.jones.mueller() * w
    }

    #[inline]
    fn add(&self, w: &Mueller, ray: &Ray, cone: &Cone, scale: f64, sums: &mut [f64]) {
        let m = w.rotate_out(exit_frame(&ray.k_out, cone.basis_s())) * scale;
        let mut readout = 0.0;
        for (e, (sum, r)) in sums[..16].iter_mut().zip(self.readout).enumerate() {
            let v = m.get(e / 4, e % 4);
            *sum += v;
            readout += r * v;
        }
        sums[16] += readout;
    }
}

impl TopoModel {
    /// As [`TopoModel::run_with_progress`], accumulating the Mueller matrix of every ray
    /// and the `readout` (module docs) per detector.
    ///
    /// # Errors
    /// As [`TopoModel::run`].
    pub fn run_mueller(
        &self,
        maps: &[&HeightMap],
        theta_i: &[f64],
        cones: &[Cone],
        readout: &[f64; 16],
        progress: &(dyn Fn(u64, u64) + Sync),
    ) -> Result<TopoMuellerResult, TopoError> {
        let acc = self.accumulate(maps, theta_i, cones, progress, &MuellerSums { readout })?;
        let (inv_n, ndet, all, apertures) = (acc.inv_n, acc.ndet, &acc.all, &acc.apertures);
        let ncones = cones.len();
        let read = |m: &Mueller| -> f64 {
            readout
                .iter()
                .enumerate()
                .map(|(e, w)| w * m.get(e / 4, e % 4))
                .sum()
        };
        let mut points = Vec::with_capacity(theta_i.len() * ncones);
        for (ii, &ti) in theta_i.iter().enumerate() {
            let specular = detector::specular_direction(ti);
            let inc = &acc.incs[ii];
            let clearcoat = clearcoat_jones(inc.amplitudes[0], inc.amplitudes[1]);
            // (ρ, se(ρ), readout, se(readout), clear coat seen) of internal detector d.
            let value = |d: usize| {
                let base = (ii * ndet + d) * CHANNELS;
                // No spread with one tile, nor in a detector without rays (module docs of
                // `model`).
                let se_factor = acc.se_factor.filter(|_| acc.rays[ii * ndet + d] > 0);
                let mut rho = [0.0; 16];
                let mut se = [0.0; 16];
                for e in 0..16 {
                    rho[e] = acc.sum[base + e] * inv_n;
                    se[e] = se_factor.map_or(0.0, |f| (f * acc.m2[base + e]).sqrt() * inv_n);
                }
                let mut rho = Mueller::from_row_major(&rho);
                let mut r = acc.sum[base + 16] * inv_n;
                let seen_cc = self.options().clearcoat && all[d].contains(&specular);
                if seen_cc {
                    let frame = exit_frame(&specular, all[d].basis_s());
                    let cc = clearcoat.rotate_out(frame).mueller();
                    rho += cc;
                    r += read(&cc);
                }
                let r_se = se_factor.map(|f| (f * acc.m2[base + 16]).sqrt() * inv_n);
                let se = se_factor.map(|_| Mueller::from_row_major(&se));
                (rho, se, r, r_se, seen_cc)
            };
            for (j, cone) in cones.iter().enumerate() {
                let (rho, se, r, r_se, seen_cc) = value(j);
                let spec = value(ncones + ii * apertures.len() + aperture_index(apertures, cone)).2;
                let inv_proj = 1.0 / cone.projected_solid_angle();
                points.push(TopoMuellerPoint {
                    theta_i: ti,
                    cone: *cone,
                    reflectance: rho,
                    reflectance_std_err: se,
                    brdf: rho * inv_proj,
                    brdf_std_err: se.map(|e| e * inv_proj),
                    readout: r,
                    readout_std_err: r_se,
                    rays: acc.rays[ii * ndet + j],
                    relative: if spec > 0.0 { r / spec } else { f64::NAN },
                    clearcoat_seen: seen_cc,
                });
            }
        }
        Ok(TopoMuellerResult {
            points,
            totals: acc.totals,
        })
    }
}
