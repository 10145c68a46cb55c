//! The scalar the shading formulas are written over, and a 3-vector of it.
//!
//! Every shading kernel ([`crate::shading`]) and the reflection and
//! refraction formulas are generic over [`Real`], so the renders run them on
//! `f32` and the derivative code runs *the same functions* on dual numbers
//! (a value with partial derivatives), rather than a second hand-written
//! copy of the physics.
//!
//! Why a trait of our own and not `num_traits::Float`: the kernels need a
//! dozen operations, and a small trait keeps what a dual type has to supply
//! (and what the WGSL shaders mirror) explicit. Why our own [`V3`] and not
//! glam's `Vec3`: glam's vectors are `f32` only. `V3<f32>` does exactly
//! glam's arithmetic in glam's order (dot = (x·x' + y·y') + z·z',
//! normalize = v·(1/|v|)), so converting at a kernel's boundary changes no
//! bit of a render: the conversions compile to nothing.

use glam::Vec3;
use std::fmt::Debug;
use std::ops::{Add, AddAssign, Div, Mul, Neg, Sub};

/// A real number as the shading kernels need it: `f32`, or a dual number
/// carrying derivatives alongside its value.
pub trait Real:
    Copy
    + Debug
    + PartialEq
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
{
    /// A constant (no derivative).
    fn from_f32(x: f32) -> Self;
    /// The value itself, without derivatives: branches (is this light in
    /// front?) are decided on it, as the primal render decides them.
    fn value(self) -> f32;
    fn sqrt(self) -> Self;
    /// `self` raised to a constant exponent.
    fn powf(self, e: f32) -> Self;

    #[inline(always)]
    fn zero() -> Self {
        Self::from_f32(0.0)
    }
    #[inline(always)]
    fn one() -> Self {
        Self::from_f32(1.0)
    }
    /// The larger of the two by value (`f32::max`'s rule: a NaN loses).
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        if o.value() > self.value() || self.value().is_nan() {
            o
        } else {
            self
        }
    }
    /// The smaller of the two by value (a NaN loses).
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        if o.value() < self.value() || self.value().is_nan() {
            o
        } else {
            self
        }
    }
}

impl Real for f32 {
    #[inline(always)]
    fn from_f32(x: f32) -> Self {
        x
    }
    #[inline(always)]
    fn value(self) -> f32 {
        self
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f32::sqrt(self)
    }
    #[inline(always)]
    fn powf(self, e: f32) -> Self {
        f32::powf(self, e)
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        f32::max(self, o)
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        f32::min(self, o)
    }
}

/// A 3-vector of [`Real`]s: a point, a direction or an RGB colour.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct V3<R> {
    pub x: R,
    pub y: R,
    pub z: R,
}

impl<R: Real> V3<R> {
    #[inline(always)]
    pub fn new(x: R, y: R, z: R) -> Self {
        Self { x, y, z }
    }
    /// All three components `v`.
    #[inline(always)]
    pub fn splat(v: R) -> Self {
        Self::new(v, v, v)
    }
    #[inline(always)]
    pub fn zero() -> Self {
        Self::splat(R::zero())
    }
    /// A constant vector (no derivatives).
    #[inline(always)]
    pub fn from_vec3(v: Vec3) -> Self {
        Self::new(R::from_f32(v.x), R::from_f32(v.y), R::from_f32(v.z))
    }
    /// The values, without derivatives.
    #[inline(always)]
    pub fn value(self) -> Vec3 {
        Vec3::new(self.x.value(), self.y.value(), self.z.value())
    }
    #[inline(always)]
    pub fn dot(self, o: Self) -> R {
        self.x * o.x + self.y * o.y + self.z * o.z
    }
    #[inline(always)]
    pub fn cross(self, o: Self) -> Self {
        Self::new(
            self.y * o.z - o.y * self.z,
            self.z * o.x - o.z * self.x,
            self.x * o.y - o.x * self.y,
        )
    }
    #[inline(always)]
    pub fn length_squared(self) -> R {
        self.dot(self)
    }
    #[inline(always)]
    pub fn length(self) -> R {
        self.dot(self).sqrt()
    }
    /// The unit vector along `self` (glam's formula: v · (1/|v|)).
    #[inline(always)]
    pub fn normalize(self) -> Self {
        self * (R::one() / self.length())
    }
    /// Component-wise product (colours).
    #[inline(always)]
    pub fn mul_elem(self, o: Self) -> Self {
        Self::new(self.x * o.x, self.y * o.y, self.z * o.z)
    }
}

impl From<Vec3> for V3<f32> {
    #[inline(always)]
    fn from(v: Vec3) -> Self {
        Self::new(v.x, v.y, v.z)
    }
}

impl From<V3<f32>> for Vec3 {
    #[inline(always)]
    fn from(v: V3<f32>) -> Self {
        Vec3::new(v.x, v.y, v.z)
    }
}

impl<R: Real> Add for V3<R> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Self::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}

impl<R: Real> AddAssign for V3<R> {
    #[inline(always)]
    fn add_assign(&mut self, o: Self) {
        *self = *self + o;
    }
}

impl<R: Real> Sub for V3<R> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Self::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}

impl<R: Real> Neg for V3<R> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Self::new(-self.x, -self.y, -self.z)
    }
}

/// Vector × scalar.
impl<R: Real> Mul<R> for V3<R> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, s: R) -> Self {
        Self::new(self.x * s, self.y * s, self.z * s)
    }
}

/// Vector × vector, component-wise (colours).
impl<R: Real> Mul for V3<R> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        self.mul_elem(o)
    }
}

impl<R: Real> Div<R> for V3<R> {
    type Output = Self;
    #[inline(always)]
    fn div(self, s: R) -> Self {
        Self::new(self.x / s, self.y / s, self.z / s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `V3<f32>` must do glam's arithmetic bit for bit, or renders through
    /// the generic kernels would differ from the f32 ones they replaced.
    #[test]
    fn v3_f32_matches_glam_bit_for_bit() {
        let mut rng = crate::math::SplitMix64(11);
        for _ in 0..10_000 {
            let mut v = || {
                Vec3::new(
                    rng.range(-3.0, 3.0),
                    rng.range(-3.0, 3.0),
                    rng.range(-3.0, 3.0),
                )
            };
            let (a, b) = (v(), v());
            let (ga, gb) = (V3::from(a), V3::from(b));
            assert_eq!(ga.dot(gb).to_bits(), a.dot(b).to_bits());
            assert_eq!(Vec3::from(ga.cross(gb)), a.cross(b));
            assert_eq!(ga.length().to_bits(), a.length().to_bits());
            assert_eq!(Vec3::from(ga.normalize()), a.normalize());
            assert_eq!(Vec3::from(ga * gb), a * b);
            assert_eq!(Vec3::from(ga * 0.3), a * 0.3);
            assert_eq!(Vec3::from(ga / 0.7), a / 0.7);
        }
    }
}
