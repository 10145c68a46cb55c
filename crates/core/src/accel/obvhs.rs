//! [obvhs](https://crates.io/crates/obvhs) 0.4 as an accelerator
//! (`--accel obvhs`): a peer Rust BVH library, measured beside Embree in
//! the `accel_speed` study and `crates/core/benches/accel.rs`. Behind the `obvhs`
//! cargo feature (on by default).
//!
//! What is built: obvhs's compressed 8-wide BVH (`obvhs::cwbvh`, the CWBVH
//! of Ylitie et al. 2017: 80-byte nodes, child boxes quantised to 8 bits
//! per plane) over the scene's triangles, by `build_cwbvh_from_tris` with
//! the preset [`PRESET`] (`BvhBuildParams::medium_build`: PLOC with
//! medium search radius, reinsertion, no spatial pre-splits, up to 3
//! triangles per leaf in the CWBVH). That is obvhs's recommended preset
//! (the one its crate documentation builds with, "around the same build
//! time as Embree but with faster traversal"); see
//! `PRESET` for how the others compared on raylab's meshes. The triangles
//! are stored as obvhs's `RtTriangle` (the form it documents as optimised
//! for CPU intersection: a vertex, two edges and the unnormalised normal)
//! in the BVH's leaf order, so a leaf indexes them directly, without
//! obvhs's `primitive_indices` indirection, as its examples advise. obvhs
//! is compiled with raylab's flags (no `target-cpu`): its node test is
//! 4-wide SSE, two steps per 8-wide node. Its `parallel` feature (a rayon
//! build) is on, so it builds on all cores, as raylab's build does.
//!
//! Queries run one ray at a time, as Embree's `rtcIntersect1`: the closest
//! hit through `CwBvh::ray_traverse`, the any-hit query through
//! `CwBvh::ray_traverse_miss` (it stops at the first hit), each with
//! `RtTriangle::intersect` (Möller–Trumbore) as the leaf test.
//!
//! The ray interval. raylab asks for hits in the open (0, t_max); obvhs's
//! triangle test accepts t in the closed [tmin, tmax], and both traversals
//! accept only t < tmax. We pass tmin = the smallest normal float (so t = 0
//! is out) and tmax = t_max. obvhs's node test also clips every box
//! interval to start at t = 10⁻⁴ (`EPSILON` in its node code), so a
//! triangle whose leaf box lies wholly within t < 10⁻⁴ of the origin is
//! never tested, and a query with t_max ≤ 10⁻⁴ finds nothing at all (raylab
//! never asks such a query of an accelerator when rendering these scenes:
//! shadow rays reach to a light, other rays to the scene's far distance).
//!
//! One change to the rays: a direction component of −0 is handed to obvhs
//! as +0, the same ray. obvhs 0.4 takes the reciprocal of −0 as −1/ε but
//! orders its node slabs by `d < 0` (false for −0), so it misses every box
//! for such a ray (`-Vec3::Z`, straight down, would find nothing).
//!
//! The hit reported is raylab's: the primitive's index in the scene's list,
//! obvhs's t, and the barycentrics of vertices 1 and 2 from obvhs's
//! `RtTriangle::compute_barycentric` (with obvhs's edges e1 = v0 − v1,
//! e2 = v2 − v0 these are raylab's `u`, `v`: p = (1−u−v)p0 + u·p1 + v·p2).
//! obvhs's triangle test is not watertight: a ray through a shared edge
//! may slip between the two triangles, where raylab's watertight test
//! finds one. `crates/core/tests/obvhs.rs` measures how often: about one ray in ten
//! aimed exactly at an edge or a vertex, none in 40 000 rays per mesh that
//! are not aimed at them.
//!
//! Only triangles: a sphere or ellipsoid (or a plane passed in, which a
//! [`Scene`](crate::scene::Scene) never does: it tests its planes outside
//! every accelerator) is refused with an error naming what the scene holds.
//!
//! Counting: obvhs's traversal counts nothing, so, as for Embree, node
//! visits and primitive tests stay at zero and `primitive_hit` is counted
//! once per query that reports a hit.

use super::Accel;
use crate::math::Vec3;
use crate::shape::{PreparedRay, PrimHit, Primitive, Shape};
use crate::stats::Stats;
use ::obvhs::cwbvh::builder::build_cwbvh_from_tris;
use ::obvhs::cwbvh::CwBvh;
use ::obvhs::ray::{Ray as ObRay, RayHit};
use ::obvhs::rt_triangle::RtTriangle;
use ::obvhs::triangle::Triangle as ObTriangle;
use ::obvhs::BvhBuildParams;
use std::fmt;
use std::time::Duration;

/// The build preset: obvhs's `medium_build`, the one its documentation
/// recommends. The presets hardly differ in traversal on raylab's meshes:
/// on the camel and the bunny (800×600 camera rays and the workload's other
/// sets, one thread) `fast_build`, `slow_build` (spatial pre-splits, wider
/// PLOC search, more reinsertion) and `very_slow_build` each traced every
/// ray kind within about 5 % of `medium_build` (`very_slow_build` at best
/// 3–5 % faster, at 3–4× its build time), which is within the noise of
/// a shared machine; [`ObvhsAccel::build_with`] takes any of them.
pub const PRESET: BvhBuildParams = BvhBuildParams::medium_build();

/// The smallest t obvhs is asked about: t = 0 is outside raylab's open
/// interval.
const TMIN: f32 = f32::MIN_POSITIVE;

/// Why obvhs cannot hold a scene: it is given primitives other than
/// triangles, or an index out of range.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct ObvhsError(String);

/// obvhs's CWBVH over a scene's triangles, with the triangles in its leaf
/// order and what each of them is in raylab's primitive list.
#[derive(Clone)]
pub struct ObvhsAccel {
    /// `None` without triangles (obvhs does not build over nothing).
    bvh: Option<CwBvh>,
    /// The triangles in leaf order: slot `i` is the BVH's primitive `i`.
    tris: Vec<RtTriangle>,
    /// raylab's index of the triangle in each slot.
    ids: Vec<u32>,
    /// Triangles given (slots can exceed it only with spatial splits).
    triangles: usize,
}

impl fmt::Debug for ObvhsAccel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ObvhsAccel")
            .field("triangles", &self.triangles)
            .field("nodes", &self.nodes())
            .finish()
    }
}

/// "2 spheres, 1 ellipsoid": what of `counts` (spheres, ellipsoids,
/// planes) is there.
fn unsupported(counts: [usize; 3]) -> String {
    let names = [
        ("sphere", "spheres"),
        ("ellipsoid", "ellipsoids"),
        ("infinite plane", "infinite planes"),
    ];
    counts
        .iter()
        .zip(names)
        .filter(|(&n, _)| n > 0)
        .map(|(&n, (one, many))| format!("{n} {}", if n == 1 { one } else { many }))
        .collect::<Vec<_>>()
        .join(", ")
}

impl ObvhsAccel {
    /// Build obvhs's CWBVH over the triangles `ids` (indices into
    /// `prims`). Fails, naming what it found, if any of them is not a
    /// triangle, or an index is out of range.
    pub fn build(prims: &[Primitive], ids: &[u32]) -> Result<Self, ObvhsError> {
        Self::build_with(prims, ids, PRESET)
    }

    /// [`ObvhsAccel::build`] with another of obvhs's build presets (or
    /// parameters of one's own), to compare them.
    pub fn build_with(
        prims: &[Primitive],
        ids: &[u32],
        params: BvhBuildParams,
    ) -> Result<Self, ObvhsError> {
        let mut tris = Vec::with_capacity(ids.len());
        let mut others = [0usize; 3];
        for &id in ids {
            let prim = prims.get(id as usize).ok_or_else(|| {
                ObvhsError(format!(
                    "obvhs: primitive index {id} out of range ({} primitives)",
                    prims.len()
                ))
            })?;
            match &prim.shape {
                Shape::Triangle(t) => {
                    let [v0, v1, v2] = t.p.map(|p| p.to_array().into());
                    tris.push(ObTriangle { v0, v1, v2 });
                }
                Shape::Sphere(_) => others[0] += 1,
                Shape::Ellipsoid(_) => others[1] += 1,
                Shape::Plane(_) => others[2] += 1,
            }
        }
        if others.iter().any(|&n| n > 0) {
            return Err(ObvhsError(format!(
                "obvhs holds triangle meshes only, but the scene has {}; \
                 use --accel bvh8, bvh or embree for it",
                unsupported(others)
            )));
        }
        if tris.is_empty() {
            return Ok(Self {
                bvh: None,
                tris: Vec::new(),
                ids: Vec::new(),
                triangles: 0,
            });
        }
        let bvh = build_cwbvh_from_tris(&tris, params, &mut Duration::default());
        let slots = &bvh.primitive_indices;
        let leaf_tris = slots
            .iter()
            .map(|&i| RtTriangle::from(&tris[i as usize]))
            .collect();
        let leaf_ids = slots.iter().map(|&i| ids[i as usize]).collect();
        Ok(Self {
            bvh: Some(bvh),
            tris: leaf_tris,
            ids: leaf_ids,
            triangles: tris.len(),
        })
    }

    /// Nodes of the CWBVH (80 bytes each).
    pub fn nodes(&self) -> usize {
        self.bvh.as_ref().map_or(0, |b| b.nodes.len())
    }

    /// Triangles it holds.
    pub fn triangles(&self) -> usize {
        self.triangles
    }

    /// obvhs's ray for raylab's, on [TMIN, t_max]; `None` when the
    /// interval holds nothing (t_max ≤ TMIN, NaN) or the ray is not finite
    /// (obvhs asserts finite rays in debug builds).
    ///
    /// A direction component of −0 becomes +0 (`d + 0` does that and
    /// nothing else): see the module docs.
    #[inline(always)]
    fn ray(ray: &PreparedRay, t_max: f32) -> Option<ObRay> {
        let (o, d) = (ray.ray.origin, ray.ray.dir + Vec3::ZERO);
        if t_max.is_nan() || t_max <= TMIN || !o.is_finite() || !d.is_finite() {
            return None;
        }
        Some(ObRay::new(
            o.to_array().into(),
            d.to_array().into(),
            TMIN,
            t_max,
        ))
    }
}

impl Accel for ObvhsAccel {
    /// `CwBvh::ray_traverse`. `prims` is not read: the accelerator holds its
    /// own copy of the triangles.
    #[inline]
    fn intersect<S: Stats>(
        &self,
        _prims: &[Primitive],
        ray: &PreparedRay,
        t_max: f32,
        stats: &mut S,
    ) -> Option<(u32, PrimHit)> {
        let bvh = self.bvh.as_ref()?;
        let r = Self::ray(ray, t_max)?;
        let mut hit = RayHit::none();
        let tris = &self.tris[..];
        if !bvh.ray_traverse(r, &mut hit, |r, slot| tris[slot].intersect(r)) {
            return None;
        }
        let slot = hit.primitive_id as usize;
        let uv = tris[slot].compute_barycentric(&r);
        stats.primitive_hit();
        Some((
            self.ids[slot],
            PrimHit {
                t: hit.t,
                u: uv.x,
                v: uv.y,
            },
        ))
    }

    /// `CwBvh::ray_traverse_miss`: stops at the first hit.
    #[inline]
    fn occluded<S: Stats>(
        &self,
        _prims: &[Primitive],
        ray: &PreparedRay,
        t_max: f32,
        stats: &mut S,
    ) -> bool {
        let (Some(bvh), Some(r)) = (self.bvh.as_ref(), Self::ray(ray, t_max)) else {
            return false;
        };
        let tris = &self.tris[..];
        let hit = !bvh.ray_traverse_miss(r, |r, slot| tris[slot].intersect(r));
        if hit {
            stats.primitive_hit();
        }
        hit
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Ray;
    use crate::shape::{Ellipsoid, Intersect, Plane, Sphere, Triangle};
    use crate::stats::{Counters, NoStats};

    fn prim(shape: Shape) -> Primitive {
        Primitive { shape, object: 0 }
    }

    fn tri(p0: Vec3, p1: Vec3, p2: Vec3) -> Primitive {
        prim(Shape::Triangle(Triangle::new(p0, p1, p2)))
    }

    #[test]
    fn one_triangle_with_raylabs_barycentrics_and_interval() {
        // A scene of a plane (not given to the accelerator), a triangle
        // (index 1) at z = −2 and one at z = −4 (index 2) behind it.
        let prims = vec![
            prim(Shape::Plane(Plane::new(Vec3::ZERO, Vec3::Y))),
            tri(
                Vec3::new(0.0, 0.0, -2.0),
                Vec3::new(1.0, 0.0, -2.0),
                Vec3::new(0.0, 1.0, -2.0),
            ),
            tri(
                Vec3::new(-5.0, -5.0, -4.0),
                Vec3::new(5.0, -5.0, -4.0),
                Vec3::new(0.0, 5.0, -4.0),
            ),
        ];
        let accel = ObvhsAccel::build(&prims, &[1, 2]).unwrap();
        assert_eq!(accel.triangles(), 2);
        assert!(accel.nodes() >= 1);
        // Straight down: −Vec3::Z has x = y = −0 (see `ObvhsAccel::ray`).
        let r = PreparedRay::new(Ray::new(Vec3::new(0.25, 0.5, 0.0), -Vec3::Z));
        let mut c = Counters::default();
        let (id, h) = accel.intersect(&prims, &r, f32::INFINITY, &mut c).unwrap();
        assert_eq!(id, 1);
        // raylab's own test of the same triangle: same t and barycentrics
        // up to rounding.
        let want = prims[1].test(&r, f32::INFINITY, &mut NoStats).unwrap();
        assert!((h.t - 2.0).abs() < 1e-6, "{h:?}");
        assert!(
            (h.u - want.u).abs() < 1e-6 && (h.v - want.v).abs() < 1e-6,
            "{h:?} {want:?}"
        );
        assert!(
            (h.u - 0.25).abs() < 1e-6 && (h.v - 0.5).abs() < 1e-6,
            "{h:?}"
        );
        assert_eq!(c.primitive_hits, 1);
        assert_eq!(c.nodes_visited, 0, "obvhs counts nothing");
        // t_max is exclusive: at exactly 2 the front triangle is out, and
        // so is the one behind it.
        assert!(accel.intersect(&prims, &r, 2.0, &mut NoStats).is_none());
        assert!(!accel.occluded(&prims, &r, 2.0, &mut NoStats));
        assert!(accel.occluded(&prims, &r, 2.5, &mut NoStats));
        let (id, h) = accel.intersect(&prims, &r, 2.5, &mut NoStats).unwrap();
        assert_eq!((id, h.t), (1, 2.0));
        // Beside the small triangle: the big one behind it.
        let r = PreparedRay::new(Ray::new(Vec3::new(2.0, 0.0, 0.0), -Vec3::Z));
        let (id, h) = accel
            .intersect(&prims, &r, f32::INFINITY, &mut NoStats)
            .unwrap();
        assert_eq!(id, 2);
        assert!((h.t - 4.0).abs() < 1e-6);
        // Empty intervals and rays that are not finite miss.
        for t_max in [0.0, -1.0, f32::NAN] {
            assert!(accel.intersect(&prims, &r, t_max, &mut NoStats).is_none());
            assert!(!accel.occluded(&prims, &r, t_max, &mut NoStats));
        }
        let bad = PreparedRay::new(Ray::new(Vec3::new(f32::NAN, 0.0, 0.0), -Vec3::Z));
        assert!(accel
            .intersect(&prims, &bad, f32::INFINITY, &mut NoStats)
            .is_none());
    }

    #[test]
    fn no_triangles_miss() {
        let accel = ObvhsAccel::build(&[], &[]).unwrap();
        let r = PreparedRay::new(Ray::new(Vec3::ZERO, Vec3::X));
        assert!(accel
            .intersect(&[], &r, f32::INFINITY, &mut NoStats)
            .is_none());
        assert!(!accel.occluded(&[], &r, f32::INFINITY, &mut NoStats));
        assert_eq!(accel.nodes(), 0);
    }

    #[test]
    fn other_shapes_and_bad_indices_are_refused_by_name() {
        let e = Ellipsoid::new(Vec3::ZERO, Vec3::ONE, crate::math::Mat3::IDENTITY);
        let prims = vec![
            tri(Vec3::ZERO, Vec3::X, Vec3::Y),
            prim(Shape::Sphere(Sphere::new(Vec3::ZERO, 1.0))),
            prim(Shape::Sphere(Sphere::new(Vec3::X, 1.0))),
            prim(Shape::Ellipsoid(e)),
            prim(Shape::Plane(Plane::new(Vec3::ZERO, Vec3::Y))),
        ];
        let err = ObvhsAccel::build(&prims, &[0, 1, 2, 3])
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("triangle meshes only") && err.contains("2 spheres, 1 ellipsoid"),
            "{err}"
        );
        let err = ObvhsAccel::build(&prims, &[4]).unwrap_err().to_string();
        assert!(err.contains("1 infinite plane"), "{err}");
        let err = ObvhsAccel::build(&prims, &[9]).unwrap_err().to_string();
        assert!(err.contains("out of range"), "{err}");
    }
}
