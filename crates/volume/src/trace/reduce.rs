//! The ordered reduction of a run's batch sums (Welford's mean and `M2` over the
//! batches) and the rows, energy balances and standard errors formed from it (module
//! docs, "Estimators").

use flakescatter_numerics::welford::Welford;
use flakescatter_optics::detector::{self, Cone};
use flakescatter_optics::fresnel;

use super::ray::{
    E_BINDER, E_CUT, E_FLAKES, E_MULTI, E_RIMS, E_SINGLE, E_SLOTS, E_SUB, E_VIA_SUB, Partial,
};
use super::{BATCHES, EnergyBalance, VolumePoint};

/// Ordered accumulation over batches: sums and Welford `M2` of the batch sums, in
/// the slots `[single, multiple, total]` per internal detector, then the energy slots
/// of [`Partial::energy`], then `absorbed_other` (rims plus cut off).
pub(super) struct Acc {
    stats: Welford,
    /// The batch's values, slot by slot (kept to avoid an allocation per batch).
    values: Vec<f64>,
    counts: Vec<u64>,
}

impl Acc {
    pub(super) fn new(nd: usize) -> Self {
        let slots = 3 * nd + E_SLOTS + 1;
        Self {
            stats: Welford::new(slots),
            values: vec![0.0; slots],
            counts: vec![0; nd],
        }
    }

    pub(super) fn add(&mut self, p: &Partial) {
        let nd = self.counts.len();
        for d in 0..nd {
            let [s, m] = p.cones[d];
            self.values[3 * d..3 * d + 3].copy_from_slice(&[s, m, s + m]);
            self.counts[d] += p.counts[d];
        }
        self.values[3 * nd..3 * nd + E_SLOTS].copy_from_slice(&p.energy);
        self.values[3 * nd + E_SLOTS] = p.energy[E_RIMS] + p.energy[E_CUT];
        self.stats.add(&self.values);
    }

    /// Σ over batches of detector `d`'s single (`k = 0`) or multiple (`k = 1`) part.
    fn sum(&self, d: usize, k: usize) -> f64 {
        self.stats.sum()[3 * d + k]
    }

    /// `M2` of detector `d`'s single (`k = 0`), multiple (1) or total (2) batch sums.
    fn m2(&self, d: usize, k: usize) -> f64 {
        self.stats.m2()[3 * d + k]
    }

    /// Σ over batches of energy slot `k`.
    fn energy(&self, k: usize) -> f64 {
        self.stats.sum()[3 * self.counts.len() + k]
    }

    /// `M2` of energy slot `k`; `k = E_SLOTS` for `absorbed_other`.
    fn energy_m2(&self, k: usize) -> f64 {
        self.stats.m2()[3 * self.counts.len() + k]
    }
}

/// The rows (incidence-major, then the user's detectors), energy balances and their
/// standard errors of a run, from each incidence's reduction `acc` (module docs,
/// "Estimators"): `all` are the internal detectors (the user's `cones`, then one
/// specular cone per incidence and distinct aperture of `apertures`), `n` the film
/// index, `rays` the rays per incidence.
pub(super) fn results(
    acc: &[Acc],
    theta_i: &[f64],
    cones: &[Cone],
    all: &[Cone],
    apertures: &[f64],
    n: f64,
    rays: u64,
) -> (Vec<VolumePoint>, Vec<EnergyBalance>, Vec<EnergyBalance>) {
    let ni = theta_i.len();
    let nf = rays as f64;
    let b = BATCHES as f64;
    let se = |m2: f64| (b / (b - 1.0) * m2).max(0.0).sqrt() / nf;
    let mut points = Vec::with_capacity(ni * cones.len());
    let mut energy = Vec::with_capacity(ni);
    let mut energy_se = Vec::with_capacity(ni);
    for (ii, &ti) in theta_i.iter().enumerate() {
        let a = &acc[ii];
        let entry = fresnel::air_to_coating(ti, n);
        let coat = entry.r_av();
        let specular = detector::specular_direction(ti);
        let value = |d: usize| {
            let coat_seen = if all[d].contains(&specular) {
                coat
            } else {
                0.0
            };
            coat_seen + (a.sum(d, 0) + a.sum(d, 1)) / nf
        };
        for (j, cone) in cones.iter().enumerate() {
            let proj = cone.projected_solid_angle();
            let coat_seen = if cone.contains(&specular) { coat } else { 0.0 };
            let single = a.sum(j, 0) / nf;
            let multiple = a.sum(j, 1) / nf;
            let total = coat_seen + single + multiple;
            let ap = apertures
                .iter()
                .position(|&x| x == cone.half_angle())
                .unwrap_or(0);
            let spec = value(cones.len() + ii * apertures.len() + ap);
            let total_se = se(a.m2(j, 2));
            points.push(VolumePoint {
                theta_i: ti,
                cone: *cone,
                brdf: total / proj,
                brdf_std_err: total_se / proj,
                coat_brdf: coat_seen / proj,
                single_brdf: single / proj,
                single_std_err: se(a.m2(j, 0)) / proj,
                multiple_brdf: multiple / proj,
                multiple_std_err: se(a.m2(j, 1)) / proj,
                reflectance: total,
                reflectance_std_err: total_se,
                relative: if spec > 0.0 { total / spec } else { f64::NAN },
                specular_reflectance: spec,
                rays: a.counts[j],
            });
        }
        let e = |k: usize| a.energy(k) / nf;
        let es = |k: usize| se(a.energy_m2(k));
        energy.push(EnergyBalance {
            coat_reflected: coat,
            escaped_single: e(E_SINGLE),
            escaped_multiple: e(E_MULTI),
            absorbed_substrate: e(E_SUB),
            absorbed_flakes: e(E_FLAKES),
            absorbed_binder: e(E_BINDER),
            absorbed_other: e(E_RIMS) + e(E_CUT),
            absorbed_rims: e(E_RIMS),
            cut_off: e(E_CUT),
            escaped_via_substrate: e(E_VIA_SUB),
        });
        energy_se.push(EnergyBalance {
            coat_reflected: 0.0,
            escaped_single: es(E_SINGLE),
            escaped_multiple: es(E_MULTI),
            absorbed_substrate: es(E_SUB),
            absorbed_flakes: es(E_FLAKES),
            absorbed_binder: es(E_BINDER),
            absorbed_other: se(a.energy_m2(E_SLOTS)),
            absorbed_rims: es(E_RIMS),
            cut_off: es(E_CUT),
            escaped_via_substrate: es(E_VIA_SUB),
        });
    }
    (points, energy, energy_se)
}
