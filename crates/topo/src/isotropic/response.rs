//! The response `h_j(θ)` of every detector to one ring ([`super::ring`]), per incidence
//! and node `θ` ([`IsoSetup::response`]).
//!
//! On the escaping arc, `k_out(φ)` is sampled at `M` equal steps (of `φ` on a whole
//! circle; of `v`, `φ = (lo + hi)/2 − (hi − lo)/2 · cos v`, on an arc whose ends exit at
//! the horizon like `sqrt(φ − lo)`), with `M` chosen so that consecutive exit
//! directions are less than `0.95 α_min` apart (`α_min` the smallest aperture). Every
//! detector whose axis lies within `α + 0.6 α_min` of a sample is a candidate: a point
//! of the ring inside a cone is within half a step of a sample, so no cone the ring
//! enters is missed. For each candidate cone the boundary condition
//! `k_out(φ)·r_j = cos α_j` is solved on every step where it changes sign (Newton's
//! method from the secant point, safeguarded by bisection, to 1e-13 rad), and a step
//! whose ends lie on the same side but whose derivative `d(k_out·r_j)/dφ` changes sign
//! (and whose ends are close enough to the rim for the step's length to reach it) is
//! searched for a hidden tangent pair (the extremum by the Illinois method on the
//! derivative, then two roots). The weight `F γ` (the exact Fresnel factors of
//! [`Transmission::path_factor`](flakescatter_optics::polarization::Transmission::path_factor)
//! at `cos ι = γ`, the inside exit cosine `k2.z` and `k_out.z`) is integrated over each
//! resulting azimuth interval by 8-point Gauss–Legendre (`gauss-quad`) on panels of at
//! most π/8, in `v` on a partial arc: a unit test finds it within 1e-12 of 32 points on
//! panels of π/64, also for intervals that end at the horizon.

use std::f64::consts::{PI, TAU};

use flakescatter_optics::detector::{self, Cone};
use flakescatter_optics::fresnel::{self, FresnelPower};
use flakescatter_optics::jones::RayPath;
use flakescatter_optics::polarization::Weighting;
use flakescatter_optics::{Vec3, refraction};
use gauss_quad::legendre::GaussLegendre;

use super::ring::{Arc, Axis, Ring, RingPoint};
use super::search::{end_slope, extremum, push, root};
use super::table::{NodeResponse, runs_of};
use crate::TopoError;
use crate::index::{self, ConeIndex};
use crate::model::{TopoOptions, path_factor_of, printed_scale};

/// Gauss–Legendre points per panel of the azimuth integrals.
const GL_POINTS: usize = 8;

/// Largest panel of the azimuth integrals, radians.
const PANEL: f64 = PI / 8.0;

/// Fewest samples of a ring.
const MIN_SAMPLES: usize = 32;

/// Most samples of a ring.
const MAX_SAMPLES: usize = 1 << 16;

/// Per-incidence constants of the isotropic run.
pub(crate) struct IsoInc {
    pub(crate) st: f64,
    pub(crate) ct: f64,
    pub(crate) entry: FresnelPower,
    /// Entry amplitudes `(ts, tp)` and the incident direction, for the Jones path.
    pub(crate) entry_t: (f64, f64),
    pub(crate) k_in: Vec3,
    /// Internal detectors of this incidence: the user's cones, then one specular cone
    /// per distinct aperture.
    pub(crate) cones: Vec<Cone>,
    pub(crate) axes: Vec<Axis>,
    pub(crate) index: ConeIndex,
    /// Per internal detector: `1/cos θt` (physical) or `cos ϑ'/cos ϑ` (paper-printed).
    pub(crate) scale: Vec<f64>,
}

/// Everything fixed during an isotropic run.
pub(crate) struct IsoSetup<'a> {
    pub(crate) options: &'a TopoOptions,
    pub(crate) incs: Vec<IsoInc>,
    pub(crate) kappa: f64,
    /// Largest allowed distance between consecutive ring samples, radians.
    pub(crate) max_step: f64,
    pub(crate) gl: Vec<(f64, f64)>,
    pub(crate) inv_delta: f64,
}

/// Scratch buffers of the ring computation.
#[derive(Debug, Default)]
pub(crate) struct RingScratch {
    pub(crate) phi: Vec<f64>,
    pub(crate) pts: Vec<RingPoint>,
    pub(crate) pairs: Vec<(u32, u32)>,
    pub(crate) segs: Vec<u32>,
    pub(crate) intervals: Vec<(f64, f64)>,
}

impl<'a> IsoSetup<'a> {
    /// The constants of a run with `options` at incidences `theta_i` (rad) into
    /// `cones`, with node spacing `delta` (rad): per incidence the internal detectors
    /// (the user's cones, then a specular cone per distinct aperture of `apertures`, for
    /// `relative`), their axes, an index widened by `0.6 α_min` and their factors.
    ///
    /// # Errors
    /// [`TopoError::Detector`] for a specular cone that cannot be built.
    pub fn new(
        options: &'a TopoOptions,
        theta_i: &[f64],
        cones: &[Cone],
        apertures: &[f64],
        delta: f64,
    ) -> Result<Self, TopoError> {
        let n = options.n;
        let alpha_min = cones
            .iter()
            .map(Cone::half_angle)
            .fold(f64::INFINITY, f64::min);
        let margin = 0.6 * alpha_min;
        let mut incs = Vec::with_capacity(theta_i.len());
        for &t in theta_i {
            let mut all = cones.to_vec();
            for &a in apertures {
                all.push(Cone::in_plane(-t, a).map_err(TopoError::Detector)?);
            }
            let k1 = refraction::into_coating(&detector::incident_direction(t), n);
            let ct = -k1.z;
            let scale = all
                .iter()
                .map(|c| match options.weighting {
                    Weighting::Physical => 1.0 / ct,
                    Weighting::PaperPrinted => printed_scale(Weighting::PaperPrinted, c, n),
                })
                .collect();
            let amps = fresnel::amplitudes_air_to_coating(t, n);
            incs.push(IsoInc {
                st: k1.x,
                ct,
                entry: fresnel::air_to_coating(t, n),
                entry_t: (amps[2], amps[3]),
                k_in: *detector::incident_direction(t),
                axes: all.iter().map(Axis::new).collect(),
                index: ConeIndex::with_margin(&all, margin, index::COARSE),
                scale,
                cones: all,
            });
        }
        let gl = GaussLegendre::new(GL_POINTS.try_into().expect("non-zero"))
            .as_node_weight_pairs()
            .to_vec();
        Ok(IsoSetup {
            options,
            incs,
            kappa: (1.0 - 1.0 / (n * n)).max(0.0).sqrt(),
            max_step: 0.95 * alpha_min,
            gl,
            inv_delta: 1.0 / delta,
        })
    }
}

impl IsoSetup<'_> {
    /// `h_j(θ)` for every detector of incidence `ii` (module docs).
    pub(crate) fn response(&self, ii: usize, theta: f64, sc: &mut RingScratch) -> NodeResponse {
        let inc = &self.incs[ii];
        let n = self.options.n;
        let ring = Ring::new(n, inc.st, inc.ct, theta);
        let down = ring.fraction_below(0.0);
        let tir = (ring.fraction_below(self.kappa) - down).max(0.0);
        let mut out = NodeResponse {
            entries: Vec::new(),
            runs: Vec::new(),
            tir,
            down,
        };
        let (lo, hi, full) = match ring.arc(self.kappa) {
            Arc::None => return out,
            Arc::Full => (0.0, TAU, true),
            Arc::Range(lo, hi) => (lo, hi, false),
        };
        self.sample(&ring, (lo, hi, full), sc);
        let m = sc.pts.len() - 1;

        // Candidate (detector, sample) pairs.
        sc.pairs.clear();
        for (i, p) in sc.pts.iter().enumerate() {
            for e in inc.index.candidates(p.o[0], p.o[1]) {
                if e.ax * p.o[0] + e.ay * p.o[1] + e.az * p.o[2] > e.cos_reach {
                    sc.pairs.push((e.index, i as u32));
                }
            }
        }
        sc.pairs.sort_unstable();
        sc.pairs.dedup();

        let mut start = 0;
        while start < sc.pairs.len() {
            let det = sc.pairs[start].0;
            let mut end = start;
            while end < sc.pairs.len() && sc.pairs[end].0 == det {
                end += 1;
            }
            // Steps next to a candidate sample: [i−1, i] and [i, i+1].
            sc.segs.clear();
            for &(_, i) in &sc.pairs[start..end] {
                if i > 0 {
                    sc.segs.push(i - 1);
                }
                if (i as usize) < m {
                    sc.segs.push(i);
                }
            }
            start = end;
            sc.segs.sort_unstable();
            sc.segs.dedup();
            let axis = inc.axes[det as usize];
            sc.intervals.clear();
            for k in 0..sc.segs.len() {
                let i = sc.segs[k] as usize;
                self.inside_on_step(&ring, &axis, sc, i);
            }
            let mut total = 0.0;
            for &(u, w) in &sc.intervals {
                total += self.integrate(&ring, inc, (lo, hi, full), u, w);
            }
            if total > 0.0 {
                out.entries
                    .push((det, total / TAU * inc.scale[det as usize]));
            }
        }
        out.runs = runs_of(&out.entries);
        out
    }

    /// Samples the arc `[lo, hi]` (`full` for the whole circle) with consecutive exit
    /// directions less than `max_step` apart; `sc.pts` gets `M + 1` points (the last at
    /// `hi`). A partial arc is sampled uniformly in `v`, `φ = (lo + hi)/2 −
    /// (hi − lo)/2 · cos v`, because the exit direction leaves the horizon like
    /// `sqrt(φ − lo)` at its ends.
    pub(crate) fn sample(&self, ring: &Ring, arc: (f64, f64, bool), sc: &mut RingScratch) {
        let (lo, hi, full) = arc;
        let (c0, c1) = (0.5 * (lo + hi), 0.5 * (hi - lo));
        let fill = |m: usize, sc: &mut RingScratch| -> f64 {
            sc.phi.clear();
            sc.pts.clear();
            for i in 0..=m {
                let phi = if i == m {
                    hi
                } else if i == 0 {
                    lo
                } else if full {
                    TAU * i as f64 / m as f64
                } else {
                    c0 - c1 * (PI * i as f64 / m as f64).cos()
                };
                sc.phi.push(phi);
                sc.pts.push(ring.at(phi));
            }
            sc.pts
                .windows(2)
                .map(|w| {
                    let d = [
                        w[1].o[0] - w[0].o[0],
                        w[1].o[1] - w[0].o[1],
                        w[1].o[2] - w[0].o[2],
                    ];
                    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
                })
                .fold(0.0, f64::max)
        };
        let coarse = fill(MIN_SAMPLES, sc);
        if coarse <= self.max_step {
            return;
        }
        let mut m = ((MIN_SAMPLES as f64 * coarse / self.max_step * 1.1).ceil() as usize)
            .clamp(MIN_SAMPLES, MAX_SAMPLES);
        loop {
            let chord = fill(m, sc);
            if chord <= self.max_step || m >= MAX_SAMPLES {
                return;
            }
            m = (2 * m).min(MAX_SAMPLES);
        }
    }

    /// Appends the parts of step `i` (between samples `i` and `i + 1`) that lie inside
    /// the cone, merging with the previous interval when they touch.
    pub(crate) fn inside_on_step(&self, ring: &Ring, axis: &Axis, sc: &mut RingScratch, i: usize) {
        let (pa, pb) = (sc.pts[i], sc.pts[i + 1]);
        let (a, b) = (sc.phi[i], sc.phi[i + 1]);
        let (fa, fb) = (axis.f(&pa), axis.f(&pb));
        match (fa > 0.0, fb > 0.0) {
            (true, false) => {
                let r = root(ring, axis, (a, fa), (b, fb));
                push(a, r, &mut sc.intervals);
            }
            (false, true) => {
                let r = root(ring, axis, (a, fa), (b, fb));
                push(r, b, &mut sc.intervals);
            }
            (true, true) => {
                // A dip out of the cone inside the step? Every point of the step is
                // within (d_a + d_b + L)/2 of the axis (L the step's arc length), so
                // only steps near the rim can leave the cone.
                let (da, db) = (end_slope(axis, &pa, true), end_slope(axis, &pb, false));
                if da < 0.0 && db > 0.0 && axis.may_leave(&pa, &pb) {
                    let x = extremum(ring, axis, (a, da), (b, db));
                    let fx = axis.f(&ring.at(x));
                    if fx <= 0.0 {
                        let r1 = root(ring, axis, (a, fa), (x, fx));
                        let r2 = root(ring, axis, (x, fx), (b, fb));
                        push(a, r1, &mut sc.intervals);
                        push(r2, b, &mut sc.intervals);
                        return;
                    }
                }
                push(a, b, &mut sc.intervals);
            }
            (false, false) => {
                // A hidden visit of the cone inside the step? Only possible when
                // (d_a + d_b − L)/2 < α.
                let (da, db) = (end_slope(axis, &pa, true), end_slope(axis, &pb, false));
                if da > 0.0 && db < 0.0 && axis.may_enter(&pa, &pb) {
                    let x = extremum(ring, axis, (a, da), (b, db));
                    let fx = axis.f(&ring.at(x));
                    if fx > 0.0 {
                        let r1 = root(ring, axis, (a, fa), (x, fx));
                        let r2 = root(ring, axis, (x, fx), (b, fb));
                        push(r1, r2, &mut sc.intervals);
                    }
                }
            }
        }
    }

    /// `∫_u^w F γ dφ` over part of the escaping arc `[lo, hi]` (`full` for the whole
    /// circle). On a partial arc the exit direction leaves at the horizon at both ends,
    /// where `k_out.z` and the exit Fresnel factor go like `sqrt(φ − lo)`; the
    /// substitution `φ = (lo + hi)/2 − (hi − lo)/2 · cos v` makes the integrand analytic
    /// there. 8-point Gauss–Legendre on panels of at most π/8 (in `φ` or `v`).
    pub(crate) fn integrate(
        &self,
        ring: &Ring,
        inc: &IsoInc,
        arc: (f64, f64, bool),
        u: f64,
        w: f64,
    ) -> f64 {
        let (lo, hi, full) = arc;
        let (c0, c1) = (0.5 * (lo + hi), 0.5 * (hi - lo));
        let to_v = |phi: f64| ((c0 - phi) / c1).clamp(-1.0, 1.0).acos();
        let (a, b) = if full { (u, w) } else { (to_v(u), to_v(w)) };
        let opts = self.options;
        let n = opts.n;
        let panels = ((b - a) / PANEL).ceil().max(1.0);
        let h = (b - a) / panels;
        let mut total = 0.0;
        for p in 0..panels as usize {
            let mid = a + (p as f64 + 0.5) * h;
            let mut s = 0.0;
            for &(x, wt) in &self.gl {
                let v = mid + 0.5 * h * x;
                let (phi, jac) = if full {
                    (v, 1.0)
                } else {
                    let (sv, cv) = v.sin_cos();
                    (c0 - c1 * cv, c1 * sv)
                };
                let q = ring.at(phi);
                if q.k2z <= 0.0 || q.o[2] <= 0.0 {
                    continue;
                }
                // The same exact path factor as the plain model's ray (its Jones path
                // out of the plane of incidence), at this azimuth of the normal.
                let (sp, cp) = phi.sin_cos();
                let m = Vec3::new(ring.s * cp, ring.s * sp, ring.c);
                let k1 = Vec3::new(inc.st, 0.0, -inc.ct);
                let path = RayPath {
                    k_in: inc.k_in,
                    k1,
                    m,
                    k2: Vec3::new(q.o[0] / n, q.o[1] / n, q.k2z),
                    k_out: Vec3::new(q.o[0], q.o[1], q.o[2]),
                };
                s += wt
                    * jac
                    * path_factor_of(opts, &inc.entry, inc.entry_t, &path, q.gamma)
                    * q.gamma;
            }
            total += 0.5 * h * s;
        }
        total
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn setup_for<'a>(options: &'a TopoOptions, theta_i: f64, cones: &[Cone]) -> IsoSetup<'a> {
        let n = options.n;
        let k1 = refraction::into_coating(&detector::incident_direction(theta_i), n);
        let alpha_min = cones
            .iter()
            .map(Cone::half_angle)
            .fold(f64::INFINITY, f64::min);
        IsoSetup {
            options,
            incs: vec![IsoInc {
                st: k1.x,
                ct: -k1.z,
                entry: fresnel::air_to_coating(theta_i, n),
                entry_t: {
                    let a = fresnel::amplitudes_air_to_coating(theta_i, n);
                    (a[2], a[3])
                },
                k_in: *detector::incident_direction(theta_i),
                axes: cones.iter().map(Axis::new).collect(),
                index: ConeIndex::with_margin(cones, 0.6 * alpha_min, index::COARSE),
                scale: vec![1.0; cones.len()],
                cones: cones.to_vec(),
            }],
            kappa: (1.0 - 1.0 / (n * n)).sqrt(),
            max_step: 0.95 * alpha_min,
            gl: GaussLegendre::new(GL_POINTS.try_into().unwrap())
                .as_node_weight_pairs()
                .to_vec(),
            inv_delta: 1.0,
        }
    }

    /// The azimuth rule (8 points on panels ≤ π/8) against 32 points on panels of π/64
    /// over whole escaping arcs and parts of them, including arcs that end at the
    /// horizon: the two agree to 1e-12.
    #[test]
    fn azimuth_rule_is_exact_to_rounding() {
        let options = TopoOptions::default();
        let cones = [Cone::in_plane(0.0, 0.1).unwrap()];
        let setup = setup_for(&options, 0.0, &cones);
        let mut fine_setup = setup_for(&options, 0.0, &cones);
        fine_setup.gl = GaussLegendre::new(32.try_into().unwrap())
            .as_node_weight_pairs()
            .to_vec();
        let mut checked = 0;
        for ti in [0.0f64, 0.5, 1.0, 1.3] {
            let st = ti.sin() / options.n;
            let inc = setup_for(&options, ti, &cones).incs.remove(0);
            assert!((inc.st - st).abs() < 1e-15);
            for theta in [0.01f64, 0.1, 0.3, 0.6, 0.9] {
                let ring = Ring::new(options.n, inc.st, inc.ct, theta);
                let arc = match ring.arc(setup.kappa) {
                    Arc::None => continue,
                    Arc::Full => (0.0, TAU, true),
                    Arc::Range(lo, hi) => (lo, hi, false),
                };
                for (fa, fb) in [(0.0, 1.0), (0.0, 0.3), (0.45, 0.55), (0.9, 1.0)] {
                    let (u, w) = (arc.0 + fa * (arc.1 - arc.0), arc.0 + fb * (arc.1 - arc.0));
                    let got = setup.integrate(&ring, &inc, arc, u, w);
                    let panels = ((w - u) / (PI / 64.0)).ceil() as usize;
                    let step = (w - u) / panels as f64;
                    let want: f64 = (0..panels)
                        .map(|p| {
                            let a = u + p as f64 * step;
                            fine_setup.integrate(&ring, &inc, arc, a, a + step)
                        })
                        .sum();
                    assert!(
                        (got - want).abs() <= 1e-12 * want.abs(),
                        "θi {ti} θ {theta} [{fa}, {fb}]: {got} vs {want}"
                    );
                    checked += 1;
                }
            }
        }
        assert!(checked > 50, "{checked}");
    }
}
