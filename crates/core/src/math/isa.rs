//! Instruction-set capabilities as types: how safe code picks the AVX2
//! forms of the SIMD kernels (the 8-wide node test [`slab8_avx2`], the
//! packet leaves' lane masks in `accel::bvh::packet`, the wide trees'
//! traversal compiled for AVX2) without ever running an instruction the
//! CPU lacks.
//!
//! [`Avx2`] is a zero-sized proof that the CPU has AVX2: its one
//! constructor, [`Avx2::detect`], returns a value only where it does. The
//! kernels are generic over an [`Isa`], [`Baseline`] or [`Avx2`], and take
//! a value of it; they reach AVX2 code only through [`Isa::avx2`], which
//! is `Some` only for an `Avx2` value, so only with a proof in hand. Safe
//! code cannot make a proof up (the field is private and there is no
//! `Default`), nor add a capability of its own (the trait is sealed), so
//! every `unsafe` block that runs AVX2 instructions is argued from a token
//! it was given. A tree records the token it detected at build time
//! (`WideBvh`), and the path tracer's inlinable view of it carries the
//! token along (`accel::bvh::InlineAvx2`).
//!
//! Why a token rather than the alternatives:
//! - a `const AVX2: bool` parameter (the design before) is the caller's
//!   word: a safe call with `true` on a CPU without AVX2 executed an
//!   illegal instruction;
//! - `unsafe fn`s with a `# Safety` section are sound, but move the check
//!   and its argument to every caller (the traversal, the inline view,
//!   the path tracer's groups, the tests), where the token is checked once,
//!   by `detect`, and then carried for free;
//! - private functions would hide the kernels from the tests and
//!   benchmarks of other modules that compare them with the portable
//!   forms.
//!
//! Cost: none. The token has no bytes, and `isa.avx2()` is a constant
//! once the kernel is monomorphised (`Some` for `Avx2`, `None` for
//! `Baseline`), so each instantiation compiles to the code the `const
//! AVX2: bool` of before gave it: the same instructions and the same bits.
//!
//! A token cannot be forged by safe code:
//!
//! ```compile_fail,E0423
//! let avx2 = raylab::math::Avx2(()); // the field is private
//! ```
//!
//! ```compile_fail,E0599
//! let avx2 = raylab::math::Avx2::default(); // no Default either
//! ```
//!
//! nor can a capability of one's own claim AVX2 (the trait is sealed):
//!
//! ```compile_fail,E0277
//! #[derive(Clone, Copy, Debug)]
//! struct Claimed;
//! impl raylab::math::Isa for Claimed {
//!     fn avx2(self) -> Option<raylab::math::Avx2> {
//!         None
//!     }
//! }
//! ```
//!
//! The one way to a token is detection:
//!
//! ```
//! use raylab::math::{slab8, slab8_with, Avx2, Baseline, Planes8, Vec3};
//! let (lo, hi): (Planes8, Planes8) = ([[0.0; 8]; 3], [[1.0; 8]; 3]);
//! let (o, inv) = (Vec3::splat(-1.0), Vec3::ONE);
//! let portable = slab8_with(Baseline, &lo, &hi, o, inv, f32::MAX);
//! assert_eq!(portable, slab8(&lo, &hi, o, inv, f32::MAX));
//! if let Some(avx2) = Avx2::detect() {
//!     assert_eq!(slab8_with(avx2, &lo, &hi, o, inv, f32::MAX), portable);
//! }
//! ```
//!
//! [`slab8_avx2`]: crate::math::slab8_avx2

use std::fmt::Debug;

/// Proof that the CPU this process runs on has AVX2 (and so AVX). No
/// bytes; made only by [`Avx2::detect`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Avx2(());

impl Avx2 {
    /// A token where the CPU has AVX2, `None` where it has not (and on
    /// every architecture but x86-64). One load of the standard library's
    /// cached feature bits after the first call.
    #[inline]
    pub fn detect() -> Option<Avx2> {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            return Some(Avx2(()));
        }
        None
    }
}

/// The instructions every CPU of the target has (SSE2 on x86-64): the
/// capability that needs no check.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Baseline;

mod sealed {
    /// Only this module's capabilities are [`super::Isa`]s.
    pub trait Sealed {}
    impl Sealed for super::Baseline {}
    impl Sealed for super::Avx2 {}
}

/// The instruction set a SIMD kernel may use: [`Baseline`] or [`Avx2`].
/// Kernels take a value of it and monomorphise on its type.
pub trait Isa: Copy + Debug + Send + Sync + sealed::Sealed {
    /// The AVX2 proof this capability holds: `Some` only for [`Avx2`]
    /// (itself), `None` for [`Baseline`]. A constant after inlining, so a
    /// branch on it costs nothing.
    fn avx2(self) -> Option<Avx2>;
}

impl Isa for Baseline {
    #[inline(always)]
    fn avx2(self) -> Option<Avx2> {
        None
    }
}

impl Isa for Avx2 {
    #[inline(always)]
    fn avx2(self) -> Option<Avx2> {
        Some(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A token exactly where the CPU has AVX2, and it costs no bytes (so
    /// carrying it into a kernel, or keeping one in a tree, is free).
    #[test]
    fn a_token_exists_exactly_where_the_cpu_has_avx2() {
        #[cfg(target_arch = "x86_64")]
        let has = std::arch::is_x86_feature_detected!("avx2");
        #[cfg(not(target_arch = "x86_64"))]
        let has = false;
        assert_eq!(Avx2::detect().is_some(), has);
        assert_eq!(Baseline.avx2(), None);
        if let Some(avx2) = Avx2::detect() {
            assert_eq!(avx2.avx2(), Some(avx2));
        }
        assert_eq!(std::mem::size_of::<Avx2>(), 0);
        assert_eq!(std::mem::size_of::<Option<Avx2>>(), 1);
    }
}
