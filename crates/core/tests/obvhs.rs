//! The obvhs accelerator (`--accel obvhs`, the obvhs crate's compressed
//! 8-wide BVH) against brute force on real meshes (CGAL's camel and Chinese
//! dragon: the rays of `crates/core/tests/accel.rs`, 10⁵ per mesh, of which a fifth
//! aimed at vertices and a fifth at edge midpoints), and a render of a mesh
//! scene with a floor plane against `bvh8`'s.
//!
//! Why not exact agreement, as the BVHs of `crates/core/tests/accel.rs` have: obvhs
//! tests triangles with its own Möller–Trumbore code, not raylab's
//! watertight test. The two compute t differently, so the same triangle's
//! t agrees up to rounding, not bit for bit; and Möller–Trumbore is not
//! watertight, so a ray through a shared edge or vertex can slip between
//! the triangles (both barycentric tests fail by a rounding) or be reported
//! hitting a triangle raylab's exact edge functions put it just outside of.
//! The checks, with distances over the size of the coordinates involved
//! (the scale of their float rounding, ε ≈ 1.2·10⁻⁷ of it):
//!
//! - where both hit the same triangle, the two hit points lie within
//!   [`T_BAND`] of each other across its plane (along the ray the gap grows
//!   as 1/cos of the incidence angle: relative differences in t of 2·10⁻⁴
//!   occur on grazing rays);
//! - where they hit different triangles at the same point, raylab's test
//!   hits obvhs's triangle too: a tie, as at a shared edge;
//! - otherwise (only one hits, or one hits farther, having slipped through
//!   the other's triangle) the ray passes within [`EDGE_BAND`] of an edge of
//!   the triangle concerned: a rounding at an edge, never a wrong answer in
//!   a triangle's interior; and how many such rays there are, by kind of
//!   ray, is bounded by [`MAX_EDGE_SLIPS`];
//! - obvhs's any-hit query agrees exactly with its closest hit (the same
//!   triangle tests), and stops short of / reaches the closest t.

use raylab::accel::{Accel, AccelKind, Accelerator};
use raylab::integrator::{render, Whitted};
use raylab::io::scene_file::{load_scene, Overrides};
use raylab::shape::{Intersect, PreparedRay, Primitive, Shape};
use raylab::stats::NoStats;
use rayon::prelude::*;

use raylab_testkit::meshes::{all_ids, brute_case};

/// The most rays of each kind of `rays_for` (of 20 000: random through the
/// box, at vertices, at edge midpoints, from inside, axis-parallel through
/// vertices) that obvhs and brute force may answer differently, each
/// passing at an edge. Measured (camel / Chinese dragon): 0 / 0 random,
/// 1550 / 1144 at vertices, 2584 / 1202 at edges (up to 13 %: a ray aimed
/// exactly at a shared edge finds each triangle's barycentric for it
/// within a rounding of zero, of either sign, and Möller–Trumbore has
/// nothing to make the two triangles' verdicts complementary), 0 / 0 from
/// inside, 3 / 18 axis-parallel. Rays not aimed at edges meet one only by
/// chance, within a rounding: none in 40 000 per mesh here.
const MAX_EDGE_SLIPS: [usize; 5] = [5, 4000, 4000, 5, 200];

/// How close to an edge of a triangle a ray must pass for obvhs and brute
/// force to disagree about it, over the size of the coordinates: 10⁻⁶,
/// about 8 roundings of them (measured: at most 6·10⁻⁸).
const EDGE_BAND: f64 = 1e-6;

/// How far apart two hits on one triangle may lie across its plane (the
/// distance along its normal between the points at t₁ and t₂ of the ray),
/// over the size of the coordinates: 10⁻⁶, about 8 roundings of them
/// (measured: at most 4·10⁻⁷).
const T_BAND: f64 = 1e-6;

fn dvec(p: raylab::math::Vec3) -> glam::DVec3 {
    p.as_dvec3()
}

fn vertices(prim: &Primitive) -> [glam::DVec3; 3] {
    let Shape::Triangle(t) = &prim.shape else {
        unreachable!("meshes hold triangles only")
    };
    t.p.map(dvec)
}

/// The size of the coordinates of a ray and a triangle: the largest of
/// |origin| and the vertices'.
fn coordinate_scale(prim: &Primitive, ray: &PreparedRay) -> f64 {
    vertices(prim)
        .iter()
        .fold(dvec(ray.ray.origin).length(), |m, q| m.max(q.length()))
}

/// The distance between the points at `t1` and `t2` of `ray` along the
/// normal of triangle `prim`, over [`coordinate_scale`].
fn plane_gap(prim: &Primitive, ray: &PreparedRay, t1: f32, t2: f32) -> f64 {
    let p = vertices(prim);
    let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
    (t1 as f64 - t2 as f64).abs() * dvec(ray.ray.dir).dot(n).abs() / coordinate_scale(prim, ray)
}

/// The distance between the line of `ray` and the nearest edge of triangle
/// `prim`, over [`coordinate_scale`], in f64.
fn edge_distance(prim: &Primitive, ray: &PreparedRay) -> f64 {
    let (o, d) = (dvec(ray.ray.origin), dvec(ray.ray.dir).normalize());
    let p = vertices(prim);
    (0..3)
        .map(|i| {
            // The segment a + s·e, s in [0, 1], against the line o + t·d:
            // the s of the closest approach, clamped, then the distance
            // from that point to the line.
            let (a, e) = (p[i], p[(i + 1) % 3] - p[i]);
            let w = a - o;
            let (ee, ed, we, wd) = (e.dot(e), e.dot(d), w.dot(e), w.dot(d));
            let denom = ee - ed * ed;
            let s = if denom > 0.0 {
                (wd * ed - we) / denom
            } else {
                0.0
            };
            let q = a + s.clamp(0.0, 1.0) * e - o;
            (q - q.dot(d) * d).length()
        })
        .fold(f64::INFINITY, f64::min)
        / coordinate_scale(prim, ray)
}

/// obvhs against brute force on one mesh; returns the rays only one side
/// hit (after checking each is at an edge).
fn agree_with_brute_force(relative: &str, seed: u64) -> [usize; 5] {
    let case = brute_case(relative, seed);
    let (prims, rays, truth) = (&case.prims[..], &case.rays[..], &case.truth[..]);
    let accel = Accelerator::build(AccelKind::Obvhs, prims, all_ids(prims)).unwrap();
    assert_eq!(accel.kind(), AccelKind::Obvhs);
    let found: Vec<_> = rays
        .par_iter()
        .map(|r| accel.intersect(prims, r, f32::INFINITY, &mut NoStats))
        .collect();

    // Slips by ray kind of `rays_for` (20 000 rays each): random through
    // the box, at vertices, at edge midpoints, from inside, axis-parallel.
    let (mut same, mut ties, mut slips) = (0, 0, [0usize; 5]);
    let (mut worst_dt, mut worst_gap, mut worst_edge) = (0.0f32, 0.0f64, 0.0f64);
    for (i, (got, want)) in found.iter().zip(truth).enumerate() {
        let r = &rays[i];
        // Where only one side hits triangle `id` (or one finds a triangle
        // nearer than the other's), the ray must pass at its edge.
        let mut slip = |id: u32| {
            let dist = edge_distance(&prims[id as usize], r);
            assert!(
                dist <= EDGE_BAND,
                "ray {i} {:?}: obvhs {got:?}, brute force {want:?}; the ray passes \
                 {dist:.1e} (relative) from triangle {id}'s nearest edge",
                r.ray,
            );
            worst_edge = worst_edge.max(dist);
            slips[i * 5 / rays.len()] += 1;
        };
        match (*got, *want) {
            (None, None) => {}
            (Some((id, h)), Some((want_id, want_t))) if id == want_id => {
                let gap = plane_gap(&prims[id as usize], r, h.t, want_t);
                assert!(
                    gap <= T_BAND,
                    "ray {i}: triangle {id}, t {} vs {want_t}: {gap:.1e} apart across its plane",
                    h.t
                );
                worst_dt = worst_dt.max((h.t - want_t).abs() / want_t);
                worst_gap = worst_gap.max(gap);
                same += 1;
            }
            (Some((id, h)), Some((want_id, want_t))) => {
                // A tie: obvhs's triangle is hit by raylab's test too, at
                // obvhs's t, and at the point brute force's triangle is.
                let again = prims[id as usize].test(r, f32::INFINITY, &mut NoStats);
                let scale = r.ray.dir.length() as f64 / coordinate_scale(&prims[id as usize], r);
                if again.is_some_and(|a| plane_gap(&prims[id as usize], r, a.t, h.t) <= T_BAND)
                    && (h.t - want_t).abs() as f64 * scale <= EDGE_BAND
                {
                    ties += 1;
                } else if h.t > want_t {
                    // obvhs slipped through brute force's triangle.
                    slip(want_id);
                } else {
                    // obvhs hit nearer, where raylab's test misses.
                    slip(id);
                }
            }
            (Some((id, _)), None) | (None, Some((id, _))) => slip(id),
        }
    }
    println!(
        "{relative}: {} rays, {same} same triangle (largest |Δt|/t {worst_dt:.1e}, across the plane {worst_gap:.1e}), \
         {ties} ties, {} at edges where obvhs and brute force differ (by kind: random \
         {}, vertices {}, edges {}, inside {}, axis-parallel {}; farthest from an edge \
         {worst_edge:.1e} relative)",
        rays.len(),
        slips.iter().sum::<usize>(),
        slips[0],
        slips[1],
        slips[2],
        slips[3],
        slips[4]
    );

    // Any hit: exactly the closest hit's verdict, and bounded by its t:
    // nothing blocks short of it, and it blocks just beyond it; except that
    // obvhs's node test starts every box interval at t = 10⁻⁴ (see
    // crates/core/src/accel/obvhs.rs), so a query with t_max below that finds nothing.
    const NODE_TMIN: f32 = 1e-4;
    let ok = rays.par_iter().zip(&found).all(|(r, got)| {
        let mut s = NoStats;
        accel.occluded(prims, r, f32::INFINITY, &mut s) == got.is_some()
            && got.is_none_or(|(_, h)| {
                let beyond = h.t * (1.0 + 1e-5);
                !accel.occluded(prims, r, h.t * (1.0 - 1e-5), &mut s)
                    && (beyond <= NODE_TMIN || accel.occluded(prims, r, beyond, &mut s))
            })
    });
    assert!(
        ok,
        "{relative}: obvhs's occluded disagrees with its intersect"
    );
    slips
}

/// Check the rays only one of obvhs and brute force hit, by kind of ray,
/// against [`MAX_EDGE_SLIPS`].
fn check_slips(relative: &str, seed: u64) {
    let slips = agree_with_brute_force(relative, seed);
    for (k, (n, max)) in slips.iter().zip(MAX_EDGE_SLIPS).enumerate() {
        assert!(
            n <= &max,
            "{relative}: {n} edge slips of ray kind {k} (at most {max})"
        );
    }
}

#[test]
fn obvhs_agrees_with_brute_force_on_camel() {
    check_slips("cgal/camel.off", 1);
}

#[test]
fn obvhs_agrees_with_brute_force_on_chinese_dragon() {
    check_slips("cgal/ChineseDragon-10kv.off", 2);
}

/// The camel scene (a mesh on a floor plane, which stays outside the
/// accelerator) rendered through obvhs is `bvh8`'s image, but for pixels
/// where a ray meets an edge.
#[test]
fn a_mesh_scene_renders_as_with_bvh8() {
    let path = raylab_testkit::repo().join("data/scenes/camel.toml");
    raylab_testkit::external("cgal/camel.off");
    let image = |accel: &str| {
        let o = Overrides {
            width: Some(120),
            height: Some(90),
            accel: Some(accel.parse().unwrap()),
            ..Default::default()
        };
        let scene = load_scene(&path, &o).unwrap();
        render::<_, NoStats>(&scene, &Whitted, Some(2)).0
    };
    let (ours, peer) = (image("bvh8"), image("obvhs"));
    assert_eq!(ours.pixels.len(), peer.pixels.len());
    let differ = ours
        .pixels
        .iter()
        .zip(&peer.pixels)
        .filter(|(a, b)| (a.mean - b.mean).abs().max_element() > 1e-3)
        .count();
    println!("{differ} of {} pixels differ", ours.pixels.len());
    assert!(differ <= 10, "{differ} pixels differ");
}
