//! Shapes: sphere, ellipsoid, infinite plane and triangle (meshes are lists
//! of triangles). Each shape answers a ray query with the parameter `t` of
//! its nearest hit in an open interval, plus the barycentric or surface
//! coordinates needed to shade it; the full [`Hit`] (point, normals) is built
//! only for the closest hit, after the accelerator has found it.

pub mod ellipsoid;
pub mod plane;
pub mod sphere;
pub mod triangle;

pub use ellipsoid::Ellipsoid;
pub use plane::Plane;
pub use sphere::Sphere;
pub use triangle::Triangle;

use crate::math::{Ray, Vec3};
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
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        // Swap to keep the winding (and so the sign of the edge functions)
        // independent of the direction's sign along kz.
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let shear = Vec3::new(d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]);
        Self {
            ray,
            inv_dir: d.recip(),
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

/// Axis-aligned bounds of a primitive, or `None` for unbounded shapes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    pub min: Vec3,
    pub max: Vec3,
}

impl Bounds {
    pub const EMPTY: Bounds = Bounds {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    pub fn union(self, o: Bounds) -> Bounds {
        Bounds {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    pub fn include(self, p: Vec3) -> Bounds {
        Bounds {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    pub fn centre(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }

    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }
}

/// Bounds of every bounded primitive of a list (planes left out).
pub fn bounds_of(prims: &[Primitive]) -> Bounds {
    prims
        .iter()
        .filter_map(Primitive::bounds)
        .fold(Bounds::EMPTY, Bounds::union)
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
            Shape::Sphere(s) => {
                stats.sphere_test();
                s.intersect(&r.ray, t_max)
            }
            Shape::Ellipsoid(e) => {
                stats.ellipsoid_test();
                e.intersect(&r.ray, t_max)
            }
            Shape::Plane(p) => {
                stats.plane_test();
                p.intersect(&r.ray, t_max)
            }
            Shape::Triangle(t) => {
                stats.triangle_test();
                t.intersect(r, t_max)
            }
        }
    }

    /// Axis-aligned bounds; `None` for an infinite plane.
    pub fn bounds(&self) -> Option<Bounds> {
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
