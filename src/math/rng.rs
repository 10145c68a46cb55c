//! A small counter-friendly random number generator: every random number in
//! raylab comes from a SplitMix64 stream seeded by a hash of what it is for
//! (seed, pixel, sample, bounce), never from thread state.

use super::{uniform_sphere, Aabb, Vec3};

/// SplitMix64 (Steele, Lea & Flood, "Fast splittable pseudorandom number
/// generators", OOPSLA 2014): a tiny seeded generator for test and
/// validation rays, and (through [`SplitMix64::mix`]) a well-mixed hash.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    /// The generator's output function applied to `z + γ`: a bijective,
    /// well-mixed hash of `z`.
    pub fn mix(z: u64) -> u64 {
        let mut z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    pub fn next_u64(&mut self) -> u64 {
        let out = Self::mix(self.0);
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        out
    }

    /// Uniform in [0, 1), 24 random bits.
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
    }

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
