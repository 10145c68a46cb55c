//! Real meshes as raylab primitives, and the rays the accelerator tests
//! trace through them (`crates/core/tests/accel.rs`, `crates/core/tests/obvhs.rs`).

use super::{external, SplitMix64};
use raylab::accel::{Accel, Brute};
use raylab::io::read_mesh;
use raylab::math::{Aabb, Ray, Vec3};
use raylab::shape::{PreparedRay, Primitive, Shape, Triangle};
use raylab::stats::NoStats;
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::{LazyLock, Mutex, OnceLock};
use std::time::Instant;

pub fn triangle(p0: Vec3, p1: Vec3, p2: Vec3) -> Primitive {
    Primitive {
        shape: Shape::Triangle(Triangle::new(p0, p1, p2)),
        object: 0,
    }
}

pub fn mesh_prims(relative: &str) -> Vec<Primitive> {
    let path = external(relative);
    let mesh = read_mesh(&path).unwrap_or_else(|e| panic!("{e}"));
    let p = &mesh.positions;
    mesh.triangles
        .iter()
        .map(|t| triangle(p[t[0] as usize], p[t[1] as usize], p[t[2] as usize]))
        .collect()
}

pub fn all_ids(prims: &[Primitive]) -> Vec<u32> {
    (0..prims.len() as u32).collect()
}

pub fn vertices(p: &Primitive) -> [Vec3; 3] {
    match &p.shape {
        Shape::Triangle(t) => t.p,
        _ => unreachable!("meshes hold triangles only"),
    }
}

/// 10⁵ rays for a mesh, of five kinds (20 000 each):
/// - from a sphere around the mesh towards random points of its box;
/// - aimed at random triangle vertices, and at random edge midpoints (shared
///   vertices and edges, where the watertight test must not crack and ties
///   between neighbours happen);
/// - from random points inside the box in random directions (rays that
///   start inside node volumes);
/// - parallel to an axis, through a vertex's other two coordinates: those
///   coordinates are faces of node boxes, so 1/d = ±∞ meets a zero
///   distance (the 0·∞ = NaN case of the slab test).
pub fn rays_for(prims: &[Primitive], seed: u64) -> Vec<PreparedRay> {
    let bounds = prims
        .iter()
        .filter_map(Primitive::bounds)
        .fold(Aabb::EMPTY, Aabb::union);
    let centre = bounds.centre();
    let radius = 0.5 * bounds.extent().length();
    let mut rng = SplitMix64(seed);
    let mut rays = Vec::with_capacity(100_000);
    for kind in 0..5 {
        for _ in 0..20_000 {
            let outside = centre + 2.0 * radius * rng.unit_vector();
            let tri = vertices(&prims[rng.below(prims.len())]);
            let ray = match kind {
                0 => Ray::new(outside, rng.in_box(&bounds) - outside),
                1 => Ray::new(outside, tri[rng.below(3)] - outside),
                2 => {
                    let i = rng.below(3);
                    let mid = 0.5 * (tri[i] + tri[(i + 1) % 3]);
                    Ray::new(outside, mid - outside)
                }
                3 => Ray::new(rng.in_box(&bounds), rng.unit_vector()),
                _ => {
                    let axis = rng.below(3);
                    let sign = if rng.below(2) == 0 { 1.0 } else { -1.0 };
                    let mut origin = tri[rng.below(3)];
                    origin[axis] = centre[axis] - sign * 2.0 * radius;
                    let mut dir = Vec3::ZERO;
                    dir[axis] = sign;
                    Ray::new(origin, dir)
                }
            };
            rays.push(PreparedRay::new(ray));
        }
    }
    rays
}

/// One mesh's triangles, the rays of [`rays_for`] through it and brute
/// force's answers: what the accelerator tests (`accel.rs`, `obvhs.rs`)
/// check against.
pub struct BruteCase {
    pub prims: Vec<Primitive>,
    pub rays: Vec<PreparedRay>,
    /// Brute force's closest hit for each ray ([`reference()`]).
    pub truth: Vec<Option<(u32, f32)>>,
    /// How long brute force took, in seconds.
    pub brute_seconds: f64,
}

/// The [`BruteCase`] of the mesh `relative` (under `data/external/`) with
/// the rays of `seed`, computed once per test process: brute force over
/// 10⁵ rays is most of an accelerator test's time (36 s of 49 for the
/// camel on two threads), and the BVH and obvhs tests of one mesh share
/// it. A test asking while another computes it waits for that one.
pub fn brute_case(relative: &str, seed: u64) -> &'static BruteCase {
    type Cases = HashMap<(String, u64), &'static OnceLock<BruteCase>>;
    static CASES: LazyLock<Mutex<Cases>> = LazyLock::new(Mutex::default);
    let cell: &'static OnceLock<BruteCase> = CASES
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .entry((relative.to_string(), seed))
        .or_insert_with(|| Box::leak(Box::new(OnceLock::new())));
    cell.get_or_init(|| {
        let prims = mesh_prims(relative);
        let rays = rays_for(&prims, seed);
        let start = Instant::now();
        let truth = reference(&prims, &rays);
        BruteCase {
            prims,
            rays,
            truth,
            brute_seconds: start.elapsed().as_secs_f64(),
        }
    })
}

/// Brute force's closest hit for each ray: (primitive, t).
pub fn reference(prims: &[Primitive], rays: &[PreparedRay]) -> Vec<Option<(u32, f32)>> {
    let brute = Brute::new(all_ids(prims));
    rays.par_iter()
        .map(|r| {
            brute
                .intersect(prims, r, f32::INFINITY, &mut NoStats)
                .map(|(id, h)| (id, h.t))
        })
        .collect()
}
