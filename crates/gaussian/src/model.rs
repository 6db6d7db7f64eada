//! The point BRDF of the distribution model (physics.md §4, paper eqs. 9–13 corrected).
//!
//! Conventions: angles in radians; `θi ∈ [0, π/2)` is the incidence angle in air; exit
//! directions `r` are unit vectors in air with `r.z > 0` (see `flakescatter_optics`).
//! The orientation distribution enters through its macro-area density
//! `D(m) = p2(θn)/⟨cos θn⟩` (flake area per unit coating area per steradian of
//! normals, for a fully covering layer). For an exit direction `r`:
//!
//! 1. `k2 = (r.x/n, r.y/n, sqrt(1 − (r.x² + r.y²)/n²))`, `k1` refracted from `θi`;
//! 2. `m = (k2 − k1)/|k2 − k1|`, `θn = acos m.z`; no light if `m.z ≤ 0`;
//! 3. `f(θi, r) = F · R(ι) · D(m) / (4 n² cos θt cos θ2)` (sr⁻¹),
//!
//! with `F·R` the Fresnel and flake factors along the ray, `cos ι = γ = −k1·m`,
//! `cos θ2 = k2.z`. For `exact-unpolarized`, `s` and `p` the factor is exact in every
//! direction: `m00`, `m00 + m01`, `m00 − m01` of the ray's Mueller matrix
//! ([`flakescatter_optics::jones`], physics.md §11; in the plane of incidence these are
//! the power products of [`Transmission::path_factor`]); `paper` is the product of
//! averages `T_av R_av T_av'`. The obliquity `γ` cancels against the reflection
//! Jacobian `dΩ(k2) = 4γ dΩ(m)`; the refraction Jacobian `n² cos θ2/cos θo` supplies the
//! rest. With [`Weighting::PaperPrinted`] `f` is multiplied by `cos θ2 / cos θo`, the
//! printed eq. 9/13 weight, which breaks energy conservation (physics.md §4). The full
//! Mueller matrix of the point BRDF is in [`crate::mueller`].
//!
//! With binder absorption ([`DistributionModel::with_absorption`], physics.md §8.1) every
//! ray's power, scalar or Mueller, is multiplied by the factor
//! [`PathAbsorption::factor`]`(cos θt, cos θ2)` of its path inside the film; without it
//! nothing is multiplied (the default path is unchanged to the bit).

use flakescatter_numerics::simd::Kernels;
use flakescatter_optics::absorption::PathAbsorption;
use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_optics::fresnel::{self, FresnelPower};
use flakescatter_optics::jones::{self, PathAmplitudes, RayPath, Transfer};
use flakescatter_optics::polarization::{Transmission, Weighting};
use flakescatter_optics::{UnitVec3, Vec3, detector, refraction};
use flakescatter_stats::Orientation;

use crate::ModelError;
use crate::base::{BaseLoop, BaseUnder, FacetWeights};

/// Options of the distribution model. The defaults are the physical model of
/// physics.md §4: exact unpolarised Fresnel factors, physical weighting, perfect-conductor
/// flakes, no clear-coat reflection.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelOptions {
    /// Fresnel bookkeeping (default `exact-unpolarized`).
    pub transmission: Transmission,
    /// Ray weighting (default `physical`).
    pub weighting: Weighting,
    /// Flake reflectance (default perfect conductor).
    pub flake: FlakeReflectance,
    /// Add the clear coat's own specular reflection (physics.md §6) to every detector
    /// whose cone contains the specular direction (default off).
    pub clearcoat: bool,
    /// Apply the exit Fresnel factor (default `true`). `false` gives the power that
    /// reaches the top surface from inside, before the exit loss: used by conservation
    /// checks.
    pub exit_fresnel: bool,
}

impl Default for ModelOptions {
    fn default() -> Self {
        Self {
            transmission: Transmission::ExactUnpolarized,
            weighting: Weighting::Physical,
            flake: FlakeReflectance::PerfectConductor,
            clearcoat: false,
            exit_fresnel: true,
        }
    }
}

/// The distribution model: a clear coat of index `n` over flakes whose normals follow
/// an [`Orientation`].
#[derive(Debug, Clone)]
pub struct DistributionModel {
    orientation: Orientation,
    n: f64,
    options: ModelOptions,
    inv_mean_cos: f64,
    absorption: Option<PathAbsorption>,
    /// A Lambertian base under transmitting flakes (physics.md §13), if any.
    base: Option<std::sync::Arc<BaseUnder>>,
    /// The kernels of [`DistributionModel::brdf_batch`].
    kernels: Kernels,
}

/// The point BRDF of one exit direction without its density
/// ([`DistributionModel::kernel`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayKernel {
    /// Polar angle of the flake normal that sends light to the direction, radians.
    pub theta_n: f64,
    /// `cos θ2`, the inside exit direction's cosine from the coating normal.
    pub cos_2: f64,
    /// `K` in `f = K · D(θn)`, sr⁻¹ per unit of macro-area density.
    pub factor: f64,
}

/// Everything about one incidence angle that does not depend on the exit direction.
#[derive(Debug, Clone, Copy)]
pub struct Incidence {
    /// Incidence angle in air, radians.
    pub theta_i: f64,
    /// Incident direction in air, `(sin θi, 0, −cos θi)`.
    pub k_in: Vec3,
    /// Refracted direction inside the coating (`k1.z < 0`).
    pub k1: Vec3,
    /// Cosine of the inside angle `θt`.
    pub cos_t: f64,
    /// Fresnel powers of the entry crossing.
    pub entry: FresnelPower,
    /// Fresnel amplitudes `[rs, rp, ts, tp]` of the entry crossing (physics.md §2).
    pub amplitudes: [f64; 4],
    /// Fraction of the beam that enters, `T_in`.
    pub t_in: f64,
    /// Fraction reflected specularly by the clear coat's top surface.
    pub clearcoat: f64,
    /// Specular direction `(sin θi, 0, cos θi)`.
    pub specular: UnitVec3,
}

impl DistributionModel {
    /// A model for coating index `n` (≥ 1) and flake orientations `orientation`.
    ///
    /// # Errors
    /// [`ModelError::Index`] when `n` is not a finite real ≥ 1;
    /// [`ModelError::FlakeIndex`] for an invalid complex flake index;
    /// [`ModelError::Delta`] for [`Orientation::flat`], which has no density;
    /// [`ModelError::SimdSwitch`] when the environment variable `FLAKESCATTER_SIMD` holds
    /// a value other than `auto` or `portable` ([`Kernels::from_env`]), which sets the
    /// kernels of [`DistributionModel::brdf_batch`].
    pub fn new(
        orientation: Orientation,
        n: f64,
        options: ModelOptions,
    ) -> Result<Self, ModelError> {
        flakescatter_optics::check_index(n).map_err(ModelError::Index)?;
        // A delta has no density: its reflectance is a delta at specular, which this
        // model cannot represent (it would return 0 everywhere, a silent wrong number).
        if orientation.is_delta() {
            return Err(ModelError::Delta);
        }
        if let FlakeReflectance::Complex { n: fn_, k } = options.flake {
            FlakeReflectance::complex(fn_, k).map_err(ModelError::FlakeIndex)?;
        }
        let inv_mean_cos = 1.0 / orientation.mean_cos();
        let kernels = Kernels::from_env().map_err(|e| ModelError::SimdSwitch(e.0))?;
        Ok(Self {
            orientation,
            n,
            options,
            inv_mean_cos,
            absorption: None,
            base: None,
            kernels,
        })
    }

    /// The same model running `kernels` in [`DistributionModel::brdf_batch`]:
    /// [`Kernels::Portable`] forces the portable code, whatever `FLAKESCATTER_SIMD` says
    /// (the results are the same bits either way; `crate::batch`, "Vector
    /// instructions").
    #[must_use]
    pub fn with_kernels(mut self, kernels: Kernels) -> Self {
        self.kernels = kernels;
        self
    }

    /// The kernels [`DistributionModel::brdf_batch`] runs.
    #[must_use]
    pub fn kernels(&self) -> Kernels {
        self.kernels
    }

    /// The same model with the binder absorbing along each ray's path inside the film
    /// (module docs; physics.md §8.1).
    #[must_use]
    pub fn with_absorption(mut self, absorption: PathAbsorption) -> Self {
        self.absorption = Some(absorption);
        self
    }

    /// The same model over a Lambertian base of albedo `albedo` under the flakes
    /// (physics.md §13; module [`crate::base`]): its term is added to what every detector
    /// collects ([`DistributionModel::collect`], [`crate::curve`]); the point BRDF
    /// [`DistributionModel::brdf`] stays the flakes' own, the base's is
    /// [`DistributionModel::base_brdf`]. `albedo = 0` adds exactly nothing and keeps no
    /// base.
    ///
    /// # Errors
    /// [`ModelError::BaseAlbedo`] unless `0 ≤ albedo ≤ 1`; [`ModelError::BaseFlake`]
    /// unless the flakes are a thin-film stack without a core; [`ModelError::BaseSetting`]
    /// with binder absorption, a polarised beam (`s`, `p`), the paper-printed weighting,
    /// or without the exit Fresnel factor.
    pub fn with_base(self, albedo: f64, repeat: BaseLoop) -> Result<Self, ModelError> {
        self.with_base_from(albedo, repeat, None)
    }

    /// [`DistributionModel::with_base`] with the facet weights of this model's
    /// orientation distribution already computed ([`FacetWeights::new`]; shared by the
    /// wavelengths of a spectrum). Weights of another distribution give another model.
    ///
    /// # Errors
    /// As [`DistributionModel::with_base`].
    pub fn with_base_weights(
        self,
        albedo: f64,
        repeat: BaseLoop,
        weights: &FacetWeights,
    ) -> Result<Self, ModelError> {
        self.with_base_from(albedo, repeat, Some(weights))
    }

    fn with_base_from(
        mut self,
        albedo: f64,
        repeat: BaseLoop,
        weights: Option<&FacetWeights>,
    ) -> Result<Self, ModelError> {
        if !(albedo.is_finite() && (0.0..=1.0).contains(&albedo)) {
            return Err(ModelError::BaseAlbedo(albedo));
        }
        if albedo == 0.0 {
            self.base = None;
            return Ok(self);
        }
        let o = &self.options;
        if self.absorption.is_some() {
            return Err(ModelError::BaseSetting("binder absorption"));
        }
        if matches!(o.transmission, Transmission::S | Transmission::P) {
            return Err(ModelError::BaseSetting(
                "a polarised beam (transmission s or p)",
            ));
        }
        if o.weighting != Weighting::Physical {
            return Err(ModelError::BaseSetting("the paper-printed weighting"));
        }
        if !o.exit_fresnel {
            return Err(ModelError::BaseSetting("the exit Fresnel factor off"));
        }
        let base = match weights {
            Some(w) => BaseUnder::with_weights(albedo, self.n, &o.flake, w, repeat)?,
            None => BaseUnder::new(albedo, self.n, &o.flake, &self.orientation, repeat)?,
        };
        self.base = Some(std::sync::Arc::new(base));
        Ok(self)
    }

    /// The base under the flakes, if any.
    #[must_use]
    pub fn base(&self) -> Option<&BaseUnder> {
        self.base.as_deref()
    }

    /// The base term's point BRDF `f_base(θi, r)` (sr⁻¹; physics.md §13); 0 without a
    /// base.
    #[must_use]
    pub fn base_brdf(&self, inc: &Incidence, r: &Vec3) -> f64 {
        self.base.as_ref().map_or(0.0, |b| {
            b.brdf(b.reaching(inc.cos_t, inc.entry.ts, inc.entry.tp), r)
        })
    }

    /// The binder absorption, if any.
    #[must_use]
    pub fn absorption(&self) -> Option<&PathAbsorption> {
        self.absorption.as_ref()
    }

    /// The absorption factor of a ray with inside cosines `cos_t`, `cos_2`; `None`
    /// without absorption (so that nothing is multiplied).
    #[inline]
    pub(crate) fn absorption_factor(&self, cos_t: f64, cos_2: f64) -> Option<f64> {
        self.absorption.as_ref().map(|a| a.factor(cos_t, cos_2))
    }

    /// The coating index.
    #[must_use]
    pub fn index(&self) -> f64 {
        self.n
    }

    /// The options.
    #[must_use]
    pub fn options(&self) -> &ModelOptions {
        &self.options
    }

    /// The orientation distribution.
    #[must_use]
    pub fn orientation(&self) -> &Orientation {
        &self.orientation
    }

    /// `1/⟨cos θn⟩`, the factor from `p2` to the macro-area density `D`.
    #[must_use]
    pub fn inv_mean_cos(&self) -> f64 {
        self.inv_mean_cos
    }

    /// Precompute what depends only on the incidence angle.
    ///
    /// # Errors
    /// [`ModelError::Incidence`] unless `θi ∈ [0, π/2)`.
    pub fn incidence(&self, theta_i: f64) -> Result<Incidence, ModelError> {
        if !(theta_i.is_finite() && (0.0..std::f64::consts::FRAC_PI_2).contains(&theta_i)) {
            return Err(ModelError::Incidence(theta_i));
        }
        let k_in = detector::incident_direction(theta_i);
        let k1 = refraction::into_coating(&k_in, self.n);
        let entry = fresnel::air_to_coating(theta_i, self.n);
        Ok(Incidence {
            theta_i,
            k_in: k_in.into_inner(),
            k1: k1.into_inner(),
            cos_t: -k1.z,
            entry,
            amplitudes: fresnel::amplitudes_air_to_coating(theta_i, self.n),
            t_in: self.options.transmission.entry_factor(&entry),
            clearcoat: self.options.transmission.clearcoat_reflectance(&entry),
            specular: detector::specular_direction(theta_i),
        })
    }

    /// Point BRDF `f(θi, r)` of the flakes, sr⁻¹ (the clear coat's specular delta is not
    /// included). Zero for `r.z ≤ 0` and where no flake normal can send light to `r`.
    #[must_use]
    #[inline]
    pub fn brdf(&self, inc: &Incidence, r: &Vec3) -> f64 {
        self.brdf_about(inc, r, &Vec3::zeros())
    }

    /// The point BRDF at the exit direction `base + offset` (a unit vector), sr⁻¹, with
    /// the offset's digits kept: the half vector's transverse part is formed as
    /// `(base/n − k1) + offset/n`. With `base` the specular direction, whose term is
    /// zero to rounding, directions a few 1e-12 rad from specular are resolved, which
    /// narrow distributions need (`brdf` itself loses the digits of `r − specular`
    /// below ~1e-16).
    #[must_use]
    #[inline]
    pub fn brdf_about(&self, inc: &Incidence, base: &Vec3, offset: &Vec3) -> f64 {
        let r = base + offset;
        if r.z <= 0.0 {
            return 0.0;
        }
        let n = self.n;
        let Some((h, c2)) = self.half_vector(inc, base, offset, r.z) else {
            return 0.0;
        };
        // θn from atan2 rather than acos(m.z): acos cannot resolve angles below ~1e-8 rad.
        let p2 = self
            .orientation
            .p2((h.x * h.x + h.y * h.y).sqrt().atan2(h.z));
        if p2 == 0.0 {
            return 0.0;
        }
        let k2 = Vec3::new(r.x / n, r.y / n, c2);
        let factor = self.path_factor(inc, &h, self.obliquity(inc, &h), &k2, &r);
        let mut f = factor * p2 * self.inv_mean_cos / (4.0 * n * n * inc.cos_t * c2);
        if self.options.weighting == Weighting::PaperPrinted {
            f *= c2 / r.z;
        }
        if let Some(a) = self.absorption_factor(inc.cos_t, c2) {
            f *= a;
        }
        f
    }

    /// The point BRDF without its density: for the exit direction `r`, the polar angle
    /// `θn` of the flake normal that sends light there and the factor `K` with
    /// `f(θi, r) = K · D(θn)`, `D = p2/⟨cos θn⟩` (so `K = F·R / (4 n² cos θt cos θ2)`,
    /// times the printed weighting and the absorption when they are on). `K` does not
    /// depend on the orientation distribution: a fit that changes only the distribution
    /// can keep it. `None` where [`DistributionModel::brdf`] is zero for every
    /// distribution (`r.z ≤ 0`, no normal reaches `r`). Equal to `brdf / D` to rounding
    /// (the product is formed in another order).
    #[must_use]
    pub fn kernel(&self, inc: &Incidence, r: &Vec3) -> Option<RayKernel> {
        if r.z <= 0.0 {
            return None;
        }
        let n = self.n;
        let (h, c2) = self.half_vector(inc, r, &Vec3::zeros(), r.z)?;
        let theta_n = (h.x * h.x + h.y * h.y).sqrt().atan2(h.z);
        let k2 = Vec3::new(r.x / n, r.y / n, c2);
        let factor = self.path_factor(inc, &h, self.obliquity(inc, &h), &k2, r);
        let mut k = factor / (4.0 * n * n * inc.cos_t * c2);
        if self.options.weighting == Weighting::PaperPrinted {
            k *= c2 / r.z;
        }
        if let Some(a) = self.absorption_factor(inc.cos_t, c2) {
            k *= a;
        }
        Some(RayKernel {
            theta_n,
            cos_2: c2,
            factor: k,
        })
    }

    /// Unnormalised internal half vector `k2 − k1` and `cos θ2 = k2.z` for the exit
    /// direction `base + offset` with air cosine `rz > 0`; `None` when the half vector's
    /// `z` is not positive (no flake normal sends light there).
    #[inline]
    pub(crate) fn half_vector(
        &self,
        inc: &Incidence,
        base: &Vec3,
        offset: &Vec3,
        rz: f64,
    ) -> Option<(Vec3, f64)> {
        let n = self.n;
        // cos θ2 = sqrt(1 − (r.x² + r.y²)/n²) written as sqrt(n² − 1 + r.z²)/n (|r| = 1):
        // no cancellation near the horizon, so f·cos θr stays finite as r.z → 0.
        let c2 = (n * n - 1.0 + rz * rz).max(0.0).sqrt() / n;
        let h = Vec3::new(
            (base.x / n - inc.k1.x) + offset.x / n,
            (base.y / n - inc.k1.y) + offset.y / n,
            c2 - inc.k1.z,
        );
        (h.z > 0.0).then_some((h, c2))
    }

    /// Polar angle `θn` (radians) of the flake normal that sends light to the exit
    /// direction `base + offset` (the internal half vector of §2, digits of the offset
    /// kept as in [`DistributionModel::brdf_about`]), or `None` when no normal does.
    #[must_use]
    pub fn normal_polar_angle(&self, inc: &Incidence, base: &Vec3, offset: &Vec3) -> Option<f64> {
        let rz = base.z + offset.z;
        if rz <= 0.0 {
            return None;
        }
        let (h, _) = self.half_vector(inc, base, offset, rz)?;
        Some((h.x * h.x + h.y * h.y).sqrt().atan2(h.z))
    }

    /// The obliquity `γ = −k1·m/|m|` of the flake normal `m` (any positive multiple of
    /// the unit normal) where the flake reflectance depends on it; 1 for the perfect
    /// conductor, which does not use it.
    #[inline]
    pub(crate) fn obliquity(&self, inc: &Incidence, m: &Vec3) -> f64 {
        if self.options.flake.is_perfect() {
            1.0
        } else {
            -inc.k1.dot(m) / m.norm()
        }
    }

    /// `F · R` for the ray reflected by the flake of normal `m` (any positive multiple
    /// of the unit normal; obliquity `gamma`) into the inside direction `k2`, leaving
    /// along `k_out`: from the ray's Jones matrix for `exact-unpolarized`, `s`, `p`
    /// (module docs), the product of averages for `paper`.
    #[inline]
    pub(crate) fn path_factor(
        &self,
        inc: &Incidence,
        m: &Vec3,
        gamma: f64,
        k2: &Vec3,
        k_out: &Vec3,
    ) -> f64 {
        let t = self.options.transmission;
        if t != Transmission::Paper {
            let amps = self.amplitudes(inc, gamma, k2, k_out);
            let row = ray_path(inc, m, k2, k_out).first_row(&amps);
            return t.from_first_row(row).unwrap_or(row.0);
        }
        let flake = self.options.flake.power(gamma, self.n);
        if self.options.exit_fresnel {
            let exit = fresnel::power_from_cosines(k_out.z, k2.z, self.n);
            t.path_factor(&inc.entry, flake, &exit)
        } else {
            let unit = FresnelPower {
                rs: 0.0,
                rp: 0.0,
                ts: 1.0,
                tp: 1.0,
            };
            t.path_factor(&inc.entry, flake, &unit)
        }
    }

    /// The Jones matrix and power factor of the ray through the flake of normal `m`
    /// (any positive multiple of the unit normal; obliquity `gamma`) into `k2`, leaving
    /// along `k_out` ([`flakescatter_optics::jones`]).
    #[inline]
    pub(crate) fn transfer(
        &self,
        inc: &Incidence,
        m: &Vec3,
        k2: &Vec3,
        k_out: &Vec3,
        gamma: f64,
    ) -> Transfer {
        ray_path(inc, m, k2, k_out).transfer(&self.amplitudes(inc, gamma, k2, k_out))
    }

    /// The amplitudes met by the ray with obliquity `gamma` into `k2`, leaving along
    /// `k_out`. Without the exit Fresnel factor (`exit_fresnel == false`) the exit
    /// crossing transmits all the power in both polarisations
    /// ([`jones::lossless_exit_amplitude`]).
    #[inline]
    fn amplitudes(&self, inc: &Incidence, gamma: f64, k2: &Vec3, k_out: &Vec3) -> PathAmplitudes {
        let n = self.n;
        let exit = if self.options.exit_fresnel {
            jones::exit_amplitudes(k_out.z, k2.z, n)
        } else {
            let t = jones::lossless_exit_amplitude(k_out.z, k2.z, n);
            (t, t)
        };
        PathAmplitudes {
            entry: (inc.amplitudes[2], inc.amplitudes[3]),
            flake: self.options.flake.amplitudes(gamma, n),
            exit,
        }
    }

    /// What the ray reflected by a flake of normal `m` carries out of the coating,
    /// per unit of flake area density: `F · R · γ / cos θt` (times `cos θ2/cos θo` for
    /// the paper-printed weighting), with its exit direction; `None` when the ray is lost
    /// (`γ ≤ 0`, `k2.z ≤ 0`, total internal reflection).
    #[must_use]
    pub fn ray_weight(&self, inc: &Incidence, m: &UnitVec3) -> Option<(f64, UnitVec3)> {
        let k1 = UnitVec3::new_unchecked(inc.k1);
        let gamma = -k1.dot(m);
        if gamma <= 0.0 {
            return None;
        }
        let k2 = flakescatter_optics::reflection::reflect(&k1, m);
        if k2.z <= 0.0 {
            return None;
        }
        let out = refraction::out_of_coating(&k2, self.n)?;
        let mut w = self.path_factor(inc, m, gamma, &k2, &out) * gamma / inc.cos_t;
        if self.options.weighting == Weighting::PaperPrinted {
            w *= k2.z / out.z;
        }
        if let Some(a) = self.absorption_factor(inc.cos_t, k2.z) {
            w *= a;
        }
        Some((w, out))
    }

    /// The normal-space integrand `F · R · D(m) · γ / cos θt` (fraction of the incident
    /// power per steradian of normals) with the exit direction, or `None` when the ray is
    /// lost. Integrated over all normals it gives the hemispherical total.
    #[must_use]
    pub fn normal_space_weight(&self, inc: &Incidence, m: &UnitVec3) -> Option<(f64, UnitVec3)> {
        let (w, out) = self.ray_weight(inc, m)?;
        let theta_n = (m.x * m.x + m.y * m.y).sqrt().atan2(m.z);
        Some((w * self.orientation.p2(theta_n) * self.inv_mean_cos, out))
    }
}

/// The ray path of the incidence `inc` through the flake of normal `m` into `k2`,
/// leaving along `k_out`.
#[inline]
fn ray_path(inc: &Incidence, m: &Vec3, k2: &Vec3, k_out: &Vec3) -> RayPath {
    RayPath {
        k_in: inc.k_in,
        k1: inc.k1,
        m: *m,
        k2: *k2,
        k_out: *k_out,
    }
}
