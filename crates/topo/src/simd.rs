//! The kernel layer: the SIMD types of the topographic model, its one dispatch helper
//! ([`dispatch!`]) and its kernels, each beside its portable reference.
//!
//! # Instruction sets
//! The hot loops (the rays of a chunk, [`crate::model`]; the window sums of the normals,
//! [`crate::normals`]; the contraction of the isotropic table, [`crate::isotropic`]) run
//! under [`dispatch!`]: compiled once for AVX-512 (x86-64-v4, [`pulp::x86::V4`]), once
//! for AVX2 (x86-64-v3, [`pulp::x86::V3`]) and once portable (the target's baseline),
//! and the best the processor has is taken at run time. The loop body gets a value of
//! a [`Lanes`] type that names the instruction set: the eight-lane kernels of
//! [`Lanes`] have a portable reference (the trait's provided methods, written lane by
//! lane) and, for AVX-512, one masked vector instruction per kernel. Every form uses
//! additions, multiplications, compares and selects only, in the same order, never a
//! fused multiply–add: every instruction set gives the same bits, which the unit tests
//! below check kernel by kernel and `tests/kernels.rs` checks on whole runs.
//!
//! # The portable switch
//! [`Kernels`] chooses between the run-time choice above ([`Kernels::Auto`], the
//! default) and the portable code alone ([`Kernels::Portable`]: no run-time selection,
//! no vector kernel, the build's baseline instruction set), per model
//! ([`crate::TopoModel::with_kernels`]). [`crate::TopoModel::new`] takes it from the
//! environment variable `FLAKESCATTER_SIMD`, read once per process
//! ([`flakescatter_numerics::simd`]: the one switch and instruction-set choice of the
//! project's kernels, which the distribution model's batch BRDF and the volume model's
//! rays follow too):
//! * unset, empty or `auto`: [`Kernels::Auto`];
//! * `portable`: [`Kernels::Portable`], to check that a result does not depend on the
//!   processor (`.ci/run` runs the topo tests so);
//! * anything else (`avx2`, `Portable`, a typo, a value that is not UTF-8):
//!   [`crate::TopoModel::new`] refuses with [`crate::TopoError::SimdSwitch`] naming the
//!   value, rather than silently running the other path.

/// The instruction set [`dispatch!`] runs a body under
/// ([`flakescatter_numerics::simd::Isa`]).
pub(crate) use flakescatter_numerics::simd::Isa;
/// Which kernels a model runs: the one switch of the project's kernels
/// ([`flakescatter_numerics::simd`], module docs).
pub use flakescatter_numerics::simd::Kernels;

/// Lanes of a [`Block`] and of the eight-lane kernels: one AVX-512 register of `f64`,
/// two of AVX2.
pub(crate) const LANES: usize = 8;

/// Up to [`LANES`] cones, field by field, so that a direction is tested against all of
/// them in one loop of fixed length (vector compares): four cache lines, aligned to
/// them. Unused lanes have a zero axis and `cos_alpha = +∞`, which no direction passes.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
pub(crate) struct Block {
    pub ax: [f64; LANES],
    pub ay: [f64; LANES],
    pub az: [f64; LANES],
    pub cos_alpha: [f64; LANES],
}

impl Block {
    /// A block of unused lanes.
    pub fn empty() -> Self {
        Self {
            ax: [0.0; LANES],
            ay: [0.0; LANES],
            az: [0.0; LANES],
            cos_alpha: [f64::INFINITY; LANES],
        }
    }
}

/// The instruction set a loop body runs under, as a value ([`dispatch!`]): its
/// kernels. The provided methods are the portable references, lane by lane; the
/// AVX-512 type overrides them with one vector instruction each (the same operations
/// in the same order, so the same bits).
pub(crate) trait Lanes: Copy {
    /// Bit `l` set when `(x, y, z)` is inside lane `l`'s cone of `block`,
    /// `(ax·x + ay·y) + az·z > cos α` (each product and sum rounded, as
    /// [`crate::index::Entry::contains`]).
    #[inline(always)]
    fn inside(self, block: &Block, x: f64, y: f64, z: f64) -> u64 {
        let dot: [f64; LANES] =
            std::array::from_fn(|l| block.ax[l] * x + block.ay[l] * y + block.az[l] * z);
        let mut mask = 0u64;
        for (l, (d, c)) in dot.iter().zip(&block.cos_alpha).enumerate() {
            mask |= u64::from(d > c) << l;
        }
        mask
    }

    /// Adds `w` to each lane of `sums` whose bit of `bits` is set, and 1 to the same
    /// lane of `counts`: `sums[l] + w` rounded as one addition, the other lanes left as
    /// they are (as adding −0.0 and 0 would leave them).
    #[inline(always)]
    fn add_hits(self, sums: &mut [f64; LANES], counts: &mut [u32; LANES], bits: u8, w: f64) {
        for l in 0..LANES {
            let hit = (bits >> l) & 1 != 0;
            sums[l] += if hit { w } else { -0.0 };
            counts[l] += u32::from(hit);
        }
    }

    /// `sums[l] += g · v[l]` (the product rounded, then the sum) for the first `len`
    /// lanes (`len ≤ LANES`), the others left as they are.
    #[inline(always)]
    fn add_scaled(self, sums: &mut [f64; LANES], v: &[f64; LANES], g: f64, len: usize) {
        debug_assert!(len <= LANES);
        for (s, &v) in sums.iter_mut().zip(v).take(len) {
            *s += g * v;
        }
    }

    /// `counts[l] += n` for the first `len` lanes (`len ≤ LANES`).
    #[inline(always)]
    fn add_count(self, counts: &mut [u32; LANES], n: u32, len: usize) {
        debug_assert!(len <= LANES);
        for c in counts.iter_mut().take(len) {
            *c += n;
        }
    }

    /// Asks the processor to start loading the cache lines of `heights` and `valid`,
    /// which will be read soon: a hint that changes no value, only when the bytes
    /// arrive. The portable form gives no hint.
    #[inline(always)]
    fn prefetch(self, _heights: &[f64], _valid: &[bool]) {}
}

/// The portable code: every kernel as its reference, compiled for the build's baseline
/// (vectorised by the compiler as that allows).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Portable;

impl Lanes for Portable {}

/// AVX2: the portable kernels (vectorised by the compiler for AVX2) and prefetching.
#[cfg(target_arch = "x86_64")]
impl Lanes for pulp::x86::V3 {
    /// `prefetcht0` of every 64-byte line (the pointer is only a hint: it is never
    /// dereferenced, and a prefetch cannot fault).
    #[inline(always)]
    fn prefetch(self, heights: &[f64], valid: &[bool]) {
        const T0: i32 = core::arch::x86_64::_MM_HINT_T0;
        for k in (0..heights.len()).step_by(8) {
            self.sse._mm_prefetch::<T0>(heights[k..].as_ptr().cast());
        }
        for k in (0..valid.len()).step_by(64) {
            self.sse._mm_prefetch::<T0>(valid[k..].as_ptr().cast());
        }
    }
}

/// AVX-512: one masked vector instruction per kernel.
#[cfg(target_arch = "x86_64")]
impl Lanes for pulp::x86::V4 {
    /// `(ax·x + ay·y) + az·z > cos α` in eight lanes at once: products and sums
    /// rounded one by one, as the reference (no fused multiply–add).
    #[inline(always)]
    fn inside(self, block: &Block, x: f64, y: f64, z: f64) -> u64 {
        let (ax, ay, az, c): (pulp::f64x8, pulp::f64x8, pulp::f64x8, pulp::f64x8) = (
            pulp::cast(block.ax),
            pulp::cast(block.ay),
            pulp::cast(block.az),
            pulp::cast(block.cos_alpha),
        );
        let dot = self.add_f64x8(
            self.add_f64x8(
                self.mul_f64x8(ax, self.splat_f64x8(x)),
                self.mul_f64x8(ay, self.splat_f64x8(y)),
            ),
            self.mul_f64x8(az, self.splat_f64x8(z)),
        );
        u64::from(self.cmp_gt_f64x8(dot, c).0)
    }

    /// One masked addition per array.
    #[inline(always)]
    fn add_hits(self, sums: &mut [f64; LANES], counts: &mut [u32; LANES], bits: u8, w: f64) {
        let hit = pulp::b8(bits);
        let s: pulp::f64x8 = pulp::cast(*sums);
        *sums = pulp::cast(self.select_f64x8(hit, self.add_f64x8(s, self.splat_f64x8(w)), s));
        let c: pulp::u32x8 = pulp::cast(*counts);
        let one = self.splat_u32x8(1);
        *counts = pulp::cast(self.select_u32x8(hit, self.wrapping_add_u32x8(c, one), c));
    }

    /// One masked multiply–add (two roundings, as the reference).
    #[inline(always)]
    fn add_scaled(self, sums: &mut [f64; LANES], v: &[f64; LANES], g: f64, len: usize) {
        debug_assert!(len <= LANES);
        let first = pulp::b8(((1u32 << len) - 1) as u8);
        let s: pulp::f64x8 = pulp::cast(*sums);
        let gv = self.mul_f64x8(self.splat_f64x8(g), pulp::cast(*v));
        *sums = pulp::cast(self.select_f64x8(first, self.add_f64x8(s, gv), s));
    }

    /// One masked addition.
    #[inline(always)]
    fn add_count(self, counts: &mut [u32; LANES], n: u32, len: usize) {
        debug_assert!(len <= LANES);
        let first = pulp::b8(((1u32 << len) - 1) as u8);
        let c: pulp::u32x8 = pulp::cast(*counts);
        let added = self.wrapping_add_u32x8(c, self.splat_u32x8(n));
        *counts = pulp::cast(self.select_u32x8(first, added, c));
    }

    /// As AVX2.
    #[inline(always)]
    fn prefetch(self, heights: &[f64], valid: &[bool]) {
        (*self).prefetch(heights, valid);
    }
}

/// The one dispatch helper: `dispatch!(kernels, |lanes| body)` evaluates `body` with
/// `lanes` bound to the [`Lanes`] value of the instruction set [`Isa::of`]`(kernels)`
/// chooses, compiled for that instruction set (inside [`pulp::Simd::vectorize`], with
/// everything the body calls in its hot loops `#[inline(always)]`, so that the whole
/// loop is compiled for it; code the compiler kept out of line would run as the
/// baseline). The body is written once and compiled once per instruction set.
macro_rules! dispatch {
    ($kernels:expr, |$lanes:ident| $body:expr) => {
        match $crate::simd::Isa::of($kernels) {
            #[cfg(target_arch = "x86_64")]
            $crate::simd::Isa::V4(v4) => pulp::Simd::vectorize(
                v4,
                #[inline(always)]
                || {
                    let $lanes = v4;
                    $body
                },
            ),
            #[cfg(target_arch = "x86_64")]
            $crate::simd::Isa::V3(v3) => pulp::Simd::vectorize(
                v3,
                #[inline(always)]
                || {
                    let $lanes = v3;
                    $body
                },
            ),
            $crate::simd::Isa::Portable => {
                let $lanes = $crate::simd::Portable;
                $body
            }
        }
    };
}
pub(crate) use dispatch;

/// What the tests of the kernels share.
#[cfg(test)]
pub(crate) mod testing {
    /// The AVX-512 form of a kernel, or `None` with a note on stderr saying that its
    /// comparison with the portable reference was skipped (no AVX-512 on this
    /// processor), so that a skipped comparison is never silent.
    #[cfg(target_arch = "x86_64")]
    pub(crate) fn avx512_or_note(test: &str) -> Option<pulp::x86::V4> {
        let v4 = pulp::x86::V4::try_new();
        if v4.is_none() {
            eprintln!(
                "note: {test}: this processor has no AVX-512; the AVX-512 kernels were not compared with their portable references (only the portable form was tested)"
            );
        }
        v4
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    /// Eight sums for the lane tests: a quarter −0.0, a quarter +0.0, the rest in ±1000.
    fn test_sums(rng: &mut rand_chacha::ChaCha8Rng) -> [f64; LANES] {
        std::array::from_fn(|_| match rng.random_range(0..4) {
            0 => -0.0,
            1 => 0.0,
            _ => rng.random_range(-1e3..1e3),
        })
    }

    /// `Lanes::inside` of AVX-512 gives the portable reference's mask on random blocks
    /// (with unused lanes) and directions, and the reference is the dot product lane by
    /// lane.
    #[test]
    fn inside_masks_equal_the_reference() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        #[cfg(target_arch = "x86_64")]
        let v4 = testing::avx512_or_note("inside_masks_equal_the_reference");
        for _ in 0..5000 {
            let mut block = Block::empty();
            for l in 0..rng.random_range(0..=LANES) {
                let (a, b): (f64, f64) = (rng.random_range(-0.7..0.7), rng.random_range(-0.7..0.7));
                (block.ax[l], block.ay[l], block.az[l]) = (a, b, (1.0 - a * a - b * b).sqrt());
                block.cos_alpha[l] = rng.random_range(0.5..1.0);
            }
            let (x, y): (f64, f64) = (rng.random_range(-0.7..0.7), rng.random_range(-0.7..0.7));
            let z = (1.0 - x * x - y * y).sqrt();
            let want = (0..LANES).fold(0u64, |m, l| {
                let d = block.ax[l] * x + block.ay[l] * y + block.az[l] * z;
                m | u64::from(d > block.cos_alpha[l]) << l
            });
            assert_eq!(Portable.inside(&block, x, y, z), want);
            #[cfg(target_arch = "x86_64")]
            if let Some(v4) = v4 {
                let wide = pulp::Simd::vectorize(v4, || v4.inside(&block, x, y, z));
                assert_eq!(wide, want, "AVX-512");
            }
        }
    }

    /// `Lanes::add_hits` adds `w` to the lanes whose bit is set, once each, and leaves
    /// the others bit for bit as they were (−0.0 and +0.0 sums included), portable
    /// and AVX-512 alike: the reference is the plain `sums[l] + w` lane by lane.
    #[test]
    fn add_hits_adds_to_the_set_lanes_only() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        #[cfg(target_arch = "x86_64")]
        let v4 = testing::avx512_or_note("add_hits_adds_to_the_set_lanes_only");
        for _ in 0..2000 {
            let sums = test_sums(&mut rng);
            let counts: [u32; LANES] = std::array::from_fn(|_| rng.random_range(0..1000));
            let (bits, w) = (rng.random_range(0..=255u8), rng.random_range(1e-9..1e2));
            let want_sums: [u64; LANES] = std::array::from_fn(|l| {
                if bits >> l & 1 == 1 {
                    sums[l] + w
                } else {
                    sums[l]
                }
                .to_bits()
            });
            let want_counts: [u32; LANES] =
                std::array::from_fn(|l| counts[l] + u32::from(bits >> l & 1));
            let (mut s, mut c) = (sums, counts);
            Portable.add_hits(&mut s, &mut c, bits, w);
            assert_eq!(s.map(f64::to_bits), want_sums, "bits {bits:08b}");
            assert_eq!(c, want_counts);
            #[cfg(target_arch = "x86_64")]
            if let Some(v4) = v4 {
                let (mut s, mut c) = (sums, counts);
                pulp::Simd::vectorize(v4, || v4.add_hits(&mut s, &mut c, bits, w));
                assert_eq!(s.map(f64::to_bits), want_sums, "AVX-512, bits {bits:08b}");
                assert_eq!(c, want_counts);
            }
        }
    }

    /// `Lanes::add_scaled` adds `g · v[l]` and `Lanes::add_count` adds `n` to the first
    /// `len` lanes only, portable and AVX-512 alike, bit for bit the lane-by-lane
    /// `sums[l] + g · v[l]`.
    #[test]
    fn runs_add_to_their_first_lanes_only() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        #[cfg(target_arch = "x86_64")]
        let v4 = testing::avx512_or_note("runs_add_to_their_first_lanes_only");
        for _ in 0..2000 {
            let sums = test_sums(&mut rng);
            let v: [f64; LANES] = std::array::from_fn(|_| rng.random_range(0.0..10.0));
            let counts: [u32; LANES] = std::array::from_fn(|_| rng.random_range(0..1000));
            let (g, n, len) = (
                rng.random_range(1e-9..1e2),
                rng.random_range(0..500u32),
                rng.random_range(0..=LANES),
            );
            let want_sums: [u64; LANES] = std::array::from_fn(|l| {
                if l < len { sums[l] + g * v[l] } else { sums[l] }.to_bits()
            });
            let want_counts: [u32; LANES] =
                std::array::from_fn(|l| counts[l] + if l < len { n } else { 0 });
            let (mut s, mut c) = (sums, counts);
            Portable.add_scaled(&mut s, &v, g, len);
            Portable.add_count(&mut c, n, len);
            assert_eq!(s.map(f64::to_bits), want_sums, "len {len}");
            assert_eq!(c, want_counts, "len {len}");
            #[cfg(target_arch = "x86_64")]
            if let Some(v4) = v4 {
                let (mut s, mut c) = (sums, counts);
                pulp::Simd::vectorize(v4, || {
                    v4.add_scaled(&mut s, &v, g, len);
                    v4.add_count(&mut c, n, len);
                });
                assert_eq!(s.map(f64::to_bits), want_sums, "AVX-512, len {len}");
                assert_eq!(c, want_counts, "AVX-512, len {len}");
            }
        }
    }
}
