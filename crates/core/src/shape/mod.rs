//! Shapes: sphere, ellipsoid, infinite plane and triangle (meshes are lists
//! of triangles). Each shape answers a ray query with the parameter `t` of
//! its nearest hit in an open interval, plus the barycentric or surface
//! coordinates needed to shade it; the full [`Hit`] (point, normals) is built
//! only for the closest hit, after the accelerator has found it.

pub mod arrays;
pub mod ellipsoid;
pub mod mesh;
pub mod plane;
pub mod smooth;
pub mod sphere;
pub mod triangle;

pub use arrays::{PrimArrays, PrimKind, PrimRef, Slot};
pub use ellipsoid::Ellipsoid;
pub use mesh::MeshData;
pub use plane::Plane;
pub use smooth::{HitR, ShapeR};
pub use sphere::Sphere;
pub use triangle::Triangle;

use crate::math::{Aabb, Ray, Vec3};
use crate::stats::Stats;

/// A ray with the per-ray constants that primitive tests reuse: the
/// reciprocal direction (slab tests) and the shear of the watertight
/// triangle test (Woop, Benthin & Wald 2013, §3: the dominant axis `kz`,
/// the other two `kx`, `ky`, and the shear `s`).
#[derive(Clone, Copy, Debug)]
pub struct PreparedRay {
    pub ray: Ray,
    pub inv_dir: Vec3,
    pub kx: usize,
    pub ky: usize,
    pub kz: usize,
    /// (Sx, Sy, Sz) = (dx/dz, dy/dz, 1/dz) in the permuted axes.
    pub shear: Vec3,
}

impl PreparedRay {
    pub fn new(ray: Ray) -> Self {
        let d = ray.dir;
        let a = d.abs();
        // The axes are chosen by selects, not branches: over a path's
        // bounce rays the dominant axis and its sign are random, and the
        // branches would be mispredicted about half the time.
        let x_dominant = (a.x >= a.y) & (a.x >= a.z);
        let kz = if x_dominant {
            0
        } else {
            2 - usize::from(a.y >= a.z)
        };
        let c = d.to_array();
        // (kz + 1) % 3 and (kz + 2) % 3; swapped to keep the winding (and
        // so the sign of the edge functions) independent of the
        // direction's sign along kz.
        let (next, after) = ([1, 2, 0][kz], [2, 0, 1][kz]);
        let negative = c[kz] < 0.0;
        let kx = if negative { after } else { next };
        let ky = if negative { next } else { after };
        // Two 4-lane divisions in place of six scalar ones: each lane is
        // the same correctly rounded quotient, so the bits do not change.
        let shear = (glam::Vec4::new(c[kx], c[ky], 1.0, 1.0) / c[kz]).truncate();
        let inv_dir = glam::Vec4::new(d.x, d.y, d.z, 1.0).recip().truncate();
        Self {
            ray,
            inv_dir,
            kx,
            ky,
            kz,
            shear,
        }
    }
}

/// What a primitive test reports: the ray parameter and two surface
/// coordinates (barycentrics `u`, `v` of vertices 1 and 2 for triangles;
/// unused for the quadrics and the plane).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrimHit {
    pub t: f32,
    pub u: f32,
    pub v: f32,
}

/// A fully described hit, built for the closest intersection only.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub t: f32,
    pub point: Vec3,
    /// Unit geometric normal, on the side the ray came from.
    pub geometric_normal: Vec3,
    /// Unit shading normal (interpolated for smooth meshes), on the same
    /// side as `geometric_normal`.
    pub shading_normal: Vec3,
    /// Index of the primitive in the scene's primitive list.
    pub prim: u32,
    /// Index of the scene object the primitive belongs to.
    pub object: u32,
    /// Whether the ray hit the outside (the side the outward normal faces).
    pub front_face: bool,
}

/// Relative size of the self-intersection offset of rays leaving a hit:
/// they start at the hit point moved along the geometric normal, to the
/// side the new ray leaves on, by ε = 1e-4 · max(1, max|p_i|). The hit
/// point o + t·d carries a rounding error of a few ulps of its largest
/// coordinate (≈ 1e-7 relative in f32); 1e-4 relative is three orders of
/// magnitude above that, yet far below the size of any feature in our
/// scenes (meshes are fitted to about unit size, whose triangles are
/// ≥ 1e-3 across). Shadow rays stop the same ε short of their target.
pub const OFFSET_SCALE: f32 = 1e-4;

impl Hit {
    /// A surface point with one normal for both roles (no ray, primitive
    /// or object): the flood-fill cache's wall faces, lit like a hit.
    pub fn at_surface(point: Vec3, normal: Vec3) -> Hit {
        Hit {
            t: 0.0,
            point,
            geometric_normal: normal,
            shading_normal: normal,
            prim: u32::MAX,
            object: u32::MAX,
            front_face: true,
        }
    }

    /// The hit of primitive `prim` (of scene object `object`) at distance
    /// `t` along `ray`, whose outward and shading normals there are
    /// `outward` and `shading`: both normals turned to the side the ray
    /// came from.
    #[inline(always)]
    pub fn oriented(
        ray: &Ray,
        t: f32,
        outward: Vec3,
        shading: Vec3,
        prim: u32,
        object: u32,
    ) -> Hit {
        let front_face = outward.dot(ray.dir) < 0.0;
        let sign = if front_face { 1.0 } else { -1.0 };
        Hit {
            t,
            point: ray.at(t),
            geometric_normal: sign * outward,
            shading_normal: sign * shading,
            prim,
            object,
            front_face,
        }
    }

    /// The origin of a ray leaving the hit in direction `dir`: the point
    /// offset by [`OFFSET_SCALE`] to the side `dir` points to.
    #[inline]
    pub fn spawn_origin(&self, dir: Vec3) -> Vec3 {
        HitR::from(*self).spawn_origin(dir.into()).into()
    }

    /// The shadow segment from the hit towards `target` (`dir` is the unit
    /// direction to it, which picks the side to start on): a ray with a
    /// unit direction from the offset origin, and the distance at which it
    /// stops, ε short of the target. Every shadow ray is built here or,
    /// from an origin already offset, by [`segment_to`].
    #[inline]
    pub fn shadow_segment(&self, dir: Vec3, target: Vec3) -> (Ray, f32) {
        segment_to(self.spawn_origin(dir), target)
    }
}

/// The shadow segment from `origin` (already offset from its surface) to
/// `target`: a ray with a unit direction, and the distance at which it
/// stops, ε short of the target ([`Hit::shadow_segment`]).
#[inline(always)]
pub fn segment_to(origin: Vec3, target: Vec3) -> (Ray, f32) {
    let to_target = target - origin;
    let len = to_target.length();
    (
        Ray::new(origin, to_target / len),
        len * (1.0 - OFFSET_SCALE),
    )
}

/// A shape's ray test as the accelerators run it: the nearest hit in
/// (0, `t_max`), counted as one test of the shape's kind.
pub trait Intersect {
    fn test<S: Stats>(&self, r: &PreparedRay, t_max: f32, stats: &mut S) -> Option<PrimHit>;
}

impl Intersect for Sphere {
    #[inline(always)]
    fn test<S: Stats>(&self, r: &PreparedRay, t_max: f32, stats: &mut S) -> Option<PrimHit> {
        stats.sphere_test();
        self.intersect(&r.ray, t_max)
    }
}

impl Intersect for Ellipsoid {
    #[inline(always)]
    fn test<S: Stats>(&self, r: &PreparedRay, t_max: f32, stats: &mut S) -> Option<PrimHit> {
        stats.ellipsoid_test();
        self.intersect(&r.ray, t_max)
    }
}

impl Intersect for Plane {
    #[inline(always)]
    fn test<S: Stats>(&self, r: &PreparedRay, t_max: f32, stats: &mut S) -> Option<PrimHit> {
        stats.plane_test();
        self.intersect(&r.ray, t_max)
    }
}

impl Intersect for Triangle {
    #[inline(always)]
    fn test<S: Stats>(&self, r: &PreparedRay, t_max: f32, stats: &mut S) -> Option<PrimHit> {
        stats.triangle_test();
        self.intersect(r, t_max)
    }
}

impl Intersect for Primitive {
    #[inline(always)]
    fn test<S: Stats>(&self, r: &PreparedRay, t_max: f32, stats: &mut S) -> Option<PrimHit> {
        self.intersect(r, t_max, stats)
    }
}

impl<T: Intersect> Intersect for &T {
    #[inline(always)]
    fn test<S: Stats>(&self, r: &PreparedRay, t_max: f32, stats: &mut S) -> Option<PrimHit> {
        (**self).test(r, t_max, stats)
    }
}

/// The geometry of one primitive. An enum rather than a trait object: the
/// accelerators match on it per test, with no dynamic dispatch.
#[derive(Clone, Copy, Debug)]
pub enum Shape {
    Sphere(Sphere),
    Ellipsoid(Ellipsoid),
    Plane(Plane),
    /// A triangle with the index of its face in the owning mesh's shading
    /// data (for smooth normals).
    Triangle(Triangle),
}

/// A primitive: its geometry and the scene object it belongs to.
#[derive(Clone, Copy, Debug)]
pub struct Primitive {
    pub shape: Shape,
    pub object: u32,
}

/// Aabb of every bounded primitive of a list (planes left out).
pub fn bounds_of(prims: &[Primitive]) -> Aabb {
    prims
        .iter()
        .filter_map(Primitive::bounds)
        .fold(Aabb::EMPTY, Aabb::union)
}

/// Number of triangles in a list of primitives.
pub fn triangle_count(prims: &[Primitive]) -> usize {
    prims
        .iter()
        .filter(|p| matches!(p.shape, Shape::Triangle(_)))
        .count()
}

impl Primitive {
    /// Nearest hit with `t` in the open interval (0, `t_max`).
    #[inline]
    pub fn intersect<S: Stats>(
        &self,
        r: &PreparedRay,
        t_max: f32,
        stats: &mut S,
    ) -> Option<PrimHit> {
        match &self.shape {
            Shape::Sphere(s) => s.test(r, t_max, stats),
            Shape::Ellipsoid(e) => e.test(r, t_max, stats),
            Shape::Plane(p) => p.test(r, t_max, stats),
            Shape::Triangle(t) => t.test(r, t_max, stats),
        }
    }

    /// Axis-aligned bounds; `None` for an infinite plane.
    pub fn bounds(&self) -> Option<Aabb> {
        match &self.shape {
            Shape::Sphere(s) => Some(s.bounds()),
            Shape::Ellipsoid(e) => Some(e.bounds()),
            Shape::Plane(_) => None,
            Shape::Triangle(t) => Some(t.bounds()),
        }
    }

    /// Unit outward geometric normal at a hit (before facing the ray).
    pub fn outward_normal(&self, ray: &Ray, h: &PrimHit) -> Vec3 {
        match &self.shape {
            Shape::Sphere(s) => s.normal_at(ray.at(h.t)),
            Shape::Ellipsoid(e) => e.normal_at(ray.at(h.t)),
            Shape::Plane(p) => p.normal,
            Shape::Triangle(t) => t.normal(),
        }
    }
}
