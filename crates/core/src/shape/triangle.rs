//! Triangles, intersected with the watertight test of Woop, Benthin & Wald,
//! "Watertight Ray/Triangle Intersection" (JCGT 2(1), 2013).
//!
//! Möller–Trumbore computes each edge test from different rounded products,
//! so a ray through a shared edge can miss both triangles (a crack) or hit
//! both. The watertight test shears and translates the vertices into the
//! ray's frame, where the ray is the +z axis from the origin; the edge
//! functions U, V, W are then 2D cross products of the same transformed
//! vertices for both triangles of an edge, so the two triangles see exactly
//! the same value with opposite sign, and an edge hit is never lost. When an
//! edge function rounds to exactly zero, it is recomputed in double precision
//! (the paper's fallback) so the sign decision is exact.

use super::smooth::triangle_normal;
use super::{Aabb, PreparedRay, PrimHit};
use crate::math::{Vec3, V3};

/// Marks a triangle that does not belong to a mesh (no shading normals).
pub const NO_MESH: u32 = u32::MAX;

#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Triangle {
    pub p: [Vec3; 3],
    /// The owning mesh (index into the scene's meshes) or [`NO_MESH`].
    pub mesh: u32,
    /// The face index within the owning mesh.
    pub face: u32,
}

impl Triangle {
    pub fn new(p0: Vec3, p1: Vec3, p2: Vec3) -> Self {
        Self {
            p: [p0, p1, p2],
            mesh: NO_MESH,
            face: 0,
        }
    }

    // ANCHOR: watertight
    /// Hit with `t` in (0, t_max), reporting barycentrics `u`, `v` of
    /// vertices 1 and 2 (the hit point is (1−u−v)·p0 + u·p1 + v·p2, Embree's
    /// convention). Both faces are hit (no culling).
    #[inline(always)]
    pub fn intersect(&self, r: &PreparedRay, t_max: f32) -> Option<PrimHit> {
        let (kx, ky, kz) = (r.kx, r.ky, r.kz);
        let s = r.shear;
        // Vertices relative to the ray origin.
        let a = self.p[0] - r.ray.origin;
        let b = self.p[1] - r.ray.origin;
        let c = self.p[2] - r.ray.origin;
        // Shear so the ray becomes the +z axis (paper, §3, eqs. 3–4).
        let ax = a[kx] - s.x * a[kz];
        let ay = a[ky] - s.y * a[kz];
        let bx = b[kx] - s.x * b[kz];
        let by = b[ky] - s.y * b[kz];
        let cx = c[kx] - s.x * c[kz];
        let cy = c[ky] - s.y * c[kz];
        // Scaled barycentrics: 2D edge functions.
        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        if u == 0.0 || v == 0.0 || w == 0.0 {
            // Exact zero may be a rounding artefact: redo in f64, where the
            // products of f32 values are exact.
            let (ax, ay, bx, by, cx, cy) = (
                ax as f64, ay as f64, bx as f64, by as f64, cx as f64, cy as f64,
            );
            u = (cx * by - cy * bx) as f32;
            v = (ax * cy - ay * cx) as f32;
            w = (bx * ay - by * ax) as f32;
        }
        // The ray passes inside when all three have the same sign (either
        // winding; a zero means "on the edge" and counts as inside).
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 {
            return None; // degenerate, or the ray lies in the triangle's plane
        }
        // Scaled distance; compare against the interval without dividing.
        let az = s.z * a[kz];
        let bz = s.z * b[kz];
        let cz = s.z * c[kz];
        let t_scaled = u * az + v * bz + w * cz;
        Self::finish(v, w, det, t_scaled, t_max)
    }

    /// The last step of [`Triangle::intersect`], shared with the packet
    /// test (`accel::bvh::packet`): the interval check of the scaled
    /// distance against (0, t_max), without dividing, then the division.
    /// `v`, `w` are the edge functions of vertices 1 and 2, `det` their sum
    /// with the first's (not zero).
    #[inline(always)]
    pub fn finish(v: f32, w: f32, det: f32, t_scaled: f32, t_max: f32) -> Option<PrimHit> {
        if det > 0.0 {
            if t_scaled <= 0.0 || t_scaled >= t_max * det {
                return None;
            }
        } else if t_scaled >= 0.0 || t_scaled <= t_max * det {
            return None;
        }
        let inv = 1.0 / det;
        Some(PrimHit {
            t: t_scaled * inv,
            u: v * inv,
            v: w * inv,
        })
    }
    // ANCHOR_END: watertight

    /// Unit geometric normal (p1 − p0) × (p2 − p0): counter-clockwise
    /// vertices face the viewer ([`triangle_normal`]; zero if degenerate).
    #[inline]
    pub fn normal(&self) -> Vec3 {
        triangle_normal(self.p.map(V3::from)).into()
    }

    pub fn bounds(&self) -> Aabb {
        Aabb {
            min: self.p[0].min(self.p[1]).min(self.p[2]),
            max: self.p[0].max(self.p[1]).max(self.p[2]),
        }
    }

    pub fn area(&self) -> f32 {
        0.5 * (self.p[1] - self.p[0])
            .cross(self.p[2] - self.p[0])
            .length()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Ray;

    fn prep(o: Vec3, d: Vec3) -> PreparedRay {
        PreparedRay::new(Ray::new(o, d))
    }

    #[test]
    fn hit_reports_t_and_barycentrics() {
        let tri = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y);
        let r = prep(Vec3::new(0.25, 0.5, 2.0), -Vec3::Z);
        let h = tri.intersect(&r, f32::INFINITY).unwrap();
        assert!((h.t - 2.0).abs() < 1e-6);
        assert!((h.u - 0.25).abs() < 1e-6 && (h.v - 0.5).abs() < 1e-6);
        // Back face is hit too, and t_max is respected.
        let back = prep(Vec3::new(0.25, 0.25, -1.0), Vec3::Z);
        assert!(tri.intersect(&back, f32::INFINITY).is_some());
        assert!(tri.intersect(&r, 1.5).is_none());
    }

    #[test]
    fn shared_edge_is_watertight() {
        // Two triangles sharing the diagonal of a quad, rays aimed exactly at
        // points of the shared edge, from awkward directions: every ray must
        // hit at least one of the two.
        let p = [
            Vec3::new(-1.3, -0.7, 0.1),
            Vec3::new(1.1, -0.9, -0.2),
            Vec3::new(0.9, 1.7, 0.3),
            Vec3::new(-1.2, 1.3, -0.1),
        ];
        let t1 = Triangle::new(p[0], p[1], p[2]);
        let t2 = Triangle::new(p[0], p[2], p[3]);
        let mut misses = 0;
        // Interior points of the edge only: its end points are corners of
        // the quad, where a rounded target may fall outside both.
        for i in 0..2000 {
            let s = (i + 1) as f32 / 2001.0;
            let target = p[0] + s * (p[2] - p[0]);
            let ang = i as f32 * 2.399_963;
            let o = Vec3::new(3.0 * ang.cos(), 3.0 * ang.sin(), 2.0 + (i % 7) as f32);
            let r = prep(o, target - o);
            if t1.intersect(&r, f32::INFINITY).is_none()
                && t2.intersect(&r, f32::INFINITY).is_none()
            {
                misses += 1;
            }
        }
        assert_eq!(misses, 0);
    }
}
