//! Accelerators: given the scene's bounded primitives, find the closest hit
//! along a ray (`intersect`) or whether anything blocks a segment
//! (`occluded`, any-hit, used by shadow rays). All accelerators share one
//! trait so a scene can switch by name; the [`Accelerator`] enum dispatches
//! once per ray, never per primitive test.

pub mod brute;
pub mod bvh;

pub use brute::Brute;
pub use bvh::{Bvh, BvhConfig, BvhStats};

use bvh::{Aabb, BoundingEllipsoid, BoundingSphere, VolumeKind};

use crate::shape::{PreparedRay, PrimHit, Primitive};
use crate::stats::Stats;
use std::fmt;
use std::str::FromStr;

/// The query interface every accelerator implements. `prims` is the scene's
/// full primitive list; an accelerator only ever looks at the bounded ones
/// it was built over.
pub trait Accel: Send + Sync {
    /// Closest hit with t in (0, t_max): (primitive index, hit).
    fn intersect<S: Stats>(
        &self,
        prims: &[Primitive],
        ray: &PreparedRay,
        t_max: f32,
        stats: &mut S,
    ) -> Option<(u32, PrimHit)>;

    /// Whether any primitive is hit with t in (0, t_max). May stop at the
    /// first hit found.
    fn occluded<S: Stats>(
        &self,
        prims: &[Primitive],
        ray: &PreparedRay,
        t_max: f32,
        stats: &mut S,
    ) -> bool;
}

/// Accelerators selectable by name (`--accel`, `accel = "…"` in a scene).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum AccelKind {
    /// Test every primitive.
    #[default]
    Brute,
    /// A bounding volume hierarchy (`bvh`, `bvh:<volume>:<builder>`, …).
    Bvh(BvhConfig),
}

impl FromStr for AccelKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "brute" => Ok(AccelKind::Brute),
            _ if s == "bvh" || s.starts_with("bvh:") => s.parse().map(AccelKind::Bvh),
            _ => Err(format!(
                "unknown accelerator `{s}` (expected `brute` or {})",
                bvh::BVH_GRAMMAR
            )),
        }
    }
}

impl fmt::Display for AccelKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AccelKind::Brute => write!(f, "brute"),
            AccelKind::Bvh(c) => write!(f, "{c}"),
        }
    }
}

/// A built accelerator of any kind.
#[derive(Clone, Debug)]
pub enum Accelerator {
    Brute(Brute),
    /// A BVH of axis-aligned boxes.
    BvhAabb(Bvh<Aabb>, BvhConfig),
    /// A BVH of spheres (either fit).
    BvhSphere(Bvh<BoundingSphere>, BvhConfig),
    /// A BVH of axis-aligned ellipsoids (either fit).
    BvhEllipsoid(Bvh<BoundingEllipsoid>, BvhConfig),
}

impl Accelerator {
    /// Build an accelerator of `kind` over the primitives `bounded` (indices
    /// into `prims`).
    pub fn build(kind: AccelKind, prims: &[Primitive], bounded: Vec<u32>) -> Self {
        match kind {
            AccelKind::Brute => Accelerator::Brute(Brute::new(bounded)),
            AccelKind::Bvh(c) => {
                let o = c.options();
                match c.volume {
                    VolumeKind::Aabb => Accelerator::BvhAabb(Bvh::build(prims, bounded, o), c),
                    VolumeKind::Sphere | VolumeKind::SphereRitter => {
                        Accelerator::BvhSphere(Bvh::build(prims, bounded, o), c)
                    }
                    VolumeKind::Ellipsoid | VolumeKind::EllipsoidRitter => {
                        Accelerator::BvhEllipsoid(Bvh::build(prims, bounded, o), c)
                    }
                }
            }
        }
    }

    /// Shape and cost figures of a BVH; `None` for other accelerators.
    pub fn bvh_stats(&self, prims: &[Primitive]) -> Option<BvhStats> {
        match self {
            Accelerator::Brute(_) => None,
            Accelerator::BvhAabb(b, _) => Some(b.stats(prims)),
            Accelerator::BvhSphere(b, _) => Some(b.stats(prims)),
            Accelerator::BvhEllipsoid(b, _) => Some(b.stats(prims)),
        }
    }

    pub fn kind(&self) -> AccelKind {
        match self {
            Accelerator::Brute(_) => AccelKind::Brute,
            Accelerator::BvhAabb(_, c)
            | Accelerator::BvhSphere(_, c)
            | Accelerator::BvhEllipsoid(_, c) => AccelKind::Bvh(*c),
        }
    }
}

impl Accel for Accelerator {
    #[inline]
    fn intersect<S: Stats>(
        &self,
        prims: &[Primitive],
        ray: &PreparedRay,
        t_max: f32,
        stats: &mut S,
    ) -> Option<(u32, PrimHit)> {
        match self {
            Accelerator::Brute(a) => a.intersect(prims, ray, t_max, stats),
            Accelerator::BvhAabb(a, _) => a.intersect(prims, ray, t_max, stats),
            Accelerator::BvhSphere(a, _) => a.intersect(prims, ray, t_max, stats),
            Accelerator::BvhEllipsoid(a, _) => a.intersect(prims, ray, t_max, stats),
        }
    }

    #[inline]
    fn occluded<S: Stats>(
        &self,
        prims: &[Primitive],
        ray: &PreparedRay,
        t_max: f32,
        stats: &mut S,
    ) -> bool {
        match self {
            Accelerator::Brute(a) => a.occluded(prims, ray, t_max, stats),
            Accelerator::BvhAabb(a, _) => a.occluded(prims, ray, t_max, stats),
            Accelerator::BvhSphere(a, _) => a.occluded(prims, ray, t_max, stats),
            Accelerator::BvhEllipsoid(a, _) => a.occluded(prims, ray, t_max, stats),
        }
    }
}

