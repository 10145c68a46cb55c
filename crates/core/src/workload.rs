//! Fixed ray workloads for measuring accelerators: the same rays, built once
//! before any clock starts, traced by every accelerator that is compared.
//! The benchmarks (`crates/core/benches/accel.rs`) and the `accel_speed` study
//! (`analysis/embree-speed.toml`) both measure on these sets.
//!
//! Four kinds of ray, after the usual split of a renderer's work:
//! - [`RayKind::Camera`] ("primary"): camera rays through the pixel centres of the
//!   scene's camera (closest hit);
//! - [`RayKind::Shadow`]: from each primary hit (mesh or floor) towards the
//!   scene's first light, stopping just short of it (any hit);
//! - [`RayKind::Path`] ("diffuse"): from each primary hit, one cosine-distributed
//!   direction about the shading normal (closest hit): incoherent rays, as
//!   a path tracer's first bounce makes;
//! - [`RayKind::Random`]: from a random point on the sphere around the
//!   scene's bounds (centre, radius = the box's diagonal) through a uniform
//!   random point of the box (closest hit): the least coherent set.
//!
//! Secondary rays start at the hit point offset along the geometric normal
//! as every renderer's ray does ([`crate::shape::Hit::spawn_origin`]; shadow
//! rays are [`crate::shape::Hit::shadow_segment`]s). Every set is a pure
//! function of the scene and the seed.

use crate::accel::Accel;
use crate::math::{cosine_hemisphere, orthonormal_basis, Ray, SplitMix64, Vec3};
use crate::scene::Scene;
use crate::shape::PreparedRay;
pub use crate::stats::RayKind;
use crate::stats::{NoStats, Stats};
use glam::Vec2;
use rayon::prelude::*;

/// One ray to trace and its far limit.
#[derive(Clone, Copy, Debug)]
pub struct Segment {
    pub ray: PreparedRay,
    pub t_max: f32,
}

/// The four ray sets of one scene.
#[derive(Clone, Debug, Default)]
pub struct Workload {
    pub primary: Vec<Segment>,
    pub shadow: Vec<Segment>,
    pub diffuse: Vec<Segment>,
    pub random: Vec<Segment>,
}

/// The random numbers of ray `i`: a SplitMix64 stream seeded from the
/// seed and the ray's index, so a ray's numbers do not depend on the others
/// (or on the order the rays are made in).
fn stream(seed: u64, i: u64) -> SplitMix64 {
    SplitMix64(SplitMix64::mix(seed ^ SplitMix64::mix(i)))
}

/// A cosine-distributed unit direction about the unit vector `n` from two
/// uniform numbers: the path tracer's warp ([`cosine_hemisphere`]) in the
/// frame of [`orthonormal_basis`], so a diffuse workload ray is the ray a
/// path tracer's first bounce would trace.
pub fn cosine_direction(n: Vec3, u1: f32, u2: f32) -> Vec3 {
    let (t, b) = orthonormal_basis(n);
    let local = cosine_hemisphere(Vec2::new(u1, u2));
    (local.x * t + local.y * b + local.z * n).normalize()
}

impl Workload {
    /// The ray sets of `scene` at its camera's resolution, with `random`
    /// random rays. Primary hits are found with the scene's own
    /// accelerator (any correct one gives the same hits up to rounding).
    pub fn from_scene(scene: &Scene, random: usize, seed: u64) -> Workload {
        let cam = &scene.camera;
        let light = scene.lights.first().map(|l| l.position);
        let far = scene.settings.max_distance;
        let pixels: Vec<(u32, u32)> = (0..cam.height)
            .flat_map(|py| (0..cam.width).map(move |px| (px, py)))
            .collect();
        // Each pixel gives a primary ray and, when it hits, a shadow and a
        // diffuse ray; computed in parallel, gathered in pixel order.
        let per_pixel: Vec<(Segment, Option<Segment>, Option<Segment>)> = pixels
            .par_iter()
            .map(|&(px, py)| {
                let ray = cam.generate_ray(px as f32 + 0.5, py as f32 + 0.5);
                let primary = Segment {
                    ray: PreparedRay::new(ray),
                    t_max: far,
                };
                let Some(hit) = scene.intersect(&ray, far, &mut NoStats) else {
                    return (primary, None, None);
                };
                let shadow = light.map(|lp| {
                    let (ray, t_max) = hit.shadow_segment((lp - hit.point).normalize(), lp);
                    Segment {
                        ray: PreparedRay::new(ray),
                        t_max,
                    }
                });
                let mut rng = stream(seed, u64::from(py) * u64::from(cam.width) + u64::from(px));
                let dir = cosine_direction(hit.shading_normal, rng.next_f32(), rng.next_f32());
                let diffuse = Segment {
                    ray: PreparedRay::new(Ray::new(hit.spawn_origin(dir), dir)),
                    t_max: far,
                };
                (primary, shadow, Some(diffuse))
            })
            .collect();
        let mut w = Workload {
            random: random_through_bounds(scene, random, seed),
            ..Workload::default()
        };
        for (p, s, d) in per_pixel {
            w.primary.push(p);
            w.shadow.extend(s);
            w.diffuse.extend(d);
        }
        w
    }

    /// The kinds of ray a workload holds, in the order tables list them.
    pub const KINDS: [RayKind; 4] = [
        RayKind::Camera,
        RayKind::Shadow,
        RayKind::Path,
        RayKind::Random,
    ];

    /// The set of one kind (empty for kinds a workload does not hold).
    pub fn get(&self, kind: RayKind) -> &[Segment] {
        match kind {
            RayKind::Camera => &self.primary,
            RayKind::Shadow => &self.shadow,
            RayKind::Path => &self.diffuse,
            RayKind::Random => &self.random,
            RayKind::Reflection | RayKind::Refraction => &[],
        }
    }
}

/// `n` rays from the sphere around the bounds of `scene`'s bounded
/// primitives through uniform points of those bounds; see the module
/// documentation. Directions are unit vectors; t_max is unlimited.
pub fn random_through_bounds(scene: &Scene, n: usize, seed: u64) -> Vec<Segment> {
    let b = scene.bounds();
    if b.is_empty() {
        return Vec::new();
    }
    let (c, radius) = (b.centre(), b.extent().length().max(f32::MIN_POSITIVE));
    (0..n as u64)
        .map(|i| {
            let mut rng = stream(seed ^ 0x5EED, i);
            let origin = c + radius * rng.unit_vector();
            let d = (rng.in_box(&b) - origin).normalize();
            Segment {
                ray: PreparedRay::new(Ray::new(origin, d)),
                t_max: f32::INFINITY,
            }
        })
        .collect()
}

/// Trace every segment through `accel` (closest hit, or any hit when
/// `any_hit`) on the current thread; returns how many hit.
pub fn trace_serial<A: Accel, S: Stats>(
    accel: &A,
    scene: &Scene,
    rays: &[Segment],
    any_hit: bool,
    stats: &mut S,
) -> u64 {
    let prims = &scene.prims[..];
    let mut hits = 0;
    for r in rays {
        let hit = if any_hit {
            accel.occluded(prims, &r.ray, r.t_max, stats)
        } else {
            accel.intersect(prims, &r.ray, r.t_max, stats).is_some()
        };
        hits += u64::from(hit);
    }
    hits
}

/// Rays per parallel task: large enough that scheduling costs nothing
/// measurable, small enough that two threads finish together.
const CHUNK: usize = 1024;

/// [`trace_serial`] over the current rayon pool: one thread traces alone
/// (no task overhead); more split the rays into chunks.
pub fn trace<A: Accel + Sync>(accel: &A, scene: &Scene, rays: &[Segment], any_hit: bool) -> u64 {
    if rayon::current_num_threads() <= 1 {
        return trace_serial(accel, scene, rays, any_hit, &mut NoStats);
    }
    rays.par_chunks(CHUNK)
        .map(|c| trace_serial(accel, scene, c, any_hit, &mut NoStats))
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cosine_directions_are_unit_and_above_the_surface() {
        let n = Vec3::new(0.3, -0.5, 0.8).normalize();
        let mut rng = stream(1, 0);
        for _ in 0..1000 {
            let d = cosine_direction(n, rng.next_f32(), rng.next_f32());
            assert!((d.length() - 1.0).abs() < 1e-5);
            assert!(d.dot(n) >= -1e-6);
        }
    }

    /// The mean cosine to the normal of a cosine-weighted direction is
    /// ∫cos²θ sinθ dθ / ∫cosθ sinθ dθ = 2/3; over 10⁴ samples its standard
    /// error is √(1/2 − 4/9)/100 ≈ 0.0024, so 0.01 is over four of them.
    #[test]
    fn cosine_directions_have_the_cosine_mean() {
        let n = Vec3::new(-0.2, 0.9, 0.1).normalize();
        let mut rng = stream(7, 3);
        let mean = (0..10_000)
            .map(|_| cosine_direction(n, rng.next_f32(), rng.next_f32()).dot(n))
            .sum::<f32>()
            / 10_000.0;
        assert!((mean - 2.0 / 3.0).abs() < 0.01, "{mean}");
    }
}
