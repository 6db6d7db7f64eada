//! Several independent layers from one seed, and standard errors that include the
//! scatter between layers (physics.md §10, "Standard errors").
//!
//! One layer's standard errors ([`crate::trace`]) are those of its rays; a layer is one
//! draw of the flakes, and a detector cone that a few flakes feed changes with each
//! draw far more than with the rays (on the paper's coating, over 20 seeds, 9–12 times
//! the ray error). [`run_layers`] places `K` independent layers (realisations
//! `0 … K−1` of the seed: ChaCha8 streams of the layer, ray generators keyed by the
//! realisation), traces `N/K` rays per incidence through each, and reports for every
//! estimate `x` the mean of the `K` layer estimates `x_k` and:
//! * the **total** standard error of that mean, `s/√K` with
//!   `s² = Σ (x_k − x̄)² / (K − 1)`: the `x_k` are independent and identically
//!   distributed (a layer and its rays drawn afresh), so this is unbiased for the
//!   variance of `x̄` and holds both parts;
//! * its **ray part** `√(Σ r_k²) / K`, `r_k` the batch standard error of layer `k`;
//! * its **between-layer part** `√max(0, total² − ray²)`;
//! * the half-width of the 95 % interval, `t_{0.975, K−1} · total` (Student's t: `s` rests
//!   on `K − 1` degrees of freedom).
//!
//! With `K = 1` the total is the ray part and the layer part and the interval are not
//! estimable (`None`). Each layer is traced with all threads and the layers are combined
//! in order, so results are bit-identical for any thread count; one layer is in memory
//! at a time.

use flakescatter_optics::detector::Cone;
use statrs::distribution::{ContinuousCDF, StudentsT};

use crate::VolumeError;
use crate::layer::{Layer, LayerStats};
use crate::params::LayerParams;
use crate::trace::{EnergyBalance, TraceOptions, Tracer, VolumePoint, VolumeResult};

/// Most layers one run may draw.
pub const MAX_LAYERS: u32 = 10_000;

/// The standard errors of one estimate over `K` layers (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LayeredError {
    /// Standard error of the mean over layers (rays and layers together).
    pub total: f64,
    /// Its ray part, `√(Σ r_k²)/K`.
    pub rays: f64,
    /// Its between-layer part, `√max(0, total² − rays²)`; `None` for one layer.
    pub layers: Option<f64>,
    /// Half-width of the 95 % interval, `t_{0.975, K−1} · total`; `None` for one layer.
    pub ci95: Option<f64>,
}

/// One incidence × one detector over all layers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LayeredPoint {
    /// Means over the layers (`relative` is the summed reflectance over the summed
    /// specular reflectance, `rays` the escapes of all layers); its `*_std_err` fields
    /// are the **total** standard errors of those means.
    pub mean: VolumePoint,
    /// The parts of `mean.brdf_std_err` (sr⁻¹).
    pub brdf_error: LayeredError,
}

/// A layered run's result.
#[derive(Debug, Clone, PartialEq)]
pub struct LayeredResult {
    /// Rows, incidence-major then detector.
    pub points: Vec<LayeredPoint>,
    /// Mean energy balance per incidence.
    pub energy: Vec<EnergyBalance>,
    /// Its total standard errors (0 for `coat_reflected`).
    pub energy_std_err: Vec<EnergyBalance>,
    /// What placement realised, per layer.
    pub layers: Vec<LayerStats>,
    /// Rays traced per incidence through each layer (a multiple of the batches).
    pub rays_per_layer: u64,
    /// Straight segments traced, all layers and incidences.
    pub segments: u64,
    /// The seed.
    pub seed: u64,
    /// `t_{0.975, K−1}` (NaN for one layer).
    pub t975: f64,
}

/// Combines `K` values `x` with ray standard errors `r`: (mean, error).
fn combine(x: &[f64], r: &[f64], t975: f64) -> (f64, LayeredError) {
    let k = x.len() as f64;
    let mean = x.iter().sum::<f64>() / k;
    let rays = r.iter().map(|v| v * v).sum::<f64>().sqrt() / k;
    if x.len() < 2 {
        return (
            mean,
            LayeredError {
                total: rays,
                rays,
                layers: None,
                ci95: None,
            },
        );
    }
    let s2 = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (k - 1.0);
    let total = (s2 / k).sqrt();
    (
        mean,
        LayeredError {
            total,
            rays,
            layers: Some((total * total - rays * rays).max(0.0).sqrt()),
            ci95: Some(t975 * total),
        },
    )
}

/// A field of [`EnergyBalance`], by mutable reference.
type EnergyField = fn(&mut EnergyBalance) -> &mut f64;

/// Every field of [`EnergyBalance`].
const ENERGY_FIELDS: [EnergyField; 10] = [
    |b| &mut b.coat_reflected,
    |b| &mut b.escaped_single,
    |b| &mut b.escaped_multiple,
    |b| &mut b.absorbed_substrate,
    |b| &mut b.absorbed_flakes,
    |b| &mut b.absorbed_binder,
    |b| &mut b.absorbed_other,
    |b| &mut b.absorbed_rims,
    |b| &mut b.cut_off,
    |b| &mut b.escaped_via_substrate,
];

/// The energy balance of incidence `i` over the layers: (means, total standard errors).
fn combine_energy(runs: &[VolumeResult], i: usize, t975: f64) -> (EnergyBalance, EnergyBalance) {
    let mut mean = EnergyBalance::default();
    let mut se = EnergyBalance::default();
    for field in ENERGY_FIELDS {
        // A copy of each balance, read through the field's accessor.
        let get = |mut b: EnergyBalance| *field(&mut b);
        let x: Vec<f64> = runs.iter().map(|r| get(r.energy[i])).collect();
        let e: Vec<f64> = runs.iter().map(|r| get(r.energy_std_err[i])).collect();
        let (m, err) = combine(&x, &e, t975);
        *field(&mut mean) = m;
        *field(&mut se) = err.total;
    }
    // The coat's reflection is exact: the same in every layer, no error.
    mean.coat_reflected = runs[0].energy[i].coat_reflected;
    se.coat_reflected = 0.0;
    (mean, se)
}

/// Traces `layers` independent realisations of the layer of `params` (module docs),
/// `options.rays` rays per incidence in all: `⌈rays / layers⌉` per layer, rounded up to
/// whole batches. `progress(done, total)` counts chunks of rays over all layers.
///
/// # Errors
/// [`VolumeError::Parameter`] (`layers`) for 0 or more than [`MAX_LAYERS`] layers; as
/// [`Layer::generate`], [`Tracer::new`] and [`Tracer::run_with_progress`].
pub fn run_layers(
    params: &LayerParams,
    options: &TraceOptions,
    layers: u32,
    theta_i: &[f64],
    cones: &[Cone],
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<LayeredResult, VolumeError> {
    let mut each = run_layers_each(
        params,
        std::slice::from_ref(options),
        layers,
        theta_i,
        cones,
        progress,
    )?;
    Ok(each.remove(0))
}

/// [`run_layers`] for each of several tracing options over the **same** layers (one
/// result per entry of `options`, in order): each layer is placed once and traced with
/// every option set in turn, and the result for `options[j]` is the same bits as
/// [`run_layers`] with `options[j]` alone (the layers come from `params` alone, the rays
/// from each option set's seed). A spectrum is one option set per wavelength with the
/// same seed: its wavelengths share the layers and the rays' random numbers (common
/// random numbers), so its shape is not blurred by independent noise at each
/// wavelength. `progress(done, total)` counts chunks of rays over all layers and option
/// sets.
///
/// # Errors
/// [`VolumeError::Empty`] for no option set; as [`run_layers`].
pub fn run_layers_each(
    params: &LayerParams,
    options: &[TraceOptions],
    layers: u32,
    theta_i: &[f64],
    cones: &[Cone],
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<Vec<LayeredResult>, VolumeError> {
    if layers == 0 || layers > MAX_LAYERS {
        return Err(VolumeError::Parameter {
            name: "layers",
            value: f64::from(layers),
            expected: "between 1 and 10000 layers",
        });
    }
    if options.is_empty() {
        return Err(VolumeError::Empty("tracing options"));
    }
    let per_layer: Vec<TraceOptions> = options
        .iter()
        .map(|o| TraceOptions {
            rays: o.rays.div_ceil(u64::from(layers)).max(1),
            ..o.clone()
        })
        .collect();
    let sets = per_layer.len() as u64;
    let mut runs: Vec<Vec<VolumeResult>> =
        vec![Vec::with_capacity(layers as usize); per_layer.len()];
    let mut stats = Vec::with_capacity(layers as usize);
    for k in 0..u64::from(layers) {
        let layer = Layer::generate_realisation(params, k)?;
        for (j, opts) in per_layer.iter().enumerate() {
            let tracer = Tracer::new(&layer, opts.clone())?.with_realisation(k);
            let step = k * sets + j as u64;
            let result = tracer.run_with_progress(theta_i, cones, &|done, total| {
                progress(step * total + done, u64::from(layers) * sets * total);
            })?;
            runs[j].push(result);
        }
        stats.push(*layer.stats());
    }
    let t975 = if layers > 1 {
        StudentsT::new(0.0, 1.0, f64::from(layers - 1))
            .map(|t| t.inverse_cdf(0.975))
            .unwrap_or(f64::NAN)
    } else {
        f64::NAN
    };
    Ok(runs
        .iter()
        .zip(options)
        .map(|(r, o)| combine_layers(r, &stats, theta_i.len(), t975, o.seed))
        .collect())
}

/// The layered result of one option set's `runs` (one per layer).
fn combine_layers(
    runs: &[VolumeResult],
    stats: &[LayerStats],
    incidences: usize,
    t975: f64,
    seed: u64,
) -> LayeredResult {
    let layers = runs.len() as u32;
    let first = &runs[0];
    let points = (0..first.points.len())
        .map(|j| {
            let p: Vec<&VolumePoint> = runs.iter().map(|r| &r.points[j]).collect();
            let part = |v: fn(&VolumePoint) -> f64, e: fn(&VolumePoint) -> f64| {
                let x: Vec<f64> = p.iter().map(|q| v(q)).collect();
                let r: Vec<f64> = p.iter().map(|q| e(q)).collect();
                combine(&x, &r, t975)
            };
            let (brdf, brdf_error) = part(|q| q.brdf, |q| q.brdf_std_err);
            let (single, single_e) = part(|q| q.single_brdf, |q| q.single_std_err);
            let (multiple, multiple_e) = part(|q| q.multiple_brdf, |q| q.multiple_std_err);
            let (reflectance, reflectance_e) = part(|q| q.reflectance, |q| q.reflectance_std_err);
            let spec: f64 = p.iter().map(|q| q.specular_reflectance).sum();
            let summed: f64 = p.iter().map(|q| q.reflectance).sum();
            LayeredPoint {
                mean: VolumePoint {
                    brdf,
                    brdf_std_err: brdf_error.total,
                    single_brdf: single,
                    single_std_err: single_e.total,
                    multiple_brdf: multiple,
                    multiple_std_err: multiple_e.total,
                    reflectance,
                    reflectance_std_err: reflectance_e.total,
                    relative: if spec > 0.0 { summed / spec } else { f64::NAN },
                    specular_reflectance: spec / f64::from(layers),
                    rays: p.iter().map(|q| q.rays).sum(),
                    ..*p[0]
                },
                brdf_error,
            }
        })
        .collect();
    let (energy, energy_std_err) = (0..incidences)
        .map(|i| combine_energy(runs, i, t975))
        .unzip();
    LayeredResult {
        points,
        energy,
        energy_std_err,
        layers: stats.to_vec(),
        rays_per_layer: first.rays_per_incidence,
        segments: runs.iter().map(|r| r.segments).sum(),
        seed,
        t975,
    }
}

#[cfg(test)]
mod tests {
    use super::combine;

    #[test]
    fn combine_follows_the_definitions() {
        // x = 1, 2, 3: mean 2, s² = 1, total = √(1/3); rays = √(3 · 0.01)/3.
        let (m, e) = combine(&[1.0, 2.0, 3.0], &[0.1, 0.1, 0.1], 4.302_652_729_749_464);
        assert_eq!(m, 2.0);
        assert!((e.total - (1.0f64 / 3.0).sqrt()).abs() < 1e-15);
        assert!((e.rays - 0.03f64.sqrt() / 3.0).abs() < 1e-15);
        let layers = e.layers.unwrap();
        assert!((layers - (1.0 / 3.0 - 0.03 / 9.0f64).sqrt()).abs() < 1e-15);
        assert!((e.ci95.unwrap() - 4.302_652_729_749_464 * e.total).abs() < 1e-15);
        // Layers closer together than their rays allow: the layer part is 0, not NaN.
        let (_, e) = combine(&[1.0, 1.0], &[0.5, 0.5], 12.7);
        assert_eq!(e.layers, Some(0.0));
        // One layer: the rays only.
        let (m, e) = combine(&[4.0], &[0.25], f64::NAN);
        assert_eq!(
            (m, e.total, e.rays, e.layers, e.ci95),
            (4.0, 0.25, 0.25, None, None)
        );
    }
}
