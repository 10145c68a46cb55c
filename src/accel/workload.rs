//! Fixed ray workloads for measuring accelerators: the same rays, built once
//! before any clock starts, traced by every accelerator that is compared.
//! The benchmarks (`benches/accel.rs`) and the `accel_speed` study
//! (`analysis/embree-speed.toml`) both measure on these sets.
//!
//! Four kinds of ray, after the usual split of a renderer's work:
//! - [`RayKind::Primary`]: camera rays through the pixel centres of the
//!   scene's camera (closest hit);
//! - [`RayKind::Shadow`]: from each primary hit (mesh or floor) towards the
//!   scene's first light, stopping just short of it (any hit);
//! - [`RayKind::Diffuse`]: from each primary hit, one cosine-distributed
//!   direction about the shading normal (closest hit): incoherent rays, as
//!   a path tracer's first bounce makes;
//! - [`RayKind::Random`]: from a random point on the sphere around the
//!   scene's bounds (centre, radius = the box's diagonal) through a uniform
//!   random point of the box (closest hit): the least coherent set, as in
//!   the Embree comparison figures of the issue.
//!
//! Secondary rays start at the hit point offset along the geometric normal
//! as the Whitted integrator does ([`offset_origin`]). Every set is a pure
//! function of the scene and the seed.

use super::Accel;
use crate::integrator::whitted::offset_origin;
use crate::math::{orthonormal_basis, Ray, SplitMix64, Vec3};
use crate::scene::Scene;
use crate::shape::PreparedRay;
use crate::stats::{NoStats, Stats};
use rayon::prelude::*;
use std::f32::consts::PI;
use std::fmt;
use std::str::FromStr;

/// One ray to trace and its far limit.
#[derive(Clone, Copy, Debug)]
pub struct Segment {
    pub ray: PreparedRay,
    pub t_max: f32,
}

/// The kinds of ray a workload holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RayKind {
    Primary,
    Shadow,
    Diffuse,
    Random,
}

impl RayKind {
    /// Every kind, in the order tables list them.
    pub const ALL: [RayKind; 4] = [
        RayKind::Primary,
        RayKind::Shadow,
        RayKind::Diffuse,
        RayKind::Random,
    ];

    /// The kind's name in tables and parameters.
    pub fn name(self) -> &'static str {
        match self {
            RayKind::Primary => "primary",
            RayKind::Shadow => "shadow",
            RayKind::Diffuse => "diffuse",
            RayKind::Random => "random",
        }
    }

    /// Shadow rays ask whether anything is hit (any-hit query); the others
    /// ask for the closest hit.
    pub fn any_hit(self) -> bool {
        self == RayKind::Shadow
    }
}

impl fmt::Display for RayKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for RayKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        RayKind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| {
                format!("unknown ray kind `{s}` (expected primary, shadow, diffuse or random)")
            })
    }
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
/// uniform numbers: Malley's method (a uniform point on the unit disc lifted
/// to the hemisphere, pbrt-v4 §A.5.3) in the frame of
/// [`orthonormal_basis`].
pub fn cosine_direction(n: Vec3, u1: f32, u2: f32) -> Vec3 {
    let (t, bt) = orthonormal_basis(n);
    let (r, phi) = (u1.sqrt(), 2.0 * PI * u2);
    let z = (1.0 - u1).max(0.0).sqrt();
    (r * phi.cos() * t + r * phi.sin() * bt + z * n).normalize()
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
                    let o = offset_origin(&hit, (lp - hit.point).normalize());
                    let d = lp - o;
                    let len = d.length();
                    Segment {
                        ray: PreparedRay::new(Ray::new(o, d / len)),
                        t_max: len * (1.0 - 1e-4),
                    }
                });
                let mut rng = stream(seed, u64::from(py) * u64::from(cam.width) + u64::from(px));
                let dir = cosine_direction(hit.shading_normal, rng.next_f32(), rng.next_f32());
                let diffuse = Segment {
                    ray: PreparedRay::new(Ray::new(offset_origin(&hit, dir), dir)),
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

    /// The set of one kind.
    pub fn get(&self, kind: RayKind) -> &[Segment] {
        match kind {
            RayKind::Primary => &self.primary,
            RayKind::Shadow => &self.shadow,
            RayKind::Diffuse => &self.diffuse,
            RayKind::Random => &self.random,
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
    fn ray_kinds_parse_back() {
        for k in RayKind::ALL {
            assert_eq!(k.name().parse::<RayKind>(), Ok(k));
        }
        assert!("camera".parse::<RayKind>().is_err());
    }

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
