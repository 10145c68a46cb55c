//! A small counter-friendly random number generator: every random number in
//! raylab comes from a SplitMix64 stream seeded by a hash of what it is for
//! (seed, pixel, sample, bounce), never from thread state.

use super::{uniform_sphere, Aabb, Vec3};

/// SplitMix64 (Steele, Lea & Flood, "Fast splittable pseudorandom number
/// generators", OOPSLA 2014): a tiny seeded generator for test and
/// validation rays, and (through [`SplitMix64::mix`]) a well-mixed hash.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SplitMix64(pub u64);

/// The 64-bit word operations SplitMix64 needs, on one `u64` or on SIMD
/// lanes of them (the path tracer's groups draw 16 streams at once with
/// AVX-512), so that its formulas are written once for both.
pub trait Words: Copy {
    fn splat(x: u64) -> Self;
    fn wrapping_add(self, o: Self) -> Self;
    fn wrapping_mul(self, o: Self) -> Self;
    fn xor(self, o: Self) -> Self;
    /// `self >> N`.
    fn shr<const N: u32>(self) -> Self;
}

impl Words for u64 {
    #[inline(always)]
    fn splat(x: u64) -> Self {
        x
    }
    #[inline(always)]
    fn wrapping_add(self, o: Self) -> Self {
        u64::wrapping_add(self, o)
    }
    #[inline(always)]
    fn wrapping_mul(self, o: Self) -> Self {
        u64::wrapping_mul(self, o)
    }
    #[inline(always)]
    fn xor(self, o: Self) -> Self {
        self ^ o
    }
    #[inline(always)]
    fn shr<const N: u32>(self) -> Self {
        self >> N
    }
}

impl SplitMix64 {
    /// The generator's increment γ (the golden ratio's fraction).
    pub const GAMMA: u64 = 0x9E37_79B9_7F4A_7C15;

    /// The generator's output function applied to `z + γ`: a bijective,
    /// well-mixed hash of `z`.
    #[inline]
    pub fn mix(z: u64) -> u64 {
        Self::mix_words(z)
    }

    /// [`Self::mix`] on any [`Words`].
    #[inline(always)]
    pub fn mix_words<W: Words>(z: W) -> W {
        let z = z.wrapping_add(W::splat(Self::GAMMA));
        let z = z
            .xor(z.shr::<30>())
            .wrapping_mul(W::splat(0xBF58_476D_1CE4_E5B9));
        let z = z
            .xor(z.shr::<27>())
            .wrapping_mul(W::splat(0x94D0_49BB_1331_11EB));
        z.xor(z.shr::<31>())
    }

    /// The state of the stream keyed by (`seed`, `pixel`, `key`):
    /// mix(seed ⊕ mix(pixel ⊕ mix(key))). The pixel sampler's streams and
    /// the path tracer's per-vertex ones start here.
    #[inline(always)]
    pub fn keyed<W: Words>(seed: W, pixel: W, key: W) -> W {
        let mix = Self::mix_words::<W>;
        mix(seed.xor(mix(pixel.xor(mix(key)))))
    }

    /// The `n`th output of the stream whose state is `state` (0 first):
    /// [`Self::next_u64`] after `n` calls, on any [`Words`].
    #[inline(always)]
    pub fn output_words<W: Words>(state: W, n: u64) -> W {
        Self::mix_words(state.wrapping_add(W::splat(Self::GAMMA.wrapping_mul(n))))
    }

    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        let out = Self::mix(self.0);
        self.0 = self.0.wrapping_add(Self::GAMMA);
        out
    }

    /// Uniform in [0, 1), 24 random bits: the top 24 bits of an output
    /// ([`Self::UNIT_SHIFT`]) times 2⁻²⁴ ([`Self::UNIT_SCALE`]), exact.
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u64() >> Self::UNIT_SHIFT) as f32 * Self::UNIT_SCALE
    }

    /// [`Self::next_f32`]'s shift: 64 − 24.
    pub const UNIT_SHIFT: u32 = 40;
    /// [`Self::next_f32`]'s scale: 2⁻²⁴.
    pub const UNIT_SCALE: f32 = 1.0 / (1u64 << 24) as f32;

    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.next_f32()
    }

    /// Uniform integer in [0, n) (n > 0; the modulo bias is below 2⁻³² for
    /// any n that fits in memory).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }

    /// Uniform direction on the unit sphere (see [`uniform_sphere`]).
    pub fn unit_vector(&mut self) -> Vec3 {
        let u = glam::Vec2::new(self.next_f32(), self.next_f32());
        uniform_sphere(u)
    }

    /// Uniform point in a box.
    pub fn in_box(&mut self, b: &Aabb) -> Vec3 {
        b.min + b.extent() * Vec3::new(self.next_f32(), self.next_f32(), self.next_f32())
    }
}
