//! Whitted renderer against analytic answers (issue: foundation).

use raylab::integrator::whitted::{trace, MediumStack};
use raylab::integrator::{render, Whitted};
use raylab::io::scene_file::{load_scene, parse_scene, Overrides};
use raylab::math::{Ray, Vec3, V3};
use raylab::scene::Scene;
use raylab::shading::{reflect, refract};
use raylab::stats::{Counters, NoStats};
use std::path::Path;

fn scene(toml: &str) -> Scene {
    parse_scene(toml, Path::new("test.toml"), &Overrides::default()).unwrap()
}

const SPHERE_UNDER_LIGHT: &str = r#"
[image]
width = 160
height = 120
[camera]
eye = [0.0, 0.0, 5.0]
look_at = [0.0, 0.0, 0.0]
fov = 30.0
[render]
background = [0.0, 0.0, 0.0]
ambient = [0.2, 0.3, 0.4]
[materials.matte]
color = [0.9, 0.5, 0.25]
ambient = 0.5
diffuse = 0.8
[[sphere]]
center = [0.0, 0.0, 0.0]
radius = 1.0
material = "matte"
[[light]]
position = [3.0, 4.0, 5.0]
color = [1.0, 0.8, 0.6]
intensity = 1.5
"#;

/// Every pixel that sees the Lambertian sphere has the value
/// k_a·A·C + k_d·C·E·max(0, n·l), computed here independently in f64 from
/// the camera ray and the analytic ray–sphere intersection.
///
/// Tolerance 1e-4 absolute (values are ≤ 1.1): the renderer works in f32,
/// whose hit point carries a relative error of a few 1e-7 and n·l a few
/// 1e-7 more; near the terminator n·l is small and exact in both, so no
/// pixel should be off by more than ~1e-5. A wrong normal, a missing
/// ambient term or light attenuation would be off by ≥ 1e-2.
#[test]
fn lambertian_sphere_matches_analytic_shading() {
    let s = scene(SPHERE_UNDER_LIGHT);
    let (film, _) = render::<_, NoStats>(&s, &Whitted, None);
    let (c, ka, kd) = ([0.9f64, 0.5, 0.25], 0.5f64, 0.8f64);
    let (amb, e) = ([0.2f64, 0.3, 0.4], [1.5f64, 1.2, 0.9]);
    let light = [3.0f64, 4.0, 5.0];
    let mut lit = 0;
    for y in 0..120 {
        for x in 0..160 {
            let ray = s.camera.generate_ray(x as f32 + 0.5, y as f32 + 0.5);
            let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
            // |o + t d|² = 1 with |d| = 1.
            let b = o.dot(d);
            let disc = b * b - (o.dot(o) - 1.0);
            let got = film.pixel(x, y).mean.as_dvec3();
            if disc < 0.0 {
                assert_eq!(
                    got,
                    glam::DVec3::ZERO,
                    "pixel ({x},{y}) should be background"
                );
                continue;
            }
            // Skip the silhouette, where f32 and f64 may disagree on a hit.
            if disc < 1e-3 {
                continue;
            }
            let p = o + (-b - disc.sqrt()) * d;
            let n = p.normalize();
            let l = (glam::DVec3::from(light) - p).normalize();
            let ndotl = n.dot(l).max(0.0);
            for k in 0..3 {
                let want = ka * amb[k] * c[k] + kd * c[k] * e[k] * ndotl;
                assert!(
                    (got[k] - want).abs() < 1e-4,
                    "pixel ({x},{y}) channel {k}: {} vs {want}",
                    got[k]
                );
            }
            lit += 1;
        }
    }
    assert!(lit > 1000, "the sphere covers too few pixels ({lit})");
}

/// The silhouette of a sphere of radius r at distance d on the axis is a
/// disc of angular radius α = asin(r/d); on the image it has radius
/// tan α / tan(θ/2) · nRows/2 pixels. Counting pixel centres inside a disc of
/// radius ~100 px estimates its area to within O(perimeter) ≈ 0.3 % (Gauss
/// circle problem: error ≪ r), so 1 % is a safe bound that still catches an
/// off-by-half-pixel camera or a wrong view angle (≥ 1 % each).
#[test]
fn sphere_silhouette_matches_analytic_disc_area() {
    let mut toml = SPHERE_UNDER_LIGHT.replace("width = 160", "width = 400");
    toml = toml.replace("height = 120", "height = 400");
    let s = scene(&toml);
    let mut hits = 0usize;
    for y in 0..400 {
        for x in 0..400 {
            let ray = s.camera.generate_ray(x as f32 + 0.5, y as f32 + 0.5);
            hits += s.intersect(&ray, f32::INFINITY, &mut NoStats).is_some() as usize;
        }
    }
    let alpha = (1.0f64 / 5.0).asin();
    let radius_px = alpha.tan() / (15.0f64).to_radians().tan() * 200.0;
    let area = std::f64::consts::PI * radius_px * radius_px;
    let rel = (hits as f64 - area).abs() / area;
    assert!(
        rel < 0.01,
        "silhouette {hits} px vs analytic {area:.1} px ({:.3} %)",
        rel * 100.0
    );
}

const SHADOW: &str = r#"
[image]
width = 64
height = 64
[camera]
eye = [0.0, 3.0, 6.0]
look_at = [0.0, 0.0, 0.0]
fov = 40.0
[render]
ambient = [0.5, 0.5, 0.5]
[materials.floor]
color = [0.6, 0.7, 0.8]
ambient = 0.3
diffuse = 0.9
specular = 0.5
[materials.blocker]
color = [1.0, 1.0, 1.0]
[[plane]]
point = [0.0, 0.0, 0.0]
normal = [0.0, 1.0, 0.0]
material = "floor"
[[sphere]]
center = [0.0, 1.5, 0.0]
radius = 0.5
material = "blocker"
[[light]]
position = [0.0, 4.0, 0.0]
"#;

/// A floor point directly below the blocker, with the light directly above,
/// gets exactly the ambient term k_a·A·C (no diffuse, no specular); a point
/// outside the shadow gets more. Exact equality is expected: the ambient
/// term is the same f32 expression in both.
#[test]
fn point_in_shadow_gets_only_ambient() {
    let s = scene(SHADOW);
    let at = |target: Vec3| {
        let eye = Vec3::new(0.0, 3.0, 6.0);
        let ray = Ray::new(eye, (target - eye).normalize());
        Vec3::from(trace(
            &s,
            &ray.into(),
            0,
            1.0,
            MediumStack::default(),
            &mut NoStats,
        ))
    };
    let ambient = 0.3 * 0.5 * Vec3::new(0.6, 0.7, 0.8);
    assert_eq!(at(Vec3::new(0.0, 0.0, 0.1)), ambient);
    let lit = at(Vec3::new(2.0, 0.0, 0.5));
    assert!(lit.min_element() > ambient.max_element() + 0.1, "{lit}");
}

/// A fully transparent sphere of index 1 must not bend rays: the image with
/// it equals the image without it. No lights (so no shadow rays, which a
/// transparent object still blocks by design), emissive objects behind.
/// The only difference allowed comes from the self-intersection offset
/// (1e-4 relative, ~0.5 % of a pixel footprint here), which can move a ray
/// across an edge behind only when it passes within 1e-4 of it: at most a
/// few pixels, so ≤ 5 pixels may differ and the mean difference must be
/// tiny.
#[test]
fn index_one_sphere_leaves_background_undistorted() {
    let behind = r#"
[image]
width = 200
height = 150
[camera]
eye = [0.0, 0.0, 6.0]
look_at = [0.0, 0.0, 0.0]
fov = 40.0
[render]
background = [0.1, 0.2, 0.3]
max_depth = 6
[materials.glass]
color = [1.0, 1.0, 1.0]
ambient = 0.0
diffuse = 0.0
transparency = 1.0
ior = 1.0
[materials.a]
ambient = 0.0
diffuse = 0.0
emission = [0.9, 0.2, 0.1]
[materials.b]
ambient = 0.0
diffuse = 0.0
emission = [0.1, 0.8, 0.3]
[[sphere]]
center = [-0.6, 0.3, -3.0]
radius = 0.7
material = "a"
[[sphere]]
center = [0.7, -0.4, -2.0]
radius = 0.5
material = "b"
[[triangle]]
vertices = [[-3.0, -2.0, -5.0], [3.0, -2.0, -5.0], [0.0, 2.5, -5.0]]
material = "a"
"#;
    let with = format!(
        "{behind}\n[[sphere]]\ncenter = [0.0, 0.0, 1.0]\nradius = 1.2\nmaterial = \"glass\"\n"
    );
    let (a, _) = render::<_, NoStats>(&scene(behind), &Whitted, None);
    let (b, _) = render::<_, NoStats>(&scene(&with), &Whitted, None);
    let (ia, ib) = (a.image(), b.image());
    let mut differing = 0;
    let mut total = 0.0f64;
    for (pa, pb) in ia
        .exact_chunks(ndarray::Ix3(1, 1, 3))
        .into_iter()
        .zip(ib.exact_chunks(ndarray::Ix3(1, 1, 3)))
    {
        let d: f32 = pa
            .iter()
            .zip(pb.iter())
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f32::max);
        total += d as f64;
        differing += (d > 1e-4) as usize;
    }
    assert!(differing <= 5, "{differing} pixels changed");
    assert!(total / (200.0 * 150.0) < 1e-4);
}

/// Snell's law: n1 sin θ1 = n2 sin θ2, with the refracted ray in the plane
/// of incidence and on the far side; total internal reflection exactly past
/// the critical angle asin(n2/n1). Tolerance 1e-5 (f32 trigonometry).
#[test]
fn refraction_obeys_snell_and_total_internal_reflection() {
    let n = Vec3::Y;
    for (n1, n2) in [(1.0f32, 1.5f32), (1.5, 1.0), (1.33, 2.4)] {
        let critical = if n1 > n2 {
            (n2 / n1).asin().to_degrees()
        } else {
            90.0
        };
        for deg in (0..90).map(|d| d as f32) {
            let th = deg.to_radians();
            // I points back towards where the ray came from.
            let i = Vec3::new(th.sin(), th.cos(), 0.0);
            let t = refract(V3::from(i), V3::from(n), n1 / n2).map(Vec3::from);
            if deg < critical - 0.01 {
                let t = t.unwrap_or_else(|| panic!("no refraction at {deg}° for {n1}->{n2}"));
                assert!((t.length() - 1.0).abs() < 1e-5);
                assert!(t.y < 0.0 && t.z.abs() < 1e-6, "{t}");
                let sin2 = (t.x * t.x + t.z * t.z).sqrt();
                assert!((n1 * th.sin() - n2 * sin2).abs() < 1e-5);
                assert!(
                    t.x <= 0.0,
                    "refracted ray must cross to the other side of the normal"
                );
            } else if deg > critical + 0.01 {
                assert!(
                    t.is_none(),
                    "TIR expected at {deg}° for {n1}->{n2} (critical {critical}°)"
                );
            }
        }
    }
}

/// S2's reflection P = 2(N·(−D))N + D: angle in equals angle out, in the
/// plane of incidence, length kept.
#[test]
fn reflection_mirrors_about_the_normal() {
    let n = Vec3::new(1.0, 2.0, 0.5).normalize();
    for d in [
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(0.3, -2.0, 1.0),
        Vec3::new(0.0, -1.0, 0.0),
    ] {
        let p = Vec3::from(reflect(V3::from(d), V3::from(n)));
        assert!((p.length() - d.length()).abs() < 1e-5);
        assert!((p.dot(n) + d.dot(n)).abs() < 1e-5);
        // Tangential component kept.
        assert!(((p - p.dot(n) * n) - (d - d.dot(n) * n)).length() < 1e-5);
    }
}

/// A ray inside a glass sphere that meets the surface past the critical
/// angle is reflected: the refraction count stays zero and reflection rays
/// are traced. From the inside, the ray at 60° from the normal (critical
/// 41.8° for index 1.5) must not escape.
#[test]
fn total_internal_reflection_inside_glass() {
    let s = scene(
        r#"
[image]
width = 8
height = 8
[camera]
eye = [0.0, 0.0, 5.0]
look_at = [0.0, 0.0, 0.0]
fov = 30.0
[render]
background = [1.0, 1.0, 1.0]
max_depth = 2
[materials.glass]
ambient = 0.0
diffuse = 0.0
transparency = 1.0
ior = 1.5
[[sphere]]
center = [0.0, 0.0, 0.0]
radius = 1.0
material = "glass"
"#,
    );
    // Start inside, on the chord at distance sin 60° from the centre: the
    // ray meets the surface at (cos 60°, sin 60°), 60° from the normal.
    let h = 60f32.to_radians().sin();
    let ray = Ray::new(Vec3::new(0.0, h, 0.0), Vec3::X);
    let media = MediumStack::default().entered(0, 1.5);
    let mut c = Counters::default();
    let colour = Vec3::from(trace(&s, &ray.into(), 0, 1.0, media, &mut c));
    assert_eq!(
        c.refraction_rays, 0,
        "the ray escaped past the critical angle"
    );
    assert_eq!(c.reflection_rays, 1);
    // With depth 2 the reflected ray ends at the next hit, which is inside
    // the glass again and has no local colour: black, not the background.
    assert_eq!(colour, Vec3::ZERO);
}

/// Images do not depend on the number of threads: bit-identical films, for
/// the deterministic samplers and for the randomised ones (their random
/// numbers are keyed by pixel, sample index and seed).
#[test]
fn one_and_two_threads_give_identical_images() {
    let bits = |f: &raylab::film::Film| -> Vec<u32> {
        f.pixels
            .iter()
            .flat_map(|p| p.mean.to_array().map(f32::to_bits))
            .collect()
    };
    for sampler in [
        "centre", "rgss", "jitter:2", "random:3", "halton:4", "sobol:4",
    ] {
        let overrides = Overrides {
            width: Some(96),
            height: Some(72),
            sampler: Some(raylab::sampler::Sampler::parse(sampler).unwrap()),
            ..Default::default()
        };
        let s = load_scene(
            &raylab_testkit::repo_path("data/scenes/s1-spheres.toml"),
            &overrides,
        )
        .unwrap();
        let (a, ca) = render::<_, Counters>(&s, &Whitted, Some(1));
        let (b, cb) = render::<_, Counters>(&s, &Whitted, Some(2));
        assert_eq!(ca, cb, "{sampler}");
        assert_eq!(bits(&a), bits(&b), "{sampler}");
    }
}

/// The shipped scenes load (meshes from data/external: run `make deps`).
#[test]
fn shipped_scenes_load_and_render_small() {
    let overrides = Overrides {
        width: Some(24),
        height: Some(18),
        ..Default::default()
    };
    let mut paths: Vec<_> = std::fs::read_dir(raylab_testkit::repo_path("data/scenes"))
        .unwrap()
        .chain(std::fs::read_dir(raylab_testkit::repo_path("data/scenes/s1-family")).unwrap())
        .chain(std::fs::read_dir(raylab_testkit::repo_path("data/scenes/aa")).unwrap())
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    paths.sort();
    assert!(paths.len() >= 29, "{paths:?}");
    for p in paths {
        let s = load_scene(&p, &overrides)
            .unwrap_or_else(|e| panic!("{e} (run `make deps` for meshes)"));
        let (film, c) = render::<_, Counters>(&s, &Whitted, None);
        assert_eq!(c.camera_rays, 24 * 18, "{}", p.display());
        // Something other than background is visible in every scene.
        let bg = s.settings.background;
        assert!(
            film.pixels.iter().any(|px| px.mean != bg),
            "{} shows only background",
            p.display()
        );
    }
}

/// Per-pixel cost buffers sum to the totals, and a background pixel costs
/// exactly one camera ray testing every primitive once.
#[test]
fn per_pixel_costs_sum_to_totals() {
    let overrides = Overrides {
        width: Some(40),
        height: Some(30),
        ..Default::default()
    };
    let s = load_scene(
        &raylab_testkit::repo_path("data/scenes/s1-spheres.toml"),
        &overrides,
    )
    .unwrap();
    let (film, total, costs) = raylab::integrator::render_with_costs(&s, &Whitted, Some(2));
    let mut sum = Counters::default();
    for c in &costs {
        sum += *c;
    }
    assert_eq!(sum, total);
    // The top-left pixel sees the sky: 1 camera ray, 4 spheres + 1 plane.
    assert_eq!(film.pixel(0, 0).mean, s.settings.background);
    let c = costs[0];
    assert_eq!(
        (c.camera_rays, c.rays(), c.sphere_tests, c.plane_tests),
        (1, 1, 4, 1)
    );
}
