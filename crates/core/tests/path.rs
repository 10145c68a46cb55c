//! The path tracer against analytic answers, against the Whitted
//! integrator, and against itself (MIS vs single strategies, Russian
//! roulette on and off, thread counts).
//!
//! Statistical tests compare Monte Carlo means with a tolerance of a few
//! standard errors, the standard error coming from the film's own per-pixel
//! sample variances (pixels are independent, so the variance of a block
//! mean is Σ s²/n over its pixels divided by the block size squared). The
//! seeds are fixed, so each test gives the same answer on every run; 4σ
//! keeps a correct estimator's chance of failing a single comparison below
//! 1e-4 when the seeds are changed.

use raylab::film::Film;
use raylab::integrator::path::LightStrategy;
use raylab::integrator::{render, IntegratorKind, PathTracer, Whitted};
use raylab::io::scene_file::{load_scene, parse_scene, Overrides};
use raylab::sampler::Sampler;
use raylab::scene::Scene;
use raylab::stats::{Counters, NoStats};
use std::path::Path;

fn scene(toml: &str) -> Scene {
    parse_scene(toml, Path::new("test.toml"), &Overrides::default()).unwrap()
}

fn cornell(size: u32, spp: u32) -> Scene {
    let path = raylab_testkit::repo().join("data/scenes/cornell-box.toml");
    let overrides = Overrides {
        width: Some(size),
        height: Some(size),
        sampler: Some(Sampler::Random { n: spp }),
        accel: Some("bvh".parse().unwrap()),
        ..Overrides::default()
    };
    load_scene(&path, &overrides).unwrap()
}

/// Two Lambertian spheres (one shadowing the other) under two point lights,
/// one with 1/d² falloff; no ambient, no specular, black background.
const SPHERES_UNDER_LIGHTS: &str = r#"
[image]
width = 64
height = 48
[camera]
eye = [0.0, 0.0, 5.0]
look_at = [0.0, 0.0, 0.0]
fov = 40.0
[render]
background = [0.0, 0.0, 0.0]
ambient = [0.0, 0.0, 0.0]
[materials.matte]
color = [0.9, 0.5, 0.25]
ambient = 0.0
diffuse = 0.8
specular = 0.0
[materials.blue]
color = [0.2, 0.3, 0.9]
ambient = 0.0
diffuse = 1.0
[[sphere]]
center = [0.0, 0.0, 0.0]
radius = 1.0
material = "matte"
[[sphere]]
center = [1.2, 1.2, 1.0]
radius = 0.4
material = "blue"
[[light]]
position = [3.0, 4.0, 5.0]
color = [1.0, 0.8, 0.6]
intensity = 1.5
[[light]]
position = [-3.0, 1.0, 2.0]
color = [0.5, 0.5, 1.0]
intensity = 9.0
falloff = "inverse_square"
"#;

/// With point lights only and nothing to bounce light onto a visible
/// surface within zero bounces, `direct` computes Σ ρ·E·falloff·cos θ·V per
/// pixel, which is the Whitted integrator's diffuse term term for term.
///
/// Tolerance 1e-5 absolute on values ≤ ~1.5: both sides evaluate the same
/// f32 products in a different order (ρ·(E·cos) against (k_d·cos)·C·E), a
/// few ulps (≈ 1e-7 relative) apart; a missing π, a wrong albedo or a
/// missed shadow would be off by ≥ 1e-2.
#[test]
fn direct_lighting_from_point_lights_equals_whitted_diffuse() {
    let s = scene(SPHERES_UNDER_LIGHTS);
    let (whitted, _) = render::<_, NoStats>(&s, &Whitted, None);
    let (direct, _) = IntegratorKind::Direct.render::<NoStats>(&s, None).unwrap();
    let (mut lit, mut worst) = (0, 0.0f32);
    for (a, b) in whitted.pixels.iter().zip(&direct.pixels) {
        worst = worst.max((a.mean - b.mean).abs().max_element());
        if a.mean.max_element() > 0.05 {
            lit += 1;
        }
    }
    assert!(worst < 1e-5, "largest difference {worst}");
    assert!(
        lit > 500,
        "only {lit} lit pixels: the test needs lit surfaces"
    );
    // The shadow of the small sphere must fall on the large one.
    let dark_on_sphere = whitted
        .pixels
        .iter()
        .filter(|p| p.mean.max_element() < 1e-6)
        .count();
    assert!(dark_on_sphere > 0);
}

/// Mean of a block of pixels per channel and its standard error.
fn block_mean(film: &Film, x0: u32, y0: u32, side: u32) -> ([f64; 3], [f64; 3]) {
    let (mut sum, mut var) = ([0.0f64; 3], [0.0f64; 3]);
    for y in y0..y0 + side {
        for x in x0..x0 + side {
            let p = film.pixel(x, y);
            let v = p.variance();
            for c in 0..3 {
                sum[c] += f64::from(p.mean[c]);
                var[c] += f64::from(v[c]) / f64::from(p.count);
            }
        }
    }
    let n = f64::from(side * side);
    (sum.map(|s| s / n), var.map(|v| v.sqrt() / n))
}

/// Every `side`×`side` block of `a` and `b` agrees per channel within
/// `k` combined standard errors.
fn assert_blocks_agree(a: &Film, b: &Film, side: u32, k: f64, what: &str) {
    let mut compared = 0;
    for y0 in (0..a.height).step_by(side as usize) {
        for x0 in (0..a.width).step_by(side as usize) {
            let (ma, sa) = block_mean(a, x0, y0, side);
            let (mb, sb) = block_mean(b, x0, y0, side);
            for c in 0..3 {
                let se = (sa[c] * sa[c] + sb[c] * sb[c]).sqrt();
                assert!(
                    (ma[c] - mb[c]).abs() <= k * se + 1e-6,
                    "{what}: block ({x0}, {y0}) channel {c}: {} vs {} (σ = {se})",
                    ma[c],
                    mb[c]
                );
                compared += 1;
            }
        }
    }
    assert!(compared >= 48);
}

/// Inside a closed sphere whose wall has albedo a and emits L_e everywhere,
/// the radiance in every direction is L_e·Σ aⁱ = L_e/(1 − a) (the white
/// furnace). a = 0.8, L_e = 0.2, so L = 1, and paths need many bounces
/// (a⁶⁴ ≈ 6e-7 is what truncation at 64 bounces leaves out: below the
/// tolerance). The mean over the image must lie within 4 standard errors
/// (≈ 1e-3 here) of 1; a missing MIS weight doubles the direct term
/// (error 0.2), a biased roulette shifts the mean by ≥ 1e-2.
#[test]
fn white_furnace_converges_to_le_over_one_minus_albedo() {
    let s = scene(&raylab_testkit::furnace_scene(24));
    for strategy in [
        LightStrategy::Mis,
        LightStrategy::BsdfOnly,
        LightStrategy::LightOnly,
    ] {
        let pt = PathTracer {
            max_bounces: 64,
            rr_start: Some(3),
            strategy,
        };
        let (film, _) = render::<_, NoStats>(&s, &pt, None);
        let (mean, se) = block_mean(&film, 0, 0, 24);
        for c in 0..3 {
            assert!(
                (mean[c] - 1.0).abs() <= 4.0 * se[c] + 1e-4,
                "{strategy:?}: channel {c}: {} ± {}",
                mean[c],
                se[c]
            );
            assert!(
                se[c] < 5e-3,
                "{strategy:?}: standard error {} too large to test",
                se[c]
            );
        }
    }
}

/// MIS, light sampling alone and BRDF sampling alone estimate the same
/// integral: on the Cornell box (area light only, two bounces) every 8×8
/// block agrees within 4 standard errors.
#[test]
fn mis_light_only_and_brdf_only_agree_in_expectation() {
    let s = cornell(32, 64);
    let film = |strategy| {
        let pt = PathTracer {
            max_bounces: 2,
            rr_start: None,
            strategy,
        };
        render::<_, NoStats>(&s, &pt, None).0
    };
    let mis = film(LightStrategy::Mis);
    let light = film(LightStrategy::LightOnly);
    let brdf = film(LightStrategy::BsdfOnly);
    assert_blocks_agree(&mis, &light, 8, 4.0, "MIS vs light only");
    assert_blocks_agree(&mis, &brdf, 8, 4.0, "MIS vs BRDF only");
    // MIS should not be noisier than BRDF sampling of a small light.
    assert!(mis.mean_sample_variance() < brdf.mean_sample_variance());
}

/// Russian roulette changes the noise, not the expectation: path:6 with
/// roulette from the first bounce on and without roulette agree block by
/// block within 4 standard errors, and roulette traces fewer path rays.
#[test]
fn russian_roulette_is_unbiased() {
    let s = cornell(32, 64);
    let run = |rr_start| {
        let pt = PathTracer {
            max_bounces: 6,
            rr_start,
            strategy: LightStrategy::Mis,
        };
        render::<_, Counters>(&s, &pt, None)
    };
    let (with_rr, c_rr) = run(Some(0));
    let (without, c_all) = run(None);
    assert_blocks_agree(&with_rr, &without, 8, 4.0, "roulette vs none");
    assert!(c_rr.path_rays < c_all.path_rays);
}

/// Images do not depend on the thread count: every random number is keyed
/// by (seed, pixel, sample, bounce, dimension).
#[test]
fn path_tracer_is_deterministic_across_thread_counts() {
    let s = cornell(24, 4);
    let kind = IntegratorKind::parse("path:4").unwrap();
    let (one, c1) = kind.render::<Counters>(&s, Some(1)).unwrap();
    let (two, c2) = kind.render::<Counters>(&s, Some(2)).unwrap();
    assert_eq!(one, two);
    assert_eq!(c1, c2);
    // And the seed matters.
    let mut reseeded = s.clone();
    reseeded.settings.seed = 7;
    let (other, _) = kind.render::<NoStats>(&reseeded, Some(2)).unwrap();
    assert_ne!(one, other);
}

/// Ray accounting of one path: camera ray, then per vertex one shadow ray
/// per point light and area-light sample and one path ray, up to K + 1
/// vertices. In the closed furnace every ray hits, and without roulette
/// every path takes exactly K + 1 path rays.
#[test]
fn bounce_count_means_path_rays_per_sample() {
    let s = scene(
        r#"
[image]
width = 4
height = 4
[camera]
eye = [0.0, 0.0, 0.0]
look_at = [0.0, 0.0, -1.0]
fov = 60.0
[materials.wall]
color = [0.5, 0.5, 0.5]
emission = [1.0, 1.0, 1.0]
[[sphere]]
center = [0.0, 0.0, 0.0]
radius = 1.0
material = "wall"
"#,
    );
    for k in [0u32, 1, 4] {
        let pt = PathTracer {
            max_bounces: k,
            rr_start: None,
            strategy: LightStrategy::Mis,
        };
        let (_, c) = render::<_, Counters>(&s, &pt, None);
        assert_eq!(c.camera_rays, 16);
        assert_eq!(c.path_rays, 16 * u64::from(k + 1), "path:{k}");
        assert_eq!(c.shadow_rays, 16 * u64::from(k + 1), "path:{k}");
    }
}

#[test]
fn integrator_names_parse_and_bad_ones_explain() {
    assert_eq!(
        IntegratorKind::parse("whitted"),
        Ok(IntegratorKind::Whitted)
    );
    assert_eq!(IntegratorKind::parse("direct"), Ok(IntegratorKind::Direct));
    let p = IntegratorKind::parse("path:4").unwrap();
    assert_eq!(p.name(), "path:4");
    assert_eq!(p.path_tracer().unwrap().max_bounces, 4);
    let e = IntegratorKind::parse("path").unwrap_err();
    assert!(e.to_string().contains("path:K"), "{e}");
    let e = IntegratorKind::parse("path:x").unwrap_err();
    assert!(e.to_string().contains("0..="), "{e}");
}

/// The Cornell box at `width` × `height` pixels and `spp` random samples.
fn cornell_wh(width: u32, height: u32, spp: u32) -> Scene {
    let mut s = cornell(width, spp);
    s.camera.height = height;
    s
}

/// Films equal bit for bit: every pixel's count, mean and M2.
fn assert_same_film(a: &Film, b: &Film, what: &str) {
    assert_eq!(a.pixels.len(), b.pixels.len(), "{what}");
    for (i, (p, q)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        let bits = |s: &raylab::film::PixelStats| {
            (
                s.count,
                s.mean.to_array().map(f32::to_bits),
                s.m2.to_array().map(f32::to_bits),
            )
        };
        assert_eq!(bits(p), bits(q), "{what}: pixel {i} differs");
    }
}

// The lanes path tracer (groups of 16 samples in lockstep, the renders'
// path for scenes it supports) performs the one-sample loop's operations
// in the same order on the same numbers: same film bit for bit, same
// counters. 9 × 7 pixels at 5 spp puts group borders inside pixels and
// rows; the cases cover every strategy, roulette on and off, direct only,
// point lights beside area lights.
#[test]
fn lanes_render_the_one_sample_loops_image_bit_for_bit() {
    use raylab::integrator::lanes;
    let strategies = [
        (4, None, LightStrategy::Mis),
        (4, Some(1), LightStrategy::Mis),
        (0, Some(3), LightStrategy::Mis),
        (2, Some(2), LightStrategy::LightOnly),
        (2, Some(2), LightStrategy::BsdfOnly),
    ];
    let rooms = raylab_testkit::repo().join("data/scenes/leak-rooms.toml");
    let small = Overrides {
        width: Some(6),
        height: Some(5),
        sampler: Some(Sampler::Random { n: 3 }),
        ..Overrides::default()
    };
    // The box's point light, made one the path tracer uses.
    let mut lit = cornell_wh(5, 4, 3);
    for l in &mut lit.lights {
        l.whitted_only = false;
    }
    let scenes = [
        ("cornell", cornell_wh(9, 7, 5)),
        ("cornell, point light", lit),
        ("leak-rooms", load_scene(&rooms, &small).unwrap()),
    ];
    for (name, scene) in &scenes {
        for (bounces, rr_start, strategy) in strategies {
            let p = PathTracer {
                max_bounces: bounces,
                rr_start,
                strategy,
            };
            let what = format!("{name}, path:{bounces}, rr {rr_start:?}, {strategy:?}");
            assert!(lanes::supported(scene), "{what}: not supported");
            let (a, ca): (Film, Counters) = render(scene, &p, Some(2));
            let (b, cb): (Film, Counters) = lanes::render(scene, &p, Some(2));
            assert_same_film(&a, &b, &what);
            assert_eq!(ca, cb, "{what}: counters");
        }
        // The CLI's way in (`IntegratorKind::render`) takes the lanes.
        let kind = IntegratorKind::parse("path:3").unwrap();
        let (a, _): (Film, NoStats) = kind.render(scene, Some(1)).unwrap();
        let (b, _): (Film, NoStats) = render(scene, &kind.path_tracer().unwrap(), Some(1));
        assert_same_film(&a, &b, name);
    }
}

// Renders the lanes do not cover take the one-sample loop: quadrics,
// filters wider than the box; `lanes::render` hands them over itself.
#[test]
fn lanes_decline_what_they_do_not_cover() {
    use raylab::integrator::lanes;
    let p = PathTracer::new(2);
    assert!(lanes::supported(&cornell(4, 1)));
    let s1 = raylab_testkit::repo().join("data/scenes/s1-spheres.toml");
    let tiny = Overrides {
        width: Some(8),
        height: Some(6),
        ..Overrides::default()
    };
    let s1 = load_scene(&s1, &tiny).unwrap();
    assert!(!lanes::supported(&s1), "spheres");
    // Asked anyway, they hand the render to the one-sample loop.
    let (a, _): (Film, NoStats) = lanes::render(&s1, &p, Some(1));
    let (b, _): (Film, NoStats) = render(&s1, &p, Some(1));
    assert_same_film(&a, &b, "S1");
    let mut tent = cornell(4, 1);
    tent.settings.filter = raylab::film::Filter::Tent;
    assert!(!lanes::supported(&tent), "tent filter");
}
