//! The portable switch and the instruction-set choice of every SIMD kernel of the
//! project (the topographic model's, the distribution model's batch BRDF, the volume
//! model's rays).
//!
//! The kernels are compiled once for AVX-512 (x86-64-v4, [`pulp::x86::V4`]), once for
//! AVX2 (x86-64-v3, [`pulp::x86::V3`]) and once portable (the target's baseline), and
//! [`Isa::of`] takes the best the processor has at run time, unless [`Kernels`] asks
//! for the portable code alone. The kernels use the same operations in the same order
//! in every build (no fused multiply–add but where a kernel writes one explicitly,
//! which every build rounds correctly), so every instruction set gives the same bits;
//! the switch exists to check that.
//!
//! The environment variable `FLAKESCATTER_SIMD`, read once per process
//! ([`Kernels::from_env`]), sets the kernels of the models that read it:
//! * unset, empty or `auto`: [`Kernels::Auto`];
//! * `portable`: [`Kernels::Portable`] (`.ci/run` runs the model tests so);
//! * anything else (`avx2`, `Portable`, a typo, a value that is not UTF-8): an error
//!   naming the value ([`SimdSwitchError`]), which the models return when they are
//!   built rather than silently running the other path.
//!
//! [`dispatch`] runs a [`pulp::WithSimd`] operation under the chosen instruction set;
//! the topographic model's kernels, typed by their own lane trait, match on
//! [`Isa::of`] themselves.

use std::sync::OnceLock;

/// Which kernels a model runs (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Kernels {
    /// The processor's best instruction set (AVX-512, AVX2, else the portable code),
    /// chosen at run time.
    #[default]
    Auto,
    /// The portable code only.
    Portable,
}

/// `FLAKESCATTER_SIMD` holds a value other than unset, empty, `auto` or `portable`: the
/// value, lossily decoded.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "environment variable FLAKESCATTER_SIMD={0:?} is not valid: expected `auto` (or unset) for the processor's best instruction set, or `portable` for the portable code"
)]
pub struct SimdSwitchError(pub String);

impl Kernels {
    /// The environment variable that sets the kernels (module docs).
    pub const ENV: &'static str = "FLAKESCATTER_SIMD";

    /// The kernels `FLAKESCATTER_SIMD` asks for (module docs), read once per process.
    ///
    /// # Errors
    /// [`SimdSwitchError`] for a value other than unset, empty, `auto` or `portable`.
    pub fn from_env() -> Result<Self, SimdSwitchError> {
        static FROM_ENV: OnceLock<Result<Kernels, SimdSwitchError>> = OnceLock::new();
        FROM_ENV
            .get_or_init(|| Self::parse(std::env::var_os(Self::ENV).as_deref()))
            .clone()
    }

    /// The kernels a value of `FLAKESCATTER_SIMD` asks for (`None`: unset).
    ///
    /// # Errors
    /// As [`Kernels::from_env`].
    pub fn parse(value: Option<&std::ffi::OsStr>) -> Result<Self, SimdSwitchError> {
        match value.map(|v| v.to_str()) {
            None | Some(Some("" | "auto")) => Ok(Self::Auto),
            Some(Some("portable")) => Ok(Self::Portable),
            Some(_) => Err(SimdSwitchError(
                value.unwrap_or_default().to_string_lossy().into_owned(),
            )),
        }
    }
}

/// The instruction set a kernel runs under.
#[derive(Debug, Clone, Copy)]
pub enum Isa {
    /// AVX-512 (x86-64-v4).
    #[cfg(target_arch = "x86_64")]
    V4(pulp::x86::V4),
    /// AVX2 (x86-64-v3).
    #[cfg(target_arch = "x86_64")]
    V3(pulp::x86::V3),
    /// The portable code.
    Portable,
}

impl Isa {
    /// The instruction set for `kernels` on this processor: [`Isa::Portable`] for
    /// [`Kernels::Portable`], else the best of AVX-512, AVX2 and the portable code.
    #[inline]
    #[must_use]
    pub fn of(kernels: Kernels) -> Self {
        if kernels == Kernels::Portable {
            return Self::Portable;
        }
        #[cfg(target_arch = "x86_64")]
        {
            if let Some(v4) = pulp::x86::V4::try_new() {
                return Self::V4(v4);
            }
            if let Some(v3) = pulp::x86::V3::try_new() {
                return Self::V3(v3);
            }
        }
        Self::Portable
    }

    /// Its name (`AVX-512`, `AVX2`, `portable`), for messages.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            #[cfg(target_arch = "x86_64")]
            Self::V4(_) => "AVX-512",
            #[cfg(target_arch = "x86_64")]
            Self::V3(_) => "AVX2",
            Self::Portable => "portable",
        }
    }
}

/// Runs `op` under the instruction set [`Isa::of`]`(kernels)` chooses: its
/// `with_simd` is inlined into that instruction set's build (with everything it
/// inlines in turn), or called with [`pulp::Scalar`] for the portable code.
#[inline(always)]
pub fn dispatch<Op: pulp::WithSimd>(kernels: Kernels, op: Op) -> Op::Output {
    dispatch_on(Isa::of(kernels), op)
}

/// Runs `op` under the instruction set `isa` ([`dispatch`]; for tests that compare the
/// instruction sets one by one).
#[inline(always)]
pub fn dispatch_on<Op: pulp::WithSimd>(isa: Isa, op: Op) -> Op::Output {
    match isa {
        #[cfg(target_arch = "x86_64")]
        Isa::V4(v4) => pulp::Simd::vectorize(v4, op),
        #[cfg(target_arch = "x86_64")]
        Isa::V3(v3) => pulp::Simd::vectorize(v3, op),
        Isa::Portable => pulp::Simd::vectorize(pulp::Scalar::new(), op),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::ffi::OsStr;

    /// The switch's values: unset, empty and `auto` are the run-time choice,
    /// `portable` the portable code, anything else an error naming the value.
    #[test]
    fn the_switch_accepts_three_values_and_names_any_other() {
        assert_eq!(Kernels::parse(None), Ok(Kernels::Auto));
        assert_eq!(Kernels::parse(Some(OsStr::new(""))), Ok(Kernels::Auto));
        assert_eq!(Kernels::parse(Some(OsStr::new("auto"))), Ok(Kernels::Auto));
        assert_eq!(
            Kernels::parse(Some(OsStr::new("portable"))),
            Ok(Kernels::Portable)
        );
        for bad in ["avx2", "Portable", "scalar", " portable"] {
            let err = Kernels::parse(Some(OsStr::new(bad))).unwrap_err();
            assert_eq!(err, SimdSwitchError(bad.to_owned()));
            let text = err.to_string();
            assert!(
                text.contains("FLAKESCATTER_SIMD") && text.contains(bad),
                "{text}"
            );
        }
        assert_eq!(Isa::of(Kernels::Portable).name(), "portable");
    }

    /// Which `Simd` type an operation is given.
    struct Lanes;

    impl pulp::WithSimd for Lanes {
        type Output = usize;

        fn with_simd<S: pulp::Simd>(self, _: S) -> usize {
            std::mem::size_of::<S::f64s>() / std::mem::size_of::<f64>()
        }
    }

    /// `dispatch` runs the portable code (one `f64` per vector, `pulp::Scalar`) for
    /// `Kernels::Portable`, and for `Kernels::Auto` the width of the best instruction set
    /// the processor has: 8 lanes for AVX-512, 4 for AVX2 (pulp's `f64s` of each).
    #[test]
    fn dispatch_follows_the_switch() {
        assert_eq!(dispatch(Kernels::Portable, Lanes), 1);
        let want = match Isa::of(Kernels::Auto) {
            #[cfg(target_arch = "x86_64")]
            Isa::V4(_) => 8,
            #[cfg(target_arch = "x86_64")]
            Isa::V3(_) => 4,
            Isa::Portable => 1,
        };
        assert_eq!(dispatch(Kernels::Auto, Lanes), want);
        #[cfg(target_arch = "x86_64")]
        if pulp::x86::V3::try_new().is_some() {
            assert!(want >= 4, "a processor with AVX2 runs at least 4 lanes");
        }
    }
}
