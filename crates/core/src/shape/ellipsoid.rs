//! Ellipsoid: centre, three radii and a rotation. Intersected by mapping the
//! ray into the frame where the ellipsoid is the unit sphere,
//! x' = S⁻¹Rᵀ(x − c); the ray parameter `t` is unchanged by an affine map,
//! and the world normal is the inverse transpose applied to the local one:
//! n = (S⁻¹Rᵀ)ᵀ n' = R S⁻¹ n'.

use super::sphere::{nearest_root, Sphere};
use super::{Aabb, PrimHit};
use crate::math::{Mat3, Ray, Real, Vec3, M3, V3};

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Ellipsoid {
    pub centre: Vec3,
    /// S⁻¹Rᵀ: world offsets to unit-sphere coordinates. The rotation and
    /// radii are not stored separately: primitives are kept small (the
    /// `Shape` enum is as large as its largest variant, and brute force
    /// streams through all of them).
    to_unit: Mat3,
}

/// The map from world offsets to the unit sphere's coordinates of an
/// ellipsoid of radii `radii` turned by `rotation`, S⁻¹Rᵀ, over [`Real`]
/// (the one formula: the `f32` ellipsoid and the derivative code's).
#[inline]
pub fn to_unit<R: Real>(radii: V3<R>, rotation: &M3<R>) -> M3<R> {
    let one = R::one();
    let inv = V3::new(one / radii.x, one / radii.y, one / radii.z);
    M3::diagonal(inv).mul_mat(&rotation.transpose())
}

impl Ellipsoid {
    /// `rotation` must be orthonormal; radii must be positive.
    pub fn new(centre: Vec3, radii: Vec3, rotation: Mat3) -> Self {
        let m = to_unit(V3::<f32>::from(radii), &M3::from_mat3(rotation));
        Self::from_to_unit(centre, m.to_mat3())
    }

    /// The ellipsoid of centre `centre` whose map to the unit sphere is
    /// `to_unit` ([`to_unit`]).
    pub fn from_to_unit(centre: Vec3, to_unit: Mat3) -> Self {
        Self { centre, to_unit }
    }

    /// The affine map unit sphere → world: x = R·S·x' + c.
    pub fn from_unit(&self) -> Mat3 {
        self.to_unit.inverse()
    }

    /// The linear map world offsets → unit-sphere coordinates, S⁻¹Rᵀ.
    pub fn to_unit(&self) -> Mat3 {
        self.to_unit
    }

    #[inline]
    pub fn intersect(&self, ray: &Ray, t_max: f32) -> Option<PrimHit> {
        let local = Ray::new(
            self.to_unit * (ray.origin - self.centre),
            self.to_unit * ray.dir,
        );
        nearest_root(Sphere::roots(Vec3::ZERO, 1.0, &local)?, t_max)
    }

    pub fn normal_at(&self, p: Vec3) -> Vec3 {
        let local = self.to_unit * (p - self.centre);
        (self.to_unit.transpose() * local).normalize()
    }

    /// Tight axis-aligned bounds: along world axis i the half-extent is
    /// |row i of R·S|, the support of the transformed unit sphere.
    pub fn bounds(&self) -> Aabb {
        let m = self.from_unit();
        let half = Vec3::new(m.row(0).length(), m.row(1).length(), m.row(2).length());
        Aabb {
            min: self.centre - half,
            max: self.centre + half,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::rotation_xyz_degrees;

    #[test]
    fn axis_aligned_hit_and_normal() {
        let e = Ellipsoid::new(Vec3::ZERO, Vec3::new(2.0, 1.0, 0.5), Mat3::IDENTITY);
        let r = Ray::new(Vec3::new(-10.0, 0.0, 0.0), Vec3::X);
        let h = e.intersect(&r, f32::INFINITY).unwrap();
        assert!((h.t - 8.0).abs() < 1e-5);
        assert!((e.normal_at(r.at(h.t)) - -Vec3::X).length() < 1e-5);
        // Normal at a general point: gradient of x²/a²+y²/b²+z²/c².
        let p = Vec3::new(2.0 * 0.6, 0.8, 0.0);
        let g = Vec3::new(p.x / 4.0, p.y, p.z / 0.25).normalize();
        assert!((e.normal_at(p) - g).length() < 1e-5);
    }

    #[test]
    fn primitives_stay_small() {
        // Brute force streams through every primitive: keep them compact.
        assert!(std::mem::size_of::<crate::shape::Primitive>() <= 56);
    }

    #[test]
    fn rotated_bounds_contain_surface_points() {
        let e = Ellipsoid::new(
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::new(2.0, 1.0, 0.5),
            rotation_xyz_degrees(Vec3::new(30.0, 45.0, 10.0)),
        );
        let b = e.bounds();
        for i in 0..200 {
            let th = i as f32 * 0.37;
            let ph = i as f32 * 0.91;
            let u = Vec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos());
            let p = e.from_unit() * u + e.centre;
            assert!(p.cmpge(b.min - 1e-5).all() && p.cmple(b.max + 1e-5).all());
        }
    }
}
