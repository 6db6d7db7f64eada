//! Fast evaluation of the paint model at a fit's points.
//!
//! The model of [`crate::model`] is evaluated term for term, with what does not change
//! between evaluations kept: for a coat index, each point's geometry (the distribution
//! model's [`kernel`](flakescatter_gaussian::DistributionModel::kernel) per channel, the
//! coat surface's Fresnel factor and half vector, the inside angles and the flat
//! transmittances); for an orientation, its density and shadowing table; for the coat
//! surface, its albedo table. A test holds the values to [`PaintModel::brdf`] at 1e-12.
//!
//! [`PaintModel::brdf`]: crate::PaintModel::brdf

use std::cell::RefCell;
use std::sync::Arc;

use flakescatter_gaussian::{DistributionModel, ModelOptions};
use flakescatter_optics::{Vec3, fresnel};
use flakescatter_stats::{GaussianWidth, Orientation};
use rayon::prelude::*;

use super::data::{Measurement, Point};
use super::layout::Layout;
use crate::PaintError;
use crate::base::base_brdf;
use crate::coat::{AlbedoTable, CoatSurface, lobe_value};
use crate::layer::FlakeShadowing;
use crate::model::FlakeMetal;

/// One point's geometry at one coat index.
#[derive(Debug, Clone, Copy)]
struct PointGeometry {
    /// Index into the incidences.
    incidence: usize,
    /// `cos θo` of the detector.
    wo_z: f64,
    /// The coat lobe's `(F, cos θm)`, if any facet reflects into the detector.
    lobe: Option<(f64, f64)>,
    /// Inside exit angle `θ2`.
    theta_2: f64,
    /// `cos θ2`.
    cos_2: f64,
    /// Flat exit transmittance `T_av(θo)`.
    t_out: f64,
    /// The flake kernel `(θn, K)` in the point's channel, if any normal reaches it.
    kernel: Option<(f64, f64)>,
}

/// One incidence at one coat index.
#[derive(Debug, Clone, Copy)]
struct IncidenceGeometry {
    cos_i: f64,
    /// Inside angle `θt`.
    theta_t: f64,
    /// `cos θt`.
    cos_t: f64,
    /// Flat entry transmittance `T_av(θi)`.
    t_in: f64,
}

/// All points at one coat index (and stack thickness, when fitted).
#[derive(Debug)]
struct Geometry {
    n: f64,
    thickness: Option<f64>,
    incidences: Vec<IncidenceGeometry>,
    points: Vec<PointGeometry>,
}

/// The evaluator of one fit.
pub(crate) struct Engine<'a> {
    measurement: &'a Measurement,
    points: &'a [Point],
    layout: &'a Layout,
    metal: FlakeMetal,
    /// The stack's layers whose thickness the layout's thickness entry sets.
    thickness_layers: &'a [usize],
    /// `λ` of the log-linear penalty.
    smoothing: f64,
    /// Distinct incidence angles, and each row's index into them.
    thetas: Vec<f64>,
    row_incidence: Vec<usize>,
    geometry: RefCell<Option<Geometry>>,
    orientation: RefCell<Option<(Vec<u64>, Orientation, FlakeShadowing)>>,
    coat: RefCell<Option<(Vec<u64>, CoatSurface)>>,
    /// Albedo tables of the coat's populations met so far (the last few).
    tables: RefCell<Vec<Arc<AlbedoTable>>>,
}

/// How many albedo tables the engine keeps.
const TABLES_KEPT: usize = 12;

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

impl<'a> Engine<'a> {
    pub(crate) fn new(
        measurement: &'a Measurement,
        points: &'a [Point],
        layout: &'a Layout,
        metal: FlakeMetal,
        thickness_layers: &'a [usize],
        smoothing: f64,
    ) -> Self {
        let mut thetas: Vec<f64> = Vec::new();
        let row_incidence = measurement
            .rows
            .iter()
            .map(|r| {
                thetas
                    .iter()
                    .position(|&t| t == r.theta_i)
                    .unwrap_or_else(|| {
                        thetas.push(r.theta_i);
                        thetas.len() - 1
                    })
            })
            .collect();
        Self {
            measurement,
            points,
            layout,
            metal,
            thickness_layers,
            smoothing,
            thetas,
            row_incidence,
            geometry: RefCell::new(None),
            orientation: RefCell::new(None),
            coat: RefCell::new(None),
            tables: RefCell::new(Vec::new()),
        }
    }

    /// The geometry at index `n` and stack thickness `thickness` (nm, when fitted),
    /// built on first use and whenever either changes.
    fn build_geometry(&self, n: f64, thickness: Option<f64>) -> Result<Geometry, PaintError> {
        let metal = match thickness {
            Some(d) => self.metal.with_thickness(self.thickness_layers, d)?,
            None => self.metal.clone(),
        };
        // The kernel does not depend on the distribution: any one will do.
        let any = Orientation::gaussian(GaussianWidth::Hwhm(0.1))
            .map_err(|e| PaintError::Fit(e.to_string()))?;
        let models = self
            .measurement
            .channels
            .iter()
            .map(|c| {
                let options = ModelOptions {
                    flake: metal.at(c, n)?,
                    ..ModelOptions::default()
                };
                DistributionModel::new(any.clone(), n, options)
                    .map_err(|e| PaintError::Parameter(format!("flakes: {e}")))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let incs = self
            .thetas
            .iter()
            .map(|&t| {
                models
                    .iter()
                    .map(|m| m.incidence(t))
                    .collect::<Result<Vec<_>, _>>()
                    .map_err(|e| PaintError::Geometry(e.to_string()))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let incidences = self
            .thetas
            .iter()
            .zip(&incs)
            .map(|(&t, inc)| IncidenceGeometry {
                cos_i: t.cos(),
                theta_t: inc[0].cos_t.clamp(-1.0, 1.0).acos(),
                cos_t: inc[0].cos_t,
                t_in: fresnel::air_to_coating(t, n).t_av(),
            })
            .collect();
        let (rows, row_incidence) = (&self.measurement.rows, &self.row_incidence);
        let points = self
            .points
            .par_iter()
            .map(|p| {
                let o = &rows[p.row];
                let i = row_incidence[p.row];
                let r = o.direction();
                let wi = Vec3::new(-o.theta_i.sin(), 0.0, o.theta_i.cos());
                let c2 = (n * n - 1.0 + r.z * r.z).max(0.0).sqrt() / n;
                PointGeometry {
                    incidence: i,
                    wo_z: r.z,
                    lobe: crate::coat::lobe_geometry(n, &wi, &r),
                    theta_2: c2.clamp(-1.0, 1.0).acos(),
                    cos_2: c2,
                    t_out: fresnel::power_from_cosines(r.z, c2, n).t_av(),
                    kernel: models[p.channel]
                        .kernel(&incs[i][p.channel], &r)
                        .map(|k| (k.theta_n, k.factor)),
                }
            })
            .collect();
        Ok(Geometry {
            n,
            thickness,
            incidences,
            points,
        })
    }

    /// The model's value at every point for the parameters `q`, sr⁻¹.
    pub(crate) fn values(&self, q: &[f64]) -> Result<Vec<f64>, PaintError> {
        let l = self.layout;
        let n = l.n(q);
        let thickness = l.thickness(q);
        {
            let mut g = self.geometry.borrow_mut();
            if g.as_ref()
                .is_none_or(|g| g.n != n || g.thickness != thickness)
            {
                *g = Some(self.build_geometry(n, thickness)?);
            }
        }
        {
            let key: Vec<u64> = bits(l.shape(q)).into_iter().chain([n.to_bits()]).collect();
            let mut o = self.orientation.borrow_mut();
            if o.as_ref().is_none_or(|(k, _, _)| *k != key) {
                let orientation = l.orientation(q)?;
                let shadowing = FlakeShadowing::new(&orientation, n);
                *o = Some((key, orientation, shadowing));
            }
        }
        {
            let key = bits(l.coat_entries(q))
                .into_iter()
                .chain([n.to_bits()])
                .collect();
            let mut c = self.coat.borrow_mut();
            if c.as_ref().is_none_or(|(k, _)| *k != key) {
                let mut tables = self.tables.borrow_mut();
                let mut table = |alpha: f64, n: f64| {
                    if let Some(i) = tables.iter().position(|t| t.key() == (alpha, n)) {
                        let t = tables.remove(i);
                        tables.push(t.clone());
                        return t;
                    }
                    let t = Arc::new(AlbedoTable::new(alpha, n));
                    if tables.len() == TABLES_KEPT {
                        tables.remove(0);
                    }
                    tables.push(t.clone());
                    t
                };
                *c = Some((key, CoatSurface::with_tables(l.coat(q), &mut table)?));
            }
        }
        let geometry = self.geometry.borrow();
        let geometry = geometry.as_ref().expect("built above");
        let orientation = self.orientation.borrow();
        let (_, orientation, shadowing) = orientation.as_ref().expect("built above");
        let coat = self.coat.borrow();
        let (_, coat) = coat.as_ref().expect("built above");
        let inv_mean_cos = 1.0 / orientation.mean_cos();
        let cp = coat.params().clone();
        let flake_amp: Vec<f64> = (0..l.channels).map(|k| l.flake_amplitude(q, k)).collect();
        let base_amp: Vec<f64> = (0..l.channels).map(|k| l.base_amplitude(q, k)).collect();
        let tints = (0..l.channels)
            .map(|k| crate::model::tint_absorption(l.tint(q, k)))
            .collect::<Result<Vec<_>, _>>()?;
        // Per incidence: τ(θi), T'(θi), G1(θt).
        let per_inc: Vec<(f64, f64, f64)> = geometry
            .incidences
            .iter()
            .map(|g| {
                let tau = coat.transmission_factor(g.cos_i);
                (tau, tau * g.t_in, shadowing.g1(g.theta_t))
            })
            .collect();
        let r_i = coat.internal_diffuse_reflectance();
        let values = self
            .points
            .par_iter()
            .zip(&geometry.points)
            .map(|(p, g)| {
                let (tau_in, t_in, g1_in) = per_inc[g.incidence];
                let cos_i = geometry.incidences[g.incidence].cos_i;
                let k = p.channel;
                let mut coat_term = 0.0;
                if let Some((f, cm)) = g.lobe {
                    if cp.roughness > 0.0 && cp.haze < 1.0 {
                        coat_term +=
                            (1.0 - cp.haze) * lobe_value(cp.roughness, f, cm, cos_i, g.wo_z);
                    }
                    if cp.haze > 0.0 {
                        coat_term += cp.haze * lobe_value(cp.haze_roughness, f, cm, cos_i, g.wo_z);
                    }
                }
                let tau_out = coat.transmission_factor(g.wo_z);
                let flakes = match g.kernel {
                    Some((theta_n, kf)) => {
                        let d = orientation.p2(theta_n) * inv_mean_cos;
                        if d == 0.0 {
                            0.0
                        } else {
                            flake_amp[k]
                                * g1_in
                                * shadowing.g1(g.theta_2)
                                * tau_in
                                * tau_out
                                * (kf * d)
                                * tints[k].map_or(1.0, |a| {
                                    a.factor(geometry.incidences[g.incidence].cos_t, g.cos_2)
                                })
                        }
                    }
                    None => 0.0,
                };
                let base = base_brdf(1.0, base_amp[k], t_in, tau_out * g.t_out, geometry.n, r_i);
                coat_term + flakes + base
            })
            .collect();
        Ok(values)
    }

    /// Weighted log residuals `(ln m − ln y)/σ` of the points, then the penalty rows;
    /// `None` where the model is not positive at a point.
    pub(crate) fn residuals(&self, q: &[f64]) -> Result<Option<Vec<f64>>, PaintError> {
        let m = self.values(q)?;
        let mut r = Vec::with_capacity(m.len() + 16);
        for (p, v) in self.points.iter().zip(&m) {
            if !(*v > 0.0 && v.is_finite()) {
                return Ok(None);
            }
            r.push((v.ln() - p.value.ln()) / p.sigma_ln);
        }
        self.layout.penalty(q, self.smoothing, &mut r);
        Ok(Some(r))
    }
}
