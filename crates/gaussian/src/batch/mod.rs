//! The point BRDF for a batch of exit directions at one incidence (issue 22).
//!
//! [`DistributionModel::brdf_batch`] gives, for every exit direction of a slice, the
//! value [`DistributionModel::brdf`] gives (sr⁻¹, same conventions: zero for `r.z ≤ 0`
//! and where no flake normal sends light to `r`), to within 1e-12 relative. It exists
//! for speed: what depends only on the incidence and the options (refraction in, the
//! entry Fresnel amplitudes, the `s`/`p` basis of the incident beam, the transmission
//! mode, the perfect conductor's `rs = −1`, `rp = +1`) is computed once per batch, and
//! the per-direction work is written as branch-free arithmetic on blocks of
//! [`LANES`] directions that the compiler turns into vector instructions.
//!
//! # What differs from the scalar path, and why it stays within 1e-12
//! The arithmetic is that of [`DistributionModel::brdf`] except:
//!
//! * `θn = atan2(ρ, h_z)` (`ρ = |h_xy|`, the internal half vector `h` of
//!   [`crate::model`]) is a branch-free arctangent: the ratio of the smaller to the larger
//!   of `ρ, h_z` in `[0, 1]`, reduced by `atan t = π/4 + atan((t − 1)/(t + 1))` above
//!   `t = 0.66`, and the Cephes rational approximation of degree 4/5 (its published
//!   coefficients; relative error about 2e-16 on the reduced range); `π/2 − θ` when
//!   `ρ > h_z`. A relative error `ε` in `θn` changes the Gaussian `exp(−θ²/(2s²))` by
//!   `2 |θ²/(2s²)| ε`.
//! * `exp` of the Gaussian exponent `x = −θ²/(2s²) ∈ [`MIN_VECTOR_EXPONENT`, 0]` is
//!   `2^k · e^r` with `k = round(x / ln 2)`, `r = x − k ln 2` in two parts (`|r| ≤ ln 2/2`)
//!   and `e^r` by a polynomial of degree 11 fitted to it, evaluated by Estrin's scheme
//!   (relative error 1.7e-17 with its coefficients rounded to `f64`; they and that error
//!   come from `crates/gaussian/tools/exp_fit.py`).
//!   Lanes whose exponent is below [`MIN_VECTOR_EXPONENT`] (`p2` below `e^−400` of its
//!   peak) are given to the scalar path, so the worst amplification of the arctangent's
//!   error is `2 · 400 · 4e-16 = 3.2e-13`, and every value the scalar path rounds to zero
//!   or to a subnormal is the scalar path's own.
//! * The products and quotients after the half vector are regrouped so that one
//!   division serves them all: the exit amplitudes enter only squared, and the
//!   `(2n cos θ2)²` of their numerators cancels the `cos θ2` of the power factor and of
//!   the refraction Jacobian. The `s` and `p` factors are formed as `2(…)` directly
//!   rather than as `m00 ± m01`; `a b` and `g d` of the frame rotations, both
//!   `rc1 rc2 rd1 rd2`, are one product; the factors that do not depend on the
//!   direction (the Gaussian's normalisation, the power factor's constants, the column
//!   weights times the entry amplitudes) are multiplied together once per batch. This
//!   changes the rounding by a few ulp (the sums involved have no cancellation: every
//!   term is a non-negative power). For the perfect conductor (`|rs|² = |rp|² = 1`,
//!   `2 Re(rs rp*) = ∓2`, so `x2 = ∓2`) the two entries of the coherency product are
//!   squares, `aa + bb − x2 ab = (a ± b)²` and `gg + dd + x2 gd = (g ∓ d)²` with
//!   `ab = gd`: six operations instead of fourteen, and no cancellation where the
//!   expanded form had one (the sum of the two entries is `(rc1² + rd1²)(rc2² + rd2²)`
//!   either way, so the change is a few ulp of the BRDF).
//! * `cos θ2` is `sqrt(n² − 1 + r_z²) · (1/n)` (one ulp from the scalar quotient; it
//!   enters `h_z = cos θ2 + cos θt`, a sum of positive numbers). The transverse half
//!   vector `r_xy/n − k1_xy` is computed exactly as in the scalar path: near specular it
//!   cancels, and narrow distributions would amplify any change there.
//!
//! Lanes with a non-finite component, or whose normal lies within 1e-8 rad of the
//! horizon (`θn = π/2` is outside the Gaussian's support and the rounding of `θn` there
//! decides between zero and not), are computed by [`DistributionModel::brdf`] itself.
//! A tabulated distribution takes `θn` from the scalar `atan2` and its bin from
//! [`Orientation::p2`](flakescatter_stats::Orientation::p2) (a bin edge must fall where
//! the scalar path puts it); a complex flake index takes `γ` and `(rs, rp)` per lane
//! from the scalar functions, the `paper` bookkeeping its product of averages per lane,
//! binder absorption its factor per lane: each of these is a scalar call inside the
//! block, the rest stays vectorised.
//!
//! # Vector instructions
//! The block kernel runs under the instruction set [`Isa::of`] chooses at run time
//! (the one switch of `flakescatter_numerics::simd`): AVX-512 (x86-64-v4, eight `f64`
//! per vector) or else AVX2 + FMA (x86-64-v3, four), and otherwise the same generic
//! code with one lane per vector ([`pulp::Scalar`], the baseline build), which is also
//! what `FLAKESCATTER_SIMD=portable` ([`DistributionModel::with_kernels`]) forces. Rust never
//! contracts `a * b + c`; the fused multiply-adds are explicit (pulp's `mul_add_f64s`,
//! correctly rounded in every build: an instruction with FMA, software without) and
//! only where no cancellation can occur: the arctangent's and the exponential's
//! polynomials (every partial sum of one sign), and the sums of non-negative powers of
//! pass 4 (the coherency entries, the rows, the exit denominators). The half vector,
//! the cross product and the frame rotations keep the scalar path's own expressions.
//! Addition, multiplication, division, square root and fused multiply-add are
//! correctly rounded in every instruction set, so all builds give the same bits. Plain
//! loops over fixed-size arrays were not vectorised by the compiler (checked in the
//! assembly: scalar `vmulsd`/`vdivsd` loops), hence the
//! explicit vectors of [`pulp::Simd`]. In the x86-64-v4 build of the bench binary
//! (`objdump` of `pulp::x86::v4::V4::vectorize::imp_fastcall`, the function the kernel
//! is inlined into) the vector kernel, both flake branches of pass 4 included, is
//! 89 `vmulpd`, 31 `vaddpd`, 13 `vsubpd`, 26 `vfmadd`/`vfnmadd`, 5 `vdivpd` and 2
//! `vsqrtpd` on `zmm` registers; the calls to `atan2` and `exp` in that function
//! belong to the per-lane scalar paths above. The five divisions are `r_x/n`, `r_y/n` (computed once and kept
//! for the frame rotations), the arctangent's ratio and rational function, and the final
//! quotient; `perf` puts about a fifth of the kernel's time in pass 1 (two divisions
//! and two square roots per vector), a third in the arctangent and exponential, and
//! the rest mostly in pass 4. On a 2-core Xeon the AVX-512 build took 0.71–0.72× the CPU
//! time of the AVX2 build on the bench's 1000 directions (user time of 10⁵ batches,
//! measured side by side), with the same output bits.
//!
//! # Where things are
//! This file holds the entry point and the per-thread block arrays; `lanes` the
//! vector type and the branch-free arctangent and exponential, `setup` the per-batch
//! constants, `block` the four passes of a block.

mod block;
mod lanes;
mod setup;

use flakescatter_numerics::simd::{Isa, dispatch_on};
use flakescatter_optics::Vec3;

use crate::model::{DistributionModel, Incidence};
use setup::Setup;

/// Directions per block of the kernel (sixteen AVX2 vectors of four `f64`, eight
/// AVX-512 vectors of eight).
pub const LANES: usize = 64;

/// Gaussian exponents `−θ²/(2s²)` below this are handed to the scalar path (module
/// docs).
pub const MIN_VECTOR_EXPONENT: f64 = -400.0;

/// Lanes with `h_z < NEAR_HORIZON · ρ` (normal within about 1e-8 rad of the horizon)
/// are handed to the scalar path (module docs).
const NEAR_HORIZON: f64 = 1e-8;

/// One call of the kernel, handed to [`dispatch_on`]: its `with_simd` is
/// inlined into the instruction-set build that was chosen, and so is everything
/// below it (a closure would not be: the compiler keeps it out of line, without the
/// target features).
struct Batch<'a> {
    model: &'a DistributionModel,
    inc: &'a Incidence,
    setup: &'a Setup,
    dirs: &'a [Vec3],
    out: &'a mut Vec<f64>,
    buf: &'a mut Buffers,
}

impl pulp::WithSimd for Batch<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, simd: S) {
        self.model
            .batch_blocks(simd, self.inc, self.setup, self.dirs, self.out, self.buf);
    }
}

impl DistributionModel {
    /// Point BRDF `f(θi, r)` (sr⁻¹) at every exit direction of `dirs` (unit vectors in
    /// air, frame of `flakescatter_optics`), written to `out`, which is cleared and
    /// filled with `dirs.len()` values in the same order: what
    /// [`DistributionModel::brdf`] gives for each, to within 1e-12 relative (the module
    /// docs say what differs and why; exact zeros and non-finite values are the scalar
    /// path's own). The clear coat's specular delta is not included; zero for
    /// `r.z ≤ 0` and where no flake normal can send light to `r`. The result does not
    /// depend on how `dirs` is split into calls, nor on the instruction set the
    /// processor offers.
    pub fn brdf_batch(&self, inc: &Incidence, dirs: &[Vec3], out: &mut Vec<f64>) {
        self.brdf_batch_on(Isa::of(self.kernels()), inc, dirs, out);
    }

    /// [`DistributionModel::brdf_batch`] on the instruction set `isa`.
    fn brdf_batch_on(&self, isa: Isa, inc: &Incidence, dirs: &[Vec3], out: &mut Vec<f64>) {
        out.clear();
        out.reserve(dirs.len());
        let setup = self.batch_setup(inc);
        // The block arrays (9 KiB) are kept per thread rather than zeroed on every call:
        // every lane a block reads was written earlier in that block (`batch_block`).
        BUFFERS.with(|cell| {
            let mut fresh;
            let mut held;
            let buf: &mut Buffers = if let Ok(b) = cell.try_borrow_mut() {
                held = b;
                &mut held
            } else {
                fresh = Buffers::default();
                &mut fresh
            };
            dispatch_on(
                isa,
                Batch {
                    model: self,
                    inc,
                    setup: &setup,
                    dirs,
                    out,
                    buf,
                },
            );
        });
    }
}

thread_local! {
    /// Each thread's block arrays for [`DistributionModel::brdf_batch`].
    static BUFFERS: std::cell::RefCell<Buffers> = std::cell::RefCell::new(Buffers::default());
}

/// The per-block arrays of the kernel (structure of arrays, [`LANES`] each).
#[derive(Debug, Clone)]
struct Buffers {
    x: [f64; LANES],
    y: [f64; LANES],
    z: [f64; LANES],
    hx: [f64; LANES],
    hy: [f64; LANES],
    hz: [f64; LANES],
    /// `r.x / n`, `r.y / n`.
    k2x: [f64; LANES],
    k2y: [f64; LANES],
    c2: [f64; LANES],
    rho: [f64; LANES],
    /// 1.0 where the BRDF is zero, 0.0 elsewhere.
    zero: [f64; LANES],
    /// 1.0 where the scalar path computes the lane, 0.0 elsewhere.
    scalar: [f64; LANES],
    p2: [f64; LANES],
    shifted: [f64; LANES],
    big_rs: [f64; LANES],
    big_rp: [f64; LANES],
    x2: [f64; LANES],
    out: [f64; LANES],
}

impl Default for Buffers {
    fn default() -> Self {
        let z = [0.0; LANES];
        Self {
            x: z,
            y: z,
            z,
            hx: z,
            hy: z,
            hz: z,
            k2x: z,
            k2y: z,
            c2: z,
            rho: z,
            zero: z,
            scalar: z,
            p2: z,
            shifted: z,
            big_rs: z,
            big_rp: z,
            x2: z,
            out: z,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::ModelOptions;
    use flakescatter_optics::flake::FlakeReflectance;
    use flakescatter_optics::polarization::Transmission;
    use flakescatter_stats::{GaussianWidth, Orientation};
    use rand::{RngExt, SeedableRng};

    /// Each instruction set the processor has (AVX-512, AVX2) gives the portable
    /// code's bits (one lane per vector, [`pulp::Scalar`]: the reference) on every
    /// flake branch of the kernel (perfect conductor, complex index, the `paper`
    /// bookkeeping, a tabulated distribution), over the upper hemisphere and random
    /// directions; an instruction set the processor lacks is named on stderr, so that
    /// a skipped comparison is never silent.
    #[test]
    fn every_instruction_set_gives_the_portable_bits() {
        let mut isas = Vec::new();
        #[cfg(target_arch = "x86_64")]
        {
            match pulp::x86::V4::try_new() {
                Some(v4) => isas.push(Isa::V4(v4)),
                None => eprintln!(
                    "note: every_instruction_set_gives_the_portable_bits: no AVX-512 on this processor; its kernel was not compared"
                ),
            }
            match pulp::x86::V3::try_new() {
                Some(v3) => isas.push(Isa::V3(v3)),
                None => eprintln!(
                    "note: every_instruction_set_gives_the_portable_bits: no AVX2 on this processor; its kernel was not compared"
                ),
            }
        }
        let gaussian =
            |hwhm: f64| Orientation::gaussian(GaussianWidth::Hwhm(hwhm.to_radians())).unwrap();
        let metal = FlakeReflectance::complex(1.2, 7.0).unwrap();
        let models = [
            (gaussian(6.0), ModelOptions::default()),
            (gaussian(0.3), ModelOptions::default()),
            (
                gaussian(20.0),
                ModelOptions {
                    flake: metal,
                    ..ModelOptions::default()
                },
            ),
            (
                gaussian(8.0),
                ModelOptions {
                    transmission: Transmission::Paper,
                    ..ModelOptions::default()
                },
            ),
            (
                Orientation::tabulated(vec![0.0, 0.1, 0.3, 0.6], vec![0.5, 0.3, 0.2]).unwrap(),
                ModelOptions::default(),
            ),
        ];
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(22);
        let mut dirs: Vec<Vec3> = (0..45)
            .flat_map(|i| {
                let t = (2.0 * f64::from(i) + 0.5).to_radians();
                (0..90).map(move |j| {
                    let p = f64::from(4 * j).to_radians();
                    Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
                })
            })
            .collect();
        dirs.extend((0..1000).map(|_| {
            let z: f64 = rng.random_range(-0.2..1.0);
            let phi = rng.random_range(0.0..std::f64::consts::TAU);
            let s = (1.0 - z * z).sqrt();
            Vec3::new(s * phi.cos(), s * phi.sin(), z)
        }));
        let (mut want, mut got) = (Vec::new(), Vec::new());
        let mut nonzero = 0;
        for (orientation, options) in models {
            let m = DistributionModel::new(orientation, 1.5, options).unwrap();
            for ti in [0.0, 0.3, 0.8, 1.3] {
                let inc = m.incidence(ti).unwrap();
                m.brdf_batch_on(Isa::Portable, &inc, &dirs, &mut want);
                nonzero += want.iter().filter(|&&v| v > 0.0).count();
                for &isa in &isas {
                    m.brdf_batch_on(isa, &inc, &dirs, &mut got);
                    for ((r, g), w) in dirs.iter().zip(&got).zip(&want) {
                        assert_eq!(
                            g.to_bits(),
                            w.to_bits(),
                            "{} θi {ti} r {r:?}: {g:e} vs portable {w:e}",
                            isa.name()
                        );
                    }
                }
            }
        }
        assert!(nonzero > 20_000, "only {nonzero} non-zero values");
    }
}
