//! Library side of `flakescatter reproduce`: a synthetic "measured" goniometric curve.
//!
//! We have no NIST measurements, so the paper's measured curves (Figs. 9, 10) are stood
//! in for by the topographic model averaged over the sample's rotation (physics.md §5.1:
//! what a goniometer sees of an isotropic sample) on the exact surfaces of *rough*
//! synthetic flake layers ([`flakescatter_synth`]), plus multiplicative Gaussian noise of
//! the paper's size (0.7 % relative). The same [`SyntheticSample`] type describes the
//! map sets of the Fig. 10 samples ([`SyntheticSample::masked_maps`]). Everything is
//! seeded: the same sample and noise seed give bit-identical curves.
//!
//! Conventions: radians and micrometres in every API; the curve's values are BRDFs
//! (sr⁻¹, cone-averaged over the instrument's aperture, physics.md §4), in-plane
//! detector angles signed with `θs = −θi` the specular direction.

use flakescatter_io::measured::{MeasuredCurve, MeasuredPoint};
use flakescatter_stats::heightmap::{HeightMap, HeightMapError};
use flakescatter_stats::{GaussianWidth, Orientation};
use flakescatter_synth::{LayerParams, LayerSpec, SynthError, generate};
use flakescatter_topo::IsotropicResult;

use crate::PipelineError;
use crate::instrument::Instrument;
use crate::pipeline::{Coating, Curves, Settings, TopoSettings, isotropic_curves};

/// Errors of [`synthetic_measurement`].
#[derive(Debug, thiserror::Error)]
pub enum ReproduceError {
    /// The synthetic sample's parameters are not valid.
    #[error("synthetic sample: {0}")]
    Sample(String),
    /// A layer could not be generated.
    #[error("synthetic layer {layer}: {source}")]
    Synth {
        /// Index of the layer (0-based).
        layer: usize,
        /// What went wrong.
        source: SynthError,
    },
    /// A layer's intensity mask left nothing usable.
    #[error("synthetic layer {layer}: intensity mask: {source}")]
    Mask {
        /// Index of the layer (0-based).
        layer: usize,
        /// What went wrong.
        source: HeightMapError,
    },
    /// The topographic model failed.
    #[error(transparent)]
    Pipeline(#[from] PipelineError),
}

/// A synthetic sample: `maps` layers of `size × size` pixels, seeds `seed, seed + 1,
/// ...` (the "measured" coating of [`synthetic_measurement`], or a set of confocal maps).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SyntheticSample {
    /// Gaussian orientation width of the flakes, hwhm of `p̃`, radians.
    pub hwhm: f64,
    /// Number of layers (maps), ≥ 1.
    pub maps: usize,
    /// Side of each map, pixels.
    pub size: usize,
    /// Pixel pitch, µm.
    pub pitch_um: f64,
    /// Flake surface roughness rms, µm.
    pub roughness_rms_um: f64,
    /// Roughness correlation length, µm.
    pub roughness_correlation_um: f64,
    /// Confocal z quantisation step, µm (0 = off).
    pub z_step_um: f64,
    /// Confocal height noise sd, µm.
    pub height_noise_um: f64,
    /// Seed of the first layer.
    pub seed: u64,
}

impl SyntheticSample {
    /// The "measured" sample of `flakescatter reproduce`: flakes with a Gaussian hwhm of
    /// 3° (the width of the paper's Fig. 7 histograms) whose surfaces are rough (rms
    /// 0.12 µm, correlation length 2 µm), 6 maps of 2048² pixels at the paper's 0.18 µm
    /// (6 × 0.136 mm², about 7 × 10³ visible flakes), exact heights (no z quantisation,
    /// no height noise: the surface itself, not a microscope's view of it), seeds
    /// 9000–9005.
    #[must_use]
    pub fn reproduce_default() -> Self {
        Self {
            hwhm: 3f64.to_radians(),
            maps: 6,
            size: 2048,
            pitch_um: 0.18,
            roughness_rms_um: 0.12,
            roughness_correlation_um: 2.0,
            z_step_um: 0.0,
            height_noise_um: 0.0,
            seed: 9000,
        }
    }

    /// The same sample with 1 map of 2048² pixels (for quick checks and tests: noisier).
    #[must_use]
    pub fn quick() -> Self {
        Self {
            maps: 1,
            ..Self::reproduce_default()
        }
    }

    /// Generator parameters of layer `k` (library defaults otherwise: 38 µm film,
    /// log-normal diameters mean 16 µm, relative sd 0.25, 1 µm thick, coverage 1.5).
    ///
    /// # Errors
    /// [`ReproduceError::Sample`] or [`ReproduceError::Synth`] for invalid parameters.
    pub fn layer_params(&self, k: usize) -> Result<LayerParams, ReproduceError> {
        let o = Orientation::gaussian(GaussianWidth::Hwhm(self.hwhm))
            .map_err(|e| ReproduceError::Sample(format!("hwhm {} rad: {e}", self.hwhm)))?;
        let mut spec = LayerSpec::new(self.size, self.size, o, self.seed.wrapping_add(k as u64));
        spec.dx_um = self.pitch_um;
        spec.dy_um = self.pitch_um;
        spec.roughness.rms_um = self.roughness_rms_um;
        spec.roughness.correlation_um = self.roughness_correlation_um;
        spec.confocal.z_step_um = self.z_step_um;
        spec.confocal.noise_sd_um = self.height_noise_um;
        LayerParams::new(spec).map_err(|source| ReproduceError::Synth { layer: k, source })
    }

    /// Generates the sample's layers and masks each height map with its intensity map at
    /// the levels' midpoint (as a confocal user would): the maps and the number of
    /// visible flakes over all layers. `progress(stage)` is told what is being done.
    ///
    /// # Errors
    /// [`ReproduceError`] for invalid parameters.
    pub fn masked_maps(
        &self,
        progress: &dyn Fn(&str),
    ) -> Result<(Vec<HeightMap>, usize), ReproduceError> {
        if self.maps == 0 {
            return Err(ReproduceError::Sample("at least one map is needed".into()));
        }
        let mut maps: Vec<HeightMap> = Vec::with_capacity(self.maps);
        let mut visible_flakes = 0;
        for k in 0..self.maps {
            progress(&format!(
                "generating synthetic layer {}/{} ({}² pixels at {} µm)",
                k + 1,
                self.maps,
                self.size,
                self.pitch_um
            ));
            let params = self.layer_params(k)?;
            let layer =
                generate(&params).map_err(|source| ReproduceError::Synth { layer: k, source })?;
            visible_flakes += layer.visible_flakes().count();
            let mut height = layer.height;
            height
                .apply_intensity_cutoff(&layer.intensity, params.spec().intensity.midpoint())
                .map_err(|source| ReproduceError::Mask { layer: k, source })?;
            maps.push(height);
        }
        Ok((maps, visible_flakes))
    }
}

/// A synthetic measured curve and what it rests on.
#[derive(Debug, Clone)]
pub struct SyntheticMeasurement {
    /// The noisy curve: values are BRDFs (sr⁻¹), uncertainties one standard uncertainty
    /// (the noise and the clean curve's own sampling error, in quadrature); `file` names
    /// it as synthetic.
    pub curve: MeasuredCurve,
    /// The noise-free (isotropic topographic) curves it was drawn from.
    pub clean: Curves,
    /// Totals of the topographic run (pixels, rings, interpolation errors).
    pub topo: IsotropicResult,
    /// Visible flakes over all layers (from the generator's truth).
    pub visible_flakes: usize,
    /// Detectors left out of `curve` because no ray reached them (a zero is below any
    /// real instrument's noise floor and cannot be compared on a log scale).
    pub dropped_points: usize,
}

/// Generates the layers of `sample` ([`SyntheticSample::masked_maps`]), runs the
/// topographic model averaged over the sample's rotation ([`isotropic_curves`]) for
/// `instrument` (in-plane detectors), and multiplies every BRDF by
/// `1 + rel_sd · N(0, 1)` with the noise drawn by [`gaussian_noise`] from `noise_seed`.
/// Each point's uncertainty is `sqrt((rel_sd · BRDF)² + se²)`, `se` the clean value's
/// standard error from the map tiles (the sample is finite; `se` is left out where it
/// cannot be estimated). Detectors that no ray reached are left out of the curve (counted
/// in `dropped_points`). `progress(stage)` is told what is being done.
///
/// # Errors
/// [`ReproduceError`] for invalid parameters or a failing model.
pub fn synthetic_measurement(
    sample: &SyntheticSample,
    coating: &Coating,
    settings: &Settings,
    instrument: &Instrument,
    rel_sd: f64,
    noise_seed: u64,
    progress: &dyn Fn(&str),
) -> Result<SyntheticMeasurement, ReproduceError> {
    // Checked before the expensive layers are generated and traced.
    let crate::instrument::DetectorSet::InPlane(theta_s) = instrument.detectors() else {
        return Err(ReproduceError::Sample(
            "a synthetic measured curve needs in-plane detectors".into(),
        ));
    };
    if sample.maps == 0 {
        return Err(ReproduceError::Sample("at least one map is needed".into()));
    }
    if !(rel_sd.is_finite() && rel_sd >= 0.0) {
        return Err(ReproduceError::Sample(format!(
            "relative noise {rel_sd} must be finite and ≥ 0"
        )));
    }
    let (maps, visible_flakes) = sample.masked_maps(progress)?;
    progress(
        "tracing the rings of every pixel over the synthetic layers (isotropic topographic model)",
    );
    let refs: Vec<&HeightMap> = maps.iter().collect();
    let (clean, topo) = isotropic_curves(
        coating,
        instrument,
        settings,
        &TopoSettings::default(),
        None,
        &refs,
        &|_, _| {},
    )?;
    let noise = gaussian_noise(clean.rows.len(), noise_seed);
    let points = clean
        .rows
        .iter()
        .zip(&noise)
        .enumerate()
        .map(|(k, (r, z))| MeasuredPoint {
            theta_i: r.theta_i,
            theta_s: theta_s[r.detector],
            value: r.brdf * (1.0 + rel_sd * z),
            uncertainty: Some((r.brdf * rel_sd).hypot(r.std_err.unwrap_or(0.0))),
            line: k as u64 + 2,
        })
        .filter(|p| p.value > 0.0)
        .collect::<Vec<_>>();
    let dropped_points = clean.rows.len() - points.len();
    Ok(SyntheticMeasurement {
        curve: MeasuredCurve {
            file: "synthetic measured curve (topographic model on rough synthetic layers)".into(),
            points,
        },
        clean,
        topo,
        visible_flakes,
        dropped_points,
    })
}

/// `n` standard normal deviates from `seed`, deterministic on every platform:
/// SplitMix64 uniforms (53-bit) through the Box–Muller transform.
#[must_use]
pub fn gaussian_noise(n: usize, seed: u64) -> Vec<f64> {
    let mut state = seed;
    let mut next = move || {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        // In (0, 1]: never 0, so the logarithm is finite.
        ((z >> 11) as f64 + 1.0) / (1u64 << 53) as f64
    };
    let mut out = Vec::with_capacity(n + 1);
    while out.len() < n {
        let (u1, u2) = (next(), next());
        let r = (-2.0 * u1.ln()).sqrt();
        let a = 2.0 * std::f64::consts::PI * u2;
        out.push(r * a.cos());
        out.push(r * a.sin());
    }
    out.truncate(n);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::instrument::DetectorSet;

    #[test]
    fn noise_has_unit_variance_and_is_deterministic() {
        let n = 200_000;
        let z = gaussian_noise(n, 7);
        assert_eq!(z, gaussian_noise(n, 7));
        assert_ne!(z[..10], gaussian_noise(10, 8)[..]);
        let mean = z.iter().sum::<f64>() / n as f64;
        let var = z.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1) as f64;
        // Standard errors for N(0,1): mean 1/sqrt(n) = 0.0022, variance sqrt(2/n) = 0.0032.
        assert!(mean.abs() < 5.0 * 0.0023, "mean {mean}");
        assert!((var - 1.0).abs() < 5.0 * 0.0032, "variance {var}");
        // Fraction beyond 2 sd: 2·(1 − Φ(2)) = 0.04550, binomial sd sqrt(p(1−p)/n) = 0.00047.
        let tail = z.iter().filter(|x| x.abs() > 2.0).count() as f64 / n as f64;
        assert!((tail - 0.0455).abs() < 5.0 * 0.00047, "tail {tail}");
    }

    #[test]
    fn measured_curve_holds_the_clearcoat_peak_and_the_noise() {
        let sample = SyntheticSample {
            maps: 1,
            size: 256,
            ..SyntheticSample::quick()
        };
        let ts: Vec<f64> = (-40..=40).map(|d| f64::from(d).to_radians()).collect();
        let aperture = 1.5f64.to_radians();
        let instrument = Instrument::new(
            vec![30f64.to_radians()],
            DetectorSet::InPlane(ts.clone()),
            aperture,
        )
        .unwrap();
        let settings = Settings {
            clearcoat: true,
            ..Settings::default()
        };
        let m = synthetic_measurement(
            &sample,
            &Coating::default(),
            &settings,
            &instrument,
            0.007,
            1,
            &|_| {},
        )
        .unwrap();
        assert_eq!(m.curve.points.len() + m.dropped_points, ts.len());
        assert!(m.visible_flakes > 0);
        // The specular detector (θs = −30°) collects the clear coat's own reflection,
        // R_av(30°) for n = 1.5: Rs = 0.057796, Rp = 0.025249 (Fresnel), mean 0.041523. As
        // a cone-averaged BRDF that is at least R_av / ∫cone cos θ dΩ, and for a cone of
        // half-angle α about an axis at 30° from the normal ∫cone cos θ dΩ =
        // cos 30° · π sin² α = 1.8643e-3 sr (exact while the cone stays above the horizon).
        let spec = m
            .curve
            .points
            .iter()
            .find(|p| (p.theta_s + 30f64.to_radians()).abs() < 1e-9)
            .unwrap();
        let floor =
            0.041523 / (30f64.to_radians().cos() * std::f64::consts::PI * aperture.sin().powi(2));
        assert!(spec.value > 0.97 * floor, "{} vs {floor}", spec.value);
        // Noisy / clean ratios: mean 1 and sd 0.007 over the points with light.
        let ratios: Vec<f64> = m
            .curve
            .points
            .iter()
            .map(|p| p.value / m.clean.rows[p.line as usize - 2].brdf)
            .collect();
        let n = ratios.len() as f64;
        let mean = ratios.iter().sum::<f64>() / n;
        let sd = (ratios.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        assert!((mean - 1.0).abs() < 5.0 * 0.007 / n.sqrt(), "mean {mean}");
        // sd of a sample sd ≈ σ/sqrt(2(n−1)) ≈ 0.0006 for n = 81.
        assert!((sd - 0.007).abs() < 0.0025, "sd {sd}");
        // Uncertainties: the 0.7 % noise and the clean value's tile standard error in
        // quadrature, so never below either.
        for p in &m.curve.points {
            let r = &m.clean.rows[p.line as usize - 2];
            let u = p.uncertainty.unwrap();
            assert!(u >= 0.007 * r.brdf * (1.0 - 1e-12), "{u}");
            assert!(u >= r.std_err.unwrap_or(0.0) * (1.0 - 1e-12), "{u}");
        }
    }

    #[test]
    fn bad_samples_are_typed_errors() {
        let instrument = Instrument::new(
            vec![0.5],
            DetectorSet::InPlane(vec![-0.5]),
            1.5f64.to_radians(),
        )
        .unwrap();
        let zero = SyntheticSample {
            maps: 0,
            ..SyntheticSample::quick()
        };
        let run = |s: &SyntheticSample, sd: f64| {
            synthetic_measurement(
                s,
                &Coating::default(),
                &Settings::default(),
                &instrument,
                sd,
                1,
                &|_| {},
            )
        };
        assert!(matches!(run(&zero, 0.01), Err(ReproduceError::Sample(_))));
        assert!(matches!(
            run(&SyntheticSample::quick(), f64::NAN),
            Err(ReproduceError::Sample(_))
        ));
        let bad = SyntheticSample {
            pitch_um: -1.0,
            ..SyntheticSample::quick()
        };
        assert!(matches!(run(&bad, 0.01), Err(ReproduceError::Synth { .. })));
    }
}
