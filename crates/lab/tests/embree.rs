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

use raylab::accel::embree::{
    enable_ftz_daz, ftz_daz_enabled, BuildQuality, EmbreeAccel, EmbreeConfig,
};
use raylab::accel::{Accel, AccelKind, Accelerator, Brute};
use raylab::math::{Ray, Vec3};
use raylab::shape::{bounds_of, PreparedRay, Primitive, Shape, Sphere, Triangle};
use raylab::stats::NoStats;
use raylab_lab::validate::compare::{incidence, place, t_tolerance};
use raylab_lab::validate::rays::point_on;
use raylab_lab::validate::{
    compare_set, random_quadrics, HitPlace, Input, RaySet, SetComparison, SetReport, Tally,
    Tolerances, ValidationOptions, ValidationReport,
};

/// The default tolerances: |Δt|/t 10⁻⁵ beyond 1° from grazing, the
/// grazing band, normals 10⁻⁴ rad (argued in crates/lab/src/validate/mod.rs).
const TOL: Tolerances = Tolerances {
    t_rel: 1e-5,
    grazing_deg: 1.0,
    normal_angle: 1e-4,
    max_unexplained: 0,
    max_borderline: None,
};

use raylab_testkit::{external, SplitMix64};

fn prim(shape: Shape) -> Primitive {
    Primitive { shape, object: 0 }
}

fn all(prims: &[Primitive]) -> Vec<u32> {
    (0..prims.len() as u32).collect()
}

/// Half the rays come from a sphere around the scene, half start at a
/// random point inside its bounds (so some start inside closed shapes).
/// Each is aimed at a point of a random primitive (its surface for
/// triangles, its interior for quadrics). Directions are not normalised: t
/// is in units of the direction, on both sides alike.
fn random_rays(prims: &[Primitive], n: usize, seed: u64) -> Vec<Ray> {
    let b = bounds_of(prims);
    let mut rng = SplitMix64(seed);
    let radius = b.extent().length();
    (0..n)
        .map(|i| {
            let origin = if i % 2 == 0 {
                b.centre() + radius * rng.unit_vector()
            } else {
                rng.in_box(&b)
            };
            let p = &prims[rng.below(prims.len())];
            let target = point_on(&mut rng, p);
            let scale = rng.range(0.5, 2.0);
            Ray::new(origin, scale * (target - origin))
        })
        .collect()
}

fn camel() -> Vec<Primitive> {
    Input::from_mesh(&external("cgal/camel.off"))
        .expect("camel.off reads")
        .prims
}

/// Compare brute force with Embree (closest hit and any-hit) over `rays`
/// with the library's classification (crates/lab/src/validate/compare.rs).
fn compare(prims: &[Primitive], rays: Vec<Ray>, config: EmbreeConfig) -> Tally {
    let input = Input {
        name: "test".into(),
        prims: prims.to_vec(),
        camera: None,
    };
    let ids = all(prims);
    let accel = Accelerator::build(AccelKind::Brute, prims, ids.clone()).unwrap();
    let embree = EmbreeAccel::build(prims, &ids, config).unwrap();
    let opts = ValidationOptions {
        embree: config,
        worst: 5,
        // Brute-force any-hit over the camel would triple the cost;
        // `mixed_scene_with_finite_t_max` checks occlusion.
        any_hit: false,
        ..ValidationOptions::default()
    };
    let set = RaySet {
        name: "random",
        rays,
    };
    let SetComparison { report, worst } = compare_set(&input, &set, &accel, &embree, &opts);
    let t = report.tally;
    assert_eq!(
        t.unexplained(),
        0,
        "{}",
        ValidationReport {
            input: String::new(),
            primitives: prims.len(),
            triangles: 0,
            closed: false,
            embree: config.to_string(),
            sets: vec![SetReport {
                set: "random",
                accel: "brute".into(),
                tally: t.clone(),
            }],
            worst,
        }
        .worst_text()
    );
    t
}

/// Print the tally (visible with `--nocapture`) and assert what every
/// comparison must satisfy beyond "nothing unexplained" (checked by
/// [`compare`]).
fn check(what: &str, tally: &Tally) {
    let dt = tally.rel_dt_percentiles();
    eprintln!(
        "{what}: {} rays, {} hits, {} ties, {} borderline; |Δt|/t p50 {:.1e} p99 {:.1e} max {:.1e}; \
         max normal angle {:.1e}",
        tally.rays,
        tally.hits(),
        tally.tie_edge + tally.tie_coincident,
        tally.borderline(),
        dt[0],
        dt[1],
        dt[2],
        tally.normal_angle_percentiles()[2]
    );
    // The rays are aimed at the shapes: nearly all must hit, or the test
    // says little.
    assert!(tally.hits() * 10 > tally.rays * 9, "{what}: {tally:?}");
    // Disagreements left to rounding stay rare on random rays: under 10⁻³
    // of them.
    assert!(
        (tally.tie_edge + tally.tie_coincident + tally.borderline()) * 1000 < tally.rays,
        "{what}: {tally:?}"
    );
}

#[test]
fn camel_agrees_with_brute_force() {
    let prims = camel();
    for config in [
        EmbreeConfig::default(),
        EmbreeConfig {
            quality: BuildQuality::High,
            robust: true,
        },
    ] {
        let tally = compare(&prims, random_rays(&prims, 100_000, 1), config);
        check(&format!("camel, {config}"), &tally);
    }
}

fn quadrics_agree(ellipsoids: bool) -> Tally {
    let prims = random_quadrics(300, 7, ellipsoids);
    // The normal angle is measured by the library: raylab's `normal_at`
    // Embree's hit point against Embree's own normal (its Ng, through the
    // inverse transpose for an ellipsoid), not for grazing hits.
    let tally = compare(
        &prims,
        random_rays(&prims, 100_000, 11),
        EmbreeConfig::default(),
    );
    check(if ellipsoids { "ellipsoids" } else { "spheres" }, &tally);
    tally
}

/// Spheres: Embree's sphere points. Normals within 10⁻⁴ rad: both sides
/// derive them from f32 hit points with ~10⁻⁶ relative error over radii ≥
/// 0.2; a wrong centre or a missing normalisation is off by far more.
#[test]
fn spheres_agree_with_brute_force() {
    let tally = quadrics_agree(false);
    assert!(tally.normal_angle_percentiles()[2] < 1e-4, "{tally:?}");
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
    assert!(tally.normal_angle_percentiles()[2] < 1e-4, "{tally:?}");
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
                let origin = point_on(&mut rng, p);
                let ray = Ray::new(origin, rng.unit_vector());
                let pr = PreparedRay::new(ray);
                let ours = p.intersect(&pr, f32::INFINITY, &mut NoStats).unwrap();
                let e = accel
                    .trace(&ray, f32::INFINITY)
                    .expect("a ray from inside hits");
                assert_eq!(e.prim, i as u32);
                let cos = incidence(&prims, &ray, i as u32, &ours);
                let tol = t_tolerance(&TOL, &ray, &prims[i], &ours, cos);
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
    // Aimed into the quadrics (the bounds are the same cube).
    let rays = random_rays(&prims[..200], 20_000, 24);
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
                let cos = incidence(&prims, ray, pa, &ha);
                let tol = t_tolerance(&TOL, ray, &prims[pa as usize], &ha, cos);
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
                    let prim = &prims[p as usize];
                    let near_end = (h.t - t_max).abs() <= t_tolerance(&TOL, ray, prim, &h, 1.0);
                    near_end || place(&TOL, &prims, ray, p, &h) != HitPlace::Elsewhere
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
    // Exactly at t_max: not a hit (open interval), on either side. The
    // distance Embree computes for a surface carries its own rounding (for
    // these surfaces at t = 2 it is 2 on some CPUs' code paths and 1.9999999
    // on others), so t_max is set to the distance Embree itself reports: at
    // that bound the hit must be gone, a few ulps above it must be found.
    let ray = Ray::new(Vec3::new(0.0, 0.0, 0.0), Vec3::X);
    let pr = PreparedRay::new(ray);
    for shape in [
        Shape::Sphere(Sphere::new(Vec3::new(3.0, 0.0, 0.0), 1.0)),
        Shape::Triangle(Triangle::new(
            Vec3::new(2.0, -1.0, -1.0),
            Vec3::new(2.0, 1.0, -1.0),
            Vec3::new(2.0, 0.0, 1.0),
        )),
    ] {
        let unit = vec![prim(shape)];
        let accel = EmbreeAccel::build(&unit, &[0], EmbreeConfig::default()).unwrap();
        let (_, h) = accel
            .intersect(&unit, &pr, f32::INFINITY, &mut NoStats)
            .expect("the surface is in front");
        assert!((h.t - 2.0).abs() < 1e-5, "{shape:?}: t = {}", h.t);
        // Embree compares the bound before its final division, so the
        // bound that admits its own rounded t may sit a few ulps above it:
        // 1e-6 relative is 8 ulps.
        let above = h.t * (1.0 + 1e-6);
        assert!(
            accel.intersect(&unit, &pr, h.t, &mut NoStats).is_none(),
            "{shape:?}"
        );
        assert!(!accel.occluded(&unit, &pr, h.t, &mut NoStats), "{shape:?}");
        assert!(
            accel.intersect(&unit, &pr, above, &mut NoStats).is_some(),
            "{shape:?}"
        );
        assert!(accel.occluded(&unit, &pr, above, &mut NoStats), "{shape:?}");
    }
}

/// Embree is called with FTZ/DAZ on (set around each call) and leaves the
/// caller's thread as it found it; results do not depend on whether the
/// caller turned the modes on for the whole thread.
#[test]
fn ftz_daz_is_scoped_to_embree_calls() {
    let prims = random_quadrics(50, 31, true);
    let accel = EmbreeAccel::build(&prims, &all(&prims), EmbreeConfig::default()).unwrap();
    let rays = random_rays(&prims, 2_000, 32);
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
