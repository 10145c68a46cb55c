//! Sphere (S2: (x−a)²+(y−b)²+(z−c)² = r²).

use super::{Aabb, PrimHit};
use crate::math::{Ray, Vec3};

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Sphere {
    pub centre: Vec3,
    pub radius: f32,
}

impl Sphere {
    pub fn new(centre: Vec3, radius: f32) -> Self {
        Self { centre, radius }
    }

    // ANCHOR: sphere_roots
    /// The roots of `|o + t·d − c|² = r²`, smaller first, or `None` when the
    /// line misses. S2 writes At²+Bt+C = 0 with A = d·d, B = 2d·(o−c),
    /// C = |o−c|² − r². The textbook formula loses precision when the sphere
    /// is small and far away (B² ≈ 4AC); we use the stable form of Haines et
    /// al., "Precision Improvements for Ray/Sphere Intersection" (Ray Tracing
    /// Gems, ch. 7): the discriminant from the distance of the centre to the
    /// line, and the second root from Vieta's formula.
    #[inline]
    pub fn roots(centre: Vec3, radius: f32, ray: &Ray) -> Option<(f32, f32)> {
        let f = ray.origin - centre;
        let a = ray.dir.dot(ray.dir);
        let b = -f.dot(ray.dir); // −B/2
        let c = f.dot(f) - radius * radius;
        let l = f + (b / a) * ray.dir; // centre → closest point of the line
        let disc = radius * radius - l.dot(l); // (B²/4 − AC)/A
        if disc < 0.0 {
            return None;
        }
        let q = b + b.signum() * (a * disc).sqrt();
        if q == 0.0 {
            // Ray origin at the centre of a zero-radius sphere.
            return Some((0.0, 0.0));
        }
        let (t0, t1) = (c / q, q / a);
        Some(if t0 <= t1 { (t0, t1) } else { (t1, t0) })
    }
    // ANCHOR_END: sphere_roots

    /// Nearest root in (0, t_max): the entry point from outside, the exit
    /// point from inside (as Embree reports).
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_max: f32) -> Option<PrimHit> {
        nearest_root(Self::roots(self.centre, self.radius, ray)?, t_max)
    }

    pub fn normal_at(&self, p: Vec3) -> Vec3 {
        ((p - self.centre) / self.radius).normalize()
    }

    pub fn bounds(&self) -> Aabb {
        let r = Vec3::splat(self.radius.abs());
        Aabb {
            min: self.centre - r,
            max: self.centre + r,
        }
    }
}

/// The smaller root in (0, t_max), else the larger one, else `None`.
#[inline]
pub(crate) fn nearest_root((t0, t1): (f32, f32), t_max: f32) -> Option<PrimHit> {
    let t = if t0 > 0.0 { t0 } else { t1 };
    (t > 0.0 && t < t_max).then_some(PrimHit { t, u: 0.0, v: 0.0 })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hits_from_outside_and_inside() {
        let s = Sphere::new(Vec3::new(0.0, 0.0, -5.0), 1.0);
        let r = Ray::new(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0));
        assert!((s.intersect(&r, f32::INFINITY).unwrap().t - 4.0).abs() < 1e-6);
        let inside = Ray::new(Vec3::new(0.0, 0.0, -5.0), Vec3::new(0.0, 0.0, -2.0));
        // Direction of length 2: the exit at distance 1 is t = 0.5.
        assert!((s.intersect(&inside, f32::INFINITY).unwrap().t - 0.5).abs() < 1e-6);
        assert!(s.intersect(&r, 3.9).is_none());
        let miss = Ray::new(Vec3::ZERO, Vec3::new(0.0, 1.0, 0.0));
        assert!(s.intersect(&miss, f32::INFINITY).is_none());
    }

    #[test]
    fn small_far_sphere_is_precise() {
        // Textbook quadratic loses all digits here (B² ≈ 4AC in f32).
        let s = Sphere::new(Vec3::new(0.0, 0.0, -1.0e4), 0.01);
        let r = Ray::new(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0));
        let t = s.intersect(&r, f32::INFINITY).unwrap().t;
        assert!((t - (1.0e4 - 0.01)).abs() < 1e-3, "{t}");
    }
}
