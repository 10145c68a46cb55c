//! Embree 4 against raylab's own intersection code (through brute force,
//! which tests every primitive): a real mesh (CGAL's camel, installed by
//! `scripts/fetch-data`), spheres and rotated ellipsoids.
//!
//! The two sides share no arithmetic: Embree holds its own copy of the
//! geometry in its own primitives (triangle mesh, sphere points, instances
//! of a unit sphere) and intersects it with its own code. So exact equality
//! is not expected, only agreement within rounding, and hit/miss may differ
//! where rounding decides it: for a ray through (or within rounding of) a
//! triangle edge, or tangent to a quadric. Each test says which rays count
//! as such and bounds how many there may be.

#![cfg(feature = "embree")]

use raylab::accel::embree::{
    enable_ftz_daz, ftz_daz_enabled, BuildQuality, EmbreeAccel, EmbreeConfig,
};
use raylab::accel::{Accel, Brute};
use raylab::io::read_mesh;
use raylab::math::{rotation_xyz_degrees, Ray, Vec3};
use raylab::shape::{Bounds, Ellipsoid, PreparedRay, PrimHit, Primitive, Shape, Sphere, Triangle};
use raylab::stats::NoStats;
use rayon::prelude::*;
use std::path::Path;

mod common;
use common::SplitMix64;

fn prim(shape: Shape) -> Primitive {
    Primitive { shape, object: 0 }
}

fn all(prims: &[Primitive]) -> Vec<u32> {
    (0..prims.len() as u32).collect()
}

fn bounds(prims: &[Primitive]) -> Bounds {
    prims
        .iter()
        .filter_map(Primitive::bounds)
        .fold(Bounds::EMPTY, Bounds::union)
}

/// Half the rays come from a sphere around the scene, half start at a
/// random point inside its bounds (so some start inside closed shapes).
/// Each is aimed at a point from `target`. Directions are not normalised: t
/// is in units of the direction, on both sides alike.
fn random_rays(
    b: &Bounds,
    n: usize,
    seed: u64,
    mut target: impl FnMut(&mut SplitMix64) -> Vec3,
) -> Vec<Ray> {
    let mut rng = SplitMix64(seed);
    let radius = b.extent().length();
    (0..n)
        .map(|i| {
            let origin = if i % 2 == 0 {
                b.centre() + radius * rng.unit_vector()
            } else {
                rng.in_box(b)
            };
            let scale = rng.range(0.5, 2.0);
            Ray::new(origin, scale * (target(&mut rng) - origin))
        })
        .collect()
}

/// A uniformly random point of a random triangle of the list.
fn on_triangles(prims: &[Primitive]) -> impl FnMut(&mut SplitMix64) -> Vec3 + '_ {
    move |rng| {
        let i = (rng.next_u64() % prims.len() as u64) as usize;
        let Shape::Triangle(t) = &prims[i].shape else {
            unreachable!("triangles only")
        };
        // Folding the unit square onto the triangle keeps it uniform.
        let (mut u, mut v) = (rng.next_f32(), rng.next_f32());
        if u + v > 1.0 {
            (u, v) = (1.0 - u, 1.0 - v);
        }
        (1.0 - u - v) * t.p[0] + u * t.p[1] + v * t.p[2]
    }
}

/// Angle between two unit vectors in radians, accurate for small angles
/// (atan2 of sine and cosine rather than acos of the dot product).
fn angle(a: Vec3, b: Vec3) -> f32 {
    a.cross(b).length().atan2(a.dot(b))
}

/// Raylab's closest hit over every primitive.
fn brute_hits(prims: &[Primitive], rays: &[Ray], t_max: f32) -> Vec<Option<(u32, PrimHit)>> {
    let brute = Brute::new(all(prims));
    rays.par_iter()
        .map(|r| brute.intersect(prims, &PreparedRay::new(*r), t_max, &mut NoStats))
        .collect()
}

fn embree_hits(
    accel: &EmbreeAccel,
    prims: &[Primitive],
    rays: &[Ray],
    t_max: f32,
) -> Vec<Option<(u32, PrimHit)>> {
    rays.par_iter()
        .map(|r| accel.intersect(prims, &PreparedRay::new(*r), t_max, &mut NoStats))
        .collect()
}

fn camel() -> Vec<Primitive> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/external");
    assert!(
        root.join(".complete").is_file(),
        "{} is missing or incomplete: run scripts/fetch-data (make test does)",
        root.display()
    );
    let mesh = read_mesh(&root.join("cgal/camel.off")).expect("camel.off reads");
    mesh.triangles
        .iter()
        .map(|t| {
            let p = t.map(|i| mesh.positions[i as usize]);
            prim(Shape::Triangle(Triangle::new(p[0], p[1], p[2])))
        })
        .collect()
}

/// The tolerance on t asked of both sides: 10⁻⁵ relative is ~80 ulps of
/// f32, room for two different formulas (raylab's watertight shear test or
/// stable quadratic, Embree's own) each rounding a handful of times, while
/// any real mistake (wrong root, wrong primitive, wrong transform) is off
/// by far more.
const T_REL: f32 = 1e-5;

/// Below this cosine between ray and surface normal a hit is grazing: t is
/// then ill-conditioned, its rounding error growing like 1/cos θ (a small
/// tilt of the computed plane moves a grazing hit far along the ray;
/// checked in exact arithmetic for a camel ray at cos θ = 5.6·10⁻⁴, where
/// raylab's t is off by 3·10⁻⁶ relative and Embree's by 4·10⁻⁵). Grazing
/// hits get a tolerance scaled by GRAZING/cos θ; above it the amplification
/// is at most 20, which keeps a handful of ε under T_REL.
const GRAZING: f32 = 0.05;

/// |cos θ| between the ray and the outward normal at raylab's hit.
fn incidence(prims: &[Primitive], ray: &Ray, p: u32, h: &PrimHit) -> f32 {
    prims[p as usize]
        .outward_normal(ray, h)
        .dot(ray.dir.normalize())
        .abs()
}

/// The largest difference in t accepted between two hits of the same
/// primitive: T_REL relative, but never below 16 ulps of the coordinates
/// involved (origin and hit point), and both scaled up for grazing hits. A
/// ray that starts almost on a surface has a tiny t computed from
/// coordinates of order 1 to 10, each rounded to ~10⁻⁷ of its size: that
/// relative error says nothing about either algorithm.
fn t_tolerance(ray: &Ray, h: &PrimHit, cos: f32) -> f32 {
    let grazing = (GRAZING / cos).max(1.0);
    let scale = ray.origin.length() + ray.at(h.t).length();
    let floor = 16.0 * f32::EPSILON * scale / ray.dir.length();
    (T_REL * h.t).max(floor) * grazing
}

/// How a set of rays fared on both sides.
#[derive(Default, Debug)]
struct Tally {
    both_miss: usize,
    /// Both hit the same primitive (t, u, v compared).
    same: usize,
    /// Of those, grazing hits (cos θ < GRAZING).
    grazing: usize,
    /// Different primitives at the same t (a shared edge or vertex).
    tie: usize,
    /// Hit/miss or primitive decided by rounding: the first hit is at an
    /// edge or grazing.
    borderline: usize,
    /// Largest |Δt| / tolerance over same-primitive hits (≤ 1 passes).
    worst_t: f32,
    /// Largest relative |Δt| over non-grazing hits above the floor, for
    /// the record.
    max_t_rel: f32,
    /// Largest distance between the points the two sides' barycentrics
    /// name, over the t tolerance as a distance (≤ 1 passes).
    worst_uv: f32,
    /// Largest angle between the two sides' normals (quadrics).
    max_normal_angle: f32,
    /// Disagreements that are not borderline: must stay empty.
    bad: Vec<String>,
}

impl Tally {
    fn hits(&self) -> usize {
        self.same + self.tie + self.borderline
    }

    /// The numbers, without the list of failures.
    fn summary(&self) -> String {
        format!(
            "{} same-primitive hits ({} grazing), {} misses, {} ties, {} borderline; \
             worst Δt/tolerance {:.3}, max relative Δt {:.2e}, worst Δ(u,v)/tolerance {:.3}, \
             max normal angle {:.2e} rad; {} bad",
            self.same,
            self.grazing,
            self.both_miss,
            self.tie,
            self.borderline,
            self.worst_t,
            self.max_t_rel,
            self.worst_uv,
            self.max_normal_angle,
            self.bad.len()
        )
    }
}

/// The point (1−u−v)·p0 + u·p1 + v·p2 of a triangle.
fn barycentric_point(t: &Triangle, h: &PrimHit) -> Vec3 {
    (1.0 - h.u - h.v) * t.p[0] + h.u * t.p[1] + h.v * t.p[2]
}

/// World distance from a triangle hit to the nearest edge: each
/// barycentric times the height over the edge it measures from.
fn edge_gap(t: &Triangle, h: &PrimHit) -> f32 {
    let twice_area = 2.0 * t.area();
    let height = |a: Vec3, b: Vec3| twice_area / (b - a).length();
    let w = 1.0 - h.u - h.v;
    (w * height(t.p[1], t.p[2]))
        .min(h.u * height(t.p[2], t.p[0]))
        .min(h.v * height(t.p[0], t.p[1]))
}

/// Whether rounding may decide a hit: grazing, or (triangles) within ten
/// t tolerances, as a distance, of an edge. Ten: the two sides' hit points
/// differ by at most one tolerance where the test passes, and an edge
/// decision is made from the same rounded quantities.
fn borderline(prims: &[Primitive], ray: &Ray, p: u32, h: &PrimHit) -> bool {
    let cos = incidence(prims, ray, p, h);
    cos < GRAZING
        || match &prims[p as usize].shape {
            Shape::Triangle(t) => {
                edge_gap(t, h) < 10.0 * t_tolerance(ray, h, cos) * ray.dir.length()
            }
            _ => false,
        }
}

/// Compare raylab's and Embree's closest hits ray by ray.
fn compare(
    prims: &[Primitive],
    rays: &[Ray],
    ours: &[Option<(u32, PrimHit)>],
    theirs: &[Option<(u32, PrimHit)>],
) -> Tally {
    let mut tally = Tally::default();
    for (i, ((a, b), ray)) in ours.iter().zip(theirs).zip(rays).enumerate() {
        match (a, b) {
            (None, None) => tally.both_miss += 1,
            (Some((pa, ha)), Some((pb, hb))) if pa == pb => {
                tally.same += 1;
                let cos = incidence(prims, ray, *pa, ha);
                let tol = t_tolerance(ray, ha, cos);
                let ratio = (hb.t - ha.t).abs() / tol;
                tally.worst_t = tally.worst_t.max(ratio);
                if cos < GRAZING {
                    tally.grazing += 1;
                } else if T_REL * ha.t >= tol {
                    tally.max_t_rel = tally.max_t_rel.max((hb.t - ha.t).abs() / ha.t);
                }
                // Embree's u, v must be raylab's barycentrics (of vertices 1
                // and 2): the points they name agree as the hit points do.
                // A swapped or complemented convention is off by a good
                // part of the triangle.
                let uv_ratio = match &prims[*pa as usize].shape {
                    Shape::Triangle(t) => {
                        let gap = barycentric_point(t, ha).distance(barycentric_point(t, hb));
                        gap / (tol * ray.dir.length())
                    }
                    // Quadrics report no surface coordinates on either side.
                    _ => {
                        if (ha.u, ha.v) == (hb.u, hb.v) {
                            0.0
                        } else {
                            f32::INFINITY
                        }
                    }
                };
                tally.worst_uv = tally.worst_uv.max(uv_ratio);
                if ratio > 1.0 || uv_ratio > 1.0 {
                    tally.bad.push(format!(
                        "ray {i} {ray:?}: raylab {ha:?} vs Embree {hb:?}, cos θ {cos:.2e}"
                    ));
                }
            }
            (Some((pa, ha)), Some((_, hb)))
                if (hb.t - ha.t).abs() <= t_tolerance(ray, ha, incidence(prims, ray, *pa, ha)) =>
            {
                tally.tie += 1
            }
            _ => {
                // The first hit decides: the other side missed it. It must
                // be one that rounding can take or give.
                let first = match (a, b) {
                    (Some(x), Some(y)) => Some(if x.1.t < y.1.t { x } else { y }),
                    (Some(x), None) | (None, Some(x)) => Some(x),
                    (None, None) => None,
                };
                match first {
                    Some((p, h)) if borderline(prims, ray, *p, h) => tally.borderline += 1,
                    _ => tally
                        .bad
                        .push(format!("ray {i} {ray:?}: raylab {a:?}, Embree {b:?}")),
                }
            }
        }
    }
    tally
}

/// Print the tally (visible with `--nocapture`) and assert what every
/// comparison must satisfy.
fn check(what: &str, tally: &Tally, rays: usize) {
    eprintln!("{what}: {}", tally.summary());
    let few = &tally.bad[..tally.bad.len().min(5)];
    assert!(
        tally.bad.is_empty(),
        "{what}: {}\n{few:#?}",
        tally.summary()
    );
    // The rays are aimed at the shapes: nearly all must hit, or the test
    // says little.
    assert!(tally.hits() * 10 > rays * 9, "{what}: {}", tally.summary());
    // Disagreements left to rounding stay rare: under 10⁻³ of the rays.
    assert!(
        (tally.tie + tally.borderline) * 1000 < rays,
        "{what}: {}",
        tally.summary()
    );
}

#[test]
fn camel_agrees_with_brute_force() {
    let prims = camel();
    let rays = random_rays(&bounds(&prims), 100_000, 1, on_triangles(&prims));
    let ours = brute_hits(&prims, &rays, f32::INFINITY);
    for config in [
        EmbreeConfig::default(),
        EmbreeConfig {
            quality: BuildQuality::High,
            robust: true,
        },
    ] {
        let accel = EmbreeAccel::build(&prims, &all(&prims), config).unwrap();
        let theirs = embree_hits(&accel, &prims, &rays, f32::INFINITY);
        let tally = compare(&prims, &rays, &ours, &theirs);
        check(&format!("camel, {config}"), &tally, rays.len());
    }
}

/// Random spheres (radius 0.2 to 2) or rotated ellipsoids (radii 0.5 to 2
/// each) in [−10, 10]³: they overlap now and then, so rays also cross from
/// one into another.
fn random_quadrics(n: usize, seed: u64, ellipsoids: bool) -> Vec<Primitive> {
    let mut rng = SplitMix64(seed);
    (0..n)
        .map(|_| {
            let c = Vec3::new(
                rng.range(-10.0, 10.0),
                rng.range(-10.0, 10.0),
                rng.range(-10.0, 10.0),
            );
            if ellipsoids {
                let radii = Vec3::new(
                    rng.range(0.5, 2.0),
                    rng.range(0.5, 2.0),
                    rng.range(0.5, 2.0),
                );
                let angles = Vec3::new(
                    rng.range(0.0, 360.0),
                    rng.range(0.0, 360.0),
                    rng.range(0.0, 360.0),
                );
                prim(Shape::Ellipsoid(Ellipsoid::new(
                    c,
                    radii,
                    rotation_xyz_degrees(angles),
                )))
            } else {
                prim(Shape::Sphere(Sphere::new(c, rng.range(0.2, 2.0))))
            }
        })
        .collect()
}

/// A random point inside a random one of the quadrics (a point of the
/// unit ball mapped by the shape's transform).
fn in_quadrics(prims: &[Primitive]) -> impl FnMut(&mut SplitMix64) -> Vec3 + '_ {
    move |rng| {
        let i = (rng.next_u64() % prims.len() as u64) as usize;
        let p = rng.unit_vector() * rng.next_f32().cbrt();
        match &prims[i].shape {
            Shape::Sphere(s) => s.centre + s.radius * p,
            Shape::Ellipsoid(e) => e.centre + e.from_unit() * p,
            _ => unreachable!("quadrics only"),
        }
    }
}

fn quadrics_agree(ellipsoids: bool) -> Tally {
    let prims = random_quadrics(300, 7, ellipsoids);
    let rays = random_rays(&bounds(&prims), 100_000, 11, in_quadrics(&prims));
    let ours = brute_hits(&prims, &rays, f32::INFINITY);
    let accel = EmbreeAccel::build(&prims, &all(&prims), EmbreeConfig::default()).unwrap();
    let theirs = embree_hits(&accel, &prims, &rays, f32::INFINITY);
    let mut tally = compare(&prims, &rays, &ours, &theirs);
    // Embree's own normal (its Ng, through the inverse transpose for an
    // ellipsoid) against raylab's `normal_at` the same point, Embree's hit:
    // evaluated at raylab's hit instead, the comparison would mostly
    // measure the difference in t times the curvature (up to r_max/r_min²
    // = 8 here). Not for grazing hits, where Embree's own Ng is computed
    // from an uncertain point.
    for (ray, ours) in rays.iter().zip(&ours) {
        let (Some((p, h)), Some(e)) = (ours, accel.trace(ray, f32::INFINITY)) else {
            continue;
        };
        if e.prim != *p || incidence(&prims, ray, *p, h) < GRAZING {
            continue;
        }
        let n = prims[*p as usize].outward_normal(ray, &e.hit);
        tally.max_normal_angle = tally.max_normal_angle.max(angle(n, e.normal));
    }
    let what = if ellipsoids { "ellipsoids" } else { "spheres" };
    check(what, &tally, rays.len());
    tally
}

/// Spheres: Embree's sphere points. Normals within 10⁻⁴ rad: both sides
/// derive them from f32 hit points with ~10⁻⁶ relative error over radii ≥
/// 0.2; a wrong centre or a missing normalisation is off by far more.
#[test]
fn spheres_agree_with_brute_force() {
    let tally = quadrics_agree(false);
    assert!(tally.max_normal_angle < 1e-4, "{}", tally.summary());
}

/// Rotated ellipsoids with three different radii: Embree sees instances of
/// its unit sphere under R·S and a translation. Normals within 10⁻⁴ rad; a
/// wrong normal transform (the transpose instead of the inverse transpose,
/// say) is off by tenths of a radian. Precision: Embree computes its
/// normal in the unit sphere's space, where the ray origin lies d/r_min
/// away (d its world distance, r_min the smallest radius), so its local
/// hit point is off by ~ε·d/r_min; mapped back to world space, the
/// normal's error grows by up to r_max/r_min. With radii 0.5 to 2 and
/// d ≤ 50 that is ≲ 6·10⁻⁸·100·4 ≈ 2.4·10⁻⁵. (Radii down to 0.2 reached
/// 9.9·10⁻⁵, as the formula predicts: a limit of f32 instancing, not of
/// either code.)
#[test]
fn ellipsoids_agree_with_brute_force() {
    let tally = quadrics_agree(true);
    assert!(tally.max_normal_angle < 1e-4, "{}", tally.summary());
}

/// From inside, raylab reports the exit point (its first root is behind
/// the origin): Embree must too, for spheres and ellipsoids alike.
#[test]
fn rays_from_inside_report_the_exit() {
    for ellipsoids in [false, true] {
        let prims = random_quadrics(50, 3, ellipsoids);
        let mut rng = SplitMix64(5);
        for (i, p) in prims.iter().enumerate() {
            let accel = EmbreeAccel::build(&prims, &[i as u32], EmbreeConfig::default()).unwrap();
            for _ in 0..200 {
                let origin = in_quadrics(&prims[i..=i])(&mut rng);
                let ray = Ray::new(origin, rng.unit_vector());
                let pr = PreparedRay::new(ray);
                let ours = p.intersect(&pr, f32::INFINITY, &mut NoStats).unwrap();
                let e = accel
                    .trace(&ray, f32::INFINITY)
                    .expect("a ray from inside hits");
                assert_eq!(e.prim, i as u32);
                let tol = t_tolerance(&ray, &ours, incidence(&prims, &ray, i as u32, &ours));
                assert!(
                    (e.hit.t - ours.t).abs() <= tol,
                    "{ray:?}: {} vs {}",
                    e.hit.t,
                    ours.t
                );
                // An exit: the outward normal points along the ray.
                assert!(e.normal.dot(ray.dir) > 0.0, "{ray:?}: {e:?}");
            }
        }
    }
}

/// A mixed scene (triangles, spheres, ellipsoids) with finite t_max:
/// closest hits and shadow-ray occlusion agree with brute force, and the
/// interval (0, t_max) is open at both ends on both sides.
#[test]
fn mixed_scene_with_finite_t_max() {
    let mut prims = random_quadrics(100, 21, false);
    prims.extend(random_quadrics(100, 22, true));
    let mut rng = SplitMix64(23);
    for _ in 0..300 {
        let a = Vec3::new(
            rng.range(-10.0, 10.0),
            rng.range(-10.0, 10.0),
            rng.range(-10.0, 10.0),
        );
        let b = a + Vec3::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        );
        let c = a + Vec3::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        );
        prims.push(prim(Shape::Triangle(Triangle::new(a, b, c))));
    }
    let ids = all(&prims);
    let brute = Brute::new(ids.clone());
    let accel = EmbreeAccel::build(&prims, &ids, EmbreeConfig::default()).unwrap();
    let rays = random_rays(&bounds(&prims), 20_000, 24, in_quadrics(&prims[..200]));
    let mut disagreements = 0;
    for (k, ray) in rays.iter().enumerate() {
        let pr = PreparedRay::new(*ray);
        // Segments of random length, as shadow rays to random lights.
        let t_max = rng.range(0.0, 1.5);
        let ours = brute.intersect(&prims, &pr, t_max, &mut NoStats);
        let theirs = accel.intersect(&prims, &pr, t_max, &mut NoStats);
        let blocked = brute.occluded(&prims, &pr, t_max, &mut NoStats);
        assert_eq!(
            accel.occluded(&prims, &pr, t_max, &mut NoStats),
            theirs.is_some(),
            "ray {k}"
        );
        match (ours, theirs) {
            (None, None) => assert!(!blocked, "ray {k}: occluded without a closest hit"),
            (Some((pa, ha)), Some((pb, hb))) if pa == pb => {
                assert!(blocked, "ray {k}: a closest hit but not occluded");
                let tol = t_tolerance(ray, &ha, incidence(&prims, ray, pa, &ha));
                assert!((ha.t - hb.t).abs() <= tol, "ray {k}: {ha:?} vs {hb:?}");
            }
            _ => {
                // Only a hit within rounding of t_max, of an edge or of a
                // silhouette may go either way.
                let first = match (ours, theirs) {
                    (Some(x), Some(y)) => Some(if x.1.t < y.1.t { x } else { y }),
                    (x, y) => x.or(y),
                };
                let ok = first.is_some_and(|(p, h)| {
                    let near_end = (h.t - t_max).abs() <= t_tolerance(ray, &h, 1.0);
                    near_end || borderline(&prims, ray, p, &h)
                });
                assert!(
                    ok,
                    "ray {k} {ray:?} t_max {t_max}: raylab {ours:?}, Embree {theirs:?}"
                );
                disagreements += 1;
            }
        }
    }
    assert!(
        disagreements * 1000 < rays.len(),
        "{disagreements} borderline disagreements"
    );
    // Exactly at t_max: not a hit (open interval), on either side.
    let ray = Ray::new(Vec3::new(0.0, 0.0, 0.0), Vec3::X);
    let unit = vec![prim(Shape::Sphere(Sphere::new(
        Vec3::new(3.0, 0.0, 0.0),
        1.0,
    )))];
    let accel = EmbreeAccel::build(&unit, &[0], EmbreeConfig::default()).unwrap();
    let pr = PreparedRay::new(ray);
    assert!(accel.intersect(&unit, &pr, 2.0, &mut NoStats).is_none());
    assert!(!accel.occluded(&unit, &pr, 2.0, &mut NoStats));
    assert!(accel.intersect(&unit, &pr, 2.0001, &mut NoStats).is_some());
}

/// Embree is called with FTZ/DAZ on (set around each call) and leaves the
/// caller's thread as it found it; results do not depend on whether the
/// caller turned the modes on for the whole thread.
#[test]
fn ftz_daz_is_scoped_to_embree_calls() {
    let prims = random_quadrics(50, 31, true);
    let accel = EmbreeAccel::build(&prims, &all(&prims), EmbreeConfig::default()).unwrap();
    let rays = random_rays(&bounds(&prims), 2_000, 32, in_quadrics(&prims));
    let trace = move |enable: bool| {
        std::thread::spawn(move || {
            if enable {
                enable_ftz_daz();
            }
            let hits: Vec<_> = rays.iter().map(|r| accel.trace(r, f32::INFINITY)).collect();
            (hits, ftz_daz_enabled())
        })
        .join()
        .unwrap()
    };
    let (plain, after_plain) = trace.clone()(false);
    let (flushed, after_flushed) = trace(true);
    assert!(!after_plain, "tracing must not leave FTZ/DAZ on");
    assert!(after_flushed, "tracing must not turn FTZ/DAZ off");
    assert_eq!(plain, flushed);
}
