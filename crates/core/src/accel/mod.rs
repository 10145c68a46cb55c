//! Accelerators: given the scene's bounded primitives, find the closest hit
//! along a ray (`intersect`) or whether anything blocks a segment
//! (`occluded`, any-hit, used by shadow rays). All accelerators share one
//! trait so a scene can switch by name; the [`Accelerator`] enum dispatches
//! once per ray, never per primitive test.

pub mod brute;
pub mod bvh;
#[cfg(feature = "embree")]
pub mod embree;
#[cfg(feature = "obvhs")]
pub mod obvhs;

pub use brute::Brute;
pub use bvh::{Bvh, Bvh4, Bvh8, BvhConfig, BvhStats};
#[cfg(feature = "embree")]
pub use embree::{EmbreeAccel, EmbreeConfig};
#[cfg(feature = "obvhs")]
pub use obvhs::ObvhsAccel;

use bvh::{Aabb, BoundingEllipsoid, BoundingSphere, BuildOptions, VolumeKind};

use crate::error::ParseError;
use crate::shape::{PreparedRay, PrimHit, Primitive};
use crate::stats::Stats;
use std::fmt;
use std::str::FromStr;

/// Why an accelerator could not be built over a scene's primitives: only
/// the trees inside other libraries can fail.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum AccelError {
    /// Embree reported an error (no usable device, out of memory).
    #[cfg(feature = "embree")]
    #[error(transparent)]
    Embree(embree::EmbreeError),
    /// obvhs cannot hold the scene (primitives other than triangles).
    #[cfg(feature = "obvhs")]
    #[error(transparent)]
    Obvhs(obvhs::ObvhsError),
}

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
    /// A binary bounding volume hierarchy (`bvh2`, the box tree;
    /// `bvh:<volume>:<builder>[:<leaf size>]`), kept by name for teaching
    /// and for the bounding-volume comparison.
    Bvh(BvhConfig),
    /// The 4-wide box BVH (`bvh4`): the default binary SAH box tree (the
    /// same leaves) collapsed to four children per node, tested 4-wide.
    Bvh4,
    /// The 8-wide box BVH (`bvh8`, and plain `bvh`, which names raylab's
    /// fastest tree, this one): a binary SAH box
    /// tree built for packet leaves ([`bvh::BuildOptions::wide`]) collapsed
    /// to eight children per node, tested with AVX2 where the CPU has it.
    Bvh8,
    /// Embree 4 (`embree`, `embree:low|medium|high`, `…+robust`).
    #[cfg(feature = "embree")]
    Embree(EmbreeConfig),
    /// The obvhs crate's compressed 8-wide BVH (`obvhs`), a peer library
    /// measured beside Embree; triangles only.
    #[cfg(feature = "obvhs")]
    Obvhs,
}

impl FromStr for AccelKind {
    type Err = ParseError;
    fn from_str(s: &str) -> Result<Self, ParseError> {
        match s {
            "brute" => Ok(AccelKind::Brute),
            "bvh4" => Ok(AccelKind::Bvh4),
            "bvh" | "bvh8" => Ok(AccelKind::Bvh8),
            _ if s == "bvh2" || s.starts_with("bvh:") => s.parse().map(AccelKind::Bvh),
            #[cfg(feature = "embree")]
            _ if s.starts_with("embree") => s.parse().map(AccelKind::Embree),
            #[cfg(not(feature = "embree"))]
            _ if s.starts_with("embree") => Err(ParseError::NotBuilt {
                what: "accelerator",
                given: s.to_string(),
                needs: "Embree",
                feature: "embree",
            }),
            #[cfg(feature = "obvhs")]
            "obvhs" => Ok(AccelKind::Obvhs),
            #[cfg(not(feature = "obvhs"))]
            "obvhs" => Err(ParseError::NotBuilt {
                what: "accelerator",
                given: s.to_string(),
                needs: "the obvhs crate",
                feature: "obvhs",
            }),
            _ => Err(ParseError::Unknown {
                what: "accelerator",
                given: s.to_string(),
                expected: format!(
                    "`brute`, `bvh` (the fastest tree, `bvh8`), {}, `bvh4`, `bvh8`, \
                     `embree[:low|medium|high][+robust]` or `obvhs`",
                    bvh::BVH_GRAMMAR
                ),
            }),
        }
    }
}

impl fmt::Display for AccelKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AccelKind::Brute => write!(f, "brute"),
            AccelKind::Bvh(c) => write!(f, "{c}"),
            AccelKind::Bvh4 => write!(f, "bvh4"),
            AccelKind::Bvh8 => write!(f, "bvh8"),
            #[cfg(feature = "embree")]
            AccelKind::Embree(c) => write!(f, "{c}"),
            #[cfg(feature = "obvhs")]
            AccelKind::Obvhs => write!(f, "obvhs"),
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
    /// The 4-wide box BVH.
    Bvh4(Bvh4),
    /// The 8-wide box BVH.
    Bvh8(Bvh8),
    /// Embree 4's own BVH over Embree's own primitives.
    #[cfg(feature = "embree")]
    Embree(EmbreeAccel),
    /// The obvhs crate's CWBVH over obvhs's own copy of the triangles.
    #[cfg(feature = "obvhs")]
    Obvhs(ObvhsAccel),
}

impl Accelerator {
    /// Build an accelerator of `kind` over the primitives `bounded` (indices
    /// into `prims`). Only Embree (no usable device, out of memory: the
    /// error says what Embree reported) and obvhs (anything but triangles)
    /// can fail.
    pub fn build(
        kind: AccelKind,
        prims: &[Primitive],
        bounded: Vec<u32>,
    ) -> Result<Self, AccelError> {
        Ok(match kind {
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
            AccelKind::Bvh4 => {
                Accelerator::Bvh4(Bvh4::build(prims, bounded, BvhConfig::default().options()))
            }
            AccelKind::Bvh8 => Accelerator::Bvh8(Bvh8::build(prims, bounded, BuildOptions::wide())),
            #[cfg(feature = "embree")]
            AccelKind::Embree(c) => Accelerator::Embree(
                EmbreeAccel::build(prims, &bounded, c).map_err(AccelError::Embree)?,
            ),
            #[cfg(feature = "obvhs")]
            AccelKind::Obvhs => {
                Accelerator::Obvhs(ObvhsAccel::build(prims, &bounded).map_err(AccelError::Obvhs)?)
            }
        })
    }

    /// Shape and cost figures of a BVH; `None` for other accelerators.
    pub fn bvh_stats(&self, prims: &[Primitive]) -> Option<BvhStats> {
        match self {
            Accelerator::Brute(_) => None,
            Accelerator::BvhAabb(b, _) => Some(b.stats(prims)),
            Accelerator::BvhSphere(b, _) => Some(b.stats(prims)),
            Accelerator::BvhEllipsoid(b, _) => Some(b.stats(prims)),
            Accelerator::Bvh4(b) => Some(b.stats(prims)),
            Accelerator::Bvh8(b) => Some(b.stats(prims)),
            #[cfg(feature = "embree")]
            Accelerator::Embree(_) => None,
            #[cfg(feature = "obvhs")]
            Accelerator::Obvhs(_) => None,
        }
    }

    /// [`Bvh::test_volumes`] on this accelerator's tree; `None` for
    /// accelerators without bounding volumes of raylab's own.
    pub fn test_volumes(&self, rays: &[PreparedRay], max_nodes: usize) -> Option<(u64, f64)> {
        match self {
            Accelerator::Brute(_) => None,
            Accelerator::BvhAabb(b, _) => Some(b.test_volumes(rays, max_nodes)),
            Accelerator::BvhSphere(b, _) => Some(b.test_volumes(rays, max_nodes)),
            Accelerator::BvhEllipsoid(b, _) => Some(b.test_volumes(rays, max_nodes)),
            Accelerator::Bvh4(_) | Accelerator::Bvh8(_) => None,
            #[cfg(feature = "embree")]
            Accelerator::Embree(_) => None,
            #[cfg(feature = "obvhs")]
            Accelerator::Obvhs(_) => None,
        }
    }

    pub fn kind(&self) -> AccelKind {
        match self {
            Accelerator::Brute(_) => AccelKind::Brute,
            Accelerator::BvhAabb(_, c)
            | Accelerator::BvhSphere(_, c)
            | Accelerator::BvhEllipsoid(_, c) => AccelKind::Bvh(*c),
            Accelerator::Bvh4(_) => AccelKind::Bvh4,
            Accelerator::Bvh8(_) => AccelKind::Bvh8,
            #[cfg(feature = "embree")]
            Accelerator::Embree(a) => AccelKind::Embree(a.config()),
            #[cfg(feature = "obvhs")]
            Accelerator::Obvhs(_) => AccelKind::Obvhs,
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
            Accelerator::Bvh4(a) => a.intersect(prims, ray, t_max, stats),
            Accelerator::Bvh8(a) => a.intersect(prims, ray, t_max, stats),
            #[cfg(feature = "embree")]
            Accelerator::Embree(a) => a.intersect(prims, ray, t_max, stats),
            #[cfg(feature = "obvhs")]
            Accelerator::Obvhs(a) => a.intersect(prims, ray, t_max, stats),
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
            Accelerator::Bvh4(a) => a.occluded(prims, ray, t_max, stats),
            Accelerator::Bvh8(a) => a.occluded(prims, ray, t_max, stats),
            #[cfg(feature = "embree")]
            Accelerator::Embree(a) => a.occluded(prims, ray, t_max, stats),
            #[cfg(feature = "obvhs")]
            Accelerator::Obvhs(a) => a.occluded(prims, ray, t_max, stats),
        }
    }
}
