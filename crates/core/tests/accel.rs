//! The BVH accelerators against brute force, on real meshes (CGAL's camel
//! and Chinese dragon, assimp's Wuson, installed by `scripts/fetch-data`),
//! plus structural checks of the flattened trees and exact test counts on a
//! hand-built scene.
//!
//! Why exact agreement is expected: a BVH runs the very same triangle test
//! (`Primitive::intersect`, through the same `closest_in`/`any_in` helpers)
//! on the same prepared ray as brute force; the reported t does not depend
//! on the t_max passed in. So whenever both report the same primitive, its
//! t must be bit-for-bit equal. They may legitimately report different
//! primitives only at a tie: two primitives hit at the same t (a ray through
//! a shared edge or vertex, aimed at on purpose here), where brute force
//! keeps the lowest index and the BVH the first it visits. A tie is
//! accepted when the BVH's primitive really is hit at a t within 10⁻⁶
//! (relative) of brute force's: that is ~16 ε, room for the two triangles'
//! own roundings of the same point, far below any geometric gap in these
//! meshes.

use raylab::accel::bvh::{
    BoundingVolume, BuildOptions, Builder, BvhConfig, Fit, Node, VolumeKind, DEFAULT_LEAF_SIZE,
    MAX_DEPTH,
};
use raylab::accel::{Accel, AccelKind, Accelerator, Bvh, Bvh4, Bvh8};
use raylab::io::scene_file::{load_scene, Overrides};
use raylab::math::Aabb;
use raylab::math::{Ray, Vec3};
use raylab::shape::{PreparedRay, Primitive};
use raylab::stats::{Counters, NoStats};
use rayon::prelude::*;
use std::time::Instant;

use raylab_testkit::meshes::{all_ids, brute_case, triangle, vertices};

/// Visit every node with the range of primitive slots below it (subtrees
/// are contiguous in the index array), checking the layout on the way:
/// children adjacent and after their parent, leaves within the size limit.
fn walk<V: BoundingVolume>(
    bvh: &Bvh<V>,
    leaf_limit: u32,
    mut visit: impl FnMut(&Node<V>, std::ops::Range<usize>),
) {
    fn go<V: BoundingVolume>(
        bvh: &Bvh<V>,
        i: usize,
        depth: u32,
        leaf_limit: u32,
        visit: &mut impl FnMut(&Node<V>, std::ops::Range<usize>),
    ) -> std::ops::Range<usize> {
        let n = &bvh.nodes()[i];
        assert!(depth < MAX_DEPTH);
        let range = if n.is_leaf() {
            assert!(n.count <= leaf_limit, "leaf of {} > {leaf_limit}", n.count);
            n.first as usize..(n.first + n.count) as usize
        } else {
            let c = n.first as usize;
            assert!(c > i && c + 1 < bvh.nodes().len(), "children of {i} at {c}");
            let l = go(bvh, c, depth + 1, leaf_limit, visit);
            let r = go(bvh, c + 1, depth + 1, leaf_limit, visit);
            assert_eq!(l.end, r.start, "subtree ranges of {i} not contiguous");
            l.start..r.end
        };
        visit(n, range.clone());
        range
    }
    if !bvh.nodes().is_empty() {
        let all = go(bvh, 0, 0, leaf_limit, &mut visit);
        assert_eq!(all, 0..bvh.indices().len());
    }
}

/// Structure of a built tree: the indices are a permutation of the input;
/// every node's volume contains every vertex below it, and for S3's fit
/// (volume derived from the box) also the corners of the box of its
/// contents. Tight fits enclose the points only, not their box, so the
/// corners are not checked there. Tolerance 10⁻⁶ relative: fits are padded
/// by 10⁻⁶ beyond their own rounding, so points should be inside with no
/// tolerance at all; the check's own arithmetic (a difference, a scale and
/// a length: ~4 ε ≈ 2.4·10⁻⁷) gets the 10⁻⁶.
fn check_structure<V: BoundingVolume>(bvh: &Bvh<V>, prims: &[Primitive], config: &BvhConfig) {
    let mut sorted = bvh.indices().to_vec();
    sorted.sort_unstable();
    assert_eq!(
        sorted,
        all_ids(prims),
        "{config}: indices not a permutation"
    );
    let tol = 1e-6;
    walk(bvh, config.leaf_size, |node, range| {
        let mut content = Aabb::EMPTY;
        for &id in &bvh.indices()[range] {
            for v in vertices(&prims[id as usize]) {
                assert!(
                    node.volume.contains(v, tol),
                    "{config}: {v} outside {:?}",
                    node.volume
                );
                content = content.include(v);
            }
        }
        if bvh.options().fit == Fit::Box {
            for i in 0..8 {
                let corner = content.corner(i);
                assert!(
                    node.volume.contains(corner, tol),
                    "{config}: corner {corner} outside {:?}",
                    node.volume
                );
            }
        }
    });
}

fn check_accelerator_structure(accel: &Accelerator, prims: &[Primitive], config: &BvhConfig) {
    match accel {
        Accelerator::BvhAabb(b, _) => check_structure(b, prims, config),
        Accelerator::BvhSphere(b, _) => check_structure(b, prims, config),
        Accelerator::BvhEllipsoid(b, _) => check_structure(b, prims, config),
        _ => unreachable!("a BVH was built"),
    }
}

/// Every volume × builder against brute force on one mesh; prints a table
/// of speed and per-ray counts (run with `--nocapture` to see it).
fn agree_with_brute_force(relative: &str, seed: u64) {
    let case = brute_case(relative, seed);
    let (prims, rays, truth) = (&case.prims[..], &case.rays[..], &case.truth[..]);
    let brute_seconds = case.brute_seconds;
    let hits = truth.iter().filter(|h| h.is_some()).count();
    println!(
        "{relative}: {} triangles, {} rays, {hits} hit; brute force {brute_seconds:.2} s on {} threads",
        prims.len(),
        rays.len(),
        rayon::current_num_threads()
    );
    println!(
        "{:<26} {:>8} {:>9} {:>7} {:>7} {:>7} {:>6} {:>6} {:>5}",
        "variant", "build ms", "ms/1e5", "nodes", "bv", "tris", "sah", "area", "ties"
    );
    assert!(hits > rays.len() / 4, "too few hits to test anything");

    for config in BvhConfig::all() {
        let accel = Accelerator::build(AccelKind::Bvh(config), prims, all_ids(prims)).unwrap();
        assert_eq!(accel.kind(), AccelKind::Bvh(config));
        check_accelerator_structure(&accel, prims, &config);
        check_against_brute_force(&accel, prims, rays, truth);
    }
    // The wide trees (packet leaves, the 4- and 8-lane node tests).
    for kind in [AccelKind::Bvh4, AccelKind::Bvh8] {
        let wide = Accelerator::build(kind, prims, all_ids(prims)).unwrap();
        assert_eq!(wide.kind(), kind);
        check_against_brute_force(&wide, prims, rays, truth);
    }
}

/// Every closest hit of `accel` is brute force's (the same triangle at the
/// bit-identical t, or another triangle at the same t within 10⁻⁶ relative:
/// a tie at a shared edge or a duplicate face), any-hit agrees with
/// closest-hit, and a line of timings and per-ray counts is printed.
fn check_against_brute_force(
    accel: &Accelerator,
    prims: &[Primitive],
    rays: &[PreparedRay],
    truth: &[Option<(u32, f32)>],
) {
    let config = accel.kind();
    let stats = accel.bvh_stats(prims).unwrap_or_default();
    {
        // Timed pass, one thread, no counting.
        let start = Instant::now();
        let found: Vec<_> = rays
            .iter()
            .map(|r| accel.intersect(prims, r, f32::INFINITY, &mut NoStats))
            .collect();
        let seconds = start.elapsed().as_secs_f64();

        let mut ties = 0;
        for (i, (got, want)) in found.iter().zip(truth).enumerate() {
            let r = &rays[i];
            match (got, want) {
                (None, None) => {}
                (Some((id, h)), Some((want_id, want_t))) if id == want_id => {
                    assert_eq!(
                        h.t.to_bits(),
                        want_t.to_bits(),
                        "{config} ray {i}: same triangle {id}, t {} vs {want_t}",
                        h.t
                    );
                }
                (Some((id, h)), Some((want_id, want_t))) => {
                    let again = prims[*id as usize].intersect(r, f32::INFINITY, &mut NoStats);
                    assert!(
                        (h.t - want_t).abs() <= 1e-6 * want_t && again.map(|a| a.t) == Some(h.t),
                        "{config} ray {i} {:?}: triangle {id} at t {} but brute force \
                         found {want_id} at {want_t}",
                        r.ray,
                        h.t
                    );
                    ties += 1;
                }
                _ => panic!("{config} ray {i} {:?}: {got:?} vs {want:?}", r.ray),
            }
        }

        // Any-hit agrees with closest-hit. With t_max just short of the
        // closest t nothing may block, just beyond it something must; the
        // 10⁻⁵ margin is because the triangle test compares t against t_max
        // in scaled form (t·det against t_max·det), whose rounding (~ε) can
        // move a hit at exactly t_max across the boundary.
        let occlusion_ok = rays.par_iter().zip(truth).all(|(r, want)| {
            let mut s = NoStats;
            let blocked = accel.occluded(prims, r, f32::INFINITY, &mut s);
            blocked == want.is_some()
                && want.is_none_or(|(_, t)| {
                    !accel.occluded(prims, r, t * (1.0 - 1e-5), &mut s)
                        && accel.occluded(prims, r, t * (1.0 + 1e-5), &mut s)
                })
        });
        assert!(occlusion_ok, "{config}: occluded disagrees with intersect");

        // Per-ray costs, on every 10th ray (10⁴ rays put the means within
        // about 1 %, and the counting pass is not free).
        let mut c = Counters::default();
        let sample: Vec<_> = rays.iter().step_by(10).collect();
        for r in &sample {
            accel.intersect(prims, r, f32::INFINITY, &mut c);
        }
        let per_ray = |n: u64| n as f64 / sample.len() as f64;
        println!(
            "{:<26} {:>8.1} {:>9.1} {:>7.1} {:>7.1} {:>7.1} {:>6.1} {:>6.2} {:>5}",
            config.to_string(),
            stats.build_seconds * 1e3,
            seconds * 1e3 * 1e5 / rays.len() as f64,
            per_ray(c.nodes_visited),
            per_ray(c.bounding_volume_tests()),
            per_ray(c.triangle_tests),
            stats.sah_cost,
            stats.mean_area_ratio,
            ties
        );
    }
}

#[test]
fn bvhs_agree_with_brute_force_on_camel() {
    agree_with_brute_force("cgal/camel.off", 1);
}

#[test]
fn bvhs_agree_with_brute_force_on_chinese_dragon() {
    agree_with_brute_force("cgal/ChineseDragon-10kv.off", 2);
}

#[test]
fn bvhs_agree_with_brute_force_on_wuson() {
    agree_with_brute_force("assimp/PLY/Wuson.ply", 3);
}

/// Two unit triangles in the planes x = 0 and x = 100, leaf size 1, so
/// every tree is a root with two leaves. Triangle A covers (y, z) in
/// (0,−1,−1), (0,1,−1), (0,0,1); B covers (100,−1,−1), (100,1,−1),
/// (100,1,1). The rays are chosen so that the answer is the same for boxes,
/// spheres and ellipsoids with either fit and builder.
#[test]
fn test_counts_on_a_hand_built_scene() {
    let prims = vec![
        triangle(
            Vec3::new(0.0, -1.0, -1.0),
            Vec3::new(0.0, 1.0, -1.0),
            Vec3::new(0.0, 0.0, 1.0),
        ),
        triangle(
            Vec3::new(100.0, -1.0, -1.0),
            Vec3::new(100.0, 1.0, -1.0),
            Vec3::new(100.0, 1.0, 1.0),
        ),
    ];
    struct Case {
        origin: Vec3,
        dir: Vec3,
        t_max: f32,
        /// Expected (hit primitive, node visits, volume tests, triangle
        /// tests) for the closest-hit query.
        expect: (Option<u32>, u64, u64, u64),
    }
    let cases = [
        // Along +x through A, then B: root test, visit root, test both
        // children (A entered at t = 10, B at 110), visit A, hit it at 10;
        // B's entry 110 > 10, so B is dropped when popped.
        Case {
            origin: Vec3::new(-10.0, 0.0, 0.0),
            dir: Vec3::X,
            t_max: f32::INFINITY,
            expect: (Some(0), 2, 3, 1),
        },
        // The same the other way: B first.
        Case {
            origin: Vec3::new(200.0, 0.0, 0.0),
            dir: -Vec3::X,
            t_max: f32::INFINITY,
            expect: (Some(1), 2, 3, 1),
        },
        // Through A's volume but beside triangle A (y = 0.9 > 0.25 at
        // z = 0.5), then through B: both leaves visited, 2 triangle tests.
        Case {
            origin: Vec3::new(-10.0, 0.9, 0.5),
            dir: Vec3::X,
            t_max: f32::INFINITY,
            expect: (Some(1), 3, 3, 2),
        },
        // Starts inside the root volume, between the leaves, going +y:
        // misses both children.
        Case {
            origin: Vec3::new(50.0, 0.0, 0.0),
            dir: Vec3::Y,
            t_max: f32::INFINITY,
            expect: (None, 1, 3, 0),
        },
        // Misses the root volume.
        Case {
            origin: Vec3::new(50.0, 100.0, 0.0),
            dir: Vec3::Y,
            t_max: f32::INFINITY,
            expect: (None, 0, 1, 0),
        },
        // Ends (t_max = 5) before reaching the root volume (the box is
        // entered at t = 100, the sphere at ≈ 99.98, the ellipsoid, which
        // reaches x = 50 − 50√3 ≈ −36.6, at ≈ 63.4).
        Case {
            origin: Vec3::new(-100.0, 0.0, 0.0),
            dir: Vec3::X,
            t_max: 5.0,
            expect: (None, 0, 1, 0),
        },
    ];
    for volume in VolumeKind::ALL {
        for builder in Builder::ALL {
            let config = BvhConfig {
                volume,
                builder,
                leaf_size: 1,
            };
            let accel = Accelerator::build(AccelKind::Bvh(config), &prims, vec![0, 1]).unwrap();
            let stats = accel.bvh_stats(&prims).unwrap();
            assert_eq!((stats.nodes, stats.leaves, stats.max_depth), (3, 2, 1));
            for (k, case) in cases.iter().enumerate() {
                let ray = PreparedRay::new(Ray::new(case.origin, case.dir));
                let mut c = Counters::default();
                let hit = accel.intersect(&prims, &ray, case.t_max, &mut c);
                let volume_tests = match volume {
                    VolumeKind::Aabb => c.box_tests,
                    VolumeKind::Sphere | VolumeKind::SphereRitter => c.bounding_sphere_tests,
                    VolumeKind::Ellipsoid | VolumeKind::EllipsoidRitter => {
                        c.bounding_ellipsoid_tests
                    }
                };
                assert_eq!(
                    c.bounding_volume_tests(),
                    volume_tests,
                    "{config}: wrong kind of volume test counted"
                );
                let got = (
                    hit.map(|(id, _)| id),
                    c.nodes_visited,
                    volume_tests,
                    c.triangle_tests,
                );
                assert_eq!(got, case.expect, "{config}, case {k}");
                let blocked = accel.occluded(&prims, &ray, case.t_max, &mut NoStats);
                assert_eq!(blocked, hit.is_some(), "{config}, case {k}");
            }
        }
    }
    // The 4-wide tree of the same two leaves is one wide node with two
    // children: the root box test, then the same visits and tests as the
    // binary box tree.
    let options = BvhConfig {
        volume: VolumeKind::Aabb,
        builder: Builder::Sah,
        leaf_size: 1,
    }
    .options();
    let wide4 = Bvh4::build(&prims, vec![0, 1], options);
    let wide8 = Bvh8::build(&prims, vec![0, 1], options);
    assert_eq!(wide4.nodes().len(), 1);
    assert_eq!(wide8.nodes().len(), 1);
    let trees = [
        ("bvh4", Accelerator::Bvh4(wide4)),
        ("bvh8", Accelerator::Bvh8(wide8)),
    ];
    for (name, tree) in trees {
        for (k, case) in cases.iter().enumerate() {
            let ray = PreparedRay::new(Ray::new(case.origin, case.dir));
            let mut c = Counters::default();
            let hit = tree
                .intersect(&prims, &ray, case.t_max, &mut c)
                .map(|h| h.0);
            let got = (hit, c.nodes_visited, c.box_tests, c.triangle_tests);
            assert_eq!(got, case.expect, "{name}, case {k}");
            assert_eq!(c.bounding_volume_tests(), c.box_tests);
        }
    }
}

#[test]
fn degenerate_inputs_build_and_answer() {
    let ray = PreparedRay::new(Ray::new(Vec3::new(0.5, 0.25, 5.0), -Vec3::Z));
    let tri = triangle(Vec3::ZERO, Vec3::X, Vec3::Y);
    let point = triangle(Vec3::ONE, Vec3::ONE, Vec3::ONE);
    for config in BvhConfig::all() {
        let kind = AccelKind::Bvh(config);
        // No primitives.
        let empty = Accelerator::build(kind, &[], vec![]).unwrap();
        assert!(empty
            .intersect(&[], &ray, f32::INFINITY, &mut NoStats)
            .is_none());
        assert_eq!(empty.bvh_stats(&[]).unwrap().nodes, 0);
        // One primitive: a root leaf.
        let one = Accelerator::build(kind, &[tri], vec![0]).unwrap();
        assert_eq!(one.bvh_stats(&[tri]).unwrap().nodes, 1);
        assert!(one.occluded(&[tri], &ray, f32::INFINITY, &mut NoStats));
        // 50 copies of one triangle plus 50 zero-area triangles at one
        // point: every centroid of each group coincides, so no split can
        // separate them by position; the builders must still terminate with
        // leaves within the limit and find the triangle.
        let mut many = vec![tri; 50];
        many.extend(std::iter::repeat_n(point, 50));
        let accel = Accelerator::build(kind, &many, all_ids(&many)).unwrap();
        check_accelerator_structure(&accel, &many, &config);
        let hit = accel.intersect(&many, &ray, f32::INFINITY, &mut NoStats);
        assert!(hit.is_some_and(|(id, h)| id < 50 && (h.t - 5.0).abs() < 1e-6));
    }
    // The same inputs for the wide trees (packet leaves: the zero-area
    // triangles take the exact f64 path of the triangle test).
    for kind in [AccelKind::Bvh4, AccelKind::Bvh8] {
        let empty = Accelerator::build(kind, &[], vec![]).unwrap();
        assert!(empty
            .intersect(&[], &ray, f32::INFINITY, &mut NoStats)
            .is_none());
        assert!(!empty.occluded(&[], &ray, f32::INFINITY, &mut NoStats));
        let one = Accelerator::build(kind, &[tri], vec![0]).unwrap();
        assert!(one.occluded(&[tri], &ray, f32::INFINITY, &mut NoStats));
        assert!(one
            .intersect(&[tri], &ray, f32::INFINITY, &mut NoStats)
            .is_some_and(|(id, h)| id == 0 && (h.t - 5.0).abs() < 1e-6));
        let mut many = vec![tri; 50];
        many.extend(std::iter::repeat_n(point, 50));
        let accel = Accelerator::build(kind, &many, all_ids(&many)).unwrap();
        let hit = accel.intersect(&many, &ray, f32::INFINITY, &mut NoStats);
        assert!(hit.is_some_and(|(id, h)| id < 50 && (h.t - 5.0).abs() < 1e-6));
        assert!(accel.occluded(&many, &ray, f32::INFINITY, &mut NoStats));
    }
}

#[test]
fn names_parse_and_print() {
    let parse = |s: &str| s.parse::<AccelKind>();
    // Plain `bvh` is the fastest tree; the binary box tree keeps its names.
    assert_eq!(parse("bvh"), Ok(AccelKind::Bvh8));
    let default = AccelKind::Bvh(BvhConfig::default());
    assert_eq!(parse("bvh2"), Ok(default));
    assert_eq!(parse("bvh:aabb:sah"), Ok(default));
    assert!("bvh".parse::<BvhConfig>().is_err());
    assert_eq!(default.to_string(), "bvh:aabb:sah");
    for wide in [AccelKind::Bvh4, AccelKind::Bvh8] {
        assert_eq!(parse(&wide.to_string()), Ok(wide));
    }
    let c = BvhConfig {
        volume: VolumeKind::SphereRitter,
        builder: Builder::S3,
        leaf_size: 8,
    };
    assert_eq!(parse("bvh:sphere-ritter:s3:8"), Ok(AccelKind::Bvh(c)));
    for config in BvhConfig::all() {
        assert_eq!(parse(&config.to_string()), Ok(AccelKind::Bvh(config)));
        assert_eq!(config.leaf_size, DEFAULT_LEAF_SIZE);
    }
    for bad in [
        "bvh:box",
        "bvh:aabb:midpoint",
        "bvh:aabb:sah:0",
        "bvh:aabb:sah:4:x",
        "bvhx",
    ] {
        let err = parse(bad).unwrap_err();
        assert!(err.to_string().contains("bvh:<volume>"), "{bad}: {err}");
    }
    assert_eq!(parse("brute"), Ok(AccelKind::Brute));
}

/// The 8-wide tree of a room: each wall of the Cornell box gets a leaf of
/// its own, so a ray leaving a wall does not start inside a room-sized
/// leaf of several walls and test its packet. Without the collapse's term
/// for rays born on the surfaces (`surface_origins` 0) one leaf holds
/// several walls, and rays leaving the walls test more triangles: this is
/// what the term is for (module `collapse`).
#[test]
fn a_rooms_walls_get_leaves_of_their_own() {
    let path = raylab_testkit::repo().join("data/scenes/cornell-box.toml");
    let scene = load_scene(&path, &Overrides::default()).unwrap();
    let prims = &scene.prims;
    // The file's first ten triangles are the floor, ceiling, back, left
    // and right walls, two each: each pair spans one face of the room.
    let room = Aabb {
        min: Vec3::new(-1.0, 0.0, -1.0),
        max: Vec3::new(1.0, 2.0, 1.0),
    };
    // Per wall: its axis and its inward normal; the room's face it lies in.
    let walls = [
        (1, Vec3::Y),
        (1, -Vec3::Y),
        (2, Vec3::Z),
        (0, Vec3::X),
        (0, -Vec3::X),
    ];
    let face = |a: usize, n: Vec3| if n[a] > 0.0 { room.min } else { room.max };
    for (w, &(a, n)) in walls.iter().enumerate() {
        let b = prims[2 * w]
            .bounds()
            .unwrap()
            .union(prims[2 * w + 1].bounds().unwrap());
        let face = face(a, n);
        assert!(b.min[a] == face[a] && b.max[a] == face[a], "wall {w}");
        let other = |k: usize| b.min[k] == room.min[k] && b.max[k] == room.max[k];
        assert!((0..3).filter(|&k| k != a).all(other), "wall {w}");
    }
    // The most walls any leaf holds.
    let walls_in_a_leaf = |t: &Bvh8| {
        let mut stack = vec![t.root()];
        let mut most = 0;
        while let Some((first, count)) = stack.pop() {
            if count > 0 {
                let mut walls: Vec<u32> = t
                    .leaf_slots(first, count)
                    .map(|j| t.indices()[j as usize])
                    .filter(|&id| id < 10)
                    .map(|id| id / 2)
                    .collect();
                walls.sort_unstable();
                walls.dedup();
                most = most.max(walls.len());
                continue;
            }
            let n = &t.nodes()[first as usize];
            for i in (0..8).filter(|&i| n.count[i] != u32::MAX) {
                stack.push((n.first[i], n.count[i]));
            }
        }
        most
    };
    // Triangle tests of rays leaving the walls into the room, from just
    // off their surface.
    let tests = |t: &Bvh8| {
        let mut rng = raylab::math::SplitMix64(7);
        let mut c = Counters::default();
        for k in 0..5000 {
            let (a, n) = walls[k % 5];
            let face = face(a, n);
            let mut o = room.min
                + (room.max - room.min) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            o[a] = face[a];
            let d = Vec3::new(
                rng.next_f32() - 0.5,
                rng.next_f32() - 0.5,
                rng.next_f32() - 0.5,
            );
            let d = if d.dot(n) < 0.0 { -d } else { d };
            let ray = PreparedRay::new(Ray::new(o + 1e-4 * n, d.normalize()));
            t.intersect(prims, &ray, f32::INFINITY, &mut c);
        }
        c.triangle_tests
    };
    let ids = all_ids(prims);
    let wide = Bvh8::build(prims, ids.clone(), BuildOptions::wide());
    let plain = BuildOptions {
        surface_origins: 0.0,
        ..BuildOptions::wide()
    };
    let plain = Bvh8::build(prims, ids, plain);
    assert_eq!(walls_in_a_leaf(&wide), 1);
    assert!(walls_in_a_leaf(&plain) > 1);
    let (t_wide, t_plain) = (tests(&wide), tests(&plain));
    assert!(
        t_wide < t_plain,
        "{t_wide} against {t_plain} triangle tests"
    );
}
