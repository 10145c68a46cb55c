//! `raylab_lab::validate` on real meshes (CGAL's and assimp's test models) and
//! on quadrics: raylab's default BVH against Embree 4 over every ray set,
//! ≥ 10⁶ rays in all, with the acceptance criteria of the oracle:
//!
//! - no disagreement (hit/miss or primitive, closest hit or any-hit) away
//!   from edges, vertices and grazing hits;
//! - |Δt|/t ≤ 10⁻⁵ for same-primitive hits more than 1° from grazing
//!   (above the rounding floor of the coordinates: see
//!   `validate::compare::t_tolerance`);
//! - every edge or vertex disagreement attributed to the side that missed;
//! - normals within 10⁻⁴ rad (spheres and ellipsoids included), and rays
//!   from inside a quadric reporting the exit on both sides.

use raylab::accel::{AccelKind, BvhConfig};
use raylab_lab::validate::{
    random_quadrics, validate, HitPlace, Input, Outcome, Tally, ValidationOptions, ValidationReport,
};

use raylab_testkit::external;

/// Assert the acceptance criteria on every set of a report.
fn assert_accepted(report: &ValidationReport) {
    eprint!("{}", report.table());
    for s in &report.sets {
        let t: &Tally = &s.tally;
        let what = format!("{} {} ({})", report.input, s.set, s.accel);
        assert_eq!(t.unexplained(), 0, "{what}:\n{}", report.worst_text());
        assert_eq!(t.disagreements_at(HitPlace::Elsewhere), 0, "{what}");
        assert!(
            t.max_rel_dt_above_floor <= 1e-5,
            "{what}: max |Δt|/t {:e}",
            t.max_rel_dt_above_floor
        );
        let edge = t.disagreements_at(HitPlace::Edge) + t.disagreements_at(HitPlace::Vertex);
        assert_eq!(t.edge_leaks.0 + t.edge_leaks.1, edge, "{what}");
        // Normals: every angle within its bound (10⁻⁴, or a thin
        // triangle's conditioning bound) is checked by `unexplained`.
        assert_eq!(t.normal_breaches, 0, "{what}");
    }
    // The worst cases listed are those of the report: none breaks.
    let tol = raylab_lab::validate::Tolerances::default();
    assert!(report.worst.iter().all(|c| !c.verdict.breaks()));
    assert!(report.breaches(&tol).is_empty());
}

fn bvh_options(rays: usize, seed: u64) -> ValidationOptions {
    ValidationOptions {
        rays,
        seed,
        accels: vec![AccelKind::Bvh(BvhConfig::default())],
        ..ValidationOptions::default()
    }
}

/// Every CGAL and assimp mesh the tests read (and the armadillo, whose
/// seed 90217 once drew an inside origin lying on another part of its
/// surface), in four formats, closed and open, with three seeds each: 7
/// ray sets (6 for open meshes, which have no inside) of 28 000 rays per
/// seed, ≥ 5·10⁵ rays per mesh, 9·10⁶ in all. Zero unexplained
/// disagreements for any of them: a ray that starts on a surface is
/// classed apart (`HitPlace::Origin`), never unexplained.
#[test]
fn real_meshes_agree_with_embree() {
    let meshes: [(&str, [u64; 3]); 17] = [
        ("cgal/camel.off", [0, 101, 202]),
        ("cgal/ChineseDragon-10kv.off", [1, 102, 203]),
        ("cgal/elephant.off", [2, 103, 204]),
        ("cgal/armadillo.off", [90_217, 104, 205]),
        ("cgal/sphere.off", [4, 105, 206]),
        ("cgal/sphere.ply", [5, 106, 207]),
        ("cgal/cube-ouvert.off", [6, 107, 208]),
        ("assimp/PLY/Wuson.ply", [7, 108, 209]),
        ("assimp/PLY/cube.ply", [8, 109, 210]),
        ("assimp/PLY/cube_binary.ply", [9, 110, 211]),
        ("assimp/OFF/Wuson.off", [10, 111, 212]),
        ("assimp/OBJ/spider.obj", [11, 112, 213]),
        ("assimp/OBJ/WusonOBJ.obj", [12, 113, 214]),
        ("assimp/3DS/fels.3ds", [13, 114, 215]),
        ("assimp/3DS/test1.3ds", [14, 115, 216]),
        ("assimp/3DS/cubes_with_alpha.3DS", [15, 116, 217]),
        (
            "assimp/3DS/CameraRollAnimWithChildObject.3ds",
            [16, 117, 218],
        ),
    ];
    let mut total = 0;
    for (m, seeds) in meshes {
        let input = Input::from_mesh(&external(m)).unwrap();
        let mut rays = 0;
        for seed in seeds {
            let report = validate(&input, &bvh_options(28_000, seed)).unwrap();
            assert_accepted(&report);
            // Aimed sets must mostly hit, or they test little (on an open
            // mesh, rays at its boundary's edges and vertices may pass by:
            // 89 % of cube-ouvert's vertex rays hit).
            for s in &report.sets {
                if ["surface", "edges", "vertices", "grazing", "inside"].contains(&s.set) {
                    assert!(s.tally.hits() * 5 > s.tally.rays * 4, "{m} {}", s.set);
                }
            }
            rays += report.overall().rays;
        }
        assert!(rays >= 500_000, "{m}: {rays} rays");
        total += rays;
    }
    eprintln!("{total} rays over {} meshes", meshes.len());
}

/// Rays aimed exactly at edges and vertices of a closed mesh do disagree
/// now and then (Embree's default triangle test is not watertight), and
/// each such disagreement names the side that missed; raylab's watertight
/// test should leak far less often than Embree's.
#[test]
fn edge_disagreements_are_attributed() {
    let input = Input::from_mesh(&external("cgal/camel.off")).unwrap();
    let report = validate(&input, &bvh_options(20_000, 3)).unwrap();
    let edges = report.sets.iter().find(|s| s.set == "edges").unwrap();
    let t = &edges.tally;
    let borderline = t.disagreements_at(HitPlace::Edge) + t.disagreements_at(HitPlace::Vertex);
    assert!(borderline > 0, "no edge disagreement to attribute: {t:?}");
    assert_eq!(t.edge_leaks.0 + t.edge_leaks.1, borderline);
    assert!(t.edge_leaks.0 < t.edge_leaks.1, "{t:?}");
    // Every such case listed says who leaked.
    for c in report.worst.iter().filter(|c| {
        matches!(
            c.verdict.outcome,
            Outcome::Disagree {
                place: HitPlace::Edge | HitPlace::Vertex,
                ..
            }
        )
    }) {
        assert!(c.class().contains("leaked"), "{}", c.class());
    }
}

/// Spheres (radius 0.2 to 2) and ellipsoids (radii 0.5 to 2), brute
/// force and the BVH: rays from inside
/// (`inside-quadrics`) hit the same primitive on both sides, i.e. the exit
/// (the only hit ahead of an interior origin of a lone quadric, and the
/// nearest one of overlapping ones alike); normals within 10⁻⁴ rad. The
/// ellipsoid bound is argued in crates/lab/tests/embree.rs
/// (`ellipsoids_agree_with_brute_force`): ≲ 2.4·10⁻⁵ for these radii.
#[test]
fn quadrics_agree_with_embree() {
    for ellipsoids in [false, true] {
        let input = Input {
            name: if ellipsoids { "ellipsoids" } else { "spheres" }.into(),
            prims: random_quadrics(200, 5, ellipsoids),
            camera: None,
        };
        let opts = ValidationOptions {
            rays: 20_000,
            ..ValidationOptions::default()
        };
        let report = validate(&input, &opts).unwrap();
        assert_accepted(&report);
        let inside = report
            .sets
            .iter()
            .find(|s| s.set == "inside-quadrics")
            .expect("an inside-quadrics set");
        let t = &inside.tally;
        // From inside there is always a hit ahead, and both sides agree on it.
        assert_eq!(t.both_miss, 0);
        assert!(t.agree * 1000 >= t.rays * 999, "{t:?}");
    }
}

/// Closedness is decided from the mesh: every edge shared by exactly two
/// triangles. CGAL's camel is closed; its `cube-ouvert` (open cube) is not.
#[test]
fn closedness_comes_from_the_edges() {
    use raylab_lab::validate::Topology;
    let closed = Input::from_mesh(&external("cgal/camel.off")).unwrap();
    assert!(Topology::of(&closed.prims).is_closed());
    let open = Input::from_mesh(&external("cgal/cube-ouvert.off")).unwrap();
    let t = Topology::of(&open.prims);
    assert!(!t.is_closed());
    assert!(t.open_and_nonmanifold_edges().0 > 0);
}
