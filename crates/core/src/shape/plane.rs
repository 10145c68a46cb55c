//! Infinite plane n·(x − p) = 0. Unbounded, so accelerators keep it out of
//! their hierarchies and the scene tests it separately.

use super::PrimHit;
use crate::math::{Ray, Vec3};

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Plane {
    pub point: Vec3,
    /// Unit normal; the "front" side.
    pub normal: Vec3,
}

impl Plane {
    pub fn new(point: Vec3, normal: Vec3) -> Self {
        Self {
            point,
            normal: normal.normalize(),
        }
    }

    /// t = n·(p − o) / n·d; a ray parallel to the plane misses.
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_max: f32) -> Option<PrimHit> {
        let denom = self.normal.dot(ray.dir);
        if denom == 0.0 {
            return None;
        }
        let t = self.normal.dot(self.point - ray.origin) / denom;
        (t > 0.0 && t < t_max).then_some(PrimHit { t, u: 0.0, v: 0.0 })
    }
}
