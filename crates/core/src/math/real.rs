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

// ANCHOR: real_trait
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
    /// `self` raised to the power `e`, both variable (a Phong exponent that
    /// is itself a parameter). For `self` ≤ 0 only the base's derivative is
    /// kept (ln of a non-positive number has none).
    fn pow(self, e: Self) -> Self;
    fn sin(self) -> Self;
    fn cos(self) -> Self;
    fn tan(self) -> Self;
    // ANCHOR_END: real_trait

    #[inline(always)]
    fn zero() -> Self {
        Self::from_f32(0.0)
    }
    #[inline(always)]
    fn one() -> Self {
        Self::from_f32(1.0)
    }
    /// |self|, deciding the sign by value.
    #[inline(always)]
    fn abs(self) -> Self {
        if self.value() < 0.0 {
            -self
        } else {
            self
        }
    }
    /// The value without its derivatives (a discrete choice's probability,
    /// which the derivative of an estimator must not differentiate).
    #[inline(always)]
    fn detach(self) -> Self {
        Self::from_f32(self.value())
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
    fn pow(self, e: Self) -> Self {
        f32::powf(self, e)
    }
    #[inline(always)]
    fn sin(self) -> Self {
        f32::sin(self)
    }
    #[inline(always)]
    fn cos(self) -> Self {
        f32::cos(self)
    }
    #[inline(always)]
    fn tan(self) -> Self {
        f32::tan(self)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f32::abs(self)
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
    /// [`V3::normalize`], or zero where the length's reciprocal is not a
    /// positive finite number (glam's `normalize_or_zero`).
    #[inline(always)]
    pub fn normalize_or_zero(self) -> Self {
        let rcp = R::one() / self.length();
        if rcp.value().is_finite() && rcp.value() > 0.0 {
            self * rcp
        } else {
            Self::zero()
        }
    }
    /// Component-wise product (colours).
    #[inline(always)]
    pub fn mul_elem(self, o: Self) -> Self {
        Self::new(self.x * o.x, self.y * o.y, self.z * o.z)
    }
    /// Component `i` (0 = x).
    #[inline(always)]
    pub fn get(self, i: usize) -> R {
        [self.x, self.y, self.z][i]
    }
    /// Each component clamped to [lo, hi] by value (glam's `clamp`:
    /// max, then min).
    #[inline(always)]
    pub fn clamp(self, lo: f32, hi: f32) -> Self {
        let c = |v: R| v.max(R::from_f32(lo)).min(R::from_f32(hi));
        Self::new(c(self.x), c(self.y), c(self.z))
    }
}

/// A ray whose origin and direction are [`Real`]s: the camera ray and the
/// rays spawned at hits, as functions of the scene's parameters.
/// Traversal only ever sees [`RayR::value`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayR<R> {
    pub origin: V3<R>,
    pub dir: V3<R>,
}

impl<R: Real> RayR<R> {
    #[inline(always)]
    pub fn new(origin: V3<R>, dir: V3<R>) -> Self {
        Self { origin, dir }
    }
    /// The `f32` ray that traversal tests.
    #[inline(always)]
    pub fn value(&self) -> super::Ray {
        super::Ray::new(self.origin.value(), self.dir.value())
    }
    /// The point at parameter `t`.
    #[inline(always)]
    pub fn at(&self, t: R) -> V3<R> {
        self.origin + self.dir * t
    }
}

impl From<super::Ray> for RayR<f32> {
    #[inline(always)]
    fn from(r: super::Ray) -> Self {
        Self::new(r.origin.into(), r.dir.into())
    }
}

/// A 3×3 matrix of [`Real`]s, stored by rows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct M3<R> {
    pub rows: [V3<R>; 3],
}

impl<R: Real> M3<R> {
    #[inline(always)]
    pub fn from_rows(r0: V3<R>, r1: V3<R>, r2: V3<R>) -> Self {
        Self { rows: [r0, r1, r2] }
    }
    /// diag(d).
    pub fn diagonal(d: V3<R>) -> Self {
        let z = R::zero();
        Self::from_rows(V3::new(d.x, z, z), V3::new(z, d.y, z), V3::new(z, z, d.z))
    }
    pub fn transpose(&self) -> Self {
        let [a, b, c] = self.rows;
        Self::from_rows(
            V3::new(a.x, b.x, c.x),
            V3::new(a.y, b.y, c.y),
            V3::new(a.z, b.z, c.z),
        )
    }
    /// M·v.
    #[inline(always)]
    pub fn mul_vec(&self, v: V3<R>) -> V3<R> {
        V3::new(
            self.rows[0].dot(v),
            self.rows[1].dot(v),
            self.rows[2].dot(v),
        )
    }
    /// M⁻¹ by the adjugate (rows of the inverse are the cross products of
    /// the columns' pairs over det M); `None` when M is singular by value.
    pub fn inverse(&self) -> Option<Self> {
        let c = self.transpose().rows;
        let (r0, r1, r2) = (c[1].cross(c[2]), c[2].cross(c[0]), c[0].cross(c[1]));
        let det = c[0].dot(r0);
        if det.value() == 0.0 || !det.value().is_finite() {
            return None;
        }
        let inv = R::one() / det;
        Some(Self::from_rows(r0 * inv, r1 * inv, r2 * inv))
    }
    /// M·N.
    pub fn mul_mat(&self, o: &Self) -> Self {
        let t = o.transpose();
        let row = |r: V3<R>| V3::new(r.dot(t.rows[0]), r.dot(t.rows[1]), r.dot(t.rows[2]));
        Self::from_rows(row(self.rows[0]), row(self.rows[1]), row(self.rows[2]))
    }
    /// Rotation from Euler angles in degrees, about x, then y, then z
    /// (R = Rz·Ry·Rx): the convention of the scene files.
    pub fn rotation_xyz_degrees(deg: V3<R>) -> Self {
        let rad = R::from_f32(std::f32::consts::PI / 180.0);
        let (z, o) = (R::zero(), R::one());
        let (sx, cx) = ((deg.x * rad).sin(), (deg.x * rad).cos());
        let (sy, cy) = ((deg.y * rad).sin(), (deg.y * rad).cos());
        let (sz, cz) = ((deg.z * rad).sin(), (deg.z * rad).cos());
        let rx = Self::from_rows(V3::new(o, z, z), V3::new(z, cx, -sx), V3::new(z, sx, cx));
        let ry = Self::from_rows(V3::new(cy, z, sy), V3::new(z, o, z), V3::new(-sy, z, cy));
        let rz = Self::from_rows(V3::new(cz, -sz, z), V3::new(sz, cz, z), V3::new(z, z, o));
        rz.mul_mat(&ry).mul_mat(&rx)
    }
    /// A constant matrix (no derivatives).
    #[inline]
    pub fn from_mat3(m: glam::Mat3) -> Self {
        Self::from_rows(
            V3::from_vec3(m.row(0)),
            V3::from_vec3(m.row(1)),
            V3::from_vec3(m.row(2)),
        )
    }
}

impl M3<f32> {
    /// The same matrix as glam's (column-major) type.
    #[inline]
    pub fn to_mat3(&self) -> glam::Mat3 {
        glam::Mat3::from_cols(
            self.rows[0].into(),
            self.rows[1].into(),
            self.rows[2].into(),
        )
        .transpose()
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
